"""The issue's "weak" messages, one table per cause: each mistake ends as one line that blames
the right thing (file, field, expected form), exit code 2, no traceback, nothing written;
each signal that is not an error is a warning, not an information line.

Every case runs the real command line in this process (:func:`cli_runs.run_cli`).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cli_runs import run_cli
from test_time_history import stepped_record

FREQUENCIES = [18.0, 20.0, 22.0]


def assert_refused(result: tuple[int, str, str], folder: Path, *fragments: str) -> str:
    """Exit code 2, one line on stderr holding every fragment, no traceback, nothing in ``folder``."""
    code, _, err = result
    lines = err.strip().splitlines()
    assert code == 2, (code, err)
    assert "Traceback" not in err, err
    assert len(lines) == 1, err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert sorted(p.name for p in folder.iterdir()) == [], "something was written"
    return lines[0]


def _clipped(values: np.ndarray, fraction: float) -> np.ndarray:
    limit = fraction * np.abs(values).max()
    return np.clip(values, -limit, limit)


def clipped_sine_distortion(fraction: float) -> float:
    """√Σ_{h=2,3}|X_h|²/|X_1| of cos clipped at ``fraction`` of its amplitude (FFT of one period)."""
    spectrum = np.abs(np.fft.rfft(_clipped(np.cos(2 * np.pi * np.arange(4096) / 4096), fraction)))
    return float(np.hypot(spectrum[2], spectrum[3]) / spectrum[1])


# ------------------------------------------------------------------ time histories: the signal is not what was blamed
def _record(change, **options) -> pd.DataFrame:
    frame = stepped_record(FREQUENCIES, [1.0], dwell_s=4.0, **options)
    return change(frame.copy())


def _without_time(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.drop(columns="time_s")


def _zero(column):
    def change(frame):
        frame[column] = 0.0
        return frame
    return change


def _varying_fs(frame):
    frame = _without_time(frame)
    frame["Fs"] = 2000.0
    frame.loc[5, "Fs"] = 1000.0
    return frame


def _logged_times_three(frame):
    frame["frequency_hz"] = 3 * frame["frequency_hz"]
    return frame


TIME_HISTORY_MISTAKES = {
    "force is 0": (_zero("force"), [], ("record.csv: column 'force' (the reference) is 0 at every sample",)),
    "response is 0": (_zero("tip"), [], ("record.csv: column 'tip' (the response) is 0 at every sample",)),
    "header only": (lambda f: f.iloc[:0], [], ("record.csv: no samples", "a header without data rows")),
    "Fs varies": (_varying_fs, [], ("record.csv: column 'Fs' (sample rate) varies (1000…2000 Hz)",)),
    "--sample-rate 0": (_without_time, ["--sample-rate", "0"], ("--sample-rate 0: expected a number > 0",)),
    "--reference-calibration 0": (lambda f: f.rename(columns={"force": "voltage"}), ["--reference-calibration", "0"],
                                  ("--reference-calibration 0: expected a number > 0",)),
    "logged frequency x3": (_logged_times_three, [], (
        "record.csv: the dwell at 54 Hz: the reference's first harmonic", "oscillates at about 1",
        "is the logged 'frequency_hz' or the sample rate wrong?")),
    "sample rate x100": (_without_time, ["--sample-rate", "200000"], (
        "record.csv: the dwell at 18 Hz", "oscillates at about 1800 Hz")),
}


def folders(tmp_path):
    """(inputs, out): a folder for the case's files and an output folder that must stay empty."""
    inputs, out = tmp_path / "inputs", tmp_path / "out"
    inputs.mkdir()
    out.mkdir()
    return inputs, out


@pytest.mark.parametrize("case", TIME_HISTORY_MISTAKES, ids=list(TIME_HISTORY_MISTAKES))

def test_time_history_mistakes_blame_the_signal(tmp_path, capsys, case):
    change, options, fragments = TIME_HISTORY_MISTAKES[case]
    _record(change).to_csv(tmp_path / "record.csv", index=False)
    out = tmp_path / "out"
    out.mkdir()
    result = run_cli(capsys, "frf", tmp_path / "record.csv", *options, "--out", out / "frf.csv")
    assert_refused(result, out, "nlupdate frf: error:", *fragments)


