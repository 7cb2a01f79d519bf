"""Checks on where a command will write, made before any work starts.

One rule for every command: an existing ``--out`` is replaced only with ``--overwrite``,
only when it is an output of that command that nlupdate wrote and that holds nothing else
(:func:`nlupdate.files.check_replaceable`), and only once the new output is complete; the
working folder, its parents, the folders of the command's inputs and the results root are
never an output; a folder that cannot be created or
written is one error naming the option and the folder, and so is a folder whose disk has
less than :data:`MIN_FREE_MB` megabytes free (``NLUPDATE_MIN_FREE_MB`` changes the limit;
0 turns the check off), so a full disk stops a command before its work, not when it writes.
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable, Iterable

from nlupdate.app.cli import CliError, CliRuntimeError
from nlupdate.files import NotAnOutputError, check_replaceable

#: Free space (MB) a folder's disk must have before a command writes there.
MIN_FREE_MB = 100.0
MIN_FREE_ENV = "NLUPDATE_MIN_FREE_MB"


def add_overwrite_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--overwrite", action="store_true",
                        help="replace --out if it exists (the old output is removed only when the new one is complete)")


def min_free_mb() -> float:
    """The free space a written folder needs: ``$NLUPDATE_MIN_FREE_MB``, else :data:`MIN_FREE_MB`."""
    text = os.environ.get(MIN_FREE_ENV, "").strip()
    if not text:
        return MIN_FREE_MB
    try:
        value = float(text)
    except ValueError:
        raise CliError(f"{MIN_FREE_ENV}={text!r}: expected a number of megabytes (0 turns the check off)") from None
    if not value >= 0:
        raise CliError(f"{MIN_FREE_ENV}={text!r}: expected a number of megabytes ≥ 0")
    return value


def enough_space(folder: Path, option: str) -> None:
    """Refuse (one line, exit code 1) when ``folder``'s disk has less than :func:`min_free_mb` free."""
    needed = min_free_mb()
    if needed <= 0:
        return
    try:
        free = shutil.disk_usage(folder).free / 1e6
    except OSError:
        return  # cannot be checked here (the write check reports an unusable folder)
    if free < needed:
        raise CliRuntimeError(f"{option} {folder}: only {free:.0f} MB free on its disk, {needed:.0f} MB needed; "
                              f"free some space or choose another folder ({MIN_FREE_ENV} sets the limit)")


def writable_folder(folder: Path, option: str) -> None:
    """Create ``folder`` if needed, make sure a file can be written in it and that its disk
    has room (:func:`enough_space`)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as error:
        raise CliError(f"{option} {folder}: cannot write there ({error.strerror or error})") from None
    enough_space(folder, option)


def _protected(inputs: Iterable[str | os.PathLike]) -> dict[Path, str]:
    """Folders that are never an output, with what they are: the working folder and its
    parents, the folders holding the command's input files and their parents, the
    default results root."""
    protected: dict[Path, str] = {}
    cwd = Path.cwd().resolve()
    protected[cwd] = "the working folder"
    for parent in cwd.parents:
        protected.setdefault(parent, "a parent of the working folder")
    for given in inputs:
        folder = Path(given).resolve().parent
        protected.setdefault(folder, f"the folder of the input {given}")
        for parent in folder.parents:
            protected.setdefault(parent, f"a parent of the input {given}")
    protected.setdefault(Path("results").resolve(), "the results root")
    return protected


def checked_output(path: str | Path, overwrite: bool, *, folder: bool, kind: str | None = None,
                   inputs: Iterable[str | os.PathLike] = (), option: str = "--out",
                   replaceable_file: Callable[[Path], bool] | None = None) -> Path:
    """``path`` after checking that the command may write it (see the module docstring).

    ``kind``: the kind of output folder (``--overwrite`` replaces only such an output
    nlupdate wrote, :func:`nlupdate.files.check_replaceable`); ``inputs``: the files the
    command reads (an output is never one of them, nor a folder holding them);
    ``replaceable_file``: for a file output, whether an existing file is one the command
    writes (without it, no existing file is replaced: a command says what it writes)."""
    path = Path(path)
    resolved = path.resolve()
    inputs = list(inputs)
    if folder:
        what = _protected(inputs).get(resolved)
        if what is not None:
            raise CliError(f"{option} {path}: is {what}; nlupdate never writes its output over it; "
                           f"choose a new folder")
    else:
        same = next((given for given in inputs if Path(given).resolve() == resolved), None)
        if same is not None:
            raise CliError(f"{option} {path}: is the input {same}; choose another output file")
    if path.exists():
        if not overwrite:
            raise CliError(f"{option} {path} exists; pass --overwrite to replace it")
        if folder and not path.is_dir():
            raise CliError(f"{option} {path} exists and is a file, not a folder")
        if not folder and path.is_dir():
            raise CliError(f"{option} {path} exists and is a folder, not a file")
        if folder:
            try:
                check_replaceable(path, kind)
            except NotAnOutputError as error:
                raise CliError(f"{option} {error}") from None
        elif not folder and (replaceable_file is None or not replaceable_file(path)):
            raise CliError(f"{option} {path}: is not a file this command writes; --overwrite replaces only such a "
                           f"file; choose another output file")
    writable_folder(path.parent if str(path.parent) else Path("."), option)
    return path
