"""What acts on the bars besides the joints: lumped masses and rotary inertias at joints,
gravity, point and distributed loads, Kelvin-Voigt damping, and the torque drivers' applied moments.

* A lumped mass m at a joint is carried by the first bar of the joint: its inertia and weight
  -m (r'' - g) enter that bar's equations as a point force in ground axes (common units), its
  acceleration r'' = alpha R(theta) [x_A'', y_A'']_i + rho''(xi) from the bar's own origin
  acceleration symbols of (10).
* A lumped rotary inertia at a joint is a ``rotary.LumpedRotary`` of the bar carrying it (its
  moment is added to the generalized forces in ``symgen.model.rotary``).
* A ``[[masses]]`` entry is the same lumped mass and rotary inertia at any xi of its bar. With
  an offset d (a rigid attachment) its centre is r(xi) + R(phi) d (``rotary.arm``): its
  inertia and weight F = -m (r'' - g) act at the bar point as above, plus the couple
  (R(phi) d) x F through the cross-section's rotation phi (a ``LumpedRotary`` couple).
* Loads are (B, Gamma) groups in bar axes: at a point, or distributed (uniform) on a bar;
  a value is a parameter, or an expression of tau from the scene (held by the model's spec).
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable

import sympy as sp

from symgen.ir import names
from symgen.ir.names import Name
from symgen.ir.spec import ModelSpec
from symgen.model.bars import PointForce, rot
from symgen.model.rotary import LumpedRotary, arm
from symgen.scene.expressions import parse_tau_expression
from symgen.scene.model import GROUND


@dataclass(frozen=True)
class LumpedMass:
    """A point mass ``mass`` (a symbol) at ``xi`` of bar ``body``, from joint ``joint`` (or
    ``masses[i]``); ``offset``: (along, across) symbols of a rigid attachment's arm, or None."""

    joint: str
    body: str
    xi: float
    mass: sp.Symbol
    offset: tuple | None = None

    def point(self, tree, kin) -> tuple:
        """(r, r') of the mass's centre: the bar point at xi (``tree``: the tree kinematics),
        plus the arm of a rigid attachment (``kin``: its bar's kinematics)."""
        r, v, _ = tree.point(self.body, self.xi)
        if self.offset is None:
            return r, v
        d, dd, _ = arm(kin.sym, kin, self.xi, self.offset)
        return r + d, v + dd


@dataclass
class Loads:
    """The applied loads of a scene, by the bar they act on."""

    torques: dict  # driven bar -> the applied moment of each torque driver
    gravity: tuple | None  # (gx, gy) parameters, None without gravity
    G: sp.Matrix  # gravity as a vector (zero without gravity)
    masses: list[LumpedMass]  # in joint order, then the [[masses]]
    rotary: dict[str, list[LumpedRotary]]  # bar -> its lumped rotary inertias
    distributed: dict[str, list[tuple[sp.Expr, sp.Expr]]]  # bar -> [(B, Gamma)] uniform loads
    points: dict[str, list[PointForce]]  # bar -> lumped masses' inertia and weight, then point loads
    damping: sp.Symbol | None  # Kelvin-Voigt coefficient, None without damping


def applied_loads(spec: ModelSpec, kins: dict, param: Callable[[Name], sp.Symbol]) -> Loads:
    """The loads of the model ``spec`` on the bars ``kins`` (bar -> kinematics): a value is a
    parameter, an expression of tau (held by the spec) is parsed."""
    torques = {
        d.body: parse_tau_expression(d.torque) if d.torque != "const" else param(names.driver_parameter("torque", i))
        for i, d in enumerate(spec.drivers)
        if d.kind != "angle"
    }
    grav = (param(names.global_parameter("gx")), param(names.global_parameter("gy"))) if spec.effects.gravity else None
    G = sp.Matrix(grav) if grav else sp.zeros(2, 1)
    masses: list[LumpedMass] = []
    rotary: dict[str, list[LumpedRotary]] = {n: [] for n in kins}
    points: dict[str, list[PointForce]] = {n: [] for n in kins}
    for j in spec.joints:
        if not (j.inertia or j.mass):
            continue
        end = next(x for x in j.ends if x.body != GROUND)
        assert end.xi is not None, "a lumped mass or inertia sits on a bar at a xi"
        if j.inertia:
            rotary[end.body].append(LumpedRotary(j.name, end.body, end.xi, param(names.joint_parameter("I", j.name))))
        if j.mass:
            m = param(names.joint_parameter("m", j.name))
            masses.append(LumpedMass(j.name, end.body, end.xi, m))
            kin = kins[end.body]
            s = kin.sym
            aA = s.alpha * rot(s.th) * sp.Matrix([s.xa_dd, s.ya_dd])
            acc = aA + kin.rho_dd(end.xi) - G
            points[end.body].append(PointForce(end.xi, ground=(-m * acc[0], -m * acc[1])))
    for i, pm in enumerate(spec.masses):
        label = f"masses[{i}]"
        if pm.inertia:
            rotary[pm.body].append(LumpedRotary(label, pm.body, pm.xi, param(names.mass_parameter("I", i))))
        if not pm.mass:
            continue
        m = param(names.mass_parameter("m", i))
        kin = kins[pm.body]
        s = kin.sym
        acc = s.alpha * rot(s.th) * sp.Matrix([s.xa_dd, s.ya_dd]) + kin.rho_dd(pm.xi) - G
        offset = None
        if pm.offset:
            offset = (param(names.mass_parameter("along", i)), param(names.mass_parameter("across", i)))
            d, _, d_dd = arm(s, kin, pm.xi, offset)
            acc += d_dd
        masses.append(LumpedMass(label, pm.body, pm.xi, m, offset))
        force = (-m * acc[0], -m * acc[1])
        points[pm.body].append(PointForce(pm.xi, ground=force))
        if offset is not None:  # the force acts at the arm's end: its couple about the bar point
            couple = d[0] * force[1] - d[1] * force[0]
            rotary[pm.body].append(LumpedRotary(label, pm.body, pm.xi, sp.Integer(0), couple))
    dist: dict[str, list[tuple[sp.Expr, sp.Expr]]] = {n: [] for n in kins}
    for i, ld in enumerate(spec.loads):
        vals = []
        for comp in ("axial", "transverse"):
            val = getattr(ld, comp)
            vals.append(
                parse_tau_expression(val)
                if val != "const"
                else param(names.load_parameter(i, comp, point=ld.kind != "distributed"))
            )
        if ld.kind == "distributed":
            dist[ld.body].append((vals[0], vals[1]))
        else:
            assert ld.xi is not None, "a point load has its xi (symgen.scene.excitation)"
            points[ld.body].append(PointForce(ld.xi, bar=tuple(vals)))
    damping = param(names.global_parameter("damping")) if spec.effects.damping else None
    return Loads(torques, grav, G, masses, rotary, dist, points, damping)
