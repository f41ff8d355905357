"""Shape families and their closed-form Galerkin inner products (paper eqs. (16)-(17)).

Deformations of a bar are expanded as ``zeta = phi(xi)^T f`` (axial) and
``eta = psi(xi)^T g`` (transverse), ``xi in [0, 1]``.  This module builds the
families of ``docs/formulation.md`` ("Strain and shape functions") and integrates
every inner product the weak form needs **in closed form**.

Representation
--------------
Every shape function is held as a finite sum of terms ``c * xi**p * exp(s*xi)``:
sin, cos, sinh and cosh are rewritten as exponentials and polynomials have
``s = 0``.  Products and derivatives stay in this class, and

    int_0^1 xi^p e^(s xi) dxi = 1/(p+1)                       (s = 0)
    I_0 = (e^s - 1)/s,   I_p = e^s/s - (p/s) I_(p-1)          (s != 0)

(a power series when ``0 < |s| < 2``: this does happen, e.g. ``s = i(3 pi/2 - beta_2)
~ 0.018 i`` in ``C3`` of stress-free axial and clamped-free transverse functions).  The
exponent ``s`` is held as an exact linear combination, with Gaussian-integer
coefficients, of "atoms" (``pi/2`` and the clamped-free roots ``beta_k``), so equal
exponents merge exactly and cancellations such as ``i beta - i beta`` give an exact
zero.  Coefficients are exact (Laurent polynomials in pi over Q(i)) for the sine and
polynomial families and 50-digit :mod:`mpmath` complex numbers for the eigenfunction
family, whose hyperbolic parts would cancel catastrophically in double precision.
Inner products of real functions fold conjugate exponent pairs (half the work).

Examples
--------
>>> from symgen.model.shapes import axial_basis, transverse_basis, inner_products
>>> ip = inner_products(axial_basis("stress-free", 1), transverse_basis("pinned-pinned", "modes", 1))
>>> ip.exact["gram"][2, 3]          # (sin(pi xi/2), sin(pi xi))
4/(3*pi)
>>> ip.exact["Kt"][0, 0]            # (psi'', psi'')
pi**4/2
"""
from __future__ import annotations

import functools
import itertools
import json
import math
import os
import tempfile
import threading
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any, Union

import numpy as np
import sympy
from mpmath.ctx_mp import MPContext

