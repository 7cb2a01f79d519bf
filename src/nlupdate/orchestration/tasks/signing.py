"""Signed cache records without Prefect: signing, verifying, and reading a task's result.

The record format and why it is signed: :mod:`nlupdate.orchestration.tasks.store` (Prefect's
result storage writes and reads the records there). This module imports no Prefect
module, so that a run whose every result is in the cache can be answered before Prefect is
imported (:mod:`nlupdate.orchestration.flows.from_cache`) from the same records, verified
the same way.
"""
from __future__ import annotations

import base64
import hashlib
import hmac
import json
from pathlib import Path
from typing import Any

from nlupdate.orchestration.tasks import records
from nlupdate.user_config import cache_secret

MAGIC = b"nlupdate-record 1\n"
RECORDS_FOLDER = "records-v1"
SERIALIZER_TYPE = "nlupdate-data"


def _signature(secret: bytes, key: str, payload: bytes) -> bytes:
    message = MAGIC + key.encode() + b"\0" + payload
    return hmac.new(secret, message, hashlib.sha256).hexdigest().encode()


def sign(key: str, payload: bytes, secret: bytes | None = None) -> bytes:
    """The stored form of ``payload`` under ``key``."""
    return MAGIC + _signature(secret or cache_secret(), key, payload) + b"\n" + payload


def signed_payload(key: str, content: bytes, secret: bytes | None = None) -> bytes:
    """The payload of what :func:`sign` stored under ``key``, or ``ValueError`` saying why it
    cannot be trusted (whatever the payload holds)."""
    if not content.startswith(MAGIC):
        raise ValueError("not a signed nlupdate record (written by an older version or by something else)")
    signature, _, payload = content[len(MAGIC):].partition(b"\n")
    if not hmac.compare_digest(signature, _signature(secret or cache_secret(), key, payload)):
        raise ValueError("its signature does not match (edited, copied from another key, or signed with another "
                         "cache secret)")
    return payload


def verified(key: str, content: bytes, secret: bytes | None = None) -> bytes:
    """The payload of a stored task record, or ``ValueError`` saying why it cannot be trusted."""
    payload = signed_payload(key, content, secret)
    try:
        serializer = json.loads(payload)["metadata"]["serializer"]["type"]
    except (ValueError, KeyError, TypeError):
        raise ValueError("not a Prefect result record") from None
    if serializer != SERIALIZER_TYPE:
        raise ValueError(f"written with serializer {serializer!r}, not {SERIALIZER_TYPE!r}")
    return payload


def _result_blob(payload: bytes) -> bytes:
    """The result of a verified record, as :func:`nlupdate.orchestration.tasks.records.dumps` wrote it."""
    try:
        return base64.b64decode(json.loads(payload)["result"], validate=True)
    except (ValueError, KeyError, TypeError):
        raise ValueError("its result is not stored as data") from None


def records_schema_ok(payload: bytes) -> None:
    """``ValueError`` when the result inside a verified record is not data of this
    version's schema (:func:`nlupdate.orchestration.tasks.records.check`)."""
    blob = _result_blob(payload)
    try:
        records.check(blob)
    except records.RecordError as error:
        raise ValueError(str(error)) from None


class Missing(LookupError):
    """No usable record: absent, unreadable, or failing its check (the reason is the message)."""


def read_result(cache_folder: Path, key: str) -> Any:
    """The task result kept under ``key`` in the cache folder ``cache_folder``, verified as
    Prefect's reads of :class:`~nlupdate.orchestration.tasks.store.SignedLocalFileSystem` verify it;
    :class:`Missing` when there is none that can be used."""
    path = Path(cache_folder) / RECORDS_FOLDER / key
    try:
        content = path.read_bytes()
    except OSError as error:
        raise Missing(f"{path}: {error.strerror}") from None
    try:
        payload = verified(key, content)
        if json.loads(payload)["metadata"].get("expiration") is not None:
            raise ValueError("it has an expiration date")  # none of ours has: written by something else
        return records.loads(_result_blob(payload))
    except (ValueError, KeyError, TypeError, records.RecordError) as error:
        raise Missing(f"{path}: {error}") from None
