"""Command-line interface: ``nlupdate <command> …``.

Each command lives in its own module exposing ``register(subparsers)``; :data:`COMMANDS`
lists them with their one-line help, so ``nlupdate --help`` and ``--version`` import no
command module (they start in a fraction of a second) and a command imports only its own.
Every failure a
user can meet ends as one line on stderr, ``nlupdate <command>: error: …``, and an exit
code: 2 for a mistake in the input (options, study, model or data files), 1 when the work
itself failed (an FE solver, the Prefect server, a Dask cluster, the file system), 130
when interrupted with Ctrl-C and 143 with SIGTERM (:mod:`nlupdate.app.cli.interrupts`).
``--debug`` shows the traceback instead.
"""
from __future__ import annotations

import argparse
import importlib
import re
import signal
import sys
import threading
import warnings
from typing import Sequence

#: The commands, in the order ``--help`` lists them: name (= module) → one-line help.
COMMANDS: dict[str, str] = {
    "run": "run a study as Prefect flows (cached, parallel) and archive it",
    "demo": "run the whole chain on the embedded T-beam study; archive in results/",
    "simulate": "simulate measured FRFs (all dofs) of a model at several force levels",
    "frf": "estimate first-harmonic FRFs per level from time histories",
    "identify": "identify the nonlinearity and the linear FRF (PRD or DDF method)",
    "amplitude": "amplitude-dependent modal model of one mode (backbone and damping curve)",
    "validate": "fit on some force levels, predict the held-out ones, compare with the baseline",
    "update": "run a study (identification, updating, prediction) in this process, without Prefect",
    "discover": "find the effect a model is missing (where, which, parameters), add it and show the gap shrink",
    "archive": "list, show, compare and rerun archived runs",
    "schedule": "run a study on a cron or interval schedule (Prefect deployment)",
    "serve": "run the scheduled studies as they come due",
}

EXIT_RUNTIME, EXIT_INPUT = 1, 2


class CliError(Exception):
    """A mistake in the command line or its input files: one line, exit code 2."""


class CliRuntimeError(Exception):
    """The work failed for a reason outside the input (solver, server, disk): exit code 1."""


class Parser(argparse.ArgumentParser):
    """argparse with errors as two lines: what is wrong, and where help is (not the whole usage).

    A value that starts with a minus and a digit (``--band -50:760``, ``--forces -1,2``) is
    a value, never an option: argparse took only plain negative numbers so, and said
    "expected one argument" for the rest; the option's own check now names what is wrong.
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message: str):
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message}\n(see '{self.prog} --help')\n")


def plain(docstring: str) -> str:
    """A module docstring as terminal text: reStructuredText roles and literals removed."""
    text = re.sub(r":(?:func|class|mod|meth|attr):`~?([^`]+)`", lambda m: m.group(1).split(".")[-1], docstring)
    return text.replace("``", "").strip()


def add_command(subparsers: argparse._SubParsersAction, name: str, docstring: str,
                add_help: bool = True) -> argparse.ArgumentParser:
    """A sub-command whose ``--help`` shows ``docstring`` as plain text (first line = summary):
    the module docstring is the user's help, so it speaks of options and files, not of
    the code (``tests/test_help_texts.py`` checks)."""
    return subparsers.add_parser(name, help=COMMANDS[name], description=plain(docstring), add_help=add_help,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)


def _checked(kind: type, minimum: float, name: str):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {name}, got {text!r}") from None
        if not value >= minimum:
            raise argparse.ArgumentTypeError(f"expected {name}, got {text!r}")
        return value
    parse.__name__ = name
    return parse


positive_int = _checked(int, 1, "an integer ≥ 1")
non_negative_int = _checked(int, 0, "an integer ≥ 0")
non_negative_float = _checked(float, 0.0, "a number ≥ 0")


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser; of the commands only the one ``argv`` names gets its arguments (its
    module imported), the others are listed with their help — so is every command when
    ``argv`` is None."""
    from nlupdate import __version__

    parser = Parser(
        prog="nlupdate", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Model updating of nonlinear structures from vibration tests at several force levels.",
        epilog="Start with 'nlupdate demo'. Study and model file formats: docs/study-files.md, docs/model-files.md.",
    )
    parser.add_argument("--version", action="version", version=f"nlupdate {__version__}")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of an error")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    named = None if argv is None else next((a for a in argv if a in COMMANDS), None)
    for name, help in COMMANDS.items():
        if argv is None or name == named:
            importlib.import_module(f"nlupdate.app.cli.{name}").register(subparsers)
        else:
            subparsers.add_parser(name, help=help)
    return parser


