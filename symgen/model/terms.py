"""The exact term algebra of the shape functions: finite sums ``c * xi**p * exp(s*xi)`` and
their integrals over ``[0, 1]`` in closed form (paper eqs. (16)-(17)).

Every shape function of :mod:`symgen.model.shapes` is held as such a sum: sin, cos, sinh and
cosh are rewritten as exponentials and polynomials have ``s = 0``.  Products and derivatives
stay in this class, and

    int_0^1 xi^p e^(s xi) dxi = 1/(p+1)                       (s = 0)
    I_0 = (e^s - 1)/s,   I_p = e^s/s - (p/s) I_(p-1)          (s != 0)

(a power series when ``0 < |s| < 2``: this does happen, e.g. ``s = i(3 pi/2 - beta_2)
~ 0.018 i`` in ``C3`` of stress-free axial and clamped-free transverse functions).  The
exponent ``s`` is held as an exact linear combination, with Gaussian-integer
coefficients, of "atoms" (``pi/2`` and the clamped-free roots ``beta_k``), so equal
exponents merge exactly and cancellations such as ``i beta - i beta`` give an exact
zero.  Coefficients are exact (:class:`Exact`: Laurent polynomials in pi over Q(i)) for the
sine and polynomial families and 50-digit :mod:`mpmath` complex numbers (of the private
context :data:`MP`) for the eigenfunction family, whose hyperbolic parts would cancel
catastrophically in double precision.  Inner products of real functions fold conjugate
exponent pairs (half the work).  :class:`Table` collects the integrals of one inner-product
table as floats and SymPy values.

Examples
--------
>>> from fractions import Fraction
>>> from symgen.model.terms import integrate_product, poly_terms, sin_terms
>>> integrate_product(sin_terms(2), sin_terms(2)).to_sympy()        # (sin(pi xi), sin(pi xi))
1/2
>>> integrate_product(poly_terms({1: Fraction(1)}), sin_terms(2)).to_sympy()   # (xi, sin(pi xi))
1/pi
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import threading
from fractions import Fraction
from typing import Any
from collections.abc import Iterator

import numpy as np
import sympy
from mpmath.ctx_mp import MPContext

__all__ = [
    "DPS",
    "MP",
    "Exact",
    "Coef",
    "Terms",
    "new_terms",
    "multiply",
    "integrate",
    "integrate_product",
    "combine",
    "poly_terms",
    "sin_terms",
    "s_key",
    "s_add",
    "s_value",
    "beta_mp",
    "scratch_exponents",
    "Table",
]

DPS = 50  # working digits of every non-exact computation
MP = MPContext()  # private context: nobody else's mp.dps setting can reach us
MP.dps = DPS


# --------------------------------------------------------------------------------------
# Exact coefficients: Laurent polynomials in pi with Gaussian-rational coefficients
# --------------------------------------------------------------------------------------
class Exact:
    """An exact number ``sum_m (a_m + i b_m) pi**m`` (``a_m, b_m`` rational)."""

    __slots__ = ("d",)

    def __init__(self, d: dict[int, tuple[Fraction, Fraction]]) -> None:
        self.d = d  # never holds a zero entry

    @staticmethod
    def of(re: Any = 0, im: Any = 0, m: int = 0) -> Exact:
        re, im = Fraction(re), Fraction(im)
        return Exact({m: (re, im)} if (re or im) else {})

    def __add__(self, other: Exact) -> Exact:
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
        return Exact(d)

    def __mul__(self, other: Exact) -> Exact:
        d: dict[int, tuple[Fraction, Fraction]] = {}
        for m1, (a1, b1) in self.d.items():
            for m2, (a2, b2) in other.d.items():
                a, b = a1 * a2 - b1 * b2, a1 * b2 + b1 * a2
                m = m1 + m2
                if m in d:
                    a, b = d[m][0] + a, d[m][1] + b
                d[m] = (a, b)
        return Exact({m: v for m, v in d.items() if v[0] or v[1]})

    def scale(self, r: Fraction) -> Exact:
        if not r:
            return Exact({})
        return Exact({m: (a * r, b * r) for m, (a, b) in self.d.items()})

    def is_zero(self) -> bool:
        return not self.d

    def to_mp(self) -> Any:
        tot = MP.mpc(0)
        for m, (a, b) in self.d.items():
            tot += MP.mpc(MP.mpf(a.numerator) / a.denominator, MP.mpf(b.numerator) / b.denominator) * MP.pi**m
        return tot

    def to_sympy(self) -> sympy.Expr:
        terms = []
        for m, (a, b) in sorted(self.d.items()):
            terms.append(
                (sympy.Rational(a.numerator, a.denominator) + sympy.I * sympy.Rational(b.numerator, b.denominator))
                * sympy.pi**m
            )
        return sympy.Add(*terms)

    def is_real(self) -> bool:
        return all(b == 0 for _, b in self.d.values())


Coef = Exact | Any  # Exact or an mpc of MP


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
_SKEYS: list[tuple | None] = [()]  # None: a forgotten key (ids are never reused)
_SKEY_ID: dict[tuple, int] = {(): 0}
_SPARENTS: dict[int, tuple[int, int]] = {}
_SADD: dict[tuple[int, int], int] = {}
_SVAL: dict[int, Any] = {}
_SEXP: dict[int, Any] = {}
_KAPPA: dict[int, Fraction | None] = {0: Fraction(0)}
_SCONJ: dict[int, int] = {0: 0}


def _skey(i: int) -> tuple:
    """The key of exponent id ``i`` (KeyError if it was forgotten)."""
    key = _SKEYS[i]
    if key is None:
        raise KeyError(f"exponent id {i} was forgotten with its computation's scratch exponents")
    return key


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


@contextlib.contextmanager
def scratch_exponents() -> Iterator[None]:
    """One inner-product computation at a time; the exponent keys it makes (and every cache
    that refers to them) are forgotten when it ends."""
    with _COMPUTE_LOCK:
        start = len(_SKEYS)
        try:
            yield
        finally:
            _forget_derived(start)


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


def s_add(i: int, j: int) -> int:
    """Id of the sum of the exponents with ids ``i`` and ``j``."""
    if not i:
        return j
    if not j:
        return i
    r = _SADD.get((i, j))
    if r is None:
        d = {atom: (a, b) for atom, a, b in _skey(i)}
        for atom, a, b in _skey(j):
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
    try:
        return _KAPPA[i]
    except KeyError:
        pass
    key = _skey(i)
    k = None
    if len(key) == 1 and key[0][0] == 0 and key[0][1] == 0:
        k = Fraction(key[0][2], 2)
    _KAPPA[i] = k
    return k


def _atom_value(atom: int) -> Any:
    return MP.pi / 2 if atom == 0 else beta_mp(atom)


def s_value(i: int) -> Any:
    """The exponent with id ``i`` as a 50-digit mpc."""
    v = _SVAL.get(i)
    if v is None:
        par = _SPARENTS.get(i)
        if par is not None:
            v = s_value(par[0]) + s_value(par[1])
        else:
            v = MP.mpc(0)
            for atom, a, b in _skey(i):
                v += MP.mpc(a, b) * _atom_value(atom)
        _SVAL[i] = v
    return v


def _s_exp(i: int) -> Any:
    """``exp`` of the exponent with id ``i`` (50 digits)."""
    v = _SEXP.get(i)
    if v is None:
        par = _SPARENTS.get(i)
        v = _s_exp(par[0]) * _s_exp(par[1]) if par is not None else MP.exp(s_value(i))
        _SEXP[i] = v
    return v


def _sconj(i: int) -> int:
    """Id of the complex conjugate of exponent ``i`` (atoms are real)."""
    r = _SCONJ.get(i)
    if r is None:
        r = _sid(tuple((atom, a, -b) for atom, a, b in _skey(i)), persistent=i in _PERSISTENT)
        _SCONJ[i] = r
        _SCONJ[r] = i
    return r


def s_key(atom: int, re: int = 0, im: int = 0) -> int:
    return _sid(((atom, re, im),), persistent=True) if (re or im) else 0


# --------------------------------------------------------------------------------------
# Term sums
# --------------------------------------------------------------------------------------
class Terms:
    """``sum c * xi**p * exp(s*xi)`` as a dict ``{(p, s_id): c}``.

    ``exact`` is True when every coefficient is an :class:`Exact` and every exponent
    is ``i*pi*kappa``; otherwise every coefficient is an mpc.
    """

    __slots__ = ("d", "exact", "_derivs", "_numeric")

    def __init__(self, d: dict[tuple[int, int], Coef], exact: bool) -> None:
        self.d = d
        self.exact = exact
        self._derivs: list[Terms] = [self]
        self._numeric: dict[int, list] = {}

    def __getstate__(self) -> tuple:
        # exponent ids are process-local: pickle the keys themselves; mpc as raw mpf tuples
        if self.exact:
            items = [(p, _skey(s), c) for (p, s), c in self.d.items()]
        else:
            mp: dict[tuple[int, int], Any] = self.d  # the coefficients of inexact terms are mpc
            items = [(p, _skey(s), (c.real._mpf_, c.imag._mpf_)) for (p, s), c in mp.items()]
        return (items, self.exact)

    def __setstate__(self, state: tuple) -> None:
        items, exact = state
        if exact:
            self.d = {(p, _sid(k, persistent=True)): c for p, k, c in items}
        else:
            self.d = {(p, _sid(k, persistent=True)): MP.make_mpc(c) for p, k, c in items}
        self.exact = exact
        self._derivs = [self]
        self._numeric = {}

    def as_mp(self) -> Terms:
        if not self.exact:
            return self
        return Terms({k: c.to_mp() for k, c in self.d.items()}, exact=False)

    def deriv(self, order: int) -> Terms:
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
                out.append((p, s, c.scale(Fraction(2)) if isinstance(c, Exact) else 2 * c))
        return out

    def evaluate(self, xi: float, order: int = 0) -> float:
        """Real part of the ``order``-th derivative at ``xi``, at 50 digits, as a float."""
        num = self._numeric.get(order)
        if num is None:
            t = self.deriv(order)
            num = [(p, s_value(s) if s else None, c.to_mp() if t.exact else c) for (p, s), c in t.d.items()]
            self._numeric[order] = num
        x = MP.mpf(float(xi))
        tot = MP.mpc(0)
        for p, s, c in num:
            v = c * x**p if p else c
            if s is not None:
                v = v * MP.exp(s * x)
            tot += v
        return float(tot.real)


def new_terms(d: dict[tuple[int, int], Coef], exact: bool) -> Terms:
    if exact:
        d = {k: c for k, c in d.items() if not c.is_zero()}
    else:
        d = {k: c for k, c in d.items() if c != 0}
    return Terms(d, exact)


def _acc(out: dict, key: tuple[int, int], c: Coef) -> None:
    if key in out:
        out[key] = out[key] + c
    else:
        out[key] = c


def multiply(a: Terms, b: Terms) -> Terms:
    """Product of two term sums, equal ``(p, s)`` merged."""
    if a.exact != b.exact:
        a, b = a.as_mp(), b.as_mp()
    out: dict = {}
    for (p1, s1), c1 in a.d.items():
        for (p2, s2), c2 in b.d.items():
            _acc(out, (p1 + p2, s_add(s1, s2)), c1 * c2)
    return new_terms(out, a.exact)


def _tderiv(a: Terms) -> Terms:
    out: dict = {}
    for (p, s), c in a.d.items():
        if a.exact:
            if p:
                _acc(out, (p - 1, s), c.scale(Fraction(p)))
            if s:
                _acc(out, (p, s), c * Exact.of(0, _kappa(s), 1))
        else:
            mc: Any = c  # the coefficients of inexact terms are mpc
            if p:
                _acc(out, (p - 1, s), mc * p)
            if s:
                _acc(out, (p, s), c * s_value(s))
    return new_terms(out, a.exact)


_J_EXACT: dict[tuple[int, int], Exact] = {}
_J_MP: dict[tuple[int, int], Any] = {}


def _j_exact(p: int, s: int) -> Exact:
    """Exact ``int_0^1 xi^p exp(i pi kappa xi)`` (``2 kappa`` must be an integer)."""
    r = _J_EXACT.get((p, s))
    if r is not None:
        return r
    kappa = _kappa(s)
    if kappa is None:  # pragma: no cover - internal
        raise ValueError("exponent is not i*pi*rational")
    if kappa == 0:
        r = Exact.of(Fraction(1, p + 1))
    else:
        two_k = 2 * kappa
        if two_k.denominator != 1:
            raise ValueError(
                f"exp(i*pi*{kappa}) is not a Gaussian rational; "
                "exact integration supports half-integer multiples of pi only"
            )
        unit = [(1, 0), (0, 1), (-1, 0), (0, -1)][int(two_k) % 4]  # exp(i pi kappa) = i**(2 kappa)
        e_s = Exact.of(*unit)
        inv_s = Exact.of(0, -1 / kappa, -1)  # 1/(i pi kappa)
        r = (e_s + Exact.of(-1)) * inv_s
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
        r = MP.mpc(1) / (p + 1)
    else:
        sv = s_value(s)
        if abs(sv.real) + abs(sv.imag) < 2:
            # sum_j s^j / (j! (p + j + 1)), |s| < 2: converges to 50 digits in < 70 terms
            r, term, j = MP.mpc(0), MP.mpc(1), 0
            while True:
                add = term / (p + j + 1)
                r += add
                if j > 4 and abs(add) < MP.mpf(10) ** (-DPS - 5) * max(abs(r), 1):
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


def integrate(a: Terms) -> Coef:
    """``int_0^1 a dxi``."""
    if a.exact:
        tot = Exact({})
        for (p, s), c in a.d.items():
            tot = tot + c * _j_exact(p, s)
        return tot
    tot = MP.mpc(0)
    for (p, s), c in a.d.items():
        tot += c * _j_mp(p, s)
    return tot


def integrate_product(a: Terms, b: Terms) -> Coef:
    """``int_0^1 a b dxi`` without forming the product term sum."""
    if a.exact != b.exact:
        a, b = a.as_mp(), b.as_mp()
    A, B = a.items(), b.items()
    if a.exact:
        tot = Exact({})
        for p1, s1, c1 in A:
            acc = Exact({})
            for p2, s2, c2 in B:
                acc = acc + c2 * _j_exact(p1 + p2, s_add(s1, s2))
            tot = tot + c1 * acc
        return tot
    # a and b are real functions, so the integral is real: fold conjugate pairs of a
    A = a.half_items()
    tot = MP.mpc(0)
    jm, sadd = _J_MP, s_add
    for p1, s1, c1 in A:
        acc = MP.mpc(0)
        for p2, s2, c2 in B:
            key = (p1 + p2, sadd(s1, s2))
            j = jm.get(key)
            if j is None:
                j = _j_mp(*key)
            acc += c2 * j
        tot += c1 * acc
    return MP.mpc(tot.real)


def combine(coefs: list[Coef], weight: Fraction) -> Coef:
    """``weight * sum(coefs)`` of integrals (all :class:`Exact`, or any mpc among them)."""
    if all(isinstance(c, Exact) for c in coefs):
        tot = Exact({})
        for c in coefs:
            tot = tot + c
        return tot.scale(weight)
    tot = MP.mpc(0)
    for c in coefs:
        tot += c.to_mp() if isinstance(c, Exact) else c
    return tot * MP.mpf(weight.numerator) / weight.denominator


def poly_terms(coeffs: dict[int, Fraction]) -> Terms:
    """``sum coeffs[p] xi**p`` as an exact term sum."""
    return new_terms({(p, 0): Exact.of(c) for p, c in coeffs.items()}, exact=True)


def sin_terms(m: int) -> Terms:
    """``sin(m pi xi / 2) = (e^{i m (pi/2) xi} - e^{-i m (pi/2) xi}) / (2i)``."""
    half = Fraction(1, 2)
    return new_terms({(0, s_key(0, 0, m)): Exact.of(0, -half), (0, s_key(0, 0, -m)): Exact.of(0, half)}, exact=True)


# --------------------------------------------------------------------------------------
# The clamped-free roots (the atoms k >= 1 of the exponents)
# --------------------------------------------------------------------------------------
@functools.cache
def beta_mp(k: int) -> Any:
    """k-th root of ``cos(b) cosh(b) = -1`` at 50 digits (``mpmath.findroot``): the value of
    exponent atom ``k`` (the clamped-free eigenfunctions are in :mod:`symgen.model.shapes`)."""
    if k < 1:
        raise ValueError(f"root index must be >= 1, got {k}")
    guess = MP.mpf("1.875104068711961") if k == 1 else (2 * k - 1) * MP.pi / 2
    root = MP.findroot(lambda b: MP.cos(b) + 1 / MP.cosh(b), guess)
    if abs(root - (2 * k - 1) * MP.pi / 2) > 0.5:  # pragma: no cover - safety net
        raise RuntimeError(f"clamped-free root {k} did not converge (got {root})")
    return root


# --------------------------------------------------------------------------------------
# Tables of integrals
# --------------------------------------------------------------------------------------
_IMAG_TOL = 1e-30


def _to_sympy(c: Coef) -> sympy.Expr:
    if isinstance(c, Exact):
        if not c.is_real():  # pragma: no cover - would be a bug
            raise RuntimeError("exact inner product with an imaginary part")
        return c.to_sympy()
    if abs(c.imag) > _IMAG_TOL * max(1, abs(c.real)):  # pragma: no cover - would be a bug
        raise RuntimeError(f"inner product with an imaginary part {c.imag}")
    return sympy.Float(MP.nstr(c.real, DPS), DPS)


def _to_float(c: Coef) -> float:
    if isinstance(c, Exact):
        return float(c.to_mp().real)
    return float(c.real)


class Table:
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
