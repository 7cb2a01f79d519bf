"""Reading the files a user names: regular files only, bounded in size, sniffed before parsing.

Every reader of a user's file (study, model, measured data, decks) goes through
:func:`read_input_bytes` or :func:`read_input_text` first, so that

* only regular files are read: a folder, a device (``/dev/zero``), a FIFO or a socket is
  refused in one line naming the file (a symbolic link to a regular file is fine);
* a file larger than the input size limit is refused before it is read: the limit is
  :data:`DEFAULT_MAX_INPUT_MB` megabytes, ``NLUPDATE_MAX_INPUT_MB`` changes it (``0``
  lifts it);
* text is decoded as UTF-8 (a byte-order mark is skipped) and refused when it holds NUL
  bytes or is not UTF-8, before any parser sees it;
* binary formats that declare their sizes (parquet, MATLAB) are held to the same limit
  for what they would decode to, checked from the declarations before anything is
  decoded (:func:`check_decoded_size`, :func:`check_parquet_size`): a file of a few
  kilobytes can declare gigabytes of zeros.

:func:`sniff` names the kind of content from its first bytes (parquet, HDF5/MAT v7.3,
MAT v5, universal file, text, binary), so readers can say "this is a parquet file, not a
CSV table" instead of a parser's error.

A run reads each input once: :func:`snapshot` takes the bytes of its files when the run
starts, and within :func:`pinned` every read of those paths — by any reader, in any
thread — gets those bytes, as do the hashes and copies its archive makes
(:func:`pinned_bytes`). A file replaced on disk while the run goes on changes nothing:
what was hashed and archived is what was read.
"""
from __future__ import annotations

import contextlib
import os
import stat
import threading
from pathlib import Path
from typing import Iterable, Iterator, Mapping

#: Default largest input file, in megabytes.
DEFAULT_MAX_INPUT_MB = 512.0
MAX_INPUT_ENV = "NLUPDATE_MAX_INPUT_MB"


class InputFileError(ValueError):
    """A file the user named cannot be read as asked; the message names the file."""


def max_input_bytes() -> int | None:
    """The input size limit in bytes (``None``: no limit), from ``$NLUPDATE_MAX_INPUT_MB``."""
    text = os.environ.get(MAX_INPUT_ENV, "").strip()
    if not text:
        return int(DEFAULT_MAX_INPUT_MB * 1e6)
    try:
        value = float(text)
    except ValueError:
        raise InputFileError(f"{MAX_INPUT_ENV}={text!r}: expected a number of megabytes (0 lifts the limit)") from None
    if not value >= 0:
        raise InputFileError(f"{MAX_INPUT_ENV}={text!r}: expected a number of megabytes ≥ 0 (0 lifts the limit)")
    return None if value == 0 else int(value * 1e6)


