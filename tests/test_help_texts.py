"""``--help`` speaks to the user: options, files and docs, never the code behind them — no
dotted module names, no "this module", no bare module name left in parentheses by a
removed reference — and ``schedule list --help`` is the help of ``schedule list``
(issue "rough edges a new user hit")."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from nlupdate.app.cli import COMMANDS, main

ROOT = Path(__file__).resolve().parents[1]
#: module names of the code: "(steps)", "(outputs)" in a help text are leftovers of
#: references to them
MODULES = {path.stem for path in (ROOT / "src" / "nlupdate").rglob("*.py")} - {"__init__"}
assert len(MODULES) > 100, "the package's modules were not found: the check would pass vacuously"
CODE_WORDS = re.compile(r"nlupdate\.[a-z_]+|\bthis module\b|\bThe work is\b|:(?:func|mod|class|meth):")

COMMAND_LINES = [[name] for name in COMMANDS] + [["archive", action] for action in ("list", "show", "compare", "rerun")]


def help_text(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as ended:
        main([*argv, "--help"])
    assert ended.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("argv", COMMAND_LINES, ids=" ".join)
def test_help_names_no_code(argv, capsys):
    text = help_text(argv, capsys)
    assert not CODE_WORDS.findall(text), (argv, CODE_WORDS.findall(text))
    leftovers = [word for word in re.findall(r"\(([a-z_]+)\)", text) if word in MODULES]
    assert not leftovers, (argv, leftovers)


@pytest.mark.parametrize("action, says, option", [("list", "usage: nlupdate schedule list [--json]", "--json"),
                                                  ("delete", "usage: nlupdate schedule delete NAME", "NAME")])
def test_schedule_action_help_is_that_actions_help(action, says, option, capsys):
    whole = help_text(["schedule"], capsys)
    text = help_text(["schedule", action], capsys)
    assert text.startswith(says)
    assert option in text
    assert "--cron" not in text and "--interval" not in text and len(text) < len(whole) / 3
    assert "--cron" in whole  # the study form still has the whole help