def _input_errors() -> tuple[type[BaseException], ...]:
    return CliError, ValueError, FileNotFoundError, FileExistsError, NotADirectoryError, IsADirectoryError, KeyError


def _runtime_errors() -> tuple[type[BaseException], ...]:
    import httpx

    from nlupdate.fe.adapters.base import AdapterError

    return CliRuntimeError, AdapterError, OSError, RuntimeError, httpx.HTTPStatusError


def _runtime_message(error: BaseException) -> str:
    """One line for a runtime error; a Prefect API that refuses us says how to log in."""
    import httpx

    if isinstance(error, httpx.HTTPStatusError) and error.response.status_code in (401, 403):
        api = str(error.request.url).split("/api/")[0] + "/api"
        return (f"the Prefect API at {api} refused the request ({error.response.status_code} "
                f"{error.response.reason_phrase}); a server with authentication needs "
                f"PREFECT_API_AUTH_STRING=user:password (its PREFECT_SERVER_API_AUTH_STRING) here")
    return one_line(error)


def one_line(message: object) -> str:
    """A possibly multi-line error as one line: its first line and the log it points to."""
    lines = [line.strip() for line in str(message).splitlines() if line.strip()]
    if not lines:
        return ""
    log = next((line for line in lines[1:] if line.startswith("log:")), None)
    return f"{lines[0]} ({log})" if log and log not in lines[0] else lines[0]


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"nlupdate: warning: {message}", file=sys.stderr)


def _interrupted_line(args: argparse.Namespace, signum: int) -> str:
    how = "interrupted" if signum == signal.SIGINT else f"interrupted ({signal.Signals(signum).name})"
    return f"nlupdate {args.command}: {how}; {getattr(args, 'interrupt_note', 'nothing was written')}"


def entry() -> None:
    """The ``nlupdate`` program (``python -m nlupdate`` too): :func:`main` on the command
    line, then the process ends with its exit code without the interpreter's teardown
    (:mod:`nlupdate.app.cli.process_end`). Python code calls :func:`main`."""
    from nlupdate.app.cli import process_end

    process_end.arm()  # before the command registers its own exit handlers: runs after them
    code = main()
    process_end.ending_with(code)
    sys.exit(code)


def main(argv: Sequence[str] | None = None) -> int:
    from nlupdate.app.cli import interrupts

    handlers = interrupts.install()
    try:
        return _run_command(argv)
    finally:
        interrupts.restore(handlers)


def _run_command(argv: Sequence[str] | None) -> int:
    from nlupdate.app.cli import interrupts

    arguments = sys.argv[1:] if argv is None else list(argv)
    args = build_parser(arguments).parse_args(arguments)
    from nlupdate.notices import NlupdateWarning

    warnings.showwarning = _show_warning
    warnings.simplefilter("always", NlupdateWarning)
    said = threading.Lock()

    def say_interrupted(signum: int) -> None:
        if said.acquire(blocking=False):  # once, whether the process unwinds or the deadline ends it
            print(_interrupted_line(args, signum), file=sys.stderr, flush=True)

    last_words = interrupts.on_deadline(lambda: say_interrupted(interrupts.signal_received() or signal.SIGINT))
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt as error:
        if args.debug:
            raise
        code = interrupts.exit_code(error)
        say_interrupted(getattr(error, "signum", signal.SIGINT))
        return code
    except Exception as error:
        signum = interrupts.signal_received()
        if signum is None or args.debug:
            return _failed(args, error)
        # the interrupt surfaced inside a library that wrapped it in its own error (pydantic
        # building a schema reports it as a SchemaError): still the user's interrupt
        say_interrupted(signum)
        return interrupts.EXIT_CODES[signum]
    finally:
        interrupts.forget(last_words)


def _failed(args: argparse.Namespace, error: Exception) -> int:
    """One line for a command that failed with ``error`` (raised as it is with --debug); the exit code."""
    if args.debug:
        raise error
    if isinstance(error, _input_errors()):
        message = error.args[0] if isinstance(error, KeyError) and error.args else error
        print(f"nlupdate {args.command}: error: {message}", file=sys.stderr)
        return EXIT_INPUT
    if isinstance(error, _runtime_errors()):
        print(f"nlupdate {args.command}: error: {_runtime_message(error)}", file=sys.stderr)
        return EXIT_RUNTIME
    # a bug: say so in one line; --debug shows where
    print(f"nlupdate {args.command}: internal error: {type(error).__name__}: {error} "
          f"(rerun with --debug for the traceback)", file=sys.stderr)
    return EXIT_RUNTIME


if __name__ == "__main__":
    entry()
