"""Numerics around a compiled model: partition of the coordinates, assembly, consistent
initial values, and the algebraic solve that keeps position closure at machine precision.

Index-1 form. The rigid coordinates split into *dependent* ones q_D (one per closure row,
chosen where the closure Jacobian is best conditioned) and independent ones; all deformation
amplitudes are independent. With x = [q_I, v_I] differential and z = [q_D, v_D, a, lam]
algebraic, the DAE is

    x' = [v_I, a_I]
    0  = [phi(q), phid(q, v), res(q, v, a, lam), phidd(q, v, a)]

whose Jacobian in z is block-triangular with blocks phi_qD, phi_qD, [[M, -phi_q^T], [phi_q, 0]]:
index 1 as long as the rigid mechanism is not at a singular position (phi_qD regular).
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.errors import SceneError, SimulationError
from symgen.backends.casadi import pipeline
from symgen.backends.casadi.pipeline import CompiledModel
from symgen.ir.parameters import checked_values
from symgen.policy import POLICY
from symgen.scene import scene_of
from symgen.scene.model import Scene
from symgen.ir.records import CoordKind, RowKind
from symgen.numerics import checks, start
from symgen.numerics.index1 import Partition

if TYPE_CHECKING:
    import casadi as ca  # imported where used: a cached run of the C solver never imports CasADi

    from symgen.numerics.simulate import AlgebraicSweep


def load_mechanism(
    scene: Scene | str | os.PathLike[str], overrides: Sequence[str] = (), use_cache: bool = True, lazy: bool = False
) -> Mechanism:
    """The compiled model of a scene (a loaded ``Scene``, or a scene file with its ``--set``
    overrides) with its parameter values, ready to run: load, derive or load from the model
    cache, and wrap in a :class:`Mechanism`. ``lazy``: a cached model's CasADi Functions are read
    on first use (a run of the C solver never uses them)."""
    scene = scene_of(scene, overrides)
    # pipeline.compile_scene looked up at the call: a test (or a tool) may wrap it for every caller
    if lazy:
        return Mechanism(pipeline.compile_scene(scene, use_cache=use_cache, lazy=True), scene)
    return Mechanism(pipeline.compile_scene(scene, use_cache=use_cache), scene)


class Mechanism:
    def __init__(self, compiled: CompiledModel, scene: Scene) -> None:
        tic = time.perf_counter()
        self.scene = scene
        self.compiled = compiled  # its derivation and cache state go into a run's sidecar
        self.info = info = compiled.info
        self.coords = info.coords
        self.n, self.m = info.n, info.m
        self.p_values = checked_values(scene, list(info.params))  # checked here, at the load
        self.rigid = list(info.rigid)
        # effects.axial = "inextensible": the axial amplitudes of those bars are dependent
        # coordinates of their inextensibility rows (kept apart from the loop rows)
        self.inext_rows = list(info.inextensible_rows)
        self.inext_f = list(info.inextensible_axial)
        self.static_systems: dict[tuple[Partition, tuple[int, ...]], start.StaticSystem] = {}  # built on first use
        # the consistent start per t0 (start._start), solved on first use: the same for every
        # run of this mechanism (the parameters are fixed at the load), whatever its tolerances
        self.starts: dict[float, start.SolvedStart] = {}
        # the SX Functions of a simulation's runner per partition (symgen.numerics.simulate):
        # made on first use, shared by every later run of this mechanism (sweeps, studies)
        self.runner_functions: dict[Partition, dict[str, ca.Function]] = {}
        # the Newton continuation of a run without differential states (every rigid coordinate
        # driven, every elastic amplitude quasi-static) per partition and backend, likewise
        self.algebraic_sweeps: dict[tuple[Partition, str], AlgebraicSweep] = {}
        # an "auto" scene's von Karman model run before its decision (symgen.numerics.strain_choice):
        # evaluated once, then thrown away or remembered, so the runs of the default backend
        # ("auto") use the virtual machine and compile no library for it (issue 20, a first run)
        self.provisional = False
        # the quasi-static model a run continues with after the scene's axial switch
        # (Scene.axial_switch; symgen.numerics.simulate.after_switch), loaded on first use
        self.after_switch: Mechanism | None = None
        self.amplitudes = info.amplitudes  # body -> (axial indices, transverse indices)
        # bodies.<name>.quasi_static_transverse: the amplitudes the runs treat quasi-statically
        if stated_quasi_static(scene):  # refused here, at the load, when inconsistent
            _ = self.quasi
        # the model's CasADi build (or load from the cache) and this set-up, in this process
        self.build_s = compiled.build_s + (time.perf_counter() - tic)

    @functools.cached_property
    def p(self) -> np.ndarray:
        """The model's parameter values (:attr:`p_values`) as an array, made on first use: a cached
        run of the C solver passes the floats to its library and never imports numpy."""
        return np.array(self.p_values, dtype=float)

    # The CasADi parts are made on first use: a cached run of the C solver (which has them in its
    # library) never uses them, and so never imports CasADi (symgen.numerics.csolver).
    @property
    def f(self) -> Mapping[str, ca.Function]:
        """The model's Functions (phi, phid, phidd, res, out, energy, closure)."""
        return self.compiled.funcs

    @functools.cached_property
    def _symbols(self) -> tuple[list[ca.SX], ca.SX]:
        """The Functions' symbolic arguments [t, q, v, a, lam, p] and phi at them."""
        import casadi as ca

        args = [
            ca.SX.sym(k, s)
            for k, s in (("t", 1), ("q", self.n), ("v", self.n), ("a", self.n), ("lam", self.m), ("p", len(self.p)))
        ]
        return args, self.f["phi"](*args)

    @functools.cached_property
    def phi_q(self) -> ca.Function:
        """The closure's Jacobian in q."""
        import casadi as ca

        args, phi = self._symbols
        return ca.Function("phi_q", args, [ca.jacobian(phi, args[1])])

    @functools.cached_property
    def kkt(self) -> ca.Function:
        """The dynamics and the acceleration-level closure, and their Jacobian in (a, lam)."""
        import casadi as ca

        args = self._symbols[0]
        res, phidd = self.f["res"](*args), self.f["phidd"](*args)
        al = ca.vertcat(args[3], args[4])
        return ca.Function("kkt", args, [ca.jacobian(ca.vertcat(res, phidd), al), ca.vertcat(res, phidd)])

    @functools.cached_property
    def quasi(self) -> tuple[int, ...]:
        """bodies.<name>.quasi_static_transverse: the amplitudes the runs treat quasi-statically
        (:func:`quasi_static_amplitudes`)."""
        if not any(b.quasi_static_transverse for b in self.scene.bodies if not b.rigid) and not any(
            c.quasi_axial for c in self.scene.bases
        ):
            return ()
        import casadi as ca

        args, phi = self._symbols
        q = args[1]
        elastic = list(self.info.elastic)
        # the closure's first-order dependence on each amplitude: a slot guide's points shorten with
        # its amplitudes squared (symgen.model.slot.SlotBarKinematics), which moves no joint at first
        # order (its rate terms, g_h g_h' H, are dropped with a quasi-static amplitude's rate)
        phi_q = (
            ca.substitute(ca.jacobian(phi, q), q[elastic], ca.DM.zeros(len(elastic)))
            if elastic
            else ca.jacobian(phi, q)
        )
        return quasi_static_amplitudes(self, phi_q)

    def run_partition(self, part: Partition) -> Partition:
        """The partition a run integrates: ``part`` with the quasi-static amplitudes taken out
        of the independent coordinates (``Partition.quasi``)."""
        if not self.quasi:
            return part
        return Partition(tuple(i for i in part.ind if i not in self.quasi), part.dep, self.quasi)

    # ---------------------------------------------------------------- helpers
    def call(
        self,
        name: str,
        t: float,
        q: np.ndarray,
        v: np.ndarray | None = None,
        a: np.ndarray | None = None,
        lam: np.ndarray | None = None,
    ) -> np.ndarray:
        v = np.zeros(self.n) if v is None else v
        a = np.zeros(self.n) if a is None else a
        lam = np.zeros(self.m) if lam is None else lam
        return np.array(self.f[name](t, q, v, a, lam, self.p)).ravel()

    def jac_q(self, t: float, q: np.ndarray) -> np.ndarray:
        z = np.zeros
        return np.array(self.phi_q(t, q, z(self.n), z(self.n), z(self.m), self.p))

    def loop_name(self, row: int) -> str:
        r = self.info.lam_rows[row]
        if r.kind is RowKind.DRIVER:
            return f"driver of '{r.loop[-1]}'"
        if r.kind is RowKind.INEXTENSIBLE:
            return f"inextensibility of bar '{r.joint}'"
        return f"loop closed by joint '{r.joint}' ({' - '.join(r.loop)})"

    def driver_motion(self, t: float, body: str | None = None) -> tuple[float, float, float]:
        """(theta, theta', theta'') the angle driver of ``body`` (None: the first angle driver)
        prescribes at t, read from the model's own driver rows (phi = theta - theta(t), and its
        two derivatives): whatever the law (constant speed, ``law``, ``ramp``), the numbers the
        equations use."""
        row = self.info.driver_row if body is None else self.info.driver_rows[body]
        z = np.zeros(self.n)
        return (
            -float(self.call("phi", t, z)[row]),
            -float(self.call("phid", t, z, z)[row]),
            -float(self.call("phidd", t, z, z, z)[row]),
        )

    def driver_motions(self, t: float) -> dict[str, tuple[float, float, float]]:
        """driven bar -> (theta, theta', theta'') of every angle driver at t."""
        z = np.zeros(self.n)
        phi, phid, phidd = (self.call(f, t, z, z, z) for f in ("phi", "phid", "phidd"))
        return {
            body: (-float(phi[row]), -float(phid[row]), -float(phidd[row]))
            for body, row in self.info.driver_rows.items()
        }

    def driver_step(self, t: float) -> float:
        """Time step of the central differences of the quasi-static start: POLICY.driver_step
        rad of the fastest angle driver at its rate at t (that many tau when all are at rest)."""
        rate = max((abs(m[1]) for m in self.driver_motions(t).values()), default=0.0)
        return POLICY.driver_step / rate if rate > 0 else POLICY.driver_step

    # ---------------------------------------------------------------- partition + assembly
    def choose_partition(self, t: float, q: np.ndarray) -> Partition:
        """Greedy choice of dependent rigid coordinates with a well-conditioned closure Jacobian."""
        if self.m == 0:
            return Partition(tuple(range(self.n)), ())
        J = self.jac_q(t, q)
        order = list(reversed(self.rigid))
        first: list[int] = []  # angle-driven angles are dependent first, torque-driven ones last
        last: list[int] = []
        for drv in self.scene.drivers:
            idx = self.info.coordinate(CoordKind.THETA, drv.body)
            order.remove(idx)
            (first if drv.kind == "angle" else last).append(idx)
        order = first + order + last
        order = self.inext_f + order
        chosen: list[int] = []
        scale = max(np.abs(J).max(), 1e-300)
        for i in order:
            trial = chosen + [i]
            sv = np.linalg.svd(J[:, trial] / scale, compute_uv=False)
            if sv[-1] > POLICY.partition_ratio * sv[0]:
                chosen = trial
            if len(chosen) == self.m:
                break
        if len(chosen) < self.m:
            bad = checks.worst_row(self, J[:, chosen] if chosen else J[:, []])
            raise SimulationError(
                t,
                f"the closure equations of the {self.loop_name(bad)} are not independent: "
                f"the mechanism is at a singular position (a toggle or change point) "
                f"or over-constrained",
                "start the driver at another angle, check the joints, the driver and initial.guess",
            )
        ind = tuple(i for i in range(self.n) if i not in chosen)
        return Partition(ind, tuple(chosen))

    def assemble(
        self,
        t: float,
        q_guess: ArrayLike,
        part: Partition,
        tol: float = POLICY.assembly_tol,
        maxit: int = POLICY.assembly_maxit,
    ) -> np.ndarray:
        """Solve phi(q) = 0 for the dependent coordinates by damped Newton from q_guess."""
        q = np.array(q_guess, dtype=float)
        dep = list(part.dep)
        if not dep:
            return q
        r = self.call("phi", t, q)
        for _ in range(maxit):
            if np.abs(r).max() < tol:
                return q
            J = self.jac_q(t, q)[:, dep]
            try:
                dq = np.linalg.solve(J, -r)
            except np.linalg.LinAlgError:
                break
            step = 1.0
            while step > POLICY.assembly_min_step:
                trial = q.copy()
                trial[dep] += step * dq
                rt = self.call("phi", t, trial)
                if np.abs(rt).max() < np.abs(r).max() * (1 - POLICY.armijo * step) or np.abs(rt).max() < tol:
                    q, r = trial, rt
                    break
                step /= 2
            else:
                break
        if np.abs(r).max() < POLICY.assembly_accept:
            return q
        worst = int(np.argmax(np.abs(r)))
        raise SimulationError(
            t,
            f"the mechanism cannot be assembled near initial.guess: the closure of the "
            f"{self.loop_name(worst)} keeps a residual of {np.abs(r).max():.3g}",
            "give initial.guess angles (rad) near a real assembly, and check lengths and ground points",
        )

    def velocities(self, t: float, q: np.ndarray, v: ArrayLike, part: Partition) -> np.ndarray:
        """Dependent velocities from the velocity-level closure."""
        v = np.array(v, dtype=float)
        if not part.dep:
            return v
        dep = list(part.dep)
        v[dep] = 0.0
        r = self.call("phid", t, q, v)
        J = self.jac_q(t, q)[:, dep]
        v[dep] = np.linalg.solve(J, -r)
        return v

    def accelerations(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations and multipliers from the dynamics and the acceleration-level closure."""
        z0n, z0m = np.zeros(self.n), np.zeros(self.m)
        K, r = self.kkt(t, q, v, z0n, z0m, self.p)
        sol = np.linalg.solve(np.array(K), -np.array(r).ravel())
        return sol[: self.n], sol[self.n :]

    def initial_guess(self, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) the assembly starts from: each driver's angle and rate, initial.guess angles
        (and slot distances, by joint name), the given deformation and its rates, else zeros."""
        sc = self.scene
        q = np.zeros(self.n)
        v = np.zeros(self.n)
        guess = dict(sc.initial.guess)
        deform = dict(sc.initial.deformation)
        drivers = {d.body: d for d in sc.drivers}
        for i, c in enumerate(self.coords):
            if c.kind is CoordKind.THETA:
                q[i] = guess.get(c.body, 0.0)
                drv = drivers.get(c.body)
                if drv is not None:
                    if drv.kind == "angle":
                        q[i], v[i], _ = self.driver_motion(t0, c.body)
                    else:
                        if drv.initial is not None:
                            q[i] = drv.initial
                        v[i] = drv.rate
            elif c.kind is CoordKind.BETA:  # a slot's support distance: the guess of its slot joint
                q[i] = guess.get(c.joint, 0.5)
            elif c.elastic and c.body in deform:
                d = deform[c.body]
                vals, rates = (d.f, d.fdot) if c.kind is CoordKind.F else (d.g, d.gdot)
                if c.index < len(vals):
                    q[i] = vals[c.index]
                if c.index < len(rates):
                    v[i] = rates[c.index]
        self._guide_slope_start(q, v)
        return q, v

    def _guide_slope_start(self, q: np.ndarray, v: np.ndarray) -> None:
        """A guide with an elastic overhang whose file states its span amplitudes g (the sines
        sin(k pi xi / beta) with their tangent continuation, as written): the span functions s_k
        have zero slope at the contact, so the contact-slope function chi_0 starts at
        sum_k g_k psi_k'(beta) (and its rate likewise), beta at its guess (``symgen.model.slot``)."""
        sc = self.scene
        for j in sc.joints:
            if j.kind != "slot" or not j.overhang_modes:
                continue
            name = j.ends[1].body
            d = dict(sc.initial.deformation).get(name)
            if d is None or not (d.g or d.gdot):
                continue
            idx = self.amplitudes[name][1]
            nspan = len(idx) - j.overhang_modes - 1
            b = next(q[i] for i, c in enumerate(self.coords) if c.kind is CoordKind.BETA and c.joint == j.name)
            slope = np.array([(-1) ** k * k * np.pi / b for k in range(1, nspan + 1)])
            q[idx[nspan]] = float(slope @ q[list(idx[:nspan])])
            v[idx[nspan]] = float(slope @ v[list(idx[:nspan])])

    def initial_state(self, t0: float = 0.0) -> start.State:
        """Consistent (q, v, a, lam) at t0 and the coordinate partition (``start.consistent_start``)."""
        return start.consistent_start(self, t0)


def stated_quasi_static(scene: Scene) -> bool:
    """Whether a bar of ``scene`` has quasi-static transverse functions symgen did not choose
    (:func:`quasi_static_amplitudes` may refuse those; symgen's choice is never refused)."""
    chosen = {c.bar: c.quasi for c in scene.bases if c.quasi}
    return any(
        b.quasi_static_transverse and chosen.get(b.name) != b.quasi_static_transverse
        for b in scene.bodies
        if not b.rigid
    )


def quasi_static_amplitudes(mech: Mechanism, phi_q: ca.SX) -> tuple[int, ...]:
    """The coordinate indices of the quasi-static transverse amplitudes of the scene's bars
    (``bodies.<name>.quasi_static_transverse``: the highest of each bar's standard transverse
    functions, before its static correction functions) and of the axial amplitudes symgen chose
    quasi-static (``BasisChoice.quasi_axial``: the highest of a bar's axial functions). Refused (SceneError, exit 2) where the
    treatment would be inconsistent: a function that moves a joint (its amplitude appears in the
    loop closure ``phi_q``: its rate and acceleration would be missing from the velocity and
    acceleration closure; an inextensibility row may read it: the axial shortening then follows
    the quasi-static amplitude's value, its rate only the dynamic ones'), a slot's guide with a rigid overhang (its span functions carry the overhang's rotation; with an elastic
    overhang the span functions s_k are zero beyond the contact, ``symgen.model.slot``), polynomial
    shapes (not ordered by frequency), more functions than the bar has."""
    scene = mech.scene
    chosen = {c.bar: c.quasi for c in scene.bases if c.quasi}
    out: list[int] = []
    for body in scene.bodies:
        k = body.quasi_static_transverse
        if body.rigid or not k:
            continue
        if chosen.get(body.name) == k:  # symgen's choice (symgen.scene.bases.quasi_choice): never refused
            out += _chosen_quasi(mech, phi_q, body.name, body.transverse_modes, k)
            continue
        key = f"bodies.{body.name}.quasi_static_transverse"
        nt = body.transverse_modes if scene.effects.transverse else 0
        if body.transverse_shapes == "polynomial":
            raise SceneError(
                scene.path,
                key,
                'quasi-static functions need transverse_shapes ordered by frequency, not "polynomial"',
                'use transverse_shapes = "modes" or "eigen", or leave out quasi_static_transverse',
            )
        if any(
            j.kind == "slot" and not j.overhang_modes and any(e.body == body.name and e.variable for e in j.ends)
            for j in scene.joints
        ):
            raise SceneError(
                scene.path,
                key,
                "a slot's guide with a rigid overhang cannot have quasi-static functions (each span function "
                "carries the overhang's rotation with its end slope)",
                'leave out quasi_static_transverse on the guide, or set the slot\'s overhang = "elastic"',
            )
        if k > nt:
            raise SceneError(
                scene.path,
                key,
                f"{k} quasi-static functions is more than the bar's {nt} transverse functions"
                + ("" if scene.effects.transverse else " (effects.transverse is off)"),
                f"give at most {nt}",
            )
        idx = list(mech.amplitudes[body.name][1][nt - k : nt])
        loops = [r for r in range(mech.m) if r not in mech.inext_rows]
        moving = [i for i in idx if _reads(phi_q, loops, i)]
        if moving:
            raise SceneError(
                scene.path,
                key,
                f"the function {mech.coords[moving[0]].name} moves a joint of the bar (it is not zero at an "
                "interior pin or a slider): a quasi-static amplitude has no rate for the closure",
                "lower quasi_static_transverse to keep that function dynamic, or move the joint to an end of the bar",
            )
        out += idx
    for c in scene.bases:  # symgen's choice of quasi-static axial functions (no key states them)
        if c.quasi_axial:
            out += _chosen_quasi_axial(mech, phi_q, c.bar, c.axial, c.quasi_axial)
    return tuple(sorted(out))


def _reads(phi_q: ca.SX, rows: list[int], i: int) -> bool:
    """Whether the closure rows ``rows`` of ``phi_q`` read coordinate ``i`` (an entry that is not
    the constant zero)."""
    return any(not phi_q[r, i].is_zero() for r in rows)


def _chosen_quasi_axial(mech: Mechanism, phi_q: ca.SX, name: str, na: int, k: int) -> list[int]:
    """The amplitudes of the highest ``k`` of bar ``name``'s ``na`` axial functions that symgen
    chose quasi-static (``symgen.scene.bases.quasi_choice``), fewer where the closure reads one,
    none where the bar's axial amplitudes are not the run's own (an inextensible or quasi-static
    axial treatment makes them dependent): dynamic is always consistent."""
    idx = list(mech.amplitudes[name][0][:na])
    if any(i in mech.inext_f for i in idx):
        return []
    loops = [r for r in range(mech.m) if r not in mech.inext_rows]
    while k and any(_reads(phi_q, loops, i) for i in idx[na - k :]):
        k -= 1
    return idx[na - k :] if k else []


def _chosen_quasi(mech: Mechanism, phi_q: ca.SX, name: str, nt: int, k: int) -> list[int]:
    """The amplitudes of the highest ``k`` of bar ``name``'s ``nt`` transverse functions that
    symgen chose quasi-static, fewer where the closure reads one (the choice's numpy model found
    none: a sine at a node of its own reads about 1e-16 here): dynamic is always consistent."""
    loops = [r for r in range(mech.m) if r not in mech.inext_rows]
    idx = list(mech.amplitudes[name][1][:nt])
    while k and any(_reads(phi_q, loops, i) for i in idx[nt - k :]):
        k -= 1
    return idx[nt - k :] if k else []
