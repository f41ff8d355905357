"""Which held rates make a bent bar's quasi-static start tend to its inextensible limit (session 10,
an experiment, not in symgen; docs/exact-bars.md, "The consistent start, third step").

The oscillating arm of tests/test_axial_qs_start_ringing.py (5 axial functions, von Karman),
dynamic axial at lambda = 1e3 ... 1e10, against the inextensible model's start (symgen's, at tau 0):

1. ``oracle``: the dynamic bar's quasi-static state solved holding the inextensible start's own
   rates and accelerations (bending AND its dependent axial amplitudes', i.e. the constraint
   rates n' = 0, n'' = 0 at the inextensible start). If the two models agree in the limit this
   falls as 1/lambda; it does (tip 2.17e-6 / 2.17e-8 / 2.17e-10 at 1e4 / 1e6 / 1e8).
2. ``recipe``: what a start can do without the inextensible model: the bending's rates and
   accelerations the central differences of the zero-rate quasi-static states (as symgen's start),
   the axial amplitudes' rate and acceleration the central differences of axial-only quasi-static
   solves (bending fixed on its held motion g + dt g' + dt^2/2 g'') through the RE-SOLVED bending,
   the state solved again holding all of them, and the axial differences taken again through the
   new bending, iterated (4 times; the change in the axial acceleration falls ~200x per pass).
3. ``implemented``: symgen's start (axial rates from the zero-rate states): the lambda-independent
   offset (tip -1.3e-5, torque +1.6e-4).

Run from the repository root: ``python benchmarks/qs_start_consistent.py``.
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.qs_start_limit import AxialSystem, HeldSystem, held, mech, outs
from symgen.ir.records import CoordKind
from symgen.numerics.start import quasi_static, quasi_static_state


#: the differences' step in driver steps: at 1 (symgen's) the second differences of the stiff states
#: carry round-off amplified by lambda (recipe tip -3.3e-7 / -7.3e-6 / -3.2e-5 at 1e8 / 1e9 / 1e10); at 30
#: it is below 3e-9 to 1e10; at 300 the truncation shows (-2.6e-7 at 1e10)
H_SCALE = 30.0


def oracle_start(m, qi, vi, ai):
    part = m.initial_state()[4]
    q, v, _, _ = quasi_static_state(m, 0.0, qi.copy(), vi.copy(), part, rates=vi, accels=ai)
    return q, v


def recipe_start(m, iters=4):
    t0 = 0.0
    q1, v1, _, _, part = m.initial_state()
    G = list(m.info.indices(CoordKind.G))
    Fa = list(m.info.indices(CoordKind.F))
    S = HeldSystem(m, part)
    E = S.E
    A = AxialSystem(m, part, Fa, G)
    h = H_SCALE * m.driver_step(t0)
    # the bending's held rates and accelerations: central differences of the zero-rate states
    qs0, vs0, _ = quasi_static(m, t0, q1, v1, part)
    ends = []
    for dt in (-h, h):
        qq = qs0.copy()
        for body, motion in m.driver_motions(t0 + dt).items():
            qq[m.info.coordinate(CoordKind.THETA, body)] = motion[0]
        qq = m.assemble(t0 + dt, qq, part)
        ends.append(quasi_static(m, t0 + dt, qq, m.velocities(t0 + dt, qq, vs0, part), part)[0])
    v1 = v1.copy()
    v1[G] = (ends[1][G] - ends[0][G]) / (2 * h)
    acc = np.zeros(m.n)
    acc[G] = (ends[1][G] - 2 * qs0[G] + ends[0][G]) / h**2
    q2, v2 = q1.copy(), v1.copy()
    changes = []
    for _ in range(iters):
        fs = {}
        for k in (-1, 0, 1):
            dt = k * h
            qq = q2.copy()
            for body, motion in m.driver_motions(t0 + dt).items():
                qq[m.info.coordinate(CoordKind.THETA, body)] = motion[0]
            qq[G] = q2[G] + dt * v1[G] + 0.5 * dt * dt * acc[G]
            qq = m.assemble(t0 + dt, qq, part)
            vv = v2.copy()
            vv[G] = v1[G] + dt * acc[G]
            vv[Fa] = 0.0
            vv = m.velocities(t0 + dt, qq, vv, part)
            fs[k] = A.solve(m, t0 + dt, qq, vv, np.zeros(m.n))[0][Fa]
        vh = v1.copy()
        vh[Fa] = (fs[1] - fs[-1]) / (2 * h)
        ah = acc.copy()
        ah[Fa] = (fs[1] - 2 * fs[0] + fs[-1]) / h**2
        ah[[i for i in range(m.n) if i not in E]] = 0.0
        changes.append(float(np.abs(ah[Fa] - acc[Fa]).max()))
        q2, v2, _ = held(m, part, t0, q1, vh, ah, S)
        v2 = m.velocities(t0, q2, v2, part)
        acc = ah
    return q2, v2, changes


def main() -> None:
    mi = mech("inextensible", 1e3)
    qi, vi, *_ = mi.initial_state()
    ai = np.asarray(mi.accelerations(0.0, qi, vi)[0]).ravel()
    oi = outs(mi, qi, vi)
    for lam in (1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10):
        m = mech("dynamic", lam)
        row = []
        q1, v1, *_ = m.initial_state()
        for name, (q, v) in (
            ("implemented", (q1, v1)),
            ("oracle", oracle_start(m, qi, vi, ai)),
            ("recipe", recipe_start(m)[:2]),
        ):
            o = outs(m, q, v)
            row.append(f"{name} tip {o['tip'] - oi['tip']:+.2e} torque {o['torque'] - oi['torque']:+.2e}")
        print(f"lam {lam:g}: " + " | ".join(row), flush=True)


if __name__ == "__main__":
    main()
