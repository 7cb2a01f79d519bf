"""core/run_cache.py: a pure function's results remembered within one run, and only there."""
import sys

import numpy as np

from nlupdate.core.run_cache import one_run, remembered_in_run

calls = []
SCALE = 2.0  # a module setting the function reads: outside a run a change of it is seen


@remembered_in_run
def scaled(values, offset=0.0):
    calls.append(1)
    return {"out": np.asarray(values, dtype=float) * SCALE + offset}


def test_each_distinct_input_is_computed_once_within_a_run_and_every_call_outside_one(monkeypatch):
    calls.clear()
    with one_run():
        first = scaled(np.array([1.0, 2.0]))
        again = scaled(np.array([1.0, 2.0]))
        other = scaled(np.array([1.0, 2.0]), offset=1.0)
        bits = scaled(np.array([1.0, np.nextafter(2.0, 3.0)]))  # one bit apart: another input
        with one_run():  # a nested block shares the outer one's results
            inner = scaled(np.array([1.0, 2.0]))
        defaulted = scaled(np.array([1.0, 2.0]), 0.0)  # the same input as the first: its default given
        named = scaled(values=np.array([1.0, 2.0]), offset=1.0)  # as ``other``, by name
    assert len(calls) == 3
    for result in (first, again, inner, defaulted):
        np.testing.assert_array_equal(result["out"], [2.0, 4.0])
    np.testing.assert_array_equal(other["out"], [3.0, 5.0])
    np.testing.assert_array_equal(named["out"], [3.0, 5.0])
    assert bits["out"][1] == 2 * np.nextafter(2.0, 3.0)

    calls.clear()
    monkeypatch.setattr(sys.modules[__name__], "SCALE", 3.0)
    np.testing.assert_array_equal(scaled(np.array([1.0, 2.0]))["out"], [3.0, 6.0])
    scaled(np.array([1.0, 2.0]))
    assert len(calls) == 2


def test_a_result_changed_in_place_changes_no_later_call():
    with one_run():
        first = scaled([1.0, 2.0])
        first["out"][0] = -1.0
        first["extra"] = True
        assert set(scaled([1.0, 2.0])) == {"out"}
        np.testing.assert_array_equal(scaled([1.0, 2.0])["out"], [2.0, 4.0])


def test_arguments_that_do_not_pickle_and_errors_are_not_remembered():
    @remembered_in_run
    def apply(function, x):
        calls.append(1)
        return function(x)

    @remembered_in_run
    def fails(x):
        calls.append(1)
        raise ValueError(f"no {x}")

    calls.clear()
    with one_run():
        assert apply(lambda x: x + 1, 1) == 2 and apply(lambda x: x + 2, 1) == 3
        for _ in range(2):
            try:
                fails(1)
            except ValueError as error:
                assert str(error) == "no 1"
    assert len(calls) == 4
