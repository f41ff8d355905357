"""symgen against Exudyn on issue 20's steel slider-crank, side by side in one run (issue 20, item 6).

Problems: the validation scenes of ``benchmarks/validation/`` (benchmarks/validation/README.md), each
with its Exudyn reference converged in mesh and step (``ref/<scene>.csv.gz``, made by
``python benchmarks/bench_validation.py reference <scene>`` with ``benchmarks/exudyn_scene.py``):

* ``slider_crank_steel_rest``: issue 20's steel slider-crank: the paper's geometry, rod E = 210 GPa,
  7850 kg/m^3, 10 x 20 mm (lambda = 2.675e7, mu = 222.9 at 1 rad/s), undamped, spun up from rest
  over 2 s, 4 s; output the rod's midspan deflection (its reference converged to ~2e-4 of peak);
  targets 1 % and 0.1 % of peak;
* ``slider_crank_paper``: the paper's slider-crank (section 6.1) in SI; target 1 %.

(This section replaces issue 8's "symgen vs Exudyn on steel mechanisms": other scenes, damped and
started at speed, stated mode counts, targets of that issue and no floor.)

Error of every run, both tools: max over the run of |y - y_ref| / max |y_ref| on the reference's
output grid (the rod's midspan deflection from its chord), against the committed reference.

Exudyn: ``exudyn_scene.run`` (ANCF cable elements, ``SolveDynamic``: generalized-alpha, spectral
radius 0.9, fixed step; Newton's tolerance as for the reference, ``bench_validation.NEWTON_RTOL``)
on a grid of elements per elastic bar x steps per output step; its cheapest configuration within a
target whose next refinement (twice the steps) is within it too, or was not run (after a run past
``EX_MAX_S`` of CPU a mesh's finer steps are not run: the table says "not run").

symgen: the scene as a user runs it: ``symgen simulate SCENE -o out.csv --set
simulation.accuracy=TARGET`` (no mode counts: chosen from the accuracy; the tolerances each solver derives from the accuracy:
the scene's stated rtol and atol left out, :func:`user_scene`; strain
"auto" with its remembered decision, the default error estimate ``rerun``), the same with
``--estimate off`` (the run alone), and both with ``--solver c`` (the emitted C Radau IIA solver).

Times, CPU (user + sys), medians of ``repeats``, the tools interleaved repeat by repeat, models and
C solvers cached (warm) before the clock starts:

* integration: Exudyn ``SolveDynamic`` (after ``Assemble``); symgen, in one process on the loaded
  mechanism, ``simulate`` / ``simulate_c`` (set-up, consistent start, integration, outputs) plus,
  with the estimate, ``results.error_estimate`` (its second, richer run; after a C run by the
  richer model's C solver, built before the clock starts);
* whole process: ``resource.getrusage(RUSAGE_CHILDREN)`` of a fresh process: symgen the command
  above; Exudyn a process that imports exudyn and numpy, builds the model, solves and writes the
  CSV: its CPU at its end (``time.process_time``) minus what it spent loading symgen's scene and
  mechanism and importing SymPy (the converter's input, which a hand-written Exudyn script does
  not pay), plus the exit of a process that imported only numpy and exudyn (``EX_EXIT``: its
  rusage minus its own CPU at its end; the exit of a process holding SymPy's modules costs
  ~0.15 s more, which is not Exudyn's).

The floor (issue 20's acceptance): the steps needed to follow the first bending mode over the run,
``FLOOR_STEPS_PER_PERIOD`` per period of the lowest transverse mode of ``symgen.numerics.modes``
(at the run's start and end, the higher), times the cost of one compiled step (the C solver's own
CPU per step, ``solve_cpu_s / steps``, of the ``--solver c`` run at the same target). Each symgen
time is printed with its ratio to the floor. "Why" rows (integration only): the same run with a
looser rtol, with the tolerances each solver's rule derives from the accuracy (the validation
scenes state theirs: ``symgen.policy.tolerances``) and with quasi-static transverse functions
(``bodies.<bar>.quasi_static_transverse``, both solvers), to show which of steps, cost per step
and per-run overhead sets a ratio.
"""