__all__ = [
    "SHAPES_VERSION",
    "XI",
    "ShapeFunction",
    "Basis",
    "InnerProducts",
    "axial_basis",
    "transverse_basis",
    "inner_products",
    "clamped_free_roots",
    "cache_dir",
    "clear_memory_cache",
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

_DPS = 50  # working digits of every non-exact computation
_MP = MPContext()  # private context: nobody else's mp.dps setting can reach us
_MP.dps = _DPS


# --------------------------------------------------------------------------------------
# Exact coefficients: Laurent polynomials in pi with Gaussian-rational coefficients
# --------------------------------------------------------------------------------------
class _Exact:
    """An exact number ``sum_m (a_m + i b_m) pi**m`` (``a_m, b_m`` rational)."""

    __slots__ = ("d",)

    def __init__(self, d: dict[int, tuple[Fraction, Fraction]]) -> None:
        self.d = d  # never holds a zero entry

    @staticmethod
    def of(re: Any = 0, im: Any = 0, m: int = 0) -> _Exact:
        re, im = Fraction(re), Fraction(im)
        return _Exact({m: (re, im)} if (re or im) else {})

    def __add__(self, other: _Exact) -> _Exact:
        d = dict(self.d)
        for m, (a, b) in other.d.items():
            if m in d:
                a0, b0 = d[m]
                a, b = a0 + a, b0 + b
                if a or b:
                    d[m] = (a, b)
                else:
                    del d[m]
            else:
                d[m] = (a, b)
        return _Exact(d)

    def __mul__(self, other: _Exact) -> _Exact:
        d: dict[int, tuple[Fraction, Fraction]] = {}
        for m1, (a1, b1) in self.d.items():
            for m2, (a2, b2) in other.d.items():
                a, b = a1 * a2 - b1 * b2, a1 * b2 + b1 * a2
                m = m1 + m2
                if m in d:
                    a, b = d[m][0] + a, d[m][1] + b
                d[m] = (a, b)
        return _Exact({m: v for m, v in d.items() if v[0] or v[1]})

    def scale(self, r: Fraction) -> _Exact:
        if not r:
            return _Exact({})
        return _Exact({m: (a * r, b * r) for m, (a, b) in self.d.items()})

    def is_zero(self) -> bool:
        return not self.d

    def to_mp(self) -> Any:
        tot = _MP.mpc(0)
        for m, (a, b) in self.d.items():
            tot += _MP.mpc(_MP.mpf(a.numerator) / a.denominator,
                           _MP.mpf(b.numerator) / b.denominator) * _MP.pi ** m
        return tot

    def to_sympy(self) -> sympy.Expr:
        terms = []
        for m, (a, b) in sorted(self.d.items()):
            terms.append((sympy.Rational(a.numerator, a.denominator)
                          + sympy.I * sympy.Rational(b.numerator, b.denominator)) * sympy.pi ** m)
        return sympy.Add(*terms)

    def is_real(self) -> bool:
        return all(b == 0 for _, b in self.d.values())


Coef = Union[_Exact, Any]  # _Exact or an mpc of _MP


# --------------------------------------------------------------------------------------
# Exponents s: interned exact linear combinations of atoms
# --------------------------------------------------------------------------------------
# An exponent key is a sorted tuple of (atom, re, im) with integer re, im; its value is
# sum (re + i im) * value(atom).  Atom 0 has value pi/2 (so sin(k pi xi/2) needs only
# integers); atom k >= 1 has value beta_k, the k-th clamped-free root.  Keys are interned
# to small ints so that the inner loops hash ints only.  A key made by adding two keys
# remembers its parents, so its value and exp(value) cost one addition and one
# multiplication instead of a rebuild and a complex exp.  Keys of shape functions are
# "persistent"; the (many) keys of products made while computing inner products are
# forgotten when that computation ends, with every cache that refers to them.
_LOCK = threading.Lock()
_COMPUTE_LOCK = threading.RLock()
_PERSISTENT: set[int] = {0}
_SKEYS: list[tuple] = [()]
_SKEY_ID: dict[tuple, int] = {(): 0}
_SPARENTS: dict[int, tuple[int, int]] = {}
_SADD: dict[tuple[int, int], int] = {}
_SVAL: dict[int, Any] = {}
_SEXP: dict[int, Any] = {}
_KAPPA: dict[int, Fraction | None] = {0: Fraction(0)}
_SCONJ: dict[int, int] = {0: 0}


def _sid(key: tuple, parents: tuple[int, int] | None = None, persistent: bool = False) -> int:
    """Intern an exponent key; return its id (0 is the zero exponent)."""
    i = _SKEY_ID.get(key)
    if i is None or (persistent and i not in _PERSISTENT):
        with _LOCK:
            i = _SKEY_ID.get(key)
            if i is None:
                i = len(_SKEYS)
                _SKEYS.append(key)
                if parents is not None and not persistent:
                    _SPARENTS[i] = parents
                _SKEY_ID[key] = i
            if persistent:
                _PERSISTENT.add(i)
                _SPARENTS.pop(i, None)  # its parents may be forgotten; value from atoms
    return i


def _forget_derived(start: int) -> None:
    """Forget every non-persistent exponent key with id >= ``start`` and the caches using them."""
    with _LOCK:
        _SADD.clear()
        _J_MP.clear()
        _J_EXACT.clear()
        for i in range(start, len(_SKEYS)):
            key = _SKEYS[i]
            if key is None or i in _PERSISTENT:
                continue
            _SKEYS[i] = None  # ids are never reused
            del _SKEY_ID[key]
            for d in (_SPARENTS, _SVAL, _SEXP, _KAPPA):
                d.pop(i, None)
            j = _SCONJ.pop(i, None)
            if j is not None and _SCONJ.get(j) == i:
                del _SCONJ[j]


def _sadd(i: int, j: int) -> int:
    """Id of the sum of the exponents with ids ``i`` and ``j``."""
    if not i:
        return j
    if not j:
        return i
    r = _SADD.get((i, j))
    if r is None:
        d = {atom: (a, b) for atom, a, b in _SKEYS[i]}
        for atom, a, b in _SKEYS[j]:
            if atom in d:
                a0, b0 = d[atom]
                a, b = a0 + a, b0 + b
                if a or b:
                    d[atom] = (a, b)
                else:
                    del d[atom]
            else:
                d[atom] = (a, b)
        r = _sid(tuple(sorted((atom, a, b) for atom, (a, b) in d.items())), (i, j))
        _SADD[(i, j)] = _SADD[(j, i)] = r
    return r


def _kappa(i: int) -> Fraction | None:
    """``kappa`` if exponent ``i`` is exactly ``i*pi*kappa`` (kappa rational), else None."""
    k = _KAPPA.get(i, False)
    if k is False:
        key = _SKEYS[i]
        k = None
        if len(key) == 1 and key[0][0] == 0 and key[0][1] == 0:
            k = Fraction(key[0][2], 2)
        _KAPPA[i] = k
    return k


def _atom_value(atom: int) -> Any:
    return _MP.pi / 2 if atom == 0 else _beta_mp(atom)


def _s_value(i: int) -> Any:
    """The exponent with id ``i`` as a 50-digit mpc."""
    v = _SVAL.get(i)
    if v is None:
        par = _SPARENTS.get(i)
        if par is not None:
            v = _s_value(par[0]) + _s_value(par[1])
        else:
            v = _MP.mpc(0)
            for atom, a, b in _SKEYS[i]:
                v += _MP.mpc(a, b) * _atom_value(atom)
        _SVAL[i] = v
    return v


def _s_exp(i: int) -> Any:
    """``exp`` of the exponent with id ``i`` (50 digits)."""
    v = _SEXP.get(i)
    if v is None:
        par = _SPARENTS.get(i)
        v = _s_exp(par[0]) * _s_exp(par[1]) if par is not None else _MP.exp(_s_value(i))
        _SEXP[i] = v
    return v


def _sconj(i: int) -> int:
    """Id of the complex conjugate of exponent ``i`` (atoms are real)."""
    r = _SCONJ.get(i)
    if r is None:
        r = _sid(tuple((atom, a, -b) for atom, a, b in _SKEYS[i]), persistent=i in _PERSISTENT)
        _SCONJ[i] = r
        _SCONJ[r] = i
    return r


def _skey(atom: int, re: int = 0, im: int = 0) -> int:
    return _sid(((atom, re, im),), persistent=True) if (re or im) else 0


# --------------------------------------------------------------------------------------
# Term sums
# --------------------------------------------------------------------------------------
class _Terms:
    """``sum c * xi**p * exp(s*xi)`` as a dict ``{(p, s_id): c}``.

    ``exact`` is True when every coefficient is an :class:`_Exact` and every exponent
    is ``i*pi*kappa``; otherwise every coefficient is an mpc.
    """

    __slots__ = ("d", "exact", "_derivs", "_numeric")

    def __init__(self, d: dict[tuple[int, int], Coef], exact: bool) -> None:
        self.d = d
        self.exact = exact
        self._derivs: list[_Terms] = [self]
        self._numeric: dict[int, list] = {}

    def __getstate__(self) -> tuple:
        # exponent ids are process-local: pickle the keys themselves; mpc as raw mpf tuples
        if self.exact:
            items = [(p, _SKEYS[s], c) for (p, s), c in self.d.items()]
        else:
            items = [(p, _SKEYS[s], (c.real._mpf_, c.imag._mpf_)) for (p, s), c in self.d.items()]
        return (items, self.exact)

    def __setstate__(self, state: tuple) -> None:
        items, exact = state
        if exact:
            self.d = {(p, _sid(k, persistent=True)): c for p, k, c in items}
        else:
            self.d = {(p, _sid(k, persistent=True)): _MP.make_mpc(c) for p, k, c in items}
        self.exact = exact
        self._derivs = [self]
        self._numeric = {}

    def as_mp(self) -> _Terms:
        if not self.exact:
            return self
        return _Terms({k: c.to_mp() for k, c in self.d.items()}, exact=False)

    def deriv(self, order: int) -> _Terms:
        """The ``order``-th derivative (cached)."""
        while len(self._derivs) <= order:
            self._derivs.append(_tderiv(self._derivs[-1]))
        return self._derivs[order]

    def items(self) -> list[tuple[int, int, Coef]]:
        return [(p, s, c) for (p, s), c in self.d.items()]

    def half_items(self) -> list[tuple[int, int, Coef]]:
        """Terms of a *real* function with conjugate pairs folded: ``Re sum c F(s)`` over all
        terms equals ``Re sum`` over these when ``F(conj s) = conj F(s)``.

        A term whose exponent is real is kept as is; of a conjugate pair ``(s, conj s)`` only
        the one with the smaller id is kept, with its coefficient doubled.
        """
        out = []
        for (p, s), c in self.d.items():
            cs = _sconj(s)
            if cs == s:
                out.append((p, s, c))
            elif s < cs:
                out.append((p, s, 2 * c))
        return out

    def evaluate(self, xi: float, order: int = 0) -> float:
        """Real part of the ``order``-th derivative at ``xi``, at 50 digits, as a float."""
        num = self._numeric.get(order)
        if num is None:
            t = self.deriv(order)
            num = [(p, _s_value(s) if s else None, c.to_mp() if t.exact else c)
                   for (p, s), c in t.d.items()]
            self._numeric[order] = num
        x = _MP.mpf(float(xi))
        tot = _MP.mpc(0)
        for p, s, c in num:
            v = c * x ** p if p else c
            if s is not None:
                v = v * _MP.exp(s * x)
            tot += v
        return float(tot.real)


def _tnew(d: dict[tuple[int, int], Coef], exact: bool) -> _Terms:
    if exact:
        d = {k: c for k, c in d.items() if not c.is_zero()}
    else:
        d = {k: c for k, c in d.items() if c != 0}
    return _Terms(d, exact)


def _acc(out: dict, key: tuple[int, int], c: Coef) -> None:
    if key in out:
        out[key] = out[key] + c
    else:
        out[key] = c


def _tmul(a: _Terms, b: _Terms) -> _Terms:
    """Product of two term sums, equal ``(p, s)`` merged."""
    if a.exact != b.exact:
        a, b = a.as_mp(), b.as_mp()
    out: dict = {}
    for (p1, s1), c1 in a.d.items():
        for (p2, s2), c2 in b.d.items():
            _acc(out, (p1 + p2, _sadd(s1, s2)), c1 * c2)
    return _tnew(out, a.exact)


def _tderiv(a: _Terms) -> _Terms:
    out: dict = {}
    for (p, s), c in a.d.items():
        if a.exact:
            if p:
                _acc(out, (p - 1, s), c.scale(Fraction(p)))
            if s:
                _acc(out, (p, s), c * _Exact.of(0, _kappa(s), 1))
        else:
            if p:
                _acc(out, (p - 1, s), c * p)
            if s:
                _acc(out, (p, s), c * _s_value(s))
    return _tnew(out, a.exact)


_J_EXACT: dict[tuple[int, int], _Exact] = {}
_J_MP: dict[tuple[int, int], Any] = {}


def _j_exact(p: int, s: int) -> _Exact:
    """Exact ``int_0^1 xi^p exp(i pi kappa xi)`` (``2 kappa`` must be an integer)."""
    r = _J_EXACT.get((p, s))
    if r is not None:
        return r
    kappa = _kappa(s)
    if kappa is None:  # pragma: no cover - internal
        raise ValueError("exponent is not i*pi*rational")
    if kappa == 0:
        r = _Exact.of(Fraction(1, p + 1))
    else:
        two_k = 2 * kappa
        if two_k.denominator != 1:
            raise ValueError(f"exp(i*pi*{kappa}) is not a Gaussian rational; "
                             "exact integration supports half-integer multiples of pi only")
        unit = [(1, 0), (0, 1), (-1, 0), (0, -1)][int(two_k) % 4]  # exp(i pi kappa) = i**(2 kappa)
        e_s = _Exact.of(*unit)
        inv_s = _Exact.of(0, -1 / kappa, -1)  # 1/(i pi kappa)
        r = (e_s + _Exact.of(-1)) * inv_s
        for q in range(1, p + 1):
            r = e_s * inv_s + (inv_s * r).scale(Fraction(-q))
    _J_EXACT[(p, s)] = r
    return r


def _j_mp(p: int, s: int) -> Any:
    """``int_0^1 xi^p exp(s xi)`` at 50 digits (series for small |s|)."""
    r = _J_MP.get((p, s))
    if r is not None:
        return r
    if not s:
        r = _MP.mpc(1) / (p + 1)
    else:
        sv = _s_value(s)
        if abs(sv.real) + abs(sv.imag) < 2:
            # sum_j s^j / (j! (p + j + 1)), |s| < 2: converges to 50 digits in < 70 terms
            r, term, j = _MP.mpc(0), _MP.mpc(1), 0
            while True:
                add = term / (p + j + 1)
                r += add
                if j > 4 and abs(add) < _MP.mpf(10) ** (-_DPS - 5) * max(abs(r), 1):
                    break
                j += 1
                term = term * sv / j
        else:
            e_s = _s_exp(s)
            r = (e_s - 1) / sv
            for q in range(1, p + 1):
                r = e_s / sv - q * r / sv
    _J_MP[(p, s)] = r
    return r


def _integrate(a: _Terms) -> Coef:
    """``int_0^1 a dxi``."""
    if a.exact:
        tot = _Exact({})
        for (p, s), c in a.d.items():
            tot = tot + c * _j_exact(p, s)
        return tot
    tot = _MP.mpc(0)
    for (p, s), c in a.d.items():
        tot += c * _j_mp(p, s)
    return tot


def _integrate_product(a: _Terms, b: _Terms) -> Coef:
    """``int_0^1 a b dxi`` without forming the product term sum."""
    if a.exact != b.exact:
        a, b = a.as_mp(), b.as_mp()
    A, B = a.items(), b.items()
    if a.exact:
        tot = _Exact({})
        for p1, s1, c1 in A:
            acc = _Exact({})
            for p2, s2, c2 in B:
                acc = acc + c2 * _j_exact(p1 + p2, _sadd(s1, s2))
            tot = tot + c1 * acc
        return tot
    # a and b are real functions, so the integral is real: fold conjugate pairs of a
    A = a.half_items()
    tot = _MP.mpc(0)
    jm, sadd = _J_MP, _sadd
    for p1, s1, c1 in A:
        acc = _MP.mpc(0)
        for p2, s2, c2 in B:
            key = (p1 + p2, sadd(s1, s2))
            j = jm.get(key)
            if j is None:
                j = _j_mp(*key)
            acc += c2 * j
        tot += c1 * acc
    return _MP.mpc(tot.real)


def _poly_terms(coeffs: dict[int, Fraction]) -> _Terms:
    """``sum coeffs[p] xi**p`` as an exact term sum."""
    return _tnew({(p, 0): _Exact.of(c) for p, c in coeffs.items()}, exact=True)


def _sin_terms(m: int) -> _Terms:
    """``sin(m pi xi / 2) = (e^{i m (pi/2) xi} - e^{-i m (pi/2) xi}) / (2i)``."""
    half = Fraction(1, 2)
    return _tnew({(0, _skey(0, 0, m)): _Exact.of(0, -half),
                  (0, _skey(0, 0, -m)): _Exact.of(0, half)}, exact=True)


# --------------------------------------------------------------------------------------
# Clamped-free eigenfunctions
# --------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=None)
def _beta_mp(k: int) -> Any:
    """k-th root of ``cos(b) cosh(b) = -1`` at 50 digits (``mpmath.findroot``)."""
    if k < 1:
        raise ValueError(f"root index must be >= 1, got {k}")
    guess = _MP.mpf("1.875104068711961") if k == 1 else (2 * k - 1) * _MP.pi / 2
    root = _MP.findroot(lambda b: _MP.cos(b) + 1 / _MP.cosh(b), guess)
    if abs(root - (2 * k - 1) * _MP.pi / 2) > 0.5:  # pragma: no cover - safety net
        raise RuntimeError(f"clamped-free root {k} did not converge (got {root})")
    return root


def clamped_free_roots(n: int) -> tuple[float, ...]:
    """The first ``n`` roots ``beta_k`` of ``cos(beta) cosh(beta) = -1``.

    Examples
    --------
    >>> [round(b, 8) for b in clamped_free_roots(3)]
    [1.87510407, 4.69409113, 7.85475744]
    """
    return tuple(float(_beta_mp(k)) for k in range(1, n + 1))


@functools.lru_cache(maxsize=None)
def _eigen_data(k: int) -> dict[str, Any]:
    """Coefficients of ``X_k = cosh - cos - sigma (sinh - sin)`` in a cancellation-free form.

    ``1 - sigma = (sin b - cos b - e^-b) / (sinh b + sin b)`` is evaluated directly, so
    ``X = A e^{b xi} + B e^{-b xi} - cos(b xi) + sigma sin(b xi)`` with
    ``A = (1-sigma)/2``, ``B = (1+sigma)/2`` loses nothing at any order.
    """
    b = _beta_mp(k)
    one_minus_sigma = (_MP.sin(b) - _MP.cos(b) - _MP.exp(-b)) / (_MP.sinh(b) + _MP.sin(b))
    sigma = 1 - one_minus_sigma
    A = one_minus_sigma / 2
    B = (1 + sigma) / 2
    tip = A * _MP.exp(b) + B * _MP.exp(-b) - _MP.cos(b) + sigma * _MP.sin(b)  # A e^b = O(1)
    return {"beta": b, "sigma": sigma, "A": A, "B": B, "tip": tip}


def _sf(x: Any, digits: int = 30) -> sympy.Float:
    return sympy.Float(_MP.nstr(_MP.mpf(x), digits + 3), digits)


def _eigen_function(k: int) -> ShapeFunction:
    e = _eigen_data(k)
    b, sigma, tip = e["beta"], e["sigma"], e["tip"]
    atom = k
    half = _MP.mpf(1) / 2
    d = {
        (0, _skey(atom, 1, 0)): _MP.mpc(e["A"] / tip),
        (0, _skey(atom, -1, 0)): _MP.mpc(e["B"] / tip),
        (0, _skey(atom, 0, 1)): _MP.mpc(-half, -sigma / 2) / tip,
        (0, _skey(atom, 0, -1)): _MP.mpc(-half, sigma / 2) / tip,
    }
    bs = _sf(b)
    # stable in double precision too: no cosh - sigma*sinh difference of two huge numbers
    expr = (_sf(e["A"] / tip) * sympy.exp(bs * XI) + _sf(e["B"] / tip) * sympy.exp(-bs * XI)
            - _sf(1 / tip) * sympy.cos(bs * XI) + _sf(sigma / tip) * sympy.sin(bs * XI))
    label = rf"X_{k}(\xi)" if k < 10 else rf"X_{{{k}}}(\xi)"
    return ShapeFunction(label, expr, beta=float(b), sigma=float(sigma), tip_value=float(tip),
                         _terms=_Terms(d, exact=False))


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
    _terms: _Terms | None = field(default=None, compare=False, repr=False)

    def value(self, xi: float, deriv: int = 0) -> float:
        """Value of the ``deriv``-th derivative at ``xi`` (50-digit evaluation, then float).

        Parameters
        ----------
        xi : abscissa (normally in [0, 1])
        deriv : derivative order, >= 0
        """
        if deriv < 0:
            raise ValueError(f"derivative order must be >= 0, got {deriv}")
        if self._terms is None:  # a hand-made ShapeFunction: fall back to sympy
            return float(sympy.re(sympy.diff(self.expr, XI, deriv).evalf(_DPS, subs={XI: xi})))
        return self._terms.evaluate(xi, deriv)


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
    """

    direction: str
    family: str
    frame: str
    functions: tuple[ShapeFunction, ...]
    tip_joint: bool = False
    points: tuple[float, ...] = ()   # interior points whose static correction functions end the basis

    def __len__(self) -> int:
        return len(self.functions)

    def values(self, xi: float, deriv: int = 0) -> np.ndarray:
        """Values of every function's ``deriv``-th derivative at ``xi``, shape ``(n,)``."""
        return np.array([f.value(xi, deriv) for f in self.functions], dtype=float)

    @property
    def key(self) -> tuple[str, str, str, int, bool]:
        """``(direction, family, frame, n, tip_joint)``: what determines the functions (with
        ``points``: the standard functions before the static corrections, ``n`` counting those)."""
        return (self.direction, self.family, self.frame, len(self.functions) - len(self.points),
                self.tip_joint)


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


@functools.lru_cache(maxsize=None)
def _axial_basis(shapes: str, n: int) -> Basis:
    funcs: list[ShapeFunction] = []
    if shapes == "complete":
        for k in range(n):
            if k == 0:
                funcs.append(ShapeFunction(r"\xi", XI, _terms=_poly_terms({1: Fraction(1)})))
            else:
                lab = r"\sin(\pi\xi)" if k == 1 else rf"\sin({k}\pi\xi)"
                funcs.append(ShapeFunction(lab, sympy.sin(k * sympy.pi * XI), _terms=_sin_terms(2 * k)))
    else:
        for k in range(1, n + 1):
            m = 2 * k - 1
            lab = r"\sin(\pi\xi/2)" if m == 1 else rf"\sin({m}\pi\xi/2)"
            funcs.append(ShapeFunction(lab, sympy.sin(m * sympy.pi * XI / 2), _terms=_sin_terms(m)))
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


@functools.lru_cache(maxsize=None)
def _transverse_basis(frame: str, shapes: str, n: int, tip: bool) -> Basis:
    funcs: list[ShapeFunction] = []
    if frame == "pinned-pinned":
        for k in range(1, n + 1):
            if shapes == "polynomial":
                lab = r"\xi(1-\xi)" if k == 1 else (rf"\xi^{k}(1-\xi)" if k < 10 else rf"\xi^{{{k}}}(1-\xi)")
                funcs.append(ShapeFunction(lab, XI ** k * (1 - XI),
                                           _terms=_poly_terms({k: Fraction(1), k + 1: Fraction(-1)})))
            else:
                lab = r"\sin(\pi\xi)" if k == 1 else rf"\sin({k}\pi\xi)"
                funcs.append(ShapeFunction(lab, sympy.sin(k * sympy.pi * XI), _terms=_sin_terms(2 * k)))
    elif shapes == "polynomial":
        for k in range(1, n + 1):
            lab = rf"\xi^{k + 1}" if k + 1 < 10 else rf"\xi^{{{k + 1}}}"
            funcs.append(ShapeFunction(lab, XI ** (k + 1), _terms=_poly_terms({k + 1: Fraction(1)})))
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
    base = _poly_terms({2: Fraction(3, 2), 3: Fraction(-1, 2)}).as_mp()
    d = dict(base.d)
    coeffs = []
    for f in eig:
        t = f._terms.as_mp()
        c = _integrate_product(base, t) / _integrate_product(t, t)
        c = _MP.mpf(c.real)
        coeffs.append(c)
        for key, val in t.d.items():
            d[key] = d.get(key, _MP.mpc(0)) - c * val
    rest = _Terms(d, exact=False)
    tip = _MP.mpf(sum((c * (_MP.exp(_s_value(sid)) if sid else 1) for (_, sid), c in rest.d.items()),
                      _MP.mpc(0)).real)
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
    static = _poly_terms({2: Fraction(3, 2), 3: Fraction(-1, 2)})
    expr = XI ** 2 * (3 - XI) / 2
    if not eig:
        return ShapeFunction(r"\xi^2(3-\xi)/2", expr, _terms=static)
    coeffs, tip, d = _tip_load_projection(eig)
    scaled = _Terms({k: v / tip for k, v in d.items()}, exact=False)
    expr = (expr - sum((_sf(c) * f.expr for c, f in zip(coeffs, eig)), sympy.Integer(0))) / _sf(tip)
    m = len(eig)
    label = r"[\xi^2(3-\xi)/2]_{\perp X_{1..%d}}" % m
    return ShapeFunction(label, expr, _terms=scaled)


def _rebuild(key: tuple[str, str, str, int, bool]) -> Basis:
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


_IMAG_TOL = 1e-30


def _to_sympy(c: Coef) -> sympy.Expr:
    if isinstance(c, _Exact):
        if not c.is_real():  # pragma: no cover - would be a bug
            raise RuntimeError("exact inner product with an imaginary part")
        return c.to_sympy()
    if abs(c.imag) > _IMAG_TOL * max(1, abs(c.real)):  # pragma: no cover - would be a bug
        raise RuntimeError(f"inner product with an imaginary part {c.imag}")
    return sympy.Float(_MP.nstr(c.real, _DPS), _DPS)


def _to_float(c: Coef) -> float:
    if isinstance(c, _Exact):
        return float(c.to_mp().real)
    return float(c.real)


class _Table:
    """Collects entries as floats and sympy values."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.f = np.zeros(shape)
        self.s: dict[tuple[int, ...], sympy.Expr] = {}
        self.shape = shape

    def set(self, idx_list: Any, c: Coef) -> None:
        fv, sv = _to_float(c), _to_sympy(c)
        for idx in idx_list:
            self.f[idx] = fv
            self.s[idx] = sv

    def matrix(self) -> sympy.ImmutableMatrix:
        r, cdim = self.shape
        return sympy.ImmutableMatrix(r, cdim, lambda i, j: self.s[(i, j)])

    def array(self) -> sympy.ImmutableDenseNDimArray:
        flat = [self.s[idx] for idx in itertools.product(*(range(d) for d in self.shape))]
        return sympy.ImmutableDenseNDimArray(flat, self.shape)

    def frozen(self) -> np.ndarray:
        self.f.flags.writeable = False
        return self.f


def _terms_of(basis: Basis) -> list[_Terms]:
    out = []
    for f in basis.functions:
        if f._terms is None:
            raise ValueError(f"shape function {f.label!r} has no term representation; build bases "
                             "with axial_basis()/transverse_basis()")
        out.append(f._terms)
    return out


def _compute(axial: Basis, transverse: Basis) -> InnerProducts:
    """Every inner product, uncached (one computation at a time; its scratch is freed)."""
    phi, psi = _terms_of(axial), _terms_of(transverse)
    with _COMPUTE_LOCK:
        start = len(_SKEYS)
        try:
            return _compute_locked(phi, psi)
        finally:
            _forget_derived(start)


def _compute_locked(phi: list[_Terms], psi: list[_Terms]) -> InnerProducts:
    na, nt = len(phi), len(psi)
    b = [_poly_terms({0: Fraction(1)}), _poly_terms({1: Fraction(1)})] + phi + psi
    N = len(b)

    gram = _Table((N, N))
    for i in range(N):
        for j in range(i, N):
            gram.set({(i, j), (j, i)}, _integrate_product(b[i], b[j]))

    dphi = [t.deriv(1) for t in phi]
    dpsi = [t.deriv(1) for t in psi]
    ddpsi = [t.deriv(2) for t in psi]

    Ka = _Table((na, na))
    for i in range(na):
        for j in range(i, na):
            Ka.set({(i, j), (j, i)}, _integrate_product(dphi[i], dphi[j]))
    Kt = _Table((nt, nt))
    for i in range(nt):
        for j in range(i, nt):
            Kt.set({(i, j), (j, i)}, _integrate_product(ddpsi[i], ddpsi[j]))

    pairs = [(a, c) for a in range(nt) for c in range(a, nt)]
    P = {ab: _tmul(dpsi[ab[0]], dpsi[ab[1]]) for ab in pairs}
    Pd = _Table((nt, nt))
    for (a, c) in pairs:
        Pd.set({(a, c), (c, a)}, _integrate(P[(a, c)]))
    psid1 = _Table((nt,))
    for a in range(nt):
        psid1.set({(a,)}, _integrate(dpsi[a]))

    C3 = _Table((na, nt, nt))
    for k in range(na):
        for (a, c) in pairs:
            C3.set({(k, a, c), (k, c, a)}, _integrate_product(dphi[k], P[(a, c)]))

    D4 = _Table((nt, nt, nt, nt))
    for idx in itertools.combinations_with_replacement(range(nt), 4):
        a, c, d, e = idx
        D4.set(set(itertools.permutations(idx)), _integrate_product(P[(a, c)], P[(d, e)]))

    exact = {
        "gram": gram.matrix(),
        "Ka": Ka.matrix(),
        "Kt": Kt.matrix(),
        "Pd": Pd.matrix(),
        "psid1": sympy.ImmutableMatrix(nt, 1, lambda i, j: psid1.s[(i,)]),
        "C3": C3.array(),
        "D4": D4.array(),
    }
    return InnerProducts(na=na, nt=nt, gram=gram.frozen(), Ka=Ka.frozen(), Kt=Kt.frozen(),
                         Pd=Pd.frozen(), psid1=psid1.frozen(), C3=C3.frozen(), D4=D4.frozen(),
                         exact=exact)


def cache_dir() -> Path:
    """Directory of the on-disk inner-product cache: ``$SYMGEN_CACHE_DIR/shapes``
    (default ``~/.cache/symgen/shapes``)."""
    from symgen import cache
    return cache.shapes_dir()


def _cache_name(akey: tuple, tkey: tuple) -> str:
    def part(k: tuple) -> str:
        direction, family, frame, n, tip = k
        return f"{direction}-{family}-{frame}-n{n}-tip{int(tip)}"

    return f"v{SHAPES_VERSION}__{part(akey)}__{part(tkey)}"


def _freeze(ip: InnerProducts) -> InnerProducts:
    for name in ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4"):
        getattr(ip, name).flags.writeable = False
    return ip


# On disk an entry is one file made by symgen.cache.pack: a header line with the keyed hash of the
# JSON payload that follows. The payload holds the float arrays as lists (repr round-trips
# exactly) and the exact values as symgen.exprdata trees. Never pickle.
_CACHE_KIND = "shapes"
_ARRAYS = ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4")
_MAX_ENTRY_BYTES = 1 << 28


def _shapes_of(na: int, nt: int) -> dict[str, tuple[int, ...]]:
    nb = 2 + na + nt
    return {"gram": (nb, nb), "Ka": (na, na), "Kt": (nt, nt), "Pd": (nt, nt), "psid1": (nt,),
            "C3": (na, nt, nt), "D4": (nt, nt, nt, nt)}


def _encode_entry(name: str, ip: InnerProducts) -> bytes:
    from symgen import cache, exprdata
    doc = {"key": name, "version": SHAPES_VERSION, "na": ip.na, "nt": ip.nt,
           "floats": {a: [float(x) for x in getattr(ip, a).ravel()] for a in _ARRAYS},
           "exact": {a: exprdata.encode_tensor(ip.exact[a]) for a in _ARRAYS}}
    return cache.pack(_CACHE_KIND, json.dumps(doc, separators=(",", ":"), allow_nan=False).encode())


def _decode_entry(data: bytes, name: str) -> InnerProducts:
    """The inner products of a verified entry; ``cache.InvalidEntry`` for anything else."""
    from symgen import cache, exprdata
    payload = cache.unpack(_CACHE_KIND, data)   # keyed hash checked before any parsing

    def bad(what: str) -> Exception:
        return cache.InvalidEntry(f"is not a valid shape entry ({what})")

    def no_constant(c):
        raise ValueError(f"non-finite number {c}")
    try:
        doc = json.loads(payload.decode("utf-8"), parse_constant=no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise bad(f"JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("key") != name or doc.get("version") != SHAPES_VERSION:
        raise bad(f"written for {doc.get('key') if isinstance(doc, dict) else None!r}")
    na, nt = doc.get("na"), doc.get("nt")
    if not all(isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= 1000 for n in (na, nt)):
        raise bad("mode counts")
    floats, exact = doc.get("floats"), doc.get("exact")
    if not isinstance(floats, dict) or not isinstance(exact, dict) or \
            set(floats) != set(_ARRAYS) or set(exact) != set(_ARRAYS):
        raise bad(f"it must hold exactly {', '.join(_ARRAYS)}")
    arrays, values = {}, {}
    for a, shape in _shapes_of(na, nt).items():
        flat = floats[a]
        if not isinstance(flat, list) or len(flat) != math.prod(shape) or not all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in flat):
            raise bad(f"{a}: not {math.prod(shape)} finite numbers")
        arrays[a] = np.array(flat, dtype=float).reshape(shape)
        try:
            values[a] = exprdata.decode_tensor(exact[a])
        except (ValueError, TypeError, RecursionError) as exc:
            raise bad(f"{a}: {exc}") from None
        want = shape if a != "psid1" else (nt, 1)
        if tuple(values[a].shape) != want:
            raise bad(f"{a}: exact values of shape {tuple(values[a].shape)}, not {want}")
    return _freeze(InnerProducts(na=na, nt=nt, exact=values, **arrays))


def _load(path: Path, name: str) -> InnerProducts | None:
    """The verified entry at ``path``; None when there is none or it does not verify (then said
    in one line on stderr: it is recomputed and overwritten)."""
    from symgen import cache
    try:
        data = cache.read_bytes(path, _MAX_ENTRY_BYTES)
        return _decode_entry(data, name)
    except FileNotFoundError:
        return None
    except cache.InvalidEntry as exc:
        cache.report_invalid(path, exc.reason)
    except OSError as exc:
        cache.report_invalid(path, f"cannot be read ({exc})")
    return None


def _store(path: Path, name: str, ip: InnerProducts) -> None:
    from symgen import cache
    try:
        data = _encode_entry(name, ip)
    except (ValueError, cache.KeyUnavailable) as exc:  # no key of this user: not cached, said once per entry
        cache.report_unwritable(path, exc)
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        cache.sweep_stale(path.parent)
        fd, tmp = tempfile.mkstemp(prefix=f"{cache.TEMP_PREFIX}{path.name}-", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            os.replace(tmp, path)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
    except OSError as exc:
        cache.report_unwritable(path, exc)


@functools.lru_cache(maxsize=128)
def _cached(akey: tuple, tkey: tuple) -> InnerProducts:
    name = _cache_name(akey, tkey)
    path = cache_dir() / (name + ".json")
    ip = _load(path, name)
    if ip is None:
        ip = _compute(_rebuild(akey), _rebuild(tkey))
        _store(path, name, ip)
    return ip


def clear_memory_cache() -> None:
    """Forget the in-memory inner products (the disk cache is kept)."""
    _cached.cache_clear()
    from symgen.model import static_shapes
    static_shapes._cached_corrected.cache_clear()


def inner_products(axial: Basis, transverse: Basis) -> InnerProducts:
    """Closed-form inner products of one bar's axial and transverse bases (cached).

    Results are cached in memory per ``(family, frame, n, tip_joint)`` of both bases, and
    on disk as JSON in :func:`cache_dir` (written atomically with the keyed hash of its content,
    checked before it is parsed; an entry that does not verify is said on stderr, recomputed
    and rewritten; pickles of older versions are never read).

    Parameters
    ----------
    axial : from :func:`axial_basis`
    transverse : from :func:`transverse_basis`
    """
    if axial.direction != "axial" or transverse.direction != "transverse":
        raise ValueError("inner_products(axial, transverse): got bases with directions "
                         f"{axial.direction!r}, {transverse.direction!r}")
    akey, tkey = axial.key, transverse.key
    if axial.points or transverse.points:   # static correction functions: piecewise inner products
        from symgen.model.static_shapes import corrected_inner_products
        return corrected_inner_products(axial, transverse)
    try:
        same = all(r is b or r == b for r, b in ((_rebuild(akey), axial), (_rebuild(tkey), transverse)))
    except ValueError:
        same = False
    if not same:  # hand-made basis: nothing to key a cache on
        return _compute(axial, transverse)
    return _cached(akey, tkey)
