"""Shape families and their closed-form Galerkin inner products (paper eqs. (16)-(17)).

Deformations of a bar are expanded as ``zeta = phi(xi)^T f`` (axial) and
``eta = psi(xi)^T g`` (transverse), ``xi in [0, 1]``.  This module builds the
families of ``docs/formulation.md`` ("Strain and shape functions") and integrates
every inner product the weak form needs **in closed form**, with the exact term algebra
of :mod:`symgen.model.terms` (every function a finite sum ``c * xi**p * exp(s*xi)``).
The cached entry point is :func:`symgen.model.shape_cache.inner_products` (also for bases
closed by static correction functions, :mod:`symgen.model.static_shapes`); here the tables
are computed (:func:`compute_inner_products`).

Examples
--------
>>> from symgen.model.shapes import axial_basis, transverse_basis, compute_inner_products
>>> ip = compute_inner_products(axial_basis("stress-free", 1), transverse_basis("pinned-pinned", "modes", 1))
>>> ip.exact["gram"][2, 3]          # (sin(pi xi/2), sin(pi xi))
4/(3*pi)
>>> ip.exact["Kt"][0, 0]            # (psi'', psi'')
pi**4/2
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import numpy as np
import sympy

from symgen.model.terms import (
    DPS,
    combine,
    MP,
    Table,
    Terms,
    beta_mp,
    integrate,
    integrate_product,
    multiply,
    poly_terms,
    s_key,
    s_value,
    scratch_exponents,
    sin_terms,
)

__all__ = [
    "SHAPES_VERSION",
    "XI",
    "ShapeFunction",
    "Basis",
    "InnerProducts",
    "CurvatureProducts",
    "compute_curvature_products",
    "curvature_tables",
    "axial_basis",
    "transverse_basis",
    "compute_inner_products",
    "basis_of_key",
    "tip_load_coefficients",
    "clamped_free_roots",
    "AXIAL_FAMILIES",
    "TRANSVERSE_FAMILIES",
    "FRAMES",
]

#: Bump whenever a change here changes any cached number (invalidates disk caches).
SHAPES_VERSION = "3"

#: The dimensionless abscissa along a bar, ``xi = x / l``.
XI = sympy.Symbol("xi", real=True)

AXIAL_FAMILIES = ("complete", "stress-free")
TRANSVERSE_FAMILIES = ("modes", "eigen", "polynomial")
FRAMES = ("pinned-pinned", "cantilever")
_FRAME_ALIASES = {"pinned-sliding": "pinned-pinned"}


# --------------------------------------------------------------------------------------
# Clamped-free eigenfunctions
# --------------------------------------------------------------------------------------
def clamped_free_roots(n: int) -> tuple[float, ...]:
    """The first ``n`` roots ``beta_k`` of ``cos(beta) cosh(beta) = -1``.

    Examples
    --------
    >>> [round(b, 8) for b in clamped_free_roots(3)]
    [1.87510407, 4.69409113, 7.85475744]
    """
    return tuple(float(beta_mp(k)) for k in range(1, n + 1))


@functools.cache
def _eigen_data(k: int) -> dict[str, Any]:
    """Coefficients of ``X_k = cosh - cos - sigma (sinh - sin)`` in a cancellation-free form.

    ``1 - sigma = (sin b - cos b - e^-b) / (sinh b + sin b)`` is evaluated directly, so
    ``X = A e^{b xi} + B e^{-b xi} - cos(b xi) + sigma sin(b xi)`` with
    ``A = (1-sigma)/2``, ``B = (1+sigma)/2`` loses nothing at any order.
    """
    b = beta_mp(k)
    one_minus_sigma = (MP.sin(b) - MP.cos(b) - MP.exp(-b)) / (MP.sinh(b) + MP.sin(b))
    sigma = 1 - one_minus_sigma
    A = one_minus_sigma / 2
    B = (1 + sigma) / 2
    tip = A * MP.exp(b) + B * MP.exp(-b) - MP.cos(b) + sigma * MP.sin(b)  # A e^b = O(1)
    return {"beta": b, "sigma": sigma, "A": A, "B": B, "tip": tip}


def _sf(x: Any, digits: int = 30) -> sympy.Float:
    return sympy.Float(MP.nstr(MP.mpf(x), digits + 3), digits)


def _eigen_function(k: int) -> ShapeFunction:
    e = _eigen_data(k)
    b, sigma, tip = e["beta"], e["sigma"], e["tip"]
    atom = k
    half = MP.mpf(1) / 2
    d = {
        (0, s_key(atom, 1, 0)): MP.mpc(e["A"] / tip),
        (0, s_key(atom, -1, 0)): MP.mpc(e["B"] / tip),
        (0, s_key(atom, 0, 1)): MP.mpc(-half, -sigma / 2) / tip,
        (0, s_key(atom, 0, -1)): MP.mpc(-half, sigma / 2) / tip,
    }
    bs = _sf(b)
    # stable in double precision too: no cosh - sigma*sinh difference of two huge numbers
    expr = (
        _sf(e["A"] / tip) * sympy.exp(bs * XI)
        + _sf(e["B"] / tip) * sympy.exp(-bs * XI)
        - _sf(1 / tip) * sympy.cos(bs * XI)
        + _sf(sigma / tip) * sympy.sin(bs * XI)
    )
    label = rf"X_{k}(\xi)" if k < 10 else rf"X_{{{k}}}(\xi)"
    return ShapeFunction(
        label, expr, beta=float(b), sigma=float(sigma), tip_value=float(tip), terms=Terms(d, exact=False)
    )


# --------------------------------------------------------------------------------------
# Public data classes
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShapeFunction:
    """One shape function of ``xi in [0, 1]``.

    Attributes
    ----------
    label : short LaTeX label, e.g. ``\\sin(\\pi\\xi/2)`` or ``X_2(\\xi)``
    expr : sympy expression in :data:`XI`; exact for the sine and polynomial families.
        For clamped-free eigenfunctions it has 30-digit Floats and is written as
        ``(A e^{beta xi} + B e^{-beta xi} - cos(beta xi) + sigma sin(beta xi)) / tip`` with
        ``A = (1 - sigma)/2`` (tiny) and ``B = (1 + sigma)/2``; unlike the textbook
        ``cosh - sigma sinh`` form it stays accurate when evaluated in double precision.
    beta, sigma : the eigenfunction's root and sigma_k (None for other families)
    tip_value : for eigenfunctions, the value ``X_k(1)`` of the un-normalised
        ``cosh - cos - sigma (sinh - sin)`` that was divided out so that ``psi(1) = 1``
    """

    label: str
    expr: sympy.Expr
    beta: float | None = None
    sigma: float | None = None
    tip_value: float | None = None
    terms: Terms | None = field(default=None, compare=False, repr=False)

    def value(self, xi: float, deriv: int = 0) -> float:
        """Value of the ``deriv``-th derivative at ``xi`` (50-digit evaluation, then float).

        Parameters
        ----------
        xi : abscissa (normally in [0, 1])
        deriv : derivative order, >= 0
        """
        if deriv < 0:
            raise ValueError(f"derivative order must be >= 0, got {deriv}")
        if self.terms is None:  # a hand-made ShapeFunction: fall back to sympy
            return float(sympy.re(sympy.diff(self.expr, XI, deriv).evalf(DPS, subs={XI: xi})))
        return self.terms.evaluate(xi, deriv)


@dataclass(frozen=True)
class Basis:
    """An ordered set of shape functions of one bar direction.

    Attributes
    ----------
    direction : "axial" or "transverse"
    family : "complete" | "stress-free" (axial); "modes" | "eigen" | "polynomial" (transverse)
    frame : "pinned-pinned" | "cantilever" (transverse); "any" for axial bases, which are the
        same in every frame
    functions : the functions, in order
    tip_joint : True when the basis starts with the static tip-load shape (cantilever "modes"
        with a joint at the free end)
    points : interior points ``0 < xi_K < 1`` whose static correction functions
        (:mod:`symgen.model.static_shapes`) close the basis, one per point, after the ``key``'s functions
    moment_points : interior points whose moment correction functions (unit couple) follow those
    """

    direction: str
    family: str
    frame: str
    functions: tuple[ShapeFunction, ...]
    tip_joint: bool = False
    points: tuple[float, ...] = ()  # interior points whose static correction functions end the basis
    moment_points: tuple[float, ...] = ()  # then those whose moment correction functions end it

    def __len__(self) -> int:
        return len(self.functions)

    def values(self, xi: float, deriv: int = 0) -> np.ndarray:
        """Values of every function's ``deriv``-th derivative at ``xi``, shape ``(n,)``."""
        return np.array([f.value(xi, deriv) for f in self.functions], dtype=float)

    @property
    def key(self) -> tuple[str, str, str, int, bool]:
        """``(direction, family, frame, n, tip_joint)``: what determines the functions (with
        ``points`` or ``moment_points``: the standard functions before the static corrections,
        ``n`` counting those)."""
        n = len(self.functions) - len(self.points) - len(self.moment_points)
        return (self.direction, self.family, self.frame, n, self.tip_joint)


