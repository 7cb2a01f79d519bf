"""Derive tests/data/brb/HammerImpact_1600Hz.mat from the public HammerImpact.mat.

The original (https://github.com/mattiacenedese/BRBtesting, GPL-3.0; provenance in this
folder's README.md) samples three accelerometers at 12.8 kHz for 5.12 s. The excerpt keeps
all three channels and the whole record, decimated by 8 to 1.6 kHz (scipy.signal.decimate:
an order-8 Chebyshev type I low-pass at 640 Hz applied forwards and backwards, so no phase
shift, then every 8th sample) and stored as float32 — enough for the first bending modes
(60–400 Hz) and about a tenth of the size. Same structure and field names (``HIdata``:
``time``, ``acc1``, ``acc2``, ``acc3``, ``units``).

    python tests/data/brb/derive_impact_excerpt.py PATH/TO/HammerImpact.mat
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.io
from scipy.signal import decimate

FACTOR = 8


def main(source: str) -> None:
    data = scipy.io.loadmat(source, squeeze_me=True, struct_as_record=False)["HIdata"]
    excerpt = {"time": data.time[::FACTOR].astype(np.float64), "units": data.units}
    for channel in ("acc1", "acc2", "acc3"):
        excerpt[channel] = decimate(getattr(data, channel), FACTOR, ftype="iir", zero_phase=True).astype(np.float32)
    target = Path(__file__).with_name("HammerImpact_1600Hz.mat")
    scipy.io.savemat(target, {"HIdata": excerpt}, do_compression=True)
    print(f"wrote {target} ({target.stat().st_size} bytes)")


if __name__ == "__main__":
    main(sys.argv[1])
