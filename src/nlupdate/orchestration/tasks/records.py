"""Task results as data: a codec that never runs code from what it reads.

A cached result is written as an ``.npz`` archive (numpy's zip of ``.npy`` arrays, read
with ``allow_pickle=False``): one member ``structure`` holds the JSON description of the
value and every array is a member of its own. The JSON names the schema (:data:`SCHEMA`) and, for objects, their class as
``module:qualname``; reading rebuilds only

* JSON scalars, bytes, lists, tuples, dicts (any keys that are themselves data), complex
  numbers, non-finite floats, paths, numpy scalars and arrays (no ``object`` dtype),
  pandas tables (column by column: numeric columns as arrays, others as lists of data);
* instances of classes defined in the ``nlupdate`` package (dataclasses and plain
  classes), restored attribute by attribute without calling their constructor.

Nothing else can be named, so a record cannot make the reader import a foreign module
or call a function. A value that holds anything else (a function, an open file) cannot be
written: :class:`RecordError` says which part.
"""
from __future__ import annotations

import dataclasses
import importlib
import io
import json
import math
import threading
import zipfile
from pathlib import Path, PurePath
from typing import Any

import numpy as np
import pandas as pd

#: One record read at a time in a process. numpy parses each array's header with
#: ast.literal_eval, and CPython 3.11's AST construction is not safe from threads
#: (python/cpython#106905): two cached tasks read on the flow's threads under load failed
#: with "SystemError: AST constructor recursion depth mismatch". Reads are milliseconds.
_ARRAY_READS = threading.Lock()

#: Version of the record layout; a record of another version is recomputed.
SCHEMA = 1
#: Only classes from these packages are rebuilt.
TRUSTED_PACKAGES = ("nlupdate",)


#: pandas' own column dtypes a record keeps (others are stored as plain lists).
PANDAS_DTYPES = frozenset({"Int8", "Int16", "Int32", "Int64", "UInt8", "UInt16", "UInt32", "UInt64", "Float32",
                           "Float64", "boolean", "string"})


class RecordError(ValueError):
    """A value cannot be written as a record, or bytes are not a valid record."""


def _class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _trusted_class(name: str) -> type:
    module_name, _, qualname = name.partition(":")
    if not module_name or not qualname or module_name.split(".")[0] not in TRUSTED_PACKAGES:
        raise RecordError(f"class {name!r} is not an nlupdate class")
    try:
        value: Any = importlib.import_module(module_name)
    except ImportError:
        raise RecordError(f"class {name!r}: no such module") from None
    for part in qualname.split("."):
        if part.startswith("__") or not hasattr(value, part):
            raise RecordError(f"class {name!r}: not found")
        value = getattr(value, part)
    if not isinstance(value, type) or value.__module__ != module_name:
        raise RecordError(f"{name!r} is not a class of {module_name}")
    return value


class _Writer:
    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}

    def _array(self, array: np.ndarray) -> str:
        name = f"a{len(self.arrays)}"
        self.arrays[name] = array
        return name

    def encode(self, value: Any, where: str) -> Any:
        if value is None or isinstance(value, (bool, str)):
            return value
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float):
            return value if math.isfinite(value) else {"float": repr(value)}
        if isinstance(value, bytes):
            return {"bytes": self._array(np.frombuffer(value, dtype=np.uint8))}
        if isinstance(value, complex):
            return {"complex": [self.encode(value.real, where), self.encode(value.imag, where)]}
        if isinstance(value, np.generic):
            if value.dtype.kind == "O":
                raise RecordError(f"{where}: numpy object scalar")
            return {"scalar": self._array(np.asarray(value))}
        if isinstance(value, np.ndarray):
            if value.dtype.kind in "OV":
                raise RecordError(f"{where}: numpy array of dtype {value.dtype}")
            return {"array": self._array(value)}
        if isinstance(value, pd.DataFrame):
            if not value.columns.is_unique:
                raise RecordError(f"{where}: table with repeated column names")
            return {"table": {"columns": [self.encode(c, f"{where} column") for c in value.columns],
                              "data": [self._column(value[c], f"{where}[{c!r}]") for c in value.columns],
                              "index": self._index(value.index, f"{where} index")}}
        if isinstance(value, list):
            return [self.encode(v, f"{where}[{i}]") for i, v in enumerate(value)]
        if isinstance(value, tuple) and not hasattr(value, "_fields"):
            return {"tuple": [self.encode(v, f"{where}[{i}]") for i, v in enumerate(value)]}
        if isinstance(value, dict) and type(value) is dict:
            return {"dict": [[self.encode(k, f"{where} key"), self.encode(v, f"{where}[{k!r}]")]
                             for k, v in value.items()]}
        if isinstance(value, PurePath):
            return {"path": str(value)}
        return self._object(value, where)

    def _column(self, column: pd.Series | pd.Index, where: str) -> Any:
        """A table column as an array member (numbers, booleans, times) or a list, with its
        dtype when it is one of pandas' own (nullable integers, strings, …)."""
        if isinstance(column.dtype, np.dtype) and column.dtype.kind in "biufcmM":
            return {"array": self._array(column.to_numpy())}
        dtype = str(column.dtype)
        encoded = {"values": [self.encode(None if v is pd.NA else v, where) for v in column.tolist()]}
        return {**encoded, "dtype": dtype} if dtype in PANDAS_DTYPES else encoded

    def _index(self, index: pd.Index, where: str) -> Any:
        if isinstance(index, pd.RangeIndex):
            return {"range": [index.start, index.stop, index.step]}
        if isinstance(index, pd.MultiIndex):
            raise RecordError(f"{where}: multi-level index")
        return self._column(index, where)

    def _object(self, value: Any, where: str) -> Any:
        cls = type(value)
        name = _class_name(cls)
        if cls.__module__.split(".")[0] not in TRUSTED_PACKAGES or callable(value) and not dataclasses.is_dataclass(value):
            raise RecordError(f"{where}: a {cls.__module__}.{cls.__qualname__} cannot be stored as data")
        if isinstance(value, tuple):  # a NamedTuple of the package
            return {"namedtuple": name, "items": [self.encode(v, f"{where}[{i}]") for i, v in enumerate(value)]}
        try:
            attributes = vars(value)
        except TypeError:
            raise RecordError(f"{where}: a {name} has no attribute dictionary") from None
        return {"object": name, "attributes": {k: self.encode(v, f"{where}.{k}") for k, v in attributes.items()}}


