"""Every study table whose keys are plain settings is declared once (issue 36,
:mod:`nlupdate.study.declared`): the reader's allowed keys, each key's check and default,
docs/study-files.md's table of keys and, where a command or the Python API takes the same
setting, its option or keyword follow from the declaration. Compared here table by table;
and a key declared on a table's class alone is shown to reach the reader, its message, the
docs and the command line.

The study every check starts from (:data:`BASE`) holds every declared table and loads; each
check changes one key."""
from __future__ import annotations

import argparse
import copy
import dataclasses
import importlib
import inspect
import tomllib
from pathlib import Path

import pytest
import tomli_w

from nlupdate.app import api
from nlupdate.app.cli import build_parser
from nlupdate.app.cli.settings_options import add_setting_options, flag_of, setting_values
from nlupdate.settings import docs_table, setting, settings_of
from nlupdate.study import declared, sections
from nlupdate.study.declared import TABLES, declared_keys
from nlupdate.study.keys_docs import with_generated_tables
from nlupdate.study.loading import study_from_text
from nlupdate.study.reader import StudyError
from nlupdate.study.spec import ComparisonSpec, PredictionSpec, ValidationSpec

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "study-files.md"

BASE = """
[study]
name = "schema"

[measured]
file = "frf.csv"

[identification]
response_dof = "0"
input_dof = "0"

[adapter]
kind = "lumped"
options = { masses = [0.1, 0.5], stiffnesses = [0.8e6, 1.2e6, 1.0e6] }

[[parameters]]
name = "k1"
start = 0.8e6
lower = 0.5e6
upper = 1.5e6

[targets]
frequencies_hz = [267.97, 732.20]

[updating]

[eigensensitivity]

[optimisation]

[[optimisation.candidates]]
parameters = ["k1"]

[comparison]

[prediction]

[validation]

[amplitude]
impact = ["frf.csv"]
"""
SIMULATED = """
[study]
name = "schema-simulated"

[measured.simulate]
input_dof = "x1"
forces_n = [1.0]
frequencies_hz = [200.0, 300.0, 11]

[measured.simulate.adapter]
kind = "lumped"
options = { masses = [0.1, 0.5], stiffnesses = [0.8e6, 1.2e6, 1.0e6] }
"""
#: a value no declared form takes (a list of a list of a list)
NOTHING = [[[]]]
#: table → (the source key of the base study, the other keys of which the table takes exactly one)
SOURCES = {"targets": ("frequencies_hz", ("identification", "from_identification", "amplitude_models")),
           "measured": ("file", ("files", "time_histories", "simulate"))}


def load(data: dict, folder: Path):
    (folder / "frf.csv").write_text("frequency_hz,force_level_n,response_dof,input_dof,h_real,h_imag\n"
                                    "1,1,0,0,1e-6,0\n")
    return study_from_text(tomli_w.dumps(data), folder / "study.toml")


def base_of(table: str) -> dict:
    return tomllib.loads(SIMULATED if table.startswith("measured.") else BASE)


def table_in(data: dict, table: str) -> tuple[dict, str]:
    """The mapping of ``table`` in a parsed study (the first entry of an array of tables) and
    its name in messages."""
    node: object = data
    for part in table.split("."):
        node = node[part]
    if isinstance(node, list):
        return node[0], f"{table} #1"
    return node, table


def test_the_base_studies_load(tmp_path):
    assert load(base_of("study"), tmp_path).validation == ValidationSpec()
    assert load(base_of("measured.simulate.adapter"), tmp_path).measured.simulate.adapter.kind == "lumped"


@pytest.mark.parametrize("table", list(TABLES))
def test_the_reader_allows_the_declared_keys(table):
    expected = set(declared_keys(table)) | ({"candidates"} if table == "optimisation" else set())
    assert sections.ALLOWED[table] == expected


