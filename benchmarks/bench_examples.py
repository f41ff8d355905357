"""Benchmark sections on the example scenes (run through benchmarks/run.py).

1. The example scenes: derivation (fresh, no cache), CasADi build, integration (IDAS) time,
   steps, closure residual.
2. Seed model vs the accurate default on the seed's slider-crank (midspan deflection against
   a converged 6 axial + 8 transverse reference).

Times are medians of repeats measured in one run on this machine (shared, noisy machines:
compare ratios within a run, not absolute numbers across runs).
"""

from __future__ import annotations

import json
import os
import subprocess
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from symgen.backends.casadi.pipeline import compile_scene  # noqa: E402
from symgen.numerics.mechanism import Mechanism  # noqa: E402
from symgen.numerics.simulate import simulate  # noqa: E402
from symgen.scene import load_scene  # noqa: E402

EXAMPLES = ["examples/slider_crank.toml", "examples/four_bar.toml"]
ACCURATE = ["effects.strain=von_karman", "bodies.rod.axial_shapes=complete"]


def median(xs):
    return statistics.median(xs)


FRESH_DERIVE = """
import json, sys, time
sys.path.insert(0, {root!r})
from symgen.scene import load_scene
from symgen.model.derive import derive
scene = load_scene({path!r})
t0 = time.perf_counter()
derive(scene)
print(json.dumps({{"derive_s": time.perf_counter() - t0}}))
"""


def fresh_derive_time(path: str) -> float:
    """Derivation in a new process with an empty cache: SymPy's and symgen's caches cold."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, SYMGEN_CACHE_DIR=cache)
        out = subprocess.run(
            [sys.executable, "-c", FRESH_DERIVE.format(root=str(ROOT), path=str(ROOT / path))],
            capture_output=True,
            text=True,
            env=env,
            check=True,
        ).stdout
    return json.loads(out.strip().splitlines()[-1])["derive_s"]


def bench_examples(repeats: int) -> list[dict]:
    rows = []
    saved = os.environ.get("SYMGEN_CACHE_DIR")  # restored below: later sections keep their cache
    for path in EXAMPLES:
        scene = load_scene(ROOT / path)
        derive, build, sim, steps, closure = [], [], [], [], []
        for _ in range(repeats):
            derive.append(fresh_derive_time(path))
            with tempfile.TemporaryDirectory() as cache:
                os.environ["SYMGEN_CACHE_DIR"] = cache
                compiled = compile_scene(scene, use_cache=False)
                t0 = time.perf_counter()
                mech = Mechanism(compiled, scene)
                build.append(compiled.build_s + time.perf_counter() - t0)
                res = simulate(mech)
                sim.append(res.simulate_s)
                steps.append(res.steps)
                closure.append(res.closure_max)
        turns = scene.simulation.t_end / (2 * np.pi)
        rows.append(
            {
                "scene": path,
                "turns": turns,
                "derive_s": median(derive),
                "build_s": median(build),
                "simulate_s": median(sim),
                "per_turn_s": median(sim) / turns,
                "steps": int(median(steps)),
                "closure": max(closure),
                "n_states": compiled.info.n,
            }
        )
    if saved is None:
        os.environ.pop("SYMGEN_CACHE_DIR", None)
    else:
        os.environ["SYMGEN_CACHE_DIR"] = saved
    return rows


def midspan(overrides):
    scene = load_scene(ROOT / EXAMPLES[0], overrides)
    res = simulate(Mechanism(compile_scene(scene), scene))
    return res.tau, res.column("eta_mid"), res.simulate_s


def bench_seed_vs_accurate() -> list[dict]:
    _, ref, _ = midspan([*ACCURATE, "effects.axial=true", "bodies.rod.axial_modes=6", "bodies.rod.transverse_modes=8"])
    peak = np.abs(ref).max()
    cases = [
        ("seed (paper): linear strain, stress-free axial, 1+1", []),
        (
            "accurate default (rod axially quasi-static: auto), 3+4",
            [*ACCURATE, "bodies.rod.axial_modes=3", "bodies.rod.transverse_modes=4"],
        ),
        (
            "accurate, full axial dynamics (axial = true), 3+4",
            [*ACCURATE, "effects.axial=true", "bodies.rod.axial_modes=3", "bodies.rod.transverse_modes=4"],
        ),
        (
            "von Karman + stress-free axial, dynamic, 3+4",
            [
                "effects.strain=von_karman",
                "effects.axial=true",
                "bodies.rod.axial_modes=3",
                "bodies.rod.transverse_modes=4",
            ],
        ),
        ("accurate default with only 1+1", [*ACCURATE]),
    ]
    rows = [
        {
            "model": "reference: accurate, full axial dynamics, 6 axial + 8 transverse",
            "peak": peak,
            "peak_err": 0.0,
            "max_err": 0.0,
        }
    ]
    for label, ov in cases:
        _, y, t = midspan(ov)
        rows.append(
            {
                "model": label,
                "peak": np.abs(y).max(),
                "peak_err": np.abs(y).max() / peak - 1,
                "max_err": np.abs(y - ref).max() / peak,
                "simulate_s": t,
            }
        )
    return rows


def render(examples, seed) -> str:
    out = [
        "## Example scenes (medians of repeats; derivation in a fresh process with empty caches)",
        "",
        "| scene | turns | coordinates | derive s | build s | simulate s | s per turn | IDAS steps | closure max |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in examples:
        out.append(
            f"| `{r['scene']}` | {r['turns']:.0f} | {r['n_states']} | {r['derive_s']:.2f} | {r['build_s']:.2f} | "
            f"{r['simulate_s']:.2f} | {r['per_turn_s']:.2f} | {r['steps']} | {r['closure']:.1e} |"
        )
    out += [
        "",
        "## Seed model vs the accurate default (slider-crank 6.1, first two turns)",
        "",
        "Midspan deflection from the chord, /l; errors relative to the reference peak.",
        "",
        "| model | peak abs(eta_mid) | peak error | max pointwise error |",
        "|---|---|---|---|",
    ]
    for r in seed:
        out.append(f"| {r['model']} | {r['peak']:.5f} | {100 * r['peak_err']:+.2f} % | {100 * r['max_err']:.2f} % |")
    return "\n".join(out) + "\n"


def run(repeats: int) -> str:
    """Markdown of this section."""
    return render(bench_examples(repeats), bench_seed_vs_accurate())
