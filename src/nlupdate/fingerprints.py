"""Fingerprints: the one way nlupdate names content by a hash.

Cache keys, model fingerprints, archive hashes and point keys all come from here, so two
things have equal fingerprints exactly when they are equal:

* :func:`canonical` turns a value into an exact, order-independent JSON form: floats as
  ``float.hex`` (so 0.1 and 0.1000000000000001 differ), arrays and sparse matrices by
  dtype, shape and a hash of their bytes, dataclasses by their type name and fields,
  mappings sorted by key, tables by :func:`table_hash`;
* :func:`fingerprint` is the SHA-256 of that form (hex; ``length`` cuts it);
* :func:`text_hash`, :func:`file_hash`, :func:`tree_hash` and :func:`table_hash` hash a
  text, a file (as a run read it, :func:`nlupdate.input_files.pinned`), a folder and a
  table's content; :func:`source_hash` the Python sources of modules or packages.
"""
from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import math
import os
from pathlib import Path, PurePath
from typing import Any, Iterable, Mapping

import numpy as np
import pandas as pd
import scipy.sparse

from nlupdate.input_files import pinned_bytes


def _bytes_hash(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def canonical(value: Any) -> Any:
    """A JSON-serialisable, exact and order-independent description of ``value``."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__type__": type(value).__name__,
                **{f.name: canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    if isinstance(value, Mapping):
        return {str(k): canonical(v) for k, v in sorted(value.items(), key=lambda item: str(item[0]))}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    if scipy.sparse.issparse(value):
        coo = scipy.sparse.coo_array(value)
        order = np.lexsort((coo.col, coo.row))
        return {"sparse": list(coo.shape), "row": canonical(np.asarray(coo.row)[order]),
                "col": canonical(np.asarray(coo.col)[order]), "data": canonical(np.asarray(coo.data)[order])}
    if isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value)
        return {"array": str(array.dtype), "shape": list(array.shape), "sha256": _bytes_hash(array.tobytes())}
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value).hex() if math.isfinite(value) else repr(float(value))
    if isinstance(value, (complex, np.complexfloating)):
        return [canonical(value.real), canonical(value.imag)]
    if isinstance(value, pd.DataFrame):
        return {"table": table_hash(value)}
    if isinstance(value, enum.Enum):
        return canonical(value.value)
    if isinstance(value, PurePath):
        return str(value)
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"no canonical form for {type(value).__name__}")


def fingerprint(*parts: Any, length: int | None = None) -> str:
    """SHA-256 (hex) of the canonical form of ``parts``; the first ``length`` digits when given."""
    text = json.dumps(canonical(list(parts)), sort_keys=True, separators=(",", ":"))
    digest = _bytes_hash(text.encode())
    return digest if length is None else digest[:length]


def text_hash(text: str) -> str:
    """SHA-256 of a text (UTF-8)."""
    return _bytes_hash(text.encode())


def table_hash(table: pd.DataFrame) -> str:
    """SHA-256 of a table's content (values, column names and order; index ignored)."""
    digest = hashlib.sha256(",".join(map(str, table.columns)).encode())
    digest.update(pd.util.hash_pandas_object(table, index=False).to_numpy().tobytes())
    return digest.hexdigest()


def file_hash(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (of its snapshot, when a run has pinned it:
    :func:`nlupdate.input_files.pinned`)."""
    taken = pinned_bytes(path)
    if taken is not None:
        return _bytes_hash(taken)
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def tree_hash(folder: str | os.PathLike) -> str:
    """SHA-256 over a folder's files: their relative paths and contents, in sorted order.
    A link is hashed by its content when it points to a file inside the folder, else by
    the text of the link (its target is not read)."""
    digest = hashlib.sha256()
    root = Path(folder)
    inner = root.resolve()
    for path in sorted(p for p in root.rglob("*") if p.is_file() or p.is_symlink()):
        digest.update(path.relative_to(root).as_posix().encode())
        pointee = path.resolve()
        if path.is_symlink() and not (pointee.is_file() and inner in pointee.parents):
            digest.update(b"link:" + os.fsencode(os.readlink(path)))
        else:
            digest.update(file_hash(path).encode())
    return digest.hexdigest()


def source_hash(paths: Iterable[Path]) -> str:
    """SHA-256 of the Python sources under ``paths`` (files or folders), names included."""
    digest = hashlib.sha256()
    for root in sorted(Path(p) for p in paths):
        files = [root] if root.is_file() else sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts)
        for path in files:
            digest.update(str(path.relative_to(root.parent)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def path_hash(path: str | os.PathLike) -> str:
    """:func:`tree_hash` of a folder, :func:`file_hash` of a file."""
    return tree_hash(path) if Path(path).is_dir() else file_hash(path)
