"""Samples ``(a_i, ω_i, ζ_i)`` of one mode's backbone and damping curve, with the
mass-normalised shape φ_f (1/√kg) of the mode at the excited coordinate, for the amplitude-dependent
modal fits (:mod:`~nlupdate.core.identification.amplitude_modal_fit`). Two kinds of data give them:

* a **modal table** (:mod:`nlupdate.core.measurement.modal_table`: natural frequency and damping
  ratio of the mode per force level, as a phase-resonance or one-mode analysis gives them):
  at phase resonance ``2ζω² a = |φ_f| F``, so ``a_i = |φ_f| F_i / (2ζ_i ω_i²)``;
* **FRFs at several levels** (driving point or transfer): each level's resonance — the peak
  of |H| after removing the other modes' share R + S·(f²/f_c² − 1), found with the modal
  constant P from every line of every level at once (:mod:`~nlupdate.core.identification.level_residual`: a one-mode
  fit of the lowest level took part of that nonlinear curve for residual terms) — gives one
  sample: ω_i the peak frequency, x_i = |H_peak|F_i the amplitude there, ``a_i = x_i/|φ_f|``
  and ``ζ_i = φ_f²F_i/(2ω_i²x_i)`` (at resonance |H| = φ_f²/(2ζω²)). A transfer FRF (response
  r ≠ input f) has the modal constant ``P = φ_rφ_f``: its response amplitude becomes the
  driving point's, ``x_f = x_r|φ_f/φ_r|``, and the formulas above hold; without a given φ_f only P
  (from every level) is known, and the split is taken equal (|φ_r| = |φ_f| = √|P|) — that sets
  the scale of a, which no prediction of these FRFs depends on. The points off the peak
  are not used: where a stiff joint changes the mode's shape between stuck and slipping,
  single-mode theory holds at the resonance but not on the flanks (the bolted-beam example's
  exact modal model misses its flanks by 21 % rms, its peaks by ≤ 1.1 %). Without a given
  φ_f an Iwan fit fits φ_f with the backbone (the joint's damping is tied to its softening,
  which fixes the scale of a), within
  :data:`~nlupdate.core.identification.iwan_backbone_fit.SHAPE_RANGE` of the modal constant read
  with the other modes' share (the peaks fix only φ_f²/ζ; the curves' widths fix ζ, so φ_f may move only as
  much as a slipping joint changes the shape); a polynomial one uses that modal constant.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.frf_peak import resonance_peak
from nlupdate.core.identification.level_residual import LevelResidual, bound_warning, frf_residual
from nlupdate.core.measurement.modal_table import validate_modal_table
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.run_cache import remembered_in_run


#: what a mass-normalised mode shape given at a coordinate must be: a modal amplitude divides by it
SHAPE_FORM = "a finite shape ≠ 0 (1/√kg)"


def usable_shape(value: float) -> bool:
    """Whether a given shape value (1/√kg) is :data:`SHAPE_FORM`."""
    return bool(np.isfinite(value)) and value != 0


@dataclass(frozen=True, eq=False)
class ModalSamples:
    """Samples of one mode's backbone: modal amplitude a (m·√kg), natural frequency (Hz),
    damping ratio and the force amplitude F (N, the reference unit) at each; ``input_shape`` φ_f (1/√kg).

    From FRFs, ``response_amplitude`` holds the resonance amplitude x (m) at the excited
    coordinate and F is the force achieved at the resonance line (a shaker's force dips there:
    the BRB's 0.1947 N level reaches 0.142 N at its peak), so that a = x/φ_f and
    ζ = φ_f²F/(2ω²x) follow for any φ_f (:meth:`with_shape`); ``level`` is each sample's
    nominal force level (the level's name, FRF samples only),
    and ``shape_free`` says φ_f was not given (an Iwan fit then fits it); ``response_ratio``
    is φ_r/φ_f of the FRFs' response (1 at the driving point). ``modal`` is False for the
    samples of a record read without a shape at its channel: a is then the record's own
    amplitude (m), on no common scale with modal samples (φ_r = 1 is assumed, not known);
    ``channel`` is then the record's channel (what a refusal to join them names). ``warnings``:
    what the reading warns of (from FRFs: the other modes' share on the bound of its fit,
    :func:`~nlupdate.core.identification.level_residual.bound_warning`)."""

    amplitude: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    force_n: NDArray[np.float64]
    input_shape: float
    response_amplitude: NDArray[np.float64] | None = None
    shape_free: bool = False
    response_ratio: float = 1.0
    modal: bool = True
    level: NDArray[np.float64] | None = None
    channel: str = ""
    warnings: tuple[str, ...] = ()

    def with_shape(self, input_shape: float) -> "ModalSamples":
        """The same FRF samples for another φ_f (1/√kg)."""
        if self.response_amplitude is None:
            raise AmplitudeModelError("only samples from FRFs (with their response amplitudes) can change their shape")
        phi, x, omega = abs(float(input_shape)), self.response_amplitude, 2 * np.pi * self.frequency_hz
        return ModalSamples(x / phi, self.frequency_hz, phi**2 * self.force_n / (2 * omega**2 * x), self.force_n, phi,
                            x, self.shape_free, self.response_ratio, level=self.level, warnings=self.warnings)


def samples_from_modal_table(table: pd.DataFrame, input_shape: float, mode: int = 1,
                             source: str = "<modal table>") -> ModalSamples:
    """Backbone samples of ``mode`` from a modal table (phase resonance: module docstring)."""
    clean = validate_modal_table(table, source)
    rows = clean[clean["mode"] == int(mode)]
    if len(rows) < 2:
        raise AmplitudeModelError(f"{source}: mode {mode} appears at {len(rows)} force level(s); an amplitude-dependent "
                                  "model needs two or more")
    if not (np.isfinite(input_shape) and input_shape != 0):
        raise AmplitudeModelError(f"input_shape: the mass-normalised mode shape at the excited coordinate (1/√kg, ≠ 0), "
                                  f"got {input_shape}")
    force = rows["force_level_n"].to_numpy(dtype=float)
    frequency = rows["natural_frequency_hz"].to_numpy(dtype=float)
    zeta = rows["damping_ratio"].to_numpy(dtype=float)
    if np.any(zeta <= 0):
        raise AmplitudeModelError(f"{source}: mode {mode} has a damping ratio of 0; the phase-resonance amplitude "
                                  "|φ_f|F/(2ζω²) needs ζ > 0")
    amplitude = abs(input_shape) * force / (2 * zeta * (2 * np.pi * frequency) ** 2)
    return ModalSamples(amplitude, frequency, zeta, force, abs(float(input_shape)))


@remembered_in_run  # the amplitude-* models of one validation share the kept levels' samples
def samples_from_frfs(data: FRFLevels, input_shape: float | None = None, near_hz: float | None = None,
                      band_fraction: float = 0.1, start: LevelResidual | None = None) -> ModalSamples:
    """One backbone sample per force level from FRFs at the driving point or a transfer
    (module docstring): the resonance of each level (peak of |H| within ``2.5 band_fraction``
    of the lowest level's resonance near ``near_hz``, from every line near its top:
    :func:`~nlupdate.core.identification.frf_peak.resonance_peak`), after removing the other
    modes' share found from every level
    (:func:`~nlupdate.core.identification.level_residual.frf_residual`), whose modal constant also
    gives φ_f when ``input_shape`` is None and φ_r/φ_f of a transfer; ``start``: that share's
    fit starts from this end alone (a noisy copy's from the clean data's: :func:`frf_residual`)."""
    centre, shared = frf_residual(data, near_hz, band_fraction, start)
    driving = data.response_dof == data.input_dof
    constant = shared.modal_constant
    shape_free = input_shape is None
    if shape_free:
        input_shape = float(np.sqrt(abs(constant)))
    phi = abs(float(input_shape))
    ratio = 1.0 if driving else constant / phi**2  # φ_r/φ_f
    peak_hz, peak_x, forces, levels = [], [], [], []
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        band = np.abs(f - centre) <= 2.5 * band_fraction * centre
        fb = f[band]
        hb = np.abs(h[band] - shared.receptance(fb))
        if fb.size < 3:
            continue
        at_hz, height = resonance_peak(fb, hb)
        force = float(data.force_at(level, [at_hz])[0])  # the force achieved at the peak, not the level's mean
        peak_hz.append(at_hz)
        peak_x.append(height * force)
        forces.append(force)
        levels.append(float(level))
    if len(forces) < 2:
        raise AmplitudeModelError("fewer than two force levels show the resonance; measure around it at two or more levels")
    x, frequency, force = np.array(peak_x) / abs(ratio), np.array(peak_hz), np.array(forces)  # x at the driving point
    omega = 2 * np.pi * frequency
    warning = bound_warning(shared)
    return ModalSamples(x / phi, frequency, phi**2 * force / (2 * omega**2 * x), force, phi, x, shape_free, ratio,
                        level=np.array(levels), warnings=(warning,) if warning else ())
