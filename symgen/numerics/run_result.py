"""The record of one run (:class:`SimResult`), whichever solver made it: IDAS
(:mod:`symgen.numerics.simulate`) or the emitted C solver (:mod:`symgen.numerics.csolver`). Its
own module, light (numpy only), so that a cached run of the C solver never imports CasADi."""

from __future__ import annotations

from dataclasses import dataclass, field

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
