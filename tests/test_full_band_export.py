"""A full-band export (0–512 Hz, 8192 lines) of a 70–110 Hz chirp test through identify and
discover: cut to the band before any step (a full-band export failed after minutes with
"FRAC: the FRFs have 8192 and 1150 points; they must share one grid").

The test system's file holds three runs (one per level, the level only in the run name,
reference in volts) of a lightly damped SDOF with a cubic spring, each an FRF and its
coherence over the analyser's whole range; outside the excited band the "FRF" is noise
and the coherence low. Inside, H is the describing-function (first-harmonic) receptance
of the Duffing oscillator, solved here in closed form:
``|k(1 + iη) − mω² + ¾k₃X²| X = F`` is a cubic in ``u = X²``.
"""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
import pyuff

from nlupdate.app.cli import main

M, K, ETA, K3 = 1.0, (2 * np.pi * 90.0) ** 2, 0.02, 3e11  # kg (per volt), V/m, loss factor, V/m³
LEVELS = (0.25, 0.5, 1.0)  # V
F_FULL = np.arange(8192) * (512.0 / 8192)  # 0–511.94 Hz, 0.0625 Hz lines
BAND = (70.0, 110.0)


def duffing_receptance(f: np.ndarray, force: float) -> np.ndarray:
    """First-harmonic receptance X/F (m/V) of m ẍ + k(1 + iη) x + k₃ x³ = F cos ωt: the one
    positive root u = X² of b²u³ + 2ab u² + (a² + c²)u − F² = 0 (a = k − mω², b = ¾k₃,
    c = ηk); this test's levels stay below the fold, so there is exactly one."""
    out = np.empty(f.shape, complex)
    b = 0.75 * K3
    for i, w in enumerate(2 * np.pi * f):
        a, c = K - M * w**2, ETA * K
        roots = np.roots([b**2, 2 * a * b, a**2 + c**2, -force**2])
        u = roots[(abs(roots.imag) < 1e-9 * abs(roots)) & (roots.real > 0)].real
        assert u.size == 1, (f[i], force, roots)
        out[i] = 1.0 / (K * (1 + 1j * ETA) - M * w**2 + b * u[0])
    return out


def export_full_band(path: Path) -> Path:
    rng = np.random.default_rng(7)
    inside = (F_FULL >= BAND[0]) & (F_FULL <= BAND[1])
    sets = []
    for level in LEVELS:
        h = np.empty(F_FULL.size, complex)
        h[inside] = duffing_receptance(F_FULL[inside], level) * (1 + 0.002 * rng.standard_normal(inside.sum()))
        noise = rng.standard_normal((~inside).sum()) + 1j * rng.standard_normal((~inside).sum())
        h[~inside] = 1e-6 * noise  # the ratio of two noises where the chirp put no energy
        coherence = np.where(inside, 0.99, rng.uniform(0.0, 0.3, F_FULL.size))
        name = f"Round1_Chirp{level:.2f}_70to110Hz".replace(".", "p")
        common = dict(binary=0, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, x=F_FULL, id2=name,
                      id3="28-Nov-26 10:00:00", abscissa_spacing=1, abscissa_spec_data_type=18,
                      abscissa_axis_units_lab="Hz", z_axis_spec_data_type=0, z_axis_value=0.0)
        sets.append(pyuff.prepare_58(func_type=4, id1="FRF 1:+Z/1:+Z", data=h, ordinate_spec_data_type=8,
                                     ordinate_axis_units_lab="m", orddenom_spec_data_type=0,
                                     orddenom_axis_units_lab="V", **common))
        sets.append(pyuff.prepare_58(func_type=6, id1="COH 1:+Z/1:+Z", data=coherence, ordinate_spec_data_type=0,
                                     ordinate_axis_units_lab="", orddenom_spec_data_type=0,
                                     orddenom_axis_units_lab="", **common))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def run(*args: object) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def export(tmp_path_factory) -> Path:
    return export_full_band(tmp_path_factory.mktemp("full_band") / "chirp_runs.uff")