@pytest.mark.parametrize("table", list(TABLES))
def test_the_docs_table_is_the_declaration(table):
    page = PAGE.read_text()
    assert with_generated_tables(page, [table]) == page, "run: python -m nlupdate.study.keys_docs docs/study-files.md"
    assert docs_table(declared_keys(table)) in page


@pytest.mark.parametrize("table, key", [(table, key) for table in TABLES for key in declared_keys(table)])
def test_every_declared_key_is_checked_by_its_declaration_in_one_line(tmp_path, table, key):
    data = base_of(table)
    mapping, where = table_in(data, table)
    base_source, others = SOURCES.get(table, ("", ()))
    if key in others:  # one source at a time: this one instead of the base's
        del mapping[base_source]
    mapping[key] = NOTHING
    with pytest.raises(StudyError) as raised:
        load(data, tmp_path)
    message = str(raised.value)
    form = declared_keys(table)[key][1].form()
    assert f"[{where}] key '{key}': expected {form}, got {NOTHING!r}" in message and len(message.splitlines()) == 1


@pytest.mark.parametrize("table", [t for t in TABLES if not t.startswith("measured.")])
def test_an_unknown_key_names_the_declared_ones(tmp_path, table):
    data = base_of(table)
    mapping, where = table_in(data, table)
    mapping["no_such_key"] = 1
    with pytest.raises(StudyError, match=rf"unknown key\(s\) \['no_such_key'\] in \[{where}\]; allowed: "):
        load(data, tmp_path)


def test_the_defaults_are_the_declarations_resolved_once(tmp_path):
    """An empty table is its class's defaults: the reader adds none of its own."""
    study = load(base_of("study"), tmp_path)
    assert study.validation == ValidationSpec() and study.comparison == ComparisonSpec()
    assert study.prediction == PredictionSpec() and study.prediction.harmonic_balance is None
    for (cls, own), value in ((TABLES["updating"][0], study.updating),
                              (TABLES["eigensensitivity"][1], study.eigensensitivity.options),
                              (TABLES["optimisation"][0], study.optimisation)):
        for name, (field, _) in settings_of(cls, own=own).items():
            assert getattr(value, name) == field.default, (cls.__name__, name)
    assert study.eigensensitivity.formulas == TABLES["eigensensitivity"][0][0]().formulas
    assert study.parameters[0].relative_step == declared_keys("parameters")["relative_step"][0].default
    assert study.candidates[0].name == "candidate 1" and study.name == "schema"


def test_the_prediction_keywords_of_the_api_are_the_declared_defaults():
    """``nlupdate.predict`` takes the ``[prediction]`` settings a single prediction has, with
    the same defaults."""
    keywords = inspect.signature(api.predict).parameters
    shared = [name for name in declared_keys("prediction") if name in keywords]
    assert shared == ["force_levels_n", "loss_factor", "sweep"]
    for name in shared:
        assert keywords[name].default == declared_keys("prediction")[name][0].default, name


def test_the_api_and_the_study_take_an_identified_loss_factor_alike():
    """``loss_factor = "identified"`` is the mean loss factor of the extracted linear modes, one
    rule (prediction.predict.chosen_loss_factor) for ``nlupdate.predict`` and ``[prediction]``;
    a number and ``low_force_fit`` pass through to the prediction."""
    from types import SimpleNamespace

    import numpy as np

    from nlupdate.core.prediction.predict import LOSS_FACTOR_SOURCES, chosen_loss_factor

    identification = SimpleNamespace(loss_factors=np.array([0.01, 0.04]))
    assert chosen_loss_factor("identified", identification) == 0.025
    assert chosen_loss_factor("low_force_fit", identification) == "low_force_fit"
    assert chosen_loss_factor(0.03, identification) == 0.03
    assert declared_keys("prediction")["loss_factor"][1].choices == LOSS_FACTOR_SOURCES


