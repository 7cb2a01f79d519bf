"""Modal tables: CSV round trip, detection and one-line errors naming file, row and column."""
import numpy as np
import pandas as pd
import pytest

from nlupdate.core.measurement.modal_table import (
    MODAL_COLUMNS, ModalTableError, is_modal_table_file, modal_table, read_modal_table, validate_modal_table,
    write_modal_table,
)

GUN_BARREL = pd.DataFrame({  # docs/methods.md §8, mode 1 at six rms force levels
    "force_level_n": [21.851, 0.88, 1.829, 2.809, 3.859, 7.888],
    "mode": [1] * 6,
    "natural_frequency_hz": [7.196, 7.501, 7.473, 7.449, 7.416, 7.341],
    "damping_ratio": [0.02368, 0.00955, 0.01033, 0.01171, 0.01345, 0.01621],
})


def test_round_trip_sorted_by_force_and_mode(tmp_path):
    path = write_modal_table(GUN_BARREL, tmp_path / "modes.csv")
    table = read_modal_table(path)
    assert list(table.columns) == list(MODAL_COLUMNS)
    np.testing.assert_array_equal(table["force_level_n"], np.sort(GUN_BARREL["force_level_n"]))
    row = table[table["force_level_n"] == 21.851].iloc[0]
    assert (row["natural_frequency_hz"], row["damping_ratio"], row["mode"]) == (7.196, 0.02368, 1)
    assert is_modal_table_file(path)


def test_optional_input_dof_and_builder():
    table = modal_table([1.0, 2.0], 1, [10.0, 9.9], [0.01, 0.012], input_dof="tip")
    assert list(table["input_dof"]) == ["tip", "tip"]


def test_an_frf_table_is_not_a_modal_table(tmp_path):
    path = tmp_path / "frf.csv"
    path.write_text("frequency_hz,force_level_n,response_dof,input_dof,h_real,h_imag\n1,1,0,0,1e-6,0\n")
    assert not is_modal_table_file(path)


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda t: t.drop(columns="damping_ratio"), r"missing column\(s\) \['damping_ratio'\]"),
        (lambda t: t.assign(damping_ratio=[2.368, 0.955, 1.033, 1.171, 1.345, 1.621]),
         r"row 0 \(line 2\), column 'damping_ratio': .*a fraction"),
        (lambda t: t.assign(mode=[1, 1, 1, 0, 1, 1]), r"row 3 \(line 5\), column 'mode'"),
        (lambda t: t.assign(natural_frequency_hz=["7.196", "7.501", "x", "7.449", "7.416", "7.341"]),
         r"row 2 \(line 4\), column 'natural_frequency_hz': 'x'"),
        (lambda t: t.assign(force_level_n=[21.851, 0.88, 0.88, 2.809, 3.859, 7.888]), r"0.88 N, mode 1 appears more than once"),
    ],
)
def test_bad_tables_name_row_and_column(tmp_path, edit, message):
    path = tmp_path / "bad.csv"
    edit(GUN_BARREL.copy()).to_csv(path, index=False)
    with pytest.raises(ModalTableError, match=message):
        read_modal_table(path)
    assert str(path) in str(pytest.raises(ModalTableError, read_modal_table, path).value)


def test_validate_rejects_a_non_table():
    with pytest.raises(ModalTableError, match="expected a pandas DataFrame"):
        validate_modal_table([1, 2, 3])
