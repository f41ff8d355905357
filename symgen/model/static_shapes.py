"""Static correction functions at interior points of elastic bars (issue 12, Deliver 1).

A joint, point load or lumped mass at ``0 < xi_K < 1`` of an elastic bar transmits a point
force there; the bar's smooth shape functions (sines, clamped-free eigenfunctions) converge
slowly on the kink of the shear force it causes. The *static correction function* is the
bar's static deflection under a unit force at ``xi_K`` in its deformation frame
(Euler-Bernoulli, ``EI = 1``, ``l = 1``), Gram-Schmidt orthogonalised in the mass inner
product against the bar's other functions and scaled to the value 1 at ``xi_K``, exactly as
the cantilever tip-load shape (``_tip_load_function`` of :mod:`symgen.model.shapes`) is:

* pinned-pinned (chord frame): ``b xi (1 - b^2 - xi^2)/6`` left of ``xi_K = a``,
  ``a (1-xi)(1 - a^2 - (1-xi)^2)/6`` right of it (``b = 1 - a``);
* cantilever: ``xi^2 (3a - xi)/6`` left, ``a^2 (3 xi - a)/6`` right;
* axial (``phi(0) = 0``, free end): ``xi`` left, ``a`` right.

A rigid body with a rotary inertia or an offset arm at ``xi_K`` (a ``[[masses]]`` entry, a
joint's rotary inertia) also transmits a point *moment* there: the section rotation
``eta'(xi_K)`` carries its inertia, and the smooth functions converge slowly on the jump of the
bending moment it causes. Those points get a second, *moment* correction function: the static
deflection under a unit couple at ``xi_K`` (``w''`` jumps by -1 there, ``w'`` is continuous
with a kink), orthogonalised the same way (also against the force correction functions) and
scaled to the slope 1 at ``xi_K``:

* pinned-pinned: ``xi^3/6 + (a^2/2 - a + 1/3) xi`` left,
  ``xi^3/6 - xi^2/2 + (a^2/2 + 1/3) xi - a^2/2`` right;
* cantilever: ``xi^2/2`` left, ``a xi - a^2/2`` right.

These are piecewise polynomials, so the inner products stay closed form: the exact
integrator of :mod:`symgen.model.terms` is extended here to sub-intervals ``[lo, hi]`` of
``[0, 1]`` (``int_lo^hi xi^p exp(s xi)`` in closed form at the engine's 50 digits; ``xi_K``
enters as the exact rational of the scene's float). Their inner products are cached by
:mod:`symgen.model.shape_cache`.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any
from collections.abc import Sequence

import numpy as np
import sympy

from symgen.ir.spec import BodySpec
from symgen.model.shapes import (
    XI,
    Basis,
    CurvatureProducts,
    InnerProducts,
    ShapeFunction,
    axial_basis,
    basis_of_key,
    curvature_tables,
    transverse_basis,
)
from symgen.model.terms import DPS, MP, Table, Terms, multiply, new_terms, poly_terms, s_add, s_value

__all__ = [
    "STATIC_KINDS",
    "STATIC_LOADS",
    "Piecewise",
    "StaticCorrection",
    "static_correction",
    "piecewise_inner",
    "piecewise_inner_products",
    "piecewise_curvature_products",
    "SixthOrderProducts",
    "sixth_order_products",
    "static_polynomials",
    "corrected_basis",
    "bar_bases",
    "STATIC_VERSION",
]

#: (direction, frame) pairs that have a static correction function.
STATIC_KINDS = ("pinned-pinned", "cantilever", "axial")

#: what the static shape is the deflection under: a unit point force, or a unit couple
#: (transverse kinds only)
STATIC_LOADS = ("force", "moment")

#: bump when a change here changes a cached number of the corrected bases (part of their cache
#: entries' names, :mod:`symgen.model.shape_cache`)
STATIC_VERSION = "1"


# --------------------------------------------------------------------------------------
# Closed-form integrals over sub-intervals
# --------------------------------------------------------------------------------------
def _j01(p: int, z: Any) -> Any:
    """``int_0^1 u^p exp(z u) du`` at 50 digits, closed form (series when ``|z| < 2``)."""
    if z == 0:
        return MP.mpc(1) / (p + 1)
    if abs(z.real) + abs(z.imag) < 2:
        r, term, j = MP.mpc(0), MP.mpc(1), 0
        while True:
            add = term / (p + j + 1)
            r += add
            if j > 4 and abs(add) < MP.mpf(10) ** (-DPS - 5) * max(abs(r), 1):
                return r
            j += 1
            term = term * z / j
    e = MP.exp(z)
    r = (e - 1) / z
    for q in range(1, p + 1):
        r = e / z - q * r / z
    return r


_J_UPTO: dict[tuple[int, int, Any], Any] = {}


def _j_upto(p: int, s: int, x: Any) -> Any:
    """``int_0^x t^p exp(s t) dt = x^(p+1) int_0^1 u^p exp(s x u) du`` (memoised; exponent
    ids are only ever created, never recycled, for the exponents of our functions)."""
    if x == 0:
        return MP.mpc(0)
    key = (p, s, x)
    r = _J_UPTO.get(key)
    if r is None:
        sv = s_value(s) if s else 0
        r = _J_UPTO[key] = x ** (p + 1) * _j01(p, sv * x)
    return r


def _integrate_product_on(a: Terms, b: Terms, lo: Any, hi: Any) -> Any:
    """``int_lo^hi a b dxi`` of two real functions, term by term in closed form: the conjugate
    exponent pairs of ``a`` folded (the real part of the sum over one of each pair, doubled, is
    the sum) and the products' coefficients gathered per exponent before each integral is taken."""
    a, b = a.as_mp(), b.as_mp()
    acc: dict[tuple[int, int], Any] = {}
    B = list(b.d.items())
    for p1, s1, c1 in a.half_items():
        for (p2, s2), c2 in B:
            key = (p1 + p2, s_add(s1, s2))
            c = c1 * c2
            prev = acc.get(key)
            acc[key] = c if prev is None else prev + c
    tot = MP.mpc(0)
    for (p, s), c in acc.items():
        tot += c * (_j_upto(p, s, hi) - _j_upto(p, s, lo))
    return MP.mpf(tot.real)


