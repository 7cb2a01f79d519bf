"""Study keys for measured data as tests deliver it: several files with their levels,
time histories, a voltage reference and its calibration, the coordinates of stepped-sine
runs that name none."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_measured_exports import F, export_58, lms_like, receptance  # noqa: E402
from test_time_history import sdof_receptance, stepped_record  # noqa: E402

from nlupdate.core.measurement.frf_table import select_frf  # noqa: E402
from nlupdate.study.reader import StudyError  # noqa: E402
from nlupdate.study.loading import load_study  # noqa: E402
from nlupdate.study.steps.measured import measured_table  # noqa: E402


def test_files_with_levels_per_volt_and_a_calibration(tmp_path):
    h = receptance(F)
    for name in ("run_a.uff", "run_b.uff"):  # no level in the files: the study gives them
        export_58(tmp_path / name, [lms_like(h * 1j * 2 * np.pi * F, id2="")])
    (tmp_path / "study.toml").write_text(
        '[study]\nname = "beam"\n[measured]\nfiles = { "run_a.uff" = 0.05, "run_b.uff" = 0.10 }\n'
        'reference_unit = "V"\nreference_calibration = 10.0\n')
    with pytest.warns(Warning):
        table = measured_table(load_study(tmp_path / "study.toml"))
    assert sorted(set(table["force_level_n"])) == pytest.approx([0.5, 1.0])  # V × 10 N/V
    assert set(table["reference_unit"]) == {"N"}
    _, back = select_frf(table, "101:uz", "1:uz", 1.0)
    np.testing.assert_allclose(back, -h[1:] / 10.0, rtol=1e-9)


def test_time_histories_in_a_study(tmp_path):
    stepped_record([19.0, 20.0, 21.0], levels=[0.2]).to_csv(tmp_path / "dwells.csv", index=False)
    (tmp_path / "study.toml").write_text(
        '[study]\nname = "dwells"\n[measured]\ntime_histories = ["dwells.csv"]\ninput_dof = "drive"\n')
    table = measured_table(load_study(tmp_path / "study.toml"))
    f, h = select_frf(table, "tip", "drive", table["force_level_n"].iloc[0])
    np.testing.assert_allclose(h, sdof_receptance(f), rtol=0.005)


def test_coordinates_of_stepped_sine_runs_in_a_study(tmp_path):
    """The public Brake–Reuss beam runs, the sensor's axis against the force (README)."""
    data = Path(__file__).parent / "data" / "brb" / "ForcedFrequencyResponses.mat"
    (tmp_path / "study.toml").write_text(
        f'[study]\nname = "brb"\n[measured]\nfile = "{data}"\n'
        f'coordinates = {{ "{data}" = ["acc3:-y", "acc3:y"] }}\n')
    with pytest.warns(Warning, match="left out 8 run"):
        table = measured_table(load_study(tmp_path / "study.toml"))
    assert set(table["response_dof"]) == {"acc3:y"}
    assert sorted(set(table["force_level_n"])) == [0.1947, 0.4886, 0.9699, 1.46]
    f, h = select_frf(table, "acc3:y", "acc3:y", 0.1947)
    assert h[0].real > 0  # below the resonance a collocated receptance is positive


@pytest.mark.parametrize("measured, fragment", [
    ('file = "x.csv"\ncoordinates = ["a", "b"]', "'coordinates'"),
    ('file = "x.csv"\ncoordinates = { "x.csv" = ["a"] }', "<response>"),
    ('file = "x.csv"\ntime_histories = ["x.csv"]', "exactly one of file"),
    ('file = "x.csv"\ninput_dof = "0"', "'input_dof'"),
    ('file = "x.csv"\nreference_unit = "A"', "'reference_unit'"),
    ('files = { "x.csv" = -1 }', "a level > 0"),
])
def test_measured_key_mistakes(tmp_path, measured, fragment):
    (tmp_path / "x.csv").write_text("frequency_hz\n")
    (tmp_path / "study.toml").write_text(f'[study]\nname = "s"\n[measured]\n{measured}\n')
    with pytest.raises(StudyError, match=fragment):
        load_study(tmp_path / "study.toml")
