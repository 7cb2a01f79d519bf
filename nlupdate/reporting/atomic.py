"""Output folders written atomically: built in a temporary sibling, renamed when complete.

Nothing half-written ever stands under the final name. A run that fails removes its
temporary folder, or (``keep_failed``) leaves it as ``.failed-<name>`` with the traceback
in ``error.txt`` so the partial output can be inspected.
"""
from __future__ import annotations

import contextlib
import datetime as dt
import os
import shutil
import tempfile
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

ON_EXISTS = ("suffix", "replace", "error")


def run_name(prefix: str) -> str:
    """``<prefix>-YYYYmmdd-HHMMSS`` in UTC."""
    return f"{prefix}-{dt.datetime.now(dt.timezone.utc).strftime('%Y%m%d-%H%M%S')}"


@dataclass
class ArchiveDirectory:
    """``path``: where to write now (temporary); ``final``: set once renamed."""

    path: Path
    final: Path | None = None


def _free_name(final: Path) -> Path:
    target, counter = final, 1
    while target.exists():
        target = final.parent / f"{final.name}-{counter}"
        counter += 1
    return target


@contextlib.contextmanager
def atomic_directory(
    final: str | os.PathLike, on_exists: str = "suffix", keep_failed: bool = False
) -> Iterator[ArchiveDirectory]:
    """Write into a temporary directory beside ``final``; rename it to ``final`` on success.

    ``on_exists`` says what happens when ``final`` exists: ``"suffix"`` writes
    ``final-1``, ``final-2``, … instead; ``"replace"`` swaps the new folder in (the old one
    is removed only after the new one is in place); ``"error"`` refuses before any work.
    """
    if on_exists not in ON_EXISTS:
        raise ValueError(f"on_exists must be one of {ON_EXISTS}, got {on_exists!r}")
    final = Path(final)
    if final.exists() and on_exists == "error":
        raise FileExistsError(f"{final} exists: choose another output folder or allow replacing it")
    if final.exists() and not final.is_dir():
        raise ValueError(f"{final} exists and is not a directory")
    final.parent.mkdir(parents=True, exist_ok=True)
    archive = ArchiveDirectory(Path(tempfile.mkdtemp(prefix=f".tmp-{final.name}-", dir=final.parent)))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(archive.path, 0o777 & ~umask)  # mkdtemp makes 0700; give the usual permissions
    try:
        yield archive
    except BaseException:
        if keep_failed:
            (archive.path / "error.txt").write_text(traceback.format_exc())
            failed = final.parent / f".failed-{final.name}"
            shutil.rmtree(failed, ignore_errors=True)
            os.replace(archive.path, failed)
        else:
            shutil.rmtree(archive.path, ignore_errors=True)
        raise
    if final.exists() and on_exists == "replace":
        old = Path(tempfile.mkdtemp(prefix=f".old-{final.name}-", dir=final.parent))
        os.replace(final, old / final.name)
        os.replace(archive.path, final)
        shutil.rmtree(old, ignore_errors=True)
        archive.final = final
    else:
        archive.final = _free_name(final)
        os.replace(archive.path, archive.final)