# --------------------------------------------------------------------------------------
# Piecewise functions
# --------------------------------------------------------------------------------------
def _mpq(q: Fraction) -> Any:
    return MP.mpf(q.numerator) / q.denominator


@dataclass(frozen=True)
class Piecewise:
    """``f(xi) = pieces[i](xi)`` on ``[breaks[i], breaks[i+1]]``; ``breaks`` are exact rationals
    from 0 to 1. A plain :class:`ShapeFunction` is the one-piece case."""

    breaks: tuple[Fraction, ...]
    pieces: tuple[Terms, ...]

    @staticmethod
    def of(f: ShapeFunction | Piecewise) -> Piecewise:
        if isinstance(f, Piecewise):
            return f
        if isinstance(f, StaticCorrection):
            return f.function
        if f.terms is None:
            raise ValueError(f"shape function {f.label!r} has no term form")
        return Piecewise((Fraction(0), Fraction(1)), (f.terms,))

    def piece_at(self, xi: float | Fraction, right: bool = True) -> Terms:
        x = Fraction(xi)
        for i in range(len(self.pieces)):
            lo, hi = self.breaks[i], self.breaks[i + 1]
            if (lo <= x < hi) if right else (lo < x <= hi):
                return self.pieces[i]
        return self.pieces[-1] if x >= self.breaks[-1] else self.pieces[0]

    def value(self, xi: float, deriv: int = 0, right: bool = True) -> float:
        """The ``deriv``-th derivative at ``xi`` (one-sided at a break: ``right`` picks the
        piece that starts there)."""
        return self.piece_at(xi, right).evaluate(xi, deriv)

    def deriv(self, order: int) -> Piecewise:
        return Piecewise(self.breaks, tuple(t.deriv(order) for t in self.pieces))