def _check_n(n: int, what: str) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"{what}: mode count must be an integer >= 0, got {n!r}")
    return int(n)


def axial_basis(shapes: str, n: int) -> Basis:
    """Axial shape functions ``phi`` (all with ``phi(0) = 0``).

    Parameters
    ----------
    shapes : "complete" -> ``{xi, sin(k pi xi), k = 1..n-1}``;
        "stress-free" -> ``sin((2k-1) pi xi / 2), k = 1..n`` (the seed's; zero slope at the
        free end: with von Karman strain it converges more slowly than "complete")
    n : number of functions (0: axially rigid, empty basis)
    """
    n = _check_n(n, "axial_basis")
    if shapes not in AXIAL_FAMILIES:
        raise ValueError(f"unknown axial shape family {shapes!r}; expected one of {AXIAL_FAMILIES}")
    return _axial_basis(shapes, n)


@functools.cache
def _axial_basis(shapes: str, n: int) -> Basis:
    funcs: list[ShapeFunction] = []
    if shapes == "complete":
        for k in range(n):
            if k == 0:
                funcs.append(ShapeFunction(r"\xi", XI, terms=poly_terms({1: Fraction(1)})))
            else:
                lab = r"\sin(\pi\xi)" if k == 1 else rf"\sin({k}\pi\xi)"
                funcs.append(ShapeFunction(lab, sympy.sin(k * sympy.pi * XI), terms=sin_terms(2 * k)))
    else:
        for k in range(1, n + 1):
            m = 2 * k - 1
            lab = r"\sin(\pi\xi/2)" if m == 1 else rf"\sin({m}\pi\xi/2)"
            funcs.append(ShapeFunction(lab, sympy.sin(m * sympy.pi * XI / 2), terms=sin_terms(m)))
    return Basis("axial", shapes, "any", tuple(funcs))