@pytest.mark.parametrize("column, warning", [
    ("tip", r"the dwell at 20 Hz: the harmonic distortion of 'tip' is ([0-9.]+) % \(above 10 %\)"),
    ("force", r"the dwell at 20 Hz: the reference's harmonic distortion is ([0-9.]+) % \(above 10 %\)"),
])
def test_a_clipped_channel_is_a_warning(tmp_path, capsys, column, warning):
    frame = _record(lambda f: f, noise=0.0, distortion=0.0)
    dwell = frame["frequency_hz"] == 20.0  # clipped at half its own amplitude in the resonant dwell
    frame.loc[dwell, column] = _clipped(frame.loc[dwell, column].to_numpy(), 0.5)
    frame.to_csv(tmp_path / "record.csv", index=False)
    code, out, err = run_cli(capsys, "frf", tmp_path / "record.csv", "--out", tmp_path / "frf.csv")
    assert code == 0, err
    found = re.search(re.escape(f"nlupdate: warning: {tmp_path / 'record.csv'}: ") + warning, err)
    assert found, err
    # harmonic 3 of the clipped sine, 22.6 % (the transient left in the dwell moves the clipping level slightly)
    assert float(found.group(1)) == pytest.approx(100 * clipped_sine_distortion(0.5), rel=0.02)
    assert err.count("distortion") == 1, err  # the other dwells are not clipped


def test_a_dwell_whose_harmonics_outweigh_the_first_is_left_out(tmp_path, capsys):
    frame = _record(lambda f: f)
    dwell = frame["frequency_hz"] == 22.0
    t = frame.loc[dwell, "time_s"].to_numpy()
    size = frame.loc[dwell, "tip"].abs().max()
    frame.loc[dwell, "tip"] += 2 * size * np.cos(2 * np.pi * 66.0 * t)  # harmonic 3 twice the first
    frame.to_csv(tmp_path / "record.csv", index=False)
    code, out, err = run_cli(capsys, "frf", tmp_path / "record.csv", "--out", tmp_path / "frf.csv")
    assert code == 0, err
    assert "the dwell at 22 Hz left out: the harmonic distortion of 'tip' is" in err, err
    assert sorted(pd.read_csv(tmp_path / "frf.csv")["frequency_hz"].round(3)) == [18.0, 20.0]


# ------------------------------------------------------------------ measured FRF files: the field at fault is named
def _two_dof_table(levels=(0.01, 100.0)) -> pd.DataFrame:
    """A measured table of a linear SDOF (the reader does not care what it is)."""
    f = np.linspace(60.0, 120.0, 31)
    h = 1.0 / (3.2e5 * (1 + 0.02j) - (2 * np.pi * f) ** 2)
    return pd.concat([pd.DataFrame({"frequency_hz": f, "force_level_n": level, "response_dof": "tip",
                                    "input_dof": "tip", "h_real": h.real, "h_imag": h.imag}) for level in levels],
                     ignore_index=True)


def _uff(folder: Path, name: str, *datasets: dict, direction: int | None = None) -> Path:
    from test_measured_run_levels import export

    path = export(folder / name, list(datasets))
    if direction is not None:  # pyuff writes only -6…6: patch record 6's response direction field
        lines = path.read_text().splitlines(True)
        row = next(k for k, line in enumerate(lines) if line.strip() == "58") + 6
        column = 5 + 10 + 5 + 10 + 1 + 10 + 10
        lines[row] = lines[row][:column] + f"{direction:4d}" + lines[row][column + 4:]
        path.write_text("".join(lines))
    return path


def _dataset(**fields) -> dict:
    from test_measured_run_levels import F, dataset, receptance

    return dataset(receptance(F, 3.2e5), "N", **fields)


def _csv(folder: Path) -> Path:
    _two_dof_table().to_csv(folder / "frf.csv", index=False)
    return folder / "frf.csv"


def _spaced_csv(folder: Path) -> list[object]:
    text = _two_dof_table().to_csv(index=False).replace(",", ", ")
    (folder / "frf.csv").write_text(text)
    return ["--measured", folder / "frf.csv"]


def _one_level_csv(folder: Path, *levels: str) -> list[object]:
    _two_dof_table([1.0]).drop(columns="force_level_n").to_csv(folder / "frf.csv", index=False)
    return ["--measured", folder / "frf.csv", *[a for level in levels for a in ("--level", level)]]


