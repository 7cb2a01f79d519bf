"""Studies: one TOML file describes the whole chain; the steps and a plain sequential run.

* :mod:`~nlupdate.study.spec` — the study file (reading and validation);
* :mod:`~nlupdate.study.steps` — each step of the chain on plain inputs;
* :mod:`~nlupdate.study.run` — :func:`run_study`, every step in order, in one process.
"""
from nlupdate.study.run import StudyResult, run_study, study_warnings
from nlupdate.study.spec import Study, StudyError, inputs_read_once, load_study, study_from_text

__all__ = ["Study", "StudyError", "StudyResult", "inputs_read_once", "load_study", "run_study", "study_from_text",
           "study_warnings"]