from __future__ import annotations

import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

#: the problems: scene -> its targets (fractions of peak), Exudyn's grid (elements per elastic
#: bar, steps per output step) and whether the whole process is timed
PROBLEMS: dict[str, dict] = {
    "slider_crank_steel_rest": {
        "targets": (1e-2, 1e-3),
        "elements": (2, 4, 8),
        "per_output": (1, 2, 4, 8, 16, 32),
        "process": True,
    },
    "slider_crank_paper": {"targets": (1e-2,), "elements": (4, 8, 16), "per_output": (1, 2, 4, 8), "process": False},
}
#: issue 20's acceptance: (scene, target, symgen variant, what, at least) with what "integration"
#: (Exudyn's integration CPU / symgen's), "process" (whole process) or "floor" (symgen's integration
#: CPU / the floor, at most)
ACCEPTANCE = (
    ("slider_crank_steel_rest", 1e-2, "default", "integration", 10.0),
    ("slider_crank_steel_rest", 1e-2, "default", "process", 3.0),
    ("slider_crank_steel_rest", 1e-2, "c", "floor", 1.5),
    ("slider_crank_steel_rest", 1e-2, "c", "process", 10.0),
    ("slider_crank_steel_rest", 1e-3, "default", "integration", 20.0),
    ("slider_crank_steel_rest", 1e-3, "c", "integration", 150.0),
    ("slider_crank_paper", 1e-2, "c", "integration", 15.0),
)
#: symgen's variants: name -> (solver, estimate); "default" is what ``symgen simulate`` does; an
#: acceptance line of "default" / "c" is printed for the variant itself (the default estimate, what
#: the user pays) and for its run alone (``ALONE``: --estimate off)
VARIANTS = {
    "default": ("idas", "rerun"),
    "estimate off": ("idas", "off"),
    "c": ("c", "rerun"),
    "c, estimate off": ("c", "off"),
}
ALONE = {"default": "estimate off", "c": "c, estimate off"}
FLOOR_STEPS_PER_PERIOD = 11.0
EX_MAX_S = 3.0  # an Exudyn configuration past this CPU: no finer step at its mesh
EX_REPEAT_S = 0.5  # Exudyn configurations cheaper than this are timed ``repeats`` times in the grid


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


# --------------------------------------------------------------------------- timing helpers
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


