"""The run checks of a mechanism, one home for Python (the emitted C runs the same checks
under the same policy, the C runtime's ``symgen/backends/c/runtime/symgen_solver.c``; ``tests/test_check_parity.py``):

* ``singular_ratio``: sigma_min / sigma_max of the closure Jacobian in the dependent rigid
  coordinates (a singular position: a toggle, a change point), compared with
  ``POLICY.singular_ratio`` / ``POLICY.near_singular_ratio`` by the runners;
* ``beyond_range``: a bar deformed beyond the range of the bar model (its largest slope beyond
  ``POLICY.slope_limit``, its axial amplitudes beyond ``POLICY.stretch_limit``);
* ``range_record``: where an exact bar's slopes pass the accuracy's limit (``RANGE``): a warning
  made after the run from its coordinates, the same for both solvers;
* ``divergent_deformation``: a quasi-static state beyond a buckling load (a real, positive
  eigenvalue of the linearised motion of the amplitudes, ``POLICY.divergence_rtol``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.ir.records import RowKind
from symgen.numerics.index1 import Partition, index1
from symgen.policy import POLICY, RANGE, range_message

if TYPE_CHECKING:
    from symgen.ir.info import ModelInfo
    from symgen.numerics.mechanism import Mechanism


def singular_ratio(mech: Mechanism, t: float, q: np.ndarray, part: Partition) -> tuple[float, int]:
    """Smallest / largest singular value of the loop and driver rows' Jacobian in the
    dependent rigid coordinates (inextensibility rows and their axial amplitudes, a
    regular block Ka, are left out: the rigid mechanism alone decides singularity)."""
    rows = [i for i in range(mech.m) if i not in mech.inext_rows]
    cols = [i for i in part.dep if i not in mech.inext_f]
    if not cols:
        return 1.0, 0
    Jd = mech.jac_q(t, q)[np.ix_(rows, cols)]
    u, s, _ = np.linalg.svd(Jd)
    weights = np.zeros(mech.m)
    weights[rows] = u[:, -1]
    return float(s[-1] / max(s[0], 1e-300)), loop_row(mech, weights)


def worst_row(mech: Mechanism, Jd: np.ndarray) -> int:
    if Jd.shape[1] == 0:
        return 0
    u, s, _ = np.linalg.svd(Jd)
    return loop_row(mech, u[:, -1])


def loop_row(mech: Mechanism, weights: ArrayLike) -> int:
    """The closure row (a loop, not the driver) that weighs most in a singular direction."""
    w = np.abs(np.asarray(weights, dtype=float))
    if len(w) > 1:
        w[list(mech.info.rows(RowKind.DRIVER, RowKind.INEXTENSIBLE))] = -1.0
    return int(np.argmax(w))


#: the slope tables read in this process, by the model's structure key
_SLOPES: dict[str, dict[str, np.ndarray]] = {}


def slope_tables(info: ModelInfo) -> dict[str, np.ndarray]:
    """bar -> P (points x its transverse amplitudes): P[j, a] = psi_a'(xi_j), so that the bar's
    slopes there are P @ g, at the points of :meth:`symgen.ir.shape_samples.ShapeSamples.slope_table`
    (the model-form estimate's samples, from the signed cache). The emitted C solver's range
    check reads the same tables (``symgen.backends.c.context``)."""
    from symgen.numerics.model_form import _samples

    if info.key in _SLOPES:
        return _SLOPES[info.key]
    bodies = {b["name"]: b for b in info.structure.get("bodies", [])}
    tables = {}
    for body, (_, gi) in info.amplitudes.items():
        if gi:
            tables[body] = np.asarray(_samples(bodies[body]).slope_table(), dtype=float).reshape(-1, len(gi))
    _SLOPES[info.key] = tables
    return tables


def slopes(info: ModelInfo, Q: ArrayLike) -> dict[str, np.ndarray]:
    """bar -> its largest |eta'| over the points of :func:`slope_tables`, per column of Q
    (coordinates x samples)."""
    Q = np.asarray(Q, dtype=float).reshape(info.n, -1)
    tables = slope_tables(info)
    return {body: np.abs(P @ Q[list(info.amplitudes[body][1])]).max(axis=0) for body, P in tables.items()}


def beyond_range(mech: Mechanism, Q: ArrayLike) -> tuple[int, str] | None:
    """First column of Q (coordinates x outputs) where a bar is deformed beyond the range of the
    model (its largest slope beyond ``POLICY.slope_limit``, its axial amplitudes beyond
    ``POLICY.stretch_limit``), with the reason; None if none."""
    Q = np.asarray(Q, dtype=float).reshape(mech.n, -1)
    first = None
    slope = slopes(mech.info, Q)
    for body, (fi, gi) in mech.amplitudes.items():
        sizes = []
        if gi:
            sizes.append((slope[body], POLICY.slope_limit, "slope"))
        if fi:
            sizes.append((np.abs(Q[list(fi)]).sum(axis=0), POLICY.stretch_limit, "axial displacement"))
        for size, limit, what in sizes:
            bad = np.nonzero(~(size <= limit))[0]  # NaN counts as beyond
            if len(bad) and (first is None or bad[0] < first[0]):
                first = (int(bad[0]), body, what, float(size[bad[0]]), limit)
    if first is None:
        return None
    k, body, what, value, limit = first
    return k, range_message(body, what, limit, f"{value:.3g}" + ("" if what == "slope" else " of its length"))


def range_record(info: ModelInfo, tau: ArrayLike, Q: ArrayLike, accuracy: float) -> dict[str, Any]:
    """The sidecar's ``range``: each bar's largest slope over the run and when; for the exact bar
    (``effects.strain = "exact"``), the first time each bar's slope passed the accuracy's limit
    (``RANGE.warning_limit``), a warning. The von Karman and linear bars' model form is the
    error estimate's (``symgen.numerics.model_form``): no warning here. Q: samples x coordinates."""
    tau = np.asarray(tau, dtype=float).ravel()
    Q = np.asarray(Q, dtype=float).reshape(len(tau), info.n)
    exact = (info.structure.get("effects") or {}).get("strain") == "exact"
    limit = RANGE.warning_limit(accuracy)
    record: dict[str, Any] = {
        "slope_limit": POLICY.slope_limit,
        "warning_limit": limit if exact else None,
        "rule": (
            f"the exact bar's left-out terms cost about {RANGE.error_per_slope6:g} slope^6 of an output's peak: "
            f"a warning where a bar's largest slope passes (accuracy / {RANGE.error_per_slope6:g})^(1/6); "
            f"the run stops at slope {POLICY.slope_limit:g}"
            if exact
            else "von Karman or linear bars: their model form is the error estimate's; the run stops at slope "
            f"{POLICY.slope_limit:g}"
        ),
        "largest_slope": {},
        "warnings": [],
    }
    if len(tau) == 0:
        return record
    for body, s in slopes(info, Q.T).items():
        k = int(np.argmax(np.where(np.isfinite(s), s, -1.0)))
        record["largest_slope"][body] = {"slope": float(s[k]), "tau": float(tau[k])}
        over = np.nonzero(~(s <= limit))[0]
        if exact and len(over):
            j = int(over[0])
            record["warnings"].append(
                {
                    "bar": body,
                    "tau": float(tau[j]),
                    "slope": float(s[j]),
                    "message": (
                        f"bar '{body}' passes slope {limit:.3g} at tau = {tau[j]:.6g} (largest {s[k]:.3g} at tau = "
                        f"{tau[k]:.6g}): the exact bar's left-out terms (about {RANGE.error_per_slope6:g} slope^6 of "
                        f"peak) exceed simulation.accuracy = {accuracy:g} from there on"
                    ),
                }
            )
    record["warnings"].sort(key=lambda w: w["tau"])
    return record


def divergent_deformation(
    mech: Mechanism, t: float, q: np.ndarray, v: np.ndarray, part: Partition
) -> tuple[float, str]:
    """Largest real, positive eigenvalue of the linearised motion of the independent
    deformation amplitudes about (q, v) (rigid independent coordinates held; dependent
    ones follow the closure), and the amplitude dominating its eigenvector. Positive:
    the state is statically unstable (beyond a buckling load). (0.0, "") if none."""
    E = [i for i in part.ind if mech.coords[i].elastic]
    if not E:
        return 0.0, ""
    import casadi as ca  # here: a cached run of the C solver never imports CasADi

    I, D = list(part.ind), list(part.dep)
    nI, nD = len(I), len(D)
    sys_ = index1(mech.n, mech.m, part)
    G = sys_.alg(mech.f, t, mech.p)
    jac = ca.Function("lin", [sys_.x, sys_.z], [ca.jacobian(G, sys_.x), ca.jacobian(G, sys_.z)])
    a, lam = mech.accelerations(t, q, v)
    Gx, Gz = (np.array(w) for w in jac(np.concatenate([q[I], v[I]]), np.concatenate([q[D], v[D], a, lam])))
    dzdx = -np.linalg.solve(Gz, Gx)
    e = [I.index(i) for i in E]
    cols = e + [nI + k for k in e]
    A = np.zeros((2 * len(E), 2 * len(E)))
    A[: len(E), len(E) :] = np.eye(len(E))
    A[len(E) :, :] = dzdx[[2 * nD + i for i in E]][:, cols]
    s, W = np.linalg.eig(A)
    scale = max(1.0, float(np.abs(s).max()))
    tol = POLICY.divergence_rtol * scale
    real = [k for k in range(len(s)) if abs(s[k].imag) <= tol and s[k].real > tol]
    if not real:
        return 0.0, ""
    k = max(real, key=lambda j: s[j].real)
    return float(s[k].real), mech.coords[E[int(np.argmax(np.abs(W[: len(E), k])))]].name
