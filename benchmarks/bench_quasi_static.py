"""Quasi-static (residual-flexibility) transverse functions (issue 19 item 1, issue 20 item 2):
which modes set IDAS's steps, and what ``bodies.<name>.quasi_static_transverse`` saves.

    PYTHONPATH=. python benchmarks/bench_quasi_static.py measure      # steel slider-crank: steps vs functions
    PYTHONPATH=. python benchmarks/bench_quasi_static.py validation [scene ...]  # against the Exudyn references

``measure``: benchmarks/scenes/slider_crank_steel.toml (1 turn, 3 axial functions), the IDAS steps
and integration time with 1..6 transverse functions all dynamic, and with all but the first
quasi-static; with the undeformed and the quasi-static start. ``validation``: each validation
scene with its defaults (symgen chooses the counts and the quasi-static functions,
``symgen.scene.bases.quasi_choice``) against the same counts every function dynamic: per output
max |symgen - ref| / peak |ref| against the committed converged Exudyn reference, IDAS steps and
integration seconds (single runs on a shared machine: compare within a table). CPU: one scene at
a time.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from symgen.api import mechanism  # noqa: E402
from symgen.numerics import simulate as sim  # noqa: E402
from symgen.numerics.units import result_units  # noqa: E402
from symgen.scene import load_scene  # noqa: E402

STEEL = "benchmarks/scenes/slider_crank_steel.toml"
VALIDATION = [
    "slider_crank_steel_rest",
    "slider_crank_paper",
    "crank_rocker_steel",
    "slewing_arm",
    "double_pendulum_alu",
    "five_bar_elastic",
    "six_bar_soft",
    "slider_crank_torque_soft",
]


def _mech(path: str, overrides: list[str]):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return mechanism(str(ROOT / path), overrides)


def _run(path: str, overrides: list[str]):
    mech = _mech(path, overrides)
    tic = time.perf_counter()
    res = sim.simulate(mech)
    return mech, res, time.perf_counter() - tic


def measure() -> str:
    base = ["simulation.cycles=1", "bodies.rod.axial_modes=3"]
    lines = [
        f"### Steps vs transverse functions (`{STEEL}`, 1 turn, 3 axial functions, rtol 1e-6)",
        "",
        "| transverse | quasi-static | start | IDAS steps | integration s | rod_mid vs all dynamic |",
        "|---|---|---|---|---|---|",
    ]
    for nt in (1, 2, 3, 4, 6):
        for start in ("undeformed", "quasi-static"):
            ov = base + [f"bodies.rod.transverse_modes={nt}"]
            if start == "quasi-static":
                ov.append("initial.deformation=quasi-static")
            ref = None
            for k in sorted({0, nt - 1}):
                _, res, s = _run(STEEL, ov + [f"bodies.rod.quasi_static_transverse={k}"])
                if ref is None:
                    ref = res
                y, r = res.column("rod_mid"), ref.column("rod_mid")
                err = float(np.abs(y - r).max() / np.abs(r).max())
                lines.append(f"| {nt} | {k} | {start} | {res.steps} | {s:.2f} | {err:.2e} |")
                print(lines[-1], flush=True)
    return "\n".join(lines)


def _dynamic_overrides(path: str) -> tuple[list[str], list[str]]:
    """(every function dynamic, symgen's choice as text): ``quasi_static_transverse = 0`` stated
    on every elastic bar (a stated value is never chosen over), and the choice
    (``BasisChoice.quasi``) of the scene as it is."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(str(ROOT / path))
    dynamic = [f"bodies.{b.bar}.quasi_static_transverse=0" for b in scene.bases]
    chosen = [f"{b.bar} {b.quasi} of {b.transverse}" for b in scene.bases if b.quasi]
    return dynamic, chosen


def validation(names: list[str]) -> str:
    """Each validation scene with its defaults (no counts: symgen chooses the counts and, from the
    coupled modes, the quasi-static functions) against the same counts with every function
    dynamic; per output max over the run |symgen - ref| / peak |ref| against the committed
    converged Exudyn reference, IDAS steps, integration s. A scene where symgen chooses no
    quasi-static function runs once (both rows are the same run)."""
    from bench_validation import read_reference, scene_path

    lines = []
    for name in names:
        path = str(scene_path(name).relative_to(ROOT))
        t_ref, ref = read_reference(name)
        dynamic, chosen = _dynamic_overrides(path)
        lines += [
            f"### {name} (`{path}`; quasi-static: {', '.join(chosen) or 'none chosen'})",
            "",
            "| model | " + " | ".join(ref) + " | IDAS steps | integration s |",
            "|---|" + "---|" * (len(ref) + 2),
        ]
        rows = [("every function dynamic", dynamic)] + ([("symgen's choice (default)", [])] if chosen else [])
        for label, ov in rows:
            mech, res, s = _run(path, ov)
            t, vals = result_units(mech.scene).convert(res.tau, res.outputs)
            errs = []
            for k, r in ref.items():
                y = np.interp(t_ref, t, vals[:, res.output_names.index(k)])
                errs.append(f"{float(np.max(np.abs(y - r)) / np.max(np.abs(r))):.2e}")
            lines.append(f"| {label} | " + " | ".join(errs) + f" | {res.steps} | {s:.2f} |")
            print(lines[-1], flush=True)
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "measure"
    if what == "measure":
        print(measure())
    else:
        print(validation(sys.argv[2:] or VALIDATION))
