"""Checks on where a command will write, made before any work starts.

One rule for every command: an existing ``--out`` is replaced only with ``--overwrite``
(and then only once the new output is complete); a folder that cannot be created or
written is one error naming the option and the folder.
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from nlupdate.cli import CliError


def add_overwrite_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--overwrite", action="store_true",
                        help="replace --out if it exists (the old output is removed only when the new one is complete)")


def writable_folder(folder: Path, option: str) -> None:
    """Create ``folder`` if needed and make sure a file can be written in it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as error:
        raise CliError(f"{option} {folder}: cannot write there ({error.strerror or error})") from None


def checked_output(path: str | Path, overwrite: bool, *, folder: bool, option: str = "--out") -> Path:
    """``path`` after checking that the command may write it (see the module docstring)."""
    path = Path(path)
    if path.exists():
        if not overwrite:
            raise CliError(f"{option} {path} exists; pass --overwrite to replace it")
        if folder and not path.is_dir():
            raise CliError(f"{option} {path} exists and is a file, not a folder")
        if not folder and path.is_dir():
            raise CliError(f"{option} {path} exists and is a folder, not a file")
    writable_folder(path.parent if str(path.parent) else Path("."), option)
    return path
