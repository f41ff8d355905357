"""Benchmark section ``estimate_cost`` (issue 20): what the default error estimate costs beside the
run, part by part, before and after its cut.

*Before* is the tree of :data:`BASE` (the commit before the cut), taken with ``git archive``;
*after* is this checkout. Both run from one model cache, warmed first (the models, the compiled
libraries, the C solvers of the run's model and of the estimate's richer model, the strain
decision), on the steel slider-crank and the paper's slider-crank at 1 % (issue 20's scenes),
each as ``symgen simulate`` runs it (IDAS, and ``--solver c``), in one process per tree: the run
(``simulate`` / ``simulate_c``) then the estimate (``results.error_estimate``, the default
``rerun``), repeated on one mechanism; CPU (user + system) medians. The parts are timed by
wrapping the functions that make them (the same names in both trees): the truncation part's
rerun of the richer model (``error_estimate._rerun``, with the richer model's loading), the
time part's rerun at tighter tolerances (``_tighter_run``), the model-form part
(``model_form.estimate``) and the start part (``start_part``). "c, richer not built": the
``--solver c`` run of a cache without the richer model's C library (emulated: its lookup says
not built), where the richer model runs in IDAS as before.

    python benchmarks/run.py --only estimate_cost
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
#: the commit before the estimate's cut
BASE = "c33e80b"
SCENES = ("slider_crank_steel_rest", "slider_crank_paper")
ACCURACY = 0.01
#: variants: name -> (solver, the richer model's C library found)
VARIANTS = {"idas": ("idas", True), "c": ("c", True), "c, richer not built": ("c", False)}
PARTS = {
    "_rerun": "truncation rerun",
    "_tighter_run": "tighter rerun",
    "model_form": "model form",
    "start_part": "start part",
}

#: what the table shows, measured when the cut was made (RESULTS.md keeps that run's numbers)
NOTES = """Before the cut, the model-form part was a Python loop over up to 400 output samples (CasADi
calls and small numpy solves per sample, and numpy's `pow` on the subnormal slopes of a bar at rest,
7 ms a call); now all samples at once (stacked solves, one mapped call each for the KKT Jacobians
and the outputs). The richer model is loaded once per process, the run's mechanism is passed to the
estimate, the IDAS output polish takes one mapped call per Newton step (the run's too: its results
equal to the last bit), and after a `--solver c` run the richer model runs in its own C solver
where that library is in the cache (never compiled for the estimate). What is left is the
integration of the two reruns, which the estimate's definition sets: on the steel slider-crank the
richer model's two added transverse functions are dynamic and ring undamped (IDAS: 10245 steps
against the run's 1623), and 10x tighter tolerances take about twice the run's steps. The C solver
is not always the cheaper rerun of the richer model: on the paper's slider-crank it takes more
steps than IDAS (the "c" and "c, richer not built" rows). "its change from before": the largest
relative change of the estimate of an output (the C rows' richer model runs in C now)."""

IN_PROCESS = r"""
import collections, json, sys, time
sys.path.insert(0, sys.argv[1] + "/benchmarks")
import bench_validation as V
from symgen.api import mechanism
from symgen.numerics import csolver, error_estimate as E, model_form as MF
from symgen.numerics.results import error_estimate
from symgen.numerics.simulate import simulate
from symgen.numerics.strain_choice import resolved
from symgen.scene import load_scene
name, solver, richer_c, repeats = sys.argv[2], sys.argv[3], sys.argv[4] == "1", int(sys.argv[5])
acc = collections.defaultdict(float)
def wrap(owner, attr, label):
    f = getattr(owner, attr)
    def timed(*a, **k):
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            acc[label] += time.process_time() - t
    setattr(owner, attr, timed)
for attr in ("_rerun", "_tighter_run", "start_part"):
    wrap(E, attr, attr)
wrap(MF, "estimate", "model_form")
if E.MODEL_FORM_ESTIMATORS.get("curvature") is not None:
    E.MODEL_FORM_ESTIMATORS["curvature"] = MF.estimate
mech = mechanism(resolved(load_scene(V.scene_path(name), ["simulation.accuracy=%s" % sys.argv[6]])))
richer = E.richer_mechanism(mech)[0]
if solver == "c":
    csolver.simulate_c(mech)
    csolver.simulate_c(richer)  # built outside the clock
    if not richer_c and hasattr(csolver, "NotBuilt"):
        lookup = csolver.library
        def library(m, use_cache=True, build=True):
            if not build and m.info.key == richer.info.key:
                raise csolver.NotBuilt("emulated")
            return lookup(m, use_cache, build)
        csolver.library = library
run = (lambda: csolver.simulate_c(mech)) if solver == "c" else (lambda: simulate(mech))
import inspect
given = {"mech": mech} if "mech" in inspect.signature(error_estimate).parameters else {}  # as symgen simulate
rows = []
for i in range(repeats + 2):  # two warm-ups: the process's caches filled
    acc.clear()
    t0 = time.process_time()
    res = run()
    t1 = time.process_time()
    est, _ = error_estimate(mech.scene, mech.compiled, res, None, solver, "rerun", **given)
    t2 = time.process_time()
    if i >= 2:
        rows.append({"run": t1 - t0, "estimate": t2 - t1, **acc})
print("REPORT " + json.dumps({"rows": rows, "estimate": est.outputs, "truncation": est.methods["truncation"]}))
"""


def _base_tree(where: Path) -> Path:
    data = subprocess.run(["git", "-C", str(ROOT), "archive", BASE], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=BytesIO(data)) as tar:
        tar.extractall(where, filter="data")
    return where


def _measure(tree: Path, name: str, variant: str, repeats: int) -> dict:
    solver, richer_c = VARIANTS[variant]
    env = dict(os.environ, PYTHONPATH=str(tree))
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            IN_PROCESS,
            str(tree),
            name,
            solver,
            "1" if richer_c else "0",
            str(repeats),
            f"{ACCURACY:g}",
        ],
        env=env,
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
        timeout=1800,
    )
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("REPORT "))
    return json.loads(line[len("REPORT ") :])


