"""Measured-FRF tables: round trips, UFF58 layout, and error messages for bad tables."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import pyuff

from nlupdate.core.measurement.frf_files import read_frf_table, write_frf_table
from nlupdate.core.measurement.frf_table import FRF_COLUMNS, MeasurementTableError, force_levels, frf_table, select_frf, validate_frf_table

RNG = np.random.default_rng(7)
EVEN = np.linspace(600.0, 850.0, 26)  # step 10 Hz
UNEVEN = np.sort(RNG.uniform(30.0, 60.0, 17)) + 1e-7 * np.pi  # irregular, many digits
# (response, input, force level N) -> (frequencies Hz, complex receptance m/N)
CURVES = {
    ("tip:uz", "tip:uz", 0.01): (EVEN, None),
    ("tip:uz", "tip:uz", 130.0 + 1.0 / 3.0): (EVEN, None),
    ("root:ux", "tip:uz", 0.01): (UNEVEN, None),
    ("3", "tip:uz", 0.01): (np.array([710.0]), None),  # PRD: one excitation frequency
    ("beam 2 / node 17:-rz", "tip:uz", 0.01): (UNEVEN[:5], None),
}
CURVES = {
    key: (f, (RNG.normal(size=f.size) + 1j * RNG.normal(size=f.size)) * 10.0 ** RNG.uniform(-9, -3, f.size))
    for key, (f, _) in CURVES.items()
}


def reference_table() -> pd.DataFrame:
    """The CURVES as a table, rows in a scrambled order (built without frf_table)."""
    rows = [
        (fi, level, resp, inp, hi.real, hi.imag)
        for (resp, inp, level), (f, h) in CURVES.items()
        for fi, hi in zip(f, h)
    ]
    table = pd.DataFrame(rows, columns=list(FRF_COLUMNS))
    return table.iloc[RNG.permutation(len(table))].reset_index(drop=True)


def write_csv(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


HEADER = "frequency_hz,force_level_n,response_dof,input_dof,h_real,h_imag\n"


# ----------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("suffix", [".parquet", ".csv", ".uff", ".unv"])
def test_round_trip_preserves_values_names_and_levels(tmp_path, suffix):
    path = write_frf_table(reference_table(), tmp_path / f"frf{suffix}")
    table = read_frf_table(path)

    assert list(table.columns) == list(FRF_COLUMNS)
    assert len(table) == sum(f.size for f, _ in CURVES.values())
    assert set(table["response_dof"]) == {key[0] for key in CURVES}
    assert set(table["input_dof"]) == {"tip:uz"}
    assert all(isinstance(name, str) for name in table["response_dof"])
    np.testing.assert_array_equal(force_levels(table), [0.01, 130.0 + 1.0 / 3.0])
    for (resp, inp, level), (f, h) in CURVES.items():
        frequency, measured = select_frf(table, resp, inp, level)
        np.testing.assert_allclose(frequency, f, rtol=1e-12, atol=0)
        np.testing.assert_allclose(measured, h, rtol=1e-12, atol=0)
    # canonical order: force level, input, response, frequency
    keys = list(zip(table["force_level_n"], table["input_dof"], table["response_dof"], table["frequency_hz"]))
    assert keys == sorted(keys)
    assert not [p.name for p in tmp_path.iterdir() if p.name != path.name]  # no temp files left


def test_csv_lumped_dof_names_stay_strings(tmp_path):
    path = write_csv(tmp_path / "lumped.csv", HEADER + "700,1,0,0,1e-6,-2e-6\n700,1,1,0,3e-7,0\n")
    table = read_frf_table(path, known_dofs=["0", "1"])
    assert table["response_dof"].tolist() == ["0", "1"]
    assert table["input_dof"].tolist() == ["0", "0"]
    _, h = select_frf(table, 1, 0, 1.0)  # ints are looked up by name
    assert h[0] == 3e-7


def test_uff_file_layout_read_with_pyuff_directly(tmp_path):
    path = write_frf_table(reference_table(), tmp_path / "frf.uff")
    sets = pyuff.UFF(str(path)).read_sets()
    assert len(sets) == len(CURVES)
    by_key = {}
    for s in sets:
        ids = dict(line.split("=", 1) for line in (s["id1"], s["id2"], s["id3"]))
        by_key[(ids["response_dof"], ids["input_dof"], float(ids["force_level_n"]))] = s
    assert set(by_key) == set(CURVES)
    for key, s in by_key.items():
        f, h = CURVES[key]
        assert s["type"] == 58 and s["binary"] == 1 and s["func_type"] == 4
        assert s["ord_data_type"] == 6  # complex double
        assert (s["abscissa_spec_data_type"], s["ordinate_spec_data_type"], s["orddenom_spec_data_type"]) == (18, 8, 13)
        assert s["z_axis_spec_data_type"] == 13
        assert s["z_axis_value"] == pytest.approx(key[2], rel=1e-5)  # 6-digit header field
        even = f is EVEN or f.size == 1
        assert s["abscissa_spacing"] == int(even)
        assert s["n_bytes"] == f.size * 8 * (2 if even else 3)  # complex: Re, Im (+ x if uneven)
        np.testing.assert_allclose(s["data"], h, rtol=1e-15, atol=0)  # binary doubles: exact
    s = by_key[("tip:uz", "tip:uz", 0.01)]
    assert (s["rsp_ent_name"], s["rsp_node"], s["rsp_dir"]) == ("tip", 0, 3)
    assert (s["ref_node"], s["ref_dir"]) == (0, 3)
    s = by_key[("3", "tip:uz", 0.01)]
    assert (s["rsp_node"], s["rsp_dir"]) == (3, 0)


def foreign_uff(path: Path, **fields) -> Path:
    """An ASCII UFF58 as another tool would write it: no key=value ID lines."""
    x = np.array([10.0, 20.0, 30.0])
    base = dict(
        binary=0, func_type=4, rsp_node=12, rsp_dir=3, ref_node=5, ref_dir=-3,
        data=np.array([1.0 + 2.0j, 3.0 - 1.0j, -0.5 + 0.25j]) * 1e-6, x=x, id1="Hammer test",
        abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=8,
        orddenom_spec_data_type=13, z_axis_spec_data_type=13, z_axis_value=2.5,
    )
    base.update(fields)
    pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(**base)], mode="add")
    return path


def test_foreign_uff_uses_node_direction_and_z_axis_force(tmp_path):
    """The reference measured along −z (ref_dir −3): the sign is applied and the
    coordinate named by its positive direction."""
    table = read_frf_table(foreign_uff(tmp_path / "foreign.unv"))
    assert table["response_dof"].unique().tolist() == ["12:uz"]
    assert table["input_dof"].unique().tolist() == ["5:uz"]
    np.testing.assert_array_equal(force_levels(table), [2.5])
    f, h = select_frf(table, "12:uz", "5:uz", 2.5)
    np.testing.assert_allclose(f, [10.0, 20.0, 30.0], rtol=1e-12)
    np.testing.assert_allclose(h, -np.array([1.0 + 2.0j, 3.0 - 1.0j, -0.5 + 0.25j]) * 1e-6, rtol=1e-11)


def test_foreign_uff_without_force_level_is_explained(tmp_path):
    path = foreign_uff(tmp_path / "noforce.uff", z_axis_spec_data_type=0, z_axis_value=0.0)
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(path)
    message = str(error.value)
    assert "noforce.uff" in message and "dataset 0" in message
    assert "force_level_n=" in message and "z-axis" in message and "13" in message


def test_foreign_uff_of_an_unknown_quantity_is_rejected(tmp_path):
    """Pressure (15) per force is no receptance; mobility and accelerance are converted
    (tests/test_bad_input.py)."""
    path = foreign_uff(tmp_path / "p.uff", ordinate_spec_data_type=15)
    with pytest.raises(MeasurementTableError, match=r"p\.uff, dataset 0: ordinate specific data type 15; expected 8"):
        read_frf_table(path)


def test_uff_rejects_dof_name_that_does_not_fit_an_id_line(tmp_path):
    table = frf_table([100.0], 1.0, "x" * 80, "0", [1e-6])
    with pytest.raises(MeasurementTableError, match=r"long\.uff: cannot store response_dof 'xxx.*80"):
        write_frf_table(table, tmp_path / "long.uff")
    assert not list(tmp_path.iterdir())


# ----------------------------------------------------------------------------- building, selecting
def test_frf_table_broadcasts_and_sorts():
    f = np.array([3.0, 1.0, 2.0])
    h = np.array([[1 + 1j, 2, 3], [4, 5, 6j]])
    table = frf_table(f, np.array([[20.0], [10.0]]), 0, "1", h)
    assert len(table) == 6
    assert table["force_level_n"].tolist() == [10.0] * 3 + [20.0] * 3
    assert table["frequency_hz"].tolist() == [1.0, 2.0, 3.0] * 2
    assert table["response_dof"].tolist() == ["0"] * 6
    np.testing.assert_array_equal(table["h_real"] + 1j * table["h_imag"], [5, 6j, 4, 2, 3, 1 + 1j])


def test_select_frf_sorts_by_frequency_and_lists_available_curves():
    table = validate_frf_table(reference_table())  # scrambled row order kept
    f, h = select_frf(table, "root:ux", "tip:uz", 0.01)
    np.testing.assert_array_equal(f, UNEVEN)
    np.testing.assert_array_equal(h, CURVES[("root:ux", "tip:uz", 0.01)][1])
    with pytest.raises(MeasurementTableError) as error:
        select_frf(table, "root:ux", "tip:uz", 5.0)
    assert "force_level_n=5.0" in str(error.value) and "('root:ux', 'tip:uz', 0.01)" in str(error.value)


def test_force_levels_sorted_unique():
    table = frf_table([1.0, 2.0], [[3.0], [1.0], [2.0]], "a", "a", 1.0)
    np.testing.assert_array_equal(force_levels(table), [1.0, 2.0, 3.0])


# ----------------------------------------------------------------------------- bad tables
ROWS = ["700,1,0,0,1e-6,-2e-6", "710,1,0,0,1e-6,-2e-6", "720,1,0,0,1e-6,-2e-6", "730,1,0,0,1e-6,-2e-6"]


def with_row(index: int, row: str) -> str:
    rows = list(ROWS)
    rows[index] = row
    return HEADER + "\n".join(rows) + "\n"


@pytest.mark.parametrize(
    "index, row, column, expected",
    [
        (2, "720,1,0,0,1e-6,nan", "h_imag", "not a finite number"),
        (1, "710,1,0,0,,-2e-6", "h_real", "not a finite number"),
        (3, "730,1,0,0,abc,-2e-6", "h_real", "'abc'"),
        (0, "inf,1,0,0,1e-6,-2e-6", "frequency_hz", "not a finite number"),
        (2, "-720,1,0,0,1e-6,-2e-6", "frequency_hz", "≥ 0 Hz"),
        (3, "730,-2,0,0,1e-6,-2e-6", "force_level_n", "≥ 0 N"),
        (2, "720,1,,0,1e-6,-2e-6", "response_dof", "empty"),
    ],
)
def test_bad_csv_values_name_file_row_line_and_column(tmp_path, index, row, column, expected):
    path = write_csv(tmp_path / "bad.csv", with_row(index, row))
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(path)
    message = str(error.value)
    assert str(path) in message
    assert f"row {index} (line {index + 2})" in message
    assert f"'{column}'" in message
    assert expected in message


def test_duplicate_rows_are_both_named(tmp_path):
    path = write_csv(tmp_path / "dup.csv", with_row(3, "710,1,0,0,5e-6,0"))
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(path)
    message = str(error.value)
    assert "dup.csv: row 1 (line 3) and row 3 (line 5)" in message
    assert "frequency_hz=710.0" in message and "duplicate" in message


def test_unknown_dof_names_value_and_known_list(tmp_path):
    path = write_csv(tmp_path / "dofs.csv", with_row(2, "720,1,0,tip:uz,1e-6,-2e-6"))
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(path, known_dofs=["0", "1"])
    message = str(error.value)
    assert "dofs.csv: row 2 (line 4), column 'input_dof'" in message
    assert "'tip:uz'" in message and "['0', '1']" in message


def test_missing_column_is_named(tmp_path):
    path = write_csv(tmp_path / "cols.csv", "frequency_hz,force_level_n,response_dof,input_dof,h_real\n1,1,0,0,1\n")
    with pytest.raises(MeasurementTableError, match=r"cols\.csv: missing column\(s\) \['h_imag'\]"):
        read_frf_table(path)


def test_in_memory_table_errors_name_source_and_row_without_line():
    table = reference_table()
    table.loc[4, "h_real"] = np.inf
    with pytest.raises(MeasurementTableError) as error:
        validate_frf_table(table, source="sweep A")
    assert str(error.value).startswith("sweep A: row 4, column 'h_real'")
    table = reference_table().astype({"response_dof": object})
    table.loc[5, "response_dof"] = 2.5
    with pytest.raises(MeasurementTableError, match=r"<table>: row 5, column 'response_dof'.*2\.5"):
        validate_frf_table(table)


def test_bad_table_is_not_written_and_existing_file_survives(tmp_path):
    path = write_frf_table(reference_table(), tmp_path / "frf.parquet")
    before = path.read_bytes()
    bad = reference_table()
    bad.loc[0, "force_level_n"] = -1.0
    with pytest.raises(MeasurementTableError, match="force_level_n"):
        write_frf_table(bad, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["frf.parquet"]


def test_missing_file_and_unknown_suffix(tmp_path):
    with pytest.raises(ValueError, match="nothere.csv: no such file"):
        read_frf_table(tmp_path / "nothere.csv")
    with pytest.raises(MeasurementTableError) as error:
        read_frf_table(tmp_path / "frf.xlsx")
    assert "'.xlsx'" in str(error.value)
    assert all(s in str(error.value) for s in (".parquet", ".csv", ".uff", ".unv"))
