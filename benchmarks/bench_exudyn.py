"""symgen against Exudyn on steel mechanisms, side by side in one run (issue 8, "Deliver 3").

Problems (``benchmarks/scenes/``, SI, steel E = 210 GPa, 7850 kg/m^3, started on the rigid
mechanism's assembly and velocities, undeformed):

* ``slider_crank_steel``: rigid crank 100 mm, elastic rod 200 mm (10 x 4 mm), 25 rad/s:
  rod lambda ~ 1.1e6, mu ~ 36; output: the rod's midspan deflection from its chord;
* ``four_bar_steel``: crank 50 mm clamped to the shaft, coupler 150 mm, rocker 125 mm, all three
  elastic, 30 rad/s: lambda ~ 1.2e7 / 1.3e6 / 1.9e6; outputs: the crank's tip deflection in the
  clamped frame, the coupler's and the rocker's midspan deflections from their chords.

Both scenes have light Kelvin-Voigt material damping (``effects.damping = 1e-4``, the same time
constant in Exudyn's ``bendingDamping``/``axialDamping``; the scene files say why): undamped, the
ringing left by the undeformed start (the rod's axial modes, the clamped crank's bending)
keeps the fine solutions apart (slider-crank: Exudyn 32 elements at 11520, 23040, 46080
steps/turn within ~0.3 % of each other, not better; four-bar: 17 % between 11520 and 23040
steps/turn, symgen 2, 4, 6 functions 50-55 % from it).

Exudyn (``benchmarks/exudyn_models.py``): ANCF cable elements, ``SolveDynamic`` (generalized-
alpha, spectral radius 0.9, fixed step). symgen: the scene through the public API with
``bodies.*.transverse_modes``, ``simulation.rtol``/``atol`` and, per configuration, either the
scene's effects as they are (today's default axial treatment, whatever a release makes it) or
``effects.axial = "inextensible"``; each configuration both through IDAS (``symgen simulate``, the
compiled model) and through the emitted C Radau IIA solver (``symgen simulate --solver c``).

Error of every run, both tools: ``max over outputs of max_t |y - y_ref| / max_t |y_ref|`` over the
whole run, on the common output grid (one degree of crank), against ONE reference: Exudyn with a
fine mesh and small steps, whose convergence (elements x steps) is tabulated; a fine symgen
model is compared with it as a cross-check. For each tool and target (1 %, 0.1 %) the cheapest
configuration is picked whose error is within the target and whose next refinement (2x steps /
10x tighter rtol) is within it too (no lucky cancellations). Where the two converged solutions
differ by more than 0.1 % (the formulations differ: geometrically exact ANCF cable vs assumed
modes), the 0.1 % pick is also made with each tool against its own converged solution (Exudyn:
the reference; symgen: its fine model of the cross-check).

Times (medians of repeats in this run): integration CPU (Exudyn ``SolveDynamic`` after
``Assemble``; symgen ``simulate`` on a model derived before, its one-off derivation cached on
disk) and whole process: CPU (user + sys) of a fresh ``python benchmarks/exudyn_models.py ...``
and of a fresh ``python -m symgen.cli simulate ... -o out.csv`` with the model cache warm.
"""

from __future__ import annotations

import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Callable

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

TARGETS = (1e-2, 1e-3)
TARGET_SPEEDUP = {"slider_crank_steel": (30.0, 10.0), "four_bar_steel": (10.0, None)}  # integration, process
INEXTENSIBLE = 'effects.axial="inextensible"'
SLOW_RUN_S = 20.0  # a symgen configuration slower than this is run once, tighter rtols skipped


# --------------------------------------------------------------------------- error measure
def on_grid(t: np.ndarray, dt: float, n: int) -> np.ndarray:
    """Indices of the samples of t at the grid points 0, dt, ..., (n - 1) dt (to 1e-6 dt; samples
    between them are skipped); every grid point must be present: no interpolation between
    samples of a signal that rings."""
    t = np.asarray(t, float)
    k = np.rint(t / dt).astype(int)
    ok = (np.abs(t - k * dt) <= 1e-6 * dt) & (k >= 0) & (k < n)
    idx = np.full(n, -1)
    idx[k[ok]] = np.nonzero(ok)[0]
    if (idx < 0).any():
        raise ValueError(f"{int((idx < 0).sum())} of {n} grid points missing (step {dt:g})")
    return idx


