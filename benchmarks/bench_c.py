"""Benchmark section: the emitted C (symgen emit-c) against CasADi's own C.

1. Time per evaluation of the residual ``res(t, q, v, a, lam, p)`` (and of its Jacobian) in
   the emitted C, against ``Function.generate()`` C of the same CasADi Function, both compiled
   with ``gcc -O2`` and timed in one C harness (interleaved repeats, medians).
2. Compile times of the emitted files and of CasADi's C; emission time (derive excluded).
3. The C driver (Radau IIA) against the Python path (IDAS) over the scene's two crank turns.
4. Dense output and the in-process run (``simulate --solver c``): steps and CPU of the steel
   slider-crank with rows every 1 and every 10 degrees, dense against landing on every output
   (``PREFIX_solver_advance``, what the solver did before); in process (ctypes) against the
   emitted executable in a subprocess.

Times are medians of repeats in one run on this machine (shared, noisy: compare ratios).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

EXAMPLES = ["examples/slider_crank.toml", "examples/four_bar.toml"]
CFLAGS = ["-O2"]

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "{P}.h"
#include "cas_res.h"

static double now(void)
{{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}}

int main(void)
{{
    static double q[{n}], v[{n}], a[{n}], lam[{mm}], p[{npp}], out[{n}], jac[{n} * {nw}];
    static casadi_real w[100000];
    static casadi_int iw[10000];
    const casadi_real *arg[6];
    casadi_real *res[1];
    double t = 0.3, acc = 0.0, t0, best_c = 1e30, best_cas = 1e30, best_j = 1e30;
    long k, r, N = {N};
    casadi_int sz_arg, sz_res, sz_iw, sz_w;
    cas_res_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
    if (sz_w > 100000 || sz_iw > 10000) return 3;
    for (k = 0; k < {n}; ++k) {{ q[k] = 0.1 + 0.01 * k; v[k] = 0.2 - 0.01 * k; a[k] = 0.05 * k; }}
    for (k = 0; k < {mm}; ++k) lam[k] = 0.3 + k;
    for (k = 0; k < {npp}; ++k) p[k] = {P}_parameter_defaults[k] + 0.01;
    arg[0] = &t; arg[1] = q; arg[2] = v; arg[3] = a; arg[4] = lam; arg[5] = p;
    res[0] = out;
    for (r = 0; r < {R}; ++r) {{
        t0 = now();
        for (k = 0; k < N; ++k) {{ q[0] += 1e-12; {P}_res(t, q, v, a, lam, p, out); acc += out[0]; }}
        t0 = (now() - t0) / N; if (t0 < best_c) best_c = t0;
        t0 = now();
        for (k = 0; k < N; ++k) {{ q[0] += 1e-12; cas_res(arg, res, iw, w, 0); acc += out[0]; }}
        t0 = (now() - t0) / N; if (t0 < best_cas) best_cas = t0;
        t0 = now();
        for (k = 0; k < N / 4; ++k) {{ q[0] += 1e-12; {P}_res_jac(t, q, v, a, lam, p, jac); acc += jac[0]; }}
        t0 = (now() - t0) / (N / 4); if (t0 < best_j) best_j = t0;
    }}
    printf("%.6g %.6g %.6g %g\n", best_c * 1e9, best_cas * 1e9, best_j * 1e9, acc);
    return 0;
}}
"""


def _timed(cmd, cwd=None) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=cwd, check=True, capture_output=True, text=True)
    return time.perf_counter() - t0


