"""Prefect tasks: one thin cached task per study step and one per FE evaluation.

* :mod:`~nlupdate.tasks.keys` — cache keys from the project's fingerprints;
* :mod:`~nlupdate.tasks.steps` — the tasks;
* :mod:`~nlupdate.tasks.evaluation` — the point evaluator that runs FE points as tasks.
"""
