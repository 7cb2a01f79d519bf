"""Prefect tasks: one thin cached task per chain step and per job.

* :mod:`~nlupdate.orchestration.tasks.cached` — the tasks;
* :mod:`~nlupdate.orchestration.tasks.keys` — their cache keys, from the chain's declaration and fingerprints;
* :mod:`~nlupdate.orchestration.tasks.fe_points` — the point evaluator of a job: FE points computed in its task, each a cache record;
* :mod:`~nlupdate.orchestration.tasks.names` — what the Prefect UI, the progress lines and the manifest call each run;
* :mod:`~nlupdate.orchestration.tasks.store`, :mod:`~nlupdate.orchestration.tasks.records` — where results persist, as signed data.
"""
