"""Bars carrying a slot: variable span psi(xi, beta) (seed 6.3).

A slot joint lets a point of one bar slide along a second bar, the *guide*. The guide is
pinned at xi = 0 and supported at the moving contact xi = beta(tau): its deformation frame
is the chord from the pin to the contact (eta(0) = eta(beta) = 0), so

    eta = g^T psi(xi, beta),   psi_k = sin(k pi xi / beta)                  on [0, beta]
                               psi_k = psi_k'(beta) (xi - beta)              on [beta, 1]

on the span a simply supported beam's modes, on the overhang beyond the contact the tangent
continuation (value and slope continuous, so the functions are admissible for bending: the
overhang's mass moves with the span's end slope; it carries no bending of its own). The time
derivatives of eta carry the extra terms of the formulation,

    eta'  = g'^T psi + beta' g^T psi_beta
    eta'' = g''^T psi + 2 beta' g'^T psi_beta + g^T (psi_betabeta beta'^2 + psi_beta beta''),

so the Galerkin basis of the guide is b = [1, xi, psi, psi_beta, psi_betabeta] and every inner
product is a closed-form function of beta (the span integrals scale as beta times a pure number,
the overhang integrals are polynomials). The guide is axially rigid (a frictionless slot
transmits no axial force to it).

Bending overhang (the default when the guide overhangs): the tangent continuation carries no
bending of its own, and it ties the overhang's rotation to every span function. The basis is
therefore split at the contact, whose slope is the interface of the span and the overhang (the
Craig-Bampton form of a beam with an interior support; ``nover`` = 1 + ``overhang_modes``):

    s_k   = sin(k pi xi / beta) - psi_k'(beta) C  on [0, beta],  0 on [beta, 1]   (k = 1..nspan)
    chi_0 = C                                      on [0, beta],  xi - beta on [beta, 1]
    chi_m = 0                                      on [0, beta],  4 (1 - beta)^2 P_m(v) on [beta, 1]  (m = 1..no)

with v = (xi - beta) / (1 - beta), P_m the polynomials of v^2 .. v^(m+1) orthogonal on [0, 1] with
P_m(1) = 1 (``_overhang_polynomial``: the powers themselves are nearly dependent), and
C = xi (xi^2 - beta^2) / (2 beta^2), the span's static shape under a moment at the contact
(zero moment at the pin, unit slope at the contact). The span functions have zero value and slope
at the contact and vanish on the overhang; the overhang's own functions vanish on the span; chi_0
(the contact-slope function) carries the overhang's rotation. The seed's functions are
psi_k = s_k + psi_k'(beta) chi_0 and the former static tip-load function is 2 beta chi_0 + 3/4 chi_1,
so the basis spans the former one and more (one function more). The bending stiffness is block
diagonal: chi_0 is K-orthogonal to the span functions (C is the static solution: by parts, the
boundary terms vanish) and to the overhang's (straight there); the blocks couple through the mass
only. A span function is then the span's own shape: its frequencies go as 1/beta^2 and it may
be quasi-static (``quasi_static_transverse``) without dropping the overhang's inertia.
Every function is C1 at the contact (chi_0 and the s_k have a curvature jump there: the support
takes the moment's change as a kink of the shear), so psi_beta is continuous and eta' has no jump
in time where the contact passes a point (no impulse in eta''). They are appended to the span's
(psi_{nspan+1+m} = chi_m), so their beta derivatives enter eta' and eta'' exactly as above, and
every inner product stays a closed form in beta (polynomial on the overhang; beta < 1: with no
overhang left its functions vanish). The bending stiffness (psi'', psi'') covers the span and the
overhang (the tangent continuation contributes nothing there, so the seed's rigid-overhang form,
``no = 0``, is unchanged).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import numpy as np
import sympy as sp
from sympy.polys.domains import QQ
from sympy.polys.rings import PolyElement, ring

from symgen.ir.shape_samples import GuideSamples
from symgen.model.bars import CURVATURE, SHORTENING, ZERO_TOL, curvature_pairs, point_tension_name, rot

XI = sp.Symbol("xi", real=True)
_U = sp.Symbol("u", real=True)
_V = sp.Symbol("v", real=True)


@cache
def _pieces(k: int, beta: sp.Symbol, nspan: int | None = None, nover: int = 0) -> tuple:
    """(span, overhang) expressions of psi_k, psi_k,beta, psi_k,betabeta in xi.

    ``nover = 0`` (the seed's rigid overhang): psi_k = sin(k pi xi / beta) with its tangent
    continuation. ``nover > 0`` (elastic overhang, the contact's slope as the interface of the
    span and the overhang): k <= nspan: the span function s_k = sin(k pi xi / beta) - psi_k'(beta) C
    (zero value and slope at the contact, zero on the overhang); k = nspan + 1: the contact-slope
    function S = C on the span, xi - beta on the overhang (C = xi (xi^2 - beta^2) / (2 beta^2), the
    span's static shape under a moment at the contact, unit slope there); k > nspan + 1: the
    overhang's own function chi_m = 4 (1 - beta)^2 P_m((xi - beta) / (1 - beta)), m = k - nspan - 1 (zero value and slope
    at the contact, zero on the span)."""
    if nover and nspan is not None and k > nspan:
        m = k - nspan - 1
        if m == 0:
            span = XI * (XI**2 - beta**2) / (2 * beta**2)
            over = XI - beta
        else:
            span, over = (
                sp.Integer(0),
                4 * (1 - beta) ** 2 * _overhang_polynomial(m).xreplace({_V: (XI - beta) / (1 - beta)}),
            )
        return (
            (span, sp.diff(span, beta), sp.diff(span, beta, 2)),
            (over, sp.diff(over, beta), sp.diff(over, beta, 2)),
        )
    span = sp.sin(k * sp.pi * XI / beta)
    slope = (-1) ** k * k * sp.pi / beta  # d psi_k / d xi at xi = beta
    if nover:
        span = span - slope * XI * (XI**2 - beta**2) / (2 * beta**2)
        over = sp.Integer(0)
    else:
        over = slope * (XI - beta)
    return ((span, sp.diff(span, beta), sp.diff(span, beta, 2)), (over, sp.diff(over, beta), sp.diff(over, beta, 2)))


@cache
def _derivative(k: int, beta: sp.Symbol, nspan: int, nover: int, deriv: int, dbeta: int) -> tuple[sp.Expr, sp.Expr]:
    """(span, overhang) of d^deriv/dxi^deriv d^dbeta/dbeta^dbeta psi_k (``_pieces``), made once."""
    (s, _, _), (o, _, _) = _pieces(k, beta, nspan, nover)
    s = sp.diff(s, XI, deriv) if deriv else s
    o = sp.diff(o, XI, deriv) if deriv else o
    if dbeta:
        s, o = sp.diff(s, beta, dbeta), sp.diff(o, beta, dbeta)
    return s, o


@cache
def _overhang_polynomial(m: int) -> sp.Expr:
    """P_m(v), m >= 1: v^(m+1) less its projections on P_1, ..., P_(m-1) in the mass inner
    product int_0^1 f g dv (exact rationals), scaled to P_m(1) = 1: zero value and slope at
    v = 0. The overhang's own functions 4 (1 - beta)^2 P_m((xi - beta) / (1 - beta)) span the same
    functions as the powers (xi - beta)^2 .. (xi - beta)^(m+1) at each beta, mass-orthogonal to
    each other: the powers themselves grow nearly dependent (the mass matrix's condition ~40x
    per function)."""
    basis = [_overhang_polynomial(j) for j in range(1, m)]
    p = _V ** (m + 1)
    for q in basis:
        p -= sp.integrate(p * q, (_V, 0, 1)) / sp.integrate(q * q, (_V, 0, 1)) * q
    p = sp.expand(p)
    return sp.expand(p / p.xreplace({_V: 1}))


class _Span:
    """The span's integrals int_0^beta f g d xi in closed form: by xi = beta u each piece is a sum
    of terms c u^m exp(r u) (its trig arguments k pi u rewritten as exponentials), split once per
    piece; a product's terms pair those of its factors, and each integrates exactly over [0, 1]
    (``_int_pow_exp``). The same numbers, in the same form, as expanding every product anew."""

    def __init__(self, beta: sp.Symbol) -> None:
        self.beta = beta

    def piece(self, expr: sp.Expr) -> dict[tuple[int, sp.Expr], list[sp.Expr]]:
        """``expr`` (in xi and beta) as {(m, r): coefficients} of c u^m exp(r u)."""
        terms: dict[tuple[int, sp.Expr], list[sp.Expr]] = {}
        integrand = sp.expand(expr.xreplace({XI: self.beta * _U}).rewrite(sp.exp))
        for term in sp.Add.make_args(integrand):
            if term == 0:
                continue
            coeff, m, rate = sp.Integer(1), 0, sp.Integer(0)
            for f in sp.Mul.make_args(term):
                if f == _U:
                    m += 1
                elif f.is_Pow and f.base == _U:
                    m += int(f.exp)
                elif isinstance(f, sp.exp) or (f.is_Pow and isinstance(f.base, sp.exp)):
                    arg = f.args[0] if isinstance(f, sp.exp) else f.base.args[0] * f.exp
                    rate += sp.expand(arg / _U)
                else:
                    coeff *= f
            if coeff.has(_U):
                raise ValueError(f"the span's integrand is not of the form c u^m exp(r u): {term}")
            terms.setdefault((m, sp.expand(rate)), []).append(coeff)
        return terms

    def integral(
        self,
        f: dict[tuple[int, sp.Expr], list[sp.Expr]],
        g: dict[tuple[int, sp.Expr], list[sp.Expr]],
        upper: sp.Expr | None = None,
    ) -> sp.Expr:
        """int_0^beta f g d xi (or int_0^(beta upper), ``upper`` a fraction of the span), expanded."""
        paired: dict[tuple[int, sp.Expr], list[sp.Expr]] = {}
        for (m1, r1), c1 in f.items():
            for (m2, r2), c2 in g.items():
                paired.setdefault((m1 + m2, sp.expand(r1 + r2)), []).append(sp.Add(*c1) * sp.Add(*c2))
        if not paired:
            return sp.Integer(0)
        total = sp.Add(
            *[
                self.beta * sp.Add(*cs) * (_int_pow_exp(m, r) if upper is None else _int_pow_exp_to(m, r, upper))
                for (m, r), cs in paired.items()
            ]
        )
        expanded = sp.expand(total)
        # the imaginary parts cancel in the expansion; where one is left, the complex expansion
        return expanded if not expanded.has(sp.I) else sp.expand(sp.expand_complex(total))


@cache
def _int_pow_exp(m: int, a: sp.Expr) -> sp.Expr:
    """int_0^1 u^m exp(a u) du, exact (a = i k pi here)."""
    if a == 0:
        return sp.Rational(1, m + 1)
    ea = sp.exp(a)
    val = (ea - 1) / a
    for j in range(1, m + 1):
        val = ea / a - j * val / a
    return sp.expand(val)


class _Overhang:
    """The overhang's integrals int_beta^1 f g d xi in closed form: by xi = beta + (1 - beta) v each
    piece is a polynomial in v whose coefficients are rational in beta (and pi), kept as an element
    of that ring once per piece; a product's integral is then the sum of its coefficients over
    m + 1, times 1 - beta. The same numbers as a SymPy ``Poly`` of each expanded product, which
    cost 3 of the 4 minutes of a slot scene's first run (the product's expansion and the
    coefficients' domain, built again for every pair)."""

    def __init__(self, beta: sp.Symbol) -> None:
        self.field = QQ.frac_field(beta, sp.pi)
        self.ring, _ = ring([_V], self.field)
        self.beta = beta
        self.length = self.field.from_sympy(1 - beta)

    def piece(self, expr: sp.Expr) -> PolyElement:
        """``expr`` (in xi and beta) as a polynomial in v."""
        if expr == 0:
            return self.ring.zero
        return self.ring.from_expr(sp.expand(expr.xreplace({XI: self.beta + (1 - self.beta) * _V})))

    def integral(self, f: PolyElement, g: PolyElement, upper: sp.Expr | None = None) -> sp.Expr:
        """int_beta^1 f g d xi (or up to v = ``upper``), in the form of ``factor(cancel(.))``."""
        product = f * g
        if not product:
            return sp.Integer(0)
        if upper is not None:
            terms = [self.field.to_sympy(c) * upper ** (m + 1) / (m + 1) for (m,), c in product.terms()]
            return sp.factor(sp.cancel(sp.Add(*terms) * (1 - self.beta)))
        total = self.field.zero
        for (m,), c in product.terms():
            total += c / (m + 1)
        return sp.factor(sp.cancel(self.field.to_sympy(total * self.length)))


@cache
def _gram(nt: int, beta_name: str, nover: int = 0) -> tuple:
    """Closed-form Gram matrix of [1, xi, psi, psi_b, psi_bb] and (psi'', psi'') (span and
    overhang) as functions of beta; the last ``nover`` of the nt functions are overhang functions."""
    beta = sp.Symbol(beta_name, positive=True)
    span, over = [sp.Integer(1), XI], [sp.Integer(1), XI]
    blocks_s: list = [[], [], []]
    blocks_o: list = [[], [], []]
    for k in range(1, nt + 1):
        s, o = _pieces(k, beta, nt - nover, nover)
        for b in range(3):
            blocks_s[b].append(s[b])
            blocks_o[b].append(o[b])
    span += blocks_s[0] + blocks_s[1] + blocks_s[2]
    over += blocks_o[0] + blocks_o[1] + blocks_o[2]
    n = len(span)
    sh, oh = _Span(beta), _Overhang(beta)
    span_u, over_v = [sh.piece(e) for e in span], [oh.piece(e) for e in over]
    G = sp.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            G[i, j] = G[j, i] = sh.integral(span_u[i], span_u[j]) + oh.integral(over_v[i], over_v[j])
    curv_u = [sh.piece(sp.diff(e, XI, 2)) for e in blocks_s[0]]
    curv_v = [oh.piece(sp.diff(e, XI, 2)) for e in blocks_o[0]]
    Kt = sp.zeros(nt, nt)
    for i in range(nt):
        for j in range(nt):
            Kt[i, j] = sh.integral(curv_u[i], curv_u[j]) + oh.integral(curv_v[i], curv_v[j])
    return beta, G, Kt


#: the guide's tension weights (``_tension_gram``): N = (beta_bar - x_A'') (1 - xi) + theta'^2 (1 - xi^2) / 2
TENSION_WEIGHTS = {"T1": 1 - XI, "T2": (1 - XI**2) / 2}
#: the guide's curvature-rate matrices (``_rate_gram``); "Kb" is not symmetric
RATE_MATRICES = ("Kb", "Kbb")


@cache
def _tension_gram(nt: int, beta_name: str, nover: int = 0) -> tuple:
    """(beta, {name: (w psi'_a, psi'_b) over [0, 1]}) for the weights of ``TENSION_WEIGHTS``, in
    closed form (span and overhang): the geometric stiffness of an axially rigid guide's tension."""
    beta = sp.Symbol(beta_name, positive=True)
    sh, oh = _Span(beta), _Overhang(beta)
    slopes = [_derivative(k, beta, nt - nover, nover, 1, 0) for k in range(1, nt + 1)]
    plain = [(sh.piece(s), oh.piece(o)) for s, o in slopes]
    out = {}
    for name, w in TENSION_WEIGHTS.items():
        weighted = [(sh.piece(sp.expand(w * s)), oh.piece(sp.expand(w * o))) for s, o in slopes]
        W = sp.zeros(nt, nt)
        for i in range(nt):
            for j in range(i, nt):
                W[i, j] = W[j, i] = sh.integral(weighted[i][0], plain[j][0]) + oh.integral(weighted[i][1], plain[j][1])
        out[name] = W
    return beta, out


def _int_pow_exp_to(m: int, a: sp.Expr, upper: sp.Expr) -> sp.Expr:
    """int_0^upper u^m exp(a u) du, exact."""
    if a == 0:
        return upper ** (m + 1) / (m + 1)
    eau = sp.exp(a * upper)
    val = (eau - 1) / a
    for j in range(1, m + 1):
        val = upper**j * eau / a - j * val / a
    return val


@cache
def _point_tension_gram(nt: int, beta_name: str, nover: int, xi_p: float) -> tuple:
    """(beta, {point_tension_name(xi_p): int_0^xi_p psi'_a psi'_b}) in closed form: the weight of
    an axial point force at xi_p in the guide's tension (it pulls on [0, xi_p]). Piecewise in beta
    for an interior xi_p (the span alone while the contact is beyond it); the whole guide at
    xi_p = 1."""
    beta = sp.Symbol(beta_name, positive=True)
    sh, oh = _Span(beta), _Overhang(beta)
    x = sp.nsimplify(xi_p, rational=True)
    slopes = [_derivative(k, beta, nt - nover, nover, 1, 0) for k in range(1, nt + 1)]
    span = [sh.piece(a) for a, _ in slopes]
    over = [oh.piece(b) for _, b in slopes]
    W = sp.zeros(nt, nt)
    for i in range(nt):
        for j in range(i, nt):
            whole_span = sh.integral(span[i], span[j])
            if x >= 1:
                value = whole_span + oh.integral(over[i], over[j])
            else:
                value = sp.Piecewise(
                    (sh.integral(span[i], span[j], upper=x / beta), beta >= x),
                    (whole_span + oh.integral(over[i], over[j], upper=(x - beta) / (1 - beta)), True),
                )
            W[i, j] = W[j, i] = value
    return beta, {point_tension_name(xi_p): W}


#: the name of (psi'_a, psi'_b) over the span [0, beta] (``_span_slope_gram``): the contact's
#: shortening u(beta) = -1/2 g^T H g (``SlotBarKinematics``)
SPAN_TENSION = "Hspan"


@cache
def _span_slope_gram(nt: int, beta_name: str, nover: int = 0) -> tuple:
    """(beta, {SPAN_TENSION: int_0^beta psi'_a psi'_b}) in closed form."""
    beta = sp.Symbol(beta_name, positive=True)
    sh = _Span(beta)
    span = [sh.piece(_derivative(k, beta, nt - nover, nover, 1, 0)[0]) for k in range(1, nt + 1)]
    W = sp.zeros(nt, nt)
    for i in range(nt):
        for j in range(i, nt):
            W[i, j] = W[j, i] = sh.integral(span[i], span[j])
    return beta, {SPAN_TENSION: W}


@cache
def _rate_gram(nt: int, beta_name: str, nover: int = 0) -> tuple:
    """(beta, {"Kb": (psi''_a, psi''_b,beta), "Kbb": (psi''_a,beta, psi''_b,beta)}) over [0, 1] in
    closed form: the beta_dot part of the guide's curvature rate (its Kelvin-Voigt damping).
    "Kb" is not symmetric; d/dbeta of (psi''_a, psi''_b) is not its symmetric part (the span
    functions' curvature jumps at the contact)."""
    beta = sp.Symbol(beta_name, positive=True)
    sh, oh = _Span(beta), _Overhang(beta)
    curv, curv_b = [], []
    for k in range(1, nt + 1):
        s, o = _derivative(k, beta, nt - nover, nover, 2, 0)
        curv.append((sh.piece(s), oh.piece(o)))
        s, o = _derivative(k, beta, nt - nover, nover, 2, 1)
        curv_b.append((sh.piece(s), oh.piece(o)))
    Kb, Kbb = sp.zeros(nt, nt), sp.zeros(nt, nt)
    for i in range(nt):
        for j in range(nt):
            Kb[i, j] = sh.integral(curv[i][0], curv_b[j][0]) + oh.integral(curv[i][1], curv_b[j][1])
            if j >= i:
                Kbb[i, j] = Kbb[j, i] = sh.integral(curv_b[i][0], curv_b[j][0]) + oh.integral(
                    curv_b[i][1], curv_b[j][1]
                )
    return beta, {"Kb": Kb, "Kbb": Kbb}


def _scalings(k: int, nspan: int, nover: int) -> tuple[tuple[int, int] | None, tuple[int, int] | None]:
    """((p, 0), (p', o)) of psi_k (1-based): psi_k = beta^p f_k(xi / beta) on the span and
    beta^p' (1 - beta)^o h_k((xi - beta) / (1 - beta)) on the overhang, None where it vanishes: the
    span functions p = 0; chi_0 p = 1, o = 1; chi_m o = 2; the seed's rigid overhang, straight and
    sloped, psi'_k(beta) (xi - beta) = (-1)^k k pi (1 - beta) / beta v (p' = -1, o = 1)."""
    if not nover:
        return (0, 0), (-1, 1)
    if k <= nspan:
        return (0, 0), None
    return ((1, 0), (0, 1)) if k == nspan + 1 else (None, (0, 2))


#: the contact position at which the fixed functions of ``_fixed_derivative`` are read (any: they
#: do not depend on it)
_B0 = 0.5


def _fixed_derivative(k: int, nspan: int, nover: int, piece: int, n: int, scale: tuple[int, int]):
    """d^n/ds^n of psi_k's fixed function of its piece's local coordinate s (u = xi / beta on the
    span, v = (xi - beta) / (1 - beta) beyond; ``scale`` its powers (p, o) of beta and 1 - beta,
    ``_scalings``), as a numpy function of s: f^(n)(u) = beta^(n - p) psi^(n)(beta u),
    h^(n)(v) = (1 - beta)^(n - o) beta^(-p) psi^(n)(beta + (1 - beta) v), read at beta = _B0."""
    beta = sp.Symbol("beta_fixed", positive=True)
    expr = sp.diff(_pieces(k, beta, nspan, nover)[piece][0], XI, n).xreplace({beta: sp.Float(_B0)})
    f = sp.lambdify(XI, expr, "numpy")
    p, o = scale
    if piece == 0:
        return lambda s: np.broadcast_to(f(_B0 * s), np.shape(s)) * _B0 ** (n - p)
    return lambda s: np.broadcast_to(f(_B0 + (1 - _B0) * s), np.shape(s)) * (1 - _B0) ** (n - o) / _B0**p


def overhang_count(joint: dict) -> int:
    """``nover`` of a slot joint's structure record (``ModelInfo.structure``'s ``joints`` entry, its
    ``overhang`` = [kind, overhang_modes]): the contact-slope function and the overhang's own
    functions (``symgen.model.structure.overhang_modes``), 0 for the seed's rigid overhang."""
    modes = int(joint["overhang"][1]) if joint.get("overhang") else 0
    return modes + 1 if modes else 0


def guide_samples(guide: str, nt: int, nover: int, x: np.ndarray, w: np.ndarray) -> GuideSamples:
    """A guide's functions and their first two derivatives at the quadrature nodes ``x`` (weights
    ``w``) of its span (u = xi / beta) and its overhang (v = (xi - beta) / (1 - beta)), as fixed
    numbers and powers of beta and 1 - beta (:class:`symgen.ir.shape_samples.GuideSamples`):
    d^n psi_k = beta^(p - n) f_k^(n)(u) on the span and beta^p (1 - beta)^(o - n) h_k^(n)(v) beyond
    (``_scalings``, ``_fixed_derivative``); a function that vanishes on a piece is zero there."""
    nspan = nt - nover
    tables, powers = [], []
    for piece in (0, 1):
        derivs = []
        for n in (0, 1, 2):
            columns = []
            for k in range(1, nt + 1):
                sc = _scalings(k, nspan, nover)[piece]
                f = None if sc is None else _fixed_derivative(k, nspan, nover, piece, n, sc)
                columns.append(np.zeros(len(x)) if f is None else np.asarray(f(x), dtype=float))
            derivs.append(tuple(tuple(float(v) for v in row) for row in np.array(columns).T))
        tables.append(tuple(derivs))
        powers.append([_scalings(k, nspan, nover)[piece] for k in range(1, nt + 1)])
    return GuideSamples(
        guide,
        nover,
        tuple(float(v) for v in x),
        tuple(float(v) for v in w),
        tables[0],
        tables[1],
        tuple(None if sc is None else sc[0] for sc in powers[0]),
        tuple(powers[1]),
    )


@cache
def _curvature_gram(nt: int, beta_name: str, nover: int = 0) -> tuple:
    """(beta, {CURVATURE: E4}) with E4[(a, b), (c, d)] = int_0^1 psi'_a psi'_b psi''_c psi''_d d xi
    (pairs of ``curvature_pairs``): the inextensible guide's bending energy beyond mu eta''^2 / 2,
    (mu / 2) int eta'^2 eta''^2 (its curvature kappa = eta'' / sqrt(1 - eta'^2) to fourth order in
    the amplitudes).

    Each function is a power of beta times a fixed function of u = xi / beta on the span, and a
    power of 1 - beta times one of v = (xi - beta) / (1 - beta) on the overhang (``_scalings``), so
    each entry is c_s beta^(sum p - 5) + c_o (1 - beta)^(sum o - 5) (the rigid overhang is straight:
    no c_o): the constants are integrals over [0, 1] of the fixed functions (``_fixed_derivative``),
    by Gauss-Legendre quadrature exact to round-off (polynomials on the overhang; on the span
    sines of frequency up to 4 nspan pi, resolved by the nodes' count), as the exact bar's E6."""
    beta = sp.Symbol(beta_name, positive=True)
    nspan = nt - nover
    nodes, weights = np.polynomial.legendre.leggauss(max(64, 12 * nspan + 24))
    x, w = (nodes + 1) / 2, weights / 2

    pairs = curvature_pairs(nt)
    E4 = sp.zeros(len(pairs), len(pairs))
    for piece in (0, 1):
        # the functions living on this piece: k -> ((p, o), slopes, curvatures at the nodes)
        on = {}
        for k in range(nt):
            sc = _scalings(k + 1, nspan, nover)[piece]
            if sc is not None:
                on[k] = (sc, *(_fixed_derivative(k + 1, nspan, nover, piece, n, sc)(x) for n in (1, 2)))
        for i, (a, b) in enumerate(pairs):
            if a not in on or b not in on:
                continue
            slopes = w * on[a][1] * on[b][1]
            for j, (c, d) in enumerate(pairs):
                if c not in on or d not in on:
                    continue
                const = float(slopes @ (on[c][2] * on[d][2]))
                if abs(const) > 1e-14:
                    p = sum(on[m][0][0] for m in (a, b, c, d))
                    o = sum(on[m][0][1] for m in (a, b, c, d))
                    # span: beta^(p - 5); overhang: beta^p (1 - beta)^(o - 5)
                    E4[i, j] += sp.Float(const) * (beta ** (p - 5) if piece == 0 else beta**p * (1 - beta) ** (o - 5))
    return beta, {CURVATURE: E4}


def _cumulative(f, x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """int_0^s f at each node s of ``x`` (Gauss-Legendre on [0, s], the same nodes scaled)."""
    return np.array([s * np.sum(w * f(s * x)) for s in x])


@cache
def _shortening_gram(nt: int, beta_name: str, nover: int = 0) -> tuple:
    """(beta, {SHORTENING: Z}) with Z[(a, b), (c, d)] = int_0^1 H_ab H_cd d xi: the kinetic energy
    of the guide's shortening u = -1/2 g^T H(xi) g at the rate of its amplitudes,
    (1/2) int (sum_ab g_a g_b' H_ab)^2 (``bars._guide_shortening``).

    On the span H_ab = beta^(e_a + e_b - 1) h_ab(xi / beta), h_ab(s) = int_0^s f'_a f'_b (the fixed
    functions of ``_scalings``); on the overhang H_ab = H_ab(beta) + B_ab k_ab(v), B_ab a product of
    powers of beta and 1 - beta (``_scalings``: the seed's rigid overhang is straight but
    sloped), so each entry is a sum of numbers times beta^i (1 - beta)^j; the numbers by
    Gauss-Legendre quadrature (nested for h and k) exact to round-off, as E4's."""
    beta = sp.Symbol(beta_name, positive=True)
    nspan = nt - nover
    nodes, weights = np.polynomial.legendre.leggauss(max(64, 12 * nspan + 24))
    x, w = (nodes + 1) / 2, weights / 2
    pairs = curvature_pairs(nt)
    # per piece: pair -> ((beta, 1 - beta) exponents of H's scale, its fixed cumulative function at
    # the nodes, its value at 1)
    cum: list[dict[int, tuple]] = []
    for piece in (0, 1):
        on = {}
        for k in range(nt):
            sc = _scalings(k + 1, nspan, nover)[piece]
            if sc is not None:
                on[k] = (sc, _fixed_derivative(k + 1, nspan, nover, piece, 1, sc))
        table = {}
        for P, (a, b) in enumerate(pairs):
            if a in on and b in on:
                (pa, oa), fa = on[a]
                (pb, ob), fb = on[b]
                exps = (pa + pb - 1, 0) if piece == 0 else (pa + pb, oa + ob - 1)
                table[P] = (
                    exps,
                    _cumulative(lambda s, fa=fa, fb=fb: fa(s) * fb(s), x, w),
                    float(w @ (fa(x) * fb(x))),
                )
        cum.append(table)
    span, over = cum
    n = len(pairs)
    Z = sp.zeros(n, n)

    def scale(exps: tuple[int, int]) -> sp.Expr:
        return beta ** exps[0] * (1 - beta) ** exps[1]

    for P in range(n):
        for Q in range(P, n):
            value = sp.Integer(0)
            if P in span and Q in span:
                value += beta * scale(span[P][0]) * scale(span[Q][0]) * sp.Float(float(w @ (span[P][1] * span[Q][1])))
            # the overhang: H = A + B k(v), A = H(beta) (a pair on the span), B its scale there
            A = {R: scale(span[R][0]) * sp.Float(span[R][2]) for R in (P, Q) if R in span}
            B = {R: scale(over[R][0]) for R in (P, Q) if R in over}
            mean = {R: sp.Float(float(w @ over[R][1])) for R in B}
            over_part = sp.Integer(0)
            if P in A and Q in A:
                over_part += A[P] * A[Q]
            if P in A and Q in B:
                over_part += A[P] * B[Q] * mean[Q]
            if Q in A and P in B:
                over_part += A[Q] * B[P] * mean[P]
            if P in B and Q in B:
                over_part += B[P] * B[Q] * sp.Float(float(w @ (over[P][1] * over[Q][1])))
            Z[P, Q] = Z[Q, P] = value + (1 - beta) * over_part
    return beta, {SHORTENING: Z}


#: the guide's matrices beyond Kt, by the function that makes them (with their siblings)
_MADE_BY = {
    **{name: _tension_gram for name in TENSION_WEIGHTS},
    **{name: _rate_gram for name in RATE_MATRICES},
    SPAN_TENSION: _span_slope_gram,
    CURVATURE: _curvature_gram,
    SHORTENING: _shortening_gram,
}
#: the guide's matrices that are not symmetric
NONSYMMETRIC = ("Kb", CURVATURE)


@dataclass(frozen=True)
class SlotFunction:
    label: str
    span: sp.Expr
    overhang: sp.Expr


@dataclass
class SlotBasis:
    """Transverse basis of a guide bar: nt functions of (xi, beta), the last ``nover`` of them
    the overhang's own bending functions chi_m (see the module's docstring)."""

    nt: int
    beta: sp.Symbol
    nover: int = 0
    family: str = "slot"
    direction: str = "transverse"
    frame: str = "pinned-pinned"
    functions: tuple = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if not 0 <= self.nover <= self.nt:
            raise ValueError(f"nover = {self.nover} overhang functions of nt = {self.nt}")
        fs = []
        for k in range(1, self.nt + 1):
            (s, _, _), (o, _, _) = _pieces(k, self.beta, self.nspan, self.nover)
            if k > self.nspan:  # chi_0: the contact-slope function, chi_m: the overhang's own
                label = rf"\chi_{{{k - self.nspan - 1}}}"
            else:
                label = rf"s_{{{k}}}" if self.nover else rf"\sin({k}\pi\xi/\beta)"
            fs.append(SlotFunction(label, s, o))
        self.functions = tuple(fs)

    @property
    def nspan(self) -> int:
        """Number of span (sine) functions."""
        return self.nt - self.nover

    def __len__(self) -> int:
        return self.nt

    def expr(self, k: int, xi, deriv: int = 0, dbeta: int = 0) -> sp.Expr:
        """d^deriv/dxi^deriv d^dbeta/dbeta^dbeta psi_k at xi (a number or a symbol)."""
        s, o = _derivative(k + 1, self.beta, self.nspan, self.nover, deriv, dbeta)
        xi = sp.sympify(xi)
        s, o = s.xreplace({XI: xi}), o.xreplace({XI: xi})
        if xi.is_Symbol and xi == self.beta:
            return s
        if self.nover and xi.is_number and xi >= 1:  # the far end: beyond the contact (beta < 1), where the
            return o  # span functions vanish (a joint there does not read them: they may be quasi-static)
        return sp.Piecewise((s, xi <= self.beta), (o, True))

    def values(self, xi, deriv: int = 0) -> list:
        return [self.expr(k, xi, deriv) for k in range(self.nt)]


class SlotIPTable:
    """Inner products of a guide bar (closed-form functions of beta), same interface as
    ``bars.IPTable`` for the blocks [1, xi, psi, psi_beta, psi_betabeta] (na = 0)."""

    def __init__(self, basis: SlotBasis, symbolic: bool = False) -> None:
        self.basis, self.na, self.nt, self.symbolic = basis, 0, basis.nt, symbolic
        beta0, G, Kt = _gram(basis.nt, str(basis.beta), basis.nover)
        sub = {beta0: basis.beta}
        self.G = G.xreplace(sub)
        self.Kt = Kt.xreplace(sub)
        self._extra: dict[str, sp.Matrix] = {}
        nt = basis.nt
        self._labels = (
            ["1", r"\xi"]
            + [rf"\psi_{{{k + 1}}}" for k in range(nt)]
            + [rf"\psi_{{{k + 1},\beta}}" for k in range(nt)]
            + [rf"\psi_{{{k + 1},\beta\beta}}" for k in range(nt)]
        )

    def gram(self, i: int, j: int) -> sp.Expr:
        value = self.G[i, j]
        if value == 0:
            return sp.Integer(0)
        if self.symbolic:
            i, j = min(i, j), max(i, j)
            return sp.Symbol(rf"\left({self._labels[i]},{self._labels[j]}\right)")
        return value

    def matrix(self, name: str) -> sp.Matrix:
        """The guide's matrix ``name``: "Kt" (psi''_a, psi''_b), a tension weight's (w psi'_a,
        psi'_b) ("T1", "T2": ``TENSION_WEIGHTS``; "H<xi_p>": ``point_tension_name``) or the
        curvature rate's ("Kb", "Kbb": ``_rate_gram``), those made on first use."""
        if name == "Kt":
            return self.Kt
        if name not in self._extra:
            args = (self.nt, str(self.basis.beta), self.basis.nover)
            if name in _MADE_BY:
                beta0, mats = _MADE_BY[name](*args)
            elif name.startswith("H"):  # point_tension_name
                beta0, mats = _point_tension_gram(*args, float(name[1:]))
            else:
                raise KeyError(f"a guide bar has no {name} inner products")
            self._extra.update({k: m.xreplace({beta0: self.basis.beta}) for k, m in mats.items()})
        return self._extra[name]

    def mat(self, name: str, i: int, j: int, latex: str) -> sp.Expr:
        value = self.matrix(name)[i, j]
        if value == 0:
            return sp.Integer(0)
        return sp.Symbol(latex.format(i=i + 1, j=j + 1)) if self.symbolic else value

    def vec(self, name: str, i: int, latex: str) -> sp.Expr:
        raise KeyError(f"a guide bar has no {name} inner products (rotary inertia is not modelled on slots)")

    def tensor(self, name: str, idx: tuple, latex: str) -> sp.Expr:
        return sp.Integer(0)  # axially rigid: no stretching couplings

    def display(self) -> SlotDisplayIPTable:
        """The display table of these inner products (see ``bars.bar_equations``)."""
        return SlotDisplayIPTable(self)


class SlotDisplayIPTable:
    """A guide's inner products as display symbols, recording each it hands out: ``used`` maps
    it to (kind, (i, j)), kind "gram", "Kt" or "dKt" (d/dbeta of Kt), ``values`` to its closed
    form in beta.

    Same interface as ``SlotIPTable``. (psi''_i, psi''_j) is handed out as a function of beta,
    so that the beta equation's d/dbeta of the strain energy keeps its term; :meth:`finish`
    turns it, and its beta derivative, into symbols of their own.
    """

    def __init__(self, numeric: SlotIPTable) -> None:
        self.numeric, self.beta = numeric, numeric.basis.beta
        self.na, self.nt, self.symbolic = 0, numeric.nt, True
        self.labels = numeric._labels
        self.used: dict[sp.Symbol, tuple] = {}
        self.values: dict[sp.Symbol, sp.Expr] = {}
        self._funcs: dict = {}  # F(beta) -> (i, j)

    def gram(self, i: int, j: int) -> sp.Expr:
        if self.numeric.G[i, j] == 0:
            return sp.Integer(0)
        i, j = min(i, j), max(i, j)
        sym = sp.Symbol(rf"\left({self.labels[i]},{self.labels[j]}\right)")
        if sym not in self.used:
            self.used[sym] = ("gram", (i, j))
            self.values[sym] = self.numeric.G[i, j]
        return sym

    def mat(self, name: str, i: int, j: int, latex: str) -> sp.Expr:
        if name not in NONSYMMETRIC:
            i, j = min(i, j), max(i, j)
        if self.numeric.matrix(name)[i, j] == 0:
            return sp.Integer(0)
        f = sp.Function(latex.format(i=i + 1, j=j + 1))(self.beta)
        self._funcs[f] = (name, i, j)
        return f

    def vec(self, name: str, i: int, latex: str) -> sp.Expr:
        return self.numeric.vec(name, i, latex)

    def tensor(self, name: str, idx: tuple, latex: str) -> sp.Expr:
        return sp.Integer(0)

    def finish(self, expr: sp.Expr) -> sp.Expr:
        """A matrix entry (beta) -> a symbol, its beta derivative -> a symbol of its own."""
        rep = {}
        # the entries and derivatives the expression holds, found once (a has() per entry was most
        # of a slot scene's derivation once the guide's tables had a thousand entries)
        present = expr.atoms(sp.Function) | expr.atoms(sp.Derivative)
        for f, (mat, i, j) in self._funcs.items():
            name = f.func.__name__
            entry = self.numeric.matrix(mat)[i, j]
            for key, sym, kind, value in (
                (
                    sp.Derivative(f, self.beta),
                    sp.Symbol(r"\partial_{\beta}" + name),
                    "d" + mat,
                    lambda e=entry: sp.diff(e, self.beta),
                ),
                (f, sp.Symbol(name), mat, lambda e=entry: e),
            ):
                rep[key] = sym
                if sym not in self.used and key in present:
                    self.used[sym] = (kind, (i, j))
                    self.values[sym] = value()
        return expr.xreplace(rep)  # top down: a derivative is replaced before its function


class SlotBarKinematics:
    """Points of a guide bar: the same interface as ``kinematics.BarKinematics``, with the
    time derivatives taken through beta(tau) as well (generic chain rule on the local point).

    ``foreshortening`` (``effects.geometric_stiffening``): the guide keeps its length as it bends,
    its point xi at u(xi) = -1/2 int_0^xi eta'^2 = -1/2 g^T H(xi) g along the chord
    (``point_tension_name``), the contact at beta + u(beta) (H over the span); the joints on it, the
    bars hanging from it and the slot force then do the virtual work of an axial force on the
    chord's shortening: the tension they pull the guide with (DERIVE_VERSION 12). Only at the
    points the model reads (numbers xi; a symbol xi, the geometry's drawing, keeps the chord's
    xi)."""

    def __init__(self, sym, basis: SlotBasis, beta: tuple, foreshortening: bool = False) -> None:
        self.sym, self.basis_t, self.beta = sym, basis, beta  # beta = (b, db, ddb)
        self.basis_a = None
        self.foreshortening = foreshortening

    def _shortening(self, name: str) -> sp.Expr:
        """-1/2 g^T H g of the matrix ``name`` (a closed form in beta)."""
        H = SlotIPTable(self.basis_t).matrix(name)
        g = self.sym.g
        return -sp.Add(*[H[i, j] * g[i] * g[j] for i in range(len(g)) for j in range(len(g)) if H[i, j] != 0]) / 2

    def zeta(self, xi, deriv: int = 0, amp=None) -> sp.Expr:
        """u(xi) (``foreshortening``), at the coordinates' values; 0 otherwise."""
        xi = sp.sympify(xi)
        if not self.foreshortening or deriv or amp is not None or not xi.is_number or xi <= 0 or not self.sym.g:
            return sp.Integer(0)
        return self._shortening(point_tension_name(float(xi)))

    def eta(self, xi, deriv: int = 0, amp=None) -> sp.Expr:
        amp = self.sym.g if amp is None else amp
        return sp.Add(*[self.basis_t.expr(k, xi, deriv) * a for k, a in enumerate(amp)])

    def local(self, xi) -> tuple:
        return sp.sympify(xi) + self.zeta(xi), self.eta(xi)

    def contact_display(self) -> tuple[sp.Expr, dict, dict]:
        """u(beta) for the LaTeX: -1/2 sum g_j g_k F_jk(beta) with each (psi'_j, psi'_k)_[0,beta] a
        function F_jk of beta (so that u's derivatives keep theirs), the rule turning those and their
        beta derivatives into display symbols, and those symbols' closed forms; (0, {}, {}) without
        ``foreshortening``."""
        s = self.sym
        if not self.foreshortening or not s.g:
            return sp.Integer(0), {}, {}
        b = s.beta[0]
        H = SlotIPTable(self.basis_t).matrix(SPAN_TENSION)
        u = sp.Integer(0)
        rep: dict = {}
        values: dict = {}
        for i in range(len(s.g)):
            for j in range(i, len(s.g)):
                if H[i, j] == 0:
                    continue
                label = rf"\left(\psi'_{{{i + 1}}},\psi'_{{{j + 1}}}\right)_{{[0,\beta]}}"
                f = sp.Function(label)(b)
                u -= (1 if i == j else 2) * f * s.g[i] * s.g[j] / 2
                rep[sp.Derivative(f, b)] = d = sp.Symbol(r"\partial_{\beta}" + label)
                rep[f] = sym = sp.Symbol(label)
                values[sym], values[d] = H[i, j], sp.diff(H[i, j], b)
        return u, rep, values

    def contact_shortening(self) -> sp.Expr:
        """u(beta) = -1/2 int_0^beta eta'^2 (``foreshortening``), else 0."""
        if not self.foreshortening or not self.sym.g:
            return sp.Integer(0)
        return self._shortening(SPAN_TENSION)

    def _coords(self) -> tuple:
        s, (b, db, ddb) = self.sym, self.beta
        return (list(s.g) + [b], list(s.dg) + [db], list(s.ddg) + [ddb])

    def _local_derivs(self, xi) -> tuple:
        """l, l', l'' of the local point (xi + zeta, eta) by the chain rule over (g, beta)."""
        c, dc, ddc = self._coords()
        l = sp.Matrix(self.local(xi))
        J = l.jacobian(c)
        ld = J * sp.Matrix(dc)
        ldd = J * sp.Matrix(ddc)
        for i, ci in enumerate(c):
            for j, cj in enumerate(c):
                h = sp.diff(l, ci, cj)
                if h != sp.zeros(2, 1):
                    ldd += h * dc[i] * dc[j]
        return l, ld, ldd

    def rho(self, xi) -> sp.Matrix:
        s = self.sym
        return s.alpha * rot(s.th) * sp.Matrix(self.local(xi))

    def rho_d(self, xi) -> sp.Matrix:
        s = self.sym
        l, ld, _ = self._local_derivs(xi)
        return s.alpha * rot(s.th) * (ld + s.dth * sp.Matrix([-l[1], l[0]]))

    def bracket_dd(self, xi) -> sp.Matrix:
        s = self.sym
        l, ld, ldd = self._local_derivs(xi)
        Jl, Jld = sp.Matrix([-l[1], l[0]]), sp.Matrix([-ld[1], ld[0]])
        return s.alpha * (ldd + 2 * s.dth * Jld + s.ddth * Jl - s.dth**2 * l)

    def rho_dd(self, xi) -> sp.Matrix:
        return rot(self.sym.th) * self.bracket_dd(xi)

    def partials(self, xi) -> dict:
        s = self.sym
        R = rot(s.th)
        l = sp.Matrix(self.local(xi))
        out = {s.th: s.alpha * R * sp.Matrix([-l[1], l[0]])}
        c, _, _ = self._coords()
        for ci in c:
            out[ci] = s.alpha * R * sp.diff(l, ci)
        return out

    def contact(self) -> tuple:
        """(rho, rho', rho'') of the contact point xi = beta (where eta = 0; along the chord at
        beta + u(beta)), ground axes."""
        s, (b, db, ddb) = self.sym, self.beta
        R = rot(s.th)
        u = self.contact_shortening()
        if u == 0:
            l, ld, ldd = sp.Matrix([b, 0]), sp.Matrix([db, 0]), sp.Matrix([ddb, 0])
        else:
            c, dc, ddc = self._coords()
            grad = [sp.diff(u, x) for x in c]
            ud = sp.Add(*[gx * dx for gx, dx in zip(grad, dc)])
            udd = sp.Add(*[gx * ax for gx, ax in zip(grad, ddc)])
            udd += sp.Add(*[sp.diff(grad[i], cj) * dc[i] * dc[j] for i in range(len(c)) for j, cj in enumerate(c)])
            l, ld, ldd = sp.Matrix([b + u, 0]), sp.Matrix([db + ud, 0]), sp.Matrix([ddb + udd, 0])
        J = lambda v: sp.Matrix([-v[1], v[0]])
        return (
            s.alpha * R * l,
            s.alpha * R * (ld + s.dth * J(l)),
            s.alpha * R * (ldd + 2 * s.dth * J(ld) + s.ddth * J(l) - s.dth**2 * l),
        )

    def contact_partials(self) -> dict:
        """d rho(contact) / d coordinate: the slot force's lever arms (theta, beta and, with the
        foreshortening, the amplitudes)."""
        s, (b, _, _) = self.sym, self.beta
        R = rot(s.th)
        u = self.contact_shortening()
        out = {s.th: s.alpha * R * sp.Matrix([0, b + u]), b: s.alpha * R * sp.Matrix([1 + sp.diff(u, b), 0])}
        if u != 0:
            out.update({gk: s.alpha * R * sp.Matrix([sp.diff(u, gk), 0]) for gk in s.g})
        return out


def is_zero(value) -> bool:
    try:
        return abs(float(value)) < ZERO_TOL
    except TypeError:
        return value == 0
