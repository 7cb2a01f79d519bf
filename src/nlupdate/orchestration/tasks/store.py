"""The task-result store: records that are data, signed, and written atomically.

Whoever can write a cache folder must not be able to make a run execute code or use a
number it did not compute (a shared ``NLUPDATE_CACHE_DIR``, Dask workers, a scheduled
run's cache). So every record

* holds its result as data (:mod:`nlupdate.orchestration.tasks.records`: JSON and ``.npz`` arrays read
  with ``allow_pickle=False``, through :class:`DataSerializer`), never a pickle;
* is signed: ``nlupdate-record 1`` and an HMAC-SHA256 under the user's cache secret
  (:func:`nlupdate.user_config.cache_secret`, a 0600 file) of the record's key and
  content. A record is verified before any byte of it is parsed; one that is unsigned,
  edited, copied from another key, written by another serializer or of another schema is
  named in one line (an :class:`~nlupdate.notices.NlupdateWarning`) and treated as absent,
  so the task is computed again and the record rewritten;
* is written beside its final name and renamed into place: a reader sees the old record
  or the new one, never a part (Prefect's own ``LocalFileSystem`` truncates and rewrites
  in place, which made concurrent readers fail and left truncated records after kills).

Signing and verifying (and reading a result without Prefect) are in
:mod:`nlupdate.orchestration.tasks.signing`. Records live in ``<cache>/records-v1``;
records of earlier versions (pickles) are never read. A disk that fills up stops caching with one warning, not silently.
"""
from __future__ import annotations

import base64
import errno
import functools
import threading
import warnings
from pathlib import Path
from typing import Any

from prefect.filesystems import LocalFileSystem
from prefect.serializers import Serializer
from pydantic import Field

from nlupdate.files import clean_leftovers, write_bytes_atomic
from nlupdate.notices import NlupdateWarning
from nlupdate.orchestration.tasks import records
from nlupdate.orchestration.tasks.signing import (MAGIC, RECORDS_FOLDER, SERIALIZER_TYPE, records_schema_ok, sign,
                                                  signed_payload, verified)

__all__ = ["MAGIC", "RECORDS_FOLDER", "SERIALIZER_TYPE", "DataSerializer", "SignedLocalFileSystem", "record_store",
           "records_schema_ok", "sign", "signed_payload", "verified"]


class DataSerializer(Serializer):
    """Prefect serializer writing results as data (:mod:`nlupdate.orchestration.tasks.records`)."""

    type: str = Field(default=SERIALIZER_TYPE, frozen=True)

    def dumps(self, obj: Any) -> bytes:
        return base64.b64encode(records.dumps(obj))  # Prefect keeps it in a JSON string

    def loads(self, blob: bytes) -> Any:
        return records.loads(base64.b64decode(blob, validate=True))


_REPORTED: set[str] = set()
_REPORTED_LOCK = threading.Lock()


def _warn_once(subject: str, message: str) -> None:
    with _REPORTED_LOCK:
        if subject in _REPORTED:
            return
        _REPORTED.add(subject)
    warnings.warn(message, NlupdateWarning, stacklevel=3)


class SignedLocalFileSystem(LocalFileSystem):
    """Prefect's local result storage with signed, atomic records (see the module docstring).

    The first write into a folder by this process removes (and reports) the temporary
    files that killed runs on this host left there (:func:`nlupdate.files.clean_leftovers`)."""

    _block_type_name = "nlupdate signed local file system"
    _block_type_slug = "nlupdate-signed-local-file-system"

    def _key(self, resolved: Path) -> str:
        return resolved.name

    def _resolve_path(self, path: str | None) -> Path:
        """Prefect's resolution (the folder for ``None`` or ``""``, else ``path`` in it, never
        outside it), with the folder resolved once per process: a record's path is one file
        name in the folder, so unless that name is a symbolic link (then resolved in full,
        as Prefect does, and refused outside the folder) it is the resolved folder joined
        with the name — one ``lstat`` instead of Prefect's one per path component (about
        0.15 ms a call, several per task run and FE point)."""
        folder = _resolved_folder(self.basepath)
        if not path:
            return folder
        candidate = Path(path)
        if not candidate.is_absolute() and not path.startswith("~"):
            candidate = folder / candidate
        if candidate.parent == folder and candidate.name not in (".", "..") and not candidate.is_symlink():
            return candidate
        return super()._resolve_path(path)

    def read_path(self, path: str, **_: Any) -> bytes | None:  # Prefect passes _sync=True
        resolved = Path(self._resolve_path(path))
        try:
            content = resolved.read_bytes()
        except FileNotFoundError:
            return None
        try:
            payload = verified(self._key(resolved), content)
            records_schema_ok(payload)
        except ValueError as error:
            _warn_once(str(resolved), f"cache record {resolved}: {error}; not used, the result is computed again")
            return None
        return payload

    async def aread_path(self, path: str) -> bytes | None:
        return self.read_path(path)

    def write_path(self, path: str, content: bytes, **_: Any) -> str:  # Prefect passes _sync=True
        resolved = Path(self._resolve_path(path))
        try:
            resolved.parent.mkdir(exist_ok=True, parents=True)
            if resolved.exists() and not resolved.is_file():
                raise ValueError(f"Path {resolved} already exists and is not a file.")
            _clean_once(resolved.parent)
            write_bytes_atomic(resolved, sign(self._key(resolved), content))
        except OSError as error:
            if error.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES):
                _warn_once(f"write {resolved.parent}", f"cache folder {resolved.parent}: cannot write records "
                           f"({error.strerror}); results from now on are not cached")
                return str(resolved)
            raise
        return str(resolved)

    async def awrite_path(self, path: str, content: bytes) -> str:
        return self.write_path(path, content)


@functools.lru_cache(maxsize=None)
def _resolved_folder(basepath: str) -> Path:
    return Path(basepath).expanduser().resolve()


_CLEANED: set[Path] = set()
_CLEANED_LOCK = threading.Lock()


def _clean_once(folder: Path) -> None:
    with _CLEANED_LOCK:
        if folder in _CLEANED:
            return
        _CLEANED.add(folder)
    clean_leftovers(folder)


def record_store(cache_folder: Path) -> SignedLocalFileSystem:
    """The signed store of the cache folder ``cache_folder``."""
    return SignedLocalFileSystem(basepath=str(Path(cache_folder) / RECORDS_FOLDER))
