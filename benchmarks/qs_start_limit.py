"""The quasi-static start against its inextensible limit away from a dead point (session 9, an
experiment, not in symgen; docs/exact-bars.md, "A consistent quasi-static start").

The oscillating arm of tests/test_axial_qs_start_ringing.py (5 axial functions), started
quasi-statically with the axial dynamics kept, against the inextensible model's start: the tip and
the driver torque at tau = 0, for the start symgen makes (the deformation's rates and accelerations
held at the central differences of the quasi-static states) and for a start whose axial amplitudes'
rate and acceleration are taken along the bending's held motion through the re-solved state
(axial-only quasi-static solves with the bending fixed and its acceleration free at t0 - h, t0,
t0 + h), the deformation then re-solved holding them. Run from the repository root:
``python benchmarks/qs_start_limit.py``. Measured (session 9): implemented tip - limit -1.19e-5 /
-1.32e-5 / -1.79e-5 at lambda 1e5 / 1e7 / 1e9; along the held motion +1.19e-6 / -1.54e-7 /
-4.9e-6 (round-off at 1e9).
"""

import sys
import tempfile
import warnings
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symgen.ir.records import CoordKind
from symgen.numerics.mechanism import load_mechanism
from tests.test_axial_qs_start_ringing import ARM

warnings.simplefilter("ignore")
TMP = Path(tempfile.mkdtemp())


class HeldSystem:
    """quasi-static system with the independent amplitudes' rates and accelerations given."""

    def __init__(self, mech, part):
        D = list(part.dep)
        self.E = [i for i in mech.info.elastic if i not in D]
        R = sorted(set(mech.rigid) | set(D))
        nE, nD, self.nR = len(self.E), len(D), len(R)
        u = ca.SX.sym("u", nE + 2 * nD + self.nR + mech.m)
        t = ca.SX.sym("t")
        q0 = ca.SX.sym("q0", mech.n)
        v0 = ca.SX.sym("v0", mech.n)
        a0 = ca.SX.sym("a0", mech.n)
        q, v, a = ca.SX(q0), ca.SX(v0), ca.SX(a0)
        for k, i in enumerate(self.E):
            q[i] = u[k]
        for k, i in enumerate(D):
            q[i] = u[nE + k]
            v[i] = u[nE + nD + k]
        for k, i in enumerate(R):
            a[i] = u[nE + 2 * nD + k]
        lam = u[nE + 2 * nD + self.nR :]
        args = [t, q, v, a, lam, mech.p]
        F = ca.vertcat(mech.f["phi"](*args), mech.f["phid"](*args), mech.f["res"](*args), mech.f["phidd"](*args))
        self.fun = ca.Function("held", [t, q0, v0, a0, u], [F, ca.jacobian(F, u), q, v, a])
        self.D = D


def held(mech, part, t, q, v, a, sys_):
    E, D = sys_.E, sys_.D
    u = np.concatenate([q[E], q[D], v[D], np.zeros(sys_.nR), np.zeros(mech.m)])
    for _ in range(60):
        F, J, _, _, _ = sys_.fun(t, q, v, a, u)
        F = np.array(F).ravel()
        if np.abs(F).max() < 1e-12:
            break
        u = u - np.linalg.solve(np.array(J), F)
    _, _, qn, vn, an = sys_.fun(t, q, v, a, u)
    return np.array(qn).ravel(), np.array(vn).ravel(), np.array(an).ravel()


