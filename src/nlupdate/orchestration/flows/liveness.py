"""Which process runs a flow run, and flow runs whose process is gone.

A run killed with SIGKILL (``kill -9``, the out-of-memory killer, a closed laptop lid
that ended a container) cannot tell the Prefect API it stopped: its flow runs and task
runs stay "Running" in the database for ever, and the UI shows a dead run as alive.

* :func:`claim_flow_run`, called as each of our flows starts, records the process that
  runs it in the flow run's ``infrastructure_pid`` as ``<host>:<pid>@<uid>`` (the host
  name as in the temporary names of :mod:`nlupdate.files`, the process id and the user
  id of its owner; Prefect's own process workers write ``<host>:<pid>``). One API call;
  a failure is never fatal (the run goes on unclaimed).
* :func:`mark_dead_runs_crashed`, called by :func:`nlupdate.orchestration.flows.server.prefect_api` as
  each run starts, finds the Running and Pending flow runs claimed by a process of this
  host and this user that no longer runs (or whose process id now belongs to a process
  started after the flow run started, i.e. was reused), sets them Crashed (forced) with a
  message saying the process was killed, crashes their task runs that are still Running
  or Pending, and does the same for the unclaimed subflow runs those task runs started.

Runs of other hosts, of other users (a Prefect database in a shared ``PREFECT_HOME`` holds
theirs too) and runs claimed without a user (Prefect's own workers) are never touched:
whether their processes live cannot be told, or is not this user's business.
"""
from __future__ import annotations

import datetime as dt
import logging
import os
from typing import Any, Callable, Iterable

from nlupdate.files import HOST, writer_alive

logger = logging.getLogger("nlupdate.liveness")

#: States of runs that claim to be alive.
ALIVE_STATES = ("RUNNING", "PENDING")
#: Page size of the API queries.
PAGE = 200
#: A process that started this long after its flow run was created cannot have run it.
REUSED_PID_SLACK_S = 2.0


def _uid() -> int | None:
    return os.getuid() if hasattr(os, "getuid") else None


def owner(pid: int | None = None) -> str:
    """``<host>:<pid>@<uid>`` of this process (or of ``pid`` on this host, run by this user);
    ``<host>:<pid>`` where there are no user ids."""
    uid = _uid()
    return f"{HOST}:{os.getpid() if pid is None else pid}" + ("" if uid is None else f"@{uid}")


def parse_owner(text: str | None) -> tuple[str, int, int | None] | None:
    """``(host, pid, uid or None)`` of an ``infrastructure_pid`` in the form
    ``<host>:<pid>@<uid>`` or ``<host>:<pid>``, else None."""
    if not text or ":" not in text:
        return None
    host, _, rest = text.rpartition(":")
    pid, at, uid = rest.partition("@")
    if not (host and pid.isdigit() and (not at or uid.isdigit())):
        return None
    return host, int(pid), int(uid) if at else None


def claim_flow_run(flow: Any = None, flow_run: Any = None, state: Any = None) -> bool:
    """Record this process as the owner of ``flow_run`` (default: the current flow run).

    Call it first thing in a flow, or pass it as a hook (``@flow(on_running=[claim_flow_run])``:
    Prefect calls hooks with ``(flow, flow_run, state)``). Returns whether the API took it;
    never raises.
    """
    try:
        if flow_run is None:
            from prefect.context import FlowRunContext

            context = FlowRunContext.get()
            if context is None or context.flow_run is None:
                return False
            flow_run = context.flow_run
        from prefect.client.orchestration import get_client

        with get_client(sync_client=True) as client:
            client.update_flow_run(flow_run.id, infrastructure_pid=owner())
        return True
    except Exception as error:  # never fatal: the run goes on, it just cannot be found dead later
        logger.debug("could not claim flow run: %s", error)
        return False


def _zombie(pid: int) -> bool:
    """Whether ``pid`` has ended but not been reaped by its parent (it runs nothing)."""
    try:
        import psutil

        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except Exception:
        return False


def _started(pid: int) -> dt.datetime | None:
    """When process ``pid`` started (UTC), if that can be known here."""
    try:
        import psutil

        return dt.datetime.fromtimestamp(psutil.Process(pid).create_time(), dt.timezone.utc)
    except Exception:
        return None


