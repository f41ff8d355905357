"""The model-form estimate (``symgen.numerics.model_form``) against the measured change of each
output between a von Karman run and an exact-bar run (``effects.strain = "exact"``) of the same
scene: the ratio estimate / measured of every output whose measured change is above 1e-4 of its
peak (docs/exact-bars.md lists the table).

    python benchmarks/bench_model_form.py            # all scenes
    python benchmarks/bench_model_form.py NAME ...   # some (names of SCENES)

The measured change is max |y_exact - y_vk| / max |y_vk| over the run; where a driver turns, both
signals are first low-passed below 50 cycles per turn (the axial ringing left out).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from symgen.api import mechanism  # noqa: E402
from symgen.apps.study import window_error  # noqa: E402
from symgen.numerics.model_form import model_form_estimate  # noqa: E402
from symgen.numerics.simulate import simulate  # noqa: E402

ACCURATE_SC = [
    "effects.strain=von_karman",
    "bodies.rod.axial_shapes=complete",
    "bodies.rod.axial_modes=3",
    "bodies.rod.transverse_modes=4",
]
SCENES = {
    "slider_crank_paper": ("tests/data/slider_crank_paper_si.toml", []),
    "slider_crank_example": ("examples/slider_crank.toml", ACCURATE_SC),
    "slewing_arm": ("tests/data/slewing_arm.toml", []),
    "four_bar": ("examples/four_bar.toml", []),
    "four_bar_tool": ("examples/four_bar_tool.toml", []),
    "five_bar": ("examples/five_bar.toml", []),
    "six_bar": ("examples/six_bar.toml", []),
    "motor_arm": ("examples/motor_arm.toml", []),
    "double_pendulum": ("examples/double_pendulum.toml", []),
    "four_bar_steel": ("benchmarks/scenes/four_bar_steel.toml", []),
    "slider_crank_steel": ("benchmarks/scenes/slider_crank_steel.toml", []),
}


def measure(name: str) -> list[tuple[str, float, float]]:
    path, over = SCENES[name]
    runs = {}
    for st in ("von_karman", "exact"):
        mech = mechanism(str(ROOT / path), over + [f"effects.strain={st}"])
        runs[st] = (mech, simulate(mech))
    mech, vk = runs["von_karman"]
    ex = runs["exact"][1]
    est = model_form_estimate(mech, vk)
    rate = max((abs(d.rate) for d in mech.scene.drivers), default=0.0)
    rows = []
    for j, out in enumerate(vk.output_names):
        a, b = vk.outputs[:, j], ex.outputs[:, j]
        if out == "closure" or len(a) != len(b) or not np.all(np.isfinite(b)):
            continue
        peak = np.abs(a).max()
        if peak == 0:
            continue
        if rate > 0:
            dt = float(vk.tau[1] - vk.tau[0])
            meas = window_error(b, a, dt, 50 * rate / (2 * math.pi), len(a))
        else:
            meas = float(np.abs(a - b).max() / peak)
        rows.append((out, est.outputs.get(out, 0.0), meas))
    print(f"{name}: bars {est.bars}", flush=True)
    for out, e, m in rows:
        ratio = e / m if m > 0 else float("inf")
        flag = "" if m < 1e-4 else ("  ok" if 0.5 <= ratio <= 2 else "  OUT")
        print(f"  {out:14s} estimate {e:.2e}  measured {m:.2e}  ratio {ratio:.2f}{flag}", flush=True)
    return rows


if __name__ == "__main__":
    for n in sys.argv[1:] or list(SCENES):
        measure(n)