def transverse_basis(frame: str, shapes: str, n: int, tip_joint: bool = False) -> Basis:
    """Transverse shape functions ``psi``.

    Parameters
    ----------
    frame : "pinned-pinned" (alias "pinned-sliding"): ``psi(0) = psi(1) = 0``;
        "cantilever": ``psi(0) = psi'(0) = 0``
    shapes : "modes" | "eigen" | "polynomial".  Pinned: "modes" and "eigen" give
        ``sin(k pi xi)``, "polynomial" ``xi^k (1 - xi)``.  Cantilever: "eigen" gives the
        clamped-free eigenfunctions normalised to ``psi(1) = 1``; "modes" the same, preceded
        by the static tip-load shape ``xi^2 (3 - xi) / 2`` when ``tip_joint`` (the count
        ``n`` includes it); "polynomial" ``xi^(k+1)``.
    n : number of functions (0: no bending, empty basis)
    tip_joint : whether a joint acts at the free end (matters only for cantilever "modes")
    """
    n = _check_n(n, "transverse_basis")
    frame = _FRAME_ALIASES.get(frame, frame)
    if frame not in FRAMES:
        raise ValueError(f"unknown frame {frame!r}; expected one of {FRAMES + tuple(_FRAME_ALIASES)}")
    if shapes not in TRANSVERSE_FAMILIES:
        raise ValueError(f"unknown transverse shape family {shapes!r}; expected one of {TRANSVERSE_FAMILIES}")
    tip = bool(tip_joint) and frame == "cantilever" and shapes == "modes" and n > 0
    return _transverse_basis(frame, shapes, n, tip)


