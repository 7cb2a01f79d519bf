"""What ``nlupdate schedule`` registered, kept where only the user can change it.

The Prefect API is open to every local process, so the deployment it holds says only
*which* registration to run (its name and the SHA-256 of its study); everything a run
needs — the study's text, the results root, the cache folder, the thread count, the
schedule — is kept here, in ``<user config>/schedules/`` (0700, files 0600; see
:mod:`nlupdate.user_config`). A flow run can therefore name nothing but a study the user
registered: no file path and no program comes from its parameters.
"""
from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

from nlupdate.files import write_bytes_atomic
from nlupdate.user_config import config_dir


@dataclass(frozen=True)
class Registration:
    """One scheduled study as registered.

    ``study_file`` is the absolute path it was read from (it anchors the study's relative
    paths); ``study_text`` what was read then, and what every run uses; ``when`` the
    schedule: ``{"cron": EXPR, "timezone": TZ | None}`` or ``{"interval_s": SECONDS}``."""

    name: str
    study_file: str
    study_text: str
    study_sha256: str
    results_root: str
    cache_dir: str
    workers: int
    when: dict
    registered_utc: str

    @property
    def parameters(self) -> dict[str, str]:
        """The flow-run parameters of its deployment: which registration, which study."""
        return {"name": self.name, "study_sha256": self.study_sha256}


def new_registration(name: str, study_file: str | os.PathLike, study_text: str, results_root: str | os.PathLike,
                     cache_dir: str | os.PathLike, workers: int, when: dict) -> Registration:
    return Registration(
        name=name, study_file=str(Path(study_file).resolve()), study_text=study_text,
        study_sha256=hashlib.sha256(study_text.encode()).hexdigest(), results_root=str(Path(results_root).resolve()),
        cache_dir=str(Path(cache_dir).resolve()), workers=int(workers), when=dict(when),
        registered_utc=dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"))


def _folder() -> Path:
    folder = config_dir() / "schedules"
    folder.mkdir(mode=0o700, exist_ok=True)
    return folder


def _path(name: str) -> Path:
    # a hashed file name: no registration name can point outside the folder
    return _folder() / f"{hashlib.sha256(name.encode()).hexdigest()[:24]}.json"


def save(registration: Registration) -> None:
    path = _path(registration.name)
    previous = os.umask(0o077)
    try:
        write_bytes_atomic(path, json.dumps(asdict(registration), indent=1).encode())
    finally:
        os.umask(previous)


def load(name: str) -> Registration | None:
    """The registration called ``name``, or None."""
    path = _path(name)
    try:
        data = json.loads(path.read_text())
        registration = Registration(**data)
    except FileNotFoundError:
        return None
    except (ValueError, TypeError) as error:
        raise ValueError(f"{path}: the registration of {name!r} is damaged ({error}); "
                         f"register the study again with --replace") from None
    return registration if registration.name == name else None


def remove(name: str) -> bool:
    """Forget the registration ``name``; whether there was one."""
    path = _path(name)
    existed = path.exists()
    path.unlink(missing_ok=True)
    return existed


def every() -> list[Registration]:
    """Every registration, by name (damaged files are skipped)."""
    found = []
    for path in sorted(_folder().glob("*.json")):
        try:
            found.append(Registration(**json.loads(path.read_text())))
        except (ValueError, TypeError, OSError):
            continue
    return sorted(found, key=lambda r: r.name)