def piecewise_inner(f: Any, g: Any, deriv: int = 0) -> float:
    """Closed-form ``int_0^1 f^(deriv) g^(deriv) dxi`` of two (piecewise) shape functions."""
    return float(_inner_mp(Piecewise.of(f), Piecewise.of(g), deriv))


def _inner_mp(f: Piecewise, g: Piecewise, deriv: int = 0) -> Any:
    cuts = sorted(set(f.breaks) | set(g.breaks))
    tot = MP.mpf(0)
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        mid = (lo + hi) / 2
        a = f.piece_at(mid).deriv(deriv)
        b = g.piece_at(mid).deriv(deriv)
        tot += _integrate_product_on(a, b, _mpq(lo), _mpq(hi))
    return tot


# --------------------------------------------------------------------------------------
# The static shapes and their orthogonalisation
# --------------------------------------------------------------------------------------
def _pmul(p: list[Fraction], q: list[Fraction]) -> list[Fraction]:
    out = [Fraction(0)] * (len(p) + len(q) - 1)
    for i, a in enumerate(p):
        for j, b in enumerate(q):
            out[i + j] += a * b
    return out


def _padd(*ps: list[Fraction]) -> list[Fraction]:
    out = [Fraction(0)] * max(len(p) for p in ps)
    for p in ps:
        for i, a in enumerate(p):
            out[i] += a
    return out


def static_polynomials(kind: str, xi_k: float, load: str = "force") -> tuple[Fraction, list[Fraction], list[Fraction]]:
    """``(a, left, right)``: the exact rational ``a`` of ``xi_k`` and the power-series
    coefficients (lowest first) of the static shape under a unit ``load`` ("force" or
    "moment") left and right of it."""
    if kind not in STATIC_KINDS:
        raise ValueError(f"unknown static correction kind {kind!r}; expected one of {STATIC_KINDS}")
    if load not in STATIC_LOADS or (load == "moment" and kind == "axial"):
        raise ValueError(
            f"unknown static load {load!r} for kind {kind!r}; expected 'force', or 'moment' for a transverse kind"
        )
    a = Fraction(xi_k)
    if not 0 < a < 1:
        raise ValueError(f"static correction point must be inside the bar (0 < xi < 1), got {xi_k!r}")
    b = 1 - a
    if load == "moment":  # w'' = the bending moment of a unit couple at a: jumps by -1 there
        if kind == "pinned-pinned":
            left = [Fraction(0), a * a / 2 - a + Fraction(1, 3), Fraction(0), Fraction(1, 6)]
            right = [-a * a / 2, a * a / 2 + Fraction(1, 3), Fraction(-1, 2), Fraction(1, 6)]
        else:
            left = [Fraction(0), Fraction(0), Fraction(1, 2)]
            right = [-a * a / 2, a]
        return a, left, right
    if kind == "pinned-pinned":
        left = [Fraction(0), b * (1 - b * b) / 6, Fraction(0), -b / 6]
        y = [Fraction(1), Fraction(-1)]  # 1 - xi
        right = [c * a / 6 for c in _pmul(y, _padd([1 - a * a], [-c for c in _pmul(y, y)]))]
    elif kind == "cantilever":
        left = [Fraction(0), Fraction(0), a / 2, Fraction(-1, 6)]
        right = [-(a**3) / 6, a * a / 2]
    else:
        left = [Fraction(0), Fraction(1)]
        right = [a]
    return a, left, right


def _poly_mp(coeffs: Sequence[Fraction]) -> Terms:
    return new_terms({(p, 0): MP.mpc(_mpq(c)) for p, c in enumerate(coeffs) if c}, exact=False)


