"""Prefect's settings for code the tests run in their own process.

Prefect reads its settings when it is imported. In a test session it is imported while
the tests are collected, before the session's server exists, so its settings name no API
and a client would start a server of Prefect's own in the test process (6 s). Tests that
talk to a server name it explicitly (:func:`talking_to`)."""
from __future__ import annotations

from contextlib import AbstractContextManager


def talking_to(url: str) -> AbstractContextManager:
    """Within the block, Prefect talks to ``url`` and flow runs send no heartbeats (as the
    project's own runs: the heartbeat thread holds each flow run up to a second as it ends)."""
    from prefect.settings import PREFECT_API_URL, PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    return temporary_settings(updates={PREFECT_API_URL: url, PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None})
