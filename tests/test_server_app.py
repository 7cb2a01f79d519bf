"""The run's Prefect server retries writes SQLite refused as busy (src/nlupdate/orchestration/flows/server_app.py).

The middleware is driven here with a small ASGI app that answers 503 a given number of
times, the way Prefect's app does on ``SQLITE_BUSY_SNAPSHOT`` (Starlette's error middleware
sends the handler's answer and then raises the error again). The fix's effect on a real
server — the first subflow after a burst of task runs — is measured in docs/performance.md.
"""
from __future__ import annotations

import asyncio
import json

import pytest

from nlupdate.orchestration.flows.server_app import RetryBusyWrites


class BusyApp:
    """Answers 503 (and raises, as Starlette does) ``busy`` times, then 201 with the body it read."""

    def __init__(self, busy: int) -> None:
        self.busy, self.calls, self.bodies = busy, 0, []

    async def __call__(self, scope, receive, send):
        self.calls += 1
        message = await receive()
        self.bodies.append(message["body"])
        if self.calls <= self.busy:
            await send({"type": "http.response.start", "status": 503, "headers": []})
            await send({"type": "http.response.body", "body": b'{"exception_message": "Service Unavailable"}'})
            raise RuntimeError("database is locked")
        await send({"type": "http.response.start", "status": 201, "headers": []})
        await send({"type": "http.response.body", "body": json.dumps({"got": message["body"].decode()}).encode()})


def call(app, method: str, body: bytes = b'{"name": "x"}'):
    """One request, its body in two parts, through ``RetryBusyWrites(app)``; the messages the client got."""
    pieces = [body[: len(body) // 2], body[len(body) // 2:]]
    incoming = [{"type": "http.request", "body": piece, "more_body": i < len(pieces) - 1} for i, piece in enumerate(pieces)]
    sent = []

    async def receive():
        return incoming.pop(0) if incoming else {"type": "http.disconnect"}

    async def send(message):
        sent.append(message)

    asyncio.run(RetryBusyWrites(app, pause_s=0.001)({"type": "http", "method": method, "path": "/"}, receive, send))
    return sent


def test_a_write_answered_busy_is_run_again_with_the_same_body_and_the_client_sees_the_answer():
    app = BusyApp(busy=3)
    sent = call(app, "POST")
    assert app.calls == 4 and app.bodies == [b'{"name": "x"}'] * 4  # the body read whole each time
    assert [m["status"] for m in sent if m["type"] == "http.response.start"] == [201]
    assert json.loads(sent[-1]["body"]) == {"got": '{"name": "x"}'}


def test_a_write_that_stays_busy_gets_the_last_answer_after_the_attempts():
    app = BusyApp(busy=100)
    sent = call(app, "PATCH")
    assert app.calls == 12 and [m["status"] for m in sent if m["type"] == "http.response.start"] == [503]


def test_reads_pass_through_untouched():
    app = BusyApp(busy=1)
    with pytest.raises(RuntimeError, match="database is locked"):  # no retry: the error is the server's to log
        call(app, "GET")
    assert app.calls == 1


def test_an_error_without_an_answer_is_raised():
    async def broken(scope, receive, send):
        await receive()
        raise ValueError("boom")

    with pytest.raises(ValueError, match="boom"):
        call(broken, "POST")


def test_a_write_waits_two_seconds_for_the_lock_not_a_minute(tmp_path, monkeypatch):
    """The server's SQLite connections get a 2 s busy timeout (Prefect's: 60 s): a write
    meeting a lock another connection holds fails after ~2 s as a busy error, which
    Prefect answers 503 and RetryBusyWrites runs again."""
    import sqlite3

    import sqlalchemy.exc
    from prefect.server.api.server import is_client_retryable_exception
    from prefect.server.database.configurations import AioSqliteConfiguration

    from nlupdate.orchestration.flows.server_app import BUSY_TIMEOUT_MS, shorten_busy_timeout

    monkeypatch.setattr(AioSqliteConfiguration, "setup_sqlite", AioSqliteConfiguration.setup_sqlite)  # restored after
    shorten_busy_timeout()
    shorten_busy_timeout()  # twice is once
    database = tmp_path / "prefect.db"
    configuration = AioSqliteConfiguration(connection_url=f"sqlite+aiosqlite:///{database}")
    holder, writer = (sqlite3.connect(database, isolation_level=None) for _ in range(2))
    for connection in (holder, writer):
        configuration.setup_sqlite(connection, None)
    assert writer.execute("PRAGMA busy_timeout").fetchone()[0] == BUSY_TIMEOUT_MS == 2000
    holder.execute("CREATE TABLE runs (state TEXT)")
    holder.execute("BEGIN IMMEDIATE")
    holder.execute("INSERT INTO runs VALUES ('RUNNING')")
    # the connection's busy timeout (the PRAGMA above, 2 s, not Prefect's 60 s) is what the write waits
    # for: the lock is refused when it runs out, as an error Prefect's client retries
    with pytest.raises(sqlite3.OperationalError, match="database is locked") as refused:
        writer.execute("INSERT INTO runs VALUES ('COMPLETED')")
    assert is_client_retryable_exception(sqlalchemy.exc.OperationalError("INSERT", {}, refused.value))
    holder.execute("COMMIT")
    writer.execute("INSERT INTO runs VALUES ('COMPLETED')")  # the retry gets through
    assert [row[0] for row in writer.execute("SELECT state FROM runs")] == ["RUNNING", "COMPLETED"]


def test_the_background_worker_looks_for_work_every_five_seconds_and_still_does_it(monkeypatch):
    """The server's docket worker (Prefect's background jobs) is made with 5 s between its
    looks for work instead of 0.25 s — that polling was most of an idle kept server's CPU —
    and still runs a job queued for it."""
    import datetime as dt

    import prefect.server.api.background_workers as workers
    from docket import Docket

    from nlupdate.orchestration.flows.server_app import BACKGROUND_POLL_S, poll_background_work_slowly

    monkeypatch.setattr(workers, "Worker", workers.Worker)  # restored after
    poll_background_work_slowly()
    poll_background_work_slowly()  # twice is once
    assert workers.Worker.docket_worker.__module__.startswith("docket")
    done = []

    async def job(value: int) -> None:
        done.append(value)

    async def run() -> None:
        async with Docket(name="nlupdate-test", url="memory://nlupdate-test") as docket:
            async with workers.Worker(docket) as worker:
                assert worker.minimum_check_interval == worker.scheduling_resolution == dt.timedelta(
                    seconds=BACKGROUND_POLL_S) == dt.timedelta(seconds=5)
                docket.register(job)
                await docket.add(job)(7)
                await worker.run_until_finished()

    asyncio.run(run())
    assert done == [7]