@dataclass(frozen=True)
class StaticCorrection:
    """A static correction function ``(w_K - sum_k c_k f_k) / t``.

    Attributes
    ----------
    kind : "pinned-pinned" | "cantilever" (transverse) or "axial"
    xi_k : the point (the scene's float); ``a`` its exact rational
    left, right : coefficients of the raw static shape ``w_K`` on ``[0, a]`` and ``[a, 1]``
    coeffs : the mass-inner-product projections ``c_k`` on the bar's other functions
    scale : ``t``, the value of ``w_K - sum c_k f_k`` at ``xi_k`` (so the function is 1 there);
        for a moment correction its slope there (so the function's slope is 1 there)
    label : LaTeX label, e.g. ``\\chi_{0.3}``; ``\\chi^{M}_{0.3}`` for a moment correction
    load : "force" (a unit point force at ``xi_k``) or "moment" (a unit couple)
    """

    kind: str
    xi_k: float
    a: Fraction
    left: tuple[Fraction, ...]
    right: tuple[Fraction, ...]
    coeffs: tuple[float, ...]
    scale: float
    label: str
    function: Piecewise = field(compare=False, repr=False)
    expr: Any = field(default=None, compare=False, repr=False)  # sympy, in XI (set by corrected_basis)
    load: str = "force"

    # what the emitters ask of every shape function (ShapeFunction's attributes)
    beta = None
    sigma = None
    tip_value = None
    terms = None

    def value(self, xi: float, deriv: int = 0) -> float:
        return self.function.value(xi, deriv)


def static_correction(kind: str, xi_k: float, others: Sequence[Any], load: str = "force") -> StaticCorrection:
    """The static correction function of a bar at ``xi_k`` for a unit point ``load``.

    Parameters
    ----------
    kind : "pinned-pinned" or "cantilever" (transverse, frame of the bar) or "axial"
    xi_k : the interior point, ``0 < xi_k < 1``
    others : the bar's other functions of that direction (ShapeFunction, Piecewise or
        StaticCorrection): the correction is made mass-orthogonal to all of them (the Gram
        system is solved, so they need not be orthogonal among themselves)
    load : "force" (value 1 at ``xi_k``) or "moment" (a unit couple, transverse kinds only;
        slope 1 at ``xi_k``)

    Raises
    ------
    ValueError : unknown kind or load, point not inside the bar, or the static shape already
        lies in the span of ``others`` (nothing left to add)
    """
    a, left, right = static_polynomials(kind, xi_k, load)
    w = Piecewise((Fraction(0), a, Fraction(1)), (_poly_mp(left), _poly_mp(right)))
    fs = [Piecewise.of(f) for f in others]
    m = len(fs)
    coeffs: list[Any] = []
    if m:
        G = MP.matrix(m, m)
        r = MP.matrix(m, 1)
        for i in range(m):
            r[i] = _inner_mp(w, fs[i])
            for j in range(i, m):
                G[i, j] = G[j, i] = _inner_mp(fs[i], fs[j])
        c = MP.lu_solve(G, r)
        coeffs = [c[i] for i in range(m)]
    breaks = sorted(set(w.breaks).union(*(f.breaks for f in fs)))
    pieces: list[dict[tuple[int, int], Any]] = []  # inexact terms: mpc coefficients
    for lo, hi in zip(breaks[:-1], breaks[1:]):
        mid = (lo + hi) / 2
        d = dict(w.piece_at(mid).d)
        for ck, f in zip(coeffs, fs):
            for key, val in f.piece_at(mid).as_mp().d.items():
                d[key] = d.get(key, MP.mpc(0)) - ck * val
        pieces.append(d)
    rest = Piecewise(tuple(breaks), tuple(Terms(d, exact=False) for d in pieces))
    t = rest.value(xi_k, 1 if load == "moment" else 0)
    if abs(t) < 1e-13 * max(1.0, max(abs(float(x)) for x in (left + right))):
        raise ValueError(
            f"the static shape at xi = {xi_k} already lies in the span of the "
            "bar's functions: no correction function to add"
        )
    scaled = Piecewise(rest.breaks, tuple(Terms({k: v / t for k, v in p.items()}, exact=False) for p in pieces))
    label = (r"\chi^{M}_{%s}" if load == "moment" else r"\chi_{%s}") % format(float(xi_k), "g")
    return StaticCorrection(
        kind,
        float(xi_k),
        a,
        tuple(left),
        tuple(right),
        tuple(float(c) for c in coeffs),
        float(t),
        label,
        scaled,
        load=load,
    )


