"""Dynamic simulation with SUNDIALS IDAS (through CasADi) of the index-1 DAE of ``Mechanism``.

Integration runs in chunks of growing length (128 outputs, doubling up to 2048) with one
integrator object per chunk length, reused (time enters through an offset parameter), so that
a failure can be located within one output step, the partial result kept, and the rigid
mechanism's distance to a singular position checked at every output. The model's functions
run compiled (a cached shared library, :mod:`symgen.numerics.compiled`) or in CasADi's virtual
machine, with the same numbers.
At each output the algebraic variables are polished by Newton on the algebraic equations
(position closure to ~1e-14), then the outputs are evaluated.
"""
from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from symgen.errors import Interrupted, SceneError, SimulationError
from symgen.ir.records import CoordKind
from symgen.policy import POLICY
from symgen.numerics import compiled, interrupt
from symgen.numerics import checks
from symgen.numerics.index1 import Partition, index1
from symgen.numerics.mechanism import Mechanism

CHUNK = 128         # output steps of the first integrator call; each next one covers twice as
CHUNK_MAX = 2048    # many, up to CHUNK_MAX, or all the rest when that is at most twice as many
                    # (the same chunks whatever the backend: the same steps, the same numbers)
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
    """The index-1 DAE of a partition as CasADi Functions, and IDAS over it.

    ``backend``: "compiled" (the Functions compiled to a cached shared library, see
    :mod:`symgen.numerics.compiled`), "vm" (CasADi's virtual machine) or "auto" (compiled when a C
    compiler is at hand, else the virtual machine, said in one line on stderr). Both evaluate
    the same operations in the same order: their results agree to the last bit."""

    def __init__(self, mech: Mechanism, part: Partition, rtol: float, atol: float,
                 axial_atol: float | None = None, backend: str | None = None, use_cache: bool = True) -> None:
        self.mech, self.part = mech, part
        n, m = mech.n, mech.m
        I, D = list(part.ind), list(part.dep)
        nI, nD = len(I), len(D)
        self.nI, self.nD = nI, nD
        sys_ = index1(n, m, part)
        x, z, q, v, a, lam = sys_.x, sys_.z, sys_.q, sys_.v, sys_.a, sys_.lam
        p = ca.SX.sym("p", len(mech.p) + 1)
        t = ca.SX.sym("t")
        u = ca.SX.sym("u", 0)
        tt = t + p[-1]                      # time offset: one integrator serves every chunk
        args = [tt, q, v, a, lam, p[:-1]]
        f = mech.f
        alg = sys_.alg(f, tt, p[:-1])
        ode = ca.vertcat(x[nI:], a[I] if I else ca.SX(0, 1))
        dae_in, dae_out = [t, x, z, p, u], [ode, alg, ca.SX(0, 1), ca.SX(0, 1)]
        self.dae = ca.Function("dae", dae_in, dae_out, ca.dyn_in(), ca.dyn_out())
        self.g = ca.Function("g", [t, x, z, p], [alg, ca.jacobian(alg, z)])
        self.split = ca.Function("split", [x, z], [q, v, a, lam])
        # everything recorded at an output, in one call (mapped over a chunk's outputs)
        phi_q = ca.jacobian(f["phi"](*args), q)
        # singular-position check on the loop and driver rows and the dependent rigid
        # coordinates only, as checks.singular_ratio (inextensibility rows left out)
        rows = [i for i in range(m) if i not in mech.inext_rows]
        Ds = [i for i in D if i not in mech.inext_f]
        self.n_sing = len(Ds)
        self.rec = ca.Function("rec", [t, x, z, p], [q, v, lam, f["out"](*args), f["closure"](*args),
                                                     phi_q[rows, Ds] if Ds else ca.SX(len(rows), 0)])
        self.backend, self.library = "vm", None
        choice = compiled.backend_choice(backend)
        if choice != "vm":
            funcs = [self.dae, _dae_jacobian(self.dae, dae_in, dae_out), self.g, self.split, self.rec]
            try:
                ext, built = compiled.library(funcs, mech.info.key, f"ind={list(part.ind)} dep={list(part.dep)}",
                                              store=use_cache)
            except compiled.Unavailable as exc:
                if choice == "compiled":
                    raise SceneError("command line", "--backend", f"compiled: {exc.reason}",
                                     f"install a C compiler or set ${compiled.CC_ENV} to one; "
                                     "or run with --backend vm") from None
                _notice(f"{exc.reason}: running the model in CasADi's virtual machine (slower; "
                        f"--backend vm or ${compiled.BACKEND_ENV}=vm chooses it quietly)")
            else:
                self.dae, self.g, self.split, self.rec = ext["dae"], ext["g"], ext["split"], ext["rec"]
                self.backend, self.library = "compiled", "built" if built else "cached"
        # one Newton step of the output polish, solved inside CasADi: mapped over a chunk, only
        # the new Z and each column's residual norm cross into Python (not the k Jacobians)
        tm, xm, zm, pm = (ca.MX.sym(nm, w.size1()) for nm, w in (("t", t), ("x", x), ("z", z), ("p", p)))
        gm, jm = self.g(tm, xm, zm, pm)
        self.gstep = ca.Function("gstep", [tm, xm, zm, pm], [zm - ca.solve(jm, gm), ca.norm_inf(gm)])
        self._maps: dict = {}
        self._integrators: dict = {}
        self.opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 2_000_000,
                     "suppress_algebraic": True, "disable_internal_warnings": True,
                     "calc_ic": CALC_IC}
        if axial_atol is not None:
            # a looser error control on the axial amplitudes and their rates (x = [q_I, v_I])
            ax = [axial_atol if mech.coords[i].kind is CoordKind.F else atol for i in I]
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
        """IDAS over k output steps of h (time offset in the last parameter), made once per k
        and reused. The state derivatives at the start are those at (x, z) of its first use
        (x' = [v_I, a_I], read from z): CasADi would otherwise start IDAS with x' = 0, and a
        nonzero initial acceleration then forces steps of order atol/|a|; at later starts they
        are close enough."""
        if (h, k) not in self._integrators:
            opts = dict(self.opts)
            opts["init_xdot"] = [float(w) for w in self.xdot(x, z)]
            grid = [h * (i + 1) for i in range(k)]
            self._integrators[(h, k)] = ca.integrator("F", "idas", self.dae, 0.0, grid, opts)
        return self._integrators[(h, k)]

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

    def polish_many(self, t: np.ndarray, X: np.ndarray, Z: np.ndarray, p, tol: float = POLICY.polish_tol) -> np.ndarray:
        """``polish`` of every column of Z at once (one mapped Newton step per iteration, the
        same iteration per column: columns stop when their residual is below ``tol``; a column
        whose step is not finite (singular Jacobian) keeps its last value)."""
        k = X.shape[1]
        Z = np.array(Z, dtype=float)
        todo = np.ones(k, dtype=bool)
        step = self._map("gstep", k)
        for _ in range(POLICY.polish_maxit):
            Znew, res = step(t.reshape(1, -1), X, Z, p)
            todo &= np.array(res).ravel() >= tol
            if not todo.any():
                break
            Znew = np.array(Znew)
            todo &= np.isfinite(Znew).all(axis=0)
            Z[:, todo] = Znew[:, todo]
        return Z

    def polish(self, t: float, x, z, p, tol: float = POLICY.polish_tol) -> np.ndarray:
        z = np.array(z, dtype=float).ravel()
        for _ in range(POLICY.polish_maxit if tol <= POLICY.polish_tol else 30):
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
             initial: tuple | None = None, axial_atol: float | None = None, backend: str | None = None,
             use_cache: bool = True) -> SimResult:
    """Integrate the scene's DAE from t0 to t_end, output every output_step (in tau).

    ``axial_atol``: absolute tolerance of the axial amplitudes and their rates instead of
    ``atol`` (e.g. 1e3: no error control on them, so IDAS's BDF steps over the start-up
    ringing of the stiff axial modes and damps it numerically; bending and rigid motion keep
    rtol/atol; see benchmarks/RESULTS.md for what it costs in accuracy).

    ``backend``: "auto" (default, or ``$SYMGEN_BACKEND``), "compiled" or "vm" (see ``DaeRunner``);
    ``use_cache=False``: a compiled library is built for this run only."""
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
        t_setup = time.perf_counter()
        run = DaeRunner(mech, part, rtol, atol, axial_atol, backend, use_cache)
        setup_s = time.perf_counter() - t_setup
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
        beyond = checks.beyond_range(mech, qq)
        if beyond is not None:
            raise SimulationError(t, beyond[1], "check the loads, lumped masses and stiffness (lambda, mu) of that bar")
        ratio, row = checks.singular_ratio(mech, t, qq, part)
        if ratio < POLICY.singular_ratio:
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
            bad = np.nonzero(sv[:, -1] / np.maximum(sv[:, 0], 1e-300) < POLICY.singular_ratio)[0]
            if len(bad):
                stop = int(bad[0]) + 1
        beyond = checks.beyond_range(mech, Q)
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
        size = CHUNK
        while done < n_out_total:
            remaining = n_out_total - done
            k = remaining if remaining <= 2 * size else size
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
            size = min(2 * size, CHUNK_MAX)
    except BaseException as err:
        # any failure while SIGINT/SIGTERM is pending is the interrupt: inside IDAS a RuntimeError,
        # between chunks (numpy converting CasADi's results) also the SystemError CPython makes of a
        # C function that returned with the handler's exception set, or a bare KeyboardInterrupt
        n_rec = min(len(taus), len(outs), len(qs), len(vs), len(lams))
        exc = interrupt.interrupted(err, taus[n_rec - 1] if n_rec else t0)
        if not isinstance(exc, (SimulationError, Interrupted)):
            raise
        failure = str(exc)
    else:
        exc = None
    elapsed = time.perf_counter() - tic
    # an interrupt may land between the appends of one output: keep the outputs recorded whole
    n_rec = min(len(taus), len(outs), len(qs), len(vs), len(lams))
    result = SimResult(tau=np.array(taus[:n_rec]), outputs=np.array(outs[:n_rec]),
                       output_names=list(mech.info.outputs), q=np.array(qs[:n_rec]), v=np.array(vs[:n_rec]),
                       lam=np.array(lams[:n_rec]), closure_max=closure_max,
                       steps=steps, simulate_s=elapsed, partition=part, complete=exc is None, failure=failure,
                       stats={"backend": run.backend, "library": run.library, "setup_s": setup_s})
    if exc is not None:
        exc.partial = result
        raise exc
    return result


