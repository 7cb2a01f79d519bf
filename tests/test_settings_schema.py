"""One declaration per setting (issue 36): the study reader, the command line, the Python
API and docs/study-files.md all read the identification settings' declaration.

The doors are compared with each other, and a new key declared on the class alone is shown
to appear in every door."""
from __future__ import annotations

import argparse
import dataclasses
import tomllib
from pathlib import Path

import pytest

from nlupdate.app.cli import build_parser
from nlupdate.app.cli.settings_options import add_setting_options, flag_of, setting_values
from nlupdate.core.identification.settings import IdentificationSettings
from nlupdate.settings import SettingError, docs_table, from_mapping, setting, settings_of
from nlupdate.study.keys_docs import with_generated_tables
from nlupdate.study.sections import ALLOWED

ROOT = Path(__file__).resolve().parents[1]


def identify_options() -> dict[str, str]:
    """dest → option string of every option ``nlupdate identify`` has."""
    parser = build_parser(["identify"])
    command = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["identify"]
    return {action.dest: action.option_strings[0] for action in command._actions if action.option_strings}


def test_the_docs_table_is_the_declaration():
    page = (ROOT / "docs" / "study-files.md").read_text()
    assert with_generated_tables(page) == page, "run: python -m nlupdate.study.keys_docs docs/study-files.md"
    assert docs_table(IdentificationSettings) in page


def test_every_declared_key_is_a_study_key_and_an_identify_option():
    declared = settings_of(IdentificationSettings)
    assert ALLOWED["identification"] == set(declared)
    options = identify_options()
    for name, (_, declaration) in declared.items():
        if declaration.flag == "":  # the measured curve and band: the measured-data options name them
            continue
        assert options.get(name) == flag_of(name, declaration), name
    # the old hand-written spellings are kept by the declaration
    assert options["frequency_hz"] == "--frequency" and options["smoothing_window"] == "--smooth-linear"


def test_the_three_doors_build_the_same_settings(tmp_path):
    """One set of values written as a study table, as options and as keywords."""
    study = tomllib.loads('''
        response_dof = "0"
        input_dof = "0"
        method = "prd"
        elements = ["cubic", "jenkins"]
        frequency_hz = 712.5
        high_forces_n = [2, 5.5]
        noise_fraction = 0.02
        samples = 30
        seed = 4
        linear_modes_hz = [700, 1100.5]
        coherence_threshold = 0.9
    ''')
    from_study = from_mapping(IdentificationSettings, study)
    parser = argparse.ArgumentParser()
    add_setting_options(parser, IdentificationSettings)
    args = parser.parse_args(["--method", "prd", "--elements", "cubic,jenkins", "--frequency", "712.5",
                              "--high-forces", "2,5.5", "--noise-fraction", "0.02", "--samples", "30", "--seed", "4",
                              "--linear-modes-hz", "700,1100.5", "--coherence-threshold", "0.9"])
    from_cli = IdentificationSettings(response_dof="0", input_dof="0", **setting_values(args, IdentificationSettings))
    from_api = IdentificationSettings(response_dof="0", input_dof="0", method="prd", elements=("cubic", "jenkins"),
                                      frequency_hz=712.5, high_forces_n=(2.0, 5.5), noise_fraction=0.02, samples=30,
                                      seed=4, linear_modes_hz=(700.0, 1100.5), coherence_threshold=0.9)
    assert from_study == from_cli == from_api


@pytest.mark.parametrize("key, value, expected", [
    ("samples", 1, "an integer in [2, 100000]"),
    ("samples", 2.5, "an integer in [2, 100000]"),
    ("seed", True, "an integer ≥ 0"),
    ("method", "magic", "one of ['prd', 'ddf']"),
    ("force_pair_n", [1, 2, 3], "a list of 2 numbers ≥ 0"),
    ("modal_band_fraction", 0.5, "a number in (0, 0.5)"),
    ("coherence_threshold", float("nan"), "a number in [0, 1]"),
    ("elements", "cubic", "a list of strings"),
    ("typo_key", 1, "one of the keys response_dof, input_dof"),
])
def test_a_wrong_value_names_its_key_and_the_declared_form(key, value, expected):
    with pytest.raises(SettingError) as raised:
        from_mapping(IdentificationSettings, {"response_dof": "0", "input_dof": "0", key: value})
    assert raised.value.key == key and expected in raised.value.expected


def test_the_study_reader_says_the_declared_form_in_one_line(tmp_path, capsys):
    from nlupdate.app.cli import main

    study = tmp_path / "study.toml"
    study.write_text('[study]\nname = "x"\n[measured]\nfile = "frf.csv"\n'
                     '[identification]\nresponse_dof = "0"\ninput_dof = "0"\nsamples = 1\n')
    (tmp_path / "frf.csv").write_text("frequency_hz,force_level_n,response_dof,input_dof,h_real,h_imag\n"
                                      "1,1,0,0,1e-6,0\n")
    assert main(["update", str(study), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[identification] key 'samples': expected an integer in [2, 100000], got 1" in err[0]


def test_a_key_declared_on_the_class_alone_reaches_every_door():
    """What adding a study key takes: its declaration. The command line, the study reader
    and the docs table follow (shown on a subclass with one more declared key)."""

    @dataclasses.dataclass(frozen=True)
    class Extended(IdentificationSettings):
        taper_fraction: float = setting(0.0, kind="number", minimum=0, maximum=1, unit="fraction of the band",
                                        meaning="a new key")

    parser = argparse.ArgumentParser()
    add_setting_options(parser, Extended)
    args = parser.parse_args(["--taper-fraction", "0.25"])
    assert setting_values(args, Extended) == {"taper_fraction": 0.25}
    with pytest.raises(SystemExit):
        parser.parse_args(["--taper-fraction", "2"])
    read = from_mapping(Extended, {"response_dof": "0", "input_dof": "0", "taper_fraction": 0.5})
    assert read.taper_fraction == 0.5
    assert "| `taper_fraction` | a number in [0, 1] | fraction of the band | `0.0` | a new key |" in docs_table(Extended)