@functools.cache
def _transverse_basis(frame: str, shapes: str, n: int, tip: bool) -> Basis:
    funcs: list[ShapeFunction] = []
    if frame == "pinned-pinned":
        for k in range(1, n + 1):
            if shapes == "polynomial":
                lab = r"\xi(1-\xi)" if k == 1 else (rf"\xi^{k}(1-\xi)" if k < 10 else rf"\xi^{{{k}}}(1-\xi)")
                funcs.append(
                    ShapeFunction(lab, XI**k * (1 - XI), terms=poly_terms({k: Fraction(1), k + 1: Fraction(-1)}))
                )
            else:
                lab = r"\sin(\pi\xi)" if k == 1 else rf"\sin({k}\pi\xi)"
                funcs.append(ShapeFunction(lab, sympy.sin(k * sympy.pi * XI), terms=sin_terms(2 * k)))
    elif shapes == "polynomial":
        for k in range(1, n + 1):
            lab = rf"\xi^{k + 1}" if k + 1 < 10 else rf"\xi^{{{k + 1}}}"
            funcs.append(ShapeFunction(lab, XI ** (k + 1), terms=poly_terms({k + 1: Fraction(1)})))
    else:
        n_eig = n - 1 if tip else n
        eig = [_eigen_function(k) for k in range(1, n_eig + 1)]
        if tip:
            funcs.append(_tip_load_function(eig))
        funcs.extend(eig)
    return Basis("transverse", shapes, frame, tuple(funcs), tip)


def _tip_load_projection(eig: list[ShapeFunction]) -> tuple:
    """(c_k, t, terms): xi^2 (3 - xi)/2 - sum_k c_k X_k (mass inner product projections c_k) has
    the value t at xi = 1; ``terms`` is that difference (not yet divided by t)."""
    base = poly_terms({2: Fraction(3, 2), 3: Fraction(-1, 2)}).as_mp()
    d: dict[tuple[int, int], Any] = dict(base.d)  # inexact terms: mpc coefficients
    coeffs = []
    for f in eig:
        assert f.terms is not None, "an eigenfunction has its term form"
        t = f.terms.as_mp()
        ratio: Any = integrate_product(base, t)  # of inexact terms: an mpc
        c = MP.mpf((ratio / integrate_product(t, t)).real)
        coeffs.append(c)
        for key, val in t.d.items():
            d[key] = d.get(key, MP.mpc(0)) - c * val
    tip = MP.mpf(sum((c * (MP.exp(s_value(sid)) if sid else 1) for (_, sid), c in d.items()), MP.mpc(0)).real)
    return coeffs, tip, d


def tip_load_coefficients(eig: list[ShapeFunction]) -> tuple[list[float], float]:
    """(c_1..c_m, t) of the orthogonalised tip-load shape
    psi = (xi^2 (3 - xi)/2 - sum_k c_k X_k(xi)) / t, for printing it factored."""
    coeffs, tip, _ = _tip_load_projection(eig)
    return [float(c) for c in coeffs], float(tip)


def _tip_load_function(eig: list[ShapeFunction]) -> ShapeFunction:
    """The static tip-load shape xi^2 (3 - xi)/2, orthogonalised (mass inner product) against
    the eigenfunctions that follow it and scaled to psi(1) = 1.

    The basis spans the same functions as {tip-load shape, X_1..X_m}, so the Galerkin model is
    the same; but the raw tip-load shape is almost X_1 (its remainder after X_1..X_m is of the
    order (beta_1/beta_{m+1})^4), which made the mass matrix nearly singular (condition 5e6
    with 4 functions, 1e9 with 8) and IDAS fail for rich cantilever models. What is left after
    the projection is the part that carries the tip shear, which no eigenfunction has.
    """
    static = poly_terms({2: Fraction(3, 2), 3: Fraction(-1, 2)})
    expr = XI**2 * (3 - XI) / 2
    if not eig:
        return ShapeFunction(r"\xi^2(3-\xi)/2", expr, terms=static)
    coeffs, tip, d = _tip_load_projection(eig)
    scaled = Terms({k: v / tip for k, v in d.items()}, exact=False)
    expr = (expr - sum((_sf(c) * f.expr for c, f in zip(coeffs, eig)), sympy.Integer(0))) / _sf(tip)
    m = len(eig)
    label = r"[\xi^2(3-\xi)/2]_{\perp X_{1..%d}}" % m
    return ShapeFunction(label, expr, terms=scaled)