# --------------------------------------------------------------------------- the reference
def reference(name: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The committed converged Exudyn reference of validation scene ``name`` (result units)."""
    from bench_validation import read_reference

    return read_reference(name)


def error_against(t: np.ndarray, outs: dict, ref: tuple[np.ndarray, dict]) -> float:
    """max over the reference's outputs of max |y - y_ref| / max |y_ref| on the reference's grid
    (the run's samples at those times: both are on the scene's output grid)."""
    t_ref, r = ref
    return max(peak_error(np.interp(t_ref, np.asarray(t, float), np.asarray(outs[k], float)), r[k]) for k in r)


# --------------------------------------------------------------------------- Exudyn
def exudyn_grid(name: str, ref, repeats: int, elements, per_output) -> list[dict]:
    """Exudyn's runs over the grid elements x steps per output step: rows with ``id``, ``finer``
    (twice the steps), ``error``, ``cpu`` (median of ``repeats`` where cheaper than
    ``EX_REPEAT_S``), ``steps``; a mesh stops at its first run past ``EX_MAX_S``."""
    import bench_validation as V
    import exudyn_scene as X
    from symgen.numerics.mechanism import load_mechanism
    from symgen.scene import load_scene

    scene = load_scene(V.scene_path(name))
    mech = load_mechanism(scene)
    rows = []
    for ne in elements:
        for k in per_output:
            row = {"id": (ne, k), "finer": (ne, 2 * k), "ne": ne, "k": k, "config": f"{ne} elements, {k} steps/output"}
            try:
                runs = [V._exudyn(scene, mech, ne, k, newton=V.NEWTON_RTOL.get(name))]
                if runs[0].cpu < EX_REPEAT_S:
                    runs += [V._exudyn(scene, mech, ne, k, newton=V.NEWTON_RTOL.get(name)) for _ in range(repeats - 1)]
            except Exception as err:  # Exudyn's SolveDynamic raises plain exceptions
                rows.append(
                    {**row, "error": math.inf, "cpu": math.inf, "steps": 0, "failed": str(err).splitlines()[0][:90]}
                )
                continue
            t, out = X.to_result_units(scene, runs[0].tau, runs[0].outputs)
            cpu = statistics.median(r.cpu for r in runs)
            rows.append({**row, "error": error_against(t, out, ref), "cpu": cpu, "steps": runs[0].info["steps"]})
            if cpu > EX_MAX_S:
                break
    return rows


def exudyn_integration(name: str, ne: int, k: int) -> float:
    """Exudyn's integration CPU (``SolveDynamic``) of one run."""
    import bench_validation as V
    from symgen.numerics.mechanism import load_mechanism
    from symgen.scene import load_scene

    scene = load_scene(V.scene_path(name))
    return V._exudyn(scene, load_mechanism(scene), ne, k, newton=V.NEWTON_RTOL.get(name)).cpu


#: the Exudyn process: imports exudyn and numpy, builds, solves, writes the CSV; it reports the CPU
#: of loading symgen's scene and mechanism (and importing SymPy, which the converter's driver law
#: uses), which the whole-process time leaves out
EX_PROCESS = r"""
import json, sys, time
import numpy as np
import exudyn
c1 = time.process_time()
sys.path[:0] = sys.argv[1:3]
import sympy
import bench_validation as V, exudyn_scene as X
from symgen.numerics.mechanism import load_mechanism
from symgen.scene import load_scene
name, ne, k, csv = sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), sys.argv[6]
scene = load_scene(V.scene_path(name))
mech = load_mechanism(scene)
c2 = time.process_time()
r = V._exudyn(scene, mech, ne, k, newton=V.NEWTON_RTOL.get(name))
t, out = X.to_result_units(scene, r.tau, r.outputs)
np.savetxt(csv, np.column_stack([t] + list(out.values())), delimiter=",", header="t," + ",".join(out), comments="")
print(json.dumps({"excluded": c2 - c1, "end": time.process_time()}))
"""
#: a process that imports only what a hand-written Exudyn script does: its exit's CPU
EX_EXIT = "import time, numpy, exudyn; print(time.process_time())"


def _child(code: list[str]) -> tuple[float, str]:
    """(rusage CPU s, stdout) of a fresh process."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    c0 = _child_cpu()
    proc = subprocess.run(code, check=True, cwd=ROOT, env=env, capture_output=True, text=True)
    return _child_cpu() - c0, proc.stdout.strip().splitlines()[-1]


def exudyn_exit_cpu(repeats: int) -> float:
    """CPU s of the exit of a process that imported numpy and exudyn (rusage minus its CPU at its end)."""
    runs = [_child([sys.executable, "-c", EX_EXIT]) for _ in range(repeats)]
    return statistics.median(max(cpu - float(line), 0.0) for cpu, line in runs)


def exudyn_process(name: str, ne: int, k: int, out_csv: Path, exit_cpu: float) -> float:
    """CPU s of a fresh Exudyn process (``EX_PROCESS``), its symgen-side loading left out, the exit
    of a lean one (``exit_cpu``) in."""
    _, line = _child([sys.executable, "-c", EX_PROCESS, str(HERE), str(ROOT), name, str(ne), str(k), str(out_csv)])
    got = json.loads(line)
    return float(got["end"]) - float(got["excluded"]) + exit_cpu


# --------------------------------------------------------------------------- symgen
def accuracy_override(target: float) -> str:
    return f"simulation.accuracy={target:g}"


#: the folder of the scenes as a user at a target runs them (:func:`user_scene`)
USER_SCENES = Path(tempfile.gettempdir()) / "symgen-bench-exudyn-scenes"


def user_scene(name: str) -> Path:
    """The validation scene ``name`` as a user who asks for an accuracy runs it: without the
    ``rtol`` and ``atol`` the validation scene states in ``[simulation]`` (1e-8 / 1e-10 on the
    slider-cranks, for the validation suite's converged runs), so that each solver derives its
    tolerances from ``simulation.accuracy`` (``symgen.policy.tolerances``): the cheapest settings
    within the target, as for Exudyn. Written next to nothing else (the scenes read no other file)."""
    import bench_validation as V

    lines = V.scene_path(name).read_text().splitlines()
    out, section = [], ""
    for line in lines:
        head = line.strip()
        if head.startswith("["):
            section = head
        if section == "[simulation]" and head.split("=")[0].strip() in ("rtol", "atol"):
            continue
        out.append(line)
    USER_SCENES.mkdir(exist_ok=True)
    path = USER_SCENES / f"{name}.toml"
    path.write_text("\n".join(out) + "\n")
    return path


def symgen_command(name: str, target: float, variant: str, out_csv: Path, extra: tuple = ()) -> list[str]:
    """``symgen simulate`` as a user runs it at accuracy ``target`` (``VARIANTS[variant]``)."""
    solver, estimate = VARIANTS[variant]
    cmd = [sys.executable, "-m", "symgen.cli", "simulate", str(user_scene(name)), "-o", str(out_csv)]
    for o in (accuracy_override(target), *extra):
        cmd += ["--set", o]
    return cmd + ["--solver", solver, "--estimate", estimate]


def read_csv(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    with open(path) as f:
        names = f.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",", ndmin=2)
    return data[:, 0], {k: data[:, i] for i, k in enumerate(names)}


def symgen_loaded(name: str, overrides: list[str]):
    """The mechanism ``symgen simulate`` runs (the strain decision remembered for the scene)."""
    from symgen.api import mechanism
    from symgen.numerics.strain_choice import resolved
    from symgen.scene import load_scene

    return mechanism(resolved(load_scene(user_scene(name), overrides)))


def symgen_integration(mech, solver: str, estimate: str) -> dict:
    """One in-process run of a loaded mechanism: CPU (the run, plus its error estimate unless
    ``estimate`` is off), steps, the C solver's own CPU, the result table."""
    from symgen.api import results_table
    from symgen.numerics.results import error_estimate
    from symgen.numerics.simulate import simulate

    t0 = time.process_time()
    if solver == "c":
        from symgen.numerics.csolver import simulate_c

        res = simulate_c(mech)
    else:
        res = simulate(mech)
    run_cpu = time.process_time() - t0
    if estimate != "off":
        error_estimate(mech.scene, mech.compiled, res, None, solver, estimate, mech)  # as symgen simulate
    cpu = time.process_time() - t0
    if not res.complete:
        raise RuntimeError(res.failure or "incomplete run")
    return {
        "cpu": cpu,
        "run_cpu": run_cpu,
        "steps": res.steps,
        "solve_cpu": res.stats.get("solve_cpu_s"),
        "table": results_table(res, mech.scene),
    }


def first_bending(mech) -> float:
    """The lowest transverse natural frequency (rad per unit tau) at the run's start and end,
    the higher of the two."""
    from symgen.numerics.modes import modes

    f = []
    for tau in (0.0, mech.scene.simulation.t_end):
        bending = [m.natural_frequency for m in modes(mech, tau, shapes=False).modes if "transverse" in m.dominant]
        f.append(min(bending))
    return max(f)


def estimate_by_c(mech) -> float:
    """CPU s of the default estimate's two reruns (the richer model, and the run at ``TIGHTER``
    times tighter tolerances: ``symgen.numerics.error_estimate``) were they made by the C solver
    (the richer model's C solver is used only where it was built before): what the estimate of a ``--solver c`` run
    could cost (the richer model's C solver built before the clock starts)."""
    from symgen.numerics.csolver import simulate_c
    from symgen.numerics.error_estimate import TIGHTER, richer_mechanism

    richer, _ = richer_mechanism(mech)
    sim = mech.scene.simulation
    simulate_c(richer)
    t0 = time.process_time()
    simulate_c(richer)
    simulate_c(mech, rtol=sim.rtol / TIGHTER, atol=sim.atol / TIGHTER)
    return time.process_time() - t0


#: what a fresh process pays before it runs anything: (label, code)
IMPORTS = (
    ("python -c pass", "pass"),
    ("import numpy", "import numpy"),
    ("import exudyn", "import exudyn"),
    ("import casadi", "import casadi"),
    (
        "the modules of a cached `--solver c` run",
        "import symgen.cli, symgen.numerics.csolver, symgen.numerics.results, symgen.numerics.strain_choice",
    ),
)


def import_costs(repeats: int) -> dict[str, float]:
    return {
        label: statistics.median(process_time([sys.executable, "-c", code])[0] for _ in range(repeats))
        for label, code in IMPORTS
    }


def why_rows(name: str, target: float, mech, repeats: int) -> list[dict]:
    """The integration at ``target`` with a looser rtol, with each solver's tolerances from the
    accuracy, and with 1 .. all of each bar's transverse functions quasi-static (both solvers):
    what sets the steps."""
    import bench_validation as V
    from symgen.scene import load_scene

    stated = load_scene(V.scene_path(name)).simulation
    bars = [b for b in mech.scene.bodies if getattr(b, "transverse_modes", 0)]
    configs: list[tuple[str, list[str], str]] = []
    for rtol in (1e-6, 1e-4):
        for solver in ("c", "idas"):
            configs.append(
                (f"rtol {rtol:g}", [f"simulation.rtol={rtol:g}", f"simulation.atol={rtol * 1e-2:g}"], solver)
            )
    # the validation scenes' own stated tolerances (the runs above derive theirs from the accuracy)
    for solver in ("c", "idas"):
        configs.append(
            (
                f"the scene's stated tolerances (rtol {stated.rtol:g}, atol {stated.atol:g})",
                [f"simulation.rtol={stated.rtol!r}", f"simulation.atol={stated.atol!r}"],
                solver,
            )
        )
    for b in bars:
        for qs in range(1, b.transverse_modes + 1):
            for solver in ("c", "idas"):
                configs.append(
                    (
                        f"{b.name}: {qs} of {b.transverse_modes} transverse quasi-static",
                        [f"bodies.{b.name}.quasi_static_transverse={qs}"],
                        solver,
                    )
                )
    rows = []
    for label, over, solver in configs:
        try:
            m = symgen_loaded(name, [accuracy_override(target), *over])
            symgen_integration(m, solver, "off")  # warm (libraries loaded)
            runs = [symgen_integration(m, solver, "off") for _ in range(repeats)]
        except Exception as err:  # a refused configuration is a row too
            rows.append({"config": label, "solver": solver, "failed": str(err).splitlines()[0][:120]})
            continue
        t = runs[0]["table"]
        rows.append(
            {
                "config": label,
                "solver": solver,
                "cpu": statistics.median(r["cpu"] for r in runs),
                "steps": runs[0]["steps"],
                "error": error_against(t["t"], t, reference(name)),
            }
        )
    return rows


# --------------------------------------------------------------------------- one problem
def bench_problem(name: str, repeats: int) -> dict:
    spec = PROBLEMS[name]
    ref = reference(name)
    peak = {k: float(np.abs(v).max()) for k, v in ref[1].items()}
    ex_rows = exudyn_grid(name, ref, repeats, spec["elements"], spec["per_output"])
    tmp = Path(tempfile.mkdtemp(prefix="symgen-bench-exudyn-"))
    exit_cpu = exudyn_exit_cpu(repeats) if spec["process"] else 0.0
    per_target = {}
    for target in spec["targets"]:
        pick = cheapest(ex_rows, target)
        # warm: the model, its C solver, the strain decision and the estimate's richer model cached
        for variant in VARIANTS:
            process_time(symgen_command(name, target, variant, tmp / "warm.csv"))
        mechs = {v: symgen_loaded(name, [accuracy_override(target)]) for v in VARIANTS}
        estimate_by_c(mechs["c"])  # the richer model's C solver built: a --solver c estimate reruns it in C
        for v, m in mechs.items():
            symgen_integration(m, *VARIANTS[v])  # libraries loaded, caches of the process filled
        times: dict[str, dict[str, list]] = {v: {"int": [], "proc": [], "solve": []} for v in VARIANTS}
        ex_int, ex_proc = [], []
        sg_run: dict[str, dict] = {}
        for _ in range(repeats):  # the tools interleaved, repeat by repeat
            if pick:
                ex_int.append(exudyn_integration(name, pick["ne"], pick["k"]))
                if spec["process"]:
                    ex_proc.append(exudyn_process(name, pick["ne"], pick["k"], tmp / "exudyn.csv", exit_cpu))
            for v, m in mechs.items():
                r = symgen_integration(m, *VARIANTS[v])
                sg_run.setdefault(v, r)
                times[v]["int"].append(r["cpu"])
                if r["solve_cpu"] is not None:
                    times[v]["solve"].append(r["solve_cpu"] / max(r["steps"], 1))
                if spec["process"]:
                    times[v]["proc"].append(process_time(symgen_command(name, target, v, tmp / "out.csv"))[0])
        symgen = {}
        for v in VARIANTS:
            # the error of what the user gets: the CSV of the command (and the sidecar's estimate)
            process_time(symgen_command(name, target, v, tmp / "out.csv"))
            t, outs = read_csv(tmp / "out.csv")
            sidecar = json.loads((tmp / "out.json").read_text())
            est = sidecar["error_estimate"]
            symgen[v] = {
                "error": error_against(t, outs, ref),
                "estimate": max((x for x in est.values() if x is not None), default=None),
                "steps": sg_run[v]["steps"],
                "int": statistics.median(times[v]["int"]),
                "proc": statistics.median(times[v]["proc"]) if times[v]["proc"] else None,
                "per_step": statistics.median(times[v]["solve"]) if times[v]["solve"] else None,
                "bases": sidecar.get("bases"),
            }
        f1 = first_bending(mechs["c"])
        periods = f1 * mechs["c"].scene.simulation.t_end / (2 * math.pi)
        floor_steps = FLOOR_STEPS_PER_PERIOD * periods
        per_step = symgen["c"]["per_step"]
        per_target[target] = {
            "pick": pick,
            "ex_int": statistics.median(ex_int) if ex_int else None,
            "ex_proc": statistics.median(ex_proc) if ex_proc else None,
            "symgen": symgen,
            "f1": f1,
            "periods": periods,
            "floor_steps": floor_steps,
            "per_step": per_step,
            "floor": floor_steps * per_step if per_step else None,
            "why": why_rows(name, target, mechs["default"], repeats),
            "estimate_c": estimate_by_c(mechs["c"]),
        }
    for f in tmp.iterdir():
        f.unlink()
    tmp.rmdir()
    return {"name": name, "peak": peak, "ex": ex_rows, "targets": per_target, "spec": spec}


# --------------------------------------------------------------------------- report
def _pct(x: float | None) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{100 * x:.3g} %"


def _ms(x: float | None) -> str:
    return "—" if x is None else f"{1e3 * x:.1f}"


def _ratio(a: float | None, b: float | None) -> str:
    return "—" if not a or not b else f"{a / b:.2f}x"


def acceptance_lines(results: dict[str, dict]) -> list[str]:
    out = []
    for name, target, tool, what, want in ACCEPTANCE:
        r = results.get(name, {}).get("targets", {}).get(target)
        if r is None:
            continue
        parts = []
        for variant, how in ((tool, "with the default estimate"), (ALONE[tool], "--estimate off")):
            s = r["symgen"][variant]
            if what == "floor":
                got = s["int"] / r["floor"] if r["floor"] else math.nan
                ok = got <= want
                text = f"{got:.2f}x the floor ({_ms(s['int'])} ms vs {_ms(r['floor'])} ms)"
            else:
                ex = r["ex_int"] if what == "integration" else r["ex_proc"]
                mine = s["int"] if what == "integration" else s["proc"]
                got = ex / mine if ex and mine else math.nan
                ok = got >= want
                text = f"{got:.3g}x ({_ms(ex)} ms vs {_ms(mine)} ms)"
            parts.append(f"{how}: {text}, {'met' if ok else '**not met**'}")
        what_text = {
            "floor": f"within {want:g}x of the floor",
            "integration": f">= {want:g}x Exudyn's integration CPU",
            "process": f">= {want:g}x Exudyn's whole process",
        }[what]
        how = {"default": "default `symgen simulate`", "c": "`--solver c`"}[tool]
        out.append(f"- {name} at {100 * target:g} %, {how} {what_text}: " + "; ".join(parts) + ".")
    return out


def report(r: dict, repeats: int) -> list[str]:
    name, spec = r["name"], r["spec"]
    out = [
        f"### {name}",
        "",
        "Peak of the reference: " + ", ".join(f"{k} {v:.4g}" for k, v in r["peak"].items()) + ".",
        "",
    ]
    ks = spec["per_output"]
    out += [
        "Exudyn's error against the reference (CPU s of `SolveDynamic`):",
        "",
        "| elements \\ steps per output step | " + " | ".join(str(k) for k in ks) + " |",
        "|---|" + "---|" * len(ks),
    ]
    by = {row["id"]: row for row in r["ex"]}
    for ne in spec["elements"]:
        cells = []
        for k in ks:
            row = by.get((ne, k))
            if row is None:
                cells.append("not run")
            elif "failed" in row:
                cells.append("failed")
            else:
                cells.append(f"{_pct(row['error'])} ({row['cpu']:.3f})")
        out.append(f"| {ne} | " + " | ".join(cells) + " |")
    for target, t in r["targets"].items():
        pick = t["pick"]
        out += [
            "",
            f"**Target {100 * target:g} %.** Exudyn's cheapest: "
            + (f"{pick['config']} ({pick['steps']} steps), error {_pct(pick['error'])}" if pick else "none reached it")
            + f". Floor: first bending mode {t['f1']:.1f} rad per unit tau, {t['periods']:.1f} periods over the run, "
            f"{FLOOR_STEPS_PER_PERIOD:g} steps per period = {t['floor_steps']:.0f} steps x "
            + (
                f"{1e6 * t['per_step']:.1f} µs per compiled step = **{_ms(t['floor'])} ms**."
                if t["floor"]
                else "— (no C step measured)."
            ),
            "",
            "| tool | run | error | estimate | steps | integration CPU ms | Exudyn / it | it / floor | whole process CPU ms | Exudyn / it |",
            "|---|---|---|---|---|---|---|---|---|---|",
            f"| Exudyn | {pick['config'] if pick else '—'} | {_pct(pick['error']) if pick else '—'} | | "
            f"{pick['steps'] if pick else ''} | {_ms(t['ex_int'])} | | {_ratio(t['ex_int'], t['floor'])} | {_ms(t['ex_proc'])} | |",
        ]
        for v, s in t["symgen"].items():
            out.append(
                f"| symgen | {v} | {_pct(s['error'])} | {_pct(s['estimate'])} | {s['steps']} | {_ms(s['int'])} | "
                f"{_ratio(t['ex_int'], s['int'])} | {_ratio(s['int'], t['floor'])} | {_ms(s['proc'])} | "
                f"{_ratio(t['ex_proc'], s['proc'])} |"
            )
        sv = t["symgen"]
        out += [
            "",
            f"The default error estimate (two reruns: the richer model by IDAS, or by its C solver after a C run "
            f"where that is built, the run at 10x tighter "
            f"tolerances by the run's own solver; then the model-form part) costs "
            f"{_ms(sv['default']['int'] - sv['estimate off']['int'])} ms of CPU after the IDAS run and "
            f"{_ms(sv['c']['int'] - sv['c, estimate off']['int'])} ms after the C run; the two reruns alone by the C "
            f"solver: {_ms(t['estimate_c'])} ms.",
        ]
        b = t["symgen"]["default"]["bases"] or {}
        if b:
            out += [
                "",
                "symgen's bases at this accuracy (sidecar): "
                + "; ".join(
                    f"{bar}: {d.get('axial')} axial + {d.get('transverse')} transverse, dynamic "
                    f"{d.get('dynamic', {}).get('axial')} axial + {d.get('dynamic', {}).get('transverse')} transverse"
                    for bar, d in b.items()
                )
                + ".",
            ]
        out += [
            "",
            "Why (integration only, the same accuracy, estimate off, medians of repeats):",
            "",
            "| change | solver | error | steps | integration CPU ms | Exudyn / it |",
            "|---|---|---|---|---|---|",
        ]
        for w in t["why"]:
            if "failed" in w:
                out.append(f"| {w['config']} | {w['solver']} | refused: {w['failed']} | | | |")
            else:
                out.append(
                    f"| {w['config']} | {w['solver']} | {_pct(w['error'])} | {w['steps']} | {_ms(w['cpu'])} | "
                    f"{_ratio(t['ex_int'], w['cpu'])} |"
                )
    out.append("")
    return out


def run(repeats: int, quick: bool = False) -> str:
    try:
        import exudyn
    except ImportError:
        return (
            "## symgen vs Exudyn: issue 20's steel slider-crank\n\nExudyn is not installed (optional: "
            "`python -m pip install exudyn`, the `bench` extra); section skipped.\n"
        )
    import symgen

    compile_sources()
    names = ["slider_crank_steel_rest"] if quick else list(PROBLEMS)
    results = {n: bench_problem(n, repeats) for n in names}
    imports = import_costs(repeats)
    out = [
        "## symgen vs Exudyn: issue 20's steel slider-crank",
        "",
        f"Exudyn {exudyn.__version__} (ANCF cable elements, generalized-alpha rho 0.9, fixed step) vs symgen "
        f"{getattr(symgen, '__version__', '')} as a user runs it (`symgen simulate SCENE --set simulation.accuracy=TARGET`: "
        "no mode counts, the tolerances derived from the accuracy (the scene's stated rtol and atol left out), strain auto, the default error estimate, and `--estimate off`; IDAS and "
        "`--solver c`), on the validation scenes with their converged Exudyn references (benchmarks/validation/). "
        f"CPU times, medians of {repeats}, tools interleaved; problem, rules and the floor in the docstring of "
        "`benchmarks/bench_exudyn.py`. Error: max |y - y_ref| / max |y_ref| over the run.",
        "",
        "Acceptance (issue 20):",
        "",
        *acceptance_lines(results),
        "",
    ]
    out += [
        "Whole process: what a fresh process pays before it runs anything (CPU ms, medians): "
        + ", ".join(f"{k} {_ms(v)}" for k, v in imports.items())
        + ". A cached `--solver c` process reads its model's description and its remembered start plan "
        "from the cache and runs the start, the steps and the outputs in the C library: it does not import "
        "casadi (tests/test_lean_start.py).",
        "",
    ]
    for n in names:
        out += report(results[n], repeats)
    return "\n".join(out)


if __name__ == "__main__":
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 1, "--quick" in sys.argv))