# --------------------------------------------------------------------------------------
# Every inner product of a bar whose bases hold correction functions
# --------------------------------------------------------------------------------------
def piecewise_inner_products(axial: Sequence[Any], transverse: Sequence[Any]) -> InnerProducts:
    """The :class:`symgen.model.shapes.InnerProducts` of a bar whose axial functions ``axial`` and
    transverse functions ``transverse`` may include piecewise (static correction) functions.

    Same tables and conventions as :func:`symgen.model.shapes.inner_products`; every integral is
    split at the union of the functions' break points and done in closed form on each piece
    (50 digits; the ``exact`` tables hold 50-digit Floats).
    """
    phi = [Piecewise.of(f) for f in axial]
    psi = [Piecewise.of(f) for f in transverse]
    na, nt = len(phi), len(psi)
    cuts = sorted(set().union({Fraction(0), Fraction(1)}, *(f.breaks for f in phi + psi)))
    ivals = [(lo, hi, (lo + hi) / 2) for lo, hi in zip(cuts[:-1], cuts[1:])]
    lims = [(_mpq(lo), _mpq(hi)) for lo, hi, _ in ivals]
    one, xi = poly_terms({0: Fraction(1)}).as_mp(), poly_terms({1: Fraction(1)}).as_mp()

    def at(fs: list[Piecewise], d: int) -> list[list[Terms]]:  # [function][interval]
        return [[f.piece_at(mid).as_mp().deriv(d) for _, _, mid in ivals] for f in fs]

    b = [[one] * len(ivals), [xi] * len(ivals)] + at(phi, 0) + at(psi, 0)
    dphi, dpsi, ddpsi = at(phi, 1), at(psi, 1), at(psi, 2)

    def ip(u: list[Terms], v: list[Terms]) -> Any:
        return sum((_integrate_product_on(x, y, lo, hi) for x, y, (lo, hi) in zip(u, v, lims)), MP.mpf(0))

    N = len(b)
    gram = Table((N, N))
    for i in range(N):
        for j in range(i, N):
            gram.set({(i, j), (j, i)}, MP.mpc(ip(b[i], b[j])))
    Ka = Table((na, na))
    for i in range(na):
        for j in range(i, na):
            Ka.set({(i, j), (j, i)}, MP.mpc(ip(dphi[i], dphi[j])))
    Kt, Pd = Table((nt, nt)), Table((nt, nt))
    for i in range(nt):
        for j in range(i, nt):
            Kt.set({(i, j), (j, i)}, MP.mpc(ip(ddpsi[i], ddpsi[j])))
            Pd.set({(i, j), (j, i)}, MP.mpc(ip(dpsi[i], dpsi[j])))
    psid1 = Table((nt,))
    for a in range(nt):
        psid1.set({(a,)}, MP.mpc(ip(dpsi[a], [one] * len(ivals))))
    pairs = [(a, c) for a in range(nt) for c in range(a, nt)]
    P = {(a, c): [multiply(x, y) for x, y in zip(dpsi[a], dpsi[c])] for a, c in pairs}
    C3 = Table((na, nt, nt))
    for k in range(na):
        for a, c in pairs:
            C3.set({(k, a, c), (k, c, a)}, MP.mpc(ip(dphi[k], P[(a, c)])))
    D4 = Table((nt, nt, nt, nt))
    for idx in itertools.combinations_with_replacement(range(nt), 4):
        a, c, d, e = idx
        D4.set(set(itertools.permutations(idx)), MP.mpc(ip(P[(a, c)], P[(d, e)])))
    _J_UPTO.clear()
    tables = {"gram": gram, "Ka": Ka, "Kt": Kt, "Pd": Pd, "psid1": psid1, "C3": C3, "D4": D4}
    return InnerProducts.from_tables(na, nt, tables)


