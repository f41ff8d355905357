"""Hard cases and pruning (issue 5, sections 3-4), run through benchmarks/run.py.

1. Stiffness: IDAS steps and integration time vs lambda (1e3..1e9, mu = 0.495 fixed) on the
   seed's slider-crank with the accurate strain and basis family, quasi-static start, a quarter
   crank turn; the distance of eta_mid to the inextensible model (effects.axial =
   "inextensible", the lambda -> oo limit) and that model's own cost. Also IDAS with its BDF
   order capped at 2 (``max_order``, set here on the runner: not a symgen option), which shows
   why the steps grow like sqrt(lambda).
2. Pruning: ``symgen effects --measure`` on the accurate slider-crank (3 + 4 functions, one turn,
   outputs eta_mid and torque): error, steps, time and speed-up of each effect switched off, and
   the set ``--auto 1e-2`` picks.

Steps are deterministic; times are single runs (compare within a run).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from symgen.api import mechanism  # noqa: E402
from symgen.numerics import simulate as sim  # noqa: E402

SLIDER = str(ROOT / "examples" / "slider_crank.toml")
ACCURATE = [
    "effects.strain=von_karman",
    "bodies.rod.axial_shapes=complete",
    "initial.deformation=quasi-static",
    "effects.axial=true",
]  # the full axial dynamics at every lambda (not "auto")
LAMBDAS = (1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9)
WINDOW = ["simulation.cycles=0.25", "simulation.output_step=0.01"]


def _run(overrides, max_order=None):
    mech = mechanism(SLIDER, overrides)
    orig = sim.DaeRunner.__init__

    def init(self, *a, **k):
        orig(self, *a, **k)
        if max_order:
            self.opts["max_order"] = max_order

    sim.DaeRunner.__init__ = init
    try:
        tic = time.perf_counter()
        res = sim.simulate(mech)
        return res, time.perf_counter() - tic
    finally:
        sim.DaeRunner.__init__ = orig


def stiffness(na: int, nt: int) -> str:
    common = ACCURATE + [f"bodies.rod.axial_modes={na}", f"bodies.rod.transverse_modes={nt}"] + WINDOW
    ref, ref_s = _run(common + ["effects.axial=inextensible"])
    eta, peak = ref.column("eta_mid"), np.abs(ref.column("eta_mid")).max()
    lines = [
        f"**{na} axial + {nt} transverse functions** (quarter turn, rtol 1e-8):",
        "",
        "| lambda | max abs(eta_mid - inextensible) / peak | IDAS steps | integration s | "
        "steps, BDF order <= 2 | diff, order <= 2 |",
        "|---|---|---|---|---|---|",
    ]
    for lam in LAMBDAS:
        res, s = _run(common + [f"bodies.rod.lambda={lam:g}"])
        res2, _ = _run(common + [f"bodies.rod.lambda={lam:g}"], max_order=2)
        d = np.abs(res.column("eta_mid") - eta).max() / peak
        d2 = np.abs(res2.column("eta_mid") - eta).max() / peak
        lines.append(f"| {lam:.0e} | {d:.2e} | {res.steps} | {s:.2f} | {res2.steps} | {d2:.2e} |")
    lines.append(f"| inextensible | (reference) | {ref.steps} | {ref_s:.2f} | | |")
    return "\n".join(lines)


def pruning() -> str:
    from symgen.apps.effects import auto_effects, table

    overrides = ACCURATE + ["bodies.rod.axial_modes=3", "bodies.rod.transverse_modes=4"]
    with tempfile.TemporaryDirectory() as d:
        report = auto_effects(
            SLIDER, overrides, tol=1e-2, output=Path(d) / "pruned.toml", outputs=["eta_mid", "torque"]
        )
    return "```\n" + table(report) + "\n```"


def run(repeats: int = 3) -> str:
    parts = [
        "## Hard cases: stiffness (steps vs lambda) and the inextensible model",
        "",
        "Seed slider-crank, accurate strain and basis family, mu = 0.495, quasi-static start. "
        'The full axial dynamics (`effects.axial = true`) converge to `effects.axial = "inextensible"` '
        "like 1/lambda with any basis (the strain energy is that of the strain the axial basis can "
        'carry: no locking; the default `"auto"` makes such stiff bars quasi-static). IDAS steps grow like '
        "sqrt(lambda): the undamped stiff axial modes keep IDAS's BDF steps near 1/omega_axial at "
        "orders above 2 (capping the order at 2 makes the count almost independent of lambda, but "
        "costs steps at moderate lambda). The inextensible model costs the same at every lambda.",
        "",
    ]
    for na, nt in ((5, 2), (3, 4)):
        parts += [stiffness(na, nt), ""]
    parts += [
        "## Pruning: what each effect costs (`symgen effects --measure`, `--auto 1e-2`)",
        "",
        "Accurate slider-crank with its full axial dynamics (3 + 4, one turn, outputs eta_mid and torque); speed-up = "
        "integration time of the scene as it is / without the effect.",
        "",
        pruning(),
        "",
    ]
    return "\n".join(parts)


if __name__ == "__main__":
    print(run())
