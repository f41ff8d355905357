"""The record of one run (:class:`SimResult`), whichever solver made it: IDAS
(:mod:`symgen.numerics.simulate`) or the emitted C solver (:mod:`symgen.numerics.csolver`). Its
own module, light (numpy only), so that a cached run of the C solver never imports CasADi."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Generic, TypeVar

import numpy as np

from symgen.numerics.index1 import Partition


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

    def column(self, name: str) -> np.ndarray:
        """The output called ``name`` (as in the scene's [outputs])."""
        return self.outputs[:, self.output_names.index(name)]


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
