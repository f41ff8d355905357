"""Dynamic simulation with SUNDIALS IDAS (through CasADi) of the index-1 DAE of ``Mechanism``.

Integration runs in chunks with one integrator object (time enters through an offset
parameter), so that a failure can be located within one output step, the partial result kept,
and the rigid mechanism's distance to a singular position checked at every output.
At each output the algebraic variables are polished by Newton on the algebraic equations
(position closure to ~1e-14), then the outputs are evaluated.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..errors import Interrupted, SimulationError
from . import interrupt
from .mechanism import SINGULAR_RATIO, Mechanism, Partition, index1

CHUNK = 128         # output steps per integrator call
CALC_IC = False     # z0 is always consistent (our own Newton); IDACalcIC only fails on it


@dataclass
class SimResult:
    tau: np.ndarray
    outputs: np.ndarray             # (N, n_out)
    output_names: list
    q: np.ndarray                   # (N, n)
    v: np.ndarray
    lam: np.ndarray
    closure_max: float
    steps: int
    simulate_s: float
    partition: Partition
    complete: bool = True
    failure: str = ""
    stats: dict = field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        """The output called ``name`` (as in the scene's [outputs])."""
        return self.outputs[:, self.output_names.index(name)]


class DaeRunner:
    def __init__(self, mech: Mechanism, part: Partition, rtol: float, atol: float,
                 axial_atol: float | None = None) -> None:
        self.mech, self.part = mech, part
        n, m = mech.n, mech.m
        I, D = list(part.ind), list(part.dep)
        nI, nD = len(I), len(D)
        self.nI, self.nD = nI, nD
        sys_ = index1(n, m, part)
        x, z, q, v, a, lam = sys_.x, sys_.z, sys_.q, sys_.v, sys_.a, sys_.lam
        p = ca.SX.sym("p", len(mech.p) + 1)
        t = ca.SX.sym("t")
        tt = t + p[-1]                      # time offset: one integrator serves every chunk
        args = [tt, q, v, a, lam, p[:-1]]
        f = mech.f
        alg = sys_.alg(f, tt, p[:-1])
        ode = ca.vertcat(x[nI:], a[I] if I else ca.SX(0, 1))
        self.dae = {"x": x, "z": z, "p": p, "t": t, "ode": ode, "alg": alg}
        self.g = ca.Function("g", [t, x, z, p], [alg, ca.jacobian(alg, z)])
        self.split = ca.Function("split", [x, z], [q, v, a, lam])
        # everything recorded at an output, in one call (mapped over a chunk's outputs)
        phi_q = ca.jacobian(f["phi"](*args), q)
        # singular-position check on the loop and driver rows and the dependent rigid
        # coordinates only, as Mechanism.singular_ratio (inextensibility rows left out)
        rows = [i for i in range(m) if i not in mech.inext_rows]
        Ds = [i for i in D if i not in mech.inext_f]
        self.n_sing = len(Ds)
        self.rec = ca.Function("rec", [t, x, z, p], [q, v, lam, f["out"](*args), f["closure"](*args),
                                                     phi_q[rows, Ds] if Ds else ca.SX(len(rows), 0)])
        self._maps: dict = {}
        self.opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 2_000_000,
                     "suppress_algebraic": True, "disable_internal_warnings": True,
                     "calc_ic": CALC_IC}
        if axial_atol is not None:
            # a looser error control on the axial amplitudes and their rates (x = [q_I, v_I])
            ax = [axial_atol if mech.coords[i]["kind"] == "f" else atol for i in I]
            self.opts["abstolv"] = ax + ax + [atol] * (2 * nD + n + m)

    def pack(self, q, v, a, lam) -> tuple[np.ndarray, np.ndarray]:
        I, D = list(self.part.ind), list(self.part.dep)
        x = np.concatenate([q[I], v[I]])
        z = np.concatenate([q[D], v[D], a, lam])
        return x, z

    def unpack(self, x, z):
        q, v, a, lam = self.split(x, z)
        return (np.array(q).ravel(), np.array(v).ravel(), np.array(a).ravel(), np.array(lam).ravel())

    def integrator(self, h: float, k: int, x, z):
        """IDAS over k output steps of h from (x, z). The state derivatives at the start are
        given exactly (x' = [v_I, a_I], read from z): CasADi would otherwise start IDAS with
        x' = 0, and a nonzero initial acceleration then forces steps of order atol/|a|.
        (Creating the integrator costs ~10 ms, small beside a chunk's integration.)"""
        opts = dict(self.opts)
        opts["init_xdot"] = [float(w) for w in self.xdot(x, z)]
        grid = [h * (i + 1) for i in range(k)]
        return ca.integrator("F", "idas", self.dae, 0.0, grid, opts)

    def xdot(self, x, z) -> np.ndarray:
        x = np.asarray(x, dtype=float).ravel()
        z = np.asarray(z, dtype=float).ravel()
        a = z[2 * self.nD: 2 * self.nD + self.mech.n]
        return np.concatenate([x[self.nI:], a[list(self.part.ind)]])

    def _map(self, name: str, k: int):
        key = (name, k)
        if key not in self._maps:
            self._maps[key] = getattr(self, name).map(k)
        return self._maps[key]

    def polish_many(self, t: np.ndarray, X: np.ndarray, Z: np.ndarray, p, tol: float = 1e-13) -> np.ndarray:
        """``polish`` of every column of Z at once (one mapped call per Newton iteration, the
        same iteration per column: columns stop when their residual is below ``tol``)."""
        k = X.shape[1]
        Z = np.array(Z, dtype=float)
        nz = Z.shape[0]
        todo = np.ones(k, dtype=bool)
        gmap = self._map("g", k)
        for _ in range(8):
            G, J = gmap(t.reshape(1, -1), X, Z, p)
            G = np.array(G)
            todo &= np.abs(G).max(axis=0) >= tol
            if not todo.any():
                break
            J = np.array(J).reshape(nz, k, nz).transpose(1, 0, 2)
            try:
                dz = np.linalg.solve(J[todo], G.T[todo][..., None])[..., 0]
            except np.linalg.LinAlgError:
                break
            Z[:, todo] -= dz.T
        return Z

    def polish(self, t: float, x, z, p, tol: float = 1e-13) -> np.ndarray:
        z = np.array(z, dtype=float).ravel()
        for _ in range(8 if tol < 1e-12 else 30):
            g, J = self.g(t, x, z, p)
            g = np.array(g).ravel()
            if np.abs(g).max() < tol:
                break
            try:
                z = z - np.linalg.solve(np.array(J), g)
            except np.linalg.LinAlgError:
                break
        return z


