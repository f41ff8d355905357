"""Faster paths of the integration, measured against the default on both examples.

Every variant integrates the same model and start as the default (except the quasi-static
start, which changes the start: no start-up ringing) and is compared with the default path at
rtol 1e-10: every output except the closure residual, low-passed below 50 cycles per turn, max
over the whole run of |y - y_ref| / max |y_ref|, worst output named. CPU s of ``simulate``
for two turns, medians of repeats.

Variants
--------
default          : IDAS, outputs polished and recorded chunk by chunk
                   with mapped CasADi calls (the default since the benchmark of this section)
jit              : CasADi JIT of the integrator's functions (``jit``, shell compiler, -O1)
csparse          : IDAS's Newton linear solver CSparse instead of CasADi's dense QR
axial error control off : ``simulate(axial_atol=1e3)``: IDAS does not resolve the start-up
                   ringing of the stiff axial modes (BDF damps it numerically)
quasi-static start : ``initial.deformation = "quasi-static"`` (the four-bar already has it)
long chunks      : 256 outputs per IDAS call instead of 64 (fewer integrator set-ups)
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import symgen.numerics.simulate as S  # noqa: E402
from symgen.api import mechanism  # noqa: E402
from symgen.apps.study import window_error  # noqa: E402

RTOLS = (1e-4, 1e-6)
CASES = (
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
    ("four-bar (as written)", "examples/four_bar.toml", []),
)


class _Opts(S.DaeRunner):
    extra: dict = {}

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.opts.update(self.extra)


def _variants():
    jit = {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O1"], "verbose": False}}
    return [
        ("default", {}, [], {}, None),
        ("jit", {}, [], jit, None),
        ("csparse", {}, [], {"linear_solver": "csparse"}, None),
        ("axial error control off", {"axial_atol": 1e3}, [], {}, None),
        ("quasi-static start", {}, ['initial.deformation="quasi-static"'], {}, None),
        ("long chunks (256 outputs per IDAS call)", {}, [], {}, 256),
    ]


def _timed(mech, repeats, kw, extra, chunk):
    old_runner, old_chunk = S.DaeRunner, S.CHUNK
    _Opts.extra = extra
    S.DaeRunner = _Opts if extra else old_runner
    S.CHUNK = chunk or old_chunk
    try:
        cpu, res = [], None
        for _ in range(repeats):
            t0 = time.process_time()
            res = S.simulate(mech, **kw)
            cpu.append(time.process_time() - t0)
    finally:
        S.DaeRunner, S.CHUNK = old_runner, old_chunk
    return res, statistics.median(cpu)


def run(repeats: int) -> str:
    out = [
        "## Faster paths of the integration",
        "",
        "rtol 1e-4 and 1e-6 (atol = rtol/100), two turns, CPU s of `simulate`, medians of "
        f"{repeats}; error against "
        "the default path at rtol 1e-10 (low-passed below 50 cycles/turn, whole run, worst output).",
        "",
        "| scene | rtol | path | CPU s | vs default | IDAS steps | error | worst output |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (label, path, sets), rtol in [(c, r) for c in CASES for r in RTOLS]:
        base = [*sets, f"simulation.rtol={rtol:g}", f"simulation.atol={rtol / 100:g}"]
        label = f"{label} | {rtol:g}"
        ref, _ = _timed(
            mechanism(ROOT / path, [*sets, "simulation.rtol=1e-10", "simulation.atol=1e-12"]), 1, {}, {}, None
        )
        names = [n for n in ref.output_names if n != "closure"]
        dt = float(ref.tau[1] - ref.tau[0])
        t_default = None
        for name, kw, more, extra, chunk in _variants():
            mech = mechanism(ROOT / path, [*base, *more])
            try:
                res, cpu = _timed(mech, repeats, kw, extra, chunk)
            except Exception as err:
                out.append(f"| {label} | {name} | failed: {str(err)[:80]} | | | | |")
                continue
            t_default = cpu if t_default is None else t_default
            errs = {n: window_error(res.column(n), ref.column(n), dt, 50 / (2 * math.pi), len(ref.tau)) for n in names}
            worst = max(errs, key=errs.get)
            out.append(
                f"| {label} | {name} | {cpu:.3f} | {t_default / cpu:.2f}x | {res.steps} | "
                f"{100 * errs[worst]:.2g} % | {worst} |"
            )
    out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(run(1))
