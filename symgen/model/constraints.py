"""The constraints of a mechanism: loop closure (11) at the cut joints, the angle driver, and
the inextensibility rows, each at position, velocity and acceleration level with its multiplier.

* a cut pin: the two ends meet, r_a - r_b = 0 (2 rows); its multiplier (Lx, Ly) is the force
  on ends[0] from ends[1], and minus that on ends[1];
* a cut slot: the point of ends[0] stays on the guide at its moving support xi = beta (2 rows);
  the guide takes minus the force at the contact (``Constraints.slot_force``);
* a cut slider: the bar point stays on the ground line, n . (r - p0) = 0 (1 row), the multiplier
  its normal force;
* each angle driver: theta - theta_drv(tau) = 0, exactly differentiated; its multiplier is the
  driving torque (``Constraints.driver_rows``);
* an inextensible or quasi-static bar: (phi'_k, eps) = 0 for each axial function k, the
  multiplier N_k its axial force (in lambda eps units); these rows come last.

Every point is explicit in q, v, a through the tree kinematics (10)
(``symgen.model.kinematics.TreeKinematics``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from collections.abc import Callable

import sympy as sp

from symgen.ir import names
from symgen.ir.names import Name
from symgen.ir.records import ConstraintRow, RowKind
from symgen.model.bars import PointForce
from symgen.model.kinematics import TreeKinematics
from symgen.model.structure import INEXTENSIBLE, QUASI_STATIC
from symgen.model.topology import Topology
from symgen.scene.expressions import derivative, tau_symbol
from symgen.scene.model import GROUND
from symgen.scene.motion import driver_angle


@dataclass
class Constraints:
    """phi = 0 with its rates, row by row, and the multipliers ``lam`` (one per row) with
    their :class:`ConstraintRow` records."""

    phi: list = field(default_factory=list)
    phid: list = field(default_factory=list)
    phidd: list = field(default_factory=list)
    lam: list = field(default_factory=list)
    rows: list = field(default_factory=list)  # ConstraintRow per multiplier
    point_forces: dict = field(default_factory=dict)  # bar -> [PointForce] the multipliers put on it
    slot_force: dict = field(default_factory=dict)  # guide -> (Fx, Fy) at its moving contact
    n_loop_rows: int = 0  # the closure rows (11) come first
    driver_rows: dict = field(default_factory=dict)  # driven bar -> index of its angle driver's row in lam

    @property
    def driver_row(self) -> int | None:
        """The first angle driver's row in lam (None without an angle driver)."""
        return min(self.driver_rows.values(), default=None)

    def add(self, phi: sp.Expr, phid: sp.Expr, phidd: sp.Expr, lam: sp.Symbol, row: ConstraintRow) -> None:
        self.phi.append(phi)
        self.phid.append(phid)
        self.phidd.append(phidd)
        self.lam.append(lam)
        self.rows.append(row)

    @property
    def closure(self) -> list:
        """phi of the loop-closure rows (11) only."""
        return self.phi[: self.n_loop_rows]


def loop_closure(topo: Topology, joints: dict, kins: dict, tree: TreeKinematics) -> Constraints:
    """(11) at every cut joint: pins, slots and sliders, in the topology's order (``joints``:
    name -> :class:`symgen.ir.spec.JointSpec`)."""
    out = Constraints(point_forces={n: [] for n in kins})
    for cut in topo.cuts:
        j = joints[cut.joint]
        ra, va, aa = tree.end_point(j.name, j.ends[0])
        rb, vb, ab = tree.end_point(j.name, j.ends[1]) if j.kind != "slot" else (None, None, None)
        if j.kind == "pin":
            L = (names.joint_force(j.name, "x").symbol(), names.joint_force(j.name, "y").symbol())
            for k, comp in enumerate("xy"):
                out.add(
                    ra[k] - rb[k],
                    va[k] - vb[k],
                    aa[k] - ab[k],
                    L[k],
                    ConstraintRow(j.name, RowKind(f"pin-{comp}"), cut.loop),
                )
            for idx, sign in ((0, 1), (1, -1)):
                end = j.ends[idx]
                if end.body != GROUND:
                    out.point_forces[end.body].append(PointForce(end.xi, ground=(sign * L[0], sign * L[1])))
        elif j.kind == "slot":  # the point of ends[0] stays on the guide at its support distance beta
            guide = j.ends[1].body
            rA, vA, aA = tree.origin(guide)
            c0, c1, c2 = kins[guide].contact()
            rb, vb, ab = rA + c0, vA + c1, aA + c2
            L = (names.joint_force(j.name, "x").symbol(), names.joint_force(j.name, "y").symbol())
            for k, comp in enumerate("xy"):
                out.add(
                    ra[k] - rb[k],
                    va[k] - vb[k],
                    aa[k] - ab[k],
                    L[k],
                    ConstraintRow(j.name, RowKind(f"slot-{comp}"), cut.loop),
                )
            out.point_forces[j.ends[0].body].append(PointForce(j.ends[0].xi, ground=(L[0], L[1])))
            out.slot_force[guide] = (-L[0], -L[1])  # on the guide, at the moving contact
        else:  # slider: the bar point stays on the ground line
            bar_idx = 0 if j.ends[0].body != GROUND else 1
            sign = 1 if bar_idx == 0 else -1
            d = tree.slider_dir(j.name)
            n = sp.Matrix([-d[1], d[0]])
            p0 = tree.ground_point(j.name)
            r, v, a = (ra, va, aa) if bar_idx == 0 else (rb, vb, ab)
            L = names.joint_force(j.name).symbol()
            out.add(
                sign * (n.dot(r - p0)),
                sign * n.dot(v),
                sign * n.dot(a),
                L,
                ConstraintRow(j.name, RowKind.SLIDER, cut.loop),
            )
            end = j.ends[bar_idx]
            out.point_forces[end.body].append(PointForce(end.xi, ground=(sign * L * n[0], sign * L * n[1])))
    out.n_loop_rows = len(out.phi)
    return out


