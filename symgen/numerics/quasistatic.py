"""Quasi-static response (18)-(20): the deformation that follows the inertia loads of the
rigid motion without vibrating, at each input position of a cycle.

With all deformation rates and accelerations zero (f' = g' = f'' = g'' = 0) and the kinematics
of the rigid mechanism substituted, the bar equations (16)-(17) become (18)-(19) and, with the
rigid-body equations that carry the working reactions, an algebraic system per input position

    (20)   A y = B + f(y)

which symgen builds from the same generated residual the dynamic runner uses: with R(y) the
residual at the unknowns y (zero at the rigid state),

    A = dR/dy (y = 0),   B = -R(0),   f(y) = A y - (R(y) - R(0))     (the nonlinear rest),

and solves by the seed's fixed-point iteration y <- A^-1 (B + f(y)). When that iteration does
not contract it falls back to Newton on R(y) = 0 and says so (per position, in the JSON).
Its contraction factor is the spectral radius of A^-1 f'(y*). With the seed's linear strain the
axial-bending coupling is one-way (lambda (zeta' eta')' in (17) only) and the factor is about
the axial load over the bar's buckling load (0.07 at most on the seed's slider-crank). With
von Karman strain the coupling goes both ways, f'(y) has off-diagonal blocks ~ lambda g between
axial and transverse amplitudes, and the loop gain ~ lambda g^2 / mu of that pair exceeds 1 where
the rod bends most: on the accurate model of the same slider-crank the iteration diverges
(factor up to ~2) at about 40 % of the positions of a turn, and Newton solves them.

The unknowns y: every deformation amplitude and the multipliers (the reactions that do work
and the driver torque). Two readings of "rigid kinematics substituted":

* ``kinematics="deformed"`` (default): y also holds corrections of the dependent rigid
  coordinates, their rates and the rigid accelerations, and the closure (11) rows at position,
  velocity and acceleration level join R: the loop closes exactly on the deformed bars
  (closure residual ~1e-15, positions physical). The fixed point is the state the dynamic
  runner starts from with ``initial.deformation = "quasi-static"``.
* ``kinematics="rigid"``: the rigid mechanism's theta, theta', theta'' are substituted as they
  are (the paper's literal (18)-(19)); the loop then fails to close by the bars' deformation
  (O(zeta), visible in a ``closure_residual`` output), the deformations differ at second order.

Only a kinematically guided mechanism (angle driver, or no rigid degree of freedom at all) has
a quasi-static response in this sense: its rigid motion is known without solving the dynamics.

A mechanism with free rigid coordinates (no driver, a torque driver, bars left undriven) has
not; for it ``quasi_static`` computes what is defined without the dynamics, the **static
equilibrium at each input position** (``kinematics = "equilibrium"``): every rate and
acceleration zero, the prescribed (angle-driven) coordinates at their value at tau, gravity,
loads and driver torques at their values at tau, the free coordinates and every deformation
amplitude solved (``symgen.numerics.equilibrium``), each position started from the last one's
equilibrium (continuation). That is the slow-motion limit: the inertia loads of the driver's
motion are left out, since the free coordinates' motion under them is the dynamics. With
nothing varying in tau (no angle driver, constant loads) every position is the same
equilibrium, the one ``symgen modes`` reports.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from collections.abc import Callable

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from symgen.errors import Interrupted, SceneError, SimulationError
from symgen.policy import POLICY
from symgen.scene.limits import lift_hint, limit_value, over_limit
from symgen.scene.model import Driver, Scene
from symgen.numerics import interrupt
from symgen.numerics import checks
from symgen.numerics.equilibrium import RES_TOL as EQ_RES_TOL
from symgen.numerics.equilibrium import EquilibriumSystem, free_coordinates, why_free
from symgen.numerics.index1 import Partition
from symgen.numerics.mechanism import Mechanism
from symgen.ir.records import CoordKind

KINEMATICS = ("deformed", "rigid")
EQUILIBRIUM = "equilibrium"  # the kinematics of a mechanism with free rigid coordinates
RHO_MAX = 0.95  # a fixed-point iteration contracting slower than this goes to Newton
FP_MAXIT = 200
NEWTON_MAXIT = 50
RES_TOL = 1e-12  # |R|_inf <= RES_TOL * max(1, |B|_inf)


@dataclass
class PositionReport:
    tau: float
    method: str  # "fixed-point" | "newton"
    iterations: int  # fixed-point iterations done (also when Newton took over)
    newton_iterations: int
    residual: float  # |R(y)|_inf at the solution
    contraction: float | None  # estimated contraction factor of the fixed-point iteration
    reason: str = ""  # why Newton took over

    def as_dict(self) -> dict[str, float | str | int | None]:
        d: dict[str, float | str | int | None] = {
            "tau": self.tau,
            "method": self.method,
            "iterations": self.iterations,
            "newton_iterations": self.newton_iterations,
            "residual": self.residual,
            "contraction": self.contraction,
        }
        if self.reason:
            d["newton_reason"] = self.reason
        return d


@dataclass
class QuasiStaticResult:
    tau: np.ndarray
    outputs: np.ndarray  # (N, n_out)
    output_names: list[str]
    q: np.ndarray  # (N, n)
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    closure_max: float
    reports: list[PositionReport]  # one per row
    solve_s: float
    partition: Partition
    kinematics: str
    complete: bool = True
    failure: str = ""
    stats: dict[str, str | float | None] = field(default_factory=dict)

    @property
    def analysis(self) -> str:
        """What the run computed, for the JSON sidecar."""
        if self.kinematics == EQUILIBRIUM:
            return (
                "static equilibrium at each input position (a mechanism with free rigid coordinates: "
                "rates and accelerations zero, prescribed angles at their value at tau)"
            )
        return "quasi-static response (18)-(20)"

    def column(self, name: str) -> np.ndarray:
        """The output called ``name`` (as in the scene's [outputs])."""
        return self.outputs[:, self.output_names.index(name)]

    # the attributes the results sidecar reads from a dynamic run
    @property
    def steps(self) -> int:
        return int(sum(r.iterations + r.newton_iterations for r in self.reports))

    @property
    def simulate_s(self) -> float:
        return self.solve_s

    def solver_info(self) -> dict[str, object]:
        """The JSON ``solver`` entry: method, tolerances, per-position iterations and residuals."""
        newton = [r for r in self.reports if r.method == "newton"]
        its = [r.iterations for r in self.reports]
        if self.kinematics == EQUILIBRIUM:
            its = [r.newton_iterations for r in self.reports]
            return {
                "name": "static equilibrium res(tau, q, 0, 0, lam) = 0, phi(tau, q) = 0: Newton with "
                "pseudo-time damping, each position from the last one's equilibrium",
                "kinematics": self.kinematics,
                "residual_tol": EQ_RES_TOL,
                "steps": self.steps,
                "positions": len(self.reports),
                "newton_used": True,
                "newton_positions": len(self.reports),
                "iterations_max": max(its) if its else 0,
                "iterations_mean": float(np.mean(its)) if its else 0.0,
                "residual_max": max((r.residual for r in self.reports), default=0.0),
                "per_position": [r.as_dict() for r in self.reports],
            }
        return {
            "name": "quasi-static (20): fixed-point iteration y <- A^-1 (B + f(y)), Newton fallback",
            "kinematics": self.kinematics,
            "residual_tol": RES_TOL,
            "contraction_limit": RHO_MAX,
            "fixed_point_maxit": FP_MAXIT,
            "steps": self.steps,
            "positions": len(self.reports),
            "newton_used": bool(newton),
            "newton_positions": len(newton),
            "newton_taus": [r.tau for r in newton],
            "iterations_max": max(its) if its else 0,
            "iterations_mean": float(np.mean(its)) if its else 0.0,
            "residual_max": max((r.residual for r in self.reports), default=0.0),
            "per_position": [r.as_dict() for r in self.reports],
        }


class QuasiStaticSystem:
    """The system (20) of a mechanism: rigid state, residual R(y), its Jacobian, the solve."""

    def __init__(self, mech: Mechanism, part: Partition, kinematics: str = "deformed") -> None:
        if kinematics not in KINEMATICS:
            raise ValueError(f"kinematics must be one of {KINEMATICS}, got {kinematics!r}")
        require_guided(mech, part)
        self.mech, self.part, self.kinematics = mech, part, kinematics
        n, m = mech.n, mech.m
        D = list(part.dep)
        amp = list(mech.info.elastic)
        E = [i for i in amp if i not in D]  # independent amplitudes: the paper's y
        rigid_rows = [k for k in range(m) if k not in mech.info.inextensible_rows]
        deformed = kinematics == "deformed"
        if deformed:
            # every dependent coordinate, rate and acceleration follows the closure on the deformed bars
            Dq = D
            Da = sorted(set(mech.rigid) | set(D))
            rows = list(range(m))
        else:
            # rigid kinematics substituted; only amplitudes that are themselves constrained
            # (axially inextensible bars) keep their constraint rows
            Dq = [i for i in D if i in amp]
            Da = Dq
            rows = [k for k in range(m) if k not in rigid_rows]
        self.E, self.D, self.Dq, self.Da, self.rows, self.amp = E, D, Dq, Da, rows, amp
        nE, nq, na_ = len(E), len(Dq), len(Da)
        self.ny = nE + 2 * nq + na_ + m
        y = ca.SX.sym("y", self.ny)
        t = ca.SX.sym("t")
        q0, v0, a0 = ca.SX.sym("q0", n), ca.SX.sym("v0", n), ca.SX.sym("a0", n)
        q, v, a = ca.SX(q0), ca.SX(v0), ca.SX(a0)
        for k, i in enumerate(E):
            q[i] = y[k]
            v[i] = 0
            a[i] = 0
        for k, i in enumerate(Dq):
            q[i] = q0[i] + y[nE + k]
            v[i] = v0[i] + y[nE + nq + k]
        for k, i in enumerate(Da):
            a[i] = a0[i] + y[nE + 2 * nq + k]
        lam = y[nE + 2 * nq + na_ :]
        args: list[ca.SX | np.ndarray] = [t, q, v, a, lam, mech.p]
        f = mech.f
        sel: Callable[[ca.SX], ca.SX] = (lambda w: w) if deformed else (lambda w: w[rows] if rows else ca.SX(0, 1))
        R = ca.vertcat(sel(f["phi"](*args)), sel(f["phid"](*args)), f["res"](*args), sel(f["phidd"](*args)))
        self._R = ca.Function("qs_R", [t, q0, v0, a0, y], [R])
        self._RJ = ca.Function("qs_RJ", [t, q0, v0, a0, y], [R, ca.jacobian(R, y)])
        self._state = ca.Function("qs_state", [t, q0, v0, a0, y], [q, v, a, lam])

    # ------------------------------------------------------------------ rigid kinematics
    def rigid_state(self, t: float, q_guess: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """theta, theta', theta'' of the rigid mechanism at t (amplitudes, their rates and
        accelerations zero), from the closure (11) at the three levels."""
        mech, part = self.mech, self.part
        q = np.array(q_guess, dtype=float)
        q[self.amp] = 0.0
        for body, motion in mech.driver_motions(t).items():  # the angles of ALL angle drivers
            q[mech.info.coordinate(CoordKind.THETA, body)] = motion[0]
        q = mech.assemble(t, q, part)
        ratio, row = checks.singular_ratio(mech, t, q, part)
        if ratio < POLICY.singular_ratio:
            raise SimulationError(
                t,
                f"the rigid mechanism is at a singular position: the closure Jacobian of "
                f"the {mech.loop_name(row)} loses rank (ratio {ratio:.2e})",
                "the quasi-static response is not defined here; change the geometry or the driver",
            )
        v = mech.velocities(t, q, np.zeros(mech.n), part)
        a = np.zeros(mech.n)
        if self.D:
            J = mech.jac_q(t, q)[:, self.D]
            a[self.D] = np.linalg.solve(J, -mech.call("phidd", t, q, v, a))
        return q, v, a

    def next_guess(self, qr: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Where the next position's rigid state starts: this one's rigid state ``qr``."""
        return qr

    # ------------------------------------------------------------------ (20)
    def residual(self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.array(self._R(t, qr, vr, ar, y)).ravel()

    def linear_system(self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of (20) at the rigid state: A = dR/dy(0), B = -R(0)."""
        R0, J0 = self._RJ(t, qr, vr, ar, np.zeros(self.ny))
        return np.array(J0), -np.array(R0).ravel()

    def nonlinear_rest(
        self,
        t: float,
        qr: np.ndarray,
        vr: np.ndarray,
        ar: np.ndarray,
        y: np.ndarray,
        A: np.ndarray | None = None,
        B: np.ndarray | None = None,
    ) -> np.ndarray:
        """f(y) = A y - (R(y) - R(0)) of (20)."""
        if A is None or B is None:
            A, B = self.linear_system(t, qr, vr, ar)
        rest: np.ndarray = A @ y - self.residual(t, qr, vr, ar, y) - B
        return rest

    def state(
        self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Full (q, v, a, lam) of the solution y."""
        q, v, a, lam = self._state(t, qr, vr, ar, y)
        return (np.array(q).ravel(), np.array(v).ravel(), np.array(a).ravel(), np.array(lam).ravel())

    def solve(
        self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray, y0: ArrayLike | None = None
    ) -> tuple[np.ndarray, PositionReport]:
        """Solve (20) at one input position: fixed-point iteration, Newton when it does not contract."""
        A, B = self.linear_system(t, qr, vr, ar)
        tol = RES_TOL * max(1.0, float(np.abs(B).max(initial=0.0)))
        try:
            lu = np.linalg.inv(A)
        except np.linalg.LinAlgError:
            lu = None
        y = np.zeros(self.ny) if y0 is None else np.array(y0, dtype=float)
        R = self.residual(t, qr, vr, ar, y)
        it, rho, reason = 0, None, ""
        steps: list[float] = []
        if lu is None or not np.all(np.isfinite(lu)):
            reason = "A is singular (the linear part alone has no unique solution)"
        else:
            while np.abs(R).max() > tol:
                if it >= FP_MAXIT:
                    reason = f"no convergence in {FP_MAXIT} fixed-point iterations"
                    break
                # y <- A^-1 (B + f(y)) = y - A^-1 R(y)
                dy = lu @ R
                y_new = y - dy
                it += 1
                steps.append(float(np.abs(dy).max()))
                if not np.all(np.isfinite(y_new)):
                    reason = "the fixed-point iteration diverged"
                    break
                y = y_new
                R = self.residual(t, qr, vr, ar, y)
                if len(steps) >= 3 and steps[-2] > 0:
                    rho = float(np.sqrt(steps[-1] / steps[-3])) if steps[-3] > 0 else None
                    if rho is not None and rho > RHO_MAX and np.abs(R).max() > tol:
                        reason = f"the fixed-point iteration does not contract (factor {rho:.3g})"
                        break
        if not reason:
            return y, PositionReport(t, "fixed-point", it, 0, float(np.abs(R).max()), rho)
        # Newton on R(y) = 0, from the last finite fixed-point iterate (or the rigid state)
        if not np.all(np.isfinite(y)) or np.abs(R).max() > np.abs(B).max() * 10:
            y = np.zeros(self.ny) if y0 is None else np.array(y0, dtype=float)
        y, R, nit = self._newton(t, qr, vr, ar, y, tol)
        if np.abs(R).max() > max(tol, 1e-8):
            raise SimulationError(
                t,
                f"the quasi-static system (20) has no solution near the rigid state: "
                f"{reason}, and Newton stopped at residual {np.abs(R).max():.3g}",
                "a bar may be at or beyond its buckling load at this position; "
                "the dynamic response (symgen simulate) is still defined",
            )
        return y, PositionReport(t, "newton", it, nit, float(np.abs(R).max()), rho, reason)

    def _newton(
        self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray, y: np.ndarray, tol: float
    ) -> tuple[np.ndarray, np.ndarray, int]:
        R, J = self._RJ(t, qr, vr, ar, y)
        R = np.array(R).ravel()
        nit = 0
        while np.abs(R).max() > tol and nit < NEWTON_MAXIT:
            try:
                dy = np.linalg.solve(np.array(J), R)
            except np.linalg.LinAlgError:
                break
            nit += 1
            step = 1.0
            while True:
                trial = y - step * dy
                Rt = self.residual(t, qr, vr, ar, trial)
                if np.all(np.isfinite(Rt)) and (np.abs(Rt).max() < np.abs(R).max() or step < 1e-3):
                    break
                step /= 2
            y = trial
            R, J = self._RJ(t, qr, vr, ar, y)
            R = np.array(R).ravel()
        return y, R, nit


def require_guided(mech: Mechanism, part: Partition) -> None:
    """The quasi-static response (20) needs a rigid motion known without the dynamics: every
    rigid coordinate must be dependent (fixed by the closure and the prescribed coordinates)."""
    free = free_coordinates(mech, part)
    if free:
        raise SceneError(
            mech.scene.path,
            "driver",
            f"the quasi-static system (18)-(20) needs a kinematically guided mechanism, but {why_free(mech, free)}",
            "quasi_static() and modes() give such a mechanism its static equilibrium instead; "
            'to prescribe the motion use [driver] kind = "angle" on the free bar',
        )


class EquilibriumTrack:
    """The static equilibrium at each input position of a mechanism with free rigid coordinates,
    with the interface of ``QuasiStaticSystem`` that ``quasi_static`` runs: y = [q; lam]."""

    kinematics = EQUILIBRIUM

    def __init__(self, mech: Mechanism, part: Partition) -> None:
        self.mech, self.part = mech, part
        self.system = EquilibriumSystem(mech)

    def rigid_state(self, t: float, q_guess: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The start at t: the guess (the last position's equilibrium), at rest."""
        z = np.zeros(self.mech.n)
        return np.array(q_guess, dtype=float), z, z

    def next_guess(self, qr: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Where the next position starts: this one's equilibrium ``q`` (continuation)."""
        return q

    def solve(
        self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray, y0: ArrayLike | None = None
    ) -> tuple[np.ndarray, PositionReport]:
        n = self.mech.n
        lam0 = None if y0 is None else np.asarray(y0, dtype=float)[n:]
        eq = self.system.solve(t, qr, lam0)
        return np.concatenate([eq.q, eq.lam]), PositionReport(t, "newton", 0, eq.iterations, eq.residual, None)

    def state(
        self, t: float, qr: np.ndarray, vr: np.ndarray, ar: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        n = self.mech.n
        return y[:n].copy(), np.zeros(n), np.zeros(n), y[n:].copy()


def _rate_key(scene: Scene, drv: Driver | None) -> str:
    """The scene key of the turning angle driver's rate (simulation.t_end without one)."""
    if drv is None:
        return "simulation.t_end"
    return "driver.rate" if len(scene.drivers) == 1 else f"drivers[{scene.drivers.index(drv)}].rate"


def cycle_times(mech: Mechanism, cycles: float | None = None, output_step: float | None = None) -> np.ndarray:
    """Input positions: one crank turn (``cycles`` turns) at the scene's output step; a scene
    without a turning angle driver uses its [simulation] times."""
    sim = mech.scene.simulation
    h = sim.output_step if output_step is None else output_step
    # the first angle driver turning at a constant rate (as simulation.cycles)
    drv = mech.scene.turning_driver
    if drv is not None:
        t_end = (1.0 if cycles is None else cycles) * 2 * math.pi / abs(drv.rate)
    else:
        t_end = sim.t_end if cycles is None else cycles * 2 * math.pi
    rows = t_end / h + 1
    if not math.isfinite(rows) or over_limit("rows", rows):
        file, key = (
            ("command line", "--cycles") if cycles is not None else (mech.scene.path, _rate_key(mech.scene, drv))
        )
        raise SceneError(
            file,
            key,
            f"the cycle would have {rows:.4g} input positions (t_end / output_step + 1 = "
            f"{t_end:g} / {h:g} + 1), more than the limit {limit_value('rows'):g}",
            lift_hint("rows", "use fewer cycles or a larger simulation.output_step"),
        )
    n = int(math.floor(t_end / h + 1e-9))
    return np.arange(n + 1) * h


NO_POSITION = "before the first input position was solved (nothing to keep)"


def quasi_static(
    mech: Mechanism,
    taus: ArrayLike | None = None,
    kinematics: str = "deformed",
    cycles: float | None = None,
    output_step: float | None = None,
    say: Callable[[str], object] | None = None,
) -> QuasiStaticResult:
    """The quasi-static response (20) at each input position (default: one cycle).

    ``say``: an optional callable given one progress line once the first position is solved.

    Raises ``SimulationError`` (with ``.partial``, the positions solved so far) when a position
    has no quasi-static state (a singular position, or a bar at its buckling load), and
    ``Interrupted`` on SIGINT/SIGTERM inside ``interrupt.handling()``: with ``.partial`` (the
    positions solved, possibly none) once the system (20) is built, before that without (its
    message then says that no position was solved)."""
    taus, q, sys_ = _start(mech, taus, kinematics, cycles, output_step)
    positions = _Positions(sys_)
    try:
        _solve_positions(sys_, positions, taus, q, say)
        return positions.result(None)
    except BaseException as err:
        exc = positions.stopped(err)
        if exc is None:
            raise
        exc.partial = positions.result(exc)  # symgen.errors does not declare the errors' partial
    raise exc


def _start(
    mech: Mechanism, taus: ArrayLike | None, kinematics: str, cycles: float | None, output_step: float | None
) -> tuple[np.ndarray, np.ndarray, QuasiStaticSystem | EquilibriumTrack]:
    """The input positions, the consistent start at the first (its q) and the system (20) of its
    partition. A signal meanwhile (the start's assembly, building (20)): ``Interrupted`` saying
    that no position was solved."""
    try:
        taus = cycle_times(mech, cycles, output_step) if taus is None else np.asarray(taus, dtype=float)
        q, v, a, lam, part = mech.initial_state(float(taus[0]) if len(taus) else 0.0)
        sys_ = _system(mech, part, kinematics)
    except BaseException as err:
        stop = interrupt.interrupted(err)
        if not isinstance(stop, Interrupted):
            raise
        raise Interrupted(stop.signum, detail=NO_POSITION) from None
    return taus, q, sys_


def _system(mech: Mechanism, part: Partition, kinematics: str) -> QuasiStaticSystem | EquilibriumTrack:
    """The system (20) of a guided mechanism, the static equilibrium of one with free rigid
    coordinates."""
    free = free_coordinates(mech, part)
    if not free:
        return QuasiStaticSystem(mech, part, kinematics)
    if kinematics == "rigid":
        raise SceneError(
            "command line",
            "--kinematics",
            f"'rigid' substitutes the rigid mechanism's motion, but {why_free(mech, free)}, so that "
            "motion is not known without the dynamics",
            "leave --kinematics out: such a mechanism gets its static equilibrium at each position",
        )
    return EquilibriumTrack(mech, part)


def _solve_positions(
    sys_: QuasiStaticSystem | EquilibriumTrack,
    positions: _Positions,
    taus: np.ndarray,
    q: np.ndarray,
    say: Callable[[str], object] | None,
) -> None:
    """(20) at each input position in turn, each started from the last one's solution."""
    y: np.ndarray | None = None
    q_guess = q
    for t in taus:
        t = float(t)
        interrupt.check(positions.last_tau())
        qr, vr, ar = sys_.rigid_state(t, q_guess)
        y, rep = sys_.solve(t, qr, vr, ar, y)
        qq, vv, aa, ll = sys_.state(t, qr, vr, ar, y)
        positions.add(t, qq, vv, aa, ll, rep)
        q_guess = sys_.next_guess(qr, qq)
        if say is not None and len(positions.reports) == 1:
            say(f"first position solved (tau = {t:g}); {len(taus)} positions in all")


class _Positions:
    """The positions solved so far with their outputs and reports, and the
    ``QuasiStaticResult`` they make: what a run that stops early keeps."""

    def __init__(self, sys_: QuasiStaticSystem | EquilibriumTrack) -> None:
        self.mech, self.part, self.kinematics = sys_.mech, sys_.part, sys_.kinematics
        self.rows: dict[str, list[float | np.ndarray]] = {k: [] for k in ("tau", "out", "q", "v", "a", "lam")}
        self.reports: list[PositionReport] = []
        self.closure_max = 0.0
        self.tic = time.perf_counter()

    def solved(self) -> int:
        # an interrupt may land between the appends of one position: count the positions recorded whole
        return min(len(self.reports), *(len(v) for v in self.rows.values()))

    def last_tau(self) -> float | None:
        return float(self.rows["tau"][-1]) if self.rows["tau"] else None

    def add(
        self, t: float, qq: np.ndarray, vv: np.ndarray, aa: np.ndarray, ll: np.ndarray, rep: PositionReport
    ) -> None:
        """The position at t: its outputs and closure residual evaluated, then recorded."""
        mech = self.mech
        out = mech.call("out", t, qq, vv, aa, ll)
        clo = mech.call("closure", t, qq)
        if clo.size:
            self.closure_max = max(self.closure_max, float(np.abs(clo).max()))
        values: tuple[float | np.ndarray, ...] = (t, out, qq, vv, aa, ll)
        for k, val in zip(("tau", "out", "q", "v", "a", "lam"), values):
            self.rows[k].append(val)
        self.reports.append(rep)

    def stopped(self, err: BaseException) -> SimulationError | Interrupted | None:
        """What ended the run early, or None when ``err`` is neither a failure of the run nor an
        interrupt (the caller re-raises it).

        Any failure while SIGINT/SIGTERM is pending is the interrupt, whatever it looks like
        (symgen.numerics.interrupt): the handler's Interrupted, CasADi's RuntimeError, a bare
        KeyboardInterrupt, a TypeError, or the SystemError CPython makes of a C function that
        returned with the handler's exception set (numpy converting a DM: "<function
        DM.__array__> returned a result with an exception set"). Catching only SimulationError,
        Interrupted and RuntimeError let that SystemError out without the tau and the
        positions solved (2.5 to 10 % of real SIGINTs measured; 3 of 5 full-suite runs)."""
        n = self.solved()
        exc = interrupt.interrupted(err, float(self.rows["tau"][n - 1]) if n else None)
        if isinstance(exc, Interrupted) and not n:
            exc = Interrupted(exc.signum, detail=NO_POSITION)
        return exc if isinstance(exc, (SimulationError, Interrupted)) else None

    def result(self, exc: BaseException | None) -> QuasiStaticResult:
        """The positions solved whole as a ``QuasiStaticResult`` (``exc``: what ended the run early)."""
        n, rows, mech = self.solved(), self.rows, self.mech
        return QuasiStaticResult(
            tau=np.array(rows["tau"][:n]),
            outputs=np.array(rows["out"][:n]).reshape(-1, len(mech.info.outputs)),
            output_names=list(mech.info.outputs),
            q=np.array(rows["q"][:n]),
            v=np.array(rows["v"][:n]),
            a=np.array(rows["a"][:n]),
            lam=np.array(rows["lam"][:n]),
            closure_max=self.closure_max,
            reports=self.reports[:n],
            solve_s=time.perf_counter() - self.tic,
            partition=self.part,
            kinematics=self.kinematics,
            complete=exc is None,
            failure="" if exc is None else str(exc),
        )