def peak_error(y: np.ndarray, ref: np.ndarray) -> float:
    """max |y - ref| / max |ref| (inf for a non-finite run)."""
    y, ref = np.asarray(y, float), np.asarray(ref, float)
    if y.shape != ref.shape:
        raise ValueError(f"shapes differ: {y.shape} vs {ref.shape}")
    if not np.all(np.isfinite(y)):
        return math.inf
    scale = float(np.abs(ref).max())
    return float(np.abs(y - ref).max() / scale) if scale > 0 else float(np.abs(y - ref).max())


def run_error(t: np.ndarray, outs: dict, ref: dict, dt: float, names) -> float:
    """The largest ``peak_error`` over the outputs ``names`` of a run (t, {name: y}) against the
    reference ({name: y_ref} on the grid 0, dt, ...)."""
    n = len(ref[names[0]])
    idx = on_grid(t, dt, n)
    return max(peak_error(np.asarray(outs[k])[idx], ref[k]) for k in names)


def cheapest(rows: list[dict], target: float, key: str = "error") -> dict | None:
    """The cheapest row within ``target`` (``row[key]``) whose next refinement (row["finer"]), if
    run, is too."""
    by = {r["id"]: r for r in rows}
    ok = [r for r in rows if r[key] <= target and (r["finer"] not in by or by[r["finer"]][key] <= target)]
    return min(ok, key=lambda r: r["cpu"]) if ok else None


# --------------------------------------------------------------------------- problems
@dataclass
class Problem:
    name: str
    outputs: tuple
    bars: tuple  # elastic bars (their transverse_modes are set)
    exudyn: Callable
    elements: tuple  # Exudyn meshes (per bar)
    steps: tuple  # Exudyn steps per turn (multiples of 360: the output grid)
    reference: tuple  # Exudyn (elements, steps per turn) of the reference
    modes: tuple  # symgen transverse functions per bar
    rtols: tuple
    default_modes: tuple = (2, 3)  # with the scene's own (default) axial treatment
    default_rtols: tuple = (1e-4, 1e-5, 1e-6)
    check: tuple = ("inextensible", 6, 1e-9)  # symgen's own converged model: the cross-check
    turns: float = 2.0
    max_work: int = 10**9  # Exudyn configurations up to elements x steps/turn (besides the reference)

    @property
    def scene(self) -> str:
        return str(HERE / "scenes" / f"{self.name}.toml")


def problems(quick: bool) -> list[Problem]:
    from exudyn_models import four_bar, slider_crank

    sc_out, fb_out = ("rod_mid",), ("crank_tip", "coupler_mid", "rocker_mid")
    fb_bars = ("crank", "coupler", "rocker")
    if quick:
        return [
            Problem(
                "slider_crank_steel",
                sc_out,
                ("rod",),
                slider_crank,
                (4, 8),
                (720, 1440, 2880),
                (16, 11520),
                (1, 2),
                (1e-4, 1e-5, 1e-6),
                (2,),
                (1e-4, 1e-5),
                ("inextensible", 4, 1e-8),
                turns=1.0,
                max_work=8 * 2880,
            ),
            Problem(
                "four_bar_steel",
                fb_out,
                fb_bars,
                four_bar,
                (4, 8),
                (1440, 2880, 5760),
                (16, 11520),
                (1, 2),
                (1e-4, 1e-5, 1e-6),
                (1, 2),
                (1e-4, 1e-5),
                ("default", 3, 1e-8),
                turns=0.5,
                max_work=8 * 5760,
            ),
        ]
    return [
        Problem(
            "slider_crank_steel",
            sc_out,
            ("rod",),
            slider_crank,
            (2, 4, 8, 16, 32),
            (360, 720, 1440, 2880, 5760, 11520, 23040),
            (32, 23040),
            (1, 2, 3, 4),
            (1e-3, 1e-4, 1e-5, 1e-6, 1e-7),
            (2, 3),
            (1e-3, 1e-4, 1e-5, 1e-6),
            ("inextensible", 6, 1e-9),
            turns=2.0,
            max_work=32 * 23040,
        ),
        Problem(
            "four_bar_steel",
            fb_out,
            fb_bars,
            four_bar,
            (4, 8, 16, 32),
            (1440, 2880, 5760, 11520, 23040),
            (32, 23040),
            (1, 2, 3, 4),
            (1e-3, 1e-4, 1e-5, 1e-6),
            (1, 2, 3),
            (1e-3, 1e-4, 1e-5, 1e-6),
            ("default", 4, 1e-8),
            turns=1.0,
            max_work=16 * 23040,
        ),
    ]


