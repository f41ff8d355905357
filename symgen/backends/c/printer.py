"""SymPy -> C99 expression printer for the emitted model (libm only, no POSIX constants).

Symbols are printed through a map (``q[3]``, ``p[0]``, ``w12``...) given by the caller, so
that no name from a scene ever reaches the C text. Numbers are printed as ``double`` literals
with 17 significant digits (exact round trip); small integer powers become products.

>>> import sympy as sp
>>> x = sp.Symbol("x")
>>> CPrinter({x: "q[0]"}).doprint(x**2 / 3 + sp.pi)
'(0.3333333333333333)*(q[0]*q[0]) + 3.141592653589793'
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.c import C99CodePrinter

_MAX_MUL_POWER = 4


def c_double(x: float) -> str:
    """A double literal that reads back as exactly ``x``."""
    x = float(x)
    if x != x or x in (float("inf"), float("-inf")):
        raise ValueError(f"cannot emit the non-finite constant {x} as C")
    text = repr(x)
    if "e" not in text and "." not in text:
        text += ".0"
    return text


class CPrinter(C99CodePrinter):
    """C99 printer with an explicit symbol map and exact double literals."""

    def __init__(self, names: dict, settings: dict | None = None) -> None:
        # no math macros: SymPy prints pi/4, sqrt(2), 1/pi ... as M_PI_4, M_SQRT2, M_1_PI (POSIX,
        # not C99: a strict -std=c99 build has none); they are folded to double literals here
        super().__init__({"math_macros": {}, **(settings or {})})
        self._names = names

    # ------------------------------------------------------------------ atoms
    def _print_Symbol(self, expr):
        try:
            return self._names[expr]
        except KeyError:
            raise KeyError(f"symbol {expr} has no C name (not an input or an earlier assignment)") from None

    _print_Dummy = _print_Symbol

    def _print_Float(self, expr):
        return c_double(expr)

    def _print_Integer(self, expr):
        return c_double(int(expr))

    def _print_Rational(self, expr):
        return c_double(float(expr))

    def _print_NumberSymbol(self, expr):
        return c_double(sp.Float(expr, 20))

    _print_Pi = _print_NumberSymbol
    _print_Exp1 = _print_NumberSymbol
    _print_EulerGamma = _print_NumberSymbol
    _print_GoldenRatio = _print_NumberSymbol
    _print_Catalan = _print_NumberSymbol

    def _print_Zero(self, expr):
        return "0.0"

    def _print_One(self, expr):
        return "1.0"

    def _print_NegativeOne(self, expr):
        return "-1.0"

    def _print_Half(self, expr):
        return "0.5"

    def _print_BooleanTrue(self, expr):
        return "1"

    def _print_BooleanFalse(self, expr):
        return "0"

    # ------------------------------------------------------------------ operations
    def _print_Pow(self, expr):
        base, ex = expr.args
        if ex.is_Integer:
            n = int(ex)
            b = self.parenthesize(base, 100)  # always parenthesise a compound base
            if n == 0:
                return "1.0"
            # parenthesised: the caller prints a Pow with the precedence of a power
            if 0 < n <= _MAX_MUL_POWER:
                return "(" + "*".join([b] * n) + ")"
            if -_MAX_MUL_POWER <= n < 0:
                return "(1.0/(" + "*".join([b] * (-n)) + "))"
            return f"pow({self._print(base)}, {c_double(n)})"
        if ex == sp.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if ex == -sp.Rational(1, 2):
            return f"(1.0/sqrt({self._print(base)}))"
        return f"pow({self._print(base)}, {self._print(ex)})"

    def _print_Heaviside(self, expr):
        x = self._print(expr.args[0])
        return f"(({x}) > 0 ? 1.0 : (({x}) < 0 ? 0.0 : 0.5))"

    def _print_sign(self, expr):
        x = self._print(expr.args[0])
        return f"(({x}) > 0 ? 1.0 : (({x}) < 0 ? -1.0 : 0.0))"

    def _print_DiracDelta(self, expr):
        return "0.0"

    def _print_Piecewise(self, expr):
        if expr.args[-1].cond != True:  # noqa: E712
            tail = "(0.0/0.0)"  # no branch applies: NaN, as the CasADi emitter does
        else:
            tail = None
        parts = list(expr.args)
        if tail is None:
            out = self._print(parts.pop().expr)
        else:
            out = tail
        for val, cond in reversed(parts):
            out = f"(({self._print(cond)}) ? ({self._print(val)}) : ({out}))"
        return out

    def _print_Max(self, expr):
        args = [self._print(a) for a in expr.args]
        out = args[0]
        for a in args[1:]:
            out = f"fmax({out}, {a})"
        return out

    def _print_Min(self, expr):
        args = [self._print(a) for a in expr.args]
        out = args[0]
        for a in args[1:]:
            out = f"fmin({out}, {a})"
        return out

    def _print_Function(self, expr):
        raise NotImplementedError(f"the C emitter has no translation for {type(expr).__name__}: {expr}")


SUPPORTED_FUNCTIONS = (
    "sin",
    "cos",
    "tan",
    "exp",
    "log",
    "sqrt",
    "fabs",
    "sinh",
    "cosh",
    "tanh",
    "asin",
    "acos",
    "atan",
    "fmax",
    "fmin",
    "pow",
)
