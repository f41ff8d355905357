"""Accuracy-driven bases (issue 19, item 1): the counts symgen chooses from
``simulation.accuracy`` against symgen converged in its own counts.

For each scene: the counts chosen (no counts in the file, or the file's counts removed), the run
with them, and a ladder of richer uniform counts on every elastic bar; the richest run is the
reference (its distance to the one before it says how converged it is). The table gives per
output max over the run |y - y_ref| / max |y_ref|, the IDAS steps and the integration time.
Where symgen makes functions quasi-static (``BasisChoice.quasi``, ``quasi_axial``), a row with
the chosen counts stated (every function dynamic) shows what that saves.

    PYTHONPATH=. python benchmarks/bench_bases.py [scene ...]     # prints a RESULTS section

CPU: each rung derives a model (cached in SYMGEN_CACHE_DIR); run one scene at a time.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from symgen.api import mechanism  # noqa: E402
from symgen.numerics import simulate as sim  # noqa: E402
from symgen.scene import load_scene  # noqa: E402

#: (scene, extra overrides, ladder of (axial, transverse) counts on every elastic bar)
CASES = {
    "slider_crank": (
        "examples/slider_crank.toml",
        [
            "effects.strain=von_karman",
            "bodies.rod.axial_shapes=complete",
            "initial.deformation=quasi-static",
            "simulation.accuracy=0.01",
            "bodies.rod.axial_modes=",
            "bodies.rod.transverse_modes=",
        ],
        [(3, 4), (5, 6), (6, 8)],
    ),
    "slider_crank_steel": (
        "benchmarks/scenes/slider_crank_steel.toml",
        ["bodies.rod.axial_modes=", "bodies.rod.transverse_modes="],
        [(3, 4), (5, 6), (6, 8)],
    ),
    "crank_rocker_steel_900": ("benchmarks/scenes/crank_rocker_steel_900.toml", [], [(3, 4), (5, 6), (6, 8)]),
    "double_pendulum_aluminium": ("benchmarks/scenes/double_pendulum_aluminium.toml", [], [(3, 4), (5, 6), (6, 8)]),
}


def counts(path: str, overrides: list[str], na: int, nt: int) -> list[str]:
    scene = load_scene(path, [o for o in overrides if not o.endswith("=")])
    out = [o for o in overrides if not o.endswith("=")]
    for b in scene.bodies:
        if not b.rigid:
            out += [f"bodies.{b.name}.axial_modes={na if b.axial_modes else 0}"]
            out += [f"bodies.{b.name}.transverse_modes={nt if b.transverse_modes else 0}"]
    return out


def simulate_file(path: str, overrides: list[str]):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mech = mechanism(str(ROOT / path), overrides)
    tic = time.perf_counter()
    res = sim.simulate(mech)
    return mech, res, time.perf_counter() - tic


def errors(res, ref) -> dict[str, float]:
    out = {}
    for name in ref.output_names:
        if name == "closure":
            continue
        y, r = res.column(name), ref.column(name)
        n = min(len(y), len(r))
        out[name] = float(np.max(np.abs(y[:n] - r[:n])) / max(np.max(np.abs(r[:n])), 1e-300))
    return out


def case(label: str) -> str:
    path, extra, ladder = CASES[label]
    base = [o for o in extra if not o.endswith("=")]
    absent = [o[:-1] for o in extra if o.endswith("=")]
    scene = _scene_without(path, base, absent)
    mech, chosen, chosen_s = run_scene(scene)
    dynamic = None
    if any(c.quasi or c.quasi_axial for c in scene.bases):
        # the same counts stated, every function dynamic: what the quasi-static choice saves
        stated = [
            f"bodies.{c.bar}.{key}={n}"
            for c in scene.bases
            for key, n in (("axial_modes", c.axial), ("transverse_modes", c.transverse))
        ]
        _, dynamic, dynamic_s = run_scene(_scene_without(path, base + stated, []))
    runs = []
    for na, nt in ladder:
        ov = counts(path, base, na, nt)
        _, res, s = simulate_file(path, ov)
        runs.append(((na, nt), res, s))
    ref = runs[-1][1]
    lines = [
        f"### {label} (`{path}`{', ' + ', '.join(base) if base else ''})",
        "",
        "chosen: "
        + "; ".join(
            f"{c.bar} {c.axial} + {c.transverse} (estimate {c.estimate:.2g}"
            + (f", the highest {c.quasi} quasi-static" if c.quasi else "")
            + (f", the highest {c.quasi_axial} axial quasi-static" if c.quasi_axial else "")
            + ")"
            for c in scene.bases
        ),
        "",
        "| model | "
        + " | ".join(ref.output_names[i] for i in range(len(ref.output_names)) if ref.output_names[i] != "closure")
        + " | IDAS steps | integration s |",
        "|---|" + "---|" * (len([n for n in ref.output_names if n != "closure"]) + 2),
    ]

    def row(name, res, s):
        e = errors(res, ref)
        return f"| {name} | " + " | ".join(f"{v:.2e}" for v in e.values()) + f" | {res.steps} | {s:.2f} |"

    lines.append(row("chosen (accuracy %g)" % scene.simulation.accuracy, chosen, chosen_s))
    if dynamic is not None:
        lines.append(row("chosen counts, every function dynamic", dynamic, dynamic_s))
    for (na, nt), res, s in runs:
        lines.append(row(f"{na} + {nt} every bar" + (" (reference)" if res is ref else ""), res, s))
    return "\n".join(lines)


def _scene_without(path: str, base: list[str], absent: list[str]):
    """The scene with the keys ``absent`` removed from the file's tables (the loader then
    chooses those counts)."""
    import tomllib

    from symgen.scene.loader import apply_overrides, parse_scene, scene_hash

    raw = apply_overrides(tomllib.loads((ROOT / path).read_text()), base, str(ROOT / path))
    for key in absent:
        _, bar, field = key.split(".")
        for b in raw["bodies"]:
            if b.get("name") == bar:
                b.pop(field, None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return parse_scene(raw, str(ROOT / path), scene_hash(raw))


def run_scene(scene):
    mech = mechanism(scene)
    tic = time.perf_counter()
    res = sim.simulate(mech)
    return mech, res, time.perf_counter() - tic


INTRO = (
    "## Accuracy-driven bases (issue 19, item 1)\n\n"
    "No mode counts in the scene: symgen chooses each bar's from `simulation.accuracy` (0.01 here; "
    "`symgen/scene/bases.py`). Each table: max over the run |y - y_ref| / max |y_ref| per output, "
    "against symgen converged in its own counts (the richest rung, the same counts on every "
    "elastic bar; the rung before it says how converged it is), and the cost (IDAS steps, "
    "integration s: single runs on a shared machine). `python benchmarks/bench_bases.py [case]`."
)


def run(repeats: int = 1) -> str:
    return INTRO + "\n\n" + "\n\n".join(case(label) for label in CASES)


if __name__ == "__main__":
    labels = sys.argv[1:] or list(CASES)
    print("\n\n".join(case(label) for label in labels))
