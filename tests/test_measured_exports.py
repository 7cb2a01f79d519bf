"""Files shaped like test-system exports, read back to the right receptance, unit and level.

Each file is written here the way a commercial test system writes it (UFF 58 through
pyuff with its own header fields, MATLAB v5 through scipy.io, v7.3 as MATLAB lays out
HDF5) from a known analytic receptance, and the reader must return that receptance (m/N
or m/V), its level and its reference unit — or refuse in one line naming the field.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import pyuff

from nlupdate.core.measurement.frf_table import MeasurementTableError, select_frf

from nlupdate.core.measurement.frf_files import read_frf_table, read_frf_tables
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.notices import NlupdateWarning

F = np.arange(0.0, 161.0, 1.0)  # 0–160 Hz with the DC line, as an FFT analyser exports it
W = 2 * np.pi * F


def receptance(f: np.ndarray, constant: float = 1.0) -> np.ndarray:
    """Two modes (40 and 120 Hz): H = Σ A_r/(ω_r² − ω² + iη ω_r²), m/N (or m/V)."""
    w = 2 * np.pi * np.asarray(f, float)
    out = np.zeros(w.shape, complex)
    for fr, a, eta in ((40.0, constant, 0.02), (120.0, -0.6, 0.01)):
        wr = 2 * np.pi * fr
        out += a / (wr**2 - w**2 + 1j * eta * wr**2)
    return out


def export_58(path: Path, datasets: list[dict]) -> Path:
    pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(**d) for d in datasets], mode="add")
    return path


def lms_like(data: np.ndarray, **fields) -> dict:
    """One dataset 58 with the fields an analyser fills (ASCII, 13 significant digits)."""
    base = dict(
        binary=0, func_type=4, rsp_node=101, rsp_dir=-3, ref_node=1, ref_dir=3, data=data, x=F,
        id1="Bolted beam", id2="Periodic chirp 70-110 Hz", abscissa_spacing=1,
        abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=11, ordinate_axis_units_lab="m/s",
        orddenom_spec_data_type=0, orddenom_axis_units_lab="V",
        z_axis_spec_data_type=0, z_axis_value=0.0,
    )
    base.update(fields)
    return base


def coherence_dataset(values: np.ndarray, **fields) -> dict:
    base = lms_like(values.astype(float), func_type=6, ordinate_spec_data_type=0, ordinate_axis_units_lab="",
                    orddenom_spec_data_type=0, orddenom_axis_units_lab="")
    base.update(fields)
    return base


@pytest.fixture
def per_volt_export(tmp_path) -> tuple[Path, dict]:
    """Six files, one per level, as the bolted-beam export: mobility per volt, the level only
    in an ID line, the response measured along −z, a coherence dataset beside each FRF."""
    paths, truth = [], {}
    for k, level in enumerate((0.05, 0.10, 0.15, 0.20, 0.25, 0.30)):
        h = receptance(F, 1.0 - 0.1 * k)  # softening with level would be here; any known curve will do
        mobility = 1j * W * h
        coherence = np.clip(0.999 - 0.5 * ((F < 70) | (F > 110)), 0, 1)
        path = export_58(tmp_path / f"run_{k + 1:02d}.uff", [
            lms_like(mobility, id3=f"Level {level:.2f} V"),
            coherence_dataset(coherence, id3=f"Level {level:.2f} V"),
        ])
        paths.append(path)
        truth[level] = (-h, coherence)  # sign of the −z response applied
    return paths, truth


def test_per_volt_mobility_export_reads_back_as_receptance_per_volt(per_volt_export):
    paths, truth = per_volt_export
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = read_frf_tables(paths, options=ReadOptions(reference_unit="V"))
    messages = [str(w.message) for w in caught if issubclass(w.category, NlupdateWarning)]
    assert any("dropped the 0 Hz line" in m for m in messages)
    assert any("converted mobility" in m for m in messages)
    assert set(table["reference_unit"]) == {"V"}
    assert set(table["excitation"]) == {"chirp"}
    assert table["response_dof"].unique().tolist() == ["101:uz"]
    assert table["input_dof"].unique().tolist() == ["1:uz"]
    np.testing.assert_allclose(sorted(set(table["force_level_n"])), sorted(truth), rtol=1e-12)
    for level, (h, coherence) in truth.items():
        f, back = select_frf(table, "101:uz", "1:uz", level)
        np.testing.assert_allclose(f, F[1:])
        np.testing.assert_allclose(back, h[1:], rtol=1e-9)  # ASCII export: 13 significant digits
        rows = table[np.isclose(table["force_level_n"], level)].sort_values("frequency_hz")
        np.testing.assert_allclose(rows["coherence"], coherence[1:], atol=1e-9)


def test_per_volt_file_is_refused_unless_the_volts_are_stated(per_volt_export):
    paths, _ = per_volt_export
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(paths[0])
    message = str(error.value)
    assert "run_01.uff, dataset 0" in message and "per volt" in message and "--reference-unit V" in message
    with pytest.raises(MeasurementTableError, match="reference is in V .*not in N as stated"):
        read_frf_table(paths[0], options=ReadOptions(reference_unit="N"))


@pytest.mark.filterwarnings("ignore::nlupdate.notices.NlupdateWarning")
def test_calibration_turns_per_volt_into_per_newton(per_volt_export):
    paths, truth = per_volt_export
    table = read_frf_table(paths[1], options=ReadOptions(reference_unit="V", reference_calibration=4.0))
    assert set(table["reference_unit"]) == {"N"}
    f, back = select_frf(table, "101:uz", "1:uz", 0.40)  # 0.10 V × 4 N/V
    np.testing.assert_allclose(back, truth[0.10][0][1:] / 4.0, rtol=1e-9)


def test_accelerance_per_newton_with_level_only_in_the_id_line(tmp_path):
    h = receptance(F)
    path = export_58(tmp_path / "hammer.uff", [lms_like(
        (1j * W) ** 2 * h * 1e3, rsp_dir=3, id2="Random, 2.5 N rms", ordinate_spec_data_type=12,
        ordinate_axis_units_lab="mm/s^2", orddenom_spec_data_type=13, orddenom_axis_units_lab="N")])
    with pytest.warns(NlupdateWarning, match="accelerance"):
        table = read_frf_table(path)
    assert "reference_unit" not in table.columns and set(table["excitation"]) == {"random"}
    f, back = select_frf(table, "101:uz", "1:uz", 2.5)
    np.testing.assert_allclose(back, h[1:], rtol=1e-9)  # mm/s² scaled to m/s²


def test_level_from_the_z_axis_and_from_the_user(tmp_path):
    h = receptance(F)
    z = export_58(tmp_path / "z.uff", [lms_like(h, rsp_dir=3, ordinate_spec_data_type=8, ordinate_axis_units_lab="m",
                                              orddenom_spec_data_type=13, orddenom_axis_units_lab="N",
                                              z_axis_spec_data_type=13, z_axis_value=7.5, id2="")])
    assert sorted(set(read_frf_table(z)["force_level_n"])) == [7.5]
    bare = export_58(tmp_path / "bare.uff", [lms_like(h, rsp_dir=3, ordinate_spec_data_type=8,
                                                    ordinate_axis_units_lab="m", orddenom_spec_data_type=13,
                                                    orddenom_axis_units_lab="N", id2="")])
    with pytest.raises(MeasurementTableError, match=r"bare\.uff, dataset 0: no level: .*--level FILE=VALUE"):
        read_frf_table(bare)
    table = read_frf_table(bare, options=ReadOptions(levels={"bare.uff": 3.0}))
    f, back = select_frf(table, "101:uz", "1:uz", 3.0)
    np.testing.assert_allclose(back, h, rtol=1e-9)


def test_two_files_holding_the_same_level_are_named(tmp_path):
    h = receptance(F)
    fields = dict(rsp_dir=3, ordinate_spec_data_type=8, ordinate_axis_units_lab="m", orddenom_spec_data_type=13,
                  orddenom_axis_units_lab="N", id2="run at 1 N")
    a = export_58(tmp_path / "a.uff", [lms_like(h, **fields)])
    b = export_58(tmp_path / "b.uff", [lms_like(h, **fields)])
    with pytest.raises(MeasurementTableError, match=r"a\.uff and b\.uff hold the same measurement"):
        read_frf_tables([a, b])


@pytest.mark.parametrize("fields, fragments", [
    (dict(abscissa_spec_data_type=17, abscissa_axis_units_lab="s"), ("abscissa specific data type 17", "time")),
    (dict(orddenom_spec_data_type=8, orddenom_axis_units_lab="m"), ("denominator specific data type 8",
                                                                    "transmissibility")),
    (dict(orddenom_axis_units_lab=""), ("reference's unit cannot be determined", "--reference-unit")),
    (dict(ordinate_spec_data_type=0, ordinate_axis_units_lab="Pa"), ("ordinate", "'Pa'")),
])
def test_wrong_data_are_refused_naming_the_field(tmp_path, fields, fragments):
    path = export_58(tmp_path / "wrong.uff", [lms_like(receptance(F), id3="1 V", **fields)])
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(path)
    assert "wrong.uff, dataset 0" in str(error.value)
    for fragment in fragments:
        assert fragment in str(error.value)


def test_boolean_h_real_in_parquet_is_refused(tmp_path):
    table = pd.DataFrame({"frequency_hz": [1.0, 2.0], "force_level_n": 1.0, "response_dof": "0", "input_dof": "0",
                          "h_real": [True, False], "h_imag": [0.0, 0.0]})
    table.to_parquet(tmp_path / "bool.parquet")
    with pytest.raises(MeasurementTableError, match=r"bool\.parquet: row 0, column 'h_real': True is a boolean"):
        read_frf_table(tmp_path / "bool.parquet")


# ----------------------------------------------------------------------------- MATLAB
def test_mat_v5_wide_and_long_forms(tmp_path):
    import scipy.io

    f = F[1:]
    h = np.column_stack([receptance(f), receptance(f, 0.8)])
    scipy.io.savemat(tmp_path / "wide.mat", {
        "frequency_hz": f, "H": h, "force_level_n": np.array([0.1, 0.2]), "response_dof": "tip:uz",
        "input_dof": "drive:uz", "reference_unit": "V", "coherence": np.full(h.shape, 0.95)})
    table = read_frf_table(tmp_path / "wide.mat", options=ReadOptions(reference_unit="V"))
    assert set(table["reference_unit"]) == {"V"}
    for level, column in ((0.1, 0), (0.2, 1)):
        _, back = select_frf(table, "tip:uz", "drive:uz", level)
        np.testing.assert_allclose(back, h[:, column], rtol=1e-15)
    np.testing.assert_allclose(table["coherence"], 0.95)
    assert set(read_frf_table(tmp_path / "wide.mat")["reference_unit"]) == {"V"}  # the file names its unit
    with pytest.raises(MeasurementTableError, match=r"wide\.mat: the file's reference is in V .*not in N as stated"):
        read_frf_table(tmp_path / "wide.mat", options=ReadOptions(reference_unit="N"))

    scipy.io.savemat(tmp_path / "long.mat", {
        "frequency_hz": f, "force_level_n": np.full(f.size, 2.0), "response_dof": "0", "input_dof": "0",
        "h_real": receptance(f).real, "h_imag": receptance(f).imag})
    _, back = select_frf(read_frf_table(tmp_path / "long.mat"), "0", "0", 2.0)
    np.testing.assert_allclose(back, receptance(f), rtol=1e-15)


def write_v73(path: Path, variables: dict) -> Path:
    """A MATLAB v7.3 file as MATLAB writes it: a 512-byte header, HDF5 datasets holding
    the column-major arrays transposed, complex as (real, imag) compounds, text as uint16
    char codes, each with its MATLAB_class attribute."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as handle:
        for name, value in variables.items():
            if isinstance(value, str):
                data = np.array([[ord(c)] for c in value], dtype=np.uint16).T
                handle.create_dataset(name, data=data).attrs["MATLAB_class"] = np.bytes_("char")
                continue
            array = np.atleast_2d(np.asarray(value))
            if np.iscomplexobj(array):
                compound = np.empty(array.T.shape, dtype=[("real", "<f8"), ("imag", "<f8")])
                compound["real"], compound["imag"] = array.T.real, array.T.imag
                handle.create_dataset(name, data=compound).attrs["MATLAB_class"] = np.bytes_("double")
            else:
                handle.create_dataset(name, data=array.T.astype(float)).attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as stream:
        stream.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 .")
    return path


