"""Integration time per crank turn of both examples at rtol 1e-4, 1e-6, 1e-8 (atol = rtol/100),
with the IDAS step counts, and the error each tolerance leaves against rtol 1e-10 (same model).

Each example as written, and the slider-crank's accurate model (von Karman, complete axial
family, 3 axial + 4 transverse). CPU s of ``simulate`` (IDAS + output polish), medians of
repeats; the model is derived once (cached) and not timed here (see the derivation section).
Errors: every output except the closure residual, low-passed below 50 cycles per turn, max over
the whole run of |y - y_ref| / max |y_ref|, worst output named (``symgen study`` metric).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from symgen.api import mechanism  # noqa: E402
from symgen.numerics.simulate import simulate  # noqa: E402
from symgen.apps.study import window_error  # noqa: E402

RTOLS = (1e-4, 1e-6, 1e-8)
REF_RTOL = 1e-10
CASES = (
    ("slider-crank (seed model, 1+1)", "examples/slider_crank.toml", []),
    (
        "slider-crank (accurate, 3+4)",
        "examples/slider_crank.toml",
        [
            "effects.strain=von_karman",
            "bodies.rod.axial_shapes=complete",
            "bodies.rod.axial_modes=3",
            "bodies.rod.transverse_modes=4",
        ],
    ),
    ("four-bar (examples/four_bar.toml: 3 bars x 4+4, quasi-static start)", "examples/four_bar.toml", []),
)


def _run(path, sets, rtol, repeats):
    mech = mechanism(ROOT / path, [*sets, f"simulation.rtol={rtol:g}", f"simulation.atol={rtol / 100:g}"])
    cpu, res = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        res = simulate(mech)
        cpu.append(time.process_time() - t0)
    return res, statistics.median(cpu)


def run(repeats: int) -> str:
    out = [
        "## Integration time per crank turn vs tolerance",
        "",
        "CPU s of `simulate` per crank turn (two turns run), atol = rtol/100, medians of "
        f"{repeats}; error against the same model at rtol {REF_RTOL:g} (outputs low-passed below 50 "
        "cycles/turn, whole run, worst output).",
        "",
        "| scene | rtol | s per turn | IDAS steps per turn | error | worst output |",
        "|---|---|---|---|---|---|",
    ]
    for label, path, sets in CASES:
        ref, _ = _run(path, sets, REF_RTOL, 1)
        names = [n for n in ref.output_names if n != "closure"]
        dt = float(ref.tau[1] - ref.tau[0])
        turns = ref.tau[-1] / (2 * math.pi)
        for rtol in RTOLS:
            res, cpu = _run(path, sets, rtol, repeats)
            errs = {n: window_error(res.column(n), ref.column(n), dt, 50 / (2 * math.pi), len(ref.tau)) for n in names}
            worst = max(errs, key=errs.get)
            out.append(
                f"| {label} | {rtol:g} | {cpu / turns:.3f} | {res.steps / turns:.0f} | "
                f"{100 * errs[worst]:.2g} % | {worst} |"
            )
    out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(run(1))
