"""Equations of one bar: the acceleration field (1), the Galerkin equations (16)-(17) and
the three rigid-body equations, in the bar's own dimensionless form.

Everything here is local to one bar: its angle theta, amplitudes f (axial, zeta = phi^T f)
and g (transverse, eta = psi^T g), their rates and accelerations, and the acceleration of
its origin A in its own axes divided by l_i omega^2 (the paper's [r_A'']_i, given by (10)).
Each bar's equations are derived once, in *display form*: the inner products as named symbols
(``DisplayIPTable``, ``slot.SlotDisplayIPTable``), each point force of the scene given in ground
axes as its bar-axes groups (B_k, Gamma_k) and the distributed loads (gravity included) as
(beta-bar, gamma-bar). ``BarEquations.values`` maps every such display symbol to its value, and
the model's (numeric) form is the display form with those values substituted (``xreplace``):
the LaTeX backend prints ``BarEquations.display``, the model that runs, instead of deriving it
again.

Normalisation (per bar, forces in m_i l_i omega^2 per unit length):

* ``force``  : rigid-body force balance in bar axes, divided by nu alpha^2
* ``moment`` : moment balance about A, divided by nu alpha^3
* ``eq16``, ``eq17`` : the weak (symmetric) forms of (16), (17), divided by nu alpha^3

and ``generalized`` multiplies back to common units (m_ref l0^3 omega^2 per unit coordinate)
with the force rotated to ground axes.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
import math
from dataclasses import dataclass, field, replace
from itertools import combinations_with_replacement

import numpy as np
import sympy as sp

from symgen.ir import names

from symgen.model.shape_cache import curvature_products, node_form_nodes, sixth_order_products
from symgen.model.shapes import Basis, InnerProducts

ZERO_TOL = 1e-13


def rot(th: sp.Expr) -> sp.Matrix:
    """R(theta) of the formulation: bar axes -> ground axes."""
    c, s = sp.cos(th), sp.sin(th)
    return sp.Matrix([[c, -s], [s, c]])


def to_bar_axes(th: sp.Expr, x: sp.Expr, y: sp.Expr) -> tuple:
    """Components in the axes of a bar at angle ``th`` of the ground-axes vector (x, y):
    R(theta)^T (x, y)."""
    return sp.cos(th) * x + sp.sin(th) * y, -sp.sin(th) * x + sp.cos(th) * y


def point_force_groups(s: BarSymbols, fx: sp.Expr, fy: sp.Expr) -> tuple:
    """(B, Gamma) of a point force (fx, fy) on bar ``s``, given in ground axes and common
    units m_ref l0^2 omega^2: its bar-axes components divided by nu alpha^2, i.e.
    B = (cos th Fx + sin th Fy) / (nu alpha^2), Gamma = (-sin th Fx + cos th Fy) / (nu alpha^2).
    The one home of this rotation: ``bar_equations`` (hence the model), the LaTeX definitions
    of B_K, Gamma_K and the slot force on its guide use it."""
    bx, by = to_bar_axes(s.th, fx, fy)
    k = s.nu * s.alpha**2
    return bx / k, by / k


@dataclass(frozen=True)
class BarSymbols:
    """Symbols of one bar (coordinates, rates, accelerations, parameters)."""

    name: str
    th: sp.Symbol
    dth: sp.Symbol
    ddth: sp.Symbol
    f: tuple
    df: tuple
    ddf: tuple
    g: tuple
    dg: tuple
    ddg: tuple
    xa_dd: sp.Symbol  # [x_A'']_i : acceleration of A along the bar / (l_i omega^2)
    ya_dd: sp.Symbol
    alpha: sp.Symbol
    nu: sp.Symbol
    lam: sp.Symbol | None
    mu: sp.Symbol | None
    beta: tuple = ()  # guide of a slot: (beta, beta', beta'') of the moving support

    @staticmethod
    def make(name: str, na: int, nt: int, elastic: bool, lam: bool = True) -> BarSymbols:
        """``lam = False``: no lambda symbol even with axial functions (an inextensible bar
        without rotary inertia: its axial force is a multiplier, not lambda times a strain)."""

        def vec(family: str, n: int, order: int) -> tuple:
            return tuple(names.amplitude(family, name, k, order).symbol() for k in range(n))

        def par(kind: str) -> sp.Symbol:
            return names.bar_parameter(kind, name).symbol(positive=True)

        th = tuple(names.bar_angle(name, o).symbol() for o in range(3))
        return BarSymbols(
            name=name,
            th=th[0],
            dth=th[1],
            ddth=th[2],
            f=vec("f", na, 0),
            df=vec("f", na, 1),
            ddf=vec("f", na, 2),
            g=vec("g", nt, 0),
            dg=vec("g", nt, 1),
            ddg=vec("g", nt, 2),
            xa_dd=names.origin_acceleration("x", name).symbol(),
            ya_dd=names.origin_acceleration("y", name).symbol(),
            alpha=par("alpha"),
            nu=par("nu"),
            lam=par("lambda") if elastic and na and lam else None,
            mu=par("mu") if elastic and nt else None,
        )


class IPTable:
    """Inner products of one bar, as numbers (``symbolic=False``) or display symbols.

    Index convention of the Gram matrix: b = [1, xi, phi_1..phi_na, psi_1..psi_nt].
    """

    def __init__(self, ip: InnerProducts, symbolic: bool = False) -> None:
        self.ip, self.na, self.nt, self.symbolic = ip, ip.na, ip.nt, symbolic
        self._labels = (
            ["1", r"\xi"] + [rf"\phi_{{{k + 1}}}" for k in range(ip.na)] + [rf"\psi_{{{k + 1}}}" for k in range(ip.nt)]
        )

    def _num(self, x: float) -> sp.Expr:
        return sp.Integer(0) if abs(x) < ZERO_TOL else sp.Float(float(x), 17)

    def gram(self, i: int, j: int) -> sp.Expr:
        value = self.ip.gram[i, j]
        if abs(value) < ZERO_TOL:
            return sp.Integer(0)
        if not self.symbolic:
            return self._num(value)
        i, j = min(i, j), max(i, j)
        return sp.Symbol(rf"\left({self._labels[i]},{self._labels[j]}\right)")

    def mat(self, name: str, i: int, j: int, latex: str) -> sp.Expr:
        value = getattr(self.ip, name)[i, j]
        if abs(value) < ZERO_TOL:
            return sp.Integer(0)
        if not self.symbolic:
            return self._num(value)
        return sp.Symbol(latex.format(i=i + 1, j=j + 1))

    def vec(self, name: str, i: int, latex: str) -> sp.Expr:
        value = getattr(self.ip, name)[i]
        if abs(value) < ZERO_TOL:
            return sp.Integer(0)
        return sp.Symbol(latex.format(i=i + 1)) if self.symbolic else self._num(value)

    def ka_inv(self, i: int, j: int) -> sp.Expr:
        """``(Ka^{-1})_ij``, the inverse of the Gram matrix of the axial strains phi'_k (the
        projection onto their span, see ``bar_equations``)."""
        if not hasattr(self, "_ka_inv"):
            self._ka_inv = np.linalg.inv(np.asarray(self.ip.Ka, dtype=float))
        value = self._ka_inv[i, j]
        if abs(value) < ZERO_TOL * max(1.0, float(np.abs(self._ka_inv).max())):
            return sp.Integer(0)
        if not self.symbolic:
            return self._num(value)
        return sp.Symbol(rf"\left(K_a^{{-1}}\right)_{{{i + 1}{j + 1}}}")

    def tensor(self, name: str, idx: tuple, latex: str) -> sp.Expr:
        value = getattr(self.ip, name)[idx]
        if abs(value) < ZERO_TOL:
            return sp.Integer(0)
        if not self.symbolic:
            return self._num(value)
        return sp.Symbol(latex.format(*[k + 1 for k in idx]))

    def display(self) -> DisplayIPTable:
        """The display table of these inner products (see ``bar_equations``)."""
        return DisplayIPTable(self)

    def with_curvature(self, basis_a: Basis, basis_t: Basis) -> IPTable:
        """This table with the exact bar's tables E4, G3 of the bases (``effects.strain =
        "exact"``), from the shape cache."""
        if self.ip.curvature is not None:
            return self
        ip = self.ip.with_curvature(curvature_products(basis_a, basis_t))
        return IPTable(ip.with_sixth_order(sixth_order_products(basis_a, basis_t)), self.symbolic)


class DisplayIPTable(IPTable):
    """The inner products of one bar as display symbols, recording each symbol it hands out:
    ``used`` maps it to (kind, index), ``values`` to the number the numeric table gives there.

    The symmetric ones (the Gram matrix, Ka, Kt, Pd, Ka^-1) have one symbol for (i, j) and
    (j, i); its value is the mean of the two entries: either one, except where
    ``np.linalg.inv`` leaves Ka^-1 asymmetric in the last bit (its entries enter only in the
    symmetric pairs of c^T Ka^-1 c, whose coefficient, twice the mean, is their sum).
    """

    def __init__(self, numeric: IPTable) -> None:
        super().__init__(numeric.ip, symbolic=True)
        self.numeric = numeric
        self.used: dict[sp.Symbol, tuple] = {}
        self.values: dict[sp.Symbol, sp.Expr] = {}

    def _record(self, out: sp.Expr, kind: str, idx: tuple, value) -> sp.Expr:
        if isinstance(out, sp.Symbol) and out not in self.used:
            self.used[out] = (kind, idx)
            self.values[out] = value()
        return out

    def _mean(self, a: sp.Expr, b: sp.Expr) -> sp.Expr:
        return a if a == b else (a + b) / 2

    def gram(self, i: int, j: int) -> sp.Expr:
        i, j = min(i, j), max(i, j)
        return self._record(
            super().gram(i, j), "gram", (i, j), lambda: self._mean(self.numeric.gram(i, j), self.numeric.gram(j, i))
        )

    def mat(self, name: str, i: int, j: int, latex: str) -> sp.Expr:
        if name in ("Ka", "Kt", "Pd"):  # symmetric: one symbol for (a, b) and (b, a)
            i, j = min(i, j), max(i, j)
            value = lambda: self._mean(self.numeric.mat(name, i, j, latex), self.numeric.mat(name, j, i, latex))
        else:
            value = lambda: self.numeric.mat(name, i, j, latex)
        return self._record(super().mat(name, i, j, latex), name, (i, j), value)

    def vec(self, name: str, i: int, latex: str) -> sp.Expr:
        return self._record(super().vec(name, i, latex), name, (i, 0), lambda: self.numeric.vec(name, i, latex))

    def tensor(self, name: str, idx: tuple, latex: str) -> sp.Expr:
        return self._record(
            super().tensor(name, idx, latex), name, tuple(idx), lambda: self.numeric.tensor(name, idx, latex)
        )

    def ka_inv(self, i: int, j: int) -> sp.Expr:
        i, j = min(i, j), max(i, j)  # symmetric
        return self._record(
            super().ka_inv(i, j),
            "KaInv",
            (i, j),
            lambda: self._mean(self.numeric.ka_inv(i, j), self.numeric.ka_inv(j, i)),
        )

    def finish(self, expr: sp.Expr) -> sp.Expr:
        """The display form as derived (a slot's table turns functions of beta into symbols)."""
        return expr


def _ip(t: IPTable, u: list, w: list) -> sp.Expr:
    """(u, w) = integral of (u . b)(w . b) over [0, 1] for coefficient lists over b."""
    out = []
    for i, ui in enumerate(u):
        if ui == 0:
            continue
        for j, wj in enumerate(w):
            if wj == 0:
                continue
            gij = t.gram(i, j)
            if gij != 0:
                out.append(gij * ui * wj)
    return sp.Add(*out)


@dataclass(frozen=True)
class PointForce:
    """A concentrated force on the bar at xi.

    ``ground``: (Fx, Fy) in ground axes and common units m_ref l0^2 omega^2 (reactions, lumped
    masses), or ``bar``: (B, Gamma) groups F/(m_i l_i^2 omega^2) in bar axes (point loads).
    """

    xi: float
    ground: tuple | None = None
    bar: tuple | None = None


@dataclass(frozen=True)
class BarEquations:
    sym: BarSymbols
    force: tuple  # (2,) bar axes, / nu alpha^2
    moment: sp.Expr  # / nu alpha^3
    eq16: tuple  # (na,) / nu alpha^3
    eq17: tuple  # (nt,) / nu alpha^3
    kinetic: sp.Expr  # / nu alpha^3, needs xa_d, ya_d symbols
    elastic: sp.Expr  # strain energy / nu alpha^3
    xa_d: sp.Symbol
    ya_d: sp.Symbol
    constraint: tuple = ()  # inextensible bar: (phi'_k, eps) = 0, k = 1..na (multipliers N_k)
    # the exact bar's: (d/dt, d2/dt2) of each constraint, from its tables (() : by the chain rule)
    constraint_rates: tuple = ()
    eqbeta: sp.Expr | None = None  # guide of a slot: the equation of its support distance beta
    # the display form (``bar_equations``): the same fields with display symbols, and what they stand for;
    # made on first use (``display``) where it is not the model's own expression (the exact bar's node form)
    display_form: BarEquations | Callable[[], BarEquations] | None = field(default=None, compare=False, repr=False)
    # display symbol -> value, symbol -> (kind, index): complete once the display form is made (``values``)
    value_table: dict = field(default_factory=dict, compare=False, repr=False)
    inner_product_table: dict = field(default_factory=dict, compare=False, repr=False)
    points: tuple = field(default=(), compare=False, repr=False)  # (B, Gamma) shown for each point force
    loads: tuple = field(default=(), compare=False, repr=False)  # (beta-bar, gamma-bar) symbols, or ()

    @property
    def display(self) -> BarEquations | None:
        """The display form (``symgen latex``), made on first use and kept."""
        form = self.display_form
        if callable(form):
            form = form()
            object.__setattr__(self, "display_form", form)
        return form

    @property
    def values(self) -> dict:
        """Each display symbol's value (those of the display form's own sums too)."""
        _ = self.display
        return self.value_table

    @property
    def inner_products(self) -> dict:
        """Each display symbol -> (kind, index) (those of the display form's own sums too)."""
        _ = self.display
        return self.inner_product_table

    #: the fields holding equations (``substitute`` replaces in these)
    EXPRESSIONS = ("force", "moment", "eq16", "eq17", "kinetic", "elastic", "constraint", "constraint_rates", "eqbeta")

    def map(self, fn) -> BarEquations:
        """The same equations with ``fn`` applied to each expression."""

        def each(v):
            if v is None:
                return None
            if isinstance(v, tuple):
                return tuple(each(x) for x in v)
            return fn(sp.sympify(v))

        return replace(self, **{k: each(getattr(self, k)) for k in self.EXPRESSIONS})

    def substitute(self, rule: dict) -> BarEquations:
        """The same equations with ``rule`` applied as ``xreplace`` would (nothing simplified), each
        shared subexpression once (``shared_xreplace``)."""
        memo: dict = {}
        return self.map(lambda e: shared_xreplace(e, rule, memo))

    def generalized(self) -> dict:
        """Generalized forces in common units: 'XY' (ground axes), 'th', 'f', 'g'."""
        s = self.sym
        k2, k3 = s.nu * s.alpha**2, s.nu * s.alpha**3
        fxy = rot(s.th) * sp.Matrix(self.force) * k2
        return {
            "XY": (fxy[0], fxy[1]),
            "th": k3 * self.moment,
            "f": tuple(k3 * e for e in self.eq16),
            "g": tuple(k3 * e for e in self.eq17),
            "beta": None if self.eqbeta is None else k3 * self.eqbeta,
        }


def bar_equations(
    s: BarSymbols,
    basis_a: Basis,
    basis_t: Basis,
    t: IPTable,
    effects,
    *,
    loads: tuple = (),
    points: tuple = (),
    gravity: tuple | None = None,
    damping: sp.Expr | None = None,
    axial_force: tuple | None = None,
) -> BarEquations:
    """Derive one bar's equations, once, in display form; return the model's form with the
    display form beside it.

    The display form (``.display``) has the inner products as display symbols (from
    ``t.display()``: ``DisplayIPTable``, or a slot guide's ``SlotDisplayIPTable``), each point
    force given in ground axes as the symbols (B_k, Gamma_k) of its bar-axes groups (``.points``
    lists what each point force shows as), and the distributed loads, gravity included, as
    (beta-bar, gamma-bar) (``.loads``). ``.values`` maps each of those symbols to its value and
    ``.inner_products`` each inner product's symbol to (kind, index); the returned equations
    are the display form with ``.values`` substituted by ``xreplace``.

    Parameters
    ----------
    loads : ((beta, gamma), ...) uniform distributed load groups in bar axes (/ m_i l_i w^2)
    points : PointForce, ...
    gravity : (Gx, Gy) symbols (g / l0 w^2, ground axes) or None when off
    damping : Kelvin-Voigt ratio symbol or None when off
    axial_force : (N_1..N_na) multiplier symbols of an *inextensible* bar
        (``effects.axial = "inextensible"``), else None. The bar's strain is then constrained,
        in Galerkin form, to (phi'_k, eps) = 0 (returned as ``constraint``): the lambda -> oo
        limit of the weak form. The axial force N = sum_k N_k phi'_k (units of lambda eps) does
        virtual work sum_k N_k d(phi'_k, eps): it enters (16) as Ka N and, with geometric
        stiffening, (17) as (N eta', psi'), the same term for both strains (the seed's
        lambda (zeta' eta')' is (N eta')' with N = lambda zeta'). No strain energy, no axial
        damping: the constraint does no work.
    """
    exact = effects.strain == "exact" and not s.beta and len(s.g) > 0
    vk = effects.strain in ("von_karman", "exact")  # the axial strain: von Karman's (exact: docs/exact-bars.md)
    if exact:
        t = t.with_curvature(basis_a, basis_t)
    t = t.display()  # inner products as display symbols, recorded
    values: dict = {}
    # distributed loads (uniform in xi) in bar axes, gravity included: (beta-bar, gamma-bar)
    groups: tuple = ()
    if loads or gravity is not None:
        groups = load_symbols(s)
        values.update(zip(groups, distributed_groups(s, loads, gravity)))
    beta, gamma = groups if groups else (sp.Integer(0), sp.Integer(0))
    # point forces -> groups (B, Gamma) in bar axes: given in ground axes, a symbol each
    shown = []
    for k, p in enumerate(points):
        if p.ground is not None:
            pair = point_symbols(s, k)
            values.update(zip(pair, point_force_groups(s, *p.ground)))
        else:
            pair = tuple(p.bar)
        shown.append(pair)

    na, nt = len(s.f), len(s.g)
    dth, ddth = s.dth, s.ddth
    f, df, ddf = list(s.f), list(s.df), list(s.ddf)
    g, dg, ddg = list(s.g), list(s.dg), list(s.ddg)
    zf, zg = [0] * na, [0] * nt
    cor = 2 * dth if effects.coriolis else 0
    inext = axial_force is not None

    # eq. (1) divided by l_i w^2, as coefficients over b = [1, xi, phi, psi]
    ax = (
        [s.xa_dd, -(dth**2)]
        + [ddf[k] - dth**2 * f[k] for k in range(na)]
        + [-cor * dg[k] - ddth * g[k] for k in range(nt)]
    )
    ay = [s.ya_dd, ddth] + [cor * df[k] + ddth * f[k] for k in range(na)] + [ddg[k] - dth**2 * g[k] for k in range(nt)]
    pos_x = [0, 1] + f + zg  # xi + zeta
    pos_y = [0, 0] + zf + g  # eta
    one = [1, 0] + zf + zg
    var = bool(s.beta)  # variable span psi(xi, beta): blocks psi_beta, psi_betabeta
    nb = 2 * nt if var else 0
    if var:
        b, db, ddb = s.beta
        ax += [-cor * g[k] * db for k in range(nt)] + [0] * nt
        ay += [2 * dg[k] * db + g[k] * ddb for k in range(nt)] + [g[k] * db**2 for k in range(nt)]
        pos_x, pos_y, one = pos_x + [0] * nb, pos_y + [0] * nb, one + [0] * nb

    def unit(k: int) -> list:
        e = [0] * (2 + na + nt + nb)
        e[k] = 1
        return e

    pts = []
    for p, (B, G) in zip(points, shown):
        phi_k = basis_a.values(p.xi) if na else np.zeros(0)
        psi_k = basis_t.values(p.xi) if nt else np.zeros(0)
        pts.append((p.xi, B, G, [_val(v) for v in phi_k], [_val(v) for v in psi_k]))

    # rigid-body force balance (bar axes) / nu alpha^2
    fx = _ip(t, one, ax) - beta - sp.Add(*[B for _, B, _, _, _ in pts])
    fy = _ip(t, one, ay) - gamma - sp.Add(*[G for _, _, G, _, _ in pts])
    # moment about A / nu alpha^3
    mom = _ip(t, pos_x, ay) - _ip(t, pos_y, ax)
    mom -= gamma * _ip(t, one, pos_x) - beta * _ip(t, one, pos_y)
    for xi, B, G, ph, ps in pts:
        zeta = sp.Add(*[ph[k] * f[k] for k in range(na)])
        eta = sp.Add(*[ps[k] * g[k] for k in range(nt)])
        mom -= (sp.Float(xi) + zeta) * G - eta * B

    # elastic and damping generalized forces (weak, symmetric form)
    lam, mu = s.lam, s.mu
    Ka = [[t.mat("Ka", i, j, r"\left(\phi'_{{{i}}},\phi'_{{{j}}}\right)") for j in range(na)] for i in range(na)]
    Kt = [[t.mat("Kt", i, j, r"\left(\psi''_{{{i}}},\psi''_{{{j}}}\right)") for j in range(nt)] for i in range(nt)]
    quad_a = sp.Add(*[Ka[i][j] * f[i] * f[j] for i in range(na) for j in range(na)]) / 2
    quad_t = sp.Add(*[Kt[i][j] * g[i] * g[j] for i in range(nt) for j in range(nt)]) / 2
    bend4: sp.Expr = sp.Integer(0)  # the exact bar's bending terms beyond mu eta''^2 / 2 (its energy)
    # a slot guide's: its energy and its term in the beta equation (its forces go into el_g)
    bend_guide: sp.Expr = sp.Integer(0)
    bend_beta: sp.Expr = sp.Integer(0)
    # a slot guide's geometry to fourth order: its curvature (E4) and its shortening's kinetic energy (Z)
    guide_fourth = var and nt > 0 and effects.geometric_stiffening and effects.strain != "linear"
    if exact:
        # the exact bar (docs/exact-bars.md): its forces from its tables, not differentiated
        xb = _ExactBar(t, s, Ka, inext, effects.geometric_stiffening, node_form_nodes(basis_a, basis_t))
        strain_energy, el_f, el_g, bend4 = xb.energy_and_forces(quad_a, quad_t, axial_force, damping)
        constraint, constraint_rates = xb.constraint_rows() if inext else ((), ())
        coupling = sp.Integer(0)
    else:
        constraint_rates = ()
        coupling = sp.Integer(0)  # (1/2) sum C3 f g g  = (1/2) int zeta' eta'^2
        quartic = sp.Integer(0)  # (1/2) c^T Ka^-1 c, the projected (1/8) int eta'^4 (below)
        c: list = []  # c_k = (phi'_k, eta'^2 / 2), von Karman and exact, dynamic bars
        if effects.geometric_stiffening and na and nt:
            for k in range(na):
                for a, b in combinations_with_replacement(range(nt), 2):
                    c3 = t.tensor("C3", (k, a, b), r"\left(\phi'_{{{0}}},\psi'_{{{1}}}\psi'_{{{2}}}\right)")
                    mult = 1 if a == b else 2
                    coupling += sp.Rational(mult, 2) * c3 * f[k] * g[a] * g[b]
            if vk and not inext:
                # the strain energy of the axial strain the basis can carry: lambda/2 ||P eps||^2 with P
                # the projection onto span{phi'_k}, = lambda (f^T Ka f / 2 + f^T c + c^T Ka^-1 c / 2),
                # c_k = (phi'_k, eta'^2 / 2). The full lambda/8 int eta'^4 adds lambda/2 ||(1-P) eta'^2/2||^2,
                # a bending stiffness growing with lambda that no axial amplitude can relax: locking.
                # Projected, raising lambda can only approach the inextensible limit (P eps = 0).
                c = [sp.diff(coupling, f[k]) for k in range(na)]
                quartic = sp.Add(*[t.ka_inv(k, j) * c[k] * c[j] for k in range(na) for j in range(na)]) / 2
        if inext:
            strain_energy = sp.Integer(0)  # the axial part is a constraint (no energy)
        elif na and lam is not None:
            strain_energy = lam * (quad_a + (coupling + quartic if vk else 0))
        else:
            strain_energy = sp.Integer(0)
        if nt and mu is not None:
            strain_energy += mu * quad_t
        el_f = [sp.diff(strain_energy, fk) for fk in f]
        el_g = [sp.diff(strain_energy, gk) for gk in g]
        if guide_fourth and mu is not None:
            bend_guide, bend_forces, bend_beta = _shown_as(values, "E", *_guide_curvature(t.numeric, g, s.beta[0]))
            bend_guide, bend_beta = mu * bend_guide, mu * bend_beta
            el_g = [el_g[k] + mu * bend_forces[k] for k in range(nt)]
        constraint = ()
        if axial_force is not None:  # inext
            # (phi'_k, eps) = Ka f + (1/2) (phi'_k, eta'^2) (von Karman, stiffening on); N_k its multiplier
            constraint = tuple(
                sp.Add(*[Ka[k][j] * f[j] for j in range(na)]) + (sp.diff(coupling, f[k]) if vk else 0)
                for k in range(na)
            )
            el_f = [el_f[j] + sp.Add(*[axial_force[k] * Ka[k][j] for k in range(na)]) for j in range(na)]
            # (N eta', psi'_a) = sum_k N_k d(coupling)/d(f_k g_a): the coupling is (1/2) sum C3 f g g
            el_g = [
                el_g[a] + sp.Add(*[axial_force[k] * sp.diff(coupling, f[k], g[a]) for k in range(na)])
                for a in range(nt)
            ]
        if effects.strain == "linear" and lam is not None and coupling != 0 and not inext:
            # the seed's N = EA u': lambda (zeta' eta')' in (9) only, no counterpart in (8)
            el_g = [el_g[a] + lam * sp.diff(coupling, g[a]) for a in range(nt)]
        if damping is not None:
            if lam is not None and not inext and c and not var:
                # Kelvin-Voigt on the strain the basis carries (von Karman, exact): the dissipation
                # D = (damping lam / 2) ||P eps_dot||^2, eps_dot = zeta_dot' + eta' eta_dot', whose
                # coefficients on phi'_k are e_dot = f_dot + Ka^-1 J g_dot, J_ka = d c_k / d g_a. Its
                # forces: dD/df_dot = damping lam (Ka f_dot + J g_dot), dD/dg_dot = damping lam J^T e_dot.
                # Damping zeta_dot' alone (the seed's linear strain, below) would damp the chord's
                # shortening that bending makes, which is no strain: on a soft slider-crank at 6 % of
                # its length deflection that over-damped the rod's vibration by about a third
                # (benchmarks/validation, slider_crank_torque_soft, against Exudyn's ANCF cable, whose
                # axial damping acts on the rate of |r'| - 1). A slot's guide has no axial functions; its
                # curvature rate's beta_dot part is damped below.
                J = [[sp.diff(c[k], g[a]) for a in range(nt)] for k in range(na)]
                jg = [sp.Add(*[J[k][a] * dg[a] for a in range(nt)]) for k in range(na)]
                el_f = [
                    el_f[i] + damping * lam * (sp.Add(*[Ka[i][j] * df[j] for j in range(na)]) + jg[i])
                    for i in range(na)
                ]
                e_dot = [df[k] + sp.Add(*[t.ka_inv(k, j) * jg[j] for j in range(na)]) for k in range(na)]
                el_g = [el_g[a] + damping * lam * sp.Add(*[J[k][a] * e_dot[k] for k in range(na)]) for a in range(nt)]
            elif lam is not None and not inext:
                el_f = [el_f[i] + damping * lam * sp.Add(*[Ka[i][j] * df[j] for j in range(na)]) for i in range(na)]
            if mu is not None:
                el_g = [el_g[i] + damping * mu * sp.Add(*[Kt[i][j] * dg[j] for j in range(nt)]) for i in range(nt)]

    tension: sp.Expr = sp.Integer(0)
    if var and nt and effects.geometric_stiffening:
        # An axially rigid guide (slot.py) has no axial amplitudes whose constraint force would
        # stiffen its bending: its tension is the rigid-body one, N = int_xi^1 (beta_bar - a_x) with
        # a_x = x_A'' - theta'^2 xi (its far end free: a frictionless slot carries no axial force),
        # N = (beta_bar - x_A'') (1 - xi) + theta'^2 (1 - xi^2) / 2. Its virtual work (N eta', d eta')
        # enters (17) and the beta equation as the derivatives of (1/2) (N eta', eta') at fixed N.
        # Without it the guide kept the centrifugal softening theta'^2 eta^2 of its kinetic energy
        # but not the tension's stiffening (the ANCF cable's, and every inextensible bar's here).
        # The point forces given on it add theirs (below); the forces of the joints and bars it carries
        # and of the slot do virtual work on its shortening (slot.SlotBarKinematics: foreshortening).
        T1 = _square(t, "T1", nt, r"\left(\psi'_{{{i}}},(1-\xi)\,\psi'_{{{j}}}\right)")
        T2 = _square(t, "T2", nt, r"\left(\psi'_{{{i}}},\tfrac{{1-\xi^2}}{{2}}\,\psi'_{{{j}}}\right)")
        n1, n2 = beta - s.xa_dd, dth**2
        weights = [[n1 * T1[i][j] + n2 * T2[i][j] for j in range(nt)] for i in range(nt)]
        for xi, B, _G, _ph, _ps in pts:
            # an axial point force (a joint's reaction, a joint's mass, a point load) at xi_p pulls on
            # [0, xi_p]: N gains B H(xi_p - xi), weight int_0^xi_p psi'_a psi'_b (point_tension_name)
            if xi > ZERO_TOL:
                name = point_tension_name(xi)
                label = r"\left(\psi'_{{{i}}},\psi'_{{{j}}}\right)_{{[0,XI]}}".replace("XI", f"{xi:g}")
                H = _square(t, name, nt, label)
                weights = [[weights[i][j] + B * H[i][j] for j in range(nt)] for i in range(nt)]
        tension = sp.Add(*[weights[i][j] * g[i] * g[j] for i in range(nt) for j in range(nt)]) / 2
        el_g = [el_g[a] + sp.diff(tension, g[a]) for a in range(nt)]
    rate_beta: sp.Expr = sp.Integer(0)  # a guide's dD/d(beta_dot): the beta equation's damping
    if var and nt and damping is not None and mu is not None:
        # The guide's material curvature rate has a beta_dot part: kappa_dot = g_dot^T psi'' +
        # beta_dot g^T psi''_beta. Kelvin-Voigt, D = (damping mu / 2) int kappa_dot^2: above its
        # g_dot part, dD/dg_dot_a gains damping mu beta_dot (psi''_a, psi''_b,beta) g_b and the beta
        # equation dD/dbeta_dot = damping mu g_a (psi''_a,beta, kappa_dot) (what an ANCF cable's
        # bending damping acts on: the rate of its material curvature).
        Kb = _square(t, "Kb", nt, r"\left(\psi''_{{{i}}},\psi''_{{{j},\beta}}\right)")
        Kbb = _square(t, "Kbb", nt, r"\left(\psi''_{{{i},\beta}},\psi''_{{{j},\beta}}\right)")
        el_g = [el_g[a] + damping * mu * db * sp.Add(*[Kb[a][c] * g[c] for c in range(nt)]) for a in range(nt)]
        rate_beta = (
            damping
            * mu
            * sp.Add(*[g[a] * (Kb[c][a] * dg[c] + db * Kbb[a][c] * g[c]) for a in range(nt) for c in range(nt)])
        )

    short_g: list = [sp.Integer(0)] * nt  # the guide's shortening's inertia in (17) and the beta equation
    short_beta: sp.Expr = sp.Integer(0)
    short_kinetic: sp.Expr = sp.Integer(0)
    if guide_fourth:
        short_kinetic, short_g, short_beta = _shown_as(values, "Z", *_guide_shortening(t.numeric, g, dg, ddg, b, db))

    eq16 = []
    for k in range(na):
        e = unit(2 + k)
        r = _ip(t, e, ax) + el_f[k] - beta * _ip(t, e, one) - sp.Add(*[B * ph[k] for _, B, _, ph, _ in pts])
        eq16.append(r)
    eq17 = []
    for k in range(nt):
        e = unit(2 + na + k)
        r = _ip(t, e, ay) + el_g[k] - gamma * _ip(t, e, one) - sp.Add(*[G * ps[k] for _, _, G, _, ps in pts])
        eq17.append(r + short_g[k])

    # kinetic energy / nu alpha^3 (bar-axis velocity of A over l_i w: xa_d, ya_d)
    xa_d, ya_d = (names.origin_velocity(ax, s.name).symbol() for ax in "xy")
    vx = [xa_d, 0] + df + [-dth * g[k] for k in range(nt)]
    vy = [ya_d, dth] + [dth * f[k] for k in range(na)] + dg
    eqbeta = None
    if var:
        vx += [0] * nb
        vy += [g[k] * db for k in range(nt)] + [0] * nt
        # d eta' / d beta' = g^T psi_beta: the weight of the support distance's equation
        w = [0] * (2 + na + nt) + g + [0] * nt
        eqbeta = _ip(t, w, ay) + sp.diff(strain_energy + tension, b) - gamma * _ip(t, w, one)
        eqbeta += bend_beta + rate_beta + short_beta
        for _xi, _B, G, _ph, ps in pts:
            eqbeta -= G * sp.Add(*[g[k] * sp.diff(ps[k], b) for k in range(nt)])
    kinetic = (_ip(t, vx, vx) + _ip(t, vy, vy)) / 2 + short_kinetic

    if effects.rotary_inertia and nt and lam is not None and mu is not None:
        rho = mu / lam
        psid1 = [t.vec("psid1", k, r"\left(\psi'_{{{i}}},1\right)") for k in range(nt)]
        Pd = [[t.mat("Pd", i, j, r"\left(\psi'_{{{i}}},\psi'_{{{j}}}\right)") for j in range(nt)] for i in range(nt)]
        mom += rho * (ddth + sp.Add(*[psid1[k] * ddg[k] for k in range(nt)]))
        eq17 = [eq17[i] + rho * (psid1[i] * ddth + sp.Add(*[Pd[i][j] * ddg[j] for j in range(nt)])) for i in range(nt)]
        kinetic += (
            rho
            * (
                dth**2
                + 2 * dth * sp.Add(*[psid1[k] * dg[k] for k in range(nt)])
                + sp.Add(*[Pd[i][j] * dg[i] * dg[j] for i in range(nt) for j in range(nt)])
            )
            / 2
        )
    if exact:
        elastic = strain_energy
    elif inext:
        elastic = (mu * quad_t if (nt and mu is not None) else 0) + bend4
    elif effects.strain == "linear" or not effects.geometric_stiffening:
        elastic = (lam * quad_a if (na and lam is not None) else 0) + (mu * quad_t if (nt and mu is not None) else 0)
        elastic += bend4
    else:
        elastic = strain_energy + bend_guide
    display = BarEquations(
        sym=s,
        force=(fx, fy),
        moment=mom,
        eq16=tuple(eq16),
        eq17=tuple(eq17),
        kinetic=kinetic,
        elastic=sp.sympify(elastic),
        xa_d=xa_d,
        ya_d=ya_d,
        constraint=constraint,
        constraint_rates=constraint_rates,
        eqbeta=eqbeta,
    )
    display = display.map(t.finish)
    values.update(t.values)
    inner = dict(t.used)
    model = display
    form: BarEquations | Callable[[], BarEquations] = display
    if exact:
        # the exact bar's quadrature-table terms: shown expanded over their tables, evaluated at the
        # Gauss nodes in the model (the same polynomials: docs/exact-bars.md, "The node form"); the
        # display form's sums are made on first use (``symgen latex``), their table entries with them:
        # at 3 + 10 functions they were most of the derivation (docs/exact-bars.md, "The first run's cost")
        model = display.substitute(xb.nodes)

        def form(shown: BarEquations = display) -> BarEquations:
            out = shown.substitute(xb.shown)
            values.update(t.values)
            inner.update(t.used)
            return out

    return replace(
        model.substitute(values),
        display_form=form,
        value_table=values,
        inner_product_table=inner,
        points=tuple(shown),
        loads=groups,
    )


#: the name of the guide's curvature table (``_curvature_gram``): (psi'_a psi'_b, psi''_c psi''_d)
#: over [0, 1], rows and columns the pairs a <= b, c <= d (``curvature_pairs``)
CURVATURE = "E4"


def curvature_pairs(nt: int) -> tuple[tuple[int, int], ...]:
    """The index pairs (a, b), a <= b, of the guide's curvature table's rows and columns."""
    return tuple((a, b) for a in range(nt) for b in range(a, nt))


#: the name of the guide's shortening table (``_shortening_gram``): (H_ab, H_cd) over [0, 1],
#: H_ab(xi) = int_0^xi psi'_a psi'_b, rows and columns the pairs of ``curvature_pairs``
SHORTENING = "Z"


def point_tension_name(xi: float) -> str:
    """The name of a slot guide's (H(xi_p - xi) psi'_a, psi'_b) = int_0^xi_p psi'_a psi'_b
    (``slot._point_tension_gram``): the tension weight of an axial point force at xi_p, and the
    shortening of the guide's point xi_p."""
    return f"H{float(xi)!r}"


def _shown_as(values: dict, letter: str, energy: sp.Expr, forces: list, beta_term: sp.Expr) -> tuple:
    r"""A guide's fourth-order terms (``_guide_curvature``, ``_guide_shortening``: made with the
    closed-form tables) as display symbols, the terms their ``values``: the energy
    ``\mathcal{letter}``, its term in (17) k ``\mathcal{letter}_k``, in the beta equation
    ``\mathcal{letter}_\beta``. Shown expanded over their tables (nt(nt+1)/2 squared entries
    each) they were most of a guide's document (a guide of 9 functions: 150 pages); the LaTeX states
    what they are (``backends.latex.slot``)."""
    name = rf"\mathcal{{{letter}}}"
    shown = (
        sp.Symbol(name),
        [sp.Symbol(rf"{name}_{{{k + 1}}}") for k in range(len(forces))],
        sp.Symbol(rf"{name}_{{\beta}}"),
    )
    values[shown[0]], values[shown[2]] = energy, beta_term
    values.update(zip(shown[1], forces))
    return shown


def _guide_curvature(t, g: list, beta: sp.Symbol) -> tuple:
    """(V, [dV/dg_k], dV/dbeta) of V = (1/2) int eta'^2 eta''^2, an axially rigid guide's bending
    energy beyond eta''^2 / 2 per mu (slot.py, ``_curvature_gram``). The guide is inextensible, xi
    its material coordinate: its exact curvature is eta'' / sqrt(1 - eta'^2), whose square is
    eta''^2 (1 + eta'^2) to fourth order in the amplitudes, the order of its shortening
    (slot.SlotBarKinematics) and of its tension's stiffening. Without it a guide at 5 % deflection
    driving a heavy dyad bent 1.6 % of peak off a converged ANCF reference (0.17 % with it).

    V = (1/2) s^T E s, s_P = m_P g_a g_b (P = (a, b), a <= b, m_P = 2 off the diagonal),
    E = (psi'_a psi'_b, psi''_c psi''_d); its forces written from that structure, not
    differentiated: dV/dg_k = sum_{P ni k} g_other(P, k) ((E s)_P + (E^T s)_P)."""
    pairs = curvature_pairs(len(g))
    n = len(pairs)
    sq = [(1 if a == b else 2) * g[a] * g[b] for a, b in pairs]
    table = t.matrix(CURVATURE)  # the closed forms (shown as symbols: ``_shown_as``)
    E = {(i, j): table[i, j] for i in range(n) for j in range(n) if table[i, j] != 0}
    both = [
        sp.Add(*[E[i, j] * sq[j] for j in range(n) if (i, j) in E], *[E[j, i] * sq[j] for j in range(n) if (j, i) in E])
        for i in range(n)
    ]
    forces = [
        sp.Add(*[g[b if a == k else a] * both[i] for i, (a, b) in enumerate(pairs) if k in (a, b)])
        for k in range(len(g))
    ]
    energy = sp.Add(*[e * sq[i] * sq[j] for (i, j), e in E.items()]) / 2
    beta_term = sp.Add(*[sp.diff(e, beta) * sq[i] * sq[j] for (i, j), e in E.items()]) / 2
    return energy, forces, beta_term


def _guide_shortening(t, g: list, dg: list, ddg: list, beta: sp.Symbol, dbeta: sp.Expr) -> tuple:
    """(T, [its Lagrange terms in (17)], its term in the beta equation) of the kinetic energy of an
    axially rigid guide's shortening (slot.py, ``_shortening_gram``), per unit mass:

        T = (1/2) int (sum_ab g_a g_b' H_ab)^2 = (1/2) sum_PQ Z_PQ w_P w_Q,   Z_PQ = (H_P, H_Q),

    w_P the coefficient of H_P (P = (a, b), a <= b) in sum_ab g_a g_b' H_ab. Its points move along
    the chord by u = -1/2 g^T H(xi) g (slot.SlotBarKinematics) as it bends and unbends; its tension
    N keeps the rigid-body part of their axial inertia (theta'^2, x_A''), this is the rest at the
    rate of the amplitudes. Without it a guide ringing at 5 % deflection drifted in phase, 0.4 % of
    peak after a turn (benchmarks/validation/README.md, slot_dyad).

    Lagrange's terms written from the structure, not differentiated: with J_Pk = dw_P/dg'_k (the
    other amplitude of P) and dJ_Pk/dt = dw_P/dg_k, d/dt dT/dg'_k - dT/dg_k = sum_P J_Pk d(Z w)_P/dt,
    d(Z w)/dt = Z w' + beta' Z_beta w; the beta equation has -dT/dbeta = -(1/2) w^T Z_beta w. (The
    differentiated form had nt^2 derivatives of an nt^4-term energy: 5x the first run of a slot
    scene.) Left out: the part of u' from beta' at fixed amplitudes and the Coriolis couplings
    theta' int (eta' u - eta u'), smaller there (docs/exact-bars.md, "Slot guides")."""
    pairs = curvature_pairs(len(g))
    n = len(pairs)
    w = [g[a] * dg[a] if a == b else g[a] * dg[b] + g[b] * dg[a] for a, b in pairs]
    w_rate = [
        dg[a] ** 2 + g[a] * ddg[a] if a == b else 2 * dg[a] * dg[b] + g[a] * ddg[b] + g[b] * ddg[a] for a, b in pairs
    ]
    table = t.matrix(SHORTENING)  # the closed forms, symmetric (shown as symbols: ``_shown_as``)
    Z: dict = {}
    for i in range(n):
        for j in range(i, n):
            if table[i, j] != 0:
                Z[i, j] = Z[j, i] = table[i, j]
    dZ = {key: sp.diff(z, beta) for key, z in Z.items()}
    rate = [sp.Add(*[Z[i, j] * w_rate[j] + dbeta * dZ[i, j] * w[j] for j in range(n) if (i, j) in Z]) for i in range(n)]
    forces = []
    for k in range(len(g)):
        forces.append(sp.Add(*[g[b if a == k else a] * rate[i] for i, (a, b) in enumerate(pairs) if k in (a, b)]))
    kinetic = sp.Add(*[Z[i, j] * w[i] * w[j] for (i, j) in Z]) / 2
    beta_term = -sp.Add(*[dZ[i, j] * w[i] * w[j] for (i, j) in dZ]) / 2
    return kinetic, forces, beta_term


def _square(t, name: str, n: int, latex: str) -> list:
    """The n x n entries of the table's matrix ``name`` (``t.mat``), as rows."""
    return [[t.mat(name, i, j, latex) for j in range(n)] for i in range(n)]


#: False derives every bar's equations itself (``SharedBarEquations``; tests compare the two)
SHARE_BARS = True

#: the fields of ``BarSymbols`` that name one bar's own symbols (a slot guide's beta is not shared)
_OWN = ("th", "dth", "ddth", "f", "df", "ddf", "g", "dg", "ddg", "xa_dd", "ya_dd", "alpha", "nu", "lam", "mu")


class SharedBarEquations:
    """``bar_equations`` of the bars of one derivation, each bar structure derived once.

    A bar's equations depend on its own symbols (coordinates, rates, accelerations, parameters:
    parameters stay symbols) and on its structure: function counts, bases (hence inner products),
    the effects' flags, which loads and point forces act where, gravity, damping. Two bars of the
    same structure get the same equations up to their own symbols, so the first is derived
    (``bar_equations``) and the others are its equations with its symbols replaced by theirs
    (``renamed``: ``xreplace``, each shared subexpression once): the same expressions as their own
    derivation gives (SymPy's sums and products are canonical whatever the symbols' names; tested
    against it, ``tests/test_shared_bars.py``). The display form of a shared bar is renamed on first
    use (``symgen latex``), as the exact bar's own is made.

    What is substituted for a bar's display symbols (its load groups, the groups of point forces
    given in ground axes) is checked: only where the other bar's values are the first one's with
    its symbols replaced (gravity: yes; a joint's reaction or a scene load: no) are the equations
    shared, otherwise that bar is derived itself. A slot's guide and a point load given in bar
    axes are always derived themselves.
    """

    def __init__(self) -> None:
        self._made: dict = {}  # structure key -> (equations, inner products, inputs)
        #: bar -> its equations, for each bar derived itself whose equations others may share
        self.derived: dict[str, BarEquations] = {}
        #: bar -> (the bar whose equations it shares, the renaming {that bar's symbol: this bar's})
        self.shared: dict[str, tuple[str, dict]] = {}

    def __call__(self, s: BarSymbols, basis_a: Basis, basis_t: Basis, t: IPTable, effects, **inputs) -> BarEquations:
        key = _structure(s, basis_a, basis_t, t, effects, **inputs) if SHARE_BARS else None
        made = self._made.get(key) if key is not None else None
        if made is not None and (made[1] is t.ip or _same_tables(made[1], t.ip)):
            out = _instantiate(made[0], made[2], s, inputs)
            if out is not None:
                self.shared[s.name] = (made[0].sym.name, renaming(made[0], made[2], s, inputs))
                return out
        eq = bar_equations(s, basis_a, basis_t, t, effects, **inputs)
        if key is not None and made is None:
            self._made[key] = (eq, t.ip, inputs)
            self.derived[s.name] = eq
        return eq


def _structure(
    s: BarSymbols,
    basis_a: Basis,
    basis_t: Basis,
    t: IPTable,
    effects,
    *,
    loads: tuple = (),
    points: tuple = (),
    gravity: tuple | None = None,
    damping: sp.Expr | None = None,
    axial_force: tuple | None = None,
) -> tuple | None:
    """What a bar's equations depend on besides its own symbols; None: not shared."""
    if s.beta or type(t) is not IPTable or any(p.ground is None for p in points):
        return None
    if axial_force is not None and not all(isinstance(x, sp.Symbol) for x in axial_force):
        return None
    return (
        len(s.f),
        len(s.g),
        s.lam is None,
        s.mu is None,
        basis_a,
        basis_t,
        (effects.strain, effects.coriolis, effects.geometric_stiffening, effects.rotary_inertia),
        bool(loads),
        tuple(p.xi for p in points),
        gravity,
        damping,
        None if axial_force is None else len(axial_force),
    )


def _same_tables(a: InnerProducts, b: InnerProducts) -> bool:
    """The same inner products (the numbers the equations hold)."""
    names_ = ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4")
    return all(np.array_equal(getattr(a, n), getattr(b, n)) for n in names_)


def renaming(eq: BarEquations, inputs0: dict, s: BarSymbols, inputs: dict) -> dict:
    """{symbol of ``eq``'s bar: the symbol of bar ``s``} that makes ``eq`` (derived with ``inputs0``)
    the equations of ``s`` with ``inputs`` (where ``_instantiate`` gives them): the bars' own
    symbols, origin velocities, axial forces and display symbols of loads and point forces."""
    rule: dict = {}

    def pair(a, b) -> None:
        if isinstance(a, tuple):
            for x, y in zip(a, b):
                pair(x, y)
        elif a is not None:
            rule[a] = b

    for name in _OWN:
        pair(getattr(eq.sym, name), getattr(s, name))
    pair((eq.xa_d, eq.ya_d), tuple(names.origin_velocity(ax, s.name).symbol() for ax in "xy"))
    if inputs0.get("axial_force") is not None:
        pair(tuple(inputs0["axial_force"]), tuple(inputs["axial_force"]))
    if eq.loads:
        pair(eq.loads, load_symbols(s))
    for k in range(len(inputs.get("points", ()))):
        pair(eq.points[k], point_symbols(s, k))
    return rule


def _instantiate(eq: BarEquations, inputs0: dict, s: BarSymbols, inputs: dict) -> BarEquations | None:
    """``eq`` (another bar's equations, derived with ``inputs0``) for bar ``s`` with ``inputs``:
    its symbols replaced by those of ``s``; None where what ``bar_equations`` substitutes for the
    display symbols of ``s`` is not the replaced one of ``eq``'s bar."""
    rule = renaming(eq, inputs0, s, inputs)
    xa_d, ya_d = (names.origin_velocity(ax, s.name).symbol() for ax in "xy")  # recorded, as bar_equations does
    memo: dict = {}

    def ren(e):
        return renamed(sp.sympify(e), rule, memo)

    # the display symbols of s and what bar_equations would substitute for them
    own: dict = {}
    groups: tuple = ()
    if eq.loads:
        groups = load_symbols(s)
        own.update(zip(groups, distributed_groups(s, inputs.get("loads", ()), inputs.get("gravity"))))
    shown = []
    for k, p in enumerate(inputs.get("points", ())):
        shown.append(point_symbols(s, k))
        own.update(zip(shown[-1], point_force_groups(s, *p.ground)))
    table0 = eq.value_table
    back = {v: k for k, v in rule.items()}
    targets = set(back)
    if any(sp.sympify(v).free_symbols & targets for v in table0.values()):
        return None  # the first bar's values hold a symbol of this bar: a rename would not be one to one
    if any(ren(table0[back[x]]) != v for x, v in own.items()):
        return None
    values = {ren(k): ren(v) for k, v in table0.items()}
    inner = {ren(k): v for k, v in eq.inner_product_table.items()}

    def form() -> BarEquations:
        shown_form = eq.display  # the first bar's, made on first use (its tables complete then)
        assert shown_form is not None  # bar_equations always gives one
        values.update({ren(k): ren(v) for k, v in eq.value_table.items()})
        inner.update({ren(k): v for k, v in eq.inner_product_table.items()})
        return replace(shown_form.map(ren), sym=s, xa_d=xa_d, ya_d=ya_d)

    return replace(
        eq.map(ren),
        sym=s,
        xa_d=xa_d,
        ya_d=ya_d,
        display_form=form,
        value_table=values,
        inner_product_table=inner,
        points=tuple(shown),
        loads=groups,
    )


_E4 = r"\mathcal{{E}}_{{{0},{1},{2},{3}}}"
_E6 = r"\mathcal{{E}}_{{{0},{1},{2},{3},{4},{5}}}"
_G3 = r"\mathcal{{G}}_{{{0},{1},{2}}}"
_C3 = r"\left(\phi'_{{{0}}},\psi'_{{{1}}}\psi'_{{{2}}}\right)"
_C5 = r"\mathcal{{C}}_{{{0},{1},{2},{3},{4}}}"
_H4 = r"\mathcal{{H}}_{{{0},{1};{2},{3}}}"
_Q4 = r"\mathcal{{Q}}_{{{0},{1};{2},{3}}}"


def _symmetric_form(t: IPTable, name: str, latex: str, head: tuple, order: int, g: list) -> tuple:
    """(S, [dS/dg_a]) of S = sum over all index tuples i of T[head + i] g_i1 ... g_in, T fully
    symmetric in i, written over **sorted** tuples (``_multiplicity``): dS/dg_a is
    n sum over sorted (n-1)-tuples j of mult(j) T[head + sort(a, j)] g^j. Built from the table
    directly: no symbolic differentiation (docs/exact-bars.md, "Derivation cost")."""
    nt = len(g)
    terms = []
    for idx in combinations_with_replacement(range(nt), order):
        v = t.tensor(name, head + idx, latex)
        if v != 0:
            terms.append(sp.Mul(_multiplicity(idx), v, *[g[i] for i in idx]))
    grad = []
    for a in range(nt):
        parts = []
        for j in combinations_with_replacement(range(nt), order - 1):
            v = t.tensor(name, head + tuple(sorted((a, *j))), latex)
            if v != 0:
                parts.append(sp.Mul(order * _multiplicity(j), v, *[g[i] for i in j]))
        grad.append(sp.Add(*parts))
    return sp.Add(*terms), grad


class _ExactBar:
    """The exact bar's strain and bending terms of one bar (``effects.strain = "exact"``,
    docs/exact-bars.md), with their generalized forces written from the tables.

    The axial strain is the exact |r'| - 1 to fourth order on a nearly inextensible bar,
    eps = zeta' + eta'^2 / 2 + eta'^4 / 8, projected onto span{phi'_k}: its Galerkin components
    n_k = (phi'_k, eps) = (Ka f)_k + c_k + d_k, c_k = (1/2) sum C3 g g, d_k = (1/8) sum C5 g^4, and
    the strain the basis carries P eps = sum_k e_k phi'_k, e = Ka^-1 n = f + Ka^-1 (c + d).
    Jt_ka = d(c_k + d_k)/dg_a is the virtual strain of g_a (N eta' (1 + eta'^2 / 2) in the strong form).

    The node form (docs/exact-bars.md, "The node form"): where a sum over a quadrature table (E6;
    C5 in d_k and in Jt's products) has more terms than the bar has Gauss nodes, the model
    evaluates the same polynomial at the nodes (``_NodeForm``); the equations hold a placeholder
    for it, which ``shown`` maps to the sum over the table (the display form, ``symgen latex``)
    and ``nodes`` to the node form. Jt then enters only through its products with a vector,
    Jt x (``right``) and Jt^T y (collected, one per force: ``_left``).
    """

    def __init__(self, t: IPTable, s: BarSymbols, Ka: list, inext: bool, stiffening: bool, nodes: tuple) -> None:
        self.t, self.s, self.Ka, self.inext = t, s, Ka, inext
        f, g = list(s.f), list(s.g)
        na, nt = len(f), len(g)
        self.na, self.nt = na, nt
        self.axial = bool(stiffening and na and nt)
        self.node_form = _NodeForm(nodes, s)
        nq = self.node_form.nq
        # at the nodes where that is cheaper (ops of the function and of its Jacobian, measured:
        # benchmarks/bench_exact_nodes.py): each of E6's Hessian entries has (nt + 3 choose 4) terms
        # against about 3 nodes' work each; each of the C5 part's Jt entries (nt + 2 choose 3)
        self.six_nodes = _NODE_FORM.get("e6", math.comb(nt + 3, 4) > 3 * nq)
        self.c5_nodes = _NODE_FORM.get("c5", math.comb(nt + 2, 3) > nq)
        self._shown_raw: dict = {}
        self._shown: dict | None = None
        self.nodes: dict = {}
        self._memo_nodes: dict = {}
        self.c: list = []
        self.d: list = []
        self.J2: list = []  # Jt's C3 part
        self._Jt: list | None = None  # as shown
        self._right: dict = {}
        # C5's sums over its table: in the model's expression, or (node form) in the display form only,
        # made on first use (``shown``): at 5 + 13 functions they were most of the derivation
        c5 = [functools.cache(lambda k=k: _symmetric_form(t, "C5", _C5, (k,), 4, g)) for k in range(na)]
        self._c5 = c5
        if self.axial:
            for k in range(na):
                c2, j2 = _symmetric_form(t, "C3", _C3, (k,), 2, g)
                self.c.append(c2 / 2)
                if not self.c5_nodes:
                    c5[k]()
                self.d.append(
                    self._stand_in(lambda k=k: c5[k]()[0] / 8, lambda k=k: self.node_form.quartic(k) / 8, self.c5_nodes)
                )
                self.J2.append([j2[a] / 2 for a in range(nt)])
        # n_k = (phi'_k, eps)
        self.n = [sp.Add(*[Ka[k][j] * f[j] for j in range(na)]) + self.c[k] + self.d[k] for k in range(len(self.c))]
        self.e = [
            f[k] + sp.Add(*[t.ka_inv(k, j) * (self.c[j] + self.d[j]) for j in range(na)]) for k in range(len(self.c))
        ]
        # Jt^T y in the forces on g: the display pieces, and y summed (with the other terms of the pieces)
        self._left_shown: list = [[] for _ in range(nt)]
        self._left_other: list = [[] for _ in range(nt)]
        self._left_y: list = [sp.Integer(0)] * na

    @property
    def Jt(self) -> list:
        """Jt_ka = d(c_k + d_k)/dg_a from the tables (C3 and C5's sums): in the model, or (node form)
        in the display form only."""
        if self._Jt is None:
            nt = self.nt
            self._Jt = [[self.J2[k][a] + self._c5[k]()[1][a] / 8 for a in range(nt)] for k in range(len(self.J2))]
        return self._Jt

    def _stand_in(self, shown, node, use: bool) -> sp.Expr:
        """``shown()`` itself, or (``use``) a placeholder for it: ``shown()`` in the display form
        (made on first use: ``shown``), ``node()`` (the same polynomial at the nodes) in the model.
        The placeholders inside either are replaced, so that one pass of each map replaces
        everything."""
        if not use:
            return shown()
        p = sp.Dummy("exact")
        self._shown_raw[p] = shown
        self.nodes[p] = shared_xreplace(node(), self.nodes, self._memo_nodes)
        return p

    @property
    def shown(self) -> dict:
        """Each placeholder -> its sum over the table, the placeholders inside replaced (those made
        before it): made on first use, for the display form only."""
        if self._shown is None:
            memo: dict = {}
            out: dict = {}
            for p, e in self._shown_raw.items():
                out[p] = shared_xreplace(e(), out, memo)
            self._shown = out
        return self._shown

    def right(self, x: list) -> list:
        """[sum_a Jt_ka x_a]_k."""
        key = tuple(x)
        if key not in self._right:
            nt = self.nt
            self._right[key] = [
                self._stand_in(
                    lambda k=k: sp.Add(*[self.Jt[k][a] * x[a] for a in range(nt)]),
                    lambda k=k: sp.Add(*[self.J2[k][a] * x[a] for a in range(nt)]) + self.node_form.right(k, x),
                    self.c5_nodes,
                )
                for k in range(self.na)
            ]
        return self._right[key]

    def _add_left(self, el_g: list, scale: sp.Expr, y: list, other: list | None = None) -> list:
        """``el_g`` plus scale (other_a + sum_k y_k Jt_ka) for each a: added now, or (node form)
        collected into one Jt^T y per force (``_left``)."""
        na, nt = self.na, self.nt
        other = other or [sp.Integer(0)] * nt

        def piece(a: int) -> sp.Expr:
            return scale * (other[a] + sp.Add(*[y[k] * self.Jt[k][a] for k in range(na)]))

        if not self.c5_nodes:
            return [el_g[a] + piece(a) for a in range(nt)]
        for a in range(nt):
            self._left_shown[a].append(functools.partial(piece, a))
            self._left_other[a].append(scale * other[a])
        self._left_y = [self._left_y[k] + scale * y[k] for k in range(na)]
        return el_g

    def _left(self, el_g: list) -> list:
        """``el_g`` with the collected Jt^T y (node form), one placeholder per force."""
        na, nt = self.na, self.nt
        if not any(self._left_shown):
            return el_g
        y = self._left_y
        node = functools.cache(lambda: self.node_form.left(y))
        return [
            el_g[a]
            + self._stand_in(
                lambda a=a: sp.Add(*[piece() for piece in self._left_shown[a]]),
                lambda a=a: (
                    sp.Add(*self._left_other[a]) + sp.Add(*[y[k] * self.J2[k][a] for k in range(na)]) + node()[a]
                ),
                True,
            )
            for a in range(nt)
        ]

    def energy_and_forces(self, quad_a: sp.Expr, quad_t: sp.Expr, axial_force: tuple | None, damping) -> tuple:
        """(strain energy, d/df, d/dg, the bending terms' energy) of the bar, all / nu alpha^3,
        the Kelvin-Voigt forces and an inextensible / quasi-static bar's multiplier forces
        included."""
        t, s, Ka, na, nt = self.t, self.s, self.Ka, self.na, self.nt
        f, g, df, dg = list(s.f), list(s.g), list(s.df), list(s.dg)
        lam, mu = s.lam, s.mu
        zero = sp.Integer(0)
        energy: sp.Expr = zero
        el_f = [zero] * na
        el_g = [zero] * nt
        dynamic = not self.inext and lam is not None and na > 0
        if dynamic and self.axial:
            # lambda/2 ||P eps||^2 = (lambda/2) e^T Ka e: d/df = lambda n, d/dg_a = lambda e^T Jt[:, a]
            energy += lam * sp.Add(*[self.e[k] * self.n[k] for k in range(na)]) / 2
            el_f = [lam * self.n[k] for k in range(na)]
            el_g = self._add_left(el_g, lam, self.e)
            # the exact strain's next term (DERIVE_VERSION 9): |r'| - 1 = eps (1 - eta'^2 / 2) + O(eps^2 eta'^2,
            # eta'^6), so lambda/2 int eps_x^2 = lambda/2 ||P eps||^2 - (lambda/2) int (P eps)^2 eta'^2
            # = ... - (lambda/2) sum_kl e_k e_l W_kl, W_kl = sum Q4_klab g_a g_b. Without it the axial force's
            # transverse virtual work is N sin(theta) (1 + N/lambda): a geometric stiffness too large by
            # N/lambda (docs/exact-bars.md, "Where converged symgen and converged Exudyn still differ")
            W: dict = {}
            for k, m in combinations_with_replacement(range(na), 2):
                W[(k, m)] = _symmetric_form(t, "Q4", _Q4, (k, m), 2, g)
            e = self.e

            def w(k: int, m: int) -> tuple:
                return W[(min(k, m), max(k, m))]

            u = [sp.Add(*[e[m] * w(k, m)[0] for m in range(na)]) for k in range(na)]  # u_k = sum_m W_km e_m
            energy -= lam * sp.Add(*[e[k] * u[k] for k in range(na)]) / 2
            el_f = [el_f[k] - lam * u[k] for k in range(na)]
            ku = [sp.Add(*[t.ka_inv(j, k) * u[k] for k in range(na)]) for j in range(na)]  # Ka^-1 u
            el_g = self._add_left(el_g, sp.S.NegativeOne * lam, ku)
            el_g = [
                el_g[a] - lam * sp.Add(*[e[k] * e[m] * w(k, m)[1][a] for k in range(na) for m in range(na)]) / 2
                for a in range(nt)
            ]
        elif dynamic:
            energy += lam * quad_a
            el_f = [lam * sp.Add(*[Ka[k][j] * f[j] for j in range(na)]) for k in range(na)]
        bend: sp.Expr = zero
        if nt and mu is not None:
            energy += mu * quad_t
            Kt = [
                [t.mat("Kt", i, j, r"\left(\psi''_{{{i}}},\psi''_{{{j}}}\right)") for j in range(nt)] for i in range(nt)
            ]
            el_g = [el_g[a] + mu * sp.Add(*[Kt[a][b] * g[b] for b in range(nt)]) for a in range(nt)]
            # (mu/2) int eta'^2 eta''^2 (E4) and (mu/2) int eta'^4 eta''^2 (E6): the inextensible bar's
            # kappa^2 = eta''^2 / (1 - eta'^2) = eta''^2 (1 + eta'^2 + eta'^4 + ...)
            e4, d4 = _symmetric_form(t, "E4", _E4, (), 4, g)
            sums6 = functools.cache(lambda: _symmetric_form(t, "E6", _E6, (), 6, g))  # (node form) display only
            sixth = functools.cache(self.node_form.sixth)
            e6 = self._stand_in(lambda: sums6()[0], lambda: sixth()[0], self.six_nodes)
            d6 = [
                self._stand_in(lambda a=a: sums6()[1][a], lambda a=a: sixth()[1][a], self.six_nodes) for a in range(nt)
            ]
            bend = mu * (e4 + e6) / 2
            el_g = [el_g[a] + mu * (d4[a] + d6[a]) / 2 for a in range(nt)]
            if dynamic and self.axial:
                # - mu int (eps eta''^2 + eps' eta' eta''), eps = P eps = sum_k e_k phi'_k (zero on an
                # inextensible or quasi-static bar): - mu sum_k e_k g3_k, g3_k = sum G3_kab g_a g_b
                g3, dg3 = zip(*[_symmetric_form(t, "G3", _G3, (k,), 2, g) for k in range(na)])
                bend -= mu * sp.Add(*[self.e[k] * g3[k] for k in range(na)])
                h = [sp.Add(*[t.ka_inv(j, k) * g3[k] for k in range(na)]) for j in range(na)]
                el_f = [el_f[k] - mu * g3[k] for k in range(na)]
                other = [sp.Add(*[self.e[k] * dg3[k][a] for k in range(na)]) for a in range(nt)]
                el_g = self._add_left(el_g, -mu, h, other)
            energy += bend
        if axial_force is not None and na:
            # the multipliers N_k of (phi'_k, eps) = 0 do the virtual work sum_k N_k d n_k
            el_f = [el_f[j] + sp.Add(*[axial_force[k] * Ka[k][j] for k in range(na)]) for j in range(na)]
            if self.axial:
                el_g = self._add_left(el_g, sp.Integer(1), list(axial_force))
        if damping is not None:
            if dynamic and self.axial:
                # Kelvin-Voigt on the rate of the strain the basis carries (as von Karman's, bar_equations):
                # e_dot = f_dot + Ka^-1 Jt g_dot
                jg = self.right(dg)
                el_f = [
                    el_f[i] + damping * lam * (sp.Add(*[Ka[i][j] * df[j] for j in range(na)]) + jg[i])
                    for i in range(na)
                ]
                e_dot = [df[k] + sp.Add(*[t.ka_inv(k, j) * jg[j] for j in range(na)]) for k in range(na)]
                el_g = self._add_left(el_g, damping * lam, e_dot)
            elif dynamic:
                el_f = [el_f[i] + damping * lam * sp.Add(*[Ka[i][j] * df[j] for j in range(na)]) for i in range(na)]
            if nt and mu is not None:
                Kt = [
                    [t.mat("Kt", i, j, r"\left(\psi''_{{{i}}},\psi''_{{{j}}}\right)") for j in range(nt)]
                    for i in range(nt)
                ]
                # Kelvin-Voigt on the rate of the exact curvature (the ANCF cable's bending damping acts on
                # kappa_dot): D = (c mu / 2) g_dot^T (Kt + H(g)) g_dot, H_ab = sum_{c<=d} mult H4_abcd g_c g_d,
                # to fourth order (kappa = eta'' (1 + eta'^2 / 2) where the strain vanishes)
                pairs = list(combinations_with_replacement(range(nt), 2))
                H = {}
                for a, b in pairs:
                    terms = []
                    for cc, dd in pairs:
                        v = t.tensor("H4", (a, b, cc, dd), _H4)
                        if v != 0:
                            terms.append(sp.Mul(_multiplicity((cc, dd)), v, g[cc], g[dd]))
                    H[(a, b)] = sp.Add(*terms)
                # (its node form measured more costly in the Jacobian: Kt + H is the Jacobian in g_dot)
                el_g = [
                    el_g[i]
                    + damping * mu * sp.Add(*[(Kt[i][j] + H[(min(i, j), max(i, j))]) * dg[j] for j in range(nt)])
                    for i in range(nt)
                ]
        return energy, el_f, self._left(el_g), bend

    def constraint_rows(self) -> tuple:
        """((n_k), ((dn_k/dt, d2n_k/dt2))) of an inextensible or quasi-static bar: (phi'_k, eps) = 0
        and its rates, n_dot = Ka f_dot + Jt g_dot, n_ddot = Ka f_ddot + Jt g_ddot +
        sum C3 g_dot g_dot + (3/2) sum C5 g_dot g_dot g g."""
        t, s, Ka, na, nt = self.t, self.s, self.Ka, self.na, self.nt
        f, df, ddf = list(s.f), list(s.df), list(s.ddf)
        g, dg, ddg = list(s.g), list(s.dg), list(s.ddg)
        if not self.axial:
            rows = tuple(sp.Add(*[Ka[k][j] * f[j] for j in range(na)]) for k in range(na))
            first = tuple(
                (sp.Add(*[Ka[k][j] * df[j] for j in range(na)]), sp.Add(*[Ka[k][j] * ddf[j] for j in range(na)]))
                for k in range(na)
            )
            return rows, first
        rates: list[tuple] = []
        pairs = list(combinations_with_replacement(range(nt), 2))
        jdg, jddg = self.right(dg), self.right(ddg)
        for k in range(na):
            vel = sp.Add(*[Ka[k][j] * df[j] for j in range(na)]) + jdg[k]
            acc = [Ka[k][j] * ddf[j] for j in range(na)] + [jddg[k]]

            def quad(k: int, a: int, b: int) -> list:  # (3/2) sum C5 g g at (k, a, b)
                out = []
                for cc, dd in pairs:
                    v = t.tensor("C5", (k, *sorted((a, b, cc, dd))), _C5)
                    if v != 0:
                        out.append(sp.Mul(sp.Rational(3, 2) * _multiplicity((cc, dd)), v, g[cc], g[dd]))
                return out

            def quartic(k: int) -> sp.Expr:  # (3/2) sum C5 g_dot g_dot g g = (3/2) (phi'_k, eta_dot'^2 eta'^2)
                return sp.Add(*[sp.Mul(_multiplicity((a, b)), dg[a], dg[b], sp.Add(*quad(k, a, b))) for a, b in pairs])

            for a, b in pairs:
                m = _multiplicity((a, b))
                if self.c5_nodes:  # C3's part here, C5's at the nodes (its sums in the display form only)
                    acc.append(sp.Mul(m, dg[a], dg[b], t.tensor("C3", (k, a, b), _C3)))
                else:
                    acc.append(sp.Mul(m, dg[a], dg[b], sp.Add(t.tensor("C3", (k, a, b), _C3), *quad(k, a, b))))
            if self.c5_nodes and pairs:
                acc.append(
                    self._stand_in(
                        functools.partial(quartic, k), functools.partial(self.node_form.quartic_rate, k), True
                    )
                )
            rates.append((vel, sp.Add(*acc)))
        return tuple(self.n), tuple(rates)


class _NodeForm:
    """The exact bar's sums over its quadrature tables (E6, C5) evaluated at Gauss-Legendre
    nodes xi_q with weights w_q (``shape_cache.node_form_nodes``), from the slope
    s_q = eta'(xi_q) = sum_a psi'_a(xi_q) g_a and the curvature c_q = eta''(xi_q) (linear in g):
    the same polynomials as the sums over sorted tuples, whose entries are the same integrals by
    quadrature (docs/exact-bars.md, "The node form")."""

    def __init__(self, nodes: tuple, s: BarSymbols) -> None:
        W, A, B, F = nodes
        self.nq = len(W)
        self.W, self.A, self.B, self.F = W, A, B, F
        self.g = list(s.g)
        self._dg = tuple(s.dg)
        self._sl: list | None = None
        self._cu: list | None = None
        self._at: dict = {}

    @property
    def sl(self) -> list:  # eta' at the nodes
        if self._sl is None:
            self._sl = [_lin(self.A[q], self.g) for q in range(self.nq)]
        return self._sl

    @property
    def cu(self) -> list:  # eta'' at the nodes
        if self._cu is None:
            self._cu = [_lin(self.B[q], self.g) for q in range(self.nq)]
        return self._cu

    def at_nodes(self, x: list) -> list:
        """x' = sum_a psi'_a(xi_q) x_a at each node, made once per x (``right`` asks for it once per
        axial function: at 5 + 13 functions this was a quarter of the derivation)."""
        key = tuple(x)
        if key not in self._at:
            self._at[key] = [_lin(self.A[q], x) for q in range(self.nq)]
        return self._at[key]

    def sixth(self) -> tuple:
        """(int eta'^4 eta''^2, [its derivative in g_a]): E6's sums (``_symmetric_form``)."""
        W, A, B, sl, cu = self.W, self.A, self.B, self.sl, self.cu
        qs = range(self.nq)
        energy = sp.Add(*[_f(W[q]) * sl[q] ** 4 * cu[q] ** 2 for q in qs])
        t1 = [sl[q] ** 3 * cu[q] ** 2 for q in qs]
        t2 = [sl[q] ** 4 * cu[q] for q in qs]
        grad = [
            sp.Add(*[_f(4 * W[q] * A[q, a]) * t1[q] + _f(2 * W[q] * B[q, a]) * t2[q] for q in qs])
            for a in range(A.shape[1])
        ]
        return energy, grad

    def quartic(self, k: int) -> sp.Expr:
        """(phi'_k, eta'^4): C5's sum."""
        return sp.Add(*[_f(self.W[q] * self.F[q, k]) * self.sl[q] ** 4 for q in range(self.nq)])

    def right(self, k: int, x: list) -> sp.Expr:
        """sum_a x_a d/dg_a (phi'_k, eta'^4) / 8 = (phi'_k, eta'^3 x') / 2, x' = sum_a psi'_a x_a."""
        W, F, sl, xq = self.W, self.F, self.sl, self.at_nodes(x)
        return sp.Add(*[_f(W[q] * F[q, k] / 2) * sl[q] ** 3 * xq[q] for q in range(self.nq)])

    def left(self, y: list) -> list:
        """[sum_k y_k d/dg_a (phi'_k, eta'^4) / 8]_a = [(y . phi' eta'^3, psi'_a) / 2]_a."""
        W, A, F, sl = self.W, self.A, self.F, self.sl
        yq = [_lin(F[q], y) * sl[q] ** 3 for q in range(self.nq)]
        return [sp.Add(*[_f(W[q] * A[q, a] / 2) * yq[q] for q in range(self.nq)]) for a in range(A.shape[1])]

    def quartic_rate(self, k: int) -> sp.Expr:
        """(3/2) (phi'_k, eta'^2 eta_dot'^2): C5's sum in the constraint's second rate (at g_dot)."""
        W, F, sl, dq = self.W, self.F, self.sl, self.at_nodes(list(self._dg))
        return sp.Add(*[_f(1.5 * W[q] * F[q, k]) * sl[q] ** 2 * dq[q] ** 2 for q in range(self.nq)])


#: benchmarks only (``bench_exact_nodes``): {"e6": bool, "c5": bool} forces the choice of ``_ExactBar``
_NODE_FORM: dict = {}


def _f(v: float) -> sp.Expr:
    """A node-form coefficient (0 only where it is exactly 0)."""
    return sp.Float(float(v), 17) if v != 0.0 else sp.Integer(0)


def _lin(row, xs: list) -> sp.Expr:
    return sp.Add(*[_f(v) * x for v, x in zip(row, xs)])


def shared_xreplace(expr: sp.Basic, rule: dict, memo: dict) -> sp.Basic:
    """``expr.xreplace(rule)``, the same expression, with each distinct subexpression replaced
    once: ``memo`` maps what was already replaced to its result (the exact bar's forces share
    their strain components e_k, Jt_ka among many terms: xreplace rebuilds every copy)."""
    out = memo.get(expr)
    if out is not None:
        return out
    if expr in rule:
        out = rule[expr]
    elif not expr.args:
        out = expr
    else:
        args = [shared_xreplace(a, rule, memo) for a in expr.args]
        out = expr if all(a is b for a, b in zip(args, expr.args)) else expr.func(*args)
    memo[expr] = out
    return out


_CANONICAL = functools.cmp_to_key(sp.Basic.compare)  # the order of the terms of SymPy's sums and products


def renamed(expr: sp.Basic, rule: dict, memo: dict) -> sp.Basic:
    """``expr.xreplace(rule)`` for a ``rule`` that renames symbols one to one (each to a symbol of
    the same assumptions, none to one already in ``expr``), each distinct subexpression once.

    Renaming leaves a canonical expression canonical up to the order of the terms of its sums and
    products (no two terms or factors become alike, no number appears), so those are rebuilt by
    sorting their terms as SymPy's ``Add.flatten`` / ``Mul.flatten`` do (the number coefficient
    first) rather than by flattening them again: the same expression as ``xreplace`` gives, at a
    fraction of its cost on the large sums of a bar's equations (tested: ``test_shared_bars``)."""
    out = memo.get(expr)
    if out is not None:
        return out
    if expr in rule:
        out = rule[expr]
    elif not expr.args:
        out = expr
    else:
        args = [renamed(a, rule, memo) for a in expr.args]
        if all(a is b for a, b in zip(args, expr.args)):
            out = expr
        elif type(expr) in (sp.Add, sp.Mul) and expr.is_commutative:
            head = 1 if args[0].is_Number else 0
            out = type(expr)._from_args(args[:head] + sorted(args[head:], key=_CANONICAL), True)
        else:
            out = expr.func(*args)
    memo[expr] = out
    return out


def _multiplicity(idx: tuple) -> int:
    """How many index tuples sort to ``idx``: the weight of its monomial in a sum over all
    tuples of a fully symmetric tensor."""
    out = math.factorial(len(idx))
    for k in set(idx):
        out //= math.factorial(idx.count(k))
    return out


def load_symbols(s: BarSymbols) -> tuple:
    """Display symbols (beta-bar, gamma-bar) of a bar's distributed load groups."""
    B = names.upright(s.name)
    return sp.Symbol(rf"\bar\beta_{{{B}}}"), sp.Symbol(rf"\bar\gamma_{{{B}}}")


def point_symbols(s: BarSymbols, k: int) -> tuple:
    """Display symbols (B, Gamma) of point force ``k`` (0-based) of a bar, given in ground axes
    (the LaTeX backend names them after their joint)."""
    B = names.upright(s.name)
    return sp.Symbol(rf"B_{{{B},{k + 1}}}"), sp.Symbol(rf"\Gamma_{{{B},{k + 1}}}")


def distributed_groups(s: BarSymbols, loads: tuple, gravity: tuple | None) -> tuple:
    """(beta, gamma): the uniform distributed load groups of a bar in its own axes,
    / (m_i l_i omega^2): the scene's loads plus gravity (g / l0 omega^2, ground axes) / alpha."""
    beta = sp.Add(*[b for b, _ in loads])
    gamma = sp.Add(*[c for _, c in loads])
    if gravity is not None:
        gx, gy = gravity
        bx, by = to_bar_axes(s.th, gx, gy)
        beta += bx / s.alpha
        gamma += by / s.alpha
    return beta, gamma


def _val(v) -> sp.Expr:
    """A shape-function value: a number, or an expression (variable span psi(xi, beta))."""
    return v if isinstance(v, sp.Basic) else _num(v)


def _num(v: float) -> sp.Expr:
    return sp.Integer(0) if abs(v) < ZERO_TOL else sp.Float(float(v), 17)