def output_step(p: Problem) -> float:
    """The scene's output step in seconds (the common grid)."""
    from symgen.scene import load_scene

    scene = load_scene(p.scene)
    return scene.simulation.output_step / _omega(p)


def _omega(p: Problem) -> float:
    import tomllib

    with open(p.scene, "rb") as f:
        return float(tomllib.load(f)["scene"]["omega"])


# --------------------------------------------------------------------------- symgen
def symgen_overrides(p: Problem, axial: str, nt: int, rtol: float) -> list[str]:
    over = [] if axial == "default" else [INEXTENSIBLE]
    over += [f"bodies.{b}.transverse_modes={nt}" for b in p.bars]
    return over + [f"simulation.rtol={rtol:g}", f"simulation.atol={rtol * 1e-3:g}", f"simulation.cycles={p.turns:g}"]


SOLVERS = ("idas", "c")  # symgen simulate (IDAS, compiled model) and symgen simulate --solver c


def symgen_run(p: Problem, overrides: list[str], solver: str = "idas"):
    """(t s, {output: SI values}, integration CPU s, steps); see ``symgen_timed``."""
    cols, cpu, steps = symgen_timed(p.scene, overrides, solver)
    return cols["t"], cols, cpu, steps


def symgen_timed(scene, overrides: list[str], solver: str = "idas"):
    """({"t" and every output: SI values}, integration CPU s, steps) of a scene; the model derived
    (or loaded from the cache) before the clock starts. IDAS: CPU of ``simulate`` in this process
    (set-up, consistent start, integration, outputs). ``--solver c``: the emitted C solver's own
    CPU time of ``init`` + ``advance`` (its ``--stats``; the executable is built and cached before)."""
    from symgen.api import mechanism, results_table
    from symgen.numerics.simulate import simulate

    mech = mechanism(scene, overrides)
    if solver == "c":
        from symgen.numerics.csolver import simulate_c

        res = simulate_c(mech)
        cpu = res.stats["solve_cpu_s"]
    else:
        t0 = time.process_time()
        res = simulate(mech)
        cpu = time.process_time() - t0
    if not res.complete:
        raise RuntimeError(res.failure or "incomplete run")
    return results_table(res, mech.scene), cpu, res.steps


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def process_time(cmd: list[str]) -> tuple[float, float]:
    """(CPU s user + sys, wall s) of a fresh process running ``cmd`` (must succeed). Python may
    write and use bytecode caches, as after a ``pip install`` (``compile_sources`` compiled
    symgen's): a machine-wide PYTHONDONTWRITEBYTECODE would otherwise make every symgen process
    compile its sources again (~0.06 s), which no installed copy does."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    c0, w0 = _child_cpu(), time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return _child_cpu() - c0, time.perf_counter() - w0


def compile_sources() -> None:
    """Byte-compile symgen (and this folder) once, as pip does on install."""
    import compileall

    for folder in (ROOT / "symgen", HERE):
        compileall.compile_dir(str(folder), quiet=1)


# --------------------------------------------------------------------------- one problem
def bench_problem(p: Problem, repeats: int) -> dict:
    dt = output_step(p)
    n = int(round(p.turns * 360)) + 1
    ne_ref, spt_ref = p.reference
    t, ref_out, ref_cpu = p.exudyn(ne_ref, spt_ref, p.turns)
    idx = on_grid(t, dt, n)
    ref = {k: np.asarray(ref_out[k])[idx] for k in p.outputs}
    peaks = {k: float(np.abs(v).max()) for k, v in ref.items()}

    ex_rows = []
    for ne in p.elements:
        for spt in p.steps:
            if ne * spt > p.max_work and (ne, spt) != p.reference:
                continue
            row = {
                "id": (ne, spt),
                "finer": (ne, 2 * spt),
                "ne": ne,
                "spt": spt,
                "config": f"{ne} elements/bar, {spt} steps/turn",
            }
            try:
                if (ne, spt) == p.reference:
                    runs = [(t, ref_out, ref_cpu)]
                else:
                    runs = [p.exudyn(ne, spt, p.turns)]
                if runs[0][2] < SLOW_RUN_S / 10:  # time the cheap ones again (the picks are among them)
                    runs += [p.exudyn(ne, spt, p.turns) for _ in range(repeats - 1)]
                per = {k: peak_error(np.asarray(runs[0][1][k])[on_grid(runs[0][0], dt, n)], ref[k]) for k in p.outputs}
            except Exception as err:
                row.update(
                    cpu=math.inf, error=math.inf, own=math.inf, steps=0, per={}, failed=str(err).splitlines()[0][:90]
                )
                ex_rows.append(row)
                continue
            ex_rows.append(
                {
                    **row,
                    "steps": len(runs[0][0]) - 1,  # sensors write every step (adaptive halvings too)
                    "config": f"{ne} elements/bar, {spt} steps/turn",
                    "per": per,
                    "error": max(per.values()),
                    "own": max(per.values()),
                    "cpu": statistics.median(r[2] for r in runs),
                }
            )

    # symgen's own converged model, cross-checked against the Exudyn reference
    cax, cnt, crtol = p.check
    try:
        tt, cols, ccpu, csteps = symgen_run(p, symgen_overrides(p, cax, cnt, crtol))
        cidx = on_grid(tt, dt, n)
        own_ref = {k: np.asarray(cols[k])[cidx] for k in p.outputs}
        check = {k: peak_error(own_ref[k], ref[k]) for k in p.outputs}
    except Exception as err:
        own_ref, check, ccpu, csteps = None, {"failed": str(err)[:90]}, math.nan, 0

    sg_rows = []
    configs = [("inextensible", nt, rtol, sv) for sv in SOLVERS for nt in p.modes for rtol in p.rtols]
    configs += [("default", nt, rtol, sv) for sv in SOLVERS for nt in p.default_modes for rtol in p.default_rtols]
    slow: set = set()
    for axial, nt, rtol, solver in configs:
        label = f"{'inextensible' if axial != 'default' else 'scene default axial'}, {nt} transverse, rtol {rtol:g}" + (
            ", --solver c" if solver == "c" else ""
        )
        row = {
            "id": (axial, nt, rtol, solver),
            "finer": (axial, nt, rtol / 10, solver),
            "config": label,
            "axial": axial,
            "nt": nt,
            "rtol": rtol,
            "solver": solver,
        }
        if (axial, nt, solver) in slow:
            row.update(
                cpu=math.inf,
                error=math.inf,
                own=math.inf,
                steps=0,
                failed=f"not run: a looser rtol took > {SLOW_RUN_S:g} s",
            )
            sg_rows.append(row)
            continue
        over = symgen_overrides(p, axial, nt, rtol)
        try:
            runs = [symgen_run(p, over, solver)]
            if runs[0][2] > SLOW_RUN_S:
                slow.add((axial, nt, solver))
            else:
                runs += [symgen_run(p, over, solver) for _ in range(repeats - 1)]
        except Exception as err:
            row.update(cpu=math.inf, error=math.inf, own=math.inf, steps=0, failed=str(err).splitlines()[0][:90])
        else:
            tt, cols, _, steps = runs[0]
            row["per"] = {k: peak_error(np.asarray(cols[k])[on_grid(tt, dt, n)], ref[k]) for k in p.outputs}
            row.update(
                cpu=statistics.median(r[2] for r in runs),
                steps=steps,
                error=max(row["per"].values()),
                repeats=len(runs),
            )
            row["own"] = (
                max(peak_error(np.asarray(cols[k])[on_grid(tt, dt, n)], own_ref[k]) for k in p.outputs)
                if own_ref is not None
                else math.inf
            )
        sg_rows.append(row)

    # whole process, at the 1 % picks (the model cache is warm: every configuration ran above)
    procs = {}
    for target, solver in ((t_, sv) for t_ in TARGETS for sv in SOLVERS):
        e, s_ = cheapest(ex_rows, target), cheapest(_solver_rows(sg_rows, solver), target)
        if not (e and s_):
            continue
        out_csv = Path(tempfile.mkdtemp(prefix="symgen-bench-")) / "out.csv"
        ex_cmd = [sys.executable, str(HERE / "exudyn_models.py"), p.name, str(e["ne"]), str(e["spt"]), f"{p.turns:g}"]
        sg_cmd = [sys.executable, "-m", "symgen.cli", "simulate", p.scene, "-o", str(out_csv)]
        for o in symgen_overrides(p, s_["axial"], s_["nt"], s_["rtol"]):
            sg_cmd += ["--set", o]
        if solver == "c":
            sg_cmd += ["--solver", "c"]
        process_time(sg_cmd)  # warm the cache (and the OS file cache)
        ex_t = [process_time(ex_cmd) for _ in range(repeats)]
        sg_t = [process_time(sg_cmd) for _ in range(repeats)]
        procs[(target, solver)] = {
            "exudyn": statistics.median(c for c, _ in ex_t),
            "symgen": statistics.median(c for c, _ in sg_t),
            "exudyn_wall": statistics.median(w for _, w in ex_t),
            "symgen_wall": statistics.median(w for _, w in sg_t),
        }
        for f in out_csv.parent.iterdir():
            f.unlink()
        out_csv.parent.rmdir()
    # what a symgen run costs besides its steps: the same configuration over one output step
    why = {}
    s1 = cheapest(_solver_rows(sg_rows, "idas"), 1e-2)
    if s1:
        from symgen.api import mechanism
        from symgen.numerics.simulate import simulate

        mech = mechanism(p.scene, symgen_overrides(p, s1["axial"], s1["nt"], s1["rtol"]))
        fixed = []
        for _ in range(max(3, repeats)):
            t0 = time.process_time()
            simulate(mech, t_end=dt * _omega(p))
            fixed.append(time.process_time() - t0)
        why["fixed"] = statistics.median(fixed)
        why["imports"] = {
            tool: statistics.median(process_time([sys.executable, "-c", f"import {mod}"])[0] for _ in range(repeats))
            for tool, mod in (("exudyn", "exudyn"), ("symgen", "symgen.cli"))
        }
    return {
        "problem": p,
        "ref_cpu": ref_cpu,
        "why": why,
        "peaks": peaks,
        "ex": ex_rows,
        "sg": sg_rows,
        "check": check,
        "check_cpu": ccpu,
        "check_steps": csteps,
        "procs": procs,
    }


def _solver_rows(rows: list[dict], solver: str) -> list[dict]:
    return [r for r in rows if r.get("solver", "idas") == solver]


# --------------------------------------------------------------------------- report
def _pct(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{100 * x:.3g} %"


def report(r: dict, repeats: int) -> list[str]:
    p: Problem = r["problem"]
    ex, sg = r["ex"], r["sg"]
    ne_ref, spt_ref = p.reference
    out = [
        f"### {p.name} ({p.turns:g} turns; outputs {', '.join(p.outputs)})",
        "",
        "Reference: Exudyn, "
        f"{ne_ref} elements/bar, {spt_ref} steps/turn ({r['ref_cpu']:.1f} s); peaks "
        + ", ".join(f"{k} {v:.4g} m" for k, v in r["peaks"].items())
        + ".",
        "",
    ]
    cax, cnt, crtol = p.check
    cname = "inextensible" if cax == "inextensible" else "scene default axial"
    if "failed" in r["check"]:
        out.append(
            f"Cross-check: symgen {cname}, {cnt} transverse/bar at rtol {crtol:g} failed: {r['check']['failed']}"
        )
    else:
        out.append(
            f"Cross-check: symgen's own converged model ({cname}, {cnt} transverse functions/bar, rtol {crtol:g}, "
            f"{r['check_steps']} IDAS steps, {r['check_cpu']:.2f} s) differs from the reference by "
            + ", ".join(f"{k} {_pct(v)}" for k, v in r["check"].items())
            + "."
        )
    # convergence table of Exudyn
    out += [
        "",
        "Exudyn's convergence (error against the reference, max over the outputs):",
        "",
        "| elements/bar \\ steps/turn | " + " | ".join(str(s) for s in p.steps) + " |",
        "|---|" + "---|" * len(p.steps),
    ]
    by = {r_["id"]: r_ for r_ in ex if "failed" not in r_}
    for ne in p.elements:
        out.append(
            f"| {ne} | " + " | ".join(_pct(by[(ne, s)]["error"]) if (ne, s) in by else "" for s in p.steps) + " |"
        )
    # the picks
    tgt_int, tgt_proc = TARGET_SPEEDUP.get(p.name, (None, None))
    out += [
        "",
        "| target | Exudyn: cheapest | error | CPU s | symgen: cheapest | error | CPU s | steps | "
        "integration Exudyn/symgen | whole process Exudyn/symgen (CPU s) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for target, key, solver in (
        (t_, k_, sv) for t_, k_ in ((TARGETS[0], "error"), (TARGETS[1], "error"), (TARGETS[1], "own")) for sv in SOLVERS
    ):
        e, s_ = cheapest(ex, target, key), cheapest(_solver_rows(sg, solver), target, key)
        ratio = f"**{e['cpu'] / s_['cpu']:.2f}x**" if e and s_ else "—"
        pr = r["procs"].get((target, solver)) if key == "error" else None
        pcol = f"**{pr['exudyn'] / pr['symgen']:.2f}x** ({pr['exudyn']:.2f} / {pr['symgen']:.2f})" if pr else "—"
        ecol = f"{e['config']} | {_pct(e[key])} | {e['cpu']:.3f}" if e else "none reached it | | "
        scol = f"{s_['config']} | {_pct(s_[key])} | {s_['cpu']:.3f} | {s_['steps']}" if s_ else "none reached it | | | "
        against = "" if key == "error" else " (each tool against its own converged solution)"
        out.append(f"| {100 * target:g} %{against} | {ecol} | {scol} | {ratio} | {pcol} |")
    e1 = cheapest(ex, 1e-2)
    if tgt_int and e1:
        out.append("")
    for solver in SOLVERS:
        s1 = cheapest(_solver_rows(sg, solver), 1e-2)
        if not (tgt_int and e1 and s1):
            continue
        how = "symgen simulate" + (" --solver c" if solver == "c" else " (IDAS)")
        got = e1["cpu"] / s1["cpu"]
        verdict = "met" if got >= tgt_int else f"**not met**: {tgt_int / got:.1f}x short"
        out += [f"Target at 1 %, {how}: >= {tgt_int:g}x Exudyn's integration CPU: {got:.2f}x, {verdict}."]
        pr = r["procs"].get((1e-2, solver))
        if tgt_proc and pr:
            gp = pr["exudyn"] / pr["symgen"]
            verdict = "met" if gp >= tgt_proc else f"**not met**: {tgt_proc / gp:.1f}x short"
            out.append(
                f"Target at 1 %, {how}: whole process >= {tgt_proc:g}x: {gp:.2f}x, {verdict} "
                f"(wall s: Exudyn {pr['exudyn_wall']:.2f}, symgen {pr['symgen_wall']:.2f})."
            )
        out.append("")
    why = r["why"]
    s1 = cheapest(_solver_rows(sg, "idas"), 1e-2)
    if e1 and s1 and why:
        per_ex = e1["cpu"] / max(e1["steps"], 1)
        per_sg = (s1["cpu"] - why["fixed"]) / max(s1["steps"], 1)
        imp = why["imports"]
        out += [
            "",
            f"Where the time goes at 1 %: Exudyn {e1['steps']} steps x {1e6 * per_ex:.1f} µs; symgen "
            f"{s1['steps']} IDAS steps x {1e6 * per_sg:.1f} µs + {why['fixed']:.3f} s per run (the same "
            f"configuration over one output step: integrator set-up, consistent start, outputs; "
            f"{100 * why['fixed'] / s1['cpu']:.0f} % of its integration CPU). Steps: symgen/Exudyn "
            f"{s1['steps'] / max(e1['steps'], 1):.2f}; cost per step symgen/Exudyn {per_sg / per_ex:.2f}. "
            f"Whole process: importing alone costs {imp['exudyn']:.2f} s (`import exudyn`) and "
            f"{imp['symgen']:.2f} s (`import symgen.cli`) CPU.",
        ]
    out += [
        "",
        "<details><summary>every configuration</summary>",
        "",
        "| tool | configuration | CPU s | steps | error | error vs own converged | " + " | ".join(p.outputs) + " |",
        "|---|---|---|---|---|---|" + "---|" * len(p.outputs),
    ]
    for tool, rows in (("Exudyn", ex), ("symgen", sg)):
        for row in rows:
            if "failed" in row:
                out.append(f"| {tool} | {row['config']} | | | {row['failed']} | |" + " |" * len(p.outputs))
    for row in ex:
        if "failed" in row:
            continue
        out.append(
            f"| Exudyn | {row['config']} | {row['cpu']:.3f} | {row['steps']} | {_pct(row['error'])} | (same) | "
            + " | ".join(_pct(row["per"][k]) for k in p.outputs)
            + " |"
        )
    for row in sg:
        if "failed" in row:
            continue
        note = "" if row.get("repeats", repeats) == repeats else f" (1 run: > {SLOW_RUN_S:g} s)"
        out.append(
            f"| symgen | {row['config']} | {row['cpu']:.3f}{note} | {row['steps']} | {_pct(row['error'])} | "
            f"{_pct(row['own'])} | " + " | ".join(_pct(row["per"][k]) for k in p.outputs) + " |"
        )
    out += ["", "</details>", ""]
    return out


def run(repeats: int, quick: bool = False) -> str:
    try:
        import exudyn
    except ImportError:
        return (
            "## symgen vs Exudyn on steel mechanisms\n\nExudyn is not installed (optional: "
            "`python -m pip install exudyn`, the `bench` extra); section skipped.\n"
        )
    import symgen

    out = [
        "## symgen vs Exudyn on steel mechanisms",
        "",
        f"Exudyn {exudyn.__version__} (ANCF cable elements, `SolveDynamic`: generalized-alpha, spectral radius 0.9, "
        f"fixed step) vs symgen {getattr(symgen, '__version__', '')} (IDAS on the compiled model, and the emitted C "
        "Radau IIA solver of `--solver c`; configurations: the scene's default effects, and "
        '`effects.axial="inextensible"`). Scenes `benchmarks/scenes/*_steel.toml`; problem, error '
        "measure and timing rules in the docstring of `benchmarks/bench_exudyn.py`. Error: max over the outputs of "
        "max |y − y_ref| / max |y_ref| over the whole run on a one-degree grid, against one Exudyn fine-mesh, "
        "small-step reference. A configuration counts only when its next refinement (2x steps, 10x tighter rtol) "
        "is within the target too. CPU s: integration (Exudyn `SolveDynamic`, symgen `simulate` on a cached "
        "model; for `--solver c` the C solver's own CPU time) and whole process (a fresh Python process per tool: `python benchmarks/exudyn_models.py ...`, "
        f"`python -m symgen.cli simulate ...` with the model cache warm), medians of {repeats}"
        + (" (--quick: one turn, small grids)" if quick else "")
        + ".",
        "",
    ]
    compile_sources()
    for p in problems(quick):
        out += report(bench_problem(p, repeats), repeats)
    return "\n".join(out)


if __name__ == "__main__":
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 1, "--quick" in sys.argv))
