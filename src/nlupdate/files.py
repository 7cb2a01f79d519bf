"""Files and folders written atomically, with the user's permissions, and what killed runs leave.

Everything nlupdate writes is built under a temporary name beside its final one and
renamed when complete, so nothing half-written ever stands under the final name. The
temporary name carries the host and process id of its writer
(``.tmp-<name>-<host>-<pid>-<random>`` for folders, ``.<name>.tmp-<host>-<pid>-<random><suffix>``
for files): the next write into the same folder removes what a process that no longer
runs on this host left behind (a run killed with SIGKILL cannot clean up after itself)
and reports it as an :class:`~nlupdate.notices.NlupdateWarning`; a leftover from another
host is reported, not touched. Files and folders get the permissions the user's umask
gives (``mkstemp``/``mkdtemp`` alone would make them private).
"""
from __future__ import annotations

import contextlib
import datetime as dt
import errno
import json
import os
import re
import secrets
import shutil
import socket
import stat
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from nlupdate.input_files import pinned_bytes
from nlupdate.notices import NlupdateWarning

ON_EXISTS = ("suffix", "replace", "error")

#: This host's name as it appears in temporary names.
HOST = re.sub(r"[^A-Za-z0-9_.]", "_", socket.gethostname()) or "host"
_LEFTOVER = re.compile(r"^\.(?:tmp-.+|.+\.tmp)-(?P<host>[A-Za-z0-9_.]+)-(?P<pid>\d+)-[0-9a-f]{8}(?:\.[^.]*)?$")


#: The longest name nlupdate gives a folder from user input (a study name).
MAX_NAME = 100


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be one folder name nlupdate writes (None when it can): it must
    be one path component — printable, at most :data:`MAX_NAME` characters, no ``/`` or
    ``\\``, not starting with ``.`` (hidden and temporary names are nlupdate's own)."""
    if not isinstance(name, str) or not name.strip():
        return "an empty name"
    if len(name) > MAX_NAME:
        return f"{len(name)} characters (at most {MAX_NAME})"
    if "/" in name or "\\" in name:
        return "a path, not one name (it holds '/' or '\\')"
    if name.startswith("."):
        return "a name starting with '.'"
    if not name.isprintable():
        return "unprintable characters"
    return None


def inside(root: str | os.PathLike, path: str | os.PathLike) -> Path:
    """``path`` after checking that it resolves inside ``root`` (symbolic links followed);
    ``ValueError`` naming both otherwise."""
    root_resolved, resolved = Path(root).resolve(), Path(path).resolve()
    if resolved != root_resolved and root_resolved not in resolved.parents:
        raise ValueError(f"{path} is outside {root}")
    return Path(path)


def copy_private(source: str | os.PathLike, target: str | os.PathLike) -> None:
    """Copy the file ``source`` to ``target`` with permissions never wider than the
    source's (nor than the umask allows): a 0600 file stays 0600. A file a run has pinned
    is copied as the run read it (:func:`nlupdate.input_files.pinned`)."""
    source, target = Path(source), Path(target)
    mode = stat.S_IMODE(source.stat().st_mode) & (0o666 & ~_umask())
    taken = pinned_bytes(source)
    descriptor = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(descriptor, "wb") as out:
        if taken is not None:  # what the run read, not what the file holds now
            out.write(taken)
        else:
            with open(source, "rb") as stream:
                shutil.copyfileobj(stream, out, 1 << 20)
    os.chmod(target, mode)


def run_name(prefix: str) -> str:
    """``<prefix>-YYYYmmdd-HHMMSS`` in UTC."""
    return f"{prefix}-{dt.datetime.now(dt.timezone.utc).strftime('%Y%m%d-%H%M%S')}"


def _tag() -> str:
    return f"{HOST}-{os.getpid()}-{secrets.token_hex(4)}"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def temporary_writer(name: str) -> tuple[str, int] | None:
    """(host, pid) of the writer of a temporary file or folder named ``name``, or None
    when ``name`` is not a temporary name of this module."""
    match = _LEFTOVER.match(name)
    return None if match is None else (match["host"], int(match["pid"]))


def writer_alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this host."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def process_running(pid: int) -> bool:
    """Whether process ``pid`` runs on this host and has not ended: a zombie (ended, not yet
    waited for by its parent) runs nothing (read from /proc where there is one)."""
    if not writer_alive(pid):
        return False
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):  # no /proc here: the signal check above is all there is
        return True