def simulate(mech: Mechanism, t_end: float | None = None, output_step: float | None = None,
             rtol: float | None = None, atol: float | None = None, t0: float = 0.0,
             initial: tuple | None = None, axial_atol: float | None = None) -> SimResult:
    """Integrate the scene's DAE from t0 to t_end, output every output_step (in tau).

    ``axial_atol``: absolute tolerance of the axial amplitudes and their rates instead of
    ``atol`` (e.g. 1e3: no error control on them, so IDAS's BDF steps over the start-up
    ringing of the stiff axial modes and damps it numerically; bending and rigid motion keep
    rtol/atol; see benchmarks/RESULTS.md for what it costs in accuracy)."""
    sim = mech.scene.simulation
    t_end = sim.t_end if t_end is None else t_end
    h = sim.output_step if output_step is None else output_step
    rtol = sim.rtol if rtol is None else rtol
    atol = sim.atol if atol is None else atol
    try:           # a signal during the start (assembly, consistent state) stops the run at t0
        if initial is None:
            q, v, a, lam, part = mech.initial_state(t0)
        else:
            q, v, a, lam, part = initial
        run = DaeRunner(mech, part, rtol, atol, axial_atol)
        x, z = run.pack(q, v, a, lam)
    except BaseException as err:
        stop = interrupt.interrupted(err, t0)
        if stop is err:
            raise
        raise stop from None
    n_out_total = int(np.floor((t_end - t0) / h + 1e-9))
    taus, outs, qs, vs, lams = [], [], [], [], []
    closure_max = 0.0
    steps = 0
    pfull = np.concatenate([mech.p, [t0]])

    def record(t, x_, z_, append=True):
        nonlocal closure_max
        qq, vv, aa, ll = run.unpack(x_, z_)
        if append:
            out = mech.call("out", t, qq, vv, aa, ll)
            clo = mech.call("closure", t, qq)
            if clo.size:
                closure_max = max(closure_max, float(np.abs(clo).max()))
            taus.append(t), outs.append(out), qs.append(qq), vs.append(vv), lams.append(ll)
        beyond = mech.beyond_range(qq)
        if beyond is not None:
            raise SimulationError(t, beyond[1], "check the loads, lumped masses and stiffness (lambda, mu) of that bar")
        ratio, row = mech.singular_ratio(t, qq, part)
        if ratio < SINGULAR_RATIO:
            raise SimulationError(t, f"the rigid mechanism reached a singular position: the closure Jacobian "
                                     f"of the {mech.loop_name(row)} loses rank (ratio {ratio:.2e})",
                                  "the mechanism cannot pass this position as driven; shorten t_end or change the geometry")

    def record_many(ts, rel, X, Z, p):
        """``record`` of a chunk's outputs with one mapped call (same values, same stop at the
        first singular position)."""
        nonlocal closure_max
        k = len(ts)
        Q, V, L, O, C, Jd = (np.array(w) for w in run._map("rec", k)(rel.reshape(1, -1), X, Z, p))
        L, O, C = (w.reshape(-1, k) for w in (L, O, C))     # no multipliers (an open chain): (0, k)
        stop = k
        if run.n_sing:
            nd = run.n_sing
            sv = np.linalg.svd(Jd.reshape(-1, k, nd).transpose(1, 0, 2), compute_uv=False)
            bad = np.nonzero(sv[:, -1] / np.maximum(sv[:, 0], 1e-300) < SINGULAR_RATIO)[0]
            if len(bad):
                stop = int(bad[0]) + 1
        beyond = mech.beyond_range(Q)
        if beyond is not None and beyond[0] < stop:
            stop = beyond[0] + 1
        if C.size:
            closure_max = max(closure_max, float(np.abs(C[:, :stop]).max()))
        for i in range(stop):
            taus.append(ts[i]), outs.append(O[:, i]), qs.append(Q[:, i]), vs.append(V[:, i]), lams.append(L[:, i])
        if stop < k:
            record(ts[stop - 1], X[:, stop - 1], Z[:, stop - 1], append=False)   # raises, naming the loop

    failure = ""
    tic = time.perf_counter()
    try:
        record(t0, x, z)
        done = 0
        if run.nI == 0:
            # no differential state (a rigid, fully driven mechanism): the motion is the
            # algebraic solution at each output time; Newton from the previous solution
            z_prev = None
            for i in range(1, n_out_total + 1):
                ti = t0 + i * h
                pfull[-1] = ti
                guess = z if z_prev is None else 2 * z - z_prev
                z_new = run.polish(0.0, x, guess, pfull, tol=1e-12)
                g = np.array(run.g(0.0, x, z_new, pfull)[0]).ravel()
                # the position closure (first m rows) decides; the dynamic rows are linear in
                # (a, lam) and carry force units (1e6 masses: round-off above any absolute 1e-9)
                if not np.all(np.isfinite(g)) or np.abs(g[:mech.m]).max() > 1e-9:
                    raise _lost(mech, part, ti, qs[-1], taus[-1], "the closure has no solution near the last one",
                                limit=True)
                z_prev, z = z, z_new
                record(ti, x, z)
            done = n_out_total
        while done < n_out_total:
            k = min(CHUNK, n_out_total - done)
            t_start = t0 + done * h
            pfull[-1] = t_start
            interrupt.check(taus[-1])
            try:
                F = run.integrator(h, k, x, z)
                sol = F(x0=x, z0=z, p=pfull)
                steps += int(F.stats()["nsteps"])
            except RuntimeError as err:
                # SIGINT/SIGTERM inside IDAS comes back as a residual failure: it is the
                # interrupt, reported at once (no step-by-step retry)
                stop = interrupt.interrupted(err, taus[-1])
                if isinstance(stop, Interrupted):
                    raise stop from None
                # locate the failure within one output step, keeping what was computed
                for i in range(k):
                    pfull[-1] = t_start + i * h
                    try:
                        F1 = run.integrator(h, 1, x, z)
                        sol = F1(x0=x, z0=z, p=pfull)
                    except RuntimeError as err1:
                        stop = interrupt.interrupted(err1, taus[-1])
                        if isinstance(stop, Interrupted):
                            raise stop from None
                        raise _lost(mech, part, t_start + i * h, qs[-1], taus[-1],
                                    f"IDAS failed: {_idas_cause(err1)}") from None
                    steps += int(F1.stats()["nsteps"])
                    x = np.array(sol["xf"]).ravel()
                    z = run.polish(h, x, np.array(sol["zf"]).ravel(), pfull)
                    record(t_start + (i + 1) * h, x, z)
                    interrupt.check(taus[-1])
                raise SimulationError(t_start, f"IDAS failed in a chunk but not step by step: {_idas_cause(err)}") from None
            X, Z = np.array(sol["xf"]), np.array(sol["zf"])
            rel = h * np.arange(1, k + 1)
            Z = run.polish_many(rel, X, Z, pfull)
            record_many(t_start + rel, rel, X, Z, pfull)
            x, z = X[:, -1], Z[:, -1]
            done += k
    except (SimulationError, Interrupted, RuntimeError) as err:
        exc = interrupt.interrupted(err, taus[-1] if taus else t0)
        if not isinstance(exc, (SimulationError, Interrupted)):
            raise
        failure = str(exc)
    else:
        exc = None
    elapsed = time.perf_counter() - tic
    # an interrupt may land between the appends of one output: keep the outputs recorded whole
    n_rec = min(len(taus), len(outs), len(qs), len(vs), len(lams))
    result = SimResult(tau=np.array(taus[:n_rec]), outputs=np.array(outs[:n_rec]),
                       output_names=list(mech.meta["outputs"]), q=np.array(qs[:n_rec]), v=np.array(vs[:n_rec]),
                       lam=np.array(lams[:n_rec]), closure_max=closure_max,
                       steps=steps, simulate_s=elapsed, partition=part, complete=exc is None, failure=failure)
    if exc is not None:
        exc.partial = result
        raise exc
    return result


