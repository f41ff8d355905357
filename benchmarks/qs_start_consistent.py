"""A bent bar's quasi-static start against its inextensible limit (docs/exact-bars.md, "The
consistent start, landed"; session 11).

The oscillating arm of tests/test_axial_qs_start_ringing.py (5 axial functions, von Karman),
dynamic axial at lambda = 1e3 ... 1e10, against the inextensible model's start (symgen's, at tau 0),
the tip and the driver torque at tau = 0:

1. ``implemented``: symgen's start (``start.quasi_static_start``: the axial amplitudes' rates and
   accelerations along the bending's held motion through the state it solves).
2. ``oracle``: the dynamic bar's quasi-static state solved holding the inextensible start's own
   rates and accelerations (bending and its dependent axial amplitudes', i.e. the constraint rates
   n' = 0, n'' = 0 at the inextensible start): the two models agree in the limit if this falls as
   1/lambda (tip 2.17e-6 / 2.17e-8 / 2.17e-10 at 1e4 / 1e6 / 1e8).

Measured (session 11): implemented tip +1.27e-4 ... +1.12e-8 at lambda 1e3 ... 1e7 (1/lambda),
+2.1e-10 / +2.9e-9 / -5.2e-8 at 1e8 / 1e9 / 1e10 (round-off of the second differences). The
experiments that found it (axial-only solves by hand, a fixed point of the three states) were
``benchmarks/qs_start_limit.py`` and ``benchmarks/qs_start_fixed_point.py`` on branch wt-qsb
(3253bf3). Run from the repository root: ``python benchmarks/qs_start_consistent.py``.
"""

import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symgen.numerics.mechanism import Mechanism, load_mechanism
from symgen.numerics.start import quasi_static_state
from tests.test_axial_qs_start_ringing import ARM

warnings.simplefilter("ignore")
TMP = Path(tempfile.mkdtemp())


def mech(axial: str, lam: float) -> Mechanism:
    p = TMP / f"arm_{lam:g}_{axial}.toml"
    p.write_text(ARM.replace("LAMBDA", repr(lam)).replace("AXIAL_MODES", "5").replace("AXIAL", axial))
    return load_mechanism(p)


def outs(m: Mechanism, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
    a, lam = m.accelerations(0.0, q, v)
    return dict(zip(m.info.outputs, np.array(m.f["out"](0.0, q, v, a, lam, m.p)).ravel()))


def main() -> None:
    mi = mech("inextensible", 1e3)
    qi, vi, *_ = mi.initial_state()
    ai = np.asarray(mi.accelerations(0.0, qi, vi)[0]).ravel()
    oi = outs(mi, qi, vi)
    for lam in (1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10):
        m = mech("dynamic", lam)
        q1, v1, _, _, part = m.initial_state()
        qo, vo, _, _ = quasi_static_state(m, 0.0, qi.copy(), vi.copy(), part, rates=vi, accels=ai)
        row = []
        for name, (q, v) in (("implemented", (q1, v1)), ("oracle", (qo, vo))):
            o = outs(m, q, v)
            row.append(f"{name} tip {o['tip'] - oi['tip']:+.2e} torque {o['torque'] - oi['torque']:+.2e}")
        print(f"lambda {lam:g}: " + " | ".join(row), flush=True)


if __name__ == "__main__":
    main()
