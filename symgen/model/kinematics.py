"""Kinematics: points of a bar (1), origins along the spanning tree (10), loop closure (11).

A point at xi of bar j sits at r_A + rho_j(xi), rho_j(xi) = alpha_j R(theta_j) [xi + zeta(xi), eta(xi)].
Its second time derivative is the bracket of (10):

    rho_j'' = alpha_j R(theta_j) [ zeta'' - 2 theta' eta' - theta'' eta - theta'^2 (xi + zeta),
                                   eta'' + 2 theta' zeta' + theta'' (xi + zeta) - theta'^2 eta ]

and the origin of a bar hanging from its parent at joint K is r_A = r_K - rho(xi_K), so
summing these brackets along the tree from ground gives (10) for every bar.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from symgen.model.bars import BarSymbols, _num, rot
from symgen.model.shapes import Basis


@dataclass(frozen=True)
class BarKinematics:
    sym: BarSymbols
    basis_a: Basis
    basis_t: Basis

    def _vals(self, basis: Basis, xi: float, deriv: int = 0) -> list:
        if len(basis) == 0:
            return []
        return [_num(v) for v in np.atleast_1d(basis.values(xi, deriv))]

    def zeta(self, xi: float, deriv: int = 0, amp: tuple | None = None) -> sp.Expr:
        amp = self.sym.f if amp is None else amp
        return sp.Add(*[c * a for c, a in zip(self._vals(self.basis_a, xi, deriv), amp)])

    def eta(self, xi: float, deriv: int = 0, amp: tuple | None = None) -> sp.Expr:
        amp = self.sym.g if amp is None else amp
        return sp.Add(*[c * a for c, a in zip(self._vals(self.basis_t, xi, deriv), amp)])

    def local(self, xi: float) -> tuple:
        """(xi + zeta, eta) at xi, in bar axes / l_i."""
        return sp.Float(xi) + self.zeta(xi), self.eta(xi)

    def rho(self, xi: float) -> sp.Matrix:
        s = self.sym
        lx, ly = self.local(xi)
        return s.alpha * rot(s.th) * sp.Matrix([lx, ly])

    def rho_d(self, xi: float) -> sp.Matrix:
        s = self.sym
        lx, ly = self.local(xi)
        vx = self.zeta(xi, amp=s.df) - s.dth * ly
        vy = self.eta(xi, amp=s.dg) + s.dth * lx
        return s.alpha * rot(s.th) * sp.Matrix([vx, vy])

    def bracket_dd(self, xi: float) -> sp.Matrix:
        """alpha times the bracket of (10) at xi: rho'' in the bar's own axes."""
        s = self.sym
        lx, ly = self.local(xi)
        dz, de = self.zeta(xi, amp=s.df), self.eta(xi, amp=s.dg)
        ax = self.zeta(xi, amp=s.ddf) - 2 * s.dth * de - s.ddth * ly - s.dth ** 2 * lx
        ay = self.eta(xi, amp=s.ddg) + 2 * s.dth * dz + s.ddth * lx - s.dth ** 2 * ly
        return s.alpha * sp.Matrix([ax, ay])

    def rho_dd(self, xi: float) -> sp.Matrix:
        return rot(self.sym.th) * self.bracket_dd(xi)

    def partials(self, xi: float) -> dict:
        """d rho(xi) / d coordinate, ground axes, for theta and every amplitude."""
        s = self.sym
        lx, ly = self.local(xi)
        R = rot(s.th)
        out = {s.th: s.alpha * R * sp.Matrix([-ly, lx])}
        for k, fk in enumerate(s.f):
            out[fk] = s.alpha * R * sp.Matrix([_num(self.basis_a.values(xi)[k]), 0])
        for k, gk in enumerate(s.g):
            out[gk] = s.alpha * R * sp.Matrix([0, _num(self.basis_t.values(xi)[k])])
        return out
