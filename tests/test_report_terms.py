"""What a new reader meets first is explained where they meet it: the line before the
updating runs says what their names say (each parameter's ``description`` and unit, the
difference formulas' O(·)), the report's summary ends with a ``Terms:`` line for the
words it uses (printed on the terminal with it), and the report's run line says what its
time counts. Each explanation is read from the declaration that owns the word, so a word
the text does not use is not explained.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from nlupdate.core.correlation.metrics import FRAC_MEANING
from nlupdate.core.identification.methods import METHODS
from nlupdate.core.updating.sensitivity import ORDER_MEANING
from nlupdate.reporting.archive import write_archive
from nlupdate.reporting.markdown import run_line
from nlupdate.reporting.report import SIGMA_OFF_MEANING, summary_section, terms_line
from nlupdate.study import run_study, study_from_text
from studies import small_two_dof_study, study_text

K1 = "stiffness of the spring from m1 to the ground"
#: what the identified cubic + Jenkins parameters are (docs/methods.md §2, the elements' docstrings)
K3_MEANING = "cubic stiffness coefficient, force = k3·x³ (negative: softening)"
KF_MEANING = "stuck stiffness of the Jenkins element (spring in series with the slider)"
SLIP_MEANING = "force at which the Jenkins slider slips"


@pytest.fixture(scope="module")
def ran():
    """The small 2-DOF study (k1 alone, forward differences) with k1 described as :data:`K1`,
    run in this process: (its result, the progress lines it said)."""
    data = small_two_dof_study()
    data["parameters"][0]["description"] = K1
    said: list[str] = []
    return run_study(study_from_text(study_text(data), Path("small.toml")), said.append), said


def test_the_updating_runs_are_introduced_and_the_summary_explains_its_terms(ran, tmp_path):
    result, said = ran
    intro = f"updating: 1 run; parameters k1 ({K1}, N/m); O(h): {ORDER_MEANING}"
    assert intro in said and said.index(intro) + 1 == next(
        i for i, line in enumerate(said) if line.startswith("updating: eigensensitivity forward O(h) {k1}")), said
    assert "identification: PRD (pseudo-receptance difference), 4 Monte-Carlo samples" in said, said

    folder = write_archive(result, tmp_path / "archive", {"started_utc": "2026-11-30T00:38:53.685259+00:00",
                                                          "wall_time_s": 23.43, "orchestration": "test"})
    report = (folder / "report.md").read_text()
    assert "started 2026-11-30 00:38:53 UTC; its steps took 23.4 s (wall clock; not counting writing this archive); " \
           "test." in report
    terminal = summary_section(report).splitlines()
    (terms,) = [line for line in terminal if line.startswith("Terms: ")]
    # the best run is an eigensensitivity run updating k1, identified by PRD (cubic + Jenkins,
    # as the demo: k3, kf, slip_force); the prediction's FRAC; no truth beside the values (a
    # truth model file), so no "σ off"
    assert "* **Identified** (physical elements: cubic + jenkins, PRD): k3 = " in report
    assert terms == (f"Terms: PRD = {METHODS['prd'].long_name} (the identification method); k3 = {K3_MEANING}; "
                     f"kf = {KF_MEANING}; slip_force = {SLIP_MEANING}; k1 = {K1}; O(h) = {ORDER_MEANING}; "
                     f"FRAC = {FRAC_MEANING}."), terms
    assert terminal.index(terms) > max(i for i, line in enumerate(terminal) if line.startswith("* "))
    # the Updating section names the runs' parts before its table
    updating = report.split("## Updating\n", 1)[1]
    assert updating.lstrip().startswith(f"An eigensensitivity run is named by its difference formula — O(h) = "
                                        f"{ORDER_MEANING} — and the parameters it updates, in braces. "
                                        f"Parameters: k1 ({K1}, N/m).")


def test_the_run_line_says_what_its_time_counts():
    """The flows stop the clock before writing the archive, after the server started: a
    flow run's line leaves both out, a run in one process (no flow run) the archive."""
    run = {"started_utc": "2026-11-30T01:06:26.5+01:00", "wall_time_s": 71.34, "orchestration": "Prefect flow"}
    assert run_line({"run_id": "r", "run": {**run, "flow_run_id": "abc"}}) == (
        "Run `r`, started 2026-11-30 00:06:26 UTC; its steps took 71.3 s (wall clock; not counting starting the "
        "Prefect server or writing this archive); Prefect flow.")
    assert "(wall clock; not counting writing this archive)" in run_line({"run_id": "r", "run": run})
    assert run_line({"run_id": "r", "run": {}}).startswith("Run `r`, started ?; its steps took – s")


def test_a_term_the_text_does_not_use_is_not_explained(ran):
    result, _ = ran
    undescribed = tuple(dataclasses.replace(p, description="") for p in result.study.parameters)
    result = dataclasses.replace(result, study=dataclasses.replace(result.study, parameters=undescribed))
    assert terms_line(result, "nothing here") == ""
    assert terms_line(result, "k1 = 9e+05 N/m (truth 1e+06 N/m; 2.1σ off)") == f"Terms: Nσ off = {SIGMA_OFF_MEANING}."
    # a parameter without a description is not a term; DDF is not the method this study used
    assert terms_line(result, "k1 = 9e+05, DDF, FRAC 0.9") == f"Terms: FRAC = {FRAC_MEANING}."


def test_identified_element_parameters_are_explained_by_their_reported_names(ran):
    """A repeated element's parameters are reported numbered (``kf_1``, ``kf_2``): the Terms
    line explains the numbers the text uses in one term, also where a number stands in
    words (a diverged parameter), and leaves out a parameter the text does not name."""
    from nlupdate.core.identification.dfmodels import PhysicalModel

    result, _ = ran
    ident = result.identification
    model = PhysicalModel(("jenkins", "cubic", "jenkins"))
    two = dataclasses.replace(ident, result=dataclasses.replace(ident.result, model=model))
    result = dataclasses.replace(result, identification=two)
    text = "Identified (PRD): kf_1 = 3e+04 N/m; kf_2 diverged (1e+40 N/m): the data support no finite value of it"
    assert terms_line(result, text) == (f"Terms: PRD = {METHODS['prd'].long_name} (the identification method); "
                                        f"kf_1, kf_2 = {KF_MEANING} — _1, _2: the jenkins elements in the order listed.")
    # k3 inside another word (k3x) or a longer name (slip_force_12) is not the parameter
    assert terms_line(result, "k3x = 1; slip_force_12 = 2") == ""
