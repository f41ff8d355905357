"""A run of the C solver held as its library's rows (``SimResult.of_rows``) and the CSV written
from rows (``ResultUnits.convert_rows``, ``rows_text``): the same arrays and the same bytes as
the arrays' path (``ResultUnits.convert``, ``csv_text``), to the bit."""

from __future__ import annotations

import copy
import ctypes
import dataclasses
import pickle

import numpy as np

from symgen.numerics.results import csv_text, rows_text
from symgen.numerics.run_result import SimResult, table_rows
from symgen.numerics.units import ColumnUnit, ResultUnits

N_OUT, N, M = 3, 4, 2
WIDTH = 1 + N_OUT + 2 * N + M


def _record(count: int, capacity: int, seed: int = 1) -> tuple[ctypes.Array, np.ndarray]:
    """A flat ctypes buffer of ``capacity`` rows, the first ``count`` filled, and those rows."""
    rng = np.random.default_rng(seed)
    table = rng.normal(size=(count, WIDTH)) * 10.0 ** rng.integers(-12, 12, size=(count, WIDTH))
    buf = (ctypes.c_double * (capacity * WIDTH))()
    for k, x in enumerate(table.ravel().tolist()):
        buf[k] = x
    return buf, table


def _of_rows(buf: ctypes.Array, count: int) -> SimResult:
    return SimResult.of_rows(
        buf, count, N_OUT, N, M, output_names=["a", "b", "c"], closure_max=0.0, steps=7, simulate_s=0.0, partition=None
    )


def test_the_rows_and_the_arrays_of_a_c_run_are_its_records():
    buf, table = _record(5, 9)
    res = _of_rows(buf, 5)
    assert res.n_rows == 5 and res.steps == 7 and res.stats == {} and res.complete
    rows = list(res.rows(states=True))
    assert "tau" not in vars(res)  # the rows are read without the arrays
    assert rows == [r[: 1 + N_OUT + N] for r in table.tolist()]
    assert list(res.rows()) == [r[: 1 + N_OUT] for r in table.tolist()]
    a = 1 + N_OUT
    np.testing.assert_array_equal(res.tau, table[:, 0])
    np.testing.assert_array_equal(res.outputs, table[:, 1:a])
    np.testing.assert_array_equal(res.q, table[:, a : a + N])
    np.testing.assert_array_equal(res.v, table[:, a + N : a + 2 * N])
    np.testing.assert_array_equal(res.lam, table[:, a + 2 * N :])
    np.testing.assert_array_equal(res.column("b"), table[:, 2])
    assert list(res.rows(states=True)) == rows == list(table_rows(res.tau, res.outputs, res.q))
    res.outputs[0, 0] = 1.5  # a changed array is what the rows say from then on
    assert next(res.rows())[1] == 1.5
    changed = dataclasses.replace(res, steps=8)
    assert isinstance(changed, SimResult) and changed.steps == 8 and changed.n_rows == 5
    np.testing.assert_array_equal(changed.q, res.q)
    for again in (pickle.loads(pickle.dumps(_of_rows(buf, 5))), copy.deepcopy(_of_rows(buf, 5))):
        assert type(again) is SimResult and again.n_rows == 5 and again.steps == 7
        np.testing.assert_array_equal(again.lam, table[:, a + 2 * N :])


def test_an_empty_c_run_has_no_rows():
    buf, _ = _record(0, 3)
    res = _of_rows(buf, 0)
    assert res.n_rows == 0 and list(res.rows()) == []
    assert res.tau.shape == (0,) and res.outputs.shape == (0, N_OUT)


def test_rows_in_the_results_units_are_the_arrays_in_them_to_the_bit():
    _, table = _record(40, 40, seed=3)
    tau, outputs, q = table[:, 0], table[:, 1 : 1 + N_OUT], table[:, 1 + N_OUT : 1 + N_OUT + N]
    names = ["a", "b", "c"]
    for factors in ((1.0, 1.0, 1.0, 1.0), (0.004347826086956522, 0.1, 14.283000000000003, 1.0 / 3.0)):
        units = ResultUnits(
            "SI", ColumnUnit("t", "s", factors[0]), tuple(ColumnUnit(n, "m", f) for n, f in zip(names, factors[1:]))
        )
        t_col, values = units.convert(tau, outputs)
        expected = csv_text(t_col, np.hstack([values, q]), names + ["q1", "q2", "q3", "q4"], "t")
        got = rows_text(units.convert_rows(table_rows(tau, outputs, q)), names + ["q1", "q2", "q3", "q4"], "t")
        assert got == expected