def test_a_driving_point_renamed_in_the_model_names_its_input_too():
    """One rule (prediction.predict.model_dofs) for ``nlupdate.predict`` and a study's
    ``[targets]``: ``model_response_dof`` alone at a driving point (the two-DOF study's measured
    "0"/"0" is the model's "x1") names the model's input too; the study needed both keys."""
    from nlupdate.core.prediction.predict import model_dofs
    from nlupdate.study import load_study
    from nlupdate.study.steps.measured import model_pair

    source = Path(__file__).parent / "data" / "studies" / "two_dof.toml"
    text = source.read_text()
    assert 'model_input_dof = "x1"\n' in text
    without = study_from_text(text.replace('model_input_dof = "x1"\n', ""), source)
    assert without.targets.model_input_dof is None
    assert model_pair(without) == ("x1", "x1") == model_pair(load_study(source))
    assert model_dofs("0", "0", "x1") == ("x1", "x1") and model_dofs("1", "0", "x1") == ("x1", "0")
    assert model_dofs("1", "0") == ("1", "0") and model_dofs("0", "0", "x1", "x2") == ("x1", "x2")


def test_the_update_api_takes_every_declared_option_of_the_methods():
    """``nlupdate.update``'s further keywords are the updating methods' declared settings:
    each one, given at its declared default, is taken by the run, and ``formula`` left out is
    the declared default. One differs, by the API's own design: its ``method`` chooses the
    updating method (so ``[optimisation] method``, the least-squares method, keeps its
    default there)."""
    from nlupdate.fe.adapters.base import Parameter

    model = api.fe_model("lumped", masses=[0.1, 0.5], stiffnesses=[0.8e6, 1.2e6, 1.0e6])
    parameters = [Parameter("k1", "N/m", 0.8e6, 0.5e6, 1.5e6)]
    study_formulas = TABLES["eigensensitivity"][0][0]().formulas
    assert api.update(model, parameters, [267.97]).history["formula"].iloc[0] == study_formulas[0]
    for method, tables in (("eigensensitivity", ("updating", "eigensensitivity")),
                           ("optimisation", ("updating", "optimisation"))):
        options = {name: field.default for table in tables for cls, own in TABLES[table]
                   for name, (field, _) in settings_of(cls, own=own).items()
                   if cls not in (TABLES["eigensensitivity"][0][0],) and name != "method"}
        result = api.update(model, parameters, [267.97], method=method, **options)
        assert result.converged and abs(result.frequencies_hz("final")[0] / 267.97 - 1) < 1e-3, method


def validate_options() -> dict[str, argparse.Action]:
    parser = build_parser(["validate"])
    command = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["validate"]
    return {action.dest: action for action in command._actions if action.option_strings}


def test_validate_takes_the_validation_keys_it_shares_with_the_study():
    """``nlupdate validate``'s options for the ``[validation]`` keys declared with one are made
    from the declaration (``--hold-out``, ``--input-dof``); its ``--hold-out-type`` (a type held
    out instead of levels, where a study does both) takes the same types."""
    options = validate_options()
    for name, (_, declaration) in settings_of(ValidationSpec).items():
        if declaration.flag == "":  # the command's own forms: --model a,b; --shape
            continue
        assert options[name].option_strings[0] == flag_of(name, declaration), name
    assert tuple(options["hold_out_type"].choices) == settings_of(ValidationSpec)["hold_out_type"][1].choices
    for name in ("impact", "channel"):  # the command's own (shared with --hold-out-type's sources), one dest each
        assert name in settings_of(ValidationSpec) and options[name].option_strings[0] == f"--{name}", name
    parser = build_parser(["validate"])
    args = parser.parse_args(["validate", "--hold-out", "0.49,0.97", "--input-dof", "0", "--out", "x"])
    assert ValidationSpec(**setting_values(args, ValidationSpec)) == ValidationSpec(hold_out=(0.49, 0.97), input_dof="0")
    args = parser.parse_args(["validate", "--out", "x"])
    assert ValidationSpec(**setting_values(args, ValidationSpec)).hold_out == "each"
    assert parser.parse_args(["validate", "--hold-out", "top", "--out", "x"]).hold_out == "top"
    with pytest.raises(SystemExit):
        parser.parse_args(["validate", "--hold-out", "middle", "--out", "x"])