def basis_of_key(key: tuple[str, str, str, int, bool]) -> Basis:
    """The standard basis of a :attr:`Basis.key` (the functions before any static correction)."""
    direction, family, frame, n, tip = key
    if direction == "axial":
        return axial_basis(family, n)
    return transverse_basis(frame, family, n, tip)


# --------------------------------------------------------------------------------------
# Inner products
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class InnerProducts:
    """Closed-form inner products ``(a, b) = int_0^1 a b^T dxi`` of one bar's bases.

    Float arrays are read-only (they are shared through the cache).

    Attributes
    ----------
    na, nt : numbers of axial (phi) and transverse (psi) functions
    gram : ``(2+na+nt, 2+na+nt)`` Gram matrix of ``b = [1, xi, phi_1..phi_na, psi_1..psi_nt]``
    Ka : ``(phi', phi'^T)``
    Kt : ``(psi'', psi''^T)``
    Pd : ``(psi', psi'^T)``
    psid1 : ``(psi', 1) = psi(1) - psi(0)``
    C3 : ``C3[k, a, b] = int phi'_k psi'_a psi'_b``
    D4 : ``D4[a, b, c, d] = int psi'_a psi'_b psi'_c psi'_d`` (fully symmetric)
    exact : the same names mapped to sympy ``ImmutableMatrix`` (gram, Ka, Kt, Pd; psid1 as
        an ``nt x 1`` column) or ``ImmutableDenseNDimArray`` (C3, D4); entries are exact
        (rationals and powers of pi) where both factors are exact, 50-digit Floats otherwise
    """

    na: int
    nt: int
    gram: np.ndarray
    Ka: np.ndarray
    Kt: np.ndarray
    Pd: np.ndarray
    psid1: np.ndarray
    C3: np.ndarray
    D4: np.ndarray
    exact: dict[str, object]
    #: the exact bar's tables (``effects.strain = "exact"``), joined by
    #: :meth:`with_curvature`; None for the other strains
    curvature: CurvatureProducts | None = None
    #: the exact bar's sixth-order tables (:class:`symgen.model.static_shapes.SixthOrderProducts`),
    #: joined by :meth:`with_sixth_order`; None for the other strains
    sixth: Any = None

    @property
    def E6(self) -> dict[tuple[int, ...], float]:
        return self._sixth().E6

    @property
    def C5(self) -> dict[tuple[int, ...], float]:
        """``(phi'_k, psi'_a psi'_b psi'_c psi'_d)`` over sorted (a, b, c, d): the exact strain's
        eta'^4 / 8 (with the sixth-order tables)."""
        return self._sixth().C5

    @property
    def H4(self) -> dict[tuple[int, ...], float]:
        """The exact curvature rate's damping table (with the sixth-order tables)."""
        return self._sixth().H4

    @property
    def Q4(self) -> dict[tuple[int, ...], float]:
        """``(phi'_k phi'_l, psi'_a psi'_b)`` over k <= l, a <= b: the exact strain's -eps eta'^2 / 2
        (with the sixth-order tables)."""
        return self._sixth().Q4

    def _sixth(self) -> Any:
        if self.sixth is None:
            raise ValueError("these inner products have no sixth-order tables (join them with with_sixth_order)")
        return self.sixth

    def with_sixth_order(self, sixth: Any) -> InnerProducts:
        """These inner products with the exact bar's sixth-order tables."""
        if (sixth.na, sixth.nt) != (self.na, self.nt):
            raise ValueError(f"sixth-order tables of {sixth.na} + {sixth.nt} functions for {self.na} + {self.nt}")
        return replace(self, sixth=sixth)

    @property
    def E4(self) -> np.ndarray:
        return self._curvature().E4

    @property
    def G3(self) -> np.ndarray:
        return self._curvature().G3

    def _curvature(self) -> CurvatureProducts:
        if self.curvature is None:
            raise ValueError("these inner products have no curvature tables (join them with with_curvature)")
        return self.curvature

    def with_curvature(self, curvature: CurvatureProducts) -> InnerProducts:
        """These inner products with the exact bar's tables (their exact values under the same
        names in ``exact``)."""
        if (curvature.na, curvature.nt) != (self.na, self.nt):
            raise ValueError(f"curvature tables of {curvature.na} + {curvature.nt} functions for {self.na} + {self.nt}")
        return replace(self, curvature=curvature, exact={**self.exact, **curvature.exact})

    @classmethod
    def from_tables(cls, na: int, nt: int, tables: dict[str, Table]) -> InnerProducts:
        """The inner products of the filled tables ``gram, Ka, Kt, Pd, psid1, C3, D4`` (their float
        arrays and their exact values)."""
        exact: dict[str, object] = {name: tables[name].matrix() for name in ("gram", "Ka", "Kt", "Pd")}
        psid1 = tables["psid1"]
        exact["psid1"] = sympy.ImmutableMatrix(nt, 1, lambda i, j: psid1.s[(i,)])
        exact["C3"], exact["D4"] = tables["C3"].array(), tables["D4"].array()
        frozen: dict[str, Any] = {name: table.frozen() for name, table in tables.items()}
        return cls(na=na, nt=nt, exact=exact, **frozen)


