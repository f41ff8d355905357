"""Static equilibrium of a mechanism with free degrees of freedom, and the frozen DAE about it.

A mechanism whose rigid coordinates are not all fixed by the closure and the prescribed
(angle-driven) coordinates -- no driver, a torque driver, or bars left undriven -- has no
quasi-static response (18)-(20): its rigid motion is not known without the dynamics. What it
has is a static equilibrium at each input position tau: every rate and acceleration zero, the
prescribed coordinates at their value at tau, gravity, the loads and the driver torques frozen
at their values at tau, and

    res(tau, q, 0, 0, lam) = 0,   phi(tau, q) = 0

for all coordinates q (free rigid coordinates, dependent ones and every deformation amplitude)
and the multipliers lam (the reactions, and the torque an angle driver needs to hold its bar).

The solve is Newton from the start (``initial.guess``, assembled at tau) with a pseudo-time
term (pseudo-transient continuation, Kelley & Keyes, SIAM J. Numer. Anal. 35, 1998): the step
solves (J + sigma [M 0; 0 0]) dw = -F with M the mass matrix, i.e. an implicit Euler step of the
mechanism's motion with pseudo-time step 1/sigma. sigma = 0 (plain Newton) while its step turns
no rigid coordinate by more than ``TRUST`` rad; beyond, sigma grows until the step fits, and
then shrinks as the residual falls (switched evolution relaxation). So a start near an
equilibrium converges to it by Newton, stable or not (an inverted pendulum given its upright
guess stays upright), and a start far from one (a pendulum started horizontal, where Newton's
matrix is singular) moves downhill as a damped motion would and settles in a stable one.

About the equilibrium the motion is linearised with the time frozen at tau
(``frozen_alg``): phi(tau, q), phi_q v, res(tau, q, v, a, lam), phi_q a + (phi_q v)_q v --
the same index-1 system the dynamic runner integrates, with the prescribed coordinates held.
Its Jacobian carries the gravity (geometric) stiffness of the free rigid coordinates and the
bars' bending, axial and geometric stiffness, so ``symgen modes`` reports the pendulum modes
with the bending modes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from symgen.errors import SimulationError
from symgen.ir.records import CoordKind
from symgen.numerics.index1 import Index1, Partition
from symgen.numerics.mechanism import Mechanism

#: Largest turn (rad) of a rigid coordinate in one step of the equilibrium solve.
TRUST = 0.5
MAXIT = 400
RES_TOL = 1e-11  # |F|_inf <= RES_TOL * max(1, load scale)


def prescribed(mech: Mechanism, t: float) -> dict[int, float]:
    """The prescribed rigid coordinates and their values at t: index -> value (an angle driver
    prescribes its bar's angle, a torque driver nothing)."""
    # each angle as the model's driver rows prescribe it (one evaluation for all drivers)
    return {mech.info.coordinate(CoordKind.THETA, body): m[0] for body, m in mech.driver_motions(t).items()}


def guess_key(mech: Mechanism, body: str) -> str:
    """The scene key that sets the start of bar ``body``'s angle: a torque driver's ``initial``
    for its bar, else ``initial.guess.<body>``."""
    drivers = mech.scene.drivers
    found = [i for i, d in enumerate(drivers) if d.kind == "torque" and d.body == body]
    if found:
        return "driver.initial" if len(drivers) == 1 else f"drivers.{found[0]}.initial"
    return f"initial.guess.{body}"


def free_coordinates(mech: Mechanism, part: Partition) -> list[int]:
    """The rigid coordinates neither fixed by the closure nor prescribed: the mechanism's free
    degrees of freedom (empty for a kinematically guided mechanism)."""
    return [i for i in mech.rigid if i not in part.dep]


def why_free(mech: Mechanism, free: list[int]) -> str:
    """Why the coordinates ``free`` are free, in words: names the coordinates and the driver."""
    names = ", ".join(mech.coords[i].name for i in free)
    angle = [d.body for d in mech.scene.drivers if d.kind == "angle"]
    torque = [d.body for d in mech.scene.drivers if d.kind == "torque"]
    if not angle and not torque:
        driver = "the scene has no driver"
    elif not angle:
        driver = f"the driver of '{', '.join(torque)}' is a torque driver (it prescribes a moment, not a motion)"
    else:
        driver = f"the angle driver of '{', '.join(angle)}' and the closure do not fix them"
    return f"{len(free)} rigid coordinate(s) are free ({names}): {driver}"


@dataclass(frozen=True)
class Equilibrium:
    """A static equilibrium at tau: all coordinates, multipliers, how it was found."""

    tau: float
    q: np.ndarray
    lam: np.ndarray
    free: tuple[int, ...]  # the free rigid coordinates
    iterations: int
    residual: float
    damped: bool  # the pseudo-time term was needed (the start was far from an equilibrium)

    def angles(self, mech: Mechanism) -> dict[str, float]:
        """The free rigid coordinates' values (angles wrapped to (-pi, pi])."""
        out = {}
        for i in self.free:
            c = mech.coords[i]
            x = float(self.q[i])
            out[c.name] = _wrap(x) if c.kind is CoordKind.THETA else x
        return out

    def as_dict(self, mech: Mechanism) -> dict[str, object]:
        thetas = [mech.coords[i].body for i in self.free if mech.coords[i].kind is CoordKind.THETA]
        return {
            "tau": self.tau,
            "free": self.angles(mech),
            "free_deg": {
                mech.coords[i].name: math.degrees(x)
                for i, x in zip(self.free, self.angles(mech).values())
                if mech.coords[i].kind is CoordKind.THETA
            },
            "choose_with": [guess_key(mech, b) for b in thetas],
            "iterations": self.iterations,
            "residual": self.residual,
            "method": "Newton with pseudo-time damping (pseudo-transient continuation)" if self.damped else "Newton",
        }


def _wrap(x: float) -> float:
    return float(math.atan2(math.sin(x), math.cos(x)))


class EquilibriumSystem:
    """F(w) = [res(t, q, 0, 0, lam); phi(t, q)] of a mechanism, w = [q; lam], its Jacobian and
    the mass matrix, and the solve."""

    def __init__(self, mech: Mechanism) -> None:
        self.mech = mech
        n, m = mech.n, mech.m
        t = ca.SX.sym("t")
        q, lam = ca.SX.sym("q", n), ca.SX.sym("lam", m)
        a = ca.SX.sym("a", n)
        zn = ca.SX.zeros(n)
        res = mech.f["res"](t, q, zn, a, lam, mech.p)
        phi = mech.f["phi"](t, q, zn, zn, lam, mech.p)
        F = ca.vertcat(ca.substitute(res, a, zn), phi)
        w = ca.vertcat(q, lam)
        M = ca.substitute(ca.jacobian(res, a), a, zn)
        self._FJ = ca.Function("eq_FJ", [t, w], [F, ca.jacobian(F, w), M])
        self._F = ca.Function("eq_F", [t, w], [F])

    def start(self, t: float, q_guess: np.ndarray) -> np.ndarray:
        """The start at t: the guess with the prescribed coordinates at their value at t, its
        rigid coordinates assembled (closure exact)."""
        mech = self.mech
        q = np.array(q_guess, dtype=float)
        for i, x in prescribed(mech, t).items():
            q[i] = x
        return mech.assemble(t, q, mech.choose_partition(t, q))

    def solve(self, t: float, q_guess: np.ndarray, lam_guess: np.ndarray | None = None) -> Equilibrium:
        """The static equilibrium at t nearest ``q_guess`` (see the module's docstring)."""
        mech = self.mech
        n, m = mech.n, mech.m
        q0 = self.start(t, q_guess)
        w = np.concatenate([q0, np.zeros(m) if lam_guess is None else np.asarray(lam_guess, dtype=float)])
        rigid = list(mech.rigid)
        F, J, M = (np.array(x) for x in self._FJ(t, w))
        F = F.ravel()
        # the loads' scale: the generalized forces at the start (gravity, torques, loads)
        tol = RES_TOL * max(1.0, float(np.abs(F).max()))
        P = np.zeros((n + m, n + m))
        P[:n, :n] = M
        sigma, damped, it = 0.0, False, 0
        sigma0 = 1e-6 * max(1.0, float(np.abs(J).max()))
        while np.abs(F).max() > tol:
            if it >= MAXIT:
                raise SimulationError(t, *self._no_equilibrium(F, it, _turned(w, q0, rigid)))
            step = None
            while True:
                try:
                    step = np.linalg.solve(J + sigma * P, -F)
                except np.linalg.LinAlgError:
                    step = None
                turn = (
                    np.abs(step[rigid]).max(initial=0.0) if step is not None and np.all(np.isfinite(step)) else math.inf
                )
                if turn <= TRUST:
                    break
                if sigma > 1e12 * max(1.0, float(np.abs(J).max())) and step is not None and math.isfinite(turn):
                    step = step * (TRUST / turn)  # the pseudo-time term cannot shorten it: cut it
                    break
                sigma = max(4.0 * sigma, sigma0)
                damped = True
            assert step is not None
            w = w + step
            F_old = float(np.abs(F).max())
            F, J, M = (np.array(x) for x in self._FJ(t, w))
            F = F.ravel()
            P[:n, :n] = M
            it += 1
            if not np.all(np.isfinite(F)):
                raise SimulationError(t, *self._no_equilibrium(F, it, _turned(w, q0, rigid)))
            # switched evolution relaxation: the pseudo-time step grows as the residual falls
            sigma = sigma * min(float(np.abs(F).max()) / max(F_old, 1e-300), 4.0)
            if sigma < 1e-12 * sigma0:
                sigma = 0.0
        part = mech.choose_partition(t, w[:n])
        return Equilibrium(
            tau=float(t),
            q=w[:n],
            lam=w[n:],
            free=tuple(free_coordinates(mech, part)),
            iterations=it,
            residual=float(np.abs(F).max()),
            damped=damped,
        )

    def _no_equilibrium(self, F: np.ndarray, it: int, turned: float) -> tuple[str, str]:
        """Why the solve stopped without an equilibrium, naming the unbalanced coordinate: a
        free coordinate that turned by more than a full turn is driven without end."""
        mech = self.mech
        res = np.abs(F[: mech.n])
        rigid = list(mech.rigid)
        worst = max(rigid, key=lambda i: res[i]) if rigid else int(np.argmax(res))
        name = mech.coords[worst].name
        if turned > 2 * math.pi:
            return (
                f"no static equilibrium: from initial.guess, {name} turned by {turned:.3g} rad in {it} steps "
                f"and its generalized force stays unbalanced ({res[worst]:.3g}): a torque or load that gravity "
                "and the supports cannot hold turns the mechanism without end",
                "check the driver torque and the loads against gravity; the dynamic response (symgen "
                "simulate) is defined either way",
            )
        return (
            f"no static equilibrium found from initial.guess in {it} steps: the residual stays at "
            f"{np.abs(F).max():.3g} (the generalized force on {name}: {res[worst]:.3g})",
            "give initial.guess angles near an equilibrium, and check the driver torque and the loads "
            "against gravity and the bars' stiffness (a bar beyond its buckling load has no equilibrium "
            "near the straight one); the dynamic response (symgen simulate) is defined either way",
        )


def _turned(w: np.ndarray, q0: np.ndarray, rigid: list[int]) -> float:
    """The largest change of a rigid coordinate from the start."""
    return float(np.abs(w[rigid] - q0[rigid]).max(initial=0.0))


def frozen_alg(sys_: Index1, mech: Mechanism, t: float) -> ca.SX:
    """The algebraic equations [phi; phid; res; phidd] with the time frozen at t: the closure
    and the prescribed coordinates held still (phid = phi_q v, phidd = phi_q a + (phi_q v)_q v),
    the loads and torques at their values at t."""
    p = mech.p
    q, v, a, lam = sys_.q, sys_.v, sys_.a, sys_.lam
    zn = ca.SX.zeros(mech.n)
    phi = mech.f["phi"](t, q, zn, zn, lam, p)
    Jq = ca.jacobian(phi, q)
    phid = ca.mtimes(Jq, v)
    phidd = ca.mtimes(Jq, a) + ca.mtimes(ca.jacobian(phid, q), v)
    res = mech.f["res"](t, q, v, a, lam, p)
    return ca.vertcat(phi, phid, res, phidd)
