"""Exports as test systems write them: several runs in one UFF file, the level in the run
name, the z-axis or an ID line in the styles of nlupdate.core.measurement.run_levels, levels per
run given by the user, and a z-axis level typed in the unit the reference contradicts.

Every file is written here with pyuff from a known analytic receptance and known levels;
the reader must return those levels and that receptance, or refuse in one line naming the
file, the run and what it expected.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import pyuff

from nlupdate.core.measurement.frf_files import read_frf_tables
from nlupdate.core.measurement.frf_table import MeasurementTableError, select_frf
from nlupdate.core.measurement.run_levels import levels_in_text
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.notices import NlupdateWarning

F = np.arange(60.0, 120.5, 0.5)


def receptance(f: np.ndarray, stiffness: float) -> np.ndarray:
    """One mode, m = 1, loss factor 0.02: H = 1/(k(1 + 0.02i) − ω²) (m per reference unit)."""
    w = 2 * np.pi * f
    return 1.0 / (stiffness * (1 + 0.02j) - w**2)


def dataset(h: np.ndarray, unit: str = "V", **fields) -> dict:
    """A dataset 58 as an analyser writes it: function description in ID line 1, the run in
    line 2, the date in line 3; receptance over a reference in ``unit``; no level field."""
    base = dict(
        binary=0, func_type=4, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, data=h, x=F,
        id1="FRF 1:+Z/1:+Z", id2="", id3="28-Nov-26 10:00:00", id4="NONE", id5="NONE", abscissa_spacing=1,
        abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=8, ordinate_axis_units_lab="m",
        orddenom_spec_data_type=0 if unit == "V" else 13, orddenom_axis_units_lab=unit,
        z_axis_spec_data_type=0, z_axis_value=0.0,
    )
    base.update(fields)
    return base


def export(path: Path, datasets: list[dict]) -> Path:
    pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(**d) for d in datasets], mode="add")
    return path


def stiffness_of(level: float) -> float:
    """A different known curve per level (a softening joint, say): the reader must keep them apart."""
    return 3.2e5 * (1 - 0.05 * level)


# ---------------------------------------------------------------- the styles, one file each
STYLES = [
    # (run name or ID line, reference unit, level in that unit)
    ("Run3 0.10 V", "V", 0.10),
    ("Run3_0p10V", "V", 0.10),
    ("Round1_Chirp0p05_70to110Hz", "V", 0.05),
    ("F=2.5N", "N", 2.5),
    ("Burst 2.5N", "N", 2.5),
    ("Level 10mV", "V", 0.01),
    ("Sine_0.2V_stepped", "V", 0.2),
]


@pytest.mark.parametrize("name, unit, level", STYLES)
def test_level_in_the_run_name_in_each_style(tmp_path, name, unit, level):
    h = receptance(F, stiffness_of(level))
    path = export(tmp_path / "run.uff", [dataset(h, unit, id2=name)])
    table = read_frf_tables([path], options=ReadOptions(reference_unit=unit))
    assert sorted(set(table["force_level_n"])) == [pytest.approx(level, rel=1e-12)]
    _, back = select_frf(table, "1:uz", "1:uz", float(table["force_level_n"].iloc[0]))
    np.testing.assert_allclose(back, h, rtol=1e-9)


@pytest.mark.parametrize("text", ["Periodic chirp 70-110 Hz", "Chirp2", "Sweep_70to110Hz", "band 0-512Hz",
                                  "Round1", "X2N", "torque 2.5Nm", "28-Nov-26 10:00:00"])
def test_frequencies_run_numbers_and_dates_are_no_levels(text):
    assert levels_in_text(text) == set()


# ---------------------------------------------------------------- several runs in one file
LEVELS = (0.05, 0.10, 0.15, 0.20, 0.25, 0.30)


def multi_run_export(path: Path, names: list[str], **fields) -> Path:
    """Six runs in one file, each an FRF and its coherence; the runs told apart by ID line 2."""
    sets = []
    for name, level in zip(names, LEVELS):
        h = receptance(F, stiffness_of(level))
        sets.append(dataset(h, id2=name, **fields))
        sets.append(dataset(np.full(F.size, 0.99), id1="COH 1:+Z/1:+Z", id2=name, func_type=6,
                            ordinate_spec_data_type=0, ordinate_axis_units_lab="", orddenom_spec_data_type=0,
                            orddenom_axis_units_lab="", **fields))
    return export(path, sets)


def check_levels(table, levels=LEVELS):
    assert sorted(set(table["force_level_n"])) == pytest.approx(sorted(levels), rel=1e-12)
    for level in levels:
        _, back = select_frf(table, "1:uz", "1:uz", level)
        np.testing.assert_allclose(back, receptance(F, stiffness_of(level)), rtol=1e-9)
    assert np.all(table["reference_unit"] == "V") and np.allclose(table["coherence"], 0.99)


def test_six_runs_in_one_file_levels_in_the_run_names(tmp_path):
    names = [f"Round1_Chirp{level:.2f}_70to110Hz".replace(".", "p") for level in LEVELS]
    path = multi_run_export(tmp_path / "export.uff", names)
    check_levels(read_frf_tables([path], options=ReadOptions(reference_unit="V")))


def test_runs_without_a_level_are_listed_and_given_per_run(tmp_path):
    names = [f"Run {chr(65 + k)}" for k in range(len(LEVELS))]
    path = multi_run_export(tmp_path / "export.uff", names)
    with pytest.raises(MeasurementTableError) as error:
        read_frf_tables([path], options=ReadOptions(reference_unit="V"))
    message = str(error.value)
    assert "export.uff, dataset 0 (run 'Run A'): no level" in message and "\n" not in message
    assert "the file's runs: 'Run A', 'Run B', 'Run C', 'Run D', 'Run E', 'Run F'" in message
    assert "--level export.uff#RUN=VALUE" in message
    # FILE#RUN for some runs, the run name alone for the others
    levels = {f"export.uff#{name}": level for name, level in zip(names[:3], LEVELS[:3])}
    levels.update({name: level for name, level in zip(names[3:], LEVELS[3:])})
    check_levels(read_frf_tables([path], options=ReadOptions(reference_unit="V", levels=levels)))


def test_a_level_for_a_file_of_several_runs_and_a_level_naming_nothing_are_refused(tmp_path):
    names = [f"Run {chr(65 + k)}" for k in range(len(LEVELS))]
    path = multi_run_export(tmp_path / "export.uff", names)
    with pytest.raises(MeasurementTableError, match=r"export\.uff: holds 6 runs \('Run A', .*a level given for the "
                                                    r"file \(0\.1\) fits a file of one run: give each run's level "
                                                    r"with --level export\.uff#RUN=VALUE"):
        read_frf_tables([path], options=ReadOptions(reference_unit="V", levels={"export.uff": 0.1}))
    levels = {name: level for name, level in zip(names, LEVELS)} | {"Run G": 0.35}
    with pytest.raises(MeasurementTableError, match=r"level given for 'Run G' .*no file read and no run of them has "
                                                    r"that name; expected FILE, FILE#RUN or RUN .*export\.uff#Run A"):
        read_frf_tables([path], options=ReadOptions(reference_unit="V", levels=levels))


def test_several_files_each_of_several_runs(tmp_path):
    """Two exports of three runs each, read as one measurement."""
    first = multi_run_export(tmp_path / "a.uff", [f"Sweep_{v:.2f}V" for v in LEVELS])
    table = read_frf_tables([first], options=ReadOptions(reference_unit="V"))
    check_levels(table)
    sets_a, sets_b = [], []
    for k, level in enumerate(LEVELS):
        h = receptance(F, stiffness_of(level))
        (sets_a if k < 3 else sets_b).append(dataset(h, id2=f"Run{k + 1}_{level:.2f}V".replace(".", "p")))
    a, b = export(tmp_path / "b1.uff", sets_a), export(tmp_path / "b2.uff", sets_b)
    table = read_frf_tables([a, b], options=ReadOptions(reference_unit="V"))
    assert sorted(set(table["force_level_n"])) == pytest.approx(LEVELS, rel=1e-12)


# ---------------------------------------------------------------- z-axis typed in the other unit
def test_z_axis_level_typed_as_force_with_a_voltage_reference_is_used_with_a_note(tmp_path):
    names = [f"Run {k + 1}" for k in range(len(LEVELS))]
    sets = [dataset(receptance(F, stiffness_of(level)), id2=name, z_axis_spec_data_type=13,
                    z_axis_axis_units_lab="N", z_axis_value=level) for name, level in zip(names, LEVELS)]
    path = export(tmp_path / "z.uff", sets)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = read_frf_tables([path], options=ReadOptions(reference_unit="V"))
    assert sorted(set(table["force_level_n"])) == pytest.approx(LEVELS, rel=1e-12)
    notes = [str(w.message) for w in caught if issubclass(w.category, NlupdateWarning)]
    assert len(notes) == len(LEVELS)
    assert any("z.uff run 'Run 1': the z-axis level 0.05 is labelled 'N' (specific data type 13), while the "
               "reference is V; used as 0.05 V" in note for note in notes), notes


# ---------------------------------------------------------------- the study takes the same mapping
def test_study_levels_per_run_and_per_file(tmp_path):
    from nlupdate.study.loading import load_study
    from nlupdate.study.steps.measured import measured_table

    names = [f"Run {chr(65 + k)}" for k in range(len(LEVELS))]
    multi_run_export(tmp_path / "export.uff", names)
    levels = ", ".join([f'"export.uff#{n}" = {v}' for n, v in zip(names[:3], LEVELS[:3])]
                       + [f'"{n}" = {v}' for n, v in zip(names[3:], LEVELS[3:])])
    (tmp_path / "study.toml").write_text(f'[study]\nname = "runs"\n[measured]\nfile = "export.uff"\n'
                                         f'reference_unit = "V"\nlevels = {{ {levels} }}\n')
    check_levels(measured_table(load_study(tmp_path / "study.toml")))
    (tmp_path / "study.toml").write_text('[study]\nname = "runs"\n[measured]\nfile = "export.uff"\n'
                                         'reference_unit = "V"\nlevels = { "Run A" = -1 }\n')
    from nlupdate.study.reader import StudyError
    with pytest.raises(StudyError, match=r"levels.*Run A.*a level > 0 in the reference unit"):
        load_study(tmp_path / "study.toml")