def _terms_of(basis: Basis) -> list[Terms]:
    out = []
    for f in basis.functions:
        if f.terms is None:
            raise ValueError(
                f"shape function {f.label!r} has no term representation; build bases "
                "with axial_basis()/transverse_basis()"
            )
        out.append(f.terms)
    return out


def compute_inner_products(axial: Basis, transverse: Basis) -> InnerProducts:
    """Every inner product of two standard bases, uncached (one computation at a time; its
    scratch is freed). :func:`symgen.model.shape_cache.inner_products` caches it."""
    phi, psi = _terms_of(axial), _terms_of(transverse)
    with scratch_exponents():
        return _compute_locked(phi, psi)


def _compute_locked(phi: list[Terms], psi: list[Terms]) -> InnerProducts:
    na, nt = len(phi), len(psi)
    b = [poly_terms({0: Fraction(1)}), poly_terms({1: Fraction(1)})] + phi + psi
    N = len(b)

    gram = Table((N, N))
    for i in range(N):
        for j in range(i, N):
            gram.set({(i, j), (j, i)}, integrate_product(b[i], b[j]))

    dphi = [t.deriv(1) for t in phi]
    dpsi = [t.deriv(1) for t in psi]
    ddpsi = [t.deriv(2) for t in psi]

    Ka = Table((na, na))
    for i in range(na):
        for j in range(i, na):
            Ka.set({(i, j), (j, i)}, integrate_product(dphi[i], dphi[j]))
    Kt = Table((nt, nt))
    for i in range(nt):
        for j in range(i, nt):
            Kt.set({(i, j), (j, i)}, integrate_product(ddpsi[i], ddpsi[j]))

    pairs = [(a, c) for a in range(nt) for c in range(a, nt)]
    P = {ab: multiply(dpsi[ab[0]], dpsi[ab[1]]) for ab in pairs}
    Pd = Table((nt, nt))
    for a, c in pairs:
        Pd.set({(a, c), (c, a)}, integrate(P[(a, c)]))
    psid1 = Table((nt,))
    for a in range(nt):
        psid1.set({(a,)}, integrate(dpsi[a]))

    C3 = Table((na, nt, nt))
    for k in range(na):
        for a, c in pairs:
            C3.set({(k, a, c), (k, c, a)}, integrate_product(dphi[k], P[(a, c)]))

    D4 = Table((nt, nt, nt, nt))
    for idx in itertools.combinations_with_replacement(range(nt), 4):
        a, c, d, e = idx
        D4.set(set(itertools.permutations(idx)), integrate_product(P[(a, c)], P[(d, e)]))

    tables = {"gram": gram, "Ka": Ka, "Kt": Kt, "Pd": Pd, "psid1": psid1, "C3": C3, "D4": D4}
    return InnerProducts.from_tables(na, nt, tables)


