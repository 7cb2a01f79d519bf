"""The input gate (issue 19, unbounded reads): only regular files are read, a file over
the size limit is refused before a byte of it is read, text with NUL bytes never reaches a
parser — each in one line naming the file, quickly and without the memory a read would take.
"""
from __future__ import annotations

import os
import resource
import threading
from pathlib import Path

import pytest
from patience import HANG_S

from nlupdate.app.cli import main
from nlupdate.input_files import MAX_INPUT_ENV, InputFileError, read_input_bytes, read_input_text

MODEL = Path(__file__).resolve().parents[1] / "examples" / "sdof.toml"


def _one_error_line(capsys) -> str:
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    return lines[0]


def test_a_device_as_the_model_is_refused_without_reading_it(tmp_path, capsys):
    code = main(["simulate", "/dev/zero", "--input-dof", "0", "--freqs", "1:2:3", "--forces", "1",
                 "--out", str(tmp_path / "frf.csv")])
    assert code == 2
    line = _one_error_line(capsys)
    assert "/dev/zero" in line and "a device" in line and "regular file" in line
    assert not (tmp_path / "frf.csv").exists()


def test_a_file_over_the_limit_is_refused_before_it_is_read(tmp_path, capsys):
    """A 2 GB all-NUL '.csv' (sparse: no disk used) as the measured data: refused at once,
    naming its size, the limit and the variable that changes it."""
    huge = tmp_path / "levels.csv"
    with open(huge, "wb") as stream:
        stream.truncate(2_000_000_000)
    peak_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    code = main(["identify", "--measured", str(huge), "--out", str(tmp_path / "id")])
    assert code == 2
    line = _one_error_line(capsys)
    assert str(huge) in line and "2000 MB" in line and "512 MB" in line and MAX_INPUT_ENV in line
    # ru_maxrss is in kB on Linux: reading the file would add 2 GB
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak_before < 200_000
    assert not (tmp_path / "id").exists()


def test_the_limit_is_set_by_the_environment_and_a_bad_value_named(tmp_path, monkeypatch):
    table = tmp_path / "table.csv"
    table.write_text("frequency_hz,h_real\n" + "1.0,2.0\n" * 2000)  # 16 kB
    monkeypatch.setenv(MAX_INPUT_ENV, "0.01")
    with pytest.raises(InputFileError, match=r"table\.csv: 0 MB is more than the input limit of 0\.01 MB"):
        read_input_bytes(table)
    monkeypatch.setenv(MAX_INPUT_ENV, "0")  # lifts the limit
    assert len(read_input_bytes(table)) == table.stat().st_size
    monkeypatch.setenv(MAX_INPUT_ENV, "lots")
    with pytest.raises(InputFileError, match=f"{MAX_INPUT_ENV}='lots': expected a number of megabytes"):
        read_input_bytes(table)


def test_text_with_nul_bytes_never_reaches_a_parser(tmp_path, capsys):
    nul = tmp_path / "levels.csv"
    nul.write_bytes(b"\x00" * 100_000)
    with pytest.raises(InputFileError, match="NUL"):
        read_input_text(nul)
    code = main(["identify", "--measured", str(nul), "--out", str(tmp_path / "id")])
    assert code == 2
    line = _one_error_line(capsys)
    assert str(nul) in line and "missing column" not in line


def test_a_fifo_is_refused_instead_of_waiting_for_a_writer(tmp_path):
    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    outcome: list[BaseException | bytes] = []
    reader = threading.Thread(target=lambda: outcome.append(_catch(read_input_bytes, fifo)), daemon=True)
    reader.start()
    reader.join(HANG_S)  # a refusal returns at once; only a blocked open() waits this out
    if reader.is_alive():  # it blocked in open(): release it before failing
        with open(fifo, "wb"):
            pass
        pytest.fail("reading a FIFO blocked waiting for a writer")
    assert isinstance(outcome[0], InputFileError) and "a pipe (FIFO)" in str(outcome[0])


def test_a_folder_is_refused_naming_it(tmp_path):
    with pytest.raises(InputFileError, match=r"is a folder; expected a regular file \(study file\)"):
        read_input_text(tmp_path, "study file")


def _catch(function, *args):
    try:
        return function(*args)
    except BaseException as error:  # noqa: BLE001 — handed to the test thread to assert on
        return error
