"""Archives stay inside their root, copy nothing more readable than it was, follow no link
out of an input folder, and one damaged archive hides no other (issue 19, items 4 and 9)."""
from __future__ import annotations

import json
import stat
import warnings
from pathlib import Path
from types import SimpleNamespace

import pytest

from nlupdate.app.cli import main
from nlupdate.reporting.archive import archive_inputs, write_failed_archive
from nlupdate.reporting.catalogue import ArchiveError, archived_study, open_run
from nlupdate.fingerprints import tree_hash
from nlupdate.study import load_study
import studies

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "two_dof.toml"


def study_text(name_line: str | None) -> str:
    """The small 2-DOF study (:func:`studies.small_two_dof_study`) with ``name_line`` (TOML
    text, possibly invalid) as its [study] table."""
    text = studies.study_text({key: value for key, value in studies.small_two_dof_study().items() if key != "study"})
    return text + "\n[study]\n" + (name_line if name_line is not None else 'name = "two-dof"') + "\n"


@pytest.mark.parametrize("name, problem", [
    ("../../escaped", "a path, not one name"),
    ("/tmp/absolute", "a path, not one name"),
    ("a\\\\b", "a path, not one name"),
    (".hidden", "starting with '.'"),
    ("x" * 256, "256 characters (at most 100)"),
    ("tab\\there", "unprintable"),
    ("", "an empty name"),
])
def test_a_study_name_is_one_folder_name(tmp_path, capsys, name, problem):
    path = tmp_path / "study.toml"
    path.write_text(study_text(f'name = "{name}"'))
    code = main(["update", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "[study] key 'name': expected one folder name" in err and problem in err, err
    assert not (tmp_path / "out").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["study.toml"]


def test_a_file_name_too_long_for_a_study_name_says_so(tmp_path, capsys):
    path = tmp_path / ("s" * 120 + ".toml")
    path.write_text(study_text(None).replace('[study]\nname = "two-dof"\n', "[study]\n"))
    code = main(["update", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "is named after its file" in err and "give it a [study] name" in err, err


def test_an_archived_copy_is_never_more_readable_than_its_original(tmp_path):
    """A study naming a 0600 file (here as its measured data) that then fails: the copy in
    its failed archive stays 0600."""
    private = tmp_path / "private.csv"
    private.write_text("frequency_hz,force_level_n\n")
    private.chmod(0o600)
    path = tmp_path / "study.toml"
    text = study_text(None)
    start, end = text.index("[measured.simulate]"), text.index("[identification]")
    path.write_text(text[:start] + f'[measured]\nfile = "{private}"\n\n' + text[end:])
    study = load_study(path)
    folder = write_failed_archive(study, tmp_path / "results" / "two-dof" / "run", {}, "ValueError: bad table")
    copies = list((folder / "inputs").rglob("private.csv"))
    assert len(copies) == 1 and stat.S_IMODE(copies[0].stat().st_mode) == 0o600


def test_links_in_an_input_folder_are_not_followed_out_of_it(tmp_path):
    secret = tmp_path / "private"
    secret.mkdir()
    (secret / "key").write_text("secret")
    inputs = tmp_path / "ident"
    inputs.mkdir()
    (inputs / "identification.json").write_text("{}")
    (inputs / "inner-link.json").symlink_to("identification.json")
    (inputs / "to-private").symlink_to(secret)
    (inputs / "dangling").symlink_to(tmp_path / "nowhere")
    study = SimpleNamespace(input_files={"ident": inputs})
    archive = tmp_path / "archive"
    archive.mkdir()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        [entry] = archive_inputs(study, archive)
    copy = archive / entry["archived"]
    assert (copy / "inner-link.json").read_text() == "{}" and not (copy / "inner-link.json").is_symlink()
    assert (copy / "to-private").is_symlink() and (copy / "dangling").is_symlink()
    assert not any("secret" in p.read_text() for p in archive.rglob("*") if p.is_file() and not p.is_symlink())
    messages = sorted(str(w.message) for w in caught)
    assert len(messages) == 2, messages
    assert "dangling is a link that points to nothing" in messages[0]
    assert "to-private is a link that points outside the input folder" in messages[1]
    assert entry["sha256"] == tree_hash(copy) == tree_hash(inputs)


# ----------------------------------------------------------------------------- tampered archives


def make_run(root: Path, study: str, run_id: str, manifest) -> Path:
    folder = root / study / run_id
    folder.mkdir(parents=True)
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return folder


def good_manifest(run_id: str) -> dict:
    return {"run_id": run_id, "status": "complete", "study": {"name": "s"}, "run": {"started_utc": "2026-01-01"},
            "inputs": {"files": []}, "failures": []}


def test_one_damaged_archive_hides_no_other(tmp_path, capsys):
    root = tmp_path / "results"
    make_run(root, "s", "a-good", good_manifest("a-good"))
    make_run(root, "s", "b-list", [])
    make_run(root, "s", "c-empty", {})
    corrupt = make_run(root, "s", "d-table", good_manifest("d-table"))
    (corrupt / "tables").mkdir()
    (corrupt / "tables" / "ranking.parquet").write_bytes(b"PAR1 not a parquet file")
    assert main(["archive", "list", "--root", str(root)]) == 0
    lines = capsys.readouterr().out.splitlines()
    status = {line.split()[1]: line for line in lines}
    assert sorted(status) == ["a-good", "b-list", "c-empty", "d-table"], lines
    assert "complete" in status["a-good"].split()
    assert all("damaged" in status[name].split() for name in ("b-list", "c-empty", "d-table")), lines
    assert " damaged " in status["b-list"] and "holds a list, not a manifest object" in status["b-list"]
    assert " damaged " in status["c-empty"] and "no run record" in status["c-empty"]
    assert " damaged " in status["d-table"] and "ranking.parquet: cannot be read" in status["d-table"]


def test_a_manifest_nested_too_deep_to_read_is_one_damaged_archive(tmp_path, capsys):
    """A manifest nested 10⁵ deep made the JSON reader exceed Python's recursion limit, and
    `archive list` failed for the whole root (exit 1); now that archive alone is damaged."""
    root = tmp_path / "results"
    make_run(root, "s", "a-good", good_manifest("a-good"))
    deep = make_run(root, "s", "b-deep", {})
    depth = 100_000
    (deep / "manifest.json").write_text('{"run_id": "b-deep", "x": ' + "[" * depth + "]" * depth + "}")
    assert main(["archive", "list", "--root", str(root)]) == 0
    lines = capsys.readouterr().out.splitlines()
    status = {line.split()[1]: line for line in lines}
    assert sorted(status) == ["a-good", "b-deep"], lines
    assert "complete" in status["a-good"].split()
    assert " damaged " in status["b-deep"] and "nested too deep" in status["b-deep"], lines
    assert main(["archive", "show", "b-deep", "--root", str(root)]) == 2
    err = capsys.readouterr().err
    assert "b-deep" in err and "nested too deep" in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("edit, fragment", [
    (lambda m: m["inputs"]["files"].append({"as_written": "data.csv", "archived": "/etc/passwd", "sha256": "0"}),
     "archived input '/etc/passwd' points outside the archive"),
    (lambda m: m["inputs"]["files"].append({"as_written": "data.csv", "archived": "inputs/../../../x", "sha256": "0"}),
     "points outside the archive"),
    (lambda m: m["study"].update(name="../../../x"), "study name '../../../x' is not one folder name"),
])
def test_show_compare_and_rerun_refuse_a_manifest_pointing_outside(tmp_path, capsys, edit, fragment):
    root = tmp_path / "results"
    manifest = good_manifest("run-1")
    edit(manifest)
    folder = make_run(root, "s", "run-1", manifest)
    (folder / "study.toml").write_text(study_text(None))
    with pytest.raises(ArchiveError, match="points outside the archive|not one folder name"):
        open_run(folder)
    for command in (["archive", "show", "run-1"], ["archive", "rerun", "run-1", "--out", str(tmp_path / "again")],
                    ["archive", "compare", "run-1", "run-1"]):
        code = main([*command, "--root", str(root)])
        err = capsys.readouterr().err
        assert code == 2 and fragment in err and len(err.strip().splitlines()) == 1, (command, err)
    assert not (tmp_path / "again").exists() and not (tmp_path / "x").exists()


def test_an_archived_input_that_is_a_link_out_of_the_archive_is_refused(tmp_path):
    root = tmp_path / "results"
    manifest = good_manifest("run-1")
    manifest["inputs"]["files"].append({"as_written": "data.csv", "archived": "inputs/ab/data.csv", "sha256": "0"})
    folder = make_run(root, "s", "run-1", manifest)
    (folder / "inputs" / "ab").mkdir(parents=True)
    (folder / "inputs" / "ab" / "data.csv").symlink_to("/etc/passwd")
    with pytest.raises(ArchiveError, match="points outside the archive \\(through a link\\)"):
        open_run(folder)


def test_a_rerun_reads_no_file_the_archive_does_not_keep(tmp_path):
    """A study.toml edited in the archive to name a file outside it is refused."""
    root = tmp_path / "results"
    folder = make_run(root, "two-dof", "run-1", good_manifest("run-1"))
    (folder / "study.toml").write_text(study_text(None))  # names the model file, which is not kept here
    with pytest.raises(ValueError, match="names '.*two_dof.toml', which is not among the files kept with it"):
        archived_study(open_run(folder))


# ----------------------------------------------------------------------------- an input replaced mid-run


def test_a_file_replaced_during_a_run_is_archived_as_it_was_read(tmp_path, monkeypatch, capsys):
    """The issue's case: the measured CSV is replaced while the run goes on. The run reads
    its inputs once, as it starts; the manifest's hash, the archived copy and the results
    all come from those bytes."""
    import hashlib

    import pandas as pd

    import nlupdate.app.cli.update as update_command

    measured = tmp_path / "frf.csv"
    assert main(["simulate", str(MODEL), "--input-dof", "0", "--freqs", "690:770:40", "--forces",
                 "0.01,60", "--noise", "0.01", "--seed", "3", "--out", str(measured)]) == 0
    original = measured.read_bytes()
    text = study_text(None)
    start, end = text.index("[measured.simulate]"), text.index("[identification]")
    path = tmp_path / "study.toml"
    path.write_text(text[:start] + f'[measured]\nfile = "{measured}"\n\n' + text[end:])

    real_run_study = update_command.run_study

    def replaced_first(study, say):
        table = pd.read_csv(measured)
        table["h_real"] *= 1.05  # someone rewrites the data while the run goes on
        table.to_csv(measured, index=False)
        return real_run_study(study, say)

    monkeypatch.setattr(update_command, "run_study", replaced_first)
    assert main(["update", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    capsys.readouterr()
    assert measured.read_bytes() != original
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    [entry] = [e for e in manifest["inputs"]["files"] if e["as_written"] == str(measured)]
    assert entry["sha256"] == hashlib.sha256(original).hexdigest()
    assert (tmp_path / "out" / entry["archived"]).read_bytes() == original
    assert manifest["inputs"]["measured"]["file_sha256"] == hashlib.sha256(original).hexdigest()
    from nlupdate.core.measurement.frf_files import read_frf_table
    from nlupdate.fingerprints import table_hash

    measured.write_bytes(original)
    assert manifest["inputs"]["measured"]["sha256"] == table_hash(read_frf_table(measured))