def piecewise_curvature_products(axial: Sequence[Any], transverse: Sequence[Any]) -> CurvatureProducts:
    """:class:`symgen.model.shapes.CurvatureProducts` of bases that may include piecewise (static
    correction) functions: :func:`symgen.model.shapes.curvature_tables` on each piece."""
    phi = [Piecewise.of(f) for f in axial]
    psi = [Piecewise.of(f) for f in transverse]
    cuts = sorted(set().union({Fraction(0), Fraction(1)}, *(f.breaks for f in phi + psi)))
    ivals = [(lo, hi, (lo + hi) / 2) for lo, hi in zip(cuts[:-1], cuts[1:])]
    lims = [(_mpq(lo), _mpq(hi)) for lo, hi, _ in ivals]

    def at(fs: list[Piecewise], d: int) -> list[list[Terms]]:  # [function][interval]
        return [[f.piece_at(mid).as_mp().deriv(d) for _, _, mid in ivals] for f in fs]

    def ip(u: list[Terms], v: list[Terms]) -> Any:
        return MP.mpc(sum((_integrate_product_on(x, y, lo, hi) for x, y, (lo, hi) in zip(u, v, lims)), MP.mpf(0)))

    tables = curvature_tables(
        at(phi, 1),
        at(phi, 2),
        at(psi, 1),
        at(psi, 2),
        lambda u, v: [multiply(x, y) for x, y in zip(u, v)],
        lambda u: [x.deriv(1) for x in u],
        ip,
    )
    _J_UPTO.clear()
    return CurvatureProducts.from_tables(len(phi), len(psi), tables)


# --------------------------------------------------------------------------------------
# Bases that end with correction functions, their cached inner products
# --------------------------------------------------------------------------------------
def _poly_expr(coeffs: Sequence[Fraction]) -> Any:
    return sympy.Add(*[sympy.Rational(c.numerator, c.denominator) * XI**p for p, c in enumerate(coeffs) if c])


def _correction_expr(sc: StaticCorrection, others: Sequence[Any]) -> Any:
    """``(w_K - sum_k c_k f_k) / t`` as a sympy expression in XI (w_K a sympy Piecewise)."""
    a = sympy.Rational(sc.a.numerator, sc.a.denominator)
    w = sympy.Piecewise((_poly_expr(sc.left), XI <= a), (_poly_expr(sc.right), True))
    rest = sympy.Add(*[sympy.Float(c, 17) * f.expr for c, f in zip(sc.coeffs, others)])
    return (w - rest) / sympy.Float(sc.scale, 17)


def corrected_basis(basis: Basis, points: Sequence[float], moments: Sequence[float] = ()) -> Basis:
    """``basis`` followed by one static correction function per interior point (in order; each
    mass-orthogonal to every function before it), then one moment correction function per point
    of ``moments`` (transverse bases only). ``basis`` must be a standard basis of
    :func:`symgen.model.shapes.axial_basis` / :func:`symgen.model.shapes.transverse_basis`; no points: itself."""
    pts = tuple(float(x) for x in points)
    mpts = tuple(float(x) for x in moments)
    if not pts and not mpts:
        return basis
    if mpts and basis.direction != "transverse":
        raise ValueError("moment correction functions are transverse: an axial basis has none")
    return _corrected_basis(basis.key, pts, mpts)


@functools.lru_cache(maxsize=256)
def _corrected_basis(key: tuple, pts: tuple[float, ...], mpts: tuple[float, ...] = ()) -> Basis:
    base = basis_of_key(key)
    kind = "axial" if base.direction == "axial" else base.frame
    funcs: list[Any] = list(base.functions)
    for x, load in [(x, "force") for x in pts] + [(x, "moment") for x in mpts]:
        sc = static_correction(kind, x, funcs, load)
        funcs.append(replace(sc, expr=_correction_expr(sc, funcs)))
    return Basis(base.direction, base.family, base.frame, tuple(funcs), base.tip_joint, pts, mpts)


