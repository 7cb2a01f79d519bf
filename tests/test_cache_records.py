"""Cache records are data, signed: a record someone else wrote never runs code and is
never used; it is named in one line and computed again (issue 19, item 2)."""
from __future__ import annotations

import base64
import dataclasses
import io
import json
import os
import pickle
import stat
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlupdate.fe.adapters.base import ModalResult
from nlupdate.notices import NlupdateWarning
from nlupdate.orchestration.tasks import records
from nlupdate.orchestration.tasks.store import RECORDS_FOLDER, sign, verified
from patience import HANG_S
from prefect_settings import talking_to


# ----------------------------------------------------------------------------- the codec


def test_results_round_trip_as_data():
    table = pd.DataFrame({"frequency_hz": [1.0, 2.0], "response_dof": ["a", "b"], "h": [1 + 2j, np.nan],
                          "rank": pd.array([1, None], dtype="Int64"), "label": pd.array(["x", None], dtype="string")})
    modes = ModalResult(natural_frequencies_hz=np.array([10.0, 20.0]), mode_shapes=np.eye(2), coordinates=("a", "b"))
    value = {"modes": modes, ("tuple", 1): [1, 2.5, float("inf"), -0.0, None, True, "x"],
             "complex": 1 - 1j, "array": np.arange(6, dtype=np.complex128).reshape(2, 3), "table": table,
             "scalar": np.float32(1.5), "path": Path("/a/b"), 7: (1, (2, 3)), "bytes": b"\x00\x01"}
    back = records.loads(records.dumps(value))
    assert back.keys() == value.keys()
    assert isinstance(back["modes"], ModalResult) and back["modes"].coordinates == ("a", "b")
    np.testing.assert_array_equal(back["modes"].natural_frequencies_hz, modes.natural_frequencies_hz)
    assert back[("tuple", 1)][:2] == [1, 2.5] and back[("tuple", 1)][2] == float("inf")
    assert back["complex"] == 1 - 1j and back["bytes"] == b"\x00\x01" and back[7] == (1, (2, 3)) and back["path"] == Path("/a/b")
    np.testing.assert_array_equal(back["array"], value["array"])
    assert back["scalar"].dtype == np.float32
    pd.testing.assert_frame_equal(back["table"], table)


def test_a_record_can_name_no_foreign_class_or_function():
    """A structure naming os.system, builtins.eval or a module outside nlupdate is refused
    before anything is imported or called."""
    for name in ("os:system", "builtins:eval", "subprocess:Popen", "nlupdate.orchestration.tasks.records:_trusted_class",
                 "nlupdate:__class__", "nlupdate.files:os"):
        structure = {"schema": records.SCHEMA, "value": {"object": name, "attributes": {}}}
        buffer = io.BytesIO()
        np.savez(buffer, structure=np.frombuffer(json.dumps(structure).encode(), dtype=np.uint8))
        with pytest.raises(records.RecordError):
            records.loads(buffer.getvalue())


def test_a_pickle_or_another_schema_is_not_a_record():
    with pytest.raises(records.RecordError, match="not a result record"):
        records.loads(pickle.dumps({"a": 1}))
    buffer = io.BytesIO()
    np.savez(buffer, structure=np.frombuffer(json.dumps({"schema": 0, "value": 1}).encode(), dtype=np.uint8))
    with pytest.raises(records.RecordError, match="schema 0"):
        records.loads(buffer.getvalue())


def test_what_is_not_data_cannot_be_written():
    with pytest.raises(records.RecordError, match=r"result\[0\]: a builtins.function"):
        records.dumps([lambda: 1])
    with pytest.raises(records.RecordError, match="numpy array of dtype object"):
        records.dumps(np.array([{}], dtype=object))


# ----------------------------------------------------------------------------- the signature


def test_the_signature_binds_content_and_key():
    secret = b"k" * 32
    stored = sign("key-a", b'{"x": 1}', secret)
    with pytest.raises(ValueError, match="not a Prefect result record"):
        verified("key-a", stored, secret)  # signed, but not a result record
    with pytest.raises(ValueError, match="signature does not match"):
        verified("key-b", stored, secret)  # copied to another key
    with pytest.raises(ValueError, match="signature does not match"):
        verified("key-a", stored[:-2] + b"2}", secret)  # edited
    with pytest.raises(ValueError, match="signature does not match"):
        verified("key-a", stored, b"j" * 32)  # another user's secret
    with pytest.raises(ValueError, match="not a signed nlupdate record"):
        verified("key-a", b'{"x": 1}', secret)


def test_the_cache_secret_is_private_and_refused_when_others_can_read_it(tmp_path, monkeypatch):
    from nlupdate.user_config import UserConfigError, cache_secret

    monkeypatch.setenv("NLUPDATE_CONFIG_DIR", str(tmp_path / "config"))
    monkeypatch.delenv("NLUPDATE_CACHE_SECRET_FILE", raising=False)
    key = cache_secret()
    path = tmp_path / "config" / "cache-secret"
    assert len(key) >= 32 and cache_secret() == key
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE((tmp_path / "config").stat().st_mode) == 0o700
    path.chmod(0o644)
    with pytest.raises(UserConfigError, match=r"readable or writable by others \(mode 0644\).*chmod 600"):
        cache_secret()
    shared = tmp_path / "cluster-secret"
    shared.write_text("s" * 64)
    shared.chmod(0o600)
    monkeypatch.setenv("NLUPDATE_CACHE_SECRET_FILE", str(shared))
    assert cache_secret() == b"s" * 64