def _median(rows: list[dict], key: str) -> float:
    return statistics.median(r.get(key, 0.0) for r in rows)


def run(repeats: int = 5) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        base = _base_tree(Path(tmp))
        results: dict[tuple[str, str, str], list[dict]] = {}
        estimates: dict[tuple[str, str, str], dict] = {}
        for name in SCENES:
            for variant in VARIANTS:
                trees = {"before": base, "after": ROOT}
                if variant == "c, richer not built":
                    trees = {"after": ROOT}  # before: the richer model ran in IDAS whatever was built
                for _ in range(2):  # the trees interleaved, process by process
                    for label, tree in trees.items():
                        got = _measure(tree, name, variant, repeats)
                        results.setdefault((name, variant, label), []).extend(got["rows"])
                        estimates[(name, variant, label)] = got
    lines = [
        "## The error estimate's cost (issue 20)",
        "",
        f"The default estimate beside the run it estimates, before ({BASE}) and after the cut, at accuracy "
        f"{ACCURACY:g}, CPU ms, medians of {2 * repeats} (two processes per tree, interleaved); how in "
        "benchmarks/bench_estimate_cost.py.",
        "",
        "| scene | solver | tree | run | estimate | estimate / run | "
        + " | ".join(PARTS.values())
        + " | rest | largest estimate | its change from before |",
        "|---|---|---|---|---|---|" + "---|" * len(PARTS) + "---|---|---|",
    ]
    for (name, variant, label), rows in results.items():
        r, e = _median(rows, "run"), _median(rows, "estimate")
        parts = [_median(rows, k) for k in PARTS]
        est = estimates[(name, variant, label)]["estimate"]
        top = max((v for v in est.values() if v is not None), default=None)
        before = estimates.get((name, variant if variant in ("idas", "c") else "c", "before"), {}).get("estimate", {})
        changes = [abs(est[k] - v) / abs(v) for k, v in before.items() if v and est.get(k) is not None]
        lines.append(
            f"| {name} | {variant} | {label} | {1e3 * r:.1f} | {1e3 * e:.1f} | {e / r:.1f}x | "
            + " | ".join(f"{1e3 * p:.1f}" for p in parts)
            + f" | {1e3 * (e - sum(parts)):.1f} | {top:.4g} | "
            + (f"{max(changes):.1e} |" if label == "after" and changes else "— |")
        )
    lines += ["", NOTES, ""]
    for (name, variant, label), got in estimates.items():
        if label == "after":
            lines.append(f"* {name}, {variant}: truncation part: {got['truncation']}")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 5))