def bar_bases(body: BodySpec | dict) -> tuple[Basis, Basis]:
    """(axial, transverse) bases of a bar from its :class:`symgen.ir.spec.BodySpec` (or that
    record's JSON, as a cached model's ``structure["bodies"]`` holds it): ``na``/``nt`` count the
    standard functions, the static correction points add the corrections (the moment points
    their moment corrections, after the force ones)."""
    if isinstance(body, dict):
        body = BodySpec.from_json(body)
    ba = axial_basis(body.axial_shapes or "complete", body.na)
    bt = transverse_basis(
        body.frame or "pinned-pinned", body.transverse_shapes or "modes", body.nt, tip_joint=body.tip_joint
    )
    return corrected_basis(ba, body.static_axial), corrected_basis(bt, body.static_transverse, body.static_moment)


# --------------------------------------------------------------------------------------
# The exact bar's sixth-order tables (effects.strain = "exact", docs/exact-bars.md)
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SixthOrderProducts:
    """The inner products of the exact bar's sixth-order bending term, over **sorted** index
    tuples (the others follow by symmetry; ``bars._multiplicity`` counts them).

    E6 : ``{(a, b, c, d, e, f): the fully symmetric part of int psi'_a psi'_b psi'_c psi'_d psi''_e psi''_f}``,
        so that ``int eta'^4 eta''^2 = sum_sorted mult E6 g^6``
    C5 : ``{(k, a, b, c, d): int phi'_k psi'_a psi'_b psi'_c psi'_d}`` over sorted (a, b, c, d), so
        that ``(phi'_k, eta'^4) = sum_sorted mult C5 g^4``: the exact strain's eta'^4 / 8 in the
        axial strain (DERIVE_VERSION 8)
    H4 : ``{(a, b, c, d): F_ab|cd + (F_ac|bd + F_ad|bc + F_bc|ad + F_bd|ac) / 2}`` over a <= b, c <= d,
        F_ab|cd = int psi''_a psi''_b psi'_c psi'_d: the Kelvin-Voigt damping of the exact curvature's
        rate, D = (c mu / 2) int kappa_dot^2 = (c mu / 2) g_dot^T (Kt + sum H4 g_c g_d) g_dot to fourth
        order (kappa = eta'' (1 + eta'^2 / 2) on a nearly inextensible bar)
    Q4 : ``{(k, l, a, b): int phi'_k phi'_l psi'_a psi'_b}`` over k <= l, a <= b: the exact strain's
        next term, |r'| - 1 = eps (1 - eta'^2 / 2) + ..., in the strain energy
        -(lambda / 2) int (P eps)^2 eta'^2 (DERIVE_VERSION 9)

    By Gauss-Legendre quadrature on each smooth piece (:func:`sixth_order_nodes` nodes per piece:
    the integrands are products of six sines, exponentials and polynomials, integrated to
    round-off; ``tests/test_exact_bars.py`` checks against adaptive quadrature and doubled
    nodes), not in closed form: the closed form of a six-fold product of clamped-free
    eigenfunctions has 4^6 exponential terms per entry (E4's closed form, 4^4, already takes
    about a minute at 8 + 10 functions).
    """

    na: int
    nt: int
    E6: dict[tuple[int, ...], float]
    C5: dict[tuple[int, ...], float] = field(default_factory=dict)
    H4: dict[tuple[int, ...], float] = field(default_factory=dict)
    Q4: dict[tuple[int, ...], float] = field(default_factory=dict)


def sixth_order_nodes(nt: int) -> int:
    """Gauss-Legendre nodes per piece for :func:`sixth_order_products`: the highest frequency of
    a six-fold product of the first ``nt`` functions' derivatives is ~6 nt pi."""
    return 48 + 16 * nt


def node_form_nodes(n: int) -> int:
    """Gauss-Legendre nodes per piece of the exact bar's node form (:func:`quadrature_nodes`,
    ``bars._NodeForm``): the six-fold products of the first ``n`` functions' derivatives (highest
    frequency ~6 n pi) integrate to round-off with about 8 n + 16 (``tests/test_exact_bars.py``
    checks the node form against the tables, which :func:`sixth_order_nodes` computes with
    twice as many)."""
    return 24 + 8 * n