def _one(path: str, repeats: int) -> dict:
    from symgen.api import mechanism
    from symgen.model.derive import derive
    from symgen.backends.c import c_context, write_tree
    from symgen.backends.c.render import render_files
    from symgen.numerics.simulate import simulate
    from symgen.numerics.start import start_plan

    mech = mechanism(ROOT / path)
    scene = mech.scene
    name = scene.name
    model = derive(scene)
    t0 = time.perf_counter()
    ctx = c_context(scene, model, start_plan(mech), mech.info)
    files = render_files(ctx)
    emit_s = time.perf_counter() - t0
    work = Path(tempfile.mkdtemp(prefix=f"bench-c-{name}-"))
    src = write_tree(files, work / "c")
    # CasADi's own C of the same Function
    import casadi as ca

    f = mech.f["res"]
    sx = [
        ca.SX.sym(k, s)
        for k, s in (("t", 1), ("q", mech.n), ("v", mech.n), ("a", mech.n), ("lam", mech.m), ("p", len(mech.p)))
    ]
    cas = ca.Function("cas_res", sx, [f(*sx)], {"cse": True})
    t0 = time.perf_counter()
    cg = ca.CodeGenerator("cas_res.c", {"with_header": True})
    cg.add(cas)
    cg.generate(str(work) + "/")  # = cas.generate(), written into `work`, not the cwd
    gen_s = time.perf_counter() - t0
    comp = {}
    for key, file in (
        ("model", src / f"{name}.c"),
        ("jac", src / f"{name}_jac.c"),
        ("solver", src / f"{name}_solver.c"),
        ("casadi_res", work / "cas_res.c"),
    ):
        comp[key] = statistics.median(
            _timed(["gcc", *CFLAGS, "-c", str(file), "-o", str(work / (key + ".o")), f"-I{src}", f"-I{work}"])
            for _ in range(repeats)
        )
    (work / "bench.c").write_text(
        HARNESS.format(
            P=name,
            n=mech.n,
            mm=max(mech.m, 1),
            npp=max(len(mech.p), 1),
            nw=3 * mech.n + mech.m,
            N=200000 if mech.n < 10 else 40000,
            R=max(3, repeats),
        )
    )
    subprocess.run(
        [
            "gcc",
            *CFLAGS,
            f"-I{src}",
            f"-I{work}",
            str(work / "bench.c"),
            str(work / "model.o"),
            str(work / "jac.o"),
            str(work / "casadi_res.o"),
            "-o",
            str(work / "bench"),
            "-lm",
        ],
        check=True,
    )
    runs = [
        list(
            map(
                float,
                subprocess.run([str(work / "bench")], capture_output=True, text=True, check=True).stdout.split()[:3],
            )
        )
        for _ in range(repeats)
    ]
    c_ns, cas_ns, jac_ns = (statistics.median(r[i] for r in runs) for i in range(3))
    # driver vs IDAS over the scene's run
    sim_exe = work / "sim"
    subprocess.run(
        [
            "gcc",
            *CFLAGS,
            f"-I{src}",
            str(src / f"{name}.c"),
            str(src / f"{name}_jac.c"),
            str(src / f"{name}_solver.c"),
            str(src / f"{name}_sim.c"),
            "-o",
            str(sim_exe),
            "-lm",
        ],
        check=True,
    )
    c_sim, idas_sim, stats = [], [], ""
    for _ in range(repeats):
        t0 = time.perf_counter()
        proc = subprocess.run([str(sim_exe), "--stats"], capture_output=True, text=True, check=True)
        c_sim.append(time.perf_counter() - t0)
        stats = proc.stderr.strip()
        r = simulate(mech)
        idas_sim.append(r.simulate_s)
    steps = int(stats.split(" steps")[0].split()[-1]) if " steps" in stats else -1
    by = {fn["name"]: fn for fn in ctx["functions"]}
    return {
        "name": name,
        "n": mech.n,
        "res_ops": by["res"]["ops"],
        "jac_ops": by["res_jac"]["ops"],
        "cas_instr": int(cas.n_instructions()),
        "c_ns": c_ns,
        "cas_ns": cas_ns,
        "jac_ns": jac_ns,
        "emit_s": emit_s,
        "gen_s": gen_s,
        "comp": comp,
        "c_sim": statistics.median(c_sim),
        "idas_sim": statistics.median(idas_sim),
        "c_steps": steps,
        "idas_steps": r.steps,
    }


STEEL = "benchmarks/scenes/slider_crank_steel.toml"
DEG = 0.017453292519943295


