"""Lumped rotary inertias: a driver's rotor and hubs at joints (issue 12, Deliver 3).

A lumped body of rotary inertia I (about its own centre of mass, which sits at the joint and
carries the joint's lumped mass) turns with the cross-section of the bar it is carried by:

    phi = theta + eta'(xi)          (elastic bar: the chord angle plus the small bending slope,
                                     eta' = d eta / d xi, both in the bar's own axes)
    phi = theta                     (rigid bar, or a bar without transverse functions)

The axial functions do not turn the section (linear small-rotation kinematics, like the
bar's own rotary-inertia effect). Its inertial moment I phi'' does virtual work I phi'' d phi,
so it adds I phi'' d phi / d q to the generalized force of every coordinate q of that bar
(theta, the g_k, and a slot guide's beta when the shapes depend on it), and I phi'^2 / 2 to the
kinetic energy. The moment is a couple: it adds nothing to the bar's resultant force, so the
reactions of the tree joints are unchanged.

A driver's rotor (motor rotor + gears reflected to the crank shaft) turns with the driven bar's
angle theta: it adds J theta'' to that bar's moment equation and J theta'^2 / 2 to the energy.

A rigid attachment (a ``[[masses]]`` entry with an offset d = [along, across] in the axes of
the cross-section at xi) turns with the same phi: its centre sits at the bar point plus
R(phi) d (:func:`arm`). A force F acting there does the work of F at the bar point plus that of
the couple (R(phi) d) x F through d phi; ``LumpedRotary.couple`` carries such a couple, and it
enters the generalized forces with the inertial moment: (I phi'' - C) d phi / d q.

Units: I and J are / (m_ref l0^3), the common unit of the generalized forces (m_ref l0^3 omega^2).
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable, Sequence

import sympy as sp

from symgen.ir import names
from symgen.ir.names import Name
from symgen.ir.spec import DriverSpec
from symgen.model.bars import rot


@dataclass(frozen=True)
class LumpedRotary:
    """A rotary inertia ``inertia`` (a symbol, or 0) at ``xi`` of bar ``body``, from joint
    ``joint`` (or ``masses[i]``), and an applied ``couple`` (common units) that turns with the
    same cross-section (the arm of a rigid attachment's force), 0 without one."""

    joint: str
    body: str
    xi: float
    inertia: sp.Expr
    couple: sp.Expr = sp.Integer(0)


def driver_rotors(drivers: Sequence[DriverSpec], param: Callable[[Name], sp.Symbol]) -> dict:
    """driven bar -> J of each driver that carries a rotor inertia (in the drivers' order)."""
    return {d.body: param(names.driver_parameter("J_rotor", i)) for i, d in enumerate(drivers) if d.rotor_inertia}


def coordinates(sym) -> list:
    """(q, q', q'') of every coordinate of one bar that can turn a cross-section."""
    out = [(sym.th, sym.dth, sym.ddth)]
    out += list(zip(sym.g, sym.dg, sym.ddg))
    if getattr(sym, "beta", None):
        out.append(tuple(sym.beta))
    return out


def section_rotation(sym, kin, xi: float) -> sp.Expr:
    """phi = theta + eta'(xi) of the cross-section at xi (theta for a bar without bending)."""
    if not sym.g:
        return sym.th
    return sym.th + kin.eta(xi, 1)


def rotation_rates(phi: sp.Expr, coords: list) -> tuple:
    """(phi', phi'', {q: d phi / d q}) by the chain rule over ``coords`` [(q, q', q''), ...]."""
    grads = {q: sp.diff(phi, q) for q, _, _ in coords}
    phid = sp.Add(*[grads[q] * dq for q, dq, _ in coords])
    phidd = sp.Add(*[grads[q] * ddq for q, _, ddq in coords])
    phidd += sp.Add(*[sp.diff(grads[q], p) * dq * dp for q, dq, _ in coords for p, dp, _ in coords])
    return phid, phidd, grads


def arm(sym, kin, xi: float, offset: tuple) -> tuple:
    """(d, d', d''): the offset ``offset`` = (along, across) of a rigid attachment at ``xi``,
    in ground axes, d = R(phi) offset, turning with the cross-section phi (common units l0)."""
    phid, phidd, _ = rotation_rates(section_rotation(sym, kin, xi), coordinates(sym))
    d = rot(section_rotation(sym, kin, xi)) * sp.Matrix(offset)
    perp = sp.Matrix([-d[1], d[0]])
    return d, phid * perp, phidd * perp - phid**2 * d


def add_lumped_rotary(gen: dict, sym, kin, items: list) -> dict:
    """``gen`` (a bar's generalized forces, common units) plus the inertial moments and couples of
    ``items`` (:class:`LumpedRotary` on this bar): (I phi'' - C) d phi / d q on theta, every g_k
    and beta."""
    if not items:
        return gen
    coords = coordinates(sym)
    th = gen["th"]
    g = list(gen["g"])
    beta = gen.get("beta")
    for it in items:
        _, phidd, grads = rotation_rates(section_rotation(sym, kin, it.xi), coords)
        moment = it.inertia * phidd - it.couple
        th += moment * grads[sym.th]
        for k, gk in enumerate(sym.g):
            g[k] += moment * grads[gk]
        if beta is not None and getattr(sym, "beta", None):
            beta += moment * grads[sym.beta[0]]
    out = dict(gen)
    out["th"], out["g"] = th, tuple(g)
    if beta is not None:
        out["beta"] = beta
    return out


def rotary_energy(bars: dict, items: list, rotors: dict) -> sp.Expr:
    """Kinetic energy I phi'^2 / 2 of the lumped rotary inertias and J theta'^2 / 2 of the
    drivers' rotors ``rotors`` (driven bar -> J)."""
    total = sp.Integer(0)
    for it in items:
        if it.inertia == 0:
            continue
        bm = bars[it.body]
        phid, _, _ = rotation_rates(section_rotation(bm.sym, bm.kin, it.xi), coordinates(bm.sym))
        total += it.inertia * phid**2 / 2
    for body, J in rotors.items():
        total += J * bars[body].sym.dth ** 2 / 2
    return total