def _dae_jacobian(dae: ca.Function, dae_in: list, dae_out: list) -> ca.Function:
    """``jac_dae``: the Jacobian CasADi's ``external`` gives IDAS for a compiled ``dae``. The
    blocks IDAS uses are built by the factory that builds them for the SX oracle of the virtual
    machine, so the compiled library computes them with the same operations in the same order
    (bit-identical Jacobians, hence the same Newton iterates and steps); the others are exact too."""
    fac = dae.factory("jac_blocks", ca.dyn_in(), ["jac:ode:x", "jac:alg:x", "jac:ode:z", "jac:alg:z"])
    blocks = dict(zip(("ode_x", "alg_x", "ode_z", "alg_z"), fac(*dae_in)))
    nominal = [ca.SX.sym(f"out_{k}", e.shape) for k, e in zip(ca.dyn_out(), dae_out)]
    jac, names = [], []
    for ko, e in zip(ca.dyn_out(), dae_out):
        for ki, w in zip(ca.dyn_in(), dae_in):
            jac.append(blocks.get(f"{ko}_{ki}", ca.jacobian(e, w)))
            names.append(f"jac_{ko}_{ki}")
    return ca.Function("jac_dae", dae_in + nominal, jac, ca.dyn_in() + [f"out_{k}" for k in ca.dyn_out()], names)


_noticed: set = set()


def _notice(text: str) -> None:
    """One line on stderr, once per process for the same text."""
    if text not in _noticed:
        _noticed.add(text)
        print(f"symgen: {text}", file=sys.stderr)


def _lost(mech: Mechanism, part: Partition, tau: float, q_last, tau_last: float, cause: str,
          limit: bool = False) -> SimulationError:
    """The error for a step that failed: a singular position of the rigid mechanism when the
    closure Jacobian was already near rank loss at the last good output (or, ``limit``, when
    the driven closure itself lost its solution, which a smooth mechanism does only at a
    singular position), else the solver cause."""
    ratio, row = checks.singular_ratio(mech, tau_last, q_last, part)
    if ratio < POLICY.near_singular_ratio or limit:
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
