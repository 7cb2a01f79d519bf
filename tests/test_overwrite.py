"""``--overwrite`` replaces only an output nlupdate wrote (issue 19, item 1).

Each command runs in this process through :func:`nlupdate.app.cli.main` (what matters here
is what is left on disk, not process start-up); the checks are on the exit code, the one
line on stderr, and that every file the user had is still there, byte for byte.
"""
from __future__ import annotations

import threading
import warnings
from pathlib import Path

import pytest

from nlupdate.app.cli import main
from studies import two_dof_study, write_study
from nlupdate.files import OUTPUT_MARKER, NotAnOutputError, atomic_directory, check_replaceable

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "two_dof.toml"


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def one_line_error(capsys, code: int, result: int, *fragments: str) -> str:
    err = capsys.readouterr().err.strip()
    assert result == code, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    return err


@pytest.fixture
def users_folder(tmp_path, monkeypatch) -> Path:
    """The issue's folder: a thesis, a binary in a subfolder and a study, as the working folder."""
    folder = tmp_path / "work"
    (folder / "sub").mkdir(parents=True)
    (folder / "thesis.tex").write_text("\\documentclass{book}\n")
    (folder / "sub" / "data.bin").write_bytes(bytes(range(256)))
    (folder / "model.toml").write_text(MODEL.read_text())
    write_study(folder / "my_study.toml", two_dof_study(model="model.toml"))
    monkeypatch.chdir(folder)
    return folder


