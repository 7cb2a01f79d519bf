"""The files of a MAPDL batch run: its names, the errors MAPDL writes, the scratch files.

The run: ``<exe> -b -i in.inp -o out.out -j job -np <N>`` in a fresh directory (see
:mod:`nlupdate.fe.adapters.runner`); a non-zero exit or any failed check of :mod:`nlupdate.fe.adapters.mapdl` is an
:class:`AdapterError` naming the run directory and the file to read. After a successful
run the large binary files of the job (``job*.rst``, ``.full``, ``.mode``, ``.esav``,
``.emat``, ``.db``, ``.page``, ``.osav``, ``.ldhi``, ``.LNxx``, ``.rNNN``, … see
:data:`SCRATCH_FILE`) are deleted unless ``keep_files=True``; the input deck, ``out.out``,
the ``.err``/``.log`` files, the modal table and the launcher log stay. Failed runs keep
everything.

``*** ERROR ***`` is looked for in ``out.out`` **and** in ``job.err`` (and the
``job<N>.err`` files of distributed runs): MAPDL writes every error to the ``.err`` file,
also when a ``/OUTPUT`` in the deck hides it from ``out.out``. The error names the file,
the line and quotes the message.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from nlupdate.fe.adapters.runner import log_lines

INPUT_NAME = "in.inp"
OUTPUT_NAME = "out.out"
JOB_NAME = "job"
ERROR_MARKER = "*** ERROR ***"
#: Files of a job deleted after a successful run unless ``keep_files``: the result,
#: matrix, element, database, page, restart and scratch files, also the ``job<N>.*``
#: files of distributed runs.
SCRATCH_FILE = re.compile(
    rf"{JOB_NAME}\d*\.(rst|rstp|rth|full|mode|lmode|esav|emat|db|dbb|page|osav|ldhi|rdb|mlv|sub|dsub|mnf|modesym|lock|ln\d\d|r\d\d\d)",
    re.IGNORECASE,
)
_ERROR_FILE = re.compile(rf"{JOB_NAME}\d*\.err", re.IGNORECASE)
#: The most errors :func:`find_errors` reports from one file.
MAX_ERRORS = 20


def find_errors(path: Path) -> list[tuple[int, str]]:
    """``(line, message)`` of the ``*** ERROR ***`` in a MAPDL output or error file (the
    first :data:`MAX_ERRORS`), scanned line by line with every line cut to a bounded length.

    The message is the marker line without its ``CP = … TIME= …`` stamp, followed by the
    next lines up to a blank line or the next ``***`` marker (at most 4 lines).
    """
    found: list[tuple[int, str]] = []
    collecting: list[str] | None = None
    try:
        for number, line in enumerate(log_lines(path), start=1):
            if collecting is not None:
                if not line.strip() or line.strip().startswith("***") or len(collecting) == 5:
                    found[-1] = (found[-1][0], " ".join(collecting) or "(no message text)")
                    collecting = None
                else:
                    collecting.append(line.strip())
                    continue
            if ERROR_MARKER in line and len(found) < MAX_ERRORS:
                head = re.sub(r"CP\s*=\s*\S+|TIME\s*=\s*\S+", "", line.split(ERROR_MARKER, 1)[1]).strip()
                collecting = [head] if head else []
                found.append((number, ""))
    except OSError:
        return found
    if collecting is not None:
        found[-1] = (found[-1][0], " ".join(collecting) or "(no message text)")
    return found

def error_files(run_dir: Path) -> list[Path]:
    """``out.out``, then ``job.err`` and the ``job<N>.err`` files of distributed runs."""
    errs = sorted(p for p in run_dir.iterdir() if _ERROR_FILE.fullmatch(p.name)) if run_dir.is_dir() else []
    return [run_dir / OUTPUT_NAME, *errs]

@dataclass(frozen=True)
class MapdlError:
    """The first ``*** ERROR ***`` of a run: file, line, message, and how many in all."""

    path: Path
    line: int
    message: str
    total: int
    files: tuple[str, ...]

    def describe(self, after_location: str = "") -> str:
        """``*** ERROR *** in job.err (line 3)<after_location>: 'message'`` (+ how many more)."""
        more = f" (and {self.total - 1} more error message(s) in {', '.join(self.files)})" if self.total > 1 else ""
        return f"{ERROR_MARKER} in {self.path.name} (line {self.line}){after_location}: {self.message!r}{more}"

def first_error(run_dir: Path) -> MapdlError | None:
    """The first ``*** ERROR ***`` in ``out.out``, ``job.err`` or ``job<N>.err``, or None."""
    found = [(path, line, message) for path in error_files(run_dir) for line, message in find_errors(path)]
    if not found:
        return None
    path, line, message = found[0]
    files = tuple(dict.fromkeys(p.name for p, _, _ in found))
    return MapdlError(path, line, message, len(found), files)

def remove_scratch_files(run_dir: Path) -> list[str]:
    """Delete the job's large files (:data:`SCRATCH_FILE`); return their names.

    A file that cannot be deleted (e.g. still locked on Windows) is left in place."""
    removed = []
    for path in sorted(run_dir.iterdir()):
        if path.is_file() and SCRATCH_FILE.fullmatch(path.name):
            try:
                path.unlink()
            except OSError:
                continue
            removed.append(path.name)
    return removed
