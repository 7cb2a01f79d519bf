"""Where a run's task results persist, and whether to recompute them anyway: :class:`Cache`."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from prefect import Task
from prefect.results import ResultStore

from nlupdate.orchestration.tasks.cached import configured
from nlupdate.orchestration.tasks.store import DataSerializer, record_store


@dataclass(frozen=True)
class Cache:
    """``store``: the cache folder; ``refresh``: compute every task even when the store has
    its result (and overwrite it)."""

    store: str
    refresh: bool = False

    def task(self, step: Task, name: str | None = None, run_name: str | None = None) -> Task:
        """``step`` persisting its results in this cache, its runs called ``run_name`` (as
        written: not a format template) and the task ``name`` if given."""
        options = {} if name is None else {"name": name}
        if run_name is not None:
            options["task_run_name"] = lambda: run_name
        return configured(step.with_options(**options) if options else step, Path(self.store), self.refresh)

    def will_compute(self, key: str) -> bool:
        """Whether a task keyed ``key`` would compute (refresh, or no valid record in the
        store; a record that fails its signature is not valid)."""
        if self.refresh:
            return True
        return not ResultStore(result_storage=record_store(Path(self.store)), serializer=DataSerializer()).exists(key)