MEASURED_MISTAKES = {
    "--band -50:760": (lambda d: ["--measured", _csv(d), "--band", "-50:760"],
                       ("--band '-50:760': expected LOW:HIGH in Hz with 0 ≤ LOW < HIGH",)),
    "', ' separator": (_spaced_csv, ("frf.csv: the header's column names have blanks around the commas",
                                     "separator ', '")),
    "two levels for one file": (lambda d: _one_level_csv(d, "frf.csv=1", f"{d / 'frf.csv'}=2"), (
        "levels given for the file", "frf.csv contradict each other (frf.csv=1,", "frf.csv=2")),
    "run level twice": (lambda d: ["--measured", _uff(d, "run.uff", _dataset(id2="Run 3")), "--level",
                                   "run.uff#Run 3=1", "--level", "Run 3=2"], (
        "levels given for the run 'Run 3' of", "run.uff contradict each other (run.uff#Run 3=1, Run 3=2")),
    "file and run level": (lambda d: ["--measured", _uff(d, "run.uff", _dataset(id2="Run 3")), "--level",
                                      "run.uff=1", "--level", "Run 3=2"], (
        "run.uff: levels given for the file (1) and for its run 'Run 3' (2) contradict each other",)),
    "UFF z-axis level 0": (lambda d: ["--measured", _uff(d, "run.uff", _dataset(z_axis_spec_data_type=13))],
                           ("run.uff, dataset 0: the z-axis level (record 7 field 6; specific data type 13",
                            "is 0; expected a level > 0")),
    "UFF z-axis level < 0": (lambda d: ["--measured", _uff(d, "run.uff", _dataset(z_axis_spec_data_type=13,
                                                                                   z_axis_value=-2.0))],
                             ("run.uff, dataset 0: the z-axis level", "is -2; expected a level > 0")),
    "UFF direction code 9": (lambda d: ["--measured", _uff(d, "run.uff", _dataset(id2="F=1N"), direction=9)],
                             ("run.uff, dataset 0: response direction code 9 (record 6); expected 0 (scalar) or ±1…±6",)),
    "UFF ID line against z-axis": (lambda d: ["--measured", _uff(
        d, "runs.uff", _dataset(z_axis_spec_data_type=13, z_axis_value=1.0, id2="F=1N"),
        _dataset(z_axis_spec_data_type=13, z_axis_value=1.0, id2="F=2N"))],
        ("runs.uff, dataset 1 (run 'F=2N'): the z-axis level 1 N", "the ID line 'F=2N' (2 N) contradict each other")),
    "coherence abscissa against record 7": (lambda d: ["--measured", _uff(
        d, "run.uff", _dataset(id2="F=1N"),
        _dataset(id2="F=1N", func_type=6, ord_data_type=2, data=np.full(121, 0.9), id4="abscissa_hz=10.0,0.5"))],
        ("run.uff, dataset 1: the ID line 'abscissa_hz=10.0,0.5' (10 Hz + 0.5 Hz steps) and record 7 (abscissa "
         "minimum 60 Hz, increment 0.5 Hz) contradict each other",)),
}


@pytest.mark.parametrize("case", MEASURED_MISTAKES, ids=list(MEASURED_MISTAKES))
def test_measured_file_mistakes_name_the_field(tmp_path, capsys, case):
    make, fragments = MEASURED_MISTAKES[case]
    inputs, out = folders(tmp_path)
    arguments = make(inputs)
    result = run_cli(capsys, "identify", *arguments, "--out", out / "identified")
    assert_refused(result, out, "nlupdate identify: error:", *fragments)


# ------------------------------------------------------------------ MATLAB files: what the file holds, not Python's text
def _v73(folder: Path, build) -> Path:
    """A MATLAB v7.3 file (HDF5 after a 512-byte header) whose datasets ``build(handle)`` makes."""
    import h5py
    from test_measured_exports import write_v73

    path = write_v73(folder / "frf.mat", {"force_level_n": [1.0], "response_dof": "tip", "input_dof": "tip"})
    with h5py.File(path, "r+") as handle:
        build(handle, h5py)
    return path


def _empty_frequencies(handle, h5py) -> None:
    for name in ("frequency_hz", "H"):  # as MATLAB saves zeros(0, 1): its dimensions, flagged MATLAB_empty
        data = handle.create_dataset(name, data=np.array([0, 0], dtype=np.uint64))
        data.attrs["MATLAB_class"], data.attrs["MATLAB_empty"] = np.bytes_("double"), np.uint8(1)


def _external_link(handle, h5py) -> None:
    handle.create_dataset("frequency_hz", data=np.linspace(60.0, 120.0, 5)[None, :]).attrs["MATLAB_class"] = \
        np.bytes_("double")
    handle["H"] = h5py.ExternalLink("/etc/elsewhere.h5", "/H")