def clean_leftovers(folder: str | os.PathLike) -> list[Path]:
    """Remove the temporary outputs of dead writers on this host in ``folder``; returns them.

    Each removal, and each leftover of another host, is reported as a warning.
    """
    folder = Path(folder)
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for entry in folder.iterdir():
        writer = temporary_writer(entry.name)
        if writer is None:
            continue
        host, pid = writer
        if host != HOST:
            warnings.warn(f"{entry} is the unfinished output of a run on host {host!r} (process {pid}); "
                          f"remove it once that run is over", NlupdateWarning, stacklevel=2)
            continue
        if writer_alive(pid):
            continue  # a run in progress
        if entry.is_dir():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
        warnings.warn(f"removed {entry}, the unfinished output of an interrupted run (process {pid})",
                      NlupdateWarning, stacklevel=2)
    return removed


@contextlib.contextmanager
def atomic_file(final: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``final`` (same suffix); rename it to ``final`` on success.

    An existing ``final`` is replaced. On failure (or Ctrl-C) the temporary file is removed.
    """
    final = Path(final)
    clean_leftovers(final.parent)
    temporary = final.parent / f".{final.name}.tmp-{_tag()}{final.suffix}"
    try:
        yield temporary
        if temporary.exists():
            os.chmod(temporary, 0o666 & ~_umask())
        os.replace(temporary, final)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_bytes_atomic(final: str | os.PathLike, content: bytes) -> Path:
    """Write ``content`` to ``final`` through a temporary file beside it and one rename.

    A reader sees the old file or the new one, never a part of either; two writers at
    once leave one of the two contents whole; a writer killed mid-write leaves only its
    temporary file (``.<name>.tmp-<host>-<pid>-<random><suffix>``, which
    :func:`clean_leftovers` removes later), never a truncated ``final``. Unlike
    :func:`atomic_file` it does not scan the folder for leftovers (it is meant for
    many small writes, e.g. a result cache). Returns ``final``.
    """
    final = Path(final)
    temporary = final.parent / f".{final.name}.tmp-{_tag()}{final.suffix}"
    try:
        with open(temporary, "xb") as stream:
            stream.write(content)
        os.chmod(temporary, 0o666 & ~_umask())
        os.replace(temporary, final)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return final


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


#: errno of a rename whose target appeared meanwhile (Linux: ENOTEMPTY; other systems: EEXIST).
_TAKEN = {errno.EEXIST, errno.ENOTEMPTY}
_RENAME_ATTEMPTS = 1000


def _rename_to_free_name(folder: Path, final: Path) -> Path:
    """Rename ``folder`` to ``final`` or the first free ``final-N``; returns the name it got.

    Another process may take the free name between the check and the rename (two runs of
    one study finishing in the same second): the rename then fails (a directory is never
    renamed onto a non-empty one) and the next free name is tried. A complete archive is
    never empty, so no one's archive can be replaced.
    """
    for _ in range(_RENAME_ATTEMPTS):
        target = _free_name(final)
        try:
            os.rename(folder, target)
        except OSError as error:
            if error.errno in _TAKEN or isinstance(error, FileExistsError):
                continue
            raise
        return target
    raise FileExistsError(f"could not find a free name for {final} after {_RENAME_ATTEMPTS} attempts")


#: The file that marks a folder as an output nlupdate wrote (and lists what it wrote there).
#: A folder without it is never replaced, whatever files it holds.
OUTPUT_MARKER = ".nlupdate-output.json"


class NotAnOutputError(FileExistsError):
    """A folder that nlupdate did not write (or that holds files it did not write) would be replaced."""


def _entries(folder: Path) -> list[str]:
    """Every file and folder under ``folder``, as relative POSIX paths (links not followed)."""
    return sorted(path.relative_to(folder).as_posix() for path in folder.rglob("*"))


def _mark_output(folder: Path, kind: str | None) -> None:
    entries = _entries(folder)
    marker = {"written_by": "nlupdate", "kind": kind, "entries": entries}
    (folder / OUTPUT_MARKER).write_text(json.dumps(marker, indent=1) + "\n")


def _listing(names: list[str], limit: int = 4) -> str:
    shown = ", ".join(names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def check_replaceable(folder: str | os.PathLike, kind: str | None) -> None:
    """:class:`NotAnOutputError` unless ``folder`` is empty or an output of ``kind`` that
    nlupdate wrote and that holds nothing else: its :data:`OUTPUT_MARKER` lists every
    entry, at any depth."""
    folder = Path(folder)
    present = sorted(entry.name for entry in folder.iterdir())
    if not present:
        return
    what = f"an nlupdate {kind} output" if kind else "an nlupdate output"
    marker_path = folder / OUTPUT_MARKER
    if marker_path.is_file():
        try:
            marker = json.loads(marker_path.read_text())
            written, marked_kind = set(marker["entries"]), marker.get("kind")
        except (ValueError, KeyError, TypeError, OSError):
            raise NotAnOutputError(f"{folder}: its {OUTPUT_MARKER} is damaged; not replaced (remove the folder "
                                   f"yourself or choose another)") from None
        if kind is not None and marked_kind != kind:
            raise NotAnOutputError(f"{folder}: is an nlupdate {marked_kind} output, not {what}; not replaced")
        foreign = [name for name in _entries(folder) if name not in written and name != OUTPUT_MARKER]
        if foreign:
            raise NotAnOutputError(f"{folder}: holds files nlupdate did not write there ({_listing(foreign)}); "
                                   f"not replaced")
        return
    raise NotAnOutputError(f"{folder}: is not {what} (it holds {_listing(present)}); --overwrite replaces only "
                           f"a folder nlupdate wrote; choose a new or empty folder")


@contextlib.contextmanager
def atomic_directory(final: str | os.PathLike, on_exists: str = "suffix",
                     kind: str | None = None) -> Iterator[ArchiveDirectory]:
    """Write into a temporary directory beside ``final``; rename it to ``final`` on success.

    The folder is marked as an nlupdate output of ``kind`` (:data:`OUTPUT_MARKER`, listing
    what was written). ``on_exists`` says what happens when ``final`` exists:

    * ``"suffix"`` writes ``final-1``, ``final-2``, … instead;
    * ``"replace"`` swaps the new folder in — only over an empty folder or an output of
      ``kind`` nlupdate wrote (:func:`check_replaceable`, checked before the work and again
      at the swap; the old one is removed only after the new one is in place);
    * ``"error"`` refuses before any work; when another run writes ``final`` meanwhile,
      this output is kept under ``final-1`` (…) and a warning says so.

    On failure (or Ctrl-C) the temporary folder is removed.
    """
    if on_exists not in ON_EXISTS:
        raise ValueError(f"on_exists must be one of {ON_EXISTS}, got {on_exists!r}")
    final = Path(final)
    if final.exists() and not final.is_dir():
        raise ValueError(f"{final} exists and is not a directory")
    if final.exists() and on_exists == "error":
        raise FileExistsError(f"{final} exists: choose another output folder or allow replacing it")
    if final.exists() and on_exists == "replace":
        check_replaceable(final, kind)
    final.parent.mkdir(parents=True, exist_ok=True)
    clean_leftovers(final.parent)
    archive = ArchiveDirectory(final.parent / f".tmp-{final.name}-{_tag()}")
    archive.path.mkdir(mode=0o777)  # the umask applies, as for any folder the user makes
    try:
        yield archive
        _mark_output(archive.path, kind)
        if final.exists() and on_exists == "replace":
            try:
                check_replaceable(final, kind)
            except NotAnOutputError as error:
                archive.final = _rename_to_free_name(archive.path, final)
                warnings.warn(f"{error} (it changed while this run was writing); this output is {archive.final}",
                              NlupdateWarning, stacklevel=3)
                return
            old = final.parent / f".tmp-{final.name}.old-{_tag()}"
            os.replace(final, old)
            os.replace(archive.path, final)
            shutil.rmtree(old, ignore_errors=True)
            archive.final = final
        else:
            archive.final = _rename_to_free_name(archive.path, final)
            if on_exists == "error" and archive.final != final:
                warnings.warn(f"{final} was written by another run while this one was writing; this output is "
                              f"{archive.final}", NlupdateWarning, stacklevel=3)
    except OSError as error:
        shutil.rmtree(archive.path, ignore_errors=True)
        if error.filename is None:  # e.g. a full disk seen by a writer that does not say where
            raise OSError(error.errno, f"{error.strerror or error} while writing {final} (nothing of it was kept)") \
                from error
        raise
    except BaseException:
        shutil.rmtree(archive.path, ignore_errors=True)
        raise
