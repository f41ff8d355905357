"""Tolerances from the accuracy (issues 19 and 20): the time-integration error of each solver
against rtol and atol, on the validation scenes and the examples, and the rule
``symgen.policy.tolerances`` chosen from it.

Time-integration error of a run: max over the run |y - y_ref| / max |y_ref|, the worst output
(closure residuals left out), against a converged run of the same model: the C Radau IIA solver at
rtol 1e-10, atol 1e-16 (for IDAS runs IDAS's own at rtol 1e-10, atol 1e-12 where IDAS's model
differs: quasi-static transverse functions are IDAS-only). atol = rtol x the ratio shown.

Then each validation scene as a user runs it (``symgen.api.simulate_scene``, strain auto, no
estimate) from a copy without its rtol/atol lines (the derived defaults) beside the scene as
committed: error against its Exudyn reference, steps, integration CPU (median of 3); and the
error estimate's time part (the run against itself at 10x tighter tolerances, x 1.25) against
the run's true time error."""

from __future__ import annotations

import re
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
RATIOS = (1e-2, 1e-4, 1e-6)
VALIDATION = (
    "crank_rocker_steel",
    "double_pendulum_alu",
    "five_bar_elastic",
    "six_bar_soft",
    "slewing_arm",
    "slider_crank_paper",
    "slider_crank_steel_rest",
    "slider_crank_torque_soft",
)
#: examples (the double pendulum of steel bars is left out: chaotic, 2.6 million steps converged)
EXAMPLES = ("five_bar", "four_bar", "four_bar_tool", "inverted_slider_crank", "motor_arm", "six_bar", "slider_crank")


def _path(name: str) -> Path:
    p = ROOT / "benchmarks" / "validation" / f"{name}.toml"
    return p if p.exists() else ROOT / "examples" / f"{name}.toml"


def _without_tolerances(src: Path, folder: Path) -> Path:
    dst = folder / src.name
    dst.write_text(re.sub(r"(?m)^(rtol|atol)\s*=.*\n", "", src.read_text()))
    return dst


def _run(mech, solver: str, rtol=None, atol=None):
    from symgen.numerics.csolver import simulate_c
    from symgen.numerics.simulate import simulate

    return simulate(mech, rtol=rtol, atol=atol) if solver == "idas" else simulate_c(mech, rtol=rtol, atol=atol)


def _worst(mech, out: np.ndarray, ref: np.ndarray) -> tuple[float, str]:
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    worst, name = 0.0, ""
    k = min(len(out), len(ref))
    for j, n in enumerate(mech.info.outputs):
        peak = np.abs(ref[:, j]).max()
        if kinds.get(n) == "closure_residual" or peak == 0:
            continue
        e = float(np.abs(out[:k, j] - ref[:k, j]).max() / peak)
        if e > worst:
            worst, name = e, n
    return worst, name


def grid(names=VALIDATION + EXAMPLES, rtols=RTOLS, ratios=RATIOS) -> list[dict]:
    """Records of the error grid (scene, solver, rtol, ratio, err, worst, steps)."""
    from symgen.api import mechanism

    recs = []
    for name in names:
        mech = mechanism(_path(name))
        refs = {"c": _run(mech, "c", 1e-10, 1e-16).outputs}
        try:
            refs["idas"] = _run(mech, "idas", 1e-10, 1e-12).outputs
        except Exception:  # IDAS's corrector can fail at 1e-10: the C reference then
            refs["idas"] = refs["c"]
        for solver in ("idas", "c"):
            for ratio in ratios:
                for rtol in rtols:
                    try:
                        r = _run(mech, solver, rtol, rtol * ratio)
                    except Exception as err:
                        recs.append(dict(scene=name, solver=solver, rtol=rtol, ratio=ratio, failed=str(err)[:60]))
                        continue
                    err, worst = _worst(mech, r.outputs, refs[solver])
                    recs.append(
                        dict(scene=name, solver=solver, rtol=rtol, ratio=ratio, err=err, worst=worst, steps=r.steps)
                    )
    return recs


