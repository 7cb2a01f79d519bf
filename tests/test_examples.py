"""Every file in examples/ runs as its header says.

Each TOML file in examples/ starts with the ``nlupdate`` commands that use it (comment
lines ``#   nlupdate …``, ``\\`` continuing a line); the test runs them in order, in a
fresh folder, with paths into examples/ and tests/data/ made absolute. Every other file
in examples/ (measured data) must be read by one of those commands — so no example can
rot unseen.
"""
from __future__ import annotations

import re
import shlex
import tomllib
import warnings
from pathlib import Path

import pytest

from nlupdate.app.cli import main
from nlupdate.reporting.catalogue import find_runs

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
#: Examples run in the slow suite: the whole bolted-beam chain (59 s here, 2 cores), and
#: those whose header command a default-suite test runs as written and checks what it finds
#: — the Brake–Reuss beam's discover (~80 s under load: tests/test_real_measurements.py),
#: the SDOF discover (tests/test_discovery_cli.py, the `run_output` fixture) and the gun
#: barrel's discover (tests/test_discovery_modal.py, as examples/discovery/README.md gives it).
SLOW = {"bolted_beam/study.toml", "discovery/brb_mode1.toml", "discovery/sdof_linear.toml",
        "discovery/gunbarrel_mode1.toml",
        "two_dof_study.toml",  # the same study runs in the default suite: tests/test_examples_py.py
        "brb/brb.toml"}  # ~3 min with its [fe_validation]; a coarse version: tests/test_fe_validation.py


def header_commands(path: Path) -> list[list[str]]:
    """The ``nlupdate`` commands in the leading comment block of ``path`` (argv lists)."""
    commands: list[str] = []
    continuing = False
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        text = line[1:].strip()
        if continuing:
            commands[-1] += " " + text.rstrip("\\").strip()
        elif text.startswith("nlupdate "):
            commands.append(text.rstrip("\\").strip())
        continuing = text.endswith("\\")
    return [shlex.split(command)[1:] for command in commands]


def absolute(argument: str) -> str:
    """Paths into the repository (``examples/…``, ``tests/…``, also after ``=``) made absolute."""
    return re.sub(r"(^|=)((?:examples|tests)/)", lambda m: m.group(1) + str(ROOT) + "/" + m.group(2), argument)


EXAMPLE_FILES = sorted(p.relative_to(EXAMPLES).as_posix() for p in EXAMPLES.rglob("*.toml"))


def needs(name: str) -> list:
    """The marks of an example: slow ones, and those whose FE model is CalculiX (need ccx)."""
    adapter = tomllib.loads((EXAMPLES / name).read_text()).get("adapter", {})
    return ([pytest.mark.slow] if name in SLOW else []) + ([pytest.mark.calculix] if adapter.get("kind") == "calculix" else [])


@pytest.mark.parametrize("name", [pytest.param(n, marks=needs(n)) for n in EXAMPLE_FILES])
def test_the_example_runs_as_its_header_says(name, tmp_path, monkeypatch):
    commands = header_commands(EXAMPLES / name)
    assert commands, f"examples/{name} names no 'nlupdate …' command in its header"
    monkeypatch.chdir(tmp_path)
    for argv in commands:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            code = main([absolute(a) for a in argv])
        assert code == 0, f"examples/{name}: nlupdate {' '.join(argv)} exited with {code}"
        out = argv[argv.index("--out") + 1] if "--out" in argv else None
        assert out is None or (tmp_path / out).exists(), f"examples/{name}: {out} was not written"
        if argv[0] == "update" and out is not None and out.startswith("results/"):  # beside `nlupdate run`'s archives, listed with them
            runs = {run.folder.resolve(): run for run in find_runs(tmp_path / "results")}
            assert (tmp_path / out).resolve() in runs, f"examples/{name}: `nlupdate archive list` does not list {out}"
            assert runs[(tmp_path / out).resolve()].status == "complete"


def study_name(path: Path) -> str | None:
    return tomllib.loads(path.read_text()).get("study", {}).get("name")


def test_no_header_writes_where_nlupdate_run_keeps_a_study_s_archives():
    """`nlupdate run` writes results/<study name>/<UTC time>-<hash>/: a header's `--out` must
    not be such a study folder (nor sit directly in results/), and an `update` archive
    under results/ goes into its own study's folder, where `archive list` finds it."""
    studies = {n for n in (study_name(EXAMPLES / f) for f in EXAMPLE_FILES) if n}
    assert {"tbeam_single_mode", "tbeam_three_modes", "bolted_beam"} <= studies
    for name in EXAMPLE_FILES:
        for argv in header_commands(EXAMPLES / name):
            out = Path(argv[argv.index("--out") + 1]) if "--out" in argv else None
            if out is None or out.parts[0] != "results":
                continue
            assert len(out.parts) > 2, f"examples/{name}: --out {out} is where `nlupdate run` keeps a study's archives"
            if argv[0] == "update":
                assert out.parts[1] == study_name(EXAMPLES / name), f"examples/{name}: --out {out} is not in its study's folder"


def test_every_data_file_is_read_by_an_example_header():
    commands = [" ".join(argv) for name in EXAMPLE_FILES for argv in header_commands(EXAMPLES / name)]
    # the tutorial scripts (*.py) are run and checked by tests/test_examples_py.py
    data = [p for p in EXAMPLES.rglob("*") if p.is_file() and p.suffix not in (".toml", ".md", ".py")]
    assert data
    for path in data:
        relative = path.relative_to(ROOT).as_posix()
        assert any(relative in command for command in commands), f"{relative} is read by no example header"
