"""Orchestration: Prefect flows (:mod:`~nlupdate.orchestration.flows`) wire the cached tasks
(:mod:`~nlupdate.orchestration.tasks`), choose the task runner and write archives.

Imports the study, reporting and numerics layers below it; nothing below imports it.
"""
