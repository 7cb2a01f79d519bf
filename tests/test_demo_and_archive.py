"""The demo chain end to end (against the truth it simulated) and atomic archives."""
import json

import pytest

from nlupdate.reporting.atomic import atomic_directory
from nlupdate.demo import INITIAL_E_PA, TRUE_E_PA, TRUE_ELEMENTS, run_demo


def test_demo_recovers_the_hidden_structure_and_predicts_every_level(tmp_path):
    archive = run_demo(tmp_path, seed=1, say=lambda message: None)  # the seed the demo ships with
    assert archive.parent == tmp_path and archive.name.startswith("demo-")
    assert [p.name for p in tmp_path.iterdir()] == [archive.name]  # nothing temporary left
    for name in ("measured.parquet", "predicted.parquet", "summary.json", "measured_frfs.png", "prd_fit.png",
                 "linear_frf.png", "prediction_vs_measurement.png", "updating_history.parquet"):
        assert (archive / name).stat().st_size > 0, name
    summary = json.loads((archive / "summary.json").read_text())
    parameters = summary["identification"]["parameters"]
    assert parameters["k3"]["value"] == pytest.approx(TRUE_ELEMENTS[0].k3, rel=0.05)
    assert parameters["kf"]["value"] == pytest.approx(TRUE_ELEMENTS[1].kf, rel=0.03)
    # updating against the extracted linear FRF lands near the truth …
    updating = summary["updating"]
    assert updating["E_updated_pa"] == pytest.approx(TRUE_E_PA, rel=0.03)
    assert abs(updating["E_updated_pa"] - TRUE_E_PA) < 3 * updating["E_std_from_kf_pa"]
    # … while the low-force resonance (stuck friction spring) pushes E the wrong way
    assert summary["updating"]["E_from_low_force_resonance_pa"] > INITIAL_E_PA
    high_levels = [value for level, value in summary["prediction_frac"].items() if float(level) >= 10]
    assert min(high_levels) > 0.98


def test_failed_run_leaves_no_archive_under_its_final_name(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_directory(tmp_path / "run", keep_failed=True) as archive:
            (archive.path / "half.txt").write_text("partial")
            raise RuntimeError("solver died")
    assert not (tmp_path / "run").exists()
    failed = tmp_path / ".failed-run"
    assert "solver died" in (failed / "error.txt").read_text()
    with atomic_directory(tmp_path / "run") as first:
        pass
    with atomic_directory(tmp_path / "run") as second:
        pass
    assert first.final == tmp_path / "run" and second.final == tmp_path / "run-1"


def test_existing_output_is_replaced_only_when_asked(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "old.txt").write_text("old")
    with pytest.raises(FileExistsError):
        with atomic_directory(tmp_path / "out", on_exists="error"):
            pass
    with atomic_directory(tmp_path / "out", on_exists="replace") as archive:
        (archive.path / "new.txt").write_text("new")
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
