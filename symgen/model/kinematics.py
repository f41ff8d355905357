"""Kinematics: points of a bar (1), origins along the spanning tree (10).

A point at xi of bar j sits at r_A + rho_j(xi), rho_j(xi) = alpha_j R(theta_j) [xi + zeta(xi), eta(xi)].
Its second time derivative is the bracket of (10):

    rho_j'' = alpha_j R(theta_j) [ zeta'' - 2 theta' eta' - theta'' eta - theta'^2 (xi + zeta),
                                   eta'' + 2 theta' zeta' + theta'' (xi + zeta) - theta'^2 eta ]

and the origin of a bar hanging from its parent at joint K is r_A = r_K - rho(xi_K), so
summing these brackets along the tree from ground gives (10) for every bar
(:class:`TreeKinematics`). The loop closure (11) that ties the cut joints is in
``symgen.model.constraints``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from collections.abc import Callable

import numpy as np
import sympy as sp

from symgen.ir import names
from symgen.ir.names import Name
from symgen.model.bars import BarSymbols, _num, rot
from symgen.model.shapes import Basis
from symgen.model.topology import Topology
from symgen.scene.model import GROUND


@dataclass(frozen=True)
class BarKinematics:
    """The points of one bar. Each quantity is made once per abscissa and kept (``_memo``): the
    tree's origins (10) sum the brackets of every bar before a bar, the residuals take the partials
    of each coordinate, so the same (bar, xi) is asked for many times (the shape values are
    50-digit sums). Matrices are handed out as copies."""

    sym: BarSymbols
    basis_a: Basis
    basis_t: Basis
    _memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def _kept(self, key: tuple, make: Callable[[], object]):
        out = self._memo.get(key)
        if out is None:
            out = self._memo[key] = make()
        return out

    def _vals(self, basis: Basis, xi: float, deriv: int = 0) -> list:
        if len(basis) == 0:
            return []
        return self._kept(
            ("vals", basis.direction, xi, deriv), lambda: [_num(v) for v in np.atleast_1d(basis.values(xi, deriv))]
        )

    def zeta(self, xi: float, deriv: int = 0, amp: tuple | None = None) -> sp.Expr:
        amp = self.sym.f if amp is None else amp
        return sp.Add(*[c * a for c, a in zip(self._vals(self.basis_a, xi, deriv), amp)])

    def eta(self, xi: float, deriv: int = 0, amp: tuple | None = None) -> sp.Expr:
        amp = self.sym.g if amp is None else amp
        return sp.Add(*[c * a for c, a in zip(self._vals(self.basis_t, xi, deriv), amp)])

    def local(self, xi: float) -> tuple:
        """(xi + zeta, eta) at xi, in bar axes / l_i."""
        return self._kept(("local", xi), lambda: (sp.Float(xi) + self.zeta(xi), self.eta(xi)))

    def rho(self, xi: float) -> sp.Matrix:
        def make() -> sp.Matrix:
            s = self.sym
            lx, ly = self.local(xi)
            return s.alpha * rot(s.th) * sp.Matrix([lx, ly])

        return self._kept(("rho", xi), make).copy()

    def rho_d(self, xi: float) -> sp.Matrix:
        def make() -> sp.Matrix:
            s = self.sym
            lx, ly = self.local(xi)
            vx = self.zeta(xi, amp=s.df) - s.dth * ly
            vy = self.eta(xi, amp=s.dg) + s.dth * lx
            return s.alpha * rot(s.th) * sp.Matrix([vx, vy])

        return self._kept(("rho_d", xi), make).copy()

    def bracket_dd(self, xi: float) -> sp.Matrix:
        """alpha times the bracket of (10) at xi: rho'' in the bar's own axes."""

        def make() -> sp.Matrix:
            s = self.sym
            lx, ly = self.local(xi)
            dz, de = self.zeta(xi, amp=s.df), self.eta(xi, amp=s.dg)
            ax = self.zeta(xi, amp=s.ddf) - 2 * s.dth * de - s.ddth * ly - s.dth**2 * lx
            ay = self.eta(xi, amp=s.ddg) + 2 * s.dth * dz + s.ddth * lx - s.dth**2 * ly
            return s.alpha * sp.Matrix([ax, ay])

        return self._kept(("bracket_dd", xi), make).copy()

    def rho_dd(self, xi: float) -> sp.Matrix:
        return self._kept(("rho_dd", xi), lambda: rot(self.sym.th) * self.bracket_dd(xi)).copy()

    def partials(self, xi: float) -> dict:
        """d rho(xi) / d coordinate, ground axes, for theta and every amplitude."""

        def make() -> dict:
            s = self.sym
            lx, ly = self.local(xi)
            R = rot(s.th)
            out = {s.th: s.alpha * R * sp.Matrix([-ly, lx])}
            for fk, v in zip(s.f, self._vals(self.basis_a, xi)):
                out[fk] = s.alpha * R * sp.Matrix([v, 0])
            for gk, v in zip(s.g, self._vals(self.basis_t, xi)):
                out[gk] = s.alpha * R * sp.Matrix([0, v])
            return out

        return {k: m.copy() for k, m in self._kept(("partials", xi), make).items()}


#: the bar kinematics' methods giving rho, rho', rho'' (derivative order 0, 1, 2)
_RHO = ("rho", "rho_d", "rho_dd")


