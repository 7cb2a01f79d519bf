"""Test-session set-up.

* Prefect keeps its database and settings in a temporary ``PREFECT_HOME`` for the
  session (set before anything imports Prefect), nlupdate its cache secret and schedule
  registrations in a temporary ``NLUPDATE_CONFIG_DIR`` (both removed at the end), and
  :func:`prefect_server` starts one server for all the tests that need it (runs in
  subprocesses of the session use it too, and it stops with the session:
  ``NLUPDATE_PREFECT_SERVER_KEEP_S=0``). Under
  pytest-xdist (``-n 2`` in pyproject.toml) each worker process has its own folders and its
  own server. Prefect's database migrations run once per session, while the workers collect
  the tests (:mod:`prefect_home`), and each worker's home starts from that database (a
  server then answers in 3.5 s instead of 10.6 s). Prefect reads its settings when it is
  imported, during collection: tests name the server they talk to
  (:func:`prefect_settings.talking_to`).
* Tests marked ``calculix`` need the ``ccx`` program: they are skipped, with the reason,
  when it is absent — unless ``NLUPDATE_REQUIRE_CCX=1`` (set by ``.ci/run``), which turns
  the skip into a failure so CI always runs them.
* The longest modules run first (:data:`LONGEST_MODULES`), so the two workers end together.
* Studies for the tests are built as data (:mod:`studies`); ``two_dof_study`` and
  ``two_dof_study_file`` hand out the whole-chain 2-DOF study.
"""
from __future__ import annotations

import gc
import os
import shutil
import tempfile
from pathlib import Path

import pytest

os.environ["PREFECT_HOME"] = tempfile.mkdtemp(prefix="nlupdate-test-prefect-")
# the user's nlupdate folder (cache secret, schedule registrations) of the session, not the tester's
os.environ["NLUPDATE_CONFIG_DIR"] = tempfile.mkdtemp(prefix="nlupdate-test-config-")
#: the two folders this process made (each pytest-xdist worker imports this file and makes its own)
_SESSION_FOLDERS = (os.environ["PREFECT_HOME"], os.environ["NLUPDATE_CONFIG_DIR"])
# the session's references computed once (tests/reference_cache.py): made by the first process,
# which the pytest-xdist workers inherit it from, and removed by that process
if not os.environ.get("NLUPDATE_TEST_REFERENCE_CACHE"):
    os.environ["NLUPDATE_TEST_REFERENCE_CACHE"] = tempfile.mkdtemp(prefix="nlupdate-test-references-")
    _SESSION_FOLDERS += (os.environ["NLUPDATE_TEST_REFERENCE_CACHE"],)
os.environ.pop("NLUPDATE_CACHE_SECRET_FILE", None)
os.environ.pop("PREFECT_API_URL", None)
# a run's Prefect server stops when no run of the session uses it (kept 300 s otherwise),
# so none outlives the suite; tests of keeping set their own time
os.environ["NLUPDATE_PREFECT_SERVER_KEEP_S"] = "0"
# a Prefect client with no API named starts an ephemeral server and gives it 20 s to answer,
# which a loaded machine overran (tests/test_crash_safety.py at load 7): a hang guard only
os.environ["PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS"] = "600"

import prefect_home  # noqa: E402
from nlupdate.orchestration.flows.environment import prepare_environment  # noqa: E402

prepare_environment()

_TEMPLATE: list = []  # the migration this process started (the xdist controller's, or a lone session's)


def pytest_configure(config):
    """In the xdist controller of a session with workers: start migrating the template Prefect
    database (a session without workers, such as one test file run alone, migrates its one
    home itself rather than wait for a template)."""
    if not hasattr(config, "workerinput") and (config.getoption("numprocesses", default=None) or 0):
        _TEMPLATE.append(prefect_home.start_template())


def pytest_unconfigure(config):
    """Remove the session's Prefect home (its database: ~30 MB), nlupdate folder and (in the
    process that made it) folder of references; the session server has stopped by now."""
    for folder in _SESSION_FOLDERS:
        shutil.rmtree(folder, ignore_errors=True)
    while _TEMPLATE:
        prefect_home.remove_template(_TEMPLATE.pop())


