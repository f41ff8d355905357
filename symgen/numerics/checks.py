"""The run checks of a mechanism, one home for Python (the emitted C runs the same checks
under the same policy, the C runtime's ``symgen/backends/c/runtime/symgen_solver.c``; ``tests/test_check_parity.py``):

* ``singular_ratio``: sigma_min / sigma_max of the closure Jacobian in the dependent rigid
  coordinates (a singular position: a toggle, a change point), compared with
  ``POLICY.singular_ratio`` / ``POLICY.near_singular_ratio`` by the runners;
* ``beyond_range``: a bar deformed beyond the range of the bar model (``POLICY.deflection_limit``,
  ``POLICY.stretch_limit``);
* ``divergent_deformation``: a quasi-static state beyond a buckling load (a real, positive
  eigenvalue of the linearised motion of the amplitudes, ``POLICY.divergence_rtol``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.ir.records import RowKind
from symgen.numerics.index1 import Partition, index1
from symgen.policy import POLICY

if TYPE_CHECKING:
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


def beyond_range(mech: Mechanism, Q: ArrayLike) -> tuple[int, str] | None:
    """First column of Q (coordinates x outputs) where a bar is deformed beyond the range
    of the model (``POLICY.deflection_limit``, ``POLICY.stretch_limit``), with the reason; None if none."""
    Q = np.asarray(Q, dtype=float).reshape(mech.n, -1)
    first = None
    for body, (fi, gi) in mech.amplitudes.items():
        for idx, limit, what in (
            (gi, POLICY.deflection_limit, "transverse deflection"),
            (fi, POLICY.stretch_limit, "axial displacement"),
        ):
            if not idx:
                continue
            size = np.abs(Q[list(idx)]).sum(axis=0)
            bad = np.nonzero(~(size <= limit))[0]  # NaN counts as beyond
            if len(bad) and (first is None or bad[0] < first[0]):
                first = (int(bad[0]), body, what, float(size[bad[0]]), limit)
    if first is None:
        return None
    k, body, what, size, limit = first
    return k, (
        f"bar '{body}' is deformed beyond the range of the model: its {what} amplitudes "
        f"sum to {size:.3g} of its length (limit {limit:g}; the bar equations hold for moderate "
        f"rotations and small strains): a load beyond a buckling load, or forces the bar "
        f"cannot carry"
    )


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
