"""Explicit and implicit integrators on the reduced (axially eliminated) models (issue 8).

The inextensible models have no axial modes: their fastest motion is the highest kept bending
mode. Are they stiff enough to need an implicit method? Measured on the steel scenes of
``benchmarks/scenes/`` with ``effects.axial = "inextensible"``:

* implicit, variable step, dense output: IDAS (BDF orders 1-5, the compiled model, symgen's
  default path) and the emitted C Radau IIA (order 5, ``--solver c``);
* explicit, variable step, dense output: Dormand-Prince RK45 and DOP853 (SciPy ``solve_ivp``)
  on the ODE of the independent coordinates x = [q_I, v_I]: each right-hand side solves the
  algebraic equations g(t, x, z) = 0 for z (dependent coordinates and rates, accelerations,
  multipliers) by Newton inside one CasADi call (compiled), from the last solution.

Each method at several tolerances; error = max over the outputs of max |y - y_ref| / max |y_ref|
on the output grid against IDAS at rtol 1e-10. Columns: steps, right-hand-side evaluations
(explicit) or residual evaluations (C Radau), CPU s. The explicit methods' CPU is Python-bound
(one Python callback per evaluation); ``est. C s`` prices their evaluations at the cost of one
compiled right-hand side measured in a batched call (no Python in the loop), i.e. what an
explicit integrator written in C would spend on them.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

PROBLEMS = [
    ("slider_crank_steel", ["bodies.rod.transverse_modes=2"]),
    ("four_bar_steel", [f"bodies.{b}.transverse_modes=2" for b in ("crank", "coupler", "rocker")]),
]
INEXT = ['effects.axial="inextensible"']
TURNS = 1.0
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7)
EXPLICIT_RTOLS = (1e-4, 1e-6)  # their steps barely depend on it (stability-bound); Python-bound CPU


def _mech(name: str, over: list[str], rtol: float | None = None):
    from symgen.api import mechanism

    extra = [f"simulation.cycles={TURNS:g}"]
    if rtol is not None:
        extra += [f"simulation.rtol={rtol:g}", f"simulation.atol={rtol * 1e-3:g}"]
    return mechanism(str(HERE / "scenes" / f"{name}.toml"), INEXT + over + extra)


def _err(y: np.ndarray, ref: np.ndarray) -> float:
    peak = np.abs(ref).max(axis=0)
    keep = peak > 1e-12
    return float((np.abs(y[:, keep] - ref[:, keep]).max(axis=0) / peak[keep]).max())


class ExplicitODE:
    """x' = f(t, x) with z(t, x) from Newton on g (one compiled CasADi call per evaluation)."""

    def __init__(self, mech, run) -> None:
        from symgen.numerics.compiled import library

        nx, nz, npar = run.dae.size1_in(1), run.dae.size1_in(2), run.dae.size1_in(3)
        t, x, z, p = ca.SX.sym("t"), ca.SX.sym("x", nx), ca.SX.sym("z", nz), ca.SX.sym("p", npar)
        res = run.dae(t=t, x=x, z=z, p=p)
        ode, alg = res["ode"], res["alg"]
        G = ca.Function("G", [z, t, x, p], [alg])
        rf = ca.rootfinder("rf", "newton", G, {"abstol": 1e-13, "max_iter": 30, "error_on_fail": False})
        tm, xm, zm, pm = ca.MX.sym("t"), ca.MX.sym("x", nx), ca.MX.sym("z", nz), ca.MX.sym("p", npar)
        zs = rf(zm, tm, xm, pm)
        f_ode = ca.Function("f_ode", [t, x, z, p], [ode])
        rhs = ca.Function("rhs", [tm, xm, zm, pm], [f_ode(tm, xm, zs, pm), zs])
        self.rhs = rhs
        try:  # compiled like the rest of the run (Newton loop included)
            ext, _ = library([rhs], mech.info.key, "explicit-rhs " + str(run.part))
            self.rhs = ext["rhs"]
            self.compiled = True
        except Exception as exc:
            print(f"bench_integrators: explicit RHS in the virtual machine ({exc})", file=sys.stderr)
            self.compiled = False
        self.nx, self.nz = nx, nz
        self.n_eval = 0

    def solve(self, run, x0, z0, p, t_end, h, method, rtol, atol):
        from scipy.integrate import solve_ivp

        z_last = [np.asarray(z0, float)]

        def fun(t, x):
            self.n_eval += 1
            xd, z = self.rhs(t, x, z_last[0], p)
            z_last[0] = np.asarray(z).ravel()
            return np.asarray(xd).ravel()

        grid = h * np.arange(int(math.floor(t_end / h + 1e-9)) + 1)
        self.n_eval = 0
        t0 = time.process_time()
        sol = solve_ivp(fun, (0.0, grid[-1]), np.asarray(x0, float), method=method, t_eval=grid, rtol=rtol, atol=atol)
        cpu = time.process_time() - t0
        return sol, cpu, grid

    def outputs(self, run, mech, sol, z0, p):
        """Outputs on the grid: z by Newton from the previous output's, then ``rec``."""
        z = np.asarray(z0, float)
        X = sol.y
        Z = np.zeros((self.nz, X.shape[1]))
        for i, t in enumerate(sol.t):
            _, zz = self.rhs(t, X[:, i], z, p)
            z = np.asarray(zz).ravel()
            Z[:, i] = z
        k = X.shape[1]
        rec = run.rec.map(k)
        _, _, _, O, _, _ = rec(sol.t.reshape(1, -1), X, Z, p)
        return np.asarray(O).T

    def cost_per_eval(self, x0, z0, p, n: int = 2000) -> float:
        """CPU s of one right-hand side in a batched (mapped) call: no Python per evaluation."""
        f = self.rhs.map(n)
        X = np.tile(np.asarray(x0, float).reshape(-1, 1), (1, n))
        Z = np.tile(np.asarray(z0, float).reshape(-1, 1), (1, n))
        T = np.zeros((1, n))
        f(T, X, Z, p)
        t0 = time.process_time()
        f(T, X, Z, p)
        return (time.process_time() - t0) / n


