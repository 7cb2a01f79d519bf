"""Run archives under ``results/``: written to a temporary folder, renamed when complete.

Nothing half-written is ever left under its final name: a run that fails leaves its
temporary folder as ``.failed-<name>`` with ``error.txt`` (or removes it).
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


def run_name(prefix: str) -> str:
    """``<prefix>-YYYYmmdd-HHMMSS`` in UTC."""
    return f"{prefix}-{dt.datetime.now(dt.timezone.utc).strftime('%Y%m%d-%H%M%S')}"


@dataclass
class ArchiveDirectory:
    """``path``: where to write now (temporary); ``final``: set once renamed."""

    path: Path
    final: Path | None = None


@contextlib.contextmanager
def atomic_directory(final: str | os.PathLike, keep_failed: bool = True) -> Iterator[ArchiveDirectory]:
    """Write into a temporary directory beside ``final``; rename it to ``final`` on success.

    If ``final`` exists already a numeric suffix is added (``final-1``, …).
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    archive = ArchiveDirectory(Path(tempfile.mkdtemp(prefix=f".tmp-{final.name}-", dir=final.parent)))
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
    target, counter = final, 1
    while target.exists():
        target = final.parent / f"{final.name}-{counter}"
        counter += 1
    os.replace(archive.path, target)
    archive.final = target