def _two_structs(folder: Path) -> Path:
    import scipy.io

    scipy.io.savemat(folder / "frf.mat", {"low": {"frequency_hz": [60.0, 61.0]}, "high": {"frequency_hz": [60.0]}})
    return folder / "frf.mat"


MAT_MISTAKES = {
    "empty v7.3 array": (lambda d: _v73(d, _empty_frequencies),
                         ("frf.mat: variable 'frequency_hz' is empty; expected a vector of values",)),
    "HDF5 external link": (lambda d: _v73(d, _external_link),
                           ("frf.mat: variable 'H' is an HDF5 external link to /etc/elsewhere.h5:/H",
                            "reads only what the file itself holds")),
    "two structs": (_two_structs, ("frf.mat: holds 2 structs (low, high) and no variable outside them",
                                   "save('frf.mat', '-struct', 'low')")),
}


@pytest.mark.parametrize("case", MAT_MISTAKES, ids=list(MAT_MISTAKES))
def test_mat_file_mistakes_name_the_variable(tmp_path, capsys, case):
    make, fragments = MAT_MISTAKES[case]
    inputs, out = folders(tmp_path)
    result = run_cli(capsys, "identify", "--measured", make(inputs), "--out", out / "identified")
    assert_refused(result, out, "nlupdate identify: error:", *fragments)


def test_a_ragged_mat_time_record_names_the_lengths(tmp_path, capsys):
    import scipy.io

    t = np.arange(400) / 2000.0
    scipy.io.savemat(tmp_path / "record.mat", {"time_s": t, "force": np.cos(2 * np.pi * 20 * t),
                                               "tip": np.cos(2 * np.pi * 20 * t[:390])})
    out = tmp_path / "out"
    out.mkdir()
    result = run_cli(capsys, "frf", tmp_path / "record.mat", "--out", out / "frf.csv")
    assert_refused(result, out, "record.mat: the columns differ in length ('time_s' 400, 'force' 400, 'tip' 390 "
                                "samples); expected one value per sample in every column")


# ------------------------------------------------------------------ TOML nested beyond the parser: the file is named
@pytest.mark.parametrize("command, nested", [
    ("update", "[" * 3000 + "]" * 3000),
    ("update", "{a = " * 3000 + "1" + "}" * 3000),
    ("simulate", "[" * 3000 + "]" * 3000),
])
def test_a_deeply_nested_file_is_named(tmp_path, capsys, command, nested):
    path = tmp_path / "deep.toml"
    path.write_text(f"deep = {nested}\n")
    out = tmp_path / "out"
    out.mkdir()
    extra = ["--input-dof", "0", "--freqs", "1:2:3", "--forces", "1"] if command == "simulate" else []
    result = run_cli(capsys, command, path, *extra, "--out", out / ("frf.csv" if extra else "result"))
    assert_refused(result, out, f"{path}: arrays or inline tables nested too deeply for the TOML reader")


# ------------------------------------------------------------------ a value blamed on the key that holds it
def _study_with_fixed(folder: Path, fixed: dict) -> Path:
    from studies import two_dof_study, write_study

    study = two_dof_study()
    study["adapter"]["fixed"] = fixed
    return write_study(folder / "study.toml", study)


def _iwan_model(folder: Path, kt: float) -> Path:
    import tomllib

    import tomli_w

    model = tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "iwan_sdof.toml").read_text())
    model["nonlinear"][0]["kt"] = kt
    path = folder / "iwan.toml"
    path.write_text(tomli_w.dumps(model))
    return path


VALUE_MISTAKES = {
    "negative fixed k3": (lambda d, out: ["update", _study_with_fixed(d, {"k3": -1e10}), "--out", out / "run"], (
        "study.toml: [adapter.fixed] key 'k3': expected a value the lumped model can take",
        "parameter 'k3' must be positive")),
    "Iwan K_T 1e29": (lambda d, out: ["simulate", _iwan_model(d, 1e29), "--input-dof", "0", "--freqs", "650:780:11",
                                      "--forces", "0.01,1", "--method", "hb", "--out", out / "frf.csv"], (
        "iwan.toml [[nonlinear]] #1: 'kt' = 1e+29 N/m is 5e+22 times the model's largest stiffness (2e+06 N/m)",
        "expected at most 1e+12 times it")),
}