# --------------------------------------------------------------------------------------
# The exact bar's inner products (effects.strain = "exact", docs/exact-bars.md)
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class CurvatureProducts:
    """The inner products of the fourth-order curvature terms of one bar's bending energy,
    (mu/2) int kappa^2 = (mu/2) int eta''^2 + (mu/2) int eta'^2 eta''^2
    - mu int (eps eta''^2 + eps' eta' eta'') (``docs/exact-bars.md``).

    Attributes
    ----------
    E4 : ``(nt, nt, nt, nt)``, fully symmetric: the symmetric part of
        ``int psi'_a psi'_b psi''_c psi''_d``, so that ``int eta'^2 eta''^2 = sum E4 g g g g``;
        with ``P_ab = psi'_a psi'_b`` (``eta' eta'' = (eta'^2)'/2``) it is
        ``(1/12) [(P'_ab, P'_cd) + (P'_ac, P'_bd) + (P'_ad, P'_bc)]``
    G3 : ``(na, nt, nt)``, symmetric in its last two indices:
        ``(phi'_k, psi''_a psi''_b) + (phi''_k, P'_ab) / 2``, so that
        ``int (eps eta''^2 + eps' eta' eta'') = sum_k e_k sum_ab G3 g_a g_b`` for the strain
        ``eps = sum_k e_k phi'_k``
    exact : the same names mapped to ``ImmutableDenseNDimArray`` (as ``InnerProducts.exact``)
    """

    na: int
    nt: int
    E4: np.ndarray
    G3: np.ndarray
    exact: dict[str, object]

    @classmethod
    def from_tables(cls, na: int, nt: int, tables: dict[str, Table]) -> CurvatureProducts:
        exact: dict[str, object] = {name: tables[name].array() for name in ("E4", "G3")}
        return cls(na=na, nt=nt, exact=exact, E4=tables["E4"].frozen(), G3=tables["G3"].frozen())


def curvature_tables(
    dphi: list[Any], ddphi: list[Any], dpsi: list[Any], ddpsi: list[Any], mul: Any, der: Any, ip: Any
) -> dict[str, Table]:
    """The tables of :class:`CurvatureProducts` from the functions' derivatives, for any
    representation: ``mul(u, v)`` the product, ``der(u)`` the derivative and ``ip(u, v)`` the
    closed-form integral of the product over [0, 1] (one piece, or piecewise functions).
    Only sorted index tuples are integrated; the others are set by symmetry."""
    na, nt = len(dphi), len(dpsi)
    pairs = [(a, c) for a in range(nt) for c in range(a, nt)]
    dP = {(a, c): der(mul(dpsi[a], dpsi[c])) for a, c in pairs}  # P'_ac = (psi'_a psi'_c)'
    done: dict[tuple, Any] = {}

    def pp(x: tuple, y: tuple) -> Any:  # (P'_x, P'_y), each pair of pairs integrated once
        key = (min(x, y), max(x, y))
        if key not in done:
            done[key] = ip(dP[x], dP[y])
        return done[key]

    E4 = Table((nt, nt, nt, nt))
    for a, b, c, d in itertools.combinations_with_replacement(range(nt), 4):
        parts = [pp((a, b), (c, d)), pp((a, c), (b, d)), pp((a, d), (b, c))]
        E4.set(set(itertools.permutations((a, b, c, d))), combine(parts, Fraction(1, 12)))
    G3 = Table((na, nt, nt))
    for k in range(na):
        for a, c in pairs:
            value = combine([ip(dphi[k], mul(ddpsi[a], ddpsi[c]))], Fraction(1))
            value = combine([value, combine([ip(ddphi[k], dP[(a, c)])], Fraction(1, 2))], Fraction(1))
            G3.set({(k, a, c), (k, c, a)}, value)
    return {"E4": E4, "G3": G3}


def compute_curvature_products(axial: Basis, transverse: Basis) -> CurvatureProducts:
    """:class:`CurvatureProducts` of two standard bases, uncached
    (:func:`symgen.model.shape_cache.curvature_products` caches it)."""
    phi, psi = _terms_of(axial), _terms_of(transverse)
    with scratch_exponents():
        tables = curvature_tables(
            [t.deriv(1) for t in phi],
            [t.deriv(2) for t in phi],
            [t.deriv(1) for t in psi],
            [t.deriv(2) for t in psi],
            multiply,
            lambda u: u.deriv(1),
            integrate_product,
        )
        return CurvatureProducts.from_tables(len(phi), len(psi), tables)
