"""The ``nlupdate`` program ends with its command's exit code once every exit handler has
run, its output flushed, without the interpreter's teardown (app/cli/process_end.py); Python
code calling ``main`` is not affected."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

# A program run as ``nlupdate``: the command (``main``) writes unflushed output, registers an
# exit handler as Prefect's writers and the FE scratch folders do, and leaves an object whose
# finaliser only the interpreter's teardown would call.
PROGRAM = textwrap.dedent("""
    import atexit, sys
    from pathlib import Path
    import nlupdate.app.cli as cli

    folder = Path(sys.argv[1])

    class TornDown:
        def __del__(self, path=str(folder / "torn-down"), open=open):  # module globals are gone by then
            with open(path, "w") as file:
                file.write("yes")

    def command(argv=None):
        atexit.register(lambda: (folder / "exit-handler").write_text("ran"))
        sys.stdout.write("no newline, not flushed")
        sys.stderr.write("to stderr")
        globals()["kept"] = TornDown()
        if sys.argv[2] == "raise":  # as with --debug: the error propagates
            raise RuntimeError("the command failed")
        return int(sys.argv[2])

    cli.main = command
    cli.entry()
""")


def run_program(folder: Path, code: int | str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", PROGRAM, str(folder), str(code)], capture_output=True, text=True,
                          timeout=60)


def test_the_program_ends_with_the_code_after_every_exit_handler_without_teardown(tmp_path):
    for code in (0, 2, 3):
        folder = tmp_path / str(code)
        folder.mkdir()
        done = run_program(folder, code)
        assert done.returncode == code, done.stderr
        assert done.stdout == "no newline, not flushed" and done.stderr == "to stderr"
        assert (folder / "exit-handler").read_text() == "ran"
        assert not (folder / "torn-down").exists()  # the teardown was skipped


def test_python_calling_main_ends_as_usual(tmp_path):
    """A test session or a notebook calls ``main``: its own exit code and teardown stay."""
    script = textwrap.dedent("""
        import sys
        from pathlib import Path
        from nlupdate.app.cli import main

        class TornDown:
            def __del__(self, path=str(Path(sys.argv[1], "torn-down")), open=open):
                with open(path, "w") as file:
                    file.write("yes")

        kept = TornDown()
        try:
            main(["--help"])
        except SystemExit:
            pass
        sys.exit(5)
    """)
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 5, done.stderr
    assert (tmp_path / "torn-down").read_text() == "yes"


def test_a_command_that_raises_ends_as_usual_with_its_traceback(tmp_path):
    """An error that propagates (``--debug``): Python prints the traceback, exits 1 and
    tears down as usual."""
    done = run_program(tmp_path, "raise")
    assert done.returncode == 1
    assert "Traceback" in done.stderr and "RuntimeError: the command failed" in done.stderr
    assert (tmp_path / "exit-handler").read_text() == "ran" and (tmp_path / "torn-down").read_text() == "yes"


HALF_MADE_HANDLER = textwrap.dedent("""
    import sys
    from pathlib import Path
    import nlupdate.app.cli as cli

    def command(argv=None):
        import logging  # as in the program: first imported by the command (Prefect)

        class Flushed(logging.Handler):
            def flush(self):
                Path(sys.argv[1]).write_text("flushed")

        logging.getLogger("kept").addHandler(Flushed())
        cut = logging.Handler.__new__(logging.Handler)  # what a signal inside Handler.__init__
        cut._closed = False                              # leaves: registered, but no lock yet
        logging._addHandlerRef(cut)
        globals()["cut"] = cut  # held, as a logger holds its handlers
        sys.stdout.write("done")
        return 143

    cli.main = command
    cli.entry()
""")


def test_a_handler_cut_short_by_a_signal_does_not_spoil_the_exit(tmp_path):
    """An interrupted run (143) may leave a logging handler whose ``__init__`` a signal cut
    short: ``logging.shutdown`` raised AttributeError ('no attribute lock') on it, the exit
    printed a traceback, and the one line an interrupted run says was not alone (seen once in
    tests/test_interrupts.py under load). The other handlers are still flushed."""
    marker = tmp_path / "marker"
    done = subprocess.run([sys.executable, "-c", HALF_MADE_HANDLER, str(marker)], capture_output=True, text=True,
                          timeout=60)
    assert (done.returncode, done.stdout, done.stderr) == (143, "done", "")
    assert marker.read_text() == "flushed"