@pytest.mark.parametrize("case", VALUE_MISTAKES, ids=list(VALUE_MISTAKES))
def test_a_value_is_blamed_on_its_own_key(tmp_path, capsys, case):
    make, fragments = VALUE_MISTAKES[case]
    inputs, out = folders(tmp_path)
    result = run_cli(capsys, *make(inputs, out))
    assert_refused(result, out, *fragments)


# ------------------------------------------------------------------ huge inputs: bounded before the work, not hours into it
def _study(folder: Path, change) -> Path:
    from studies import two_dof_study, write_study

    study = two_dof_study()
    change(study)
    return write_study(folder / "study.toml", study)


def _many_parameters(study: dict) -> None:
    study["parameters"] = [dict(study["parameters"][0], name=f"k{i}") for i in range(1001)]


def _iwan_sliders(folder: Path, sliders: int) -> Path:
    path = _iwan_model(folder, 3e5)
    path.write_text(path.read_text().replace("beta = 0.5", f"beta = 0.5\nsliders = {sliders}"))
    return path


HUGE_INPUTS = {
    "5e7 frequencies in a study": (lambda d, out: ["update", _study(d, lambda s: s["measured"]["simulate"].update(
        frequencies_hz=[690.0, 770.0, 50_000_000])), "--out", out / "run"], (
        "study.toml: [measured.simulate] key 'frequencies_hz': expected [start, stop, count] with 2 ≤ count ≤ 200000",)),
    "frequency list longer than the cap": (lambda d, out: ["update", _study(d, lambda s: s["measured"]["simulate"].update(
        frequencies_hz={"list": [690.0 + 1e-3 * i for i in range(200_001)]})), "--out", out / "run"], (
        "[measured.simulate] key 'frequencies_hz': expected at most 200000 frequencies, found 200001",)),
    "1001 parameters": (lambda d, out: ["update", _study(d, _many_parameters), "--out", out / "run"], (
        "study.toml: 1001 [[parameters]] tables; expected at most 1000",)),
    "1001 targets": (lambda d, out: ["update", _study(d, lambda s: s.update(targets={"frequencies_hz": [
        700.0 + i for i in range(1001)]})), "--out", out / "run"], (
        "study.toml: [targets] key 'frequencies_hz': expected at most 1000 target modes, found 1001",)),
    "Iwan sliders 1e8": (lambda d, out: ["simulate", _iwan_sliders(d, 100_000_000), "--input-dof", "0", "--freqs",
                                         "650:780:11", "--forces", "0.01,1", "--method", "time", "--out",
                                         out / "frf.csv"], (
        "iwan.toml [[nonlinear]] #1: sliders must be an integer from 2 to 100000", "got 1e+08")),
}


@pytest.mark.parametrize("case", HUGE_INPUTS, ids=list(HUGE_INPUTS))
def test_huge_inputs_are_refused_before_the_work(tmp_path, capsys, case):
    make, fragments = HUGE_INPUTS[case]
    inputs, out = folders(tmp_path)
    result = run_cli(capsys, *make(inputs, out))
    assert_refused(result, out, *fragments)


# ------------------------------------------------------------------ policy: what the tool tells users to run
def _commands_starting_a_server(text: str) -> list[str]:
    """Every shell block of ``text`` that runs ``prefect server start``."""
    blocks = re.findall(r"```(?:bash|sh|console)?\n(.*?)```", text, flags=re.S)
    return [block for block in blocks if "prefect server start" in block]


@pytest.mark.parametrize("source", ["docs/schedules.md", "nlupdate.orchestration.flows.schedule:HOW_TO_START",
                                    "nlupdate.orchestration.flows.server:HELP"])
def test_a_server_users_are_told_to_start_sends_no_telemetry(source):
    root = Path(__file__).resolve().parents[1]
    if source.endswith(".md"):
        text = (root / source).read_text()
        blocks = _commands_starting_a_server(text)
        assert blocks, "the page shows how to start the server"
        for block in blocks:
            assert "PREFECT_SERVER_ANALYTICS_ENABLED=false" in block, block
        inline = re.findall(r"`([^`]*prefect server start[^`]*)`", text)
        first = next(span for span in inline if span.startswith(("prefect", "PREFECT")))
        assert "PREFECT_SERVER_ANALYTICS_ENABLED=false" in first, first
    else:
        import importlib

        module, name = source.split(":")
        text = getattr(importlib.import_module(module), name)
        assert "PREFECT_SERVER_ANALYTICS_ENABLED=false" in text, text


