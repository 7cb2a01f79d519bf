"""``nlupdate`` run in the test's own process, where a subprocess is not the point."""
from __future__ import annotations

from nlupdate.app.cli import main


def run_cli(capsys, *args: object) -> tuple[int, str, str]:
    """``nlupdate ARGS`` through :func:`nlupdate.app.cli.main`: (exit code, stdout, stderr), as
    captured by pytest's ``capsys``; argparse's own exits count as exit codes."""
    try:
        code = main([str(a) for a in args])
    except SystemExit as stop:
        code = stop.code
    out, err = capsys.readouterr()
    return code, out, err