def owner_is_dead(infrastructure_pid: str | None, created: dt.datetime | None = None) -> bool:
    """Whether ``infrastructure_pid`` names a process of this host and this user that is gone.

    A process id that is alive but belongs to a process started more than
    :data:`REUSED_PID_SLACK_S` after the flow run ``created`` (pass the time it started
    running: a scheduled run is created long before its process starts) has been reused:
    the owner is gone too. Other hosts', other users', user-less and unparsable owners are
    never dead.
    """
    parsed = parse_owner(infrastructure_pid)
    if parsed is None or parsed[0] != HOST or parsed[2] is None or parsed[2] != _uid():
        return False
    pid = parsed[1]
    if pid == os.getpid():
        return False
    if not writer_alive(pid) or _zombie(pid):
        return True
    if created is not None:
        started = _started(pid)
        if started is not None:
            if created.tzinfo is None:
                created = created.replace(tzinfo=dt.timezone.utc)
            return started > created + dt.timedelta(seconds=REUSED_PID_SLACK_S)
    return False


def _pages(read: Callable[..., list], **filters) -> list:
    runs, offset = [], 0
    while True:
        page = read(**filters, limit=PAGE, offset=offset)
        runs.extend(page)
        if len(page) < PAGE:
            return runs
        offset += PAGE


def _alive_flow_runs(client) -> list:
    from prefect.client.schemas.filters import FlowRunFilter, FlowRunFilterState, FlowRunFilterStateType

    state = FlowRunFilterState(type=FlowRunFilterStateType(any_=list(ALIVE_STATES)))
    return _pages(client.read_flow_runs, flow_run_filter=FlowRunFilter(state=state))


def _alive_task_runs(client, flow_run_ids: Iterable) -> list:
    from prefect.client.schemas.filters import (
        TaskRunFilter,
        TaskRunFilterFlowRunId,
        TaskRunFilterState,
        TaskRunFilterStateType,
    )

    ids = list(flow_run_ids)
    if not ids:
        return []
    state = TaskRunFilterState(type=TaskRunFilterStateType(any_=list(ALIVE_STATES)))
    return _pages(client.read_task_runs,
                  task_run_filter=TaskRunFilter(state=state, flow_run_id=TaskRunFilterFlowRunId(any_=ids)))


def mark_dead_runs_crashed(say: Callable[[str], None] | None = None) -> int:
    """Set Crashed the flow runs (and their task runs) left Running by killed processes of
    this host; says and returns how many flow runs (see the module docstring).

    Uses the API of the current Prefect settings. Errors of the API are raised: the
    caller decides whether they matter (:func:`~nlupdate.orchestration.flows.server.prefect_api` says one
    line and goes on).
    """
    from prefect.client.orchestration import get_client
    from prefect.states import Crashed

    with get_client(sync_client=True) as client:
        alive = _alive_flow_runs(client)
        dead = {run.id: run for run in alive if owner_is_dead(run.infrastructure_pid, run.start_time or run.created)}
        if not dead:
            return 0
        by_parent_task = {run.parent_task_run_id: run for run in alive
                          if run.parent_task_run_id is not None and run.id not in dead
                          and parse_owner(run.infrastructure_pid) is None}
        who = {run_id: run.infrastructure_pid for run_id, run in dead.items()}
        task_runs, frontier = [], list(dead)
        while frontier:  # the dead runs' task runs, and the unclaimed subflows they started
            found = _alive_task_runs(client, frontier)
            task_runs.extend(found)
            frontier = []
            for task_run in found:
                child = by_parent_task.pop(task_run.id, None)
                if child is not None:
                    dead[child.id] = child
                    who[child.id] = who[task_run.flow_run_id]
                    frontier.append(child.id)
        for run in dead.values():
            message = (f"the process that ran it ({who[run.id]}) is gone (killed); "
                       f"marked crashed by nlupdate process {owner()}")
            client.set_flow_run_state(run.id, Crashed(message=message), force=True)
        for task_run in task_runs:
            client.set_task_run_state(task_run.id, Crashed(message="its flow run's process is gone (killed)"),
                                      force=True)
    names = ", ".join(sorted({f"{run.name} ({run.infrastructure_pid})" for run in dead.values()
                              if run.infrastructure_pid}))
    if say is not None:
        say(f"marked {len(dead)} flow run(s) of killed processes as crashed: {names}")
    return len(dead)
