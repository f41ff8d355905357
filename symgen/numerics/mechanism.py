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

from dataclasses import dataclass

import casadi as ca
import numpy as np

from symgen.errors import SimulationError
from symgen.backends.casadi.pipeline import CompiledModel
from symgen.ir.parameters import parameter_values
from symgen.policy import POLICY
from symgen.scene.model import Scene
from symgen.ir.records import find_coordinate


@dataclass(frozen=True)
class Partition:
    ind: tuple      # indices of independent coordinates (differential)
    dep: tuple      # indices of dependent rigid coordinates (algebraic)


@dataclass(frozen=True)
class Index1:
    """Symbols of the index-1 DAE of a partition: x = [q_I, v_I], z = [q_D, v_D, a, lam]."""

    x: ca.SX
    z: ca.SX
    q: ca.SX
    v: ca.SX
    a: ca.SX
    lam: ca.SX

    def alg(self, f: dict, t, p) -> ca.SX:
        """The algebraic equations [phi; phid; res; phidd] at time t with parameters p."""
        args = [t, self.q, self.v, self.a, self.lam, p]
        return ca.vertcat(*(f[k](*args) for k in ("phi", "phid", "res", "phidd")))


def index1(n: int, m: int, part: Partition) -> Index1:
    """The split of (x, z) into coordinates, rates, accelerations and multipliers."""
    I, D = list(part.ind), list(part.dep)
    nI, nD = len(I), len(D)
    x = ca.SX.sym("x", 2 * nI)
    z = ca.SX.sym("z", 2 * nD + n + m)
    q, v = ca.SX.zeros(n), ca.SX.zeros(n)
    for k, i in enumerate(I):
        q[i], v[i] = x[k], x[nI + k]
    for k, i in enumerate(D):
        q[i], v[i] = z[k], z[nD + k]
    return Index1(x, z, q, v, z[2 * nD: 2 * nD + n], z[2 * nD + n:])


