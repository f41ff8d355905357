"""The index-1 form of a mechanism's DAE for a partition of its coordinates.

The rigid coordinates split into dependent ones q_D (one per closure row) and independent ones;
with x = [q_I, v_I] differential and z = [q_D, v_D, a, lam] algebraic, the algebraic equations
are [phi; phid; res; phidd] (``symgen.numerics.mechanism`` chooses the partition).

Quasi-static amplitudes h (``Partition.quasi``, docs/quasi-static-modes.md) are neither
independent nor dependent: their rates and accelerations are zero in every equation, and the
slot of a_h in z holds q_h instead, so z = [q_D, v_D, a with q_h in place of a_h, lam] keeps its
size and the rows res_h (which no longer read a_h) determine q_h.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

if TYPE_CHECKING:
    import casadi as ca  # imported where used: a cached run of the C solver never imports CasADi


@dataclass(frozen=True)
class Partition:
    ind: tuple[int, ...]  # indices of independent coordinates (differential)
    dep: tuple[int, ...]  # indices of dependent rigid coordinates (algebraic)
    quasi: tuple[int, ...] = ()  # quasi-static amplitudes (algebraic: q in the slot of a, v = a = 0)

    def pack(self, q: np.ndarray, v: np.ndarray, a: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x, z) of a state (the inverse of :func:`index1`'s split)."""
        I, D, Q = list(self.ind), list(self.dep), list(self.quasi)
        a = np.array(a, dtype=float)
        a[Q] = np.asarray(q, dtype=float)[Q]
        return np.concatenate([q[I], v[I]]), np.concatenate([q[D], v[D], a, lam])


@dataclass(frozen=True)
class Index1:
    """Symbols of the index-1 DAE of a partition: x = [q_I, v_I], z = [q_D, v_D, a, lam]."""

    x: ca.SX
    z: ca.SX
    q: ca.SX
    v: ca.SX
    a: ca.SX
    lam: ca.SX

    def alg(self, f: Mapping[str, ca.Function], t: ca.SX | float, p: ca.SX | np.ndarray) -> ca.SX:
        """The algebraic equations [phi; phid; res; phidd] at time t with parameters p."""
        import casadi as ca

        args = [t, self.q, self.v, self.a, self.lam, p]
        return ca.vertcat(*(f[k](*args) for k in ("phi", "phid", "res", "phidd")))


def index1(n: int, m: int, part: Partition) -> Index1:
    """The split of (x, z) into coordinates, rates, accelerations and multipliers."""
    import casadi as ca

    I, D = list(part.ind), list(part.dep)
    nI, nD = len(I), len(D)
    x = ca.SX.sym("x", 2 * nI)
    z = ca.SX.sym("z", 2 * nD + n + m)
    q, v = ca.SX.zeros(n), ca.SX.zeros(n)
    for k, i in enumerate(I):
        q[i], v[i] = x[k], x[nI + k]
    for k, i in enumerate(D):
        q[i], v[i] = z[k], z[nD + k]
    # row slices with an explicit column: CasADi slices a 1 x 1 matrix by a single index as a
    # row, so z[1:] of a one-element z (one coordinate, no multiplier) would be 1 x 0, not 0 x 1
    a = ca.SX(z[2 * nD : 2 * nD + n, 0])
    for i in part.quasi:
        q[i], a[i] = z[2 * nD + i], 0
    return Index1(x, z, q, v, a, z[2 * nD + n :, 0])
