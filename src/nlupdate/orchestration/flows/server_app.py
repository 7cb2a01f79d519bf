"""The API app of the Prefect server a run starts: Prefect's own, with busy writes retried inside.

Prefect's server keeps its database in SQLite. While its background services record the
events of a burst of task runs, a write request from the client (the task run Prefect
adds to a flow run for each subflow, for instance) can meet ``SQLITE_BUSY_SNAPSHOT``: in
WAL mode a transaction that read before another connection wrote cannot write, and SQLite
says so at once instead of waiting out its busy timeout. Prefect answers 503 and its client
tries again after 2 s (its back-off starts at 2¹ s). Measured here: the first subflow after
a few task runs took 1.8–2.2 s instead of 0.15 s, twice per ``nlupdate demo``.

:func:`create_app` wraps Prefect's app (:func:`prefect.server.api.server.create_app`) in
:class:`RetryBusyWrites`: a write request (POST, PUT, PATCH, DELETE) answered 503 is run
again inside the server after a short pause — the failed transaction was rolled back, so
this is the client's own retry, 2 s sooner. A write that waits for the lock gives up
after 2 s instead of Prefect's 60 s (:func:`shorten_busy_timeout`) and is retried the same
way. Servers the user runs (``PREFECT_API_URL``) are not touched.
"""
from __future__ import annotations

import asyncio
from typing import Any, Awaitable, Callable

WRITES = frozenset({"POST", "PUT", "PATCH", "DELETE"})

Message = dict[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]


class RetryBusyWrites:
    """ASGI middleware: a write answered 503 is run again, up to ``attempts`` times, after
    ``pause_s``, 2 × ``pause_s``, … (the last answer goes to the client whatever it is)."""

    def __init__(self, app: Callable, attempts: int = 12, pause_s: float = 0.02) -> None:
        self.app, self.attempts, self.pause_s = app, attempts, pause_s

    async def __call__(self, scope: dict, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] not in WRITES:
            await self.app(scope, receive, send)
            return
        body, more = b"", True
        while more:  # the request body, kept to be read again by each attempt
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            body, more = body + message.get("body", b""), message.get("more_body", False)
        for attempt in range(1, self.attempts + 1):
            answer = await self._attempt(scope, body, receive)
            if answer[0]["status"] != 503 or attempt == self.attempts:
                for message in answer:
                    await send(message)
                return
            await asyncio.sleep(self.pause_s * attempt)

    async def _attempt(self, scope: dict, body: bytes, receive: Receive) -> list[Message]:
        """One run of the app on the kept body; its response messages, held back."""
        delivered = False
        answer: list[Message] = []

        async def replay() -> Message:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()  # only a disconnect comes after the body

        async def hold(message: Message) -> None:
            answer.append(message)

        try:
            await self.app(dict(scope), replay, hold)  # a fresh copy: the app writes into its scope
        except Exception:
            # Starlette raises the error again after its handler has answered (503 here), for
            # the server to log; an error without an answer is the server's to handle
            if not answer:
                raise
        return answer


#: How long (ms) a write of this server waits for SQLite's lock before it fails (503, run
#: again by :class:`RetryBusyWrites`); Prefect waits 60 s.
BUSY_TIMEOUT_MS = 2000


def create_app() -> Callable:
    """Prefect's API app (as ``prefect server start`` serves it, UI off) in
    :class:`RetryBusyWrites`, its SQLite connections waiting at most :data:`BUSY_TIMEOUT_MS`
    for a lock (:func:`shorten_busy_timeout`)."""
    from prefect.server.api.server import create_app as prefect_app

    shorten_busy_timeout()
    poll_background_work_slowly()
    return RetryBusyWrites(prefect_app())


def shorten_busy_timeout(milliseconds: int = BUSY_TIMEOUT_MS) -> None:
    """Make every new SQLite connection of this process's Prefect server wait at most
    ``milliseconds`` for a lock instead of Prefect's 60 s.

    Measured with two ``nlupdate run`` of the two-dof study at once against one server
    (another test module running beside them): with Prefect's 60 s, two of eight pairs took
    76 and 83 s instead of 20–24 s (each stuck run waiting for a flow-state update while
    the server's threads sat idle); with 2 s, sixteen pairs took 13–25 s, none stuck. A
    write that gives up is answered 503 and run again by :class:`RetryBusyWrites`."""
    from prefect.server.database.configurations import AioSqliteConfiguration

    prefect_setup = AioSqliteConfiguration.setup_sqlite
    if getattr(prefect_setup, "nlupdate_busy_timeout_ms", None) == milliseconds:
        return
    prefect_setup = getattr(prefect_setup, "prefect_setup", prefect_setup)

    def setup_sqlite(self, conn, record) -> None:
        prefect_setup(self, conn, record)
        cursor = conn.cursor()
        cursor.execute(f"PRAGMA busy_timeout = {int(milliseconds)};")
        cursor.close()

    setup_sqlite.nlupdate_busy_timeout_ms = milliseconds
    setup_sqlite.prefect_setup = prefect_setup
    AioSqliteConfiguration.setup_sqlite = setup_sqlite


#: How often (s) this server's background worker looks for work: Prefect's docket worker
#: looks every 0.25 s, for jobs a run never queues (cancellation clean-ups, deleting the
#: logs of deleted runs, readiness of deployments and work queues; the perpetual services
#: that queue them do not run in this server).
BACKGROUND_POLL_S = 5.0


def poll_background_work_slowly(seconds: float = BACKGROUND_POLL_S) -> None:
    """Make this process's Prefect server look for background jobs every ``seconds``
    instead of every 0.25 s: a kept server waits for runs most of its life, and that
    polling was most of its CPU while it waited (measured in the module's test)."""
    import datetime as dt

    import prefect.server.api.background_workers as workers

    if getattr(workers.Worker, "nlupdate_poll_s", None) == seconds:
        return
    docket_worker = getattr(workers.Worker, "docket_worker", workers.Worker)

    class Worker(docket_worker):
        nlupdate_poll_s = seconds

        def __init__(self, docket, **options) -> None:
            options.setdefault("minimum_check_interval", dt.timedelta(seconds=seconds))
            options.setdefault("scheduling_resolution", dt.timedelta(seconds=seconds))
            super().__init__(docket, **options)

    Worker.docket_worker = docket_worker
    workers.Worker = Worker
