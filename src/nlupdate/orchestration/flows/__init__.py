"""Prefect flows: a study as identification, updating-sweep and prediction flows.

* :mod:`~nlupdate.orchestration.flows.run` — :func:`run_study_flow`: server, task runner, cache, progress;
* :mod:`~nlupdate.orchestration.flows.study` — the flows;
* :mod:`~nlupdate.orchestration.flows.runners`, :mod:`~nlupdate.orchestration.flows.server`,
  :mod:`~nlupdate.orchestration.flows.status_lines`, :mod:`~nlupdate.orchestration.flows.environment` — what a run needs.

Importing this package imports no Prefect module: the environment is prepared first.
"""
