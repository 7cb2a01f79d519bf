"""Prefect flows: a study as identification, updating-sweep and prediction flows.

* :mod:`~nlupdate.flows.run` — :func:`run_study_flow`: server, task runner, cache, progress;
* :mod:`~nlupdate.flows.study` — the flows;
* :mod:`~nlupdate.flows.runners`, :mod:`~nlupdate.flows.server`,
  :mod:`~nlupdate.flows.status_lines`, :mod:`~nlupdate.flows.environment` — what a run needs.

Importing this package imports no Prefect module: the environment is prepared first.
"""
