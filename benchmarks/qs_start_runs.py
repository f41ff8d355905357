"""The consistent quasi-static start in whole runs (session 11; docs/exact-bars.md, "The consistent
start, landed"): the oscillating arm of tests/test_axial_qs_start_ringing.py, 5 dynamic axial
functions, to tau 6 at IDAS rtol 1e-10 / atol 1e-13 against the inextensible run (tip and torque,
max difference over the run; IDAS steps), and the examples that start quasi-statically (IDAS steps
of ``simulate`` at their defaults without the estimate, and the start-up ringing over the first
0.4 tau: the residual of a quartic fit, of each output's peak). Run from the repository root, once
per checkout to compare starts: ``python benchmarks/qs_start_runs.py [arm|examples]``.
"""

import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symgen.api import mechanism
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from tests.test_axial_qs_start_ringing import ARM

EXAMPLES = ("four_bar", "five_bar", "four_bar_tool", "six_bar", "inverted_slider_crank")


def arm() -> None:
    tmp = Path(tempfile.mkdtemp())

    def scene(axial: str, lam: float) -> str:
        p = tmp / f"arm_{axial}_{lam:g}.toml"
        p.write_text(ARM.replace("LAMBDA", repr(lam)).replace("AXIAL_MODES", "5").replace("AXIAL", axial))
        return str(p)

    ref = simulate(load_mechanism(scene("inextensible", 1e3)), t_end=6.0, rtol=1e-10, atol=1e-13)
    for lam in (1e4, 1e5, 1e6):
        r = simulate(load_mechanism(scene("dynamic", lam)), t_end=6.0, rtol=1e-10, atol=1e-13)
        n = min(len(r.tau), len(ref.tau))
        d = {
            o: float(np.abs(np.asarray(r.column(o))[1:n] - np.asarray(ref.column(o))[1:n]).max())
            for o in ("tip", "torque")
        }
        print(
            f"lambda {lam:g}: IDAS steps {r.steps} (inextensible {ref.steps}), "
            f"tip {d['tip']:.3g}, torque {d['torque']:.3g}",
            flush=True,
        )


def examples() -> None:
    for name in EXAMPLES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mech = mechanism(f"examples/{name}.toml")
        res = simulate(mech)
        tau = np.asarray(res.tau)
        w = tau < 0.4
        ring = {}
        for o in mech.info.outputs:
            y = np.asarray(res.column(o))
            fit = np.polyval(np.polyfit(tau[w], y[w], 4), tau[w])
            ring[o] = f"{np.abs(y[w] - fit).max() / max(np.abs(y).max(), 1e-300):.1e}"
        print(f"{name}: IDAS steps {res.steps}, start-up ringing {ring}", flush=True)


if __name__ == "__main__":
    what = sys.argv[1:] or ["arm", "examples"]
    for w in what:
        {"arm": arm, "examples": examples}[w]()