def grid_markdown(recs: list[dict]) -> str:
    by: dict = {}
    for d in recs:
        by.setdefault((d["scene"], d["solver"], d["ratio"]), {})[d["rtol"]] = d
    rtols = sorted({d["rtol"] for d in recs}, reverse=True)
    lines = [
        "| scene | solver | atol / rtol | " + " | ".join(f"rtol {r:g}" for r in rtols) + " |",
        "|---|---|---|" + "---|" * len(rtols),
    ]
    for key in sorted(by):
        cells = []
        for r in rtols:
            d = by[key].get(r)
            cells.append("" if d is None else "failed" if "err" not in d else f"{d['err']:.1e} ({d['steps']})")
        lines.append(f"| {key[0]} | {key[1]} | {key[2]:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def as_users_run(names=VALIDATION, repeats: int = 3) -> list[dict]:
    """Each validation scene as committed and without its tolerances, IDAS and --solver c."""
    from symgen.api import simulate_scene
    from symgen.numerics.units import result_units
    from symgen.scene import load_scene
    import bench_validation as bv

    recs = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            src = _path(name)
            t_ref, ref = bv.read_reference(name)
            for label, path in (("as committed", src), ("derived", _without_tolerances(src, Path(tmp)))):
                scene = load_scene(path)
                for solver in ("idas", "c"):
                    cpu, r = [], None
                    for _ in range(repeats):
                        t0 = time.process_time()
                        r = simulate_scene(scene, solver=solver)
                        cpu.append(time.process_time() - t0)
                    t, vals = result_units(scene).convert(r.tau, r.outputs)
                    errs = {
                        k: float(
                            np.max(np.abs(np.interp(t_ref, t, vals[:, list(r.output_names).index(k)]) - y))
                            / np.max(np.abs(y))
                        )
                        for k, y in ref.items()
                    }
                    rtol, atol = scene.simulation.tolerances(solver)
                    recs.append(
                        dict(
                            scene=name,
                            label=label,
                            solver=solver,
                            rtol=rtol,
                            atol=atol,
                            steps=r.steps,
                            cpu_ms=1e3 * statistics.median(cpu),
                            errs=errs,
                        )
                    )
    return recs


def users_markdown(recs: list[dict]) -> str:
    lines = [
        "| scene | tolerances | solver | rtol / atol | error vs reference (worst output) | steps | CPU ms |",
        "|---|---|---|---|---|---|---|",
    ]
    for d in recs:
        k = max(d["errs"], key=d["errs"].get)
        lines.append(
            f"| {d['scene']} | {d['label']} | {d['solver']} | {d['rtol']:.2g} / {d['atol']:.2g} | "
            f"{100 * d['errs'][k]:.3g} % ({k}) | {d['steps']} | {d['cpu_ms']:.0f} |"
        )
    return "\n".join(lines)


def time_part(names=VALIDATION + EXAMPLES) -> list[dict]:
    """At the derived tolerances: each run's true time error (against the converged run of its
    solver) and the estimate's time part, the rerun at 10x tighter tolerances (x 1.25), and the
    a-priori bound (30 x rtol + atol / peak)."""
    from symgen.api import mechanism
    from symgen.numerics import error_estimate as ee

    recs = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            mech = mechanism(_without_tolerances(_path(name), Path(tmp)))
            kinds = {o.name: o.kind for o in mech.scene.outputs}
            for solver in ("idas", "c"):
                ref = _run(mech, solver, 1e-10, 1e-16 if solver == "c" else 1e-12)
                rtol, atol = mech.scene.simulation.tolerances(solver)
                r = _run(mech, solver)
                err, worst = _worst(mech, r.outputs, ref.outputs)
                j = list(mech.info.outputs).index(worst)
                true = float(
                    np.abs(r.outputs[:, j] - ref.outputs[: len(r.outputs), j]).max() / np.abs(ref.outputs[:, j]).max()
                )
                rerun = ee._tighter_run(mech, r, rtol, atol)[worst]
                bound = ee.time_integration_part(r, rtol, atol, None, kinds)[worst]
                recs.append(
                    dict(
                        scene=name,
                        solver=solver,
                        rtol=rtol,
                        atol=atol,
                        steps=r.steps,
                        worst=worst,
                        true=true,
                        rerun=rerun,
                        bound=bound,
                    )
                )
    return recs


def time_markdown(recs: list[dict]) -> str:
    lines = [
        "| scene | solver | rtol / atol | steps | time error (worst output) | estimate's time part (rerun) | ratio | a-priori bound |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for d in recs:
        lines.append(
            f"| {d['scene']} | {d['solver']} | {d['rtol']:.2g} / {d['atol']:.2g} | {d['steps']} | "
            f"{d['true']:.1e} ({d['worst']}) | {d['rerun']:.1e} | {d['rerun'] / d['true']:.2f} | {d['bound']:.1e} |"
        )
    return "\n".join(lines)


def run(repeats: int = 3) -> str:
    from symgen.policy import TOLERANCES

    warnings.simplefilter("ignore")
    rule = ", ".join(
        f"{s}: rtol = {TOLERANCES.rtol_factor(s):g} x accuracy, atol = {TOLERANCES.atol_factor(s):g} x rtol"
        for s in ("idas", "c")
    )
    return "\n\n".join(
        [
            "## Tolerances from the accuracy (issues 19, 20)",
            f"The rule (`symgen.policy.tolerances`, a scene that states neither rtol nor atol): {rule}.",
            "### Time-integration error against rtol and atol/rtol (errors, steps in brackets)",
            grid_markdown(grid()),
            "### The estimate's time part at the derived tolerances",
            time_markdown(time_part()),
            "### The validation scenes as users run them: as committed and with the derived tolerances",
            users_markdown(as_users_run(repeats=repeats)),
        ]
    )


if __name__ == "__main__":
    print(run())