def _landing(solver, mech, step: float, rtol: float, atol: float) -> tuple[int, float]:
    """Steps and CPU s of the run landing on every output (``PREFIX_solver_advance``), the rows
    from Python through ctypes (about a microsecond a call, 1 % of these runs)."""
    import ctypes
    import math

    import numpy as np

    lib, P = solver.lib, solver.prefix
    init = getattr(lib, f"{P}_solver_init")
    init.argtypes = [
        ctypes.c_void_p,
        ctypes.POINTER(ctypes.c_double),
        ctypes.c_double,
        ctypes.c_double,
        ctypes.c_double,
    ]
    advance = getattr(lib, f"{P}_solver_advance")
    advance.argtypes = [ctypes.c_void_p, ctypes.c_double]
    state = (ctypes.c_double * ((solver.size + 7) // 8))()
    p = np.ascontiguousarray(mech.p, dtype=float)
    n = int(math.floor(mech.scene.simulation.t_end / step + 1e-9))
    cpu = time.process_time()
    rc = init(state, p.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), 0.0, rtol, atol)
    for i in range(1, n + 1):
        rc = rc or advance(state, i * step)
    cpu = time.process_time() - cpu
    counts = (ctypes.c_double * 10)()
    solver.counters(state, counts)
    assert rc == 0, rc
    return int(counts[1]), cpu


def _dense(repeats: int) -> list[str]:
    from symgen.api import mechanism
    from symgen.backends.c import c_context, write_tree
    from symgen.backends.c.render import render_files
    from symgen.model.derive import derive
    from symgen.numerics import csolver
    from symgen.numerics.start import start_plan

    out = [
        "### Dense output and the in-process run",
        "",
        f"`{STEEL}` (undamped, from rest), two crank turns at rtol = 100 atol as given; rows every 1 and "
        "every 10 degrees. Dense: `--solver c` (steps set by the error control, rows from the collocation "
        "polynomial); landing: the same solver stopping on every output time (`PREFIX_solver_advance`, the "
        f"C solver before dense output). CPU s: medians of {repeats}, the solver's own (in process).",
        "",
        "| rtol | dense steps, 1 deg | dense steps, 10 deg | dense CPU s, 1 deg / 10 deg | landing steps, 1 deg "
        "| landing steps, 10 deg | landing CPU s, 1 deg / 10 deg |",
        "|---|---|---|---|---|---|---|",
    ]
    for rtol in (1e-3, 1e-4, 1e-6):
        mech = mechanism(ROOT / STEEL, [f"simulation.rtol={rtol!r}", f"simulation.atol={rtol / 100!r}"])
        solver, _ = csolver.solver(mech)
        cells = []
        for mode in ("dense", "landing"):
            steps, cpus = [], []
            for step in (DEG, 10 * DEG):
                runs = []
                for _ in range(repeats):
                    if mode == "dense":
                        res = csolver.simulate_c(mech, output_step=step)
                        runs.append((res.steps, float(res.stats["solve_cpu_s"])))
                    else:
                        runs.append(_landing(solver, mech, step, rtol, rtol / 100))
                steps.append(runs[0][0])
                cpus.append(statistics.median(r[1] for r in runs))
            cells += [str(steps[0]), str(steps[1]), f"{cpus[0]:.4f} / {cpus[1]:.4f}"]
        out.append(f"| {rtol:g} | " + " | ".join(cells) + " |")
    # in process against the executable in a subprocess (whole call, wall s)
    mech = mechanism(ROOT / STEEL, ["simulation.rtol=1e-4", "simulation.atol=1e-6"])
    name = mech.scene.name
    work = Path(tempfile.mkdtemp(prefix="bench-c-dense-"))
    src = write_tree(render_files(c_context(mech.scene, derive(mech.scene), start_plan(mech), mech.info)), work / "c")
    exe = work / "sim"
    subprocess.run(
        [
            "gcc",
            *CFLAGS,
            f"-I{src}",
            *(str(src / f"{name}{x}.c") for x in ("", "_jac", "_solver", "_sim")),
            "-o",
            str(exe),
            "-lm",
        ],
        check=True,
    )
    csolver.simulate_c(mech)  # loaded
    inproc, sub = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        csolver.simulate_c(mech)
        inproc.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        subprocess.run([str(exe), "--rtol", "1e-4", "--atol", "1e-6"], capture_output=True, check=True)
        sub.append(time.perf_counter() - t0)
    out += [
        "",
        "The same run (rtol 1e-4, rows every degree) in process (`simulate_c`: ctypes calls of 400 steps, "
        "the rows with the states into NumPy) against the emitted executable (`PREFIX_sim`, `gcc -O2`) "
        "in a subprocess, rows printed as CSV (wall s, medians):",
        "",
        "| in process | subprocess |",
        "|---|---|",
        f"| {statistics.median(inproc):.4f} | {statistics.median(sub):.4f} |",
        "",
    ]
    return out


def run(repeats: int) -> str:
    rows = [_one(p, repeats) for p in EXAMPLES]
    out = [
        "## Emitted C vs CasADi's generated C",
        "",
        "Residual `res(t, q, v, a, lam, p)` of each example: the emitted C (SymPy CSE) against "
        "`casadi.Function.generate()` of the same Function (SX, `cse`), both `gcc -O2`, one harness, "
        "best of interleaved repeats (ns per call).",
        "",
        "| scene | n | emitted res ops | CasADi instructions | emitted C ns | CasADi C ns | ratio | "
        "emitted res_jac ns |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        out.append(
            f"| {r['name']} | {r['n']} | {r['res_ops']} | {r['cas_instr']} | {r['c_ns']:.0f} | "
            f"{r['cas_ns']:.0f} | {r['c_ns'] / r['cas_ns']:.2f}x | {r['jac_ns']:.0f} |"
        )
    out += [
        "",
        "Compile times (`gcc -O2 -c`, s) and generation times (s):",
        "",
        "| scene | emit-c (Python, derive excluded) | model .c | solver .c | CasADi generate | CasADi res .c |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        c = r["comp"]
        out.append(
            f"| {r['name']} | {r['emit_s']:.2f} | {c['model']:.2f} | {c['solver']:.2f} | {r['gen_s']:.3f} | "
            f"{c['casadi_res']:.2f} |"
        )
    out += [
        "",
        "The scene's run (two crank turns at the scene's tolerances): C driver (Radau IIA, process "
        "wall time incl. start-up) vs the Python path (IDAS, integration time):",
        "",
        "| scene | C driver s | C steps | IDAS s | IDAS steps |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        out.append(f"| {r['name']} | {r['c_sim']:.2f} | {r['c_steps']} | {r['idas_sim']:.2f} | {r['idas_steps']} |")
    out.append("")
    out += _dense(repeats)
    return "\n".join(out)


if __name__ == "__main__":
    print(run(3))
