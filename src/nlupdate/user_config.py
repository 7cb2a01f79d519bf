"""The user's own nlupdate folder: secrets and registrations that other users must not change.

``$NLUPDATE_CONFIG_DIR``, else ``$XDG_CONFIG_HOME/nlupdate``, else ``~/.config/nlupdate``;
created private (0700). It holds

* ``cache-secret`` — the key that signs task-cache records (:func:`cache_secret`);
  ``$NLUPDATE_CACHE_SECRET_FILE`` names another file instead, e.g. one shared on purpose
  by the machines of a Dask cluster that share a cache;
* ``schedules/`` — the studies registered with ``nlupdate schedule`` (what ``nlupdate
  serve`` is allowed to run).

The folder must belong to the user and be writable by nobody else (refused in one line
otherwise: whoever can write there can swap the secret or the registrations). A secret
file must be a regular file (a FIFO or device is refused without waiting on it),
belong to the user and be readable by nobody else (0600 or stricter); otherwise it is
refused in one line, because anyone who can read it can forge records.
"""
from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

CONFIG_ENV = "NLUPDATE_CONFIG_DIR"
SECRET_ENV = "NLUPDATE_CACHE_SECRET_FILE"
SECRET_BYTES = 32


class UserConfigError(RuntimeError):
    """The user's nlupdate folder or a secret in it is unusable; the message says why."""


def config_dir() -> Path:
    """The user's nlupdate folder (created 0700 when missing)."""
    given = os.environ.get(CONFIG_ENV)
    if given:
        folder = Path(given)
    else:
        base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
        folder = Path(base) / "nlupdate"
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        info = folder.stat()
    except OSError as error:
        raise UserConfigError(f"{folder}: cannot create the nlupdate settings folder ({error.strerror or error}); "
                              f"set {CONFIG_ENV} to a folder of yours") from None
    _check_own_folder(folder, info)
    return folder


def _check_own_folder(folder: Path, info: os.stat_result) -> None:
    """Refuse a settings folder another user owns or may write to: whoever can write there
    can put their own cache secret or schedule registrations in place of the user's."""
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        raise UserConfigError(f"{folder}: the nlupdate settings folder belongs to another user (uid {info.st_uid}); "
                              f"set {CONFIG_ENV} to a folder of yours")
    if info.st_mode & 0o022:
        raise UserConfigError(f"{folder}: the nlupdate settings folder is writable by others (mode "
                              f"{stat.S_IMODE(info.st_mode):04o}): they could replace its cache secret or schedules; "
                              f"run `chmod 700 {folder}`")


def _check_private(path: Path, info: os.stat_result) -> None:
    if not stat.S_ISREG(info.st_mode):
        raise UserConfigError(f"{path}: the cache secret must be a regular file")
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        raise UserConfigError(f"{path}: the cache secret belongs to another user (uid {info.st_uid}); "
                              f"use a secret of your own")
    if info.st_mode & 0o077:
        raise UserConfigError(f"{path}: the cache secret is readable or writable by others "
                              f"(mode {stat.S_IMODE(info.st_mode):04o}); run `chmod 600 {path}`")


def secret_file() -> Path:
    """Where the cache secret is: ``$NLUPDATE_CACHE_SECRET_FILE`` or ``<config>/cache-secret``."""
    given = os.environ.get(SECRET_ENV)
    return Path(given) if given else config_dir() / "cache-secret"


def _create_secret(path: Path) -> None:
    """Write a new random secret to ``path`` (0600) unless another process got there first:
    the secret is written whole under a temporary name, then linked to ``path``."""
    temporary = path.parent / f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}"
    try:
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(descriptor, "w") as stream:
            stream.write(secrets.token_hex(SECRET_BYTES) + "\n")
        try:
            os.link(temporary, path)
        except FileExistsError:
            pass  # another process created it meanwhile: use theirs
    except OSError as error:
        raise UserConfigError(f"{path}: cannot create the cache secret ({error.strerror or error})") from None
    finally:
        temporary.unlink(missing_ok=True)


def cache_secret() -> bytes:
    """The key that signs cache records, created (random, 0600) on first use."""
    path = secret_file()
    if not path.exists():
        _create_secret(path)
    try:  # O_NONBLOCK: opening a FIFO must not wait for a writer before the check below refuses it
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
        with os.fdopen(descriptor, "rb") as stream:
            _check_private(path, os.fstat(stream.fileno()))
            key = stream.read(4096).strip()
    except OSError as error:
        raise UserConfigError(f"{path}: cannot read the cache secret ({error.strerror or error})") from None
    if len(key) < 32:
        raise UserConfigError(f"{path}: the cache secret is too short ({len(key)} bytes; at least 32 expected)")
    return key