def test_a_fifo_as_the_cache_secret_is_refused_without_blocking(tmp_path, monkeypatch):
    """Opening a FIFO for reading waits for a writer: the secret was opened before the
    regular-file check, and the run hung for good."""
    import threading

    from nlupdate.user_config import UserConfigError, cache_secret

    fifo = tmp_path / "secret-fifo"
    os.mkfifo(fifo, 0o600)
    monkeypatch.setenv("NLUPDATE_CACHE_SECRET_FILE", str(fifo))
    outcome: list = []

    def read_secret():
        try:
            outcome.append(cache_secret())
        except UserConfigError as error:
            outcome.append(error)

    reader = threading.Thread(target=read_secret, daemon=True)
    reader.start()
    reader.join(timeout=HANG_S)  # a refusal returns at once; only a blocked open() waits this out
    if reader.is_alive():  # release the blocked open: a writer arrives, and closes at once
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        reader.join(timeout=20)
        pytest.fail("reading a FIFO as the cache secret blocked")
    assert len(outcome) == 1 and isinstance(outcome[0], UserConfigError), outcome
    assert str(outcome[0]) == f"{fifo}: the cache secret must be a regular file"


# ----------------------------------------------------------------------------- attacks on a run's cache


class _Exploit:
    """Unpickling this writes a file: what a poisoned pickle record would do."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path(self.marker).write_text, ("code from the cache ran",))


def _run_twice_with(tmp_path, prefect_server, tamper):
    """A cached task (returning a ModalResult), run once; ``tamper(record_path)``; run
    again. Returns (state names, results, computations, warnings of the second run)."""
    from prefect import flow, task

    from nlupdate.orchestration.tasks.cached import configured

    calls = []

    @task(persist_result=True, cache_key_fn=lambda context, parameters: f"key-{parameters['k1']}")
    def step(k1: float) -> ModalResult:
        calls.append(k1)
        return ModalResult(natural_frequencies_hz=np.array([np.sqrt(k1)]), mode_shapes=np.ones((1, 1)), coordinates=("x",))

    @flow
    def run(k1: float):
        state = configured(step, tmp_path)(k1, return_state=True)
        return state.name, state.result()

    with talking_to(prefect_server):
        first = run(4.0)
        run(9.0)
        tamper(tmp_path / RECORDS_FOLDER)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            second = run(4.0)
    messages = [str(w.message) for w in caught if issubclass(w.category, NlupdateWarning)]
    return (first[0], second[0]), (first[1], second[1]), calls, messages


def test_a_poisoned_pickle_record_runs_no_code_and_is_recomputed(tmp_path, prefect_server):
    """The attack of the issue: a record rewritten as Prefect's own pickle record whose
    result runs code when unpickled. It is named in one line, not read, and recomputed."""
    marker = tmp_path / "pwned"

    def poison(folder: Path) -> None:
        from prefect._internal.result_records import ResultRecord, ResultRecordMetadata
        from prefect.serializers import PickleSerializer

        serializer = PickleSerializer(picklelib="pickle")
        record = ResultRecord(metadata=ResultRecordMetadata(serializer=serializer, storage_key=str(folder / "key-4.0")),
                              result=_Exploit(str(marker)))
        (folder / "key-4.0").write_bytes(record.serialize())

    states, results, calls, caught = _run_twice_with(tmp_path, prefect_server, poison)
    assert not marker.exists()
    assert states == ("Completed", "Completed") and calls == [4.0, 9.0, 4.0]
    assert results[1].natural_frequencies_hz[0] == 2.0
    assert caught == [f"cache record {tmp_path / RECORDS_FOLDER / 'key-4.0'}: not a signed nlupdate record (written by "
                      f"an older version or by something else); not used, the result is computed again"]
    # … and the record is rewritten, signed
    assert verified("key-4.0", (tmp_path / RECORDS_FOLDER / "key-4.0").read_bytes())


def _edit_result(content: bytes, edit) -> bytes:
    """A signed record with its result decoded, edited and encoded again, the old
    signature kept (what someone without the secret can do)."""
    head, _, payload = content.partition(b"\n")
    signature, _, payload = payload.partition(b"\n")
    record = json.loads(payload)
    value = records.loads(base64.b64decode(record["result"]))
    record["result"] = base64.b64encode(records.dumps(edit(value))).decode()
    return head + b"\n" + signature + b"\n" + json.dumps(record).encode()


def test_an_edited_number_is_detected_and_recomputed(tmp_path, prefect_server):
    def scale(folder: Path) -> None:
        path = folder / "key-4.0"
        path.write_bytes(_edit_result(path.read_bytes(), lambda modes: dataclasses.replace(
            modes, natural_frequencies_hz=modes.natural_frequencies_hz * 1.37)))

    states, results, calls, caught = _run_twice_with(tmp_path, prefect_server, scale)
    assert states == ("Completed", "Completed") and calls == [4.0, 9.0, 4.0]
    assert results[1].natural_frequencies_hz[0] == 2.0
    assert len(caught) == 1 and "key-4.0: its signature does not match (edited, copied from another key" in caught[0]


def test_a_record_copied_from_another_key_is_detected_and_recomputed(tmp_path, prefect_server):
    def copy(folder: Path) -> None:
        (folder / "key-4.0").write_bytes((folder / "key-9.0").read_bytes())

    states, results, calls, caught = _run_twice_with(tmp_path, prefect_server, copy)
    assert states == ("Completed", "Completed") and calls == [4.0, 9.0, 4.0]
    assert results[1].natural_frequencies_hz[0] == 2.0
    assert len(caught) == 1 and "key-4.0: its signature does not match" in caught[0]


def test_an_untouched_record_is_used(tmp_path, prefect_server):
    states, results, calls, caught = _run_twice_with(tmp_path, prefect_server, lambda folder: None)
    assert states == ("Completed", "Cached") and calls == [4.0, 9.0] and caught == []
    assert results[1].natural_frequencies_hz[0] == 2.0


def test_a_full_cache_disk_warns_once_and_the_run_goes_on(tmp_path, monkeypatch):
    """ENOSPC while writing a record: one warning naming the folder, the task's result is
    still returned (only caching stops)."""
    import errno

    from prefect.results import ResultStore

    import nlupdate.orchestration.tasks.store as store
    from nlupdate.orchestration.tasks.cached import configured
    from prefect import task

    @task
    def step():
        pass

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(store, "write_bytes_atomic", full)
    configured_step = configured(step, tmp_path)
    result_store = ResultStore(result_storage=configured_step.result_storage, serializer=configured_step.result_serializer)
    with pytest.warns(UserWarning) as caught:
        result_store.write(obj=1, key="a")
        result_store.write(obj=2, key="b")
    messages = [str(w.message) for w in caught]
    assert messages == [f"cache folder {tmp_path / RECORDS_FOLDER}: cannot write records (No space left on device); "
                        f"results from now on are not cached"]


def test_records_read_on_threads_never_parse_array_headers_at_once(monkeypatch):
    """numpy parses every array header with ast.literal_eval, and CPython 3.11's AST
    construction is not thread-safe (python/cpython#106905): two cached tasks read on a
    flow's threads under load failed with 'SystemError: AST constructor recursion depth
    mismatch'. Record reads take turns; a header parse held open (1 ms) shows any overlap."""
    import ast
    import threading
    import time as clock

    from nlupdate.orchestration.tasks import records

    blob = records.dumps({"curves": [np.arange(5.0 + i) for i in range(8)]})
    parse, inside, most = ast.literal_eval, [0], [0]
    lock = threading.Lock()

    def slow_parse(text):
        with lock:
            inside[0] += 1
            most[0] = max(most[0], inside[0])
        clock.sleep(0.001)
        try:
            return parse(text)
        finally:
            with lock:
                inside[0] -= 1

    monkeypatch.setattr(ast, "literal_eval", slow_parse)
    errors = []

    def read():
        try:
            for _ in range(5):
                records.loads(blob)
        except Exception as error:  # noqa: BLE001 - counted
            errors.append(error)

    threads = [threading.Thread(target=read) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == [] and most[0] == 1, (errors, most)


def test_record_paths_resolve_as_prefect_resolves_them_and_never_outside_the_folder(tmp_path):
    """The store resolves its folder once (a record path costs one lstat): every path it
    resolves equals Prefect's own resolution (LocalFileSystem._resolve_path, the
    reference), and a record that is a symbolic link out of the folder is refused as
    Prefect refuses it."""
    from prefect.filesystems import LocalFileSystem

    from nlupdate.orchestration.tasks.store import record_store

    real = tmp_path / "real"
    (real / RECORDS_FOLDER).mkdir(parents=True)
    (tmp_path / "link").symlink_to(real)  # the cache folder named through a link
    store = record_store(tmp_path / "link")
    prefect_own = LocalFileSystem(basepath=store.basepath)
    key = "a3f9" * 16
    folder = real / RECORDS_FOLDER
    for path in (None, "", key, str(folder / key), "sub/" + key, str(tmp_path / "link" / RECORDS_FOLDER / key)):
        assert store._resolve_path(path) == prefect_own._resolve_path(path), path
    outside = tmp_path / "elsewhere"
    outside.write_bytes(b"x")
    (folder / "escape").symlink_to(outside)
    for resolve in (store._resolve_path, prefect_own._resolve_path):
        with pytest.raises(ValueError, match="outside of the base path"):
            resolve("escape")
        with pytest.raises(ValueError, match="outside of the base path"):
            resolve("../../elsewhere")