class _Reader:
    def __init__(self, arrays: Any) -> None:
        self.arrays = arrays

    def _array(self, name: Any) -> np.ndarray:
        if not isinstance(name, str) or name not in self.arrays.files:
            raise RecordError(f"array member {name!r} is missing")
        return self.arrays[name]

    def _column(self, value: Any) -> Any:
        if "array" in value:
            return self._array(value["array"])
        values = [self.decode(v) for v in value["values"]]
        dtype = value.get("dtype")
        if dtype is None:
            return values
        if dtype not in PANDAS_DTYPES:
            raise RecordError(f"unknown column dtype {dtype!r}")
        return pd.array(values, dtype=dtype)

    def decode(self, value: Any) -> Any:
        if value is None or isinstance(value, (bool, str, int, float)):
            return value
        if isinstance(value, list):
            return [self.decode(v) for v in value]
        if not isinstance(value, dict) or not 1 <= len(value) <= 2:
            raise RecordError(f"unexpected element {str(value)[:60]!r}")
        (kind, payload), *rest = value.items()
        if kind == "float" and payload in ("nan", "inf", "-inf"):
            return float(payload)
        if kind == "complex":
            real, imag = (self.decode(v) for v in payload)
            return complex(real, imag)
        if kind == "bytes":
            return self._array(payload).tobytes()
        if kind == "scalar":
            return self._array(payload)[()]
        if kind == "array":
            return self._array(payload)
        if kind == "table":
            columns = [self.decode(c) for c in payload["columns"]]
            data = [self._column(c) for c in payload["data"]]
            index = payload["index"]
            index = pd.RangeIndex(*index["range"]) if "range" in index else pd.Index(self._column(index))
            return pd.DataFrame(dict(zip(range(len(columns)), data)), index=index).set_axis(columns, axis=1)
        if kind == "tuple":
            return tuple(self.decode(v) for v in payload)
        if kind == "dict":
            return {self.decode(k): self.decode(v) for k, v in payload}
        if kind == "path":
            return Path(payload)
        if kind == "namedtuple":
            return _trusted_class(payload)(*(self.decode(v) for v in rest[0][1]))
        if kind == "object" and rest and rest[0][0] == "attributes":
            instance = object.__new__(_trusted_class(payload))
            instance.__dict__.update({k: self.decode(v) for k, v in rest[0][1].items()})
            return instance
        raise RecordError(f"unknown element kind {kind!r}")


def dumps(value: Any) -> bytes:
    """``value`` as record bytes (see the module docstring); :class:`RecordError` naming
    the part that cannot be stored as data."""
    writer = _Writer()
    structure = {"schema": SCHEMA, "value": writer.encode(value, "result")}
    buffer = io.BytesIO()
    members = {"structure": np.frombuffer(json.dumps(structure, allow_nan=False).encode(), dtype=np.uint8),
               **writer.arrays}
    np.savez(buffer, **members)
    return buffer.getvalue()


def _open(blob: bytes) -> tuple[Any, dict]:
    """The arrays and the structure of record bytes, its schema checked."""
    try:
        arrays = np.load(io.BytesIO(blob), allow_pickle=False)
        structure = json.loads(arrays["structure"].tobytes())
    except (ValueError, OSError, KeyError, zipfile.BadZipFile, json.JSONDecodeError, UnicodeDecodeError) as error:
        raise RecordError(f"not a result record ({type(error).__name__}: {error})") from None
    if not isinstance(structure, dict) or structure.get("schema") != SCHEMA:
        found = structure.get("schema") if isinstance(structure, dict) else None
        raise RecordError(f"record schema {found!r}, this version reads schema {SCHEMA}")
    return arrays, structure


def check(blob: bytes) -> None:
    """:class:`RecordError` unless ``blob`` is a record of schema :data:`SCHEMA` (reads
    only its structure member)."""
    _open(blob)


def loads(blob: bytes) -> Any:
    """The value of record bytes; :class:`RecordError` when they are not a record of
    schema :data:`SCHEMA` or name anything but data and nlupdate classes."""
    with _ARRAY_READS:
        arrays, structure = _open(blob)
        try:
            return _Reader(arrays).decode(structure.get("value"))
        except (TypeError, ValueError, AttributeError) as error:
            if isinstance(error, RecordError):
                raise
            raise RecordError(f"malformed record ({type(error).__name__}: {error})") from None