def test_identify_reads_the_full_band_export_and_cuts_it_to_the_excited_band(export, tmp_path):
    code, out, err = run("identify", "--measured", export, "--reference-unit", "V", "--elements", "cubic",
                         "--samples", "10", "--out", tmp_path / "id")
    assert code == 0, err
    summary = json.loads((tmp_path / "id" / "identification.json").read_text())
    assert summary["band_hz"][0] == pytest.approx(BAND[0], abs=0.07) and \
        summary["band_hz"][1] == pytest.approx(BAND[1], abs=0.07)
    assert summary["parameters"]["k3"]["value"] == pytest.approx(K3, rel=0.03)
    assert summary["linear_frf"]["frac_vs_measured_at_that_level"] > 0.99
    assert "3 level(s) 0.25, 0.5, 1 V" in out and "FRFs in m/V" in out  # volts stated
    assert "k3 = " in out and "V/m³" in out


def test_identify_with_a_band_given_cuts_before_any_step(export, tmp_path):
    code, out, err = run("identify", "--measured", export, "--reference-unit", "V", "--elements", "cubic",
                         "--samples", "10", "--band", "75:105", "--out", tmp_path / "id")
    assert code == 0, err
    assert "band 75–105 Hz (--band): 23133 of 24576 measured rows outside it left out before any step" in out
    summary = json.loads((tmp_path / "id" / "identification.json").read_text())
    assert summary["parameters"]["k3"]["value"] == pytest.approx(K3, rel=0.03)


def test_discover_finds_the_cubic_spring_in_the_full_band_export(export, tmp_path):
    model = tmp_path / "sdof.toml"
    model.write_text(f'[model]\nkind = "lumped"\nmass = [[{M}]]\nstiffness = [[{K!r}]]\nloss_factor = {ETA}\n'
                     f'dof_names = ["1:uz"]\n')
    code, out, err = run("discover", "--model", model, "--measured", export, "--reference-unit", "V",
                         "--effects", "cubic_stiffness,dry_friction", "--max-effects", "1", "--out", tmp_path / "d")
    assert code == 0, err
    assert "band 70–110 Hz found (coherence ≥ 0.8" in out and "FRFs in m/V" in out
    data = json.loads((tmp_path / "d" / "discovery.json").read_text())
    assert data["effect"] == "cubic_stiffness"
    assert data["effects"][0]["parameters"]["k3"] == pytest.approx(K3, rel=0.05)
    assert data["units"]["force_level"] == "V" and "V/m³" in out  # volts stated in the JSON and the lines


def test_amplitude_reads_the_full_band_export_within_its_band(export, tmp_path):
    code, out, err = run("amplitude", "--measured", export, "--reference-unit", "V", "--backbone", "polynomial",
                         "--out", tmp_path / "amp")
    assert code == 0, err
    assert "band 70–110 Hz found (coherence ≥ 0.8" in out and "FRFs in m/V" in out
    model = json.loads((tmp_path / "amp" / "amplitude_model.json").read_text())
    # the linear limit: √(k/m)/2π = 90 Hz and ζ = η/2 = 1 % at resonance (structural damping)
    assert model["natural_frequency_hz"] == pytest.approx(90.0, rel=1e-3)
    assert model["damping_ratio"] == pytest.approx(ETA / 2, rel=0.03)


def test_validate_predicts_the_top_run_of_the_full_band_export_within_its_band(export, tmp_path):
    """The highest run held out and predicted from the two below (a single nonlinear mode
    fitted to every line near resonance): the closed-form Duffing curve's resonance and
    damping, read in its band with no --band given."""
    code, out, err = run("validate", "--measured", export, "--reference-unit", "V", "--hold-out", "top",
                         "--model", "lines", "--out", tmp_path / "v")
    assert code == 0, err
    assert "band 70–110 Hz found" in out
    (top,) = json.loads((tmp_path / "v" / "validation.json").read_text())["held_out"]
    assert top["level"] == 1.0 and top["kept_levels"] == [0.25, 0.5]
    assert abs(top["resonance_hz"]["predicted"] - top["resonance_hz"]["measured"]) < 0.05
    assert top["damping_ratio"]["predicted"] == pytest.approx(top["damping_ratio"]["measured"], rel=0.05)
    assert top["peak_abs"]["predicted"] == pytest.approx(top["peak_abs"]["measured"], rel=0.05)