NEAR_SINGULAR = 5e-2


def _lost(mech: Mechanism, part: Partition, tau: float, q_last, tau_last: float, cause: str,
          limit: bool = False) -> SimulationError:
    """The error for a step that failed: a singular position of the rigid mechanism when the
    closure Jacobian was already near rank loss at the last good output (or, ``limit``, when
    the driven closure itself lost its solution, which a smooth mechanism does only at a
    singular position), else the solver cause."""
    ratio, row = mech.singular_ratio(tau_last, q_last, part)
    if ratio < NEAR_SINGULAR or limit:
        return SimulationError(tau, f"the rigid mechanism reached a singular position (change point / toggle): "
                                    f"the closure Jacobian of the {mech.loop_name(row)} loses rank "
                                    f"(ratio {ratio:.1e} at tau = {tau_last:.6g}); {cause}",
                               "the mechanism cannot be driven through this position; shorten the run or "
                               "change the geometry or the driver")
    return SimulationError(tau, cause, "tighten or loosen simulation.rtol/atol, or check the scene near this tau")


def _idas_cause(err: Exception) -> str:
    text = str(err)
    m = re.search(r"(IDA_[A-Z_]+)", text)
    flag = m.group(1) if m else "error"
    m2 = re.search(r"(At t=[^\n]*)", text)
    detail = m2.group(1).strip() if m2 else text.strip().splitlines()[-1][:200] if text.strip() else ""
    return f"{flag}: {detail}"
