"""``nlupdate discover``: the output folder, the augmented model used by another command, and
one-line errors (exit code 2) with nothing written under ``--out``."""
import json
from pathlib import Path

import pandas as pd
import pytest

from nlupdate.app.cli import main
from nlupdate.core.model.model_file import load_system
from test_examples import header_commands

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "discovery"
MODEL = EXAMPLES / "sdof_linear.toml"
MEASURED = EXAMPLES / "sdof_friction_cubic.csv"  # time integration of the SDOF with a Jenkins joint and a cubic spring


@pytest.fixture(scope="module")
def run_output(tmp_path_factory):
    """The command of examples/discovery/sdof_linear.toml's header (its own run in
    tests/test_examples.py is in the slow suite: this is the same command)."""
    (argv,) = header_commands(MODEL)
    assert argv[:-1] == ["discover", "--model", "examples/discovery/sdof_linear.toml", "--measured",
                         "examples/discovery/sdof_friction_cubic.csv", "--out"], argv
    out = tmp_path_factory.mktemp("cli") / "found"
    code = main(["discover", "--model", str(MODEL), "--measured", str(MEASURED), "--out", str(out)])
    return code, out


def test_discover_writes_json_model_and_plots(run_output):
    code, out = run_output
    assert code == 0
    data = json.loads((out / "discovery.json").read_text())
    assert sorted((e["effect"], tuple(e["dofs"])) for e in data["effects"]) == [
        ("cubic_stiffness", (0,)), ("dry_friction", (0,)),
    ]
    assert data["effect"] == data["effects"][0]["effect"] and data["dofs"] == [0]
    assert data["gap_after"] <= 0.3 * data["gap_before"]
    assert data["candidates"] and all({"effect", "dofs", "score", "parameters"} <= set(c) for c in data["candidates"])
    for name in ("frf_levels.png", "describing_function.png", "gap_per_level.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_augmented_model_is_used_by_another_command(run_output, tmp_path):
    _, out = run_output
    system = load_system(out / "augmented_model.toml")
    assert sorted(type(e).__name__ for e in system.elements) == ["CubicStiffness", "JenkinsFriction"]
    frf = tmp_path / "frf.csv"
    code = main(["simulate", str(out / "augmented_model.toml"), "--input-dof", "0", "--freqs", "650:780:14",
                 "--forces", "2,60", "--out", str(frf)])
    assert code == 0 and len(pd.read_csv(frf)) == 28


@pytest.mark.slow
def test_modal_table_is_recognised(tmp_path):
    """In the slow suite: the default suite's tests/test_discovery_modal.py runs the same
    command on the same modal table (the README's, without --max-effects) and checks that it is
    read as a modal table and that microslip comes first; --max-effects 1 is run by
    tests/test_discovery_places.py. This second discovery of the gun barrel cost 2.8 s CPU."""
    out = tmp_path / "gun"
    code = main(["discover", "--model", str(EXAMPLES / "gunbarrel_mode1.toml"), "--measured",
                 str(EXAMPLES / "gunbarrel_modal.csv"), "--out", str(out), "--max-effects", "1"])
    data = json.loads((out / "discovery.json").read_text())
    assert code == 0 and data["measurement"] == "modal" and data["effect"] == "microslip"  # friction-type


def _bad_run(tmp_path, capsys, model=MODEL, measured=MEASURED, extra=()):
    out = tmp_path / "out"
    code = main(["discover", "--model", str(model), "--measured", str(measured), "--out", str(out), *extra])
    error = capsys.readouterr().err.strip()
    assert code == 2
    assert error.startswith("nlupdate discover: error: ") and "\n" not in error
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    return error


def test_one_force_level_is_refused_with_the_reason(tmp_path, capsys):
    one = tmp_path / "one_level.csv"
    table = pd.read_csv(MEASURED, dtype={"response_dof": str, "input_dof": str})
    table[table["force_level_n"] == 2.0].to_csv(one, index=False)
    error = _bad_run(tmp_path, capsys, measured=one)
    assert str(one) in error and "only one force level (2 N)" in error and "two or more force levels" in error


def test_coordinates_the_model_lacks(tmp_path, capsys):
    other = tmp_path / "other_dof.csv"
    table = pd.read_csv(MEASURED, dtype={"response_dof": str, "input_dof": str})
    table.assign(response_dof="tip").to_csv(other, index=False)
    error = _bad_run(tmp_path, capsys, measured=other)
    assert "column 'response_dof' names coordinate 'tip', which the model lacks" in error and str(other) in error


def test_model_without_mass_is_refused_before_work(tmp_path, capsys):
    broken = tmp_path / "broken.toml"
    broken.write_text('[model]\nkind = "lumped"\nmass = [[0.0]]\nstiffness = [[0.0]]\n')
    error = _bad_run(tmp_path, capsys, model=broken)
    assert f"{broken} [model]: 'mass' has 0 on the diagonal at dof 0" in error


def test_model_that_fails_to_solve(tmp_path, capsys, monkeypatch):
    from nlupdate.core.discovery import ModelSolveError

    def unsolvable(*args, **kwargs):
        raise ModelSolveError("the model cannot be solved at 2 N (singular dynamic stiffness)")

    monkeypatch.setattr("nlupdate.app.cli.discover.discover", unsolvable)
    error = _bad_run(tmp_path, capsys)
    assert f"{MODEL}: the model cannot be solved at 2 N" in error


def test_unknown_effect(tmp_path, capsys):
    error = _bad_run(tmp_path, capsys, extra=("--effects", "cubic_stiffness,glue"))
    assert "options.effects: unknown effect 'glue'" in error


def test_failure_while_writing_leaves_nothing(tmp_path, capsys, monkeypatch):
    def half_written(result, directory):
        (Path(directory) / "discovery.json").write_text("{")
        raise ValueError("disk full (simulated)")

    monkeypatch.setattr("nlupdate.app.cli.discover.write_discovery", half_written)
    assert "disk full" in _bad_run(tmp_path, capsys, extra=("--max-effects", "1"))


def test_the_commands_defaults_are_the_discoverys_own():
    """discover's options default to DiscoveryOptions' values and offer its choices (each was a
    second literal copy in the CLI)."""
    from nlupdate.app.cli import build_parser
    from nlupdate.core.discovery import DiscoveryOptions
    from nlupdate.core.discovery.candidates import CRITERIA

    args = build_parser().parse_args(["discover", "--model", "m.toml", "--measured", "x.csv", "--out", "o"])
    own = DiscoveryOptions()
    for name in ("criterion", "max_effects", "frequency_uncertainty", "damping_uncertainty"):
        assert getattr(args, name) == getattr(own, name), name
    actions = {a.dest: a for a in build_parser()._subparsers._group_actions[0].choices["discover"]._actions}
    assert tuple(actions["criterion"].choices) == CRITERIA and tuple(actions["sweep"].choices) == ("up", "down", "unknown")
