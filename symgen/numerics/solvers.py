"""The solvers of a run, by name: what ``--solver`` and the Python API's ``solver=`` take.

Kept free of CasADi, NumPy and SymPy: the command line's parser names them (its start-up stays
lean); the runs are in :mod:`symgen.numerics.simulate` (IDAS) and :mod:`symgen.numerics.csolver`
(the emitted C Radau IIA), one call for both: :func:`symgen.numerics.csolver.run`.
"""

from __future__ import annotations

from symgen.errors import SceneError

#: SUNDIALS IDAS through CasADi (the default), the emitted C Radau IIA
SOLVERS = ("idas", "c")
SOLVER_HELP = (
    "idas (default: SUNDIALS IDAS through CasADi) or c (the emitted C Radau IIA solver, compiled once "
    "per model and cached, run in this process with dense output: faster on stiff bars and long runs; "
    "the first run of a model compiles it)"
)


def check_solver(solver: str, key: str = "--solver") -> str:
    """``solver`` if it is one of :data:`SOLVERS`, else a SceneError naming ``key``."""
    if solver not in SOLVERS:
        raise SceneError(
            "command line", key, f"is {solver!r}; it must be one of {', '.join(SOLVERS)}", "e.g. --solver c"
        )
    return solver
