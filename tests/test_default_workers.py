"""The run's thread count when the user names none (:func:`default_workers`): one thread
for an FE model evaluated in this process, one per core for an external FE program, with
Dask processes, and for a run without a study; a count given is kept. The measurement behind
the rule (the demo on one and two threads) is ``benchmarks/prefect_share.py``."""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import pytest

from nlupdate.fe.adapters.calculix import CalculixAdapter
from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.fe.adapters.mapdl import MapdlAdapter
from nlupdate.fe.adapters.surrogate import SurrogateAdapter
from nlupdate.orchestration.flows.runners import Execution, default_workers, task_runner
from nlupdate.study import load_study

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CORES = os.cpu_count() or 2


def test_external_programs_overlap_in_process_models_do_not():
    assert CalculixAdapter.runs_a_program and MapdlAdapter.runs_a_program
    assert not LumpedAdapter.runs_a_program and not SurrogateAdapter.runs_a_program


@pytest.mark.parametrize("example, threads", [("two_dof_study.toml", 1), ("tbeam_three_modes.toml", 1),
                                              ("calculix_tbeam.toml", CORES)])
def test_a_study_gets_one_thread_unless_its_fe_model_is_an_external_program(example, threads):
    study = load_study(EXAMPLES / example)
    assert default_workers(study) == threads
    assert Execution().for_study(study).workers == threads
    assert default_workers(study, processes=True) == CORES  # Dask worker processes do not share an interpreter


def test_a_count_given_is_kept_and_a_run_without_a_study_gets_a_thread_per_core():
    study = load_study(EXAMPLES / "two_dof_study.toml")
    assert Execution(workers=3).for_study(study).workers == 3
    assert default_workers(None) == CORES
    with task_runner(Execution()) as (runner, description):
        assert description == f"{CORES} thread{'' if CORES == 1 else 's'}"
    with task_runner(dataclasses.replace(Execution(), workers=1)) as (_, description):
        assert description == "1 thread"
