"""The quasi-static start as a fixed point of the held motion (session 10, an experiment, not in
symgen; docs/exact-bars.md, "A consistent quasi-static start").

symgen's start (start.quasi_static_start) holds the deformation's rates and accelerations at the
central differences of three quasi-static states solved with those rates and accelerations ZERO,
then solves the state at t0 once more holding them. Here the three states are themselves solved
holding the rates and accelerations of the motion through them (v + dt a, a), and that is
iterated to a fixed point: the three states then lie on one held motion, the bending's and the
axial amplitudes' (foreshortening included) alike. Compared at tau = 0 with the inextensible
model's start made the same way and its implemented start, on the oscillating arm of
tests/test_axial_qs_start_ringing.py (5 axial functions). Run from the repository root:
``python benchmarks/qs_start_fixed_point.py``. A negative result (session 10): the fixed point
converges (the held accelerations' change 1e-9 after 5 passes to lambda 1e5) but the dynamic bar's
start then differs from the inextensible one's made alike by a lambda-independent tip -3.6e-5,
torque +4.5e-4 (the implemented start: -1.3e-5 / +1.6e-4); benchmarks/qs_start_consistent.py has
the recipe that tends to the limit as 1/lambda.
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.qs_start_limit import mech, outs
from symgen.ir.records import CoordKind
from symgen.numerics.start import quasi_static, static_system


def fixed_point_start(m, iters=8, hscale=1.0):
    t0 = 0.0
    q1, v1, _, _, part = m.initial_state()  # the implemented start
    E = static_system(m, part).E
    h = m.driver_step(t0) * hscale
    vE = v1.copy()
    aE = np.zeros(m.n)
    # the implemented start's held accelerations: redo its differences
    states = {}
    hist = []
    for it in range(iters):
        for dt in (-h, 0.0, h):
            qq = q1.copy() if dt == 0.0 else states.get(0.0, q1).copy()
            for body, motion in m.driver_motions(t0 + dt).items():
                qq[m.info.coordinate(CoordKind.THETA, body)] = motion[0]
            qq[E] = (states.get(dt, q1))[E] if dt in states else q1[E] + dt * vE[E] + 0.5 * dt * dt * aE[E]
            qq = m.assemble(t0 + dt, qq, part)
            vv = m.velocities(t0 + dt, qq, v1, part)
            rates = vE + dt * aE if it else np.zeros(m.n)
            accs = aE if it else np.zeros(m.n)
            states[dt] = quasi_static(m, t0 + dt, qq, vv, part, rates=rates, accels=accs)[0]
        vnew = (states[h] - states[-h]) / (2 * h)
        anew = (states[h] - 2 * states[0.0] + states[-h]) / (h * h)
        ch = np.abs(anew[E] - aE[E]).max()
        vE[E], aE[E] = vnew[E], anew[E]
        vE[list(m.quasi)] = 0.0
        aE[list(m.quasi)] = 0.0
        hist.append(ch)
    q, v, _ = quasi_static(m, t0, states[0.0], m.velocities(t0, states[0.0], v1, part), part, rates=vE, accels=aE)
    return q, m.velocities(t0, q, v, part), hist


def main() -> None:
    mi = mech("inextensible", 1e3)
    qi, vi, *_ = mi.initial_state()
    oi = outs(mi, qi, vi)
    qf, vf, hist = fixed_point_start(mi)
    of = outs(mi, qf, vf)
    print(
        f"inextensible: fixed-point - implemented tip {of['tip'] - oi['tip']:+.3e} torque {of['torque'] - oi['torque']:+.3e}; changes {['%.1e' % c for c in hist]}",
        flush=True,
    )
    for lam in (1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10):
        m = mech("dynamic", lam)
        q1, v1, *_ = m.initial_state()
        o1 = outs(m, q1, v1)
        q2, v2, hist = fixed_point_start(m)
        o2 = outs(m, q2, v2)
        print(
            f"lam {lam:g}: implemented-inext tip {o1['tip'] - oi['tip']:+.3e} torque {o1['torque'] - oi['torque']:+.3e}"
            f" | fixed-point - inext fixed-point tip {o2['tip'] - of['tip']:+.3e} torque {o2['torque'] - of['torque']:+.3e}"
            f" ; changes {['%.1e' % c for c in hist]}",
            flush=True,
        )


if __name__ == "__main__":
    main()