@pytest.mark.parametrize("mode, refused", [(0o777, True), (0o775, True), (0o757, True), (0o755, False), (0o700, False)])
def test_a_settings_folder_others_can_write_is_refused(tmp_path, monkeypatch, mode, refused):
    from nlupdate.user_config import UserConfigError, cache_secret

    folder = tmp_path / "config"
    folder.mkdir()
    folder.chmod(mode)
    monkeypatch.setenv("NLUPDATE_CONFIG_DIR", str(folder))
    monkeypatch.delenv("NLUPDATE_CACHE_SECRET_FILE", raising=False)
    if refused:
        with pytest.raises(UserConfigError) as caught:
            cache_secret()
        assert str(caught.value) == (f"{folder}: the nlupdate settings folder is writable by others (mode {mode:04o}): "
                                     f"they could replace its cache secret or schedules; run `chmod 700 {folder}`")
        assert list(folder.iterdir()) == []  # no secret written into it
    else:
        assert len(cache_secret()) >= 32


# ------------------------------------------------------------------ policy: an archive holds the run's inputs, and only those
def _study_naming(folder: Path, measured: dict) -> Path:
    from studies import two_dof_study, write_study

    (folder / "notes.key").write_text("not measured data\n")
    _two_dof_table().to_csv(folder / "frf.csv", index=False)
    study = two_dof_study()
    study["measured"] = measured
    return write_study(folder / "study.toml", study)


@pytest.mark.parametrize("measured, fragment", [
    ({"file": "notes.key"}, "[measured] key 'file': expected an existing FRF table (.parquet, .csv, .uff, .unv, .mat)"),
    ({"files": ["frf.csv", "notes.key"]}, "[measured] key 'files': expected existing measured-FRF files"),
    ({"time_histories": ["notes.key"]}, "[measured] key 'time_histories': expected existing time-record files"),
])
def test_a_study_naming_a_file_of_no_input_type_is_refused_before_any_step(tmp_path, capsys, measured, fragment):
    inputs, out = folders(tmp_path)
    result = run_cli(capsys, "update", _study_naming(inputs, measured), "--out", out / "run")
    assert_refused(result, out, "study.toml: " + fragment)


@pytest.mark.parametrize("measured", [
    {"file": "frf.csv", "levels": {"notes.key": 1.0}},
    {"file": "frf.csv", "coordinates": {"notes.key": ["tip", "tip"]}},
])
def test_a_file_a_key_only_names_is_not_copied_into_the_failed_archive(tmp_path, measured):
    from nlupdate.reporting.archive import write_failed_archive
    from nlupdate.study import load_study

    study = load_study(_study_naming(tmp_path, measured))
    folder = write_failed_archive(study, tmp_path / "results" / "two-dof" / "run", {}, "ValueError: bad table")
    archived = sorted(p.name for p in (folder / "inputs").rglob("*") if p.is_file())
    assert archived == ["frf.csv"], archived


@pytest.mark.parametrize("command", [["rerun", "run-1", "--out", "again"], ["compare", "run-1", "run-1"]])
def test_an_archived_study_file_that_is_a_link_is_not_followed(tmp_path, capsys, command):
    from test_archive_safety import good_manifest, make_run

    private = tmp_path / "private.toml"
    private.write_text('[study]\nname = "secret"\n')
    root = tmp_path / "results"
    folder = make_run(root, "s", "run-1", good_manifest("run-1"))
    (folder / "study.toml").symlink_to(private)
    code, out, err = run_cli(capsys, "archive", *[tmp_path / c if c == "again" else c for c in command],
                             "--root", root)
    assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1, (code, err)
    assert f"{folder / 'study.toml'}: is a link (to {private}), not the study file the run wrote; not followed" in err
    assert "secret" not in out and not (tmp_path / "again").exists()


@pytest.mark.parametrize("measured, fragment", [
    ({"file": "frf.csv", "levels": {"frf.csv": 1.0, "./frf.csv": 2.0}},
     "[measured.levels] key './frf.csv': expected one level per file or run: 'frf.csv' names the same one with 1"),
    ({"files": {"frf.csv": 1.0}, "levels": {"./frf.csv": 2.0}},
     "[measured.levels] key './frf.csv': expected the level [measured] files gives the file (1), or none"),
])
def test_a_study_giving_one_file_two_levels_is_refused(tmp_path, capsys, measured, fragment):
    inputs, out = folders(tmp_path)
    result = run_cli(capsys, "update", _study_naming(inputs, measured), "--out", out / "run")
    assert_refused(result, out, "study.toml: " + fragment)
