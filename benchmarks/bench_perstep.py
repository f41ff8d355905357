"""Benchmark section ``perstep`` (issue 20, item 5): the cost of one integrator step on open chains
of 2-12 elastic bars, before and after the sparse factorisations.

*Before* is the tree of :data:`BASE` (the C solver's Newton matrices by dense block elimination:
LU of g_z, the reduced ODE's full Jacobian, dense LUs of c^2 I - c A_v - A_q; IDAS with CasADi's
dense QR); *after* is this checkout (the C solver's Newton matrices factored whole with the
runtime's sparse LU, pivots kept per Jacobian; IDAS with CSparse). Both trees share one model and
compiled-library cache (the IDAS libraries are the same); the C solver is built per tree.

Each chain (``bench_derivation.scene_text``: a driven ground pin, 2 axial and 4 transverse modes
per bar) runs ``T_END`` tau with ``--solver c`` and with IDAS (compiled library), in one process
per tree and chain, the trees interleaved, each run repeated; CPU per step is the integration's
CPU (the C solver's own ``solve_cpu_s``; IDAS: ``simulate``'s CPU) over its steps, medians. The
exponent k of cost per step ~ N^k is the least-squares slope over the chains (target: k <= 1.1).

    python benchmarks/run.py --only perstep
"""

from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_derivation import scene_text
from bench_lean import base_tree as _lean_base_tree

ROOT = Path(__file__).resolve().parent.parent
#: The commit before the sparse factorisations.
BASE = "14b02aa"
BARS = (2, 4, 6, 8, 10, 12)
T_END = 1.0
TARGET_K = 1.1

ONE = r"""
import json, sys, time
from symgen.api import mechanism
from symgen.numerics.csolver import simulate_c
from symgen.numerics.simulate import simulate

mech = mechanism(sys.argv[1])
t_end, repeats = float(sys.argv[2]), int(sys.argv[3])
simulate_c(mech, t_end=0.01)
simulate(mech, t_end=0.01, backend="compiled")
c, i = [], []
for _ in range(repeats):
    r = simulate_c(mech, t_end=t_end)
    c.append({"cpu": r.stats["solve_cpu_s"], "steps": r.steps, "jacobians": r.stats.get("jacobians"),
              "factorizations": r.stats.get("factorizations")})
    t0 = time.process_time()
    r = simulate(mech, t_end=t_end, backend="compiled")
    i.append({"cpu": time.process_time() - t0, "steps": r.steps})
print(json.dumps({"n": mech.n, "c": c, "idas": i}))
"""


def base_tree(dest: Path) -> bool:
    return _lean_base_tree(dest, BASE)


def _measure(tree: Path, scene: Path, cache: Path, repeats: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), SYMGEN_CACHE_DIR=str(cache))
    proc = subprocess.run(
        [sys.executable, "-c", ONE, str(scene), str(T_END), str(repeats)],
        capture_output=True,
        text=True,
        env=env,
        cwd=tempfile.gettempdir(),
        check=True,
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _per_step(runs: list[dict]) -> float:
    """Median µs per step."""
    return statistics.median(1e6 * r["cpu"] / r["steps"] for r in runs)


def _slope(xs: list[float], ys: list[float]) -> float:
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = statistics.fmean(lx), statistics.fmean(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def run(repeats: int, quick: bool = False) -> str:
    bars = (2, 4) if quick else BARS
    rows = []
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        before = tmp / "before"
        have_before = base_tree(before)
        cache = tmp / "cache"
        for n in bars:
            scene = tmp / f"chain{n}.toml"
            scene.write_text(scene_text("chain", n, 2, 4))
            b = _measure(before, scene, cache, repeats) if have_before else None
            a = _measure(ROOT, scene, cache, repeats)
            rows.append((n, b, a))
            print(f"perstep: chain {n}: {json.dumps([b, a])}", file=sys.stderr, flush=True)
    return render(rows, repeats)


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f}"


def render(rows: list, repeats: int) -> str:
    out = [
        "## perstep: cost per step against the number of bars (issue 20, item 5)",
        "",
        f"Open chains of N elastic bars (2 axial + 4 transverse modes each), {T_END:g} tau, CPU µs per step "
        f"(integration only), medians of {repeats} runs, the trees interleaved. Before = {BASE} (C solver: "
        "dense block elimination; IDAS: dense QR), after = this tree (C solver: the whole Newton matrices "
        "factored sparse, pivots kept per Jacobian; IDAS: CSparse). Steps, Jacobians and factorizations "
        "of the C solver after.",
        "",
        "| bars | coordinates | C steps | C Jacobians | C factorizations | C before µs/step | C after µs/step "
        "| IDAS steps after | IDAS before µs/step | IDAS after µs/step |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    cols: dict[str, list[float]] = {"cb": [], "ca": [], "ib": [], "ia": []}
    ns = []
    for n, b, a in rows:
        c0 = a["c"][0]
        cb = _per_step(b["c"]) if b else None
        ib = _per_step(b["idas"]) if b else None
        ca, ia = _per_step(a["c"]), _per_step(a["idas"])
        ns.append(n)
        for key, val in (("cb", cb), ("ca", ca), ("ib", ib), ("ia", ia)):
            if val is not None:
                cols[key].append(val)
        out.append(
            f"| {n} | {a['n']} | {c0['steps']} | {c0['jacobians']} | {c0['factorizations']} | {_fmt(cb)} | "
            f"{_fmt(ca)} | {a['idas'][0]['steps']} | {_fmt(ib)} | {_fmt(ia)} |"
        )
    out += [
        "",
        f"Exponent k of µs per step ~ N^k (least squares over {ns[0]}-{ns[-1]} bars; target k <= {TARGET_K}):",
        "",
    ]
    out += ["| path | before | after |", "|---|---|---|"]
    for label, kb, ka in (("C solver", "cb", "ca"), ("IDAS (compiled)", "ib", "ia")):
        sb = f"{_slope(ns, cols[kb]):.2f}" if len(cols[kb]) == len(ns) > 1 else "-"
        sa = f"{_slope(ns, cols[ka]):.2f}" if len(cols[ka]) == len(ns) > 1 else "-"
        out.append(f"| {label} | {sb} | {sa} |")
    return "\n".join(out)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 3, quick="--quick" in sys.argv))