class TreeKinematics:
    """(10) along the spanning tree: the origin r_A of every bar, and any bar point, explicit
    in the coordinates q and their rates v, a.

    ``kins``: bar -> its kinematics (:class:`BarKinematics`, or ``slot.SlotBarKinematics`` for
    the guide of a slot); ``param``: makes (or looks up) a parameter from its name, here the
    ground points px, py and slider directions dx, dy (the derivation's symbols, or the scene's
    numbers for a picture); ``slider_s``: slider joint -> its travel (s, s', s'') (a position-only
    caller may give (s, None, None) and use :meth:`position` / :meth:`point_position` only).
    """

    def __init__(self, topology: Topology, kins: dict, param: Callable[[Name], sp.Expr], slider_s: dict) -> None:
        self.topo, self.kins, self.param, self.slider_s = topology, kins, param, slider_s
        self._paths: dict[str, list] = {}
        self._origins: dict[tuple, sp.Matrix] = {}  # (bar, order) -> r_A, r_A', r_A'' (made once)

    def ground_point(self, joint: str) -> sp.Matrix:
        """The ground end (px, py) of ``joint``."""
        return sp.Matrix(
            [self.param(names.joint_parameter("px", joint)), self.param(names.joint_parameter("py", joint))]
        )

    def slider_dir(self, joint: str) -> sp.Matrix:
        """The unit direction (dx, dy) of the ground line of slider ``joint``."""
        return sp.Matrix(
            [self.param(names.joint_parameter("dx", joint)), self.param(names.joint_parameter("dy", joint))]
        )

    def path(self, name: str) -> list:
        """Contributions to r_A of bar ``name``: (sign, body, xi) bar terms and the
        ("ground" | "slider", joint) end the tree starts from."""
        if name in self._paths:
            return self._paths[name]
        e = self.topo.edges[name]
        terms: list[tuple[str, str] | tuple[int, str, float | None]]
        if e.parent == GROUND:
            terms = [("slider" if e.slider else "ground", e.joint)]
        else:
            terms = self.path(e.parent) + [(1, e.parent, e.parent_xi)]
        terms = terms + [(-1, name, e.body_xi)]
        self._paths[name] = terms
        return terms

    def _ground_end(self, term: tuple, order: int) -> sp.Matrix:
        """Derivative ``order`` of the tree's ground end: the ground point, or on a slider the
        ground point plus s times the line's direction."""
        kind, joint = term
        p0 = self.ground_point(joint)  # made at every order: the parameters' order of creation
        if kind == "slider":
            d = self.slider_dir(joint)
            return p0 + self.slider_s[joint][0] * d if order == 0 else self.slider_s[joint][order] * d
        return p0 if order == 0 else sp.zeros(2, 1)

    def _origin(self, name: str, order: int) -> sp.Matrix:
        if (name, order) not in self._origins:
            self._origins[name, order] = self._origin_sum(name, order)
        return self._origins[name, order].copy()

    def _origin_sum(self, name: str, order: int) -> sp.Matrix:
        r = sp.zeros(2, 1)
        for term in self.path(name):
            if isinstance(term[0], str):
                r = r + self._ground_end(term, order)
            else:
                sign, body, xi = term
                r = r + sign * getattr(self.kins[body], _RHO[order])(xi)
        return r

    def origin(self, name: str) -> tuple:
        """(r_A, r_A', r_A'') of bar ``name``, ground axes, explicit in q, v, a."""
        return tuple(self._origin(name, order) for order in range(3))

    def position(self, name: str) -> sp.Matrix:
        """r_A of bar ``name``: the position level of :meth:`origin`."""
        return self._origin(name, 0)

    def velocity(self, name: str) -> sp.Matrix:
        """r_A' of bar ``name``: the velocity level of :meth:`origin`."""
        return self._origin(name, 1)

    def origin_acc_local(self, name: str) -> sp.Matrix:
        """[r_A'']_i of (10): the origin's acceleration in bar ``name``'s axes / alpha_i."""
        s = self.kins[name].sym
        out = sp.zeros(2, 1)
        for term in self.path(name):
            if isinstance(term[0], str):
                out += rot(-s.th) * self._ground_end(term, 2)
            else:
                sign, body, xi = term
                rel = rot(self.kins[body].sym.th - s.th) if body != name else sp.eye(2)
                out += sign * rel * self.kins[body].bracket_dd(xi)
        return out / s.alpha

    def point(self, name: str, xi: float) -> tuple:
        """(r, r', r'') of the point at ``xi`` of bar ``name``."""
        rA, vA, aA = self.origin(name)
        kin = self.kins[name]
        return rA + kin.rho(xi), vA + kin.rho_d(xi), aA + kin.rho_dd(xi)

    def point_position(self, name: str, xi: float) -> sp.Matrix:
        """r of the point at ``xi`` of bar ``name``."""
        return self.position(name) + self.kins[name].rho(xi)

    def end_point(self, joint: str, end) -> tuple:
        """(r, r', r'') of one end of ``joint`` (a bar point, or its fixed ground point)."""
        if end.body == GROUND:
            z = sp.zeros(2, 1)
            return self.ground_point(joint), z, z
        return self.point(end.body, end.xi)
