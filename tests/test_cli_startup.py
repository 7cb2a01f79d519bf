"""``nlupdate --help`` and ``--version`` start without the numerics, and a command loads
only its own module: the heavy imports (numpy, pandas, scipy, matplotlib, Prefect) are
what made ``--version`` take 1.4 s."""
from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("numpy", "pandas", "scipy", "matplotlib", "prefect")


def modules_after(argv: list[str]) -> tuple[str, set[str]]:
    script = (
        "import sys\nfrom nlupdate.app.cli import main\n"
        f"try:\n    main({argv!r})\nexcept SystemExit:\n    pass\n"
        "print('MODULES', ' '.join(sorted(sys.modules)))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    *shown, last = done.stdout.strip().splitlines()
    assert last.startswith("MODULES ")
    return "\n".join(shown), set(last.split()[1:])


@pytest.mark.parametrize("argv", [["--version"], ["--help"]])
def test_help_and_version_import_no_numerics(argv):
    shown, modules = modules_after(argv)
    assert "nlupdate" in shown
    loaded = sorted(m for m in modules if m.split(".")[0] in HEAVY)
    assert loaded == [], f"nlupdate {argv[0]} imported {loaded[:5]}"
    assert not any(m.startswith("nlupdate.app.cli.") and m != "nlupdate.app.cli.interrupts" for m in modules)


def test_help_lists_every_command_and_a_command_loads_only_its_module():
    from nlupdate.app.cli import COMMANDS

    shown, _ = modules_after(["--help"])
    for name, help in COMMANDS.items():
        assert name in shown and help[:30] in " ".join(shown.split()), name
    _, modules = modules_after(["identify", "--help"])
    commands = {m.split(".")[3] for m in modules if m.startswith("nlupdate.app.cli.") and m.count(".") == 3}
    assert "identify" in commands and not commands & (set(COMMANDS) - {"identify"})


def test_the_startup_benchmark_prints_both_commands(capsys):
    """benchmarks/startup.py prints a median time for each command (the figure of
    docs/performance.md); how fast it is belongs to the benchmark, not to the suite — the
    modules a command loads (above) are the behaviour that keeps it fast."""
    from benchmarks.startup import main as startup

    assert startup(["--repeats", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    timed = {line.split()[1]: float(line.split("median ")[1].split(" s")[0]) for line in lines[1:]}
    assert set(timed) == {"--version", "--help"} and min(timed.values()) > 0, lines