def _kind_of_mode(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a pipe (FIFO)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def checked_input(path: str | os.PathLike, what: str = "input file") -> Path:
    """``path`` after checking it is a regular file within the size limit; else
    :class:`InputFileError` (``what`` names the file's role in the message)."""
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise InputFileError(f"{path}: no such file ({what})") from None
    except OSError as error:
        raise InputFileError(f"{path}: cannot be read ({what}: {error.strerror or error})") from None
    if not stat.S_ISREG(info.st_mode):
        raise InputFileError(f"{path}: is {_kind_of_mode(info.st_mode)}; expected a regular file ({what})")
    limit = max_input_bytes()
    if limit is not None and info.st_size > limit:
        raise InputFileError(f"{path}: {info.st_size / 1e6:.0f} MB is more than the input limit of {limit / 1e6:g} MB "
                             f"({what}); set {MAX_INPUT_ENV} to raise it")
    return path


def megabytes(nbytes: float) -> str:
    """``nbytes`` in MB for a message: whole numbers from 10 MB, two digits below."""
    return f"{nbytes / 1e6:.0f}" if nbytes >= 10e6 else f"{nbytes / 1e6:.2g}"


def check_decoded_size(nbytes: int, path: str | os.PathLike, field: str, what: str = "input file") -> None:
    """:class:`InputFileError` when ``field`` (e.g. ``column 'x' declares 10 rows, …``) of
    ``path`` would decode to ``nbytes`` bytes, more than the input limit."""
    limit = max_input_bytes()
    if limit is not None and nbytes > limit:
        raise InputFileError(f"{path}: {field}, more than the input limit of {limit / 1e6:g} MB ({what}); set "
                             f"{MAX_INPUT_ENV} to raise it")


#: Bytes per value of parquet's physical types once decoded (a byte array: at least a pointer).
_PARQUET_WIDTHS = {"BOOLEAN": 1, "INT32": 4, "INT64": 8, "INT96": 12, "FLOAT": 4, "DOUBLE": 8, "BYTE_ARRAY": 8}


def check_parquet_size(data: bytes, path: str | os.PathLike, what: str = "input file") -> None:
    """Hold a parquet file's declared rows × column widths (its footer, read alone) to the
    input limit (:func:`check_decoded_size`), naming its widest column; a footer that
    cannot be read is left to the reader to report."""
    import io

    import pyarrow.parquet as pq

    try:
        metadata = pq.ParquetFile(io.BytesIO(data)).metadata
    except Exception:  # noqa: BLE001 - pyarrow's many errors for a damaged file: the reader reports it
        return
    rows, schema = metadata.num_rows, metadata.schema
    sizes = {}
    for index in range(metadata.num_columns):
        column = schema.column(index)
        width = column.length if column.physical_type == "FIXED_LEN_BYTE_ARRAY" else \
            _PARQUET_WIDTHS.get(column.physical_type, 8)
        sizes[column.path] = rows * max(width or 0, 1)
    if not sizes:
        return
    widest = max(sizes, key=sizes.get)
    total = sum(sizes.values())
    whole = f" ({megabytes(total)} MB for the {len(sizes)} columns)" if len(sizes) > 1 else ""
    check_decoded_size(total, path, f"column '{widest}' declares {rows} rows, {megabytes(sizes[widest])} MB once "
                                    f"decoded{whole}", what)


_PINNED: dict[Path, bytes] = {}
_PIN_COUNT: dict[Path, int] = {}
_PIN_LOCK = threading.Lock()


def snapshot(paths: Iterable[str | os.PathLike]) -> dict[str, bytes]:
    """The bytes of the input files ``paths`` (a folder: every regular file under it that
    is not a link), read now, by resolved path."""
    taken: dict[str, bytes] = {}
    for given in paths:
        path = Path(given)
        files = ([p for p in sorted(path.rglob("*")) if p.is_file() and not p.is_symlink()] if path.is_dir()
                 else [path])
        for file in files:
            taken[str(file.resolve())] = read_input_bytes(file)
    return taken


@contextlib.contextmanager
def pinned(snapshots: Mapping[str, bytes]) -> Iterator[None]:
    """Within the block, reading a path of ``snapshots`` gives its snapshot, in every thread."""
    keys = [Path(p) for p in snapshots]
    with _PIN_LOCK:
        for key in keys:
            _PINNED[key] = snapshots[str(key)]
            _PIN_COUNT[key] = _PIN_COUNT.get(key, 0) + 1
    try:
        yield
    finally:
        with _PIN_LOCK:
            for key in keys:
                _PIN_COUNT[key] -= 1
                if not _PIN_COUNT[key]:
                    del _PIN_COUNT[key], _PINNED[key]


def pinned_bytes(path: str | os.PathLike) -> bytes | None:
    """The snapshot of ``path`` when it is pinned, else None."""
    if not _PINNED:
        return None
    with _PIN_LOCK:
        return _PINNED.get(Path(path).resolve())


def read_input_bytes(path: str | os.PathLike, what: str = "input file") -> bytes:
    """The bytes of a checked input file (:func:`checked_input`) — its snapshot when it is
    :func:`pinned`; never more than the limit, even when the file grows while it is read."""
    taken = pinned_bytes(path)
    if taken is not None:
        return taken
    path = checked_input(path, what)
    limit = max_input_bytes()
    try:
        with open(path, "rb") as stream:
            data = stream.read() if limit is None else stream.read(limit + 1)
    except OSError as error:
        raise InputFileError(f"{path}: cannot be read ({what}: {error.strerror or error})") from None
    if limit is not None and len(data) > limit:
        raise InputFileError(f"{path}: grew past the input limit of {limit / 1e6:g} MB while it was read ({what}); "
                             f"set {MAX_INPUT_ENV} to raise it")
    return data


def sniff(head: bytes) -> str:
    """The kind of content that starts with ``head``: ``"parquet"``, ``"hdf5"`` (also MAT
    v7.3), ``"mat5"``, ``"uff"`` (universal file: a ``-1`` delimiter line first),
    ``"text"`` or ``"binary"``."""
    if head.startswith(b"PAR1"):
        return "parquet"
    if head.startswith(b"\x89HDF\r\n\x1a\n") or head[512:520] == b"\x89HDF\r\n\x1a\n":
        return "hdf5"
    if head.startswith(b"MATLAB 5.0"):
        return "mat5"
    sample = head[:4096]
    if b"\x00" in sample:
        return "binary"
    first = sample.lstrip(b"\xef\xbb\xbf").lstrip(b"\r\n").split(b"\n", 1)[0].strip()
    if first == b"-1":
        return "uff"
    return "text"


def decode_text(data: bytes, path: str | os.PathLike, what: str = "input file") -> str:
    """``data`` as UTF-8 text (a byte-order mark skipped); :class:`InputFileError` naming
    ``path`` when it holds NUL bytes or is not UTF-8."""
    if b"\x00" in data:
        raise InputFileError(f"{path}: holds binary data (NUL bytes); expected a UTF-8 text file ({what})")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise InputFileError(f"{path}: is not UTF-8 text (byte {error.start}: {data[error.start:error.start + 1]!r}); "
                             f"expected a UTF-8 text file ({what})") from None


def read_input_text(path: str | os.PathLike, what: str = "input file") -> str:
    """A checked input file (:func:`checked_input`) read as UTF-8 text (:func:`decode_text`)."""
    return decode_text(read_input_bytes(path, what), path, what)


def parse_toml(text: str, path: str | os.PathLike, error: type[ValueError] = InputFileError) -> dict:
    """TOML ``text`` of the file ``path`` as a dict; ``error`` (a ValueError) naming the file
    when it is not valid TOML or nests arrays or inline tables deeper than Python's parser
    follows (it ended with "maximum recursion depth exceeded" and no file named)."""
    import tomllib

    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as problem:
        raise error(f"{path}: not valid TOML ({problem})") from None
    except RecursionError:
        raise error(f"{path}: arrays or inline tables nested too deeply for the TOML reader (hundreds of levels); "
                    f"expected the tables, numbers, lists and matrices of the format") from None