@pytest.fixture(scope="module")
def measured(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("measured") / "frf.parquet"
    assert main(["simulate", str(MODEL), "--input-dof", "0", "--freqs", "650:800:12", "--forces", "0.01,30,60,100",
                 "--out", str(path)]) == 0
    return path


def test_update_over_the_working_folder_is_refused_and_nothing_is_deleted(users_folder, capsys):
    before = snapshot(users_folder)
    result = main(["update", "my_study.toml", "--out", str(users_folder), "--overwrite"])
    one_line_error(capsys, 2, result, f"--out {users_folder}: is the working folder")
    assert snapshot(users_folder) == before


@pytest.mark.parametrize("where, what", [("..", "a parent of the working folder"),
                                         ("results", "the results root")])
def test_update_over_a_parent_or_the_results_root_is_refused(users_folder, capsys, where, what):
    (users_folder / "results").mkdir()
    before = snapshot(users_folder.parent)
    result = main(["update", "my_study.toml", "--out", where, "--overwrite"])
    one_line_error(capsys, 2, result, what)
    assert snapshot(users_folder.parent) == before


def test_update_over_the_folder_of_its_study_is_refused(users_folder, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = main(["update", str(users_folder / "my_study.toml"), "--out", str(users_folder), "--overwrite"])
    one_line_error(capsys, 2, result, "is the folder of the input")


def test_update_over_a_folder_of_other_files_is_refused_naming_them(users_folder, capsys):
    before = snapshot(users_folder)
    result = main(["update", "my_study.toml", "--out", "sub", "--overwrite"])
    one_line_error(capsys, 2, result, "--out sub: is not an nlupdate archive output (it holds data.bin)")
    assert snapshot(users_folder) == before


def test_discover_and_identify_refuse_a_folder_they_did_not_write(users_folder, measured, capsys):
    before = snapshot(users_folder)
    result = main(["discover", "--model", "model.toml", "--measured", str(measured), "--out", "sub", "--overwrite"])
    one_line_error(capsys, 2, result, "--out sub: is not an nlupdate discovery output (it holds data.bin)")
    result = main(["identify", "--measured", str(measured), "--out", "sub", "--overwrite"])
    one_line_error(capsys, 2, result, "--out sub: is not an nlupdate identification output")
    result = main(["discover", "--model", "model.toml", "--measured", str(measured), "--out", ".", "--overwrite"])
    one_line_error(capsys, 2, result, "is the working folder")
    assert snapshot(users_folder) == before


def test_simulate_never_replaces_its_model_or_a_file_that_is_not_a_table(users_folder, capsys):
    before = snapshot(users_folder)
    result = main(["simulate", "model.toml", "--input-dof", "0", "--freqs", "650:800:4", "--forces", "1",
                   "--out", "model.toml", "--overwrite"])
    one_line_error(capsys, 2, result, "model.toml")  # not a table file, and the input: refused either way
    (users_folder / "notes.csv").write_text("my,own\nnotes,here\n")
    before = snapshot(users_folder)
    result = main(["simulate", "model.toml", "--input-dof", "0", "--freqs", "650:800:4", "--forces", "1",
                   "--out", "notes.csv", "--overwrite"])
    one_line_error(capsys, 2, result, "--out notes.csv: is not a file this command writes")
    assert snapshot(users_folder) == before


def steady_dwells(path: Path) -> Path:
    """Two steady stepped-sine dwells (40 periods each) of x = 1e-6·cos(ωt − 0.3) per N."""
    import numpy as np
    import pandas as pd

    t = np.arange(2000) / 1000.0
    parts = [pd.DataFrame({"force": np.cos(2 * np.pi * f * t), "tip": 1e-6 * np.cos(2 * np.pi * f * t - 0.3),
                           "frequency_hz": f}) for f in (20.0, 21.0)]
    frame = pd.concat(parts, ignore_index=True)
    frame.insert(0, "time_s", np.arange(len(frame)) / 1000.0)
    frame.to_csv(path, index=False)
    return path


def test_frf_never_replaces_its_input_or_a_file_that_is_not_a_table(users_folder, capsys):
    """``frf dwells.csv --out dwells.csv --overwrite`` replaced the raw time history with a
    small FRF table; now frf follows simulate's rule: only a measured-FRF table is replaced."""
    steady_dwells(users_folder / "dwells.csv")
    (users_folder / "notes.csv").write_text("my,own\nnotes,here\n")
    before = snapshot(users_folder)
    result = main(["frf", "dwells.csv", "--out", "dwells.csv", "--overwrite"])
    one_line_error(capsys, 2, result, "--out dwells.csv: is the input dwells.csv")
    result = main(["frf", "dwells.csv", "--out", "notes.csv", "--overwrite"])
    one_line_error(capsys, 2, result, "--out notes.csv: is not a file this command writes")
    assert snapshot(users_folder) == before
    assert main(["frf", "dwells.csv", "--out", "frf.csv"]) == 0
    assert main(["frf", "dwells.csv", "--out", "frf.csv", "--overwrite"]) == 0  # its own output: replaced
    assert snapshot(users_folder)["dwells.csv"] == before["dwells.csv"]


def test_an_identification_output_is_replaced_but_not_with_a_file_of_the_user_in_it(users_folder, measured, capsys):
    assert main(["identify", "--measured", str(measured), "--out", "ident", "--samples", "4"]) == 0
    first = snapshot(users_folder / "ident")
    assert OUTPUT_MARKER in first and "identification.json" in first
    capsys.readouterr()
    assert main(["identify", "--measured", str(measured), "--out", "ident", "--samples", "5", "--overwrite"]) == 0
    capsys.readouterr()
    (users_folder / "ident" / "my_notes.txt").write_text("mine")
    before = snapshot(users_folder)
    result = main(["identify", "--measured", str(measured), "--out", "ident", "--samples", "4", "--overwrite"])
    one_line_error(capsys, 2, result, "--out ident: holds files nlupdate did not write there (my_notes.txt)")
    assert snapshot(users_folder) == before


# ----------------------------------------------------------------------------- the rule itself


@pytest.mark.parametrize("kind, files", [
    ("identification", {"identification.json": "{}", "fit.png": "png"}),
    ("archive", {"manifest.json": "{}", "report.md": "# notes", "plots/mine.png": "the user's"}),
])
def test_a_folder_without_the_marker_is_never_replaced_even_holding_an_outputs_files(tmp_path, kind, files):
    # the files such an output holds, but no .nlupdate-output.json: nothing says nlupdate wrote
    # them (a copy, a folder of the user's named alike, files under plots/), so nothing is removed
    old = tmp_path / "old"
    for name, text in files.items():
        (old / name).parent.mkdir(parents=True, exist_ok=True)
        (old / name).write_text(text)
    before = snapshot(old)
    top = ", ".join(sorted({name.split("/")[0] for name in files}))
    with pytest.raises(NotAnOutputError) as refused:
        check_replaceable(old, kind)
    assert str(refused.value) == (f"{old}: is not an nlupdate {kind} output (it holds {top}); --overwrite replaces "
                                  f"only a folder nlupdate wrote; choose a new or empty folder")
    with pytest.raises(NotAnOutputError, match=f"is not an nlupdate {kind} output"):
        with atomic_directory(old, on_exists="replace", kind=kind) as out:
            (out.path / "new.json").write_text("{}")
    assert snapshot(old) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old"]  # no new output left beside it


def test_an_output_of_another_kind_is_not_replaced(tmp_path):
    with atomic_directory(tmp_path / "out", kind="identification") as out:
        (out.path / "identification.json").write_text("{}")
    with pytest.raises(NotAnOutputError, match="is an nlupdate identification output, not an nlupdate archive"):
        check_replaceable(tmp_path / "out", "archive")


def test_a_failed_replacement_leaves_the_old_output_intact(tmp_path):
    with atomic_directory(tmp_path / "out", kind="archive") as out:
        (out.path / "manifest.json").write_text("old")
    with pytest.raises(RuntimeError, match="solver died"):
        with atomic_directory(tmp_path / "out", on_exists="replace", kind="archive") as out:
            (out.path / "manifest.json").write_text("new")
            raise RuntimeError("solver died")
    assert (tmp_path / "out" / "manifest.json").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_folder_changed_during_the_run_is_not_replaced_and_the_new_output_is_kept(tmp_path):
    with atomic_directory(tmp_path / "out", kind="archive") as out:
        (out.path / "manifest.json").write_text("old")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with atomic_directory(tmp_path / "out", on_exists="replace", kind="archive") as out:
            (out.path / "manifest.json").write_text("new")
            (tmp_path / "out" / "added-meanwhile.txt").write_text("the user's")
    assert (tmp_path / "out" / "added-meanwhile.txt").read_text() == "the user's"
    assert out.final == tmp_path / "out-1" and (out.final / "manifest.json").read_text() == "new"
    assert any("(it changed while this run was writing); this output is" in str(w.message) for w in caught)


def test_two_runs_writing_one_new_output_at_once_both_keep_their_result(tmp_path):
    """The issue's two ``identify --out same`` started together: the second does not
    replace the first; it keeps its result beside it and says where."""
    started, finals = threading.Barrier(2), []

    def one(tag: str) -> None:
        with atomic_directory(tmp_path / "same", on_exists="error", kind="identification") as out:
            (out.path / "identification.json").write_text(tag)
            started.wait()
        finals.append(out.final)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        threads = [threading.Thread(target=one, args=(tag,)) for tag in "ab"]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    assert sorted(finals) == [tmp_path / "same", tmp_path / "same-1"]
    assert sorted((f / "identification.json").read_text() for f in finals) == ["a", "b"]
    assert [str(w.message) for w in caught if "written by another run" in str(w.message)] == [
        f"{tmp_path / 'same'} was written by another run while this one was writing; this output is "
        f"{tmp_path / 'same-1'}"]


def test_a_full_disk_while_writing_names_the_folder_and_keeps_nothing(tmp_path):
    import errno
    import os

    with pytest.raises(OSError, match=f"No space left on device while writing {tmp_path / 'out'} \\(nothing of it"):
        with atomic_directory(tmp_path / "out", kind="archive") as out:
            (out.path / "manifest.json").write_text("{}")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # as pyarrow reports it: no file name
    assert list(tmp_path.iterdir()) == []