def quadrature_nodes(axial: Sequence[Any], transverse: Sequence[Any], n: int) -> tuple:
    """(W, A, B, F): the Gauss-Legendre weights of ``n`` nodes on each smooth piece of the bases
    (split at the static corrections' points) and, at those nodes, the transverse functions'
    first (A, nodes x nt) and second (B) derivatives and the axial functions' first (F, nodes x na)."""
    psi = [Piecewise.of(f) for f in transverse]
    phi = [Piecewise.of(f) for f in axial]
    nt, na = len(psi), len(phi)
    cuts = sorted(set().union({Fraction(0), Fraction(1)}, *(f.breaks for f in psi + phi)))
    z, w = np.polynomial.legendre.leggauss(n)
    ws, A, B, F = [], [], [], []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        mid = (lo + hi) / 2
        a, b = float(lo), float(hi)
        ws.append(w * (b - a) / 2)
        for xi in a + (b - a) * (z + 1) / 2:
            A.append([f.piece_at(mid).evaluate(xi, 1) for f in psi])
            B.append([f.piece_at(mid).evaluate(xi, 2) for f in psi])
            F.append([f.piece_at(mid).evaluate(xi, 1) for f in phi])
    W = np.concatenate(ws)
    Aq = np.array(A, dtype=float).reshape(len(W), nt)
    Bq = np.array(B, dtype=float).reshape(len(W), nt)
    Fq = np.array(F, dtype=float).reshape(len(W), na)  # no axial functions: (nodes, 0)
    return W, Aq, Bq, Fq


def sixth_order_products(
    axial: Sequence[Any], transverse: Sequence[Any], nodes: int | None = None
) -> SixthOrderProducts:
    """:class:`SixthOrderProducts` of (possibly piecewise) bases (``axial`` counts only)."""
    nt, na = len(transverse), len(axial)
    W, Aq, Bq, Fq = quadrature_nodes(axial, transverse, nodes or sixth_order_nodes(max(nt, na)))
    pairs = list(itertools.combinations(range(6), 2))  # which two factors are psi''
    E6: dict[tuple[int, ...], float] = {}
    for idx in itertools.combinations_with_replacement(range(nt), 6):
        total = np.zeros_like(W)
        for i, j in pairs:
            term = Bq[:, idx[i]] * Bq[:, idx[j]]
            for m in range(6):
                if m != i and m != j:
                    term = term * Aq[:, idx[m]]
            total += term
        E6[idx] = float(W @ total) / len(pairs)
    # (phi'_k, psi'_a psi'_b psi'_c psi'_d): the weights times each sorted four-fold product, once
    C5: dict[tuple[int, ...], float] = {}
    if na:
        quads = list(itertools.combinations_with_replacement(range(nt), 4))
        P4 = np.stack([Aq[:, a] * Aq[:, b] * Aq[:, c] * Aq[:, d] for a, b, c, d in quads], axis=1) if quads else None
        if P4 is not None:
            table = Fq.T @ (W[:, None] * P4)
            for k in range(na):
                for j, idx in enumerate(quads):
                    C5[(k, *idx)] = float(table[k, j])
    F = np.einsum("q,qa,qb,qc,qd->abcd", W, Bq, Bq, Aq, Aq)  # int psi''_a psi''_b psi'_c psi'_d
    H4: dict[tuple[int, ...], float] = {}
    for a, b in itertools.combinations_with_replacement(range(nt), 2):
        for c, d in itertools.combinations_with_replacement(range(nt), 2):
            H4[(a, b, c, d)] = float(
                F[a, b, c, d] + (F[a, c, b, d] + F[a, d, b, c] + F[b, c, a, d] + F[b, d, a, c]) / 2
            )
    Q = np.einsum("q,qk,ql,qa,qb->klab", W, Fq, Fq, Aq, Aq)  # int phi'_k phi'_l psi'_a psi'_b
    Q4: dict[tuple[int, ...], float] = {
        (k, m, a, b): float(Q[k, m, a, b])
        for k, m in itertools.combinations_with_replacement(range(na), 2)
        for a, b in itertools.combinations_with_replacement(range(nt), 2)
    }
    return SixthOrderProducts(na=na, nt=nt, E6=E6, C5=C5, H4=H4, Q4=Q4)
