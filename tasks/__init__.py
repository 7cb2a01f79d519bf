"""Prefect tasks: one thin cached task per chain step, per job and per FE evaluation.

* :mod:`~nlupdate.tasks.cached` — the tasks;
* :mod:`~nlupdate.tasks.keys` — their cache keys, from the chain's declaration and fingerprints;
* :mod:`~nlupdate.tasks.fe_points` — the point evaluator that runs FE points as tasks;
* :mod:`~nlupdate.tasks.names` — what the Prefect UI, the progress lines and the manifest call each run;
* :mod:`~nlupdate.tasks.store`, :mod:`~nlupdate.tasks.records` — where results persist, as signed data.
"""
