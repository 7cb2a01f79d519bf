"""Where tasks run: a thread pool (default) or Dask — a local cluster started for the
run, or an existing cluster at a scheduler address (prefect-dask)."""
from __future__ import annotations

import contextlib
import dataclasses
import os
import socket
from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterator

if TYPE_CHECKING:
    from nlupdate.study.spec import Study


class ExecutionError(RuntimeError):
    """The requested execution cannot be set up; the message says why."""


@dataclass(frozen=True)
class Execution:
    """workers: threads, or local Dask worker processes (None: :func:`default_workers` for
    the run's study); dask: start a local cluster; dask_address: ``tcp://HOST:PORT`` of an
    existing scheduler (``workers`` ignored)."""

    workers: int | None = None
    dask: bool = False
    dask_address: str | None = None

    def __post_init__(self) -> None:
        if self.workers is not None and self.workers < 1:
            raise ExecutionError(f"workers must be at least 1, got {self.workers}")
        if self.dask and self.dask_address:
            raise ExecutionError("choose a local Dask cluster (--dask) or an existing one (--dask-address), not both")

    def for_study(self, study: "Study | None") -> "Execution":
        """This execution with its worker count set: as given, else :func:`default_workers`."""
        if self.workers is not None:
            return self
        return dataclasses.replace(self, workers=default_workers(study, processes=self.dask))


def default_workers(study: "Study | None", processes: bool = False) -> int:
    """Threads (or, with ``processes``, local Dask worker processes) for a run when the user
    names none: one per core for processes, for a study whose FE model is an external
    program (its evaluations overlap while the threads wait:
    :attr:`~nlupdate.fe.adapters.base.FEAdapter.runs_a_program`) and for a run without a
    study (a discovery); else one thread. The FE evaluations of an in-process model hold the
    interpreter, so on more threads they only contend: the demo took 1.04 s more CPU and
    0.66 s more wall on two threads than on one, the three-mode T-beam study 1.5 s more CPU
    and 0.8 s more wall (docs/performance.md, "Threads for in-process FE models")."""
    cores = os.cpu_count() or 2
    if processes or study is None:
        return cores
    if study.adapter is None:
        return 1
    from nlupdate.fe.adapters.registry import build_adapter

    return cores if build_adapter(study.adapter).runs_a_program else 1


def check_scheduler_address(address: str, timeout_s: float = 2.0) -> None:
    """Fail in one line, before a run starts anything (a Prefect server takes seconds),
    when ``address`` is not ``[tcp://]HOST:PORT`` (or ``tls://``) or nothing accepts a TCP
    connection there within ``timeout_s``. Whether it is a Dask scheduler with workers is
    checked when the task runner connects (:func:`task_runner`)."""
    scheme, separator, rest = address.rpartition("://")
    host, colon, port = rest.rpartition(":")
    host = host.strip("[]")  # an IPv6 literal, [::1]
    if (separator and scheme not in ("tcp", "tls")) or not colon or not host or not port.isdigit():
        raise ExecutionError(f"the Dask scheduler address {address!r} is not of the form tcp://HOST:PORT")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except OSError as error:
        reason = f"no answer within {timeout_s:g} s" if isinstance(error, TimeoutError) else \
            (error.strerror or str(error)).lower()
        raise ExecutionError(f"no Dask scheduler answers at {address} ({reason}); start one with `dask scheduler` "
                             f"and `dask worker ADDRESS`") from None


@contextlib.contextmanager
def task_runner(execution: Execution, connect_timeout_s: float = 10.0) -> Iterator[tuple[object, str]]:
    """Yield (a Prefect task runner, a description of it) for ``execution``; a local Dask
    cluster lives as long as the context. No worker count: :func:`default_workers` without a study."""
    execution = execution.for_study(None)
    if execution.dask_address is None and not execution.dask:
        from prefect.task_runners import ThreadPoolTaskRunner

        yield ThreadPoolTaskRunner(max_workers=execution.workers), \
            f"{execution.workers} thread{'' if execution.workers == 1 else 's'}"
        return
    if execution.dask_address is not None:
        check_scheduler_address(execution.dask_address, connect_timeout_s)
    try:
        from distributed import Client, LocalCluster
        from prefect_dask import DaskTaskRunner
    except ImportError as error:  # the optional part: pyproject.toml [dask]
        raise ExecutionError(f"running the tasks on Dask needs {error.name or 'Dask'}, an optional part of nlupdate "
                             f"that is not installed: pip install 'nlupdate[dask]'") from None

    if execution.dask_address is not None:
        try:
            with Client(execution.dask_address, timeout=connect_timeout_s) as client:
                n_workers = len(client.scheduler_info()["workers"])
        except (OSError, TimeoutError) as error:
            raise ExecutionError(f"no Dask scheduler answers at {execution.dask_address} within {connect_timeout_s:g} s "
                                 f"({error}); start one with `dask scheduler` and `dask worker ADDRESS`") from None
        if n_workers == 0:
            raise ExecutionError(f"the Dask scheduler at {execution.dask_address} has no workers; start some with "
                                 f"`dask worker {execution.dask_address}`")
        yield DaskTaskRunner(address=execution.dask_address), f"Dask at {execution.dask_address} ({n_workers} workers)"
        return
    with LocalCluster(n_workers=execution.workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        yield DaskTaskRunner(address=cluster.scheduler_address), \
            f"local Dask cluster, {execution.workers} worker processes ({cluster.scheduler_address})"