class AxialSystem:
    """unknowns [q_Fa (free positions), a_Fx (accelerations of the fixed ones), q_D, v_D, a_R, lam]"""

    def __init__(self, m, part, free, fixed):
        D = list(part.dep)
        R = sorted(set(m.rigid) | set(D))
        nf, nx, nD, nR = len(free), len(fixed), len(D), len(R)
        u = ca.SX.sym("u", nf + nx + 2 * nD + nR + m.m)
        t = ca.SX.sym("t")
        q0 = ca.SX.sym("q0", m.n)
        v0 = ca.SX.sym("v0", m.n)
        a0 = ca.SX.sym("a0", m.n)
        q, v, a = ca.SX(q0), ca.SX(v0), ca.SX(a0)
        o = 0
        for k, i in enumerate(free):
            q[i] = u[o + k]
        o += nf
        for k, i in enumerate(fixed):
            a[i] = u[o + k]
        o += nx
        for k, i in enumerate(D):
            q[i] = u[o + k]
            v[i] = u[o + nD + k]
        o += 2 * nD
        for k, i in enumerate(R):
            a[i] = u[o + k]
        o += nR
        lam = u[o:]
        args = [t, q, v, a, lam, m.p]
        F = ca.vertcat(m.f["phi"](*args), m.f["phid"](*args), m.f["res"](*args), m.f["phidd"](*args))
        self.fun = ca.Function("ax", [t, q0, v0, a0, u], [F, ca.jacobian(F, u), q, v, a])
        self.free, self.fixed, self.D, self.nR = free, fixed, D, nR

    def solve(self, m, t, q, v, a):
        u = np.concatenate(
            [q[self.free], np.zeros(len(self.fixed)), q[self.D], v[self.D], np.zeros(self.nR), np.zeros(m.m)]
        )
        for _ in range(60):
            F, J, _, _, _ = self.fun(t, q, v, a, u)
            F = np.array(F).ravel()
            if np.abs(F).max() < 1e-12:
                break
            u = u - np.linalg.solve(np.array(J), F)
        _, _, qn, vn, an = self.fun(t, q, v, a, u)
        return np.array(qn).ravel(), np.array(vn).ravel()


def fixed_start(m):
    t0 = 0.0
    q1, v1, a1, _, part = m.initial_state()  # the implemented start: rates and accelerations held
    G = [i for i in m.info.indices(CoordKind.G)]
    Fa = [i for i in m.info.indices(CoordKind.F)]
    S = HeldSystem(m, part)
    E = S.E
    if not set(Fa) <= set(E):
        return q1, v1
    A = AxialSystem(m, part, Fa, G)
    h = m.driver_step(t0)
    fs = {}
    for k in (-1, 0, 1):
        dt = k * h
        qq = q1.copy()
        for body, motion in m.driver_motions(t0 + dt).items():
            qq[m.info.coordinate(CoordKind.THETA, body)] = motion[0]
        qq[G] = q1[G] + dt * v1[G] + 0.5 * dt * dt * a1[G]
        qq = m.assemble(t0 + dt, qq, part)
        vv = v1.copy()
        vv[G] = v1[G] + dt * a1[G]
        vv[Fa] = 0.0
        vv = m.velocities(t0 + dt, qq, vv, part)
        fs[k] = A.solve(m, t0 + dt, qq, vv, np.zeros(m.n))[0][Fa]
    v2 = v1.copy()
    v2[Fa] = (fs[1] - fs[-1]) / (2 * h)
    acc = a1.copy()
    acc[Fa] = (fs[1] - 2 * fs[0] + fs[-1]) / h**2
    acc[[i for i in range(m.n) if i not in E]] = 0.0
    q2, v2, _ = held(m, part, t0, q1, v2, acc, S)
    return q2, m.velocities(t0, q2, v2, part)


def mech(axial, lam):
    p = TMP / f"arml_{lam:g}_{axial}.toml"
    p.write_text(ARM.replace("LAMBDA", repr(lam)).replace("AXIAL_MODES", "5").replace("AXIAL", axial))
    return load_mechanism(p)


def outs(m, q, v):
    a, l = m.accelerations(0.0, q, v)
    return dict(zip(m.info.outputs, np.array(m.f["out"](0.0, q, v, a, l, m.p)).ravel()))


def main() -> None:
    mi = mech("inextensible", 1e3)
    qi, vi, *_ = mi.initial_state()
    oi = outs(mi, qi, vi)
    for lam in (1e3, 1e5, 1e7, 1e9):
        m = mech("dynamic", lam)
        q1, v1, *_ = m.initial_state()
        o1 = outs(m, q1, v1)
        q2, v2 = fixed_start(m)
        o2 = outs(m, q2, v2)
        print(
            f"lam {lam:g}: implemented tip-inext {o1['tip'] - oi['tip']:+.3e} torque {o1['torque'] - oi['torque']:+.3e} | fixed tip-inext {o2['tip'] - oi['tip']:+.3e} torque {o2['torque'] - oi['torque']:+.3e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
