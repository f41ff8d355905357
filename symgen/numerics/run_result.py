"""The record of one run (:class:`SimResult`), whichever solver made it: IDAS
(:mod:`symgen.numerics.simulate`) or the emitted C solver (:mod:`symgen.numerics.csolver`). Its
own module, light (numpy on first use only), so that a cached run of the C solver never imports
CasADi, nor numpy: its result holds the library's rows (:meth:`SimResult.of_rows`) until an
array is read, and its files are written from the rows (:meth:`SimResult.rows`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Generic, TypeVar

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.numerics.index1 import Partition

#: the array fields of a run, in the order of a row of the C solver's record
ARRAYS = ("tau", "outputs", "q", "v", "lam")


@dataclass
class SimResult:
    tau: np.ndarray
    outputs: np.ndarray  # (N, n_out)
    output_names: list[str]
    q: np.ndarray  # (N, n)
    v: np.ndarray
    lam: np.ndarray
    closure_max: float
    steps: int
    simulate_s: float
    partition: Partition | None  # None: the emitted C solver's run (symgen.numerics.csolver)
    complete: bool = True
    failure: str = ""
    stats: dict[str, str | float | None] = field(default_factory=dict)  # backend, library, timings
    #: the outputs whose first sample is the continuum's joint force at an unstressed start
    #: (``symgen.numerics.start.continuum_start_outputs``), not the model's own: both solvers' runs
    start_forces: tuple[str, ...] = ()
    #: the emitted C solver's range record, kept during its run over the same rows: (the warning
    #: slope it watched, per bar the values of ``checks.C_RANGE_FIELDS``); None: made from q
    #: (``symgen.numerics.checks.range_record``)
    range_maxima: tuple[float, tuple[tuple[float, ...], ...]] | None = None

    def column(self, name: str) -> np.ndarray:
        """The output called ``name`` (as in the scene's [outputs])."""
        return self.outputs[:, self.output_names.index(name)]

    def peaks(self) -> dict[str, float]:
        """output -> its largest |value| over the run, 0.0 where that is zero to round-off (at or
        below :data:`symgen.policy.ZERO_PEAK` in the model's unit of the output's kind): the one
        peak every estimate is a fraction of and every decision reads (not finite: as it is)."""
        from symgen.policy import ZERO_PEAK

        return {n: (0.0 if p <= ZERO_PEAK else p) for n, p in self._largest().items()}

    def zero_outputs(self) -> dict[str, float]:
        """output -> its largest |value|, for the outputs that are zero to round-off over the run
        (:meth:`peaks`), in the output order."""
        from symgen.policy import ZERO_PEAK

        return {n: p for n, p in self._largest().items() if p <= ZERO_PEAK}

    def _largest(self) -> dict[str, float]:
        out = np.asarray(self.outputs, dtype=float)
        if not len(out):
            return dict.fromkeys(self.output_names, 0.0)
        return {n: float(p) for n, p in zip(self.output_names, np.max(np.abs(out), axis=0))}

    @property
    def n_rows(self) -> int:
        """The number of output rows (without reading the arrays of a C run)."""
        return len(self.tau)

    def rows(self, states: bool = False) -> Iterator[list[float]]:
        """The rows [tau, outputs..., (q... when ``states``)] as floats (for the CSV)."""
        return table_rows(self.tau, self.outputs, self.q if states else None)

    @staticmethod
    def of_rows(rows: Any, count: int, n_out: int, n: int, m: int, **fields: Any) -> SimResult:
        """The run of the first ``count`` rows of the C solver's record ``rows`` (flat doubles, a
        buffer, row after row: tau, the ``n_out`` outputs, q and v (``n`` each), lam (``m``)) and the
        other ``fields``: its arrays made (by numpy) on first read, its rows read as they are."""
        made = _RowsResult.__new__(_RowsResult)  # not through __init__: dataclasses.replace() calls that
        made._hold(rows, count, (n_out, n, m), fields)
        return made


def table_rows(tau: Any, outputs: Any, q: Any = None) -> Iterator[list[float]]:
    """The rows [tau, outputs..., (q...)] of arrays (or sequences) as lists of floats."""
    tau_list = tau.tolist() if hasattr(tau, "tolist") else list(tau)
    out_list = outputs.tolist() if hasattr(outputs, "tolist") else [list(r) for r in outputs]
    if q is None:
        return ([t, *o] for t, o in zip(tau_list, out_list))
    q_list = q.tolist() if hasattr(q, "tolist") else [list(r) for r in q]
    return ([t, *o, *x] for t, o, x in zip(tau_list, out_list, q_list))


class _RowsResult(SimResult):
    """A :class:`SimResult` that holds the C solver's flat record until an array is read
    (:meth:`SimResult.of_rows`)."""

    def _hold(self, rows: Any, count: int, sizes: tuple[int, int, int], fields: dict[str, Any]) -> None:
        self._record = (rows, count, sizes)
        for f in dataclasses.fields(SimResult):
            if f.name in ARRAYS:
                continue
            if f.name in fields:
                value = fields.pop(f.name)
            elif f.default is not dataclasses.MISSING:
                value = f.default
            elif f.default_factory is not dataclasses.MISSING:
                value = f.default_factory()
            else:
                raise TypeError(f"SimResult.of_rows() missing the field {f.name!r}")
            setattr(self, f.name, value)
        if fields:
            raise TypeError(f"SimResult.of_rows() got unknown fields {sorted(fields)}")

    def __getattr__(self, name: str) -> Any:  # an array field not made yet
        if name not in ARRAYS or "_record" not in self.__dict__:
            raise AttributeError(name)
        rows, count, (n_out, n, m) = self._record
        width, a = 1 + n_out + 2 * n + m, 1 + n_out
        block = np.frombuffer(rows, dtype=float, count=count * width).reshape(count, width)
        made = {
            "tau": block[:, 0].copy(),
            "outputs": block[:, 1:a].copy(),
            "q": block[:, a : a + n].copy(),
            "v": block[:, a + n : a + 2 * n].copy(),
            "lam": block[:, a + 2 * n :].copy(),
        }
        self.__dict__.update(made)
        return made[name]

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled and copied as the plain :class:`SimResult` of its arrays (a ctypes buffer is not
        picklable)."""
        return SimResult, tuple(getattr(self, f.name) for f in dataclasses.fields(SimResult))

    def _arrays_made(self) -> bool:
        """The arrays were made (and may have been changed since), or given (``dataclasses.replace``)."""
        return "_record" not in self.__dict__ or any(k in self.__dict__ for k in ARRAYS)

    @property
    def n_rows(self) -> int:
        return len(self.tau) if self._arrays_made() else int(self._record[1])

    def rows(self, states: bool = False) -> Iterator[list[float]]:
        if self._arrays_made():
            return super().rows(states)
        rows, count, (n_out, n, m) = self._record
        width, end = 1 + n_out + 2 * n + m, 1 + n_out + (n if states else 0)
        return (list(rows[k * width : k * width + end]) for k in range(count))


T = TypeVar("T")


class MeasuredOnce(Generic[T]):
    """A measure a run-time decision made on one run (``effects.axial = "auto"``'s axial part,
    the chosen counts' truncation part), kept for that run's error estimate to read once instead
    of making the same reruns again: read only for those very objects (the mechanism and the
    result, by identity) and the same ``key``; one slot, the previous measure dropped."""

    def __init__(self) -> None:
        self._slot: list[tuple[object, object, object, T]] = []

    def keep(self, mech: object, result: object, value: T, key: object = None) -> None:
        self._slot[:] = [(mech, result, key, value)]

    def drop(self) -> None:
        self._slot.clear()

    def take(self, mech: object, result: object, key: object = None) -> T | None:
        """The measure kept for this run and ``key`` (and forget it), else None (the slot emptied)."""
        if not self._slot:
            return None
        m, r, k, value = self._slot.pop()
        return value if m is mech and r is result and k == key else None