def bench_problem(name: str, over: list[str], repeats: int) -> list[str]:
    from symgen.numerics.csolver import simulate_c
    from symgen.numerics.simulate import DaeRunner, simulate

    ref_mech = _mech(name, over, 1e-10)
    ref = simulate(ref_mech)
    rows = []
    for rtol in RTOLS:
        mech = _mech(name, over, rtol)
        cpu = []
        for _ in range(repeats):
            t0 = time.process_time()
            res = simulate(mech)
            cpu.append(time.process_time() - t0)
        rows.append(
            ("IDAS (BDF), compiled", rtol, _err(res.outputs, ref.outputs), res.steps, "", statistics.median(cpu), "")
        )
        simulate_c(mech)
        runs = [simulate_c(mech) for _ in range(repeats)]
        res = runs[0]
        rows.append(
            (
                "C Radau IIA (`--solver c`)",
                rtol,
                _err(res.outputs, ref.outputs),
                res.steps,
                "",
                statistics.median(r.stats["solve_cpu_s"] for r in runs),
                "",
            )
        )
    mech = _mech(name, over)
    q, v, a, lam, part = mech.initial_state(0.0)
    sim = mech.scene.simulation
    run = DaeRunner(mech, part, 1e-8, 1e-11)
    x0, z0 = run.pack(q, v, a, lam)
    p = np.concatenate([mech.p, [0.0]])
    ode = ExplicitODE(mech, run)
    per = ode.cost_per_eval(x0, z0, p)
    for method in ("RK45", "DOP853"):
        for rtol in EXPLICIT_RTOLS:
            sol, cpu, _ = ode.solve(run, x0, z0, p, sim.t_end, sim.output_step, method, rtol, rtol * 1e-3)
            if sol.status != 0:
                rows.append((f"{method} (explicit)", rtol, math.inf, 0, 0, cpu, ""))
                continue
            evals = ode.n_eval
            out = ode.outputs(run, mech, sol, z0, p)
            steps = int(sol.nfev // (6 if method == "RK45" else 12))
            rows.append((f"{method} (explicit)", rtol, _err(out, ref.outputs), steps, evals, cpu, evals * per))
    lines = [
        f"### {name}, inextensible, {over[0].split('=')[-1]} transverse functions per elastic bar, {TURNS:g} turn",
        "",
        f"Reference: IDAS at rtol 1e-10 ({ref.steps} steps). One compiled explicit right-hand side (Newton "
        f"on the algebraic equations included) costs {1e6 * per:.2f} µs in a batched call.",
        "",
        "| method | rtol | error | steps | RHS evaluations | CPU s | est. C s |",
        "|---|---|---|---|---|---|---|",
    ]
    for m, rtol, err, steps, ev, cpu, est in rows:
        e = "failed" if not math.isfinite(err) else f"{100 * err:.3g} %"
        lines.append(f"| {m} | {rtol:g} | {e} | {steps} | {ev} | {cpu:.3f} | {'' if est == '' else f'{est:.4f}'} |")
    return lines + [""]


def run(repeats: int) -> str:
    out = [
        "## Integrators on the reduced models: explicit vs implicit",
        "",
        "Question of issue 8: on the axially eliminated (inextensible) models, which integrator with dense "
        "output is fastest at equal accuracy? Method and measures in the docstring of "
        f"`benchmarks/bench_integrators.py`; medians of {repeats} for IDAS and C Radau.",
        "",
    ]
    for name, over in PROBLEMS:
        out += bench_problem(name, over, repeats)
    return "\n".join(out)


if __name__ == "__main__":
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 1))