#: The modules that take longest (4 s or more summed over their tests on two workers),
#: longest first. They are handed to the workers first (``--no-loadscope-reorder`` in
#: pyproject.toml; pytest-xdist would otherwise order modules by their number of tests and
#: leave long modules of few tests for the end), so the two workers finish together. The
#: first four hold the slow suite's longest tests; the rest are in the order of their
#: default-suite times (every test's wall time, setup included, in a whole default-suite run
#: on 2026-11-29 16:03-16:22 UTC at load 5, summed per module: test_validate_held_impact,
#: test_backbone_forms and test_study_archives_brb, 54-59 s there, had been 48th-60th), then
#: the modules under 8 s there (or newer than it; test_noisy_amplitudes ~30 s by its author)
#: in the order they were given. test_amplitude_band_cut and test_validate grew after it (a
#: run at 16:31-17:06: 47 and 45 s of CPU, as test_validate_response_controlled's 51 s) and
#: stand beside that module. Modules of 3-8 s added since stand with those of their time.
LONGEST_MODULES = (
    "test_brb_example.py", "test_reduction_nonlinear.py", "test_fe_validation.py", "test_hill_reduction.py",
    "test_flows.py", "test_schedule.py", "test_interrupts.py", "test_validate_held_impact.py",
    "test_backbone_forms.py", "test_study_archives_brb.py", "test_demo_identification.py", "test_crash_safety.py",
    "test_validate_response_controlled.py", "test_amplitude_band_cut.py", "test_validate.py",
    "test_harmonic_balance.py", "test_examples_py.py", "test_real_measurements.py",
    "test_identification_single_frequency.py", "test_discovery.py", "test_stepped_sine_truth.py",
    "test_linear_frf_consistency.py", "test_progress.py", "test_examples.py", "test_iwan_identification.py",
    "test_periodic_truth.py", "test_archive_cli.py", "test_hb_cli_study.py", "test_decay_fit.py",
    "test_amplitude_modal.py", "test_iwan_response.py", "test_kept_server.py", "test_noisy_amplitudes.py",
    "test_test_type_truth.py", "test_discovery_hard.py", "test_readme_identify.py", "test_amplitude_limits.py",
    "test_joint_band.py", "test_doc_snippets.py", "test_trust_warnings.py", "test_full_band_export.py",
    "test_archive_compare_studies.py", "test_discovery_modal.py", "test_solver_vs_time_integration.py",
    "test_layering.py", "test_backbone_samples.py", "test_identification_prd.py", "test_time_integration.py",
    "test_line_band.py", "test_circle_fit.py", "test_frf_speed_benchmark.py", "test_answer_from_cache.py",
    "test_partition.py", "test_tanh_friction.py", "test_optional_dask.py", "test_time_history.py",
    "test_validate_line_forces.py", "test_impact.py", "test_reporting_archive.py", "test_discovery_places.py",
    "test_bolted_beam_example.py", "test_ring_down.py", "test_joint_sources.py", "test_study_update.py",
    "test_calculix.py", "test_reporting_plots.py", "test_validate_informative.py", "test_server_app.py",
    "test_updating_stops.py", "test_identification_cli.py", "test_docs_blocks.py", "test_validate_held_type.py",
    "test_discovery_cli.py", "test_validate_linear_limit.py", "test_response_controlled.py",
    "test_study_amplitude.py", "test_runner.py", "test_discovery_microslip.py",
    "test_validate_auto_extrapolation.py", "test_calculix_example.py", "test_held_runs_truth.py",
    "test_bad_input.py", "test_archive_safety.py", "test_weak_messages.py", "test_transmitter_beam.py",
    "test_amplitude_trust.py", "test_model_numbers.py", "test_stiffening_warning.py", "test_held_flat_beyond.py",
    "test_mapdl.py", "test_discovery_jacobian.py", "test_study_validation_impact.py",
    "test_closed_form_roots.py", "test_cli_chain.py", "test_study_hold_out_type.py", "test_line_background.py",
    "test_input_expansion.py", "test_phase_resonance.py", "test_element_registry.py", "test_calculix_reduction.py",
    "test_test_type_uff.py", "test_result_reprs.py", "test_bands.py", "test_study_schema.py",
)


def pytest_collection_modifyitems(config, items):
    """The longest modules first (:data:`LONGEST_MODULES`); the rest in collection order."""
    missing = [name for name in LONGEST_MODULES if not (Path(__file__).parent / name).is_file()]
    if missing:
        raise pytest.UsageError(f"tests/conftest.py LONGEST_MODULES names modules that do not exist: {missing}")
    rank = {name: k for k, name in enumerate(LONGEST_MODULES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def pytest_collection_finish(session):
    """Python's cyclic garbage collector stops re-scanning what collection made (every
    module and test: frozen) and runs after 10,000 new objects instead of 700: its passes
    took 3.8 s per worker over five long modules, 1.4-1.7 s after (the tests' figures,
    frames and Prefect objects make much cyclic garbage)."""
    gc.collect()
    gc.freeze()
    gc.set_threshold(10_000, 20, 20)


def pytest_runtest_setup(item):
    prefect_home.seed(_SESSION_FOLDERS[0])  # the session's Prefect home; a no-op once it has its database
    if "calculix" in item.keywords and not shutil.which("ccx"):
        if os.environ.get("NLUPDATE_REQUIRE_CCX") == "1":
            pytest.fail("ccx is required here (NLUPDATE_REQUIRE_CCX=1) but not on PATH: apt-get install -y calculix-ccx")
        pytest.skip("needs CalculiX (ccx): apt-get install -y calculix-ccx")


@pytest.fixture
def two_dof_study() -> dict:
    """The flow tests' whole-chain 2-DOF study as a dict (:mod:`studies`), a fresh copy per test."""
    from studies import two_dof_study as study

    return study()


@pytest.fixture
def two_dof_study_file(tmp_path, two_dof_study):
    """The 2-DOF study written to ``tmp_path/study.toml`` with its model path absolute."""
    from studies import write_study

    return write_study(tmp_path / "study.toml", two_dof_study)


@pytest.fixture(scope="session")
def prefect_server():
    """One Prefect server for the session; yields its API URL (also in PREFECT_API_URL)."""
    from nlupdate.orchestration.flows.server import prefect_api

    # its set-up took 69 s at load 8 (test_crash_safety run alone; the limit was 120 s): a hang guard only
    with prefect_api(lambda message: None, startup_timeout_s=600) as url:
        yield url