class Mechanism:
    def __init__(self, compiled: CompiledModel, scene: Scene) -> None:
        self.scene = scene
        self.f = compiled.funcs
        self.meta = compiled.meta
        self.coords = self.meta["coords"]
        self.n = len(self.coords)
        self.m = len(self.meta["lam_rows"])
        self.p = parameter_values(scene, self.meta["params"])
        t, q, v, a, lam, p = (ca.SX.sym(k, s) for k, s in
                              (("t", 1), ("q", self.n), ("v", self.n), ("a", self.n), ("lam", self.m),
                               ("p", len(self.p))))
        args = [t, q, v, a, lam, p]
        phi = self.f["phi"](*args)
        self.phi_q = ca.Function("phi_q", args, [ca.jacobian(phi, q)])
        res = self.f["res"](*args)
        phidd = self.f["phidd"](*args)
        self.kkt = ca.Function("kkt", args, [ca.jacobian(ca.vertcat(res, phidd), ca.vertcat(a, lam)),
                                             ca.vertcat(res, phidd)])
        self.rigid = [i for i, c in enumerate(self.coords) if c["kind"] in ("theta", "s", "beta")]
        # effects.axial = "inextensible": the axial amplitudes of those bars are dependent
        # coordinates of their inextensibility rows (kept apart from the loop rows)
        self.inext_rows = [i for i, r in enumerate(self.meta["lam_rows"]) if r["kind"] == "inextensible"]
        inext_bars = {self.meta["lam_rows"][i]["joint"] for i in self.inext_rows}
        self.inext_f = [i for i, c in enumerate(self.coords) if c["kind"] == "f" and c["body"] in inext_bars]
        self.amplitudes: dict = {}        # body -> (axial indices, transverse indices)
        for i, c in enumerate(self.coords):
            if c["kind"] in ("f", "g"):
                self.amplitudes.setdefault(c["body"], ([], []))[c["kind"] == "g"].append(i)

    # ---------------------------------------------------------------- helpers
    def call(self, name: str, t: float, q, v=None, a=None, lam=None) -> np.ndarray:
        v = np.zeros(self.n) if v is None else v
        a = np.zeros(self.n) if a is None else a
        lam = np.zeros(self.m) if lam is None else lam
        return np.array(self.f[name](t, q, v, a, lam, self.p)).ravel()

    def jac_q(self, t: float, q) -> np.ndarray:
        z = np.zeros
        return np.array(self.phi_q(t, q, z(self.n), z(self.n), z(self.m), self.p))

    def loop_name(self, row: int) -> str:
        r = self.meta["lam_rows"][row]
        if r["joint"] == "driver":
            return f"driver of '{r['loop'][-1]}'"
        if r["kind"] == "inextensible":
            return f"inextensibility of bar '{r['joint']}'"
        return f"loop closed by joint '{r['joint']}' ({' - '.join(r['loop'])})"

    def driver_motion(self, t: float) -> tuple[float, float, float]:
        """(theta, theta', theta'') an angle driver prescribes at t, read from the model's own
        driver rows (phi = theta - theta(t), and its two derivatives): whatever the law
        (constant speed, ``law``, ``ramp``), the numbers the equations use."""
        row = self.meta["driver_row"]
        z = np.zeros(self.n)
        return (-float(self.call("phi", t, z)[row]), -float(self.call("phid", t, z, z)[row]),
                -float(self.call("phidd", t, z, z, z)[row]))

    def driver_step(self, t: float) -> float:
        """Time step of the central differences of the quasi-static start: POLICY.driver_step
        rad of the driver at its rate at t (that many tau when it is at rest)."""
        rate = abs(self.driver_motion(t)[1])
        return POLICY.driver_step / rate if rate > 0 else POLICY.driver_step

    # ---------------------------------------------------------------- partition + assembly
    def choose_partition(self, t: float, q) -> Partition:
        """Greedy choice of dependent rigid coordinates with a well-conditioned closure Jacobian."""
        if self.m == 0:
            return Partition(tuple(range(self.n)), ())
        J = self.jac_q(t, q)
        drv = self.scene.driver
        order = list(reversed(self.rigid))
        if drv is not None:
            idx = find_coordinate(self.coords, "theta", drv.body)
            order.remove(idx)
            order = [idx] + order if drv.kind == "angle" else order + [idx]
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
            bad = self._worst_row(J[:, chosen] if chosen else J[:, []])
            raise SimulationError(t, f"the closure equations of the {self.loop_name(bad)} are not independent: "
                                     f"the mechanism is at a singular position (a toggle or change point) "
                                     f"or over-constrained",
                                  "start the driver at another angle, check the joints, the driver and initial.guess")
        ind = tuple(i for i in range(self.n) if i not in chosen)
        return Partition(ind, tuple(chosen))

    def _worst_row(self, Jd: np.ndarray) -> int:
        if Jd.shape[1] == 0:
            return 0
        u, s, _ = np.linalg.svd(Jd)
        return self._loop_row(u[:, -1])

    def singular_ratio(self, t: float, q, part: Partition) -> tuple[float, int]:
        """Smallest / largest singular value of the loop and driver rows' Jacobian in the
        dependent rigid coordinates (inextensibility rows and their axial amplitudes, a
        regular block Ka, are left out: the rigid mechanism alone decides singularity)."""
        rows = [i for i in range(self.m) if i not in self.inext_rows]
        cols = [i for i in part.dep if i not in self.inext_f]
        if not cols:
            return 1.0, 0
        Jd = self.jac_q(t, q)[np.ix_(rows, cols)]
        u, s, _ = np.linalg.svd(Jd)
        weights = np.zeros(self.m)
        weights[rows] = u[:, -1]
        return float(s[-1] / max(s[0], 1e-300)), self._loop_row(weights)

    def _loop_row(self, weights) -> int:
        """The closure row (a loop, not the driver) that weighs most in a singular direction."""
        w = np.abs(np.asarray(weights, dtype=float))
        for i, r in enumerate(self.meta["lam_rows"]):
            if (r["joint"] == "driver" or r["kind"] == "inextensible") and len(w) > 1:
                w[i] = -1.0
        return int(np.argmax(w))

    def assemble(self, t: float, q_guess, part: Partition, tol: float = POLICY.assembly_tol,
                 maxit: int = POLICY.assembly_maxit):
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
        raise SimulationError(t, f"the mechanism cannot be assembled near initial.guess: the closure of the "
                                 f"{self.loop_name(worst)} keeps a residual of {np.abs(r).max():.3g}",
                              "give initial.guess angles (rad) near a real assembly, and check lengths and ground points")

    def velocities(self, t: float, q, v, part: Partition) -> np.ndarray:
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

    def accelerations(self, t: float, q, v) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations and multipliers from the dynamics and the acceleration-level closure."""
        z0n, z0m = np.zeros(self.n), np.zeros(self.m)
        K, r = self.kkt(t, q, v, z0n, z0m, self.p)
        sol = np.linalg.solve(np.array(K), -np.array(r).ravel())
        return sol[: self.n], sol[self.n:]

    def initial_guess(self, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) the assembly starts from: the driver's angle and rate, initial.guess angles
        (and slot distances, by joint name), the given deformation and its rates, else zeros."""
        sc = self.scene
        q = np.zeros(self.n)
        v = np.zeros(self.n)
        guess = dict(sc.initial.guess)
        deform = dict(sc.initial.deformation)
        drv = sc.driver
        for i, c in enumerate(self.coords):
            if c["kind"] == "theta":
                q[i] = guess.get(c["body"], 0.0)
                if drv is not None and drv.body == c["body"]:
                    if drv.kind == "angle":
                        q[i], v[i], _ = self.driver_motion(t0)
                    else:
                        if drv.initial is not None:
                            q[i] = drv.initial
                        v[i] = drv.rate
            elif c["kind"] == "beta":      # a slot's support distance: the guess of its slot joint
                q[i] = guess.get(c["joint"], 0.5)
            elif c["kind"] in ("f", "g") and c["body"] in deform:
                d = deform[c["body"]]
                vals, rates = (d.f, d.fdot) if c["kind"] == "f" else (d.g, d.gdot)
                if c["index"] < len(vals):
                    q[i] = vals[c["index"]]
                if c["index"] < len(rates):
                    v[i] = rates[c["index"]]
        return q, v

    def initial_state(self, t0: float = 0.0):
        """Consistent (q, v, a, lam) at t0 and the coordinate partition."""
        sc = self.scene
        q, v = self.initial_guess(t0)
        part = self.choose_partition(t0, q)
        q = self.assemble(t0, q, part)
        part = self.choose_partition(t0, q)     # re-choose at the assembled position
        ratio, row = self.singular_ratio(t0, q, part)
        if ratio < POLICY.singular_ratio:
            raise SimulationError(t0, f"the rigid mechanism starts at a singular position: the closure Jacobian "
                                      f"of the {self.loop_name(row)} loses rank (ratio {ratio:.2e})",
                                  "start the driver at another angle or change initial.guess")
        if sc.initial.quasi_static:
            q, v = self.quasi_static_start(t0, q, v, part)
        v = self.velocities(t0, q, v, part)
        a, lam = self.accelerations(t0, q, v)
        return q, v, a, lam, part

    # ---------------------------------------------------------------- quasi-static states
    def _static_system(self, part: Partition):
        """Newton system of the quasi-static state (18)-(19): deformation rates and
        accelerations zero, rigid kinematics consistent with closure at all three levels."""
        key = part
        if getattr(self, "_static_key", None) == key:
            return self._static_fun
        D = list(part.dep)
        E = [i for i, c in enumerate(self.coords) if c["kind"] in ("f", "g") and i not in D]
        R = sorted(set(self.rigid) | set(D))        # unknown accelerations
        nE, nD, nR = len(E), len(D), len(R)
        u = ca.SX.sym("u", nE + 2 * nD + nR + self.m)
        t = ca.SX.sym("t")
        q0 = ca.SX.sym("q0", self.n)
        v0 = ca.SX.sym("v0", self.n)
        q, v, a = ca.SX(q0), ca.SX(v0), ca.SX.zeros(self.n)
        for k, i in enumerate(E):
            q[i] = u[k]
            v[i] = 0
        for k, i in enumerate(D):
            q[i] = u[nE + k]
            v[i] = u[nE + nD + k]
        for k, i in enumerate(R):
            a[i] = u[nE + 2 * nD + k]
        lam = u[nE + 2 * nD + nR:]
        args = [t, q, v, a, lam, self.p]
        F = ca.vertcat(self.f["phi"](*args), self.f["phid"](*args), self.f["res"](*args), self.f["phidd"](*args))
        self._static_fun = ca.Function("static", [t, q0, v0, u], [F, ca.jacobian(F, u), q, v])
        self._static_key = key
        self._static_E = E
        self._static_nR = nR
        return self._static_fun

    def quasi_static(self, t: float, q, v, part: Partition, tol: float = POLICY.quasi_static_tol,
                     maxit: int = POLICY.quasi_static_maxit):
        """Quasi-static deformation at t for the rigid state in (q, v): returns (q, v, iterations)."""
        fun = self._static_system(part)
        E, D = self._static_E, list(part.dep)
        u = np.concatenate([q[E], q[D], v[D], np.zeros(self._static_nR), np.zeros(self.m)])
        for it in range(1, maxit + 1):
            F, J, _, _ = fun(t, q, v, u)
            F = np.array(F).ravel()
            if np.abs(F).max() < tol:
                break
            u = u - np.linalg.solve(np.array(J), F)
        else:
            F = np.array(fun(t, q, v, u)[0]).ravel()
            if np.abs(F).max() > POLICY.quasi_static_accept:
                raise SimulationError(t, f"the quasi-static state did not converge (residual {np.abs(F).max():.3g})",
                                      "the mechanism may be near buckling or a singular position")
        _, _, qn, vn = fun(t, q, v, u)
        return np.array(qn).ravel(), np.array(vn).ravel(), it

    def beyond_range(self, Q) -> tuple[int, str] | None:
        """First column of Q (coordinates x outputs) where a bar is deformed beyond the range
        of the model (``POLICY.deflection_limit``, ``POLICY.stretch_limit``), with the reason; None if none."""
        Q = np.asarray(Q, dtype=float).reshape(self.n, -1)
        first = None
        for body, (fi, gi) in self.amplitudes.items():
            for idx, limit, what in ((gi, POLICY.deflection_limit, "transverse deflection"),
                                     (fi, POLICY.stretch_limit, "axial displacement")):
                if not idx:
                    continue
                size = np.abs(Q[idx]).sum(axis=0)
                bad = np.nonzero(~(size <= limit))[0]        # NaN counts as beyond
                if len(bad) and (first is None or bad[0] < first[0]):
                    first = (int(bad[0]), body, what, float(size[bad[0]]), limit)
        if first is None:
            return None
        k, body, what, size, limit = first
        return k, (f"bar '{body}' is deformed beyond the range of the model: its {what} amplitudes "
                   f"sum to {size:.3g} of its length (limit {limit:g}; the bar equations hold for moderate "
                   f"rotations and small strains): a load beyond a buckling load, or forces the bar "
                   f"cannot carry")

    def divergent_deformation(self, t: float, q, v, part: Partition) -> tuple[float, str]:
        """Largest real, positive eigenvalue of the linearised motion of the independent
        deformation amplitudes about (q, v) (rigid independent coordinates held; dependent
        ones follow the closure), and the amplitude dominating its eigenvector. Positive:
        the state is statically unstable (beyond a buckling load). (0.0, "") if none."""
        E = [i for i in part.ind if self.coords[i]["kind"] in ("f", "g")]
        if not E:
            return 0.0, ""
        I, D = list(part.ind), list(part.dep)
        nI, nD = len(I), len(D)
        sys_ = index1(self.n, self.m, part)
        G = sys_.alg(self.f, t, self.p)
        jac = ca.Function("lin", [sys_.x, sys_.z], [ca.jacobian(G, sys_.x), ca.jacobian(G, sys_.z)])
        a, lam = self.accelerations(t, q, v)
        Gx, Gz = (np.array(w) for w in jac(np.concatenate([q[I], v[I]]),
                                           np.concatenate([q[D], v[D], a, lam])))
        dzdx = -np.linalg.solve(Gz, Gx)
        e = [I.index(i) for i in E]
        cols = e + [nI + k for k in e]
        A = np.zeros((2 * len(E), 2 * len(E)))
        A[:len(E), len(E):] = np.eye(len(E))
        A[len(E):, :] = dzdx[[2 * nD + i for i in E]][:, cols]
        s, W = np.linalg.eig(A)
        scale = max(1.0, float(np.abs(s).max()))
        tol = POLICY.divergence_rtol * scale
        real = [k for k in range(len(s)) if abs(s[k].imag) <= tol and s[k].real > tol]
        if not real:
            return 0.0, ""
        k = max(real, key=lambda j: s[j].real)
        return float(s[k].real), self.coords[E[int(np.argmax(np.abs(W[:len(E), k])))]]["name"]

    def quasi_static_start(self, t0: float, q, v, part: Partition):
        """Initial deformation = quasi-static state; under an angle driver the deformation
        rates are the quasi-static ones too (central difference), so the start rings little.
        An unstable quasi-static state (beyond a buckling load) is refused: the run would sit on
        an equilibrium the bar leaves at the first disturbance."""
        qs, vs, _ = self.quasi_static(t0, q, v, part)
        beyond = self.beyond_range(qs)
        if beyond is not None:
            raise SimulationError(t0, f"in the quasi-static state, {beyond[1]}",
                                  "check the loads, lumped masses and stiffness (lambda, mu) of that bar")
        rate, coord = self.divergent_deformation(t0, qs, vs, part)
        if rate > 0:
            raise SimulationError(t0, f"the quasi-static state is unstable: the deformation grows at rate "
                                      f"{rate:.3g} (per unit tau) along {coord}, a load beyond a buckling load",
                                  "lower the load or stiffen the bar; or start undeformed (remove initial.deformation "
                                  "= \"quasi-static\") to follow the bar into its buckled state")
        drv = self.scene.driver
        if drv is None or drv.kind != "angle" or not any(self.driver_motion(t0)[1:]):
            return qs, vs       # a driver at rest (constant angle): the quasi-static rates are zero
        E = self._static_E
        h = self.driver_step(t0)
        ends = []
        for dt in (-h, h):
            qq = qs.copy()
            i = find_coordinate(self.coords, "theta", drv.body)
            qq[i] = self.driver_motion(t0 + dt)[0]
            qq = self.assemble(t0 + dt, qq, part)
            vv = self.velocities(t0 + dt, qq, vs, part)
            ends.append(self.quasi_static(t0 + dt, qq, vv, part)[0])
        vs = vs.copy()
        vs[E] = (ends[1][E] - ends[0][E]) / (2 * h)
        return qs, vs