def test_response_controlled_takes_the_same_choices_in_the_study_and_the_command(tmp_path):
    """``[validation] response_controlled`` and ``--response-controlled``: auto, off or kept
    from one declaration; a study's earlier true/false still reads (as auto/off); anything
    else is one line naming the key and the new form."""
    choices = settings_of(ValidationSpec)["response_controlled"][1].choices
    assert choices == ("auto", "off", "kept") and tuple(validate_options()["response_controlled"].choices) == choices
    parser = build_parser(["validate"])
    args = parser.parse_args(["validate", "--response-controlled", "kept", "--out", "x"])
    assert ValidationSpec(**setting_values(args, ValidationSpec)).response_controlled == "kept"
    with pytest.raises(SystemExit):
        parser.parse_args(["validate", "--response-controlled", "true", "--out", "x"])
    for given, read in [("kept", "kept"), ("off", "off"), ("auto", "auto"), (True, "auto"), (False, "off")]:
        data = base_of("validation")
        data["validation"]["response_controlled"] = given
        assert load(data, tmp_path).validation.response_controlled == read, given
    assert load(base_of("validation"), tmp_path).validation.response_controlled == "auto"
    data = base_of("validation")
    data["validation"]["response_controlled"] = "yes"
    with pytest.raises(StudyError) as error:
        load(data, tmp_path)
    message = str(error.value)
    assert "\n" not in message and "[validation] key 'response_controlled'" in message and '"kept"' in message, message


@dataclasses.dataclass(frozen=True)
class Extended(ValidationSpec):
    """[validation] with one more key, declared here alone."""

    taper_fraction: float = setting(0.1, kind="number", minimum=0, maximum=1, unit="fraction of the band",
                                    meaning="a new key")


@pytest.fixture
def extended_validation(monkeypatch):
    monkeypatch.setitem(TABLES, "validation", ((Extended, False),))
    importlib.reload(sections)
    yield
    monkeypatch.undo()
    importlib.reload(sections)


def test_a_key_declared_on_the_class_alone_reaches_every_door(extended_validation, tmp_path):
    data = base_of("validation")
    data["validation"]["taper_fraction"] = 0.25
    assert load(data, tmp_path).validation.taper_fraction == 0.25
    assert load(base_of("validation"), tmp_path).validation.taper_fraction == 0.1
    wrong = copy.deepcopy(data)
    wrong["validation"]["taper_fraction"] = 2
    with pytest.raises(StudyError, match=r"\[validation\] key 'taper_fraction': expected a number in \[0, 1\], got 2"):
        load(wrong, tmp_path)
    page = with_generated_tables(PAGE.read_text(), ["validation"])
    assert "| `taper_fraction` | a number in [0, 1] | fraction of the band | `0.1` | a new key |" in page
    parser = argparse.ArgumentParser()
    add_setting_options(parser, declared.classes("validation")[0])
    assert parser.parse_args(["--taper-fraction", "0.5"]).taper_fraction == 0.5


def test_amplitude_takes_the_defaults_of_the_amplitude_table():
    """``nlupdate amplitude``'s options that a study's ``[amplitude]`` key shares default to
    that key's declaration (one default for both doors)."""
    from nlupdate.study.amplitude import AmplitudeSpec

    parser = build_parser(["amplitude"])
    args = parser.parse_args(["amplitude", "--out", "x"])
    declared = AmplitudeSpec()
    for name in ("ring_down_fit", "response_unit", "backbone", "order", "mode"):
        assert getattr(args, name) == getattr(declared, name), name
