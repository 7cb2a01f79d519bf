"""Small files that declare huge data are refused before they are decoded (issue: a 2 MB
parquet record of 10⁸ samples took 2.9 GB and 95 s; a 5 KB MATLAB v7.3 file declaring a
huge array took 3.9 GB, or asked for 89 GiB).

The refusals are checked from the declarations alone: the files hold (almost) no data,
so decoding them would allocate what they declare.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlupdate.app.cli import main
from nlupdate.input_files import DEFAULT_MAX_INPUT_MB, MAX_INPUT_ENV

SAMPLES = 10**8  # 800 MB of doubles per column once decoded


def constant_parquet(path: Path, column: str, rows: int = SAMPLES) -> Path:
    """``rows`` zeros in one column, written in ten row groups (a small file)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    chunk = pa.table({column: np.zeros(rows // 10)})
    with pq.ParquetWriter(path, chunk.schema, compression="zstd") as writer:
        for _ in range(10):
            writer.write_table(chunk, row_group_size=rows // 10)
    return path


def one_line(capsys, result: int) -> str:
    err = capsys.readouterr().err.strip()
    assert result == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, (result, err)
    return err


def test_a_parquet_record_of_1e8_samples_is_refused_before_it_is_read(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv(MAX_INPUT_ENV, raising=False)
    record = constant_parquet(tmp_path / "record.parquet", "time_s")
    assert record.stat().st_size < 2e6  # the premise: a small file
    err = one_line(capsys, main(["frf", str(record), "--out", str(tmp_path / "frf.parquet")]))
    assert err.endswith(f"{record}: column 'time_s' declares {SAMPLES} rows, 800 MB once decoded, more than the "
                        f"input limit of {DEFAULT_MAX_INPUT_MB:g} MB (time-history file); set {MAX_INPUT_ENV} to "
                        f"raise it"), err
    assert not (tmp_path / "frf.parquet").exists()


def test_a_parquet_frf_table_declaring_too_many_rows_is_refused(tmp_path, capsys, monkeypatch):
    """The same check for measured-FRF tables, and the columns counted together."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    monkeypatch.setenv(MAX_INPUT_ENV, "10")
    rows = 500_000
    table = tmp_path / "frf.parquet"
    pq.write_table(pa.table({"frequency_hz": np.zeros(rows), "force_level_n": np.zeros(rows),
                             "response_dof": pa.array(["tip"] * rows).dictionary_encode()}), table)
    err = one_line(capsys, main(["identify", "--measured", str(table), "--out", str(tmp_path / "ident")]))
    assert err.endswith(f"{table}: column 'frequency_hz' declares {rows} rows, 4 MB once decoded (12 MB for the 3 "
                        f"columns), more than the input limit of 10 MB (measured-FRF file); set {MAX_INPUT_ENV} to "
                        f"raise it"), err


def test_a_matlab_v73_file_declaring_1e10_elements_is_refused_before_it_is_read(tmp_path, capsys, monkeypatch):
    import h5py

    monkeypatch.delenv(MAX_INPUT_ENV, raising=False)
    path = tmp_path / "record.mat"
    with h5py.File(path, "w", userblock_size=512) as handle:
        handle.create_dataset("time_s", data=np.arange(100.0)[None, :]).attrs["MATLAB_class"] = np.bytes_("double")
        huge = handle.create_dataset("tip", shape=(1, 10**10), dtype="f8", chunks=(1, 10**6), compression="gzip")
        huge.attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as stream:  # MATLAB's 128-byte header in the user block
        stream.write(b"MATLAB 7.3 MAT-file".ljust(116) + b"\0" * 8 + b"\x00\x02IM")
    assert path.stat().st_size < 50_000  # the premise: a small file
    err = one_line(capsys, main(["frf", str(path), "--out", str(tmp_path / "frf.parquet")]))
    assert err.endswith(f"{path}: variable 'tip' declares 10000000000 elements of 8 bytes, 80000 MB once decoded, "
                        f"more than the input limit of {DEFAULT_MAX_INPUT_MB:g} MB (time-history file); set "
                        f"{MAX_INPUT_ENV} to raise it"), err


def test_matlab_v73_variables_are_counted_together(tmp_path, monkeypatch):
    """Many variables each under the limit: their sum is what would be decoded."""
    import h5py

    from nlupdate.input_files import InputFileError
    from nlupdate.core.measurement.matfile import mat_variables

    monkeypatch.setenv(MAX_INPUT_ENV, "1")
    path = tmp_path / "many.mat"
    with h5py.File(path, "w") as handle:
        for k in range(3):
            handle.create_dataset(f"v{k}", shape=(1, 50_000), dtype="f8", compression="gzip")  # 0.4 MB each
    with pytest.raises(InputFileError, match=r"many.mat: variable 'v2' declares 50000 elements of 8 bytes, "
                                             r"0.4 MB once decoded, 1.2 MB with the variables before it, more than"):
        mat_variables(path.read_bytes(), path, "hdf5")


def test_a_matlab_v5_file_declaring_a_huge_array_is_refused(tmp_path, monkeypatch):
    """v5 files are zlib-compressed per variable: a large array of zeros is a small file."""
    import scipy.io

    from nlupdate.input_files import InputFileError
    from nlupdate.core.measurement.matfile import mat_variables

    monkeypatch.setenv(MAX_INPUT_ENV, "1")
    path = tmp_path / "zeros.mat"
    scipy.io.savemat(path, {"tip": np.zeros((1, 1_000_000))}, do_compression=True)
    assert path.stat().st_size < 1e5
    with pytest.raises(InputFileError, match=r"zeros.mat: variable 'tip' declares 1000000 elements of 8 bytes, "
                                             r"8 MB once decoded, more than the input limit of 1 MB"):
        mat_variables(path.read_bytes(), path, "mat5")


def test_files_within_the_limit_are_read(tmp_path, monkeypatch):
    """The check does not refuse what it should read: a real record of 40 000 samples."""
    import scipy.io

    from nlupdate.core.measurement.time_history import read_time_record

    monkeypatch.setenv(MAX_INPUT_ENV, "1")  # 3 × 40 000 doubles: 0.96 MB
    t = np.arange(40_000) / 1000.0
    scipy.io.savemat(tmp_path / "rec.mat", {"time_s": t, "force": np.cos(t), "tip": np.sin(t)})
    record = read_time_record(tmp_path / "rec.mat")
    np.testing.assert_array_equal(record.time_s, t)