def angle_drivers(cons: Constraints, drivers, kins: dict, param: Callable[[Name], sp.Symbol]) -> None:
    """The row of each angle driver, appended to ``cons`` in the scene's order: theta = theta0 +
    rate tau (the contract's parameters), or a law theta(tau) / the spin-up ramp with exact
    derivatives. Driver i's parameters and multiplier are named by ``names.driver_parameter``
    and ``names.driver_force`` (driver 0: the names of a single-driver scene). Torque drivers
    add nothing."""
    tau = tau_symbol()
    for i, driver in enumerate(drivers):
        if driver.kind != "angle":
            continue
        th = kins[driver.body].sym
        th0 = param(names.driver_parameter("theta0", i))
        if driver.law is None and driver.ramp is None:  # the contract's theta0 + rate tau
            rate = param(names.driver_parameter("rate", i))
            rows = (th.th - th0 - rate * tau, th.dth - rate, th.ddth)
        else:  # law(tau) or the spin-up ramp: exact derivatives
            rate = param(names.driver_parameter("rate", i)) if driver.law is None else None
            ramp = param(names.driver_parameter("ramp", i)) if driver.ramp is not None else None
            angle = driver_angle(driver, tau, th0, rate, ramp)
            rows = (th.th - angle, th.dth - derivative(angle, tau), th.ddth - derivative(angle, tau, 2))
        cons.driver_rows[driver.body] = len(cons.lam)
        row = ConstraintRow("driver", RowKind.DRIVER, (GROUND, driver.body))
        cons.add(*rows, names.driver_force(i).symbol(), row)


def axial_forces(kins: dict, treatment: dict) -> dict:
    """bar -> (N_1, ...): the multipliers of (phi'_k, eps) = 0 of every inextensible and
    quasi-static bar with axial functions (a quasi-static bar's stretch is P eps = N / lambda)."""
    return {
        name: tuple(names.axial_force(name, k).symbol() for k in range(len(kin.sym.f)))
        for name, kin in kins.items()
        if treatment.get(name) in (INEXTENSIBLE, QUASI_STATIC) and len(kin.sym.f)
    }


def quasi_static_stretch(axial_force: dict, treatment: dict) -> dict:
    """bar -> (N_1, ...) of the quasi-static bars: their amplitudes read f + N / lambda."""
    return {name: axial_force[name] for name in axial_force if treatment[name] == QUASI_STATIC}


def inextensibility(cons: Constraints, topo: Topology, bars: dict, axial_force: dict) -> None:
    """The rows (phi'_k, eps) = 0 of each bar's equations (``BarEquations.constraint``, derived
    first), appended to ``cons`` after the loops and the driver, in tree order; velocity and
    acceleration by the chain rule over the bar's amplitudes."""
    for name in topo.order:
        if name not in axial_force:
            continue
        s = bars[name].sym
        eqs = bars[name].equations
        amp = [(x, dx, ddx) for x, dx, ddx in zip(s.f + s.g, s.df + s.dg, s.ddf + s.ddg)]
        for k, c in enumerate(eqs.constraint):
            if eqs.constraint_rates:  # the exact bar's, written from its tables (symgen.model.bars)
                cd, cdd = eqs.constraint_rates[k]
            else:
                grad = [sp.diff(c, x) for x, _, _ in amp]
                cd = sp.Add(*[gi * dx for gi, (_, dx, _) in zip(grad, amp)])
                cdd = sp.Add(*[gi * ddx for gi, (_, _, ddx) in zip(grad, amp)])
                cdd += sp.Add(*[sp.diff(gi, y) * dx * dy for gi, (_, dx, _) in zip(grad, amp) for y, dy, _ in amp])
            cons.add(c, cd, cdd, axial_force[name][k], ConstraintRow(name, RowKind.INEXTENSIBLE, (name,)))
