"""Quasi-static (residual-flexibility) transverse functions (issue 19 item 1, issue 20 item 2):
which modes set IDAS's steps, and what ``bodies.<name>.quasi_static_transverse`` saves.

    PYTHONPATH=. python benchmarks/bench_quasi_static.py measure      # steel slider-crank: steps vs functions
    PYTHONPATH=. python benchmarks/bench_quasi_static.py validation [scene ...]  # against the Exudyn references

``measure``: benchmarks/scenes/slider_crank_steel.toml (1 turn, 3 axial functions), the IDAS steps
and integration time with 1..6 transverse functions all dynamic, and with all but the first
quasi-static; with the undeformed and the quasi-static start. ``validation``: each validation
scene with the counts symgen chooses (no counts in the file), every function dynamic against the
functions above each bar's dynamic band (``BasisChoice.dynamic``) quasi-static (fewer where a
function would move an interior pin): per output max |symgen - ref| / peak |ref| against the
committed converged Exudyn reference, IDAS steps and integration seconds (single runs on a shared
machine: compare within a table). CPU: one scene at a time.
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
from symgen.errors import SceneError  # noqa: E402
from symgen.numerics import simulate as sim  # noqa: E402
from symgen.numerics.units import result_units  # noqa: E402
from symgen.scene import load_scene  # noqa: E402

STEEL = "benchmarks/scenes/slider_crank_steel.toml"
VALIDATION = ["slider_crank_steel_rest", "crank_rocker_steel", "slewing_arm", "double_pendulum_alu"]


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


def _quasi_overrides(path: str) -> list[str]:
    """bodies.<bar>.quasi_static_transverse for every bar: its functions above the dynamic band,
    fewer where one would move an interior pin (refused by the mechanism)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(str(ROOT / path))
    out: list[str] = []
    for b in scene.bases:
        k = max(b.transverse - b.dynamic[1], 0)
        while k > 0:
            try:
                _mech(path, out + [f"bodies.{b.bar}.quasi_static_transverse={k}"])
                break
            except SceneError:
                k -= 1
        if k:
            out.append(f"bodies.{b.bar}.quasi_static_transverse={k}")
    return out


def validation(names: list[str]) -> str:
    from bench_validation import read_reference, scene_path

    lines = []
    for name in names:
        path = str(scene_path(name).relative_to(ROOT))
        t_ref, ref = read_reference(name)
        quasi = _quasi_overrides(path)
        lines += [
            f"### {name} (`{path}`; quasi-static: {', '.join(q.split('.', 1)[1] for q in quasi) or 'none possible'})",
            "",
            "| model | " + " | ".join(ref) + " | IDAS steps | integration s |",
            "|---|" + "---|" * (len(ref) + 2),
        ]
        for label, ov in (("every function dynamic", []), ("above the dynamic band quasi-static", quasi)):
            if label != "every function dynamic" and not ov:
                continue
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