def test_mat_v73_wide_form(tmp_path):
    f = F[1:]
    h = np.column_stack([receptance(f), receptance(f, 0.9), receptance(f, 0.8)])
    path = write_v73(tmp_path / "v73.mat", {"frequency_hz": f[:, None], "H": h, "force_level_n": np.array([1.0, 5.0, 9.0]),
                                          "response_dof": "tip:uz", "input_dof": "tip:uz"})
    table = read_frf_table(path)
    for level, column in ((1.0, 0), (5.0, 1), (9.0, 2)):
        freq, back = select_frf(table, "tip:uz", "tip:uz", level)
        np.testing.assert_allclose(freq, f)
        np.testing.assert_allclose(back, h[:, column], rtol=1e-15)


def test_mat_file_without_the_mapped_variables_names_them(tmp_path):
    import scipy.io

    scipy.io.savemat(tmp_path / "other.mat", {"FRF": np.ones(3), "freq": np.arange(3.0)})
    with pytest.raises(MeasurementTableError, match=r"other\.mat: missing variable\(s\) \['frequency_hz', 'H'"):
        read_frf_table(tmp_path / "other.mat")


def test_content_that_does_not_fit_the_suffix(tmp_path):
    pd.DataFrame({"a": [1]}).to_parquet(tmp_path / "frf.csv")
    with pytest.raises(MeasurementTableError, match=r"frf\.csv: holds a parquet file, not what its suffix"):
        read_frf_table(tmp_path / "frf.csv")
    (tmp_path / "frf.mat").write_text("frequency_hz,h\n")
    with pytest.raises(MeasurementTableError, match=r"frf\.mat: holds text"):
        read_frf_table(tmp_path / "frf.mat")
