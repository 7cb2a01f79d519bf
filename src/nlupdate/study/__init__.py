"""Studies: one TOML file describes the whole chain; the chain, its steps and a plain run.

* :mod:`~nlupdate.study.spec` — the study file (reading and validation);
* :mod:`~nlupdate.study.chain` — the chain of steps, declared once;
* :mod:`~nlupdate.study.steps` — each step on plain inputs;
* :mod:`~nlupdate.study.sequential` — :func:`run_study`, every step in order, in one process.
"""
from nlupdate.study.chain import CHAIN, StudyResult
from nlupdate.study.sequential import run_study
from nlupdate.study.loading import load_study, study_from_text
from nlupdate.study.spec import Study, StudyError, inputs_read_once

__all__ = ["CHAIN", "Study", "StudyError", "StudyResult", "inputs_read_once", "load_study", "run_study",
           "study_from_text"]
