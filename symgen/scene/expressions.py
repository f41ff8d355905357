"""Expressions of tau in a scene (loads, driver torque): one small grammar, one parser, every stage.

Scene files are data from other people, so an expression is never handed to ``eval``,
``sympify`` or ``parse_expr``: a tokenizer and a recursive-descent parser read it and build the
SymPy objects directly. The grammar (whitespace is free)::

    expr    := term (("+" | "-") term)*
    term    := unary (("*" | "/") unary)*
    unary   := ("+" | "-") unary | power
    power   := atom (("^" | "**") unary)?          right-associative: 2^3^2 = 2^9
    atom    := NUMBER | "tau" | "pi" | PARAMETER | FUNCTION "(" expr ("," expr)* ")" | "(" expr ")"
    NUMBER  := 12 | 1.5 | .5 | 2e-3            (an integer literal is exact, a decimal a Float)

as in Python, ``-tau^2`` is ``-(tau^2)`` and ``2^-1`` is ``1/2``. ``τ`` and ``π`` may be written
for ``tau`` and ``pi``. FUNCTION is one of :data:`ALLOWED_FUNCTIONS` with a fixed number of
arguments (``min``/``max`` take two or more); PARAMETER is a name the caller allows (a mapping
name -> SymPy symbol). Anything else (strings, ``and``/``or``/``if``, attribute access,
subscripts, unknown names, names starting with ``_``) is rejected with a short reason.

Bounds: at most :data:`MAX_LENGTH` characters, :data:`MAX_TOKENS` tokens and :data:`MAX_DEPTH`
levels of nesting; every constant must be a finite real double: literals (``1e400``), powers
(``9^9^9^9`` is refused from the magnitude of its logarithm before anything is computed;
constant exponents are bounded by :data:`MAX_EXPONENT`), function values (``sqrt(-1)``,
``log(0)``, ``exp(1000)``) and quotients (``1/0``). ``tau`` is the real symbol of the derivation
(:func:`tau_symbol`). A function or power of something that holds a function value
(``exp(log(tau))``) is built unevaluated: SymPy's automatic rewriting of such nests costs time
growing steeply with the nesting; everything else is exactly what SymPy's own parser built.

Examples
--------
>>> parse_tau_expression("0.1*sin(2*tau)")
0.1*sin(2*tau)
>>> parse_tau_expression("-tau^2 + 2**-1")
1/2 - tau**2
>>> parse_tau_expression("0 and sin(tau)")
Traceback (most recent call last):
...
ValueError: 'and' is a Python keyword, not part of a formula (at character 3)
"""

from __future__ import annotations

import keyword
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

#: Functions an expression may call (``abs`` is the same function as ``Abs``).
ALLOWED_FUNCTIONS = (
    "sin",
    "cos",
    "tan",
    "exp",
    "log",
    "sqrt",
    "Abs",
    "abs",
    "Heaviside",
    "sign",
    "min",
    "max",
    "atan2",
    "sinh",
    "cosh",
    "tanh",
)
ALLOWED_NAMES = ("tau", "pi") + ALLOWED_FUNCTIONS
EXPRESSION_HINT = (
    "write a formula of tau with numbers, tau, pi, + - * /, ^ (or **) for the power, "
    "parentheses and the functions " + " ".join(ALLOWED_FUNCTIONS)
)

MAX_LENGTH = 2000  # characters
MAX_TOKENS = 600
MAX_DEPTH = 20  # nested parentheses, calls, signs and exponents (SymPy slows steeply with it)
MAX_EXPONENT = 1000  # |constant exponent| of a power
MAX_EXACT_BITS = 4096  # numerator/denominator size of an exact constant (a power of 3/7, say)
_LOG_DBL_MAX = math.log(1.7976931348623157e308)

_ALIASES = {"τ": "tau", "π": "pi"}
_TOKEN = re.compile(
    r"""
    (?P<space>[ \t\r\n]+)
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*|τ|π)
  | (?P<op>\*\*|[-+*/^(),])
""",
    re.VERBOSE,
)
_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_WHY_NOT = {
    "'": "strings are not allowed",
    '"': "strings are not allowed",
    ".": "attribute access is not allowed",
    "[": "subscripts and lists are not allowed",
    "]": "subscripts and lists are not allowed",
    "{": "braces are not allowed",
    "}": "braces are not allowed",
    "=": "comparisons and assignments are not allowed",
    "<": "comparisons are not allowed",
    ">": "comparisons are not allowed",
    "!": "comparisons are not allowed",
    ";": "only one expression is allowed",
    ":": "slices and lambdas are not allowed",
    "@": "'@' is not an operator here",
    "%": "'%' is not an operator here",
    "&": "logical operators are not allowed",
    "|": "logical operators are not allowed",
    "~": "logical operators are not allowed",
    "#": "comments are not allowed",
    "\\": "backslashes are not allowed",
}


@dataclass(frozen=True)
class _Token:
    kind: str  # "number" | "name" | "op" | "end"
    text: str
    at: int  # 1-based character position, for messages


@dataclass(frozen=True)
class _Node:
    expr: Any  # the SymPy object
    value: float | None  # its value as a double when it is a constant, else None
    calls: bool = False  # it holds a function value (sin(2), sqrt(tau), ...)


def tau_symbol() -> Any:
    """The SymPy symbol ``tau`` (real) used in every scene expression and in the derivation."""
    import sympy

    return sympy.Symbol("tau", real=True)


def derivative(expr: Any, x: Any, n: int = 1) -> Any:
    """The ``n``-th derivative of a piecewise-smooth expression (``Abs``, ``Heaviside``, ``sign``,
    ``min``, ``max``), exact wherever it exists: SymPy's ``DiracDelta`` terms, which stand for
    the kinks where no derivative exists, are dropped (their value is 0 everywhere else). The
    derivative across a kink is then the one-sided value of the branch being entered, as in
    every emitted backend."""
    import sympy as sp

    for _ in range(n):
        expr = sp.diff(expr, x)
        if expr.has(sp.DiracDelta):
            expr = expr.replace(sp.DiracDelta, lambda *args: sp.S.Zero)
    return expr


#: An expression with more operations than this is sampled only (no symbolic search for poles,
#: whose cost grows steeply with the size of the expression).
MAX_POLE_SEARCH_OPS = 120


def first_pole(expr: Any, tau: Any, t_end: float) -> float | None:
    """The first pole of ``expr`` in [0, t_end] that SymPy's ``singularities`` finds, else None.

    The poles are asked for on the whole real line and the first one at or after 0 is taken
    from the answer: a finite set, or a union of evenly spaced families ``a n + b`` (``tan``,
    ``1/sin``). Asked for on [0, t_end], SymPy lists every pole of such a family there, which
    for ``tan(1e6*tau)`` is 190 000 of them (it never ends). An answer of any other form (a
    condition set, a family that is not evenly spaced) finds nothing: the samples decide."""
    import sympy as sp

    if sp.count_ops(expr) > MAX_POLE_SEARCH_OPS or expr.has(sp.Min, sp.Max):
        return None  # Min/Max: SymPy may not return (1/min(exp(tau^2), sinh(tau - 0.3)))
    try:
        poles = sp.singularities(expr, tau, sp.S.Reals)
    except Exception:  # SymPy cannot tell: the samples decide
        return None
    first = _first_at_or_after_zero(poles)
    return first if first is not None and first <= t_end else None


def _first_at_or_after_zero(poles: Any) -> float | None:
    import sympy as sp

    found: list[float] = []
    if isinstance(poles, sp.Union):
        found = [x for part in poles.args if (x := _first_at_or_after_zero(part)) is not None]
    elif isinstance(poles, sp.FiniteSet):
        for x in poles:
            try:
                v = complex(x)
            except (TypeError, ValueError):
                continue
            if v.imag == 0.0 and v.real >= 0.0:
                found.append(v.real)
    elif isinstance(poles, sp.ImageSet) and poles.base_sets == (sp.S.Integers,) and len(poles.lamda.variables) == 1:
        (n,) = poles.lamda.variables
        family = sp.Poly(poles.lamda.expr, n) if poles.lamda.expr.is_polynomial(n) else None
        if family is not None and family.degree() == 1:
            a, b = (complex(c) for c in family.all_coeffs())
            if a.imag == 0.0 and b.imag == 0.0 and a.real != 0.0 and math.isfinite(a.real) and math.isfinite(b.real):
                step, start = abs(a.real), b.real
                found.append(start + step * math.ceil(-start / step))
    return min(found) if found else None


_DOUBLE_FUNCTIONS: dict[str, Callable[..., float]] = {
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "exp": math.exp,
    "log": math.log,
    "sinh": math.sinh,
    "cosh": math.cosh,
    "tanh": math.tanh,
    "atan2": math.atan2,
    "Abs": abs,
    "sign": lambda x: math.copysign(1.0, x) if x != 0.0 else (math.nan if math.isnan(x) else x),
    "Heaviside": lambda x, h0=0.5: 1.0 if x > 0.0 else 0.0 if x < 0.0 else (float(h0) if x == 0.0 else math.nan),
    "Min": lambda *xs: math.nan if any(map(math.isnan, xs)) else min(xs),
    "Max": lambda *xs: math.nan if any(map(math.isnan, xs)) else max(xs),
}


def value_at(expr: Any, tau: Any, t: float) -> float:
    """``expr`` at tau = ``t`` in double precision, as the integrator will meet it (an overflow
    is infinite, a value that is not real is NaN). SymPy's ``evalf`` would give the exact value
    of ``sin(sinh(1e6*tau))`` at 0.6 instead, working at some 900 000 bits (minutes); a node
    outside the grammar's functions (a derivative's ``DiracDelta``) is left to ``evalf``."""
    import sympy as sp

    def ev(e: Any) -> float:
        if e is tau:
            return t
        if e.is_Number or e.is_NumberSymbol:
            return float(e)
        args = [ev(a) for a in e.args]
        try:
            if e.is_Add:
                return math.fsum(args) if all(math.isfinite(a) for a in args) else sum(args)
            if e.is_Mul:
                return math.prod(args)
            if e.is_Pow:
                base, power = args
                if base < 0.0 and power != int(power):
                    return math.nan
                return math.pow(base, power)
            name = type(e).__name__
            if name in _DOUBLE_FUNCTIONS:
                return float(_DOUBLE_FUNCTIONS[name](*args))
        except OverflowError:
            return math.inf
        except (ValueError, ZeroDivisionError):
            return math.nan
        value = complex(e.xreplace({tau: sp.Float(t)}).evalf())
        return value.real if value.imag == 0.0 else math.nan

    try:
        return ev(expr)
    except (TypeError, ValueError, ZeroDivisionError, OverflowError):
        return math.nan


def first_non_finite(expr: Any, t_end: float, samples: int = 256) -> float | None:
    """The first tau in [0, t_end] where ``expr`` (of :func:`tau_symbol`) is not a finite real
    number, else None: a pole (``1/(tau - 0.1)``, ``tan(tau)``) found by :func:`first_pole`,
    or a value that is infinite, NaN or complex at one of ``samples`` + 1 evenly spaced tau
    (``log(tau - 10)``, ``sqrt(tau - 1)``), evaluated in double precision (:func:`value_at`)."""

    tau = tau_symbol()
    if tau not in expr.free_symbols:
        return None
    first = first_pole(expr, tau, t_end)
    for k in range(samples + 1):
        t = t_end * k / samples
        if first is not None and t >= first:
            break
        if not math.isfinite(value_at(expr, tau, t)):
            return t
    return first


def _tokenize(text: str) -> list[_Token]:
    """The tokens of ``text`` (ending with an "end" token); ValueError at the first bad character."""
    tokens: list[_Token] = []
    pos = 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None:
            ch = text[pos]
            why = _WHY_NOT.get(ch, f"the character {ch!r} is not allowed")
            if ch.isalpha() and not ch.isascii():
                why = f"the character {ch!r} is not allowed (names are ASCII; tau may be written τ)"
            raise ValueError(f"{why} (at character {pos + 1})")
        kind, piece = match.lastgroup, match.group()
        assert kind is not None, "every alternative of _TOKEN is a named group"
        end = match.end()
        if kind == "number" and end < len(text) and (text[end].isalnum() or text[end] in "_."):
            tail = re.split(r"[^A-Za-z0-9_.]", text[end:], maxsplit=1)[0]  # the run of name characters
            raise ValueError(
                f"malformed number {piece + tail!r} (at character {pos + 1}); write a product with '*', e.g. 2*tau"
            )
        if kind == "name":
            piece = _ALIASES.get(piece, piece)
            if piece.startswith("_"):
                raise ValueError(f"names starting with '_' are not allowed ({piece!r} at character {pos + 1})")
            if keyword.iskeyword(piece) or keyword.issoftkeyword(piece):
                raise ValueError(f"{piece!r} is a Python keyword, not part of a formula (at character {pos + 1})")
        if kind != "space":
            tokens.append(_Token(kind, piece, pos + 1))
            if len(tokens) > MAX_TOKENS:
                raise ValueError(f"it is too long (more than {MAX_TOKENS} tokens)")
        pos = end
    tokens.append(_Token("end", "", len(text) + 1))
    return tokens


def _describe(tok: _Token) -> str:
    return "the end of the expression" if tok.kind == "end" else f"{tok.text!r} at character {tok.at}"


# -- functions: (min args, max args or None, SymPy builder name, value of constant arguments) -----
def _log(x: float) -> float:
    if x == 0:
        raise ValueError("log(0) is not finite")
    if x < 0:
        raise ValueError(f"log of the negative number {x:g} is not real")
    return math.log(x)


def _sqrt(x: float) -> float:
    if x < 0:
        raise ValueError(f"sqrt of the negative number {x:g} is not real")
    return math.sqrt(x)


def _atan2(y: float, x: float) -> float:
    if x == 0 and y == 0:
        raise ValueError("atan2(0, 0) is undefined")
    return math.atan2(y, x)


def _heaviside(x: float) -> float:
    return 1.0 if x > 0 else 0.0 if x < 0 else 0.5


def _sign(x: float) -> float:
    return 1.0 if x > 0 else -1.0 if x < 0 else 0.0


_FUNCTIONS: dict[str, tuple[int, int | None, str, Callable[..., float]]] = {
    "sin": (1, 1, "sin", math.sin),
    "cos": (1, 1, "cos", math.cos),
    "tan": (1, 1, "tan", math.tan),
    "exp": (1, 1, "exp", math.exp),
    "log": (1, 1, "log", _log),
    "sqrt": (1, 1, "sqrt", _sqrt),
    "Abs": (1, 1, "Abs", abs),
    "abs": (1, 1, "Abs", abs),
    "Heaviside": (1, 1, "Heaviside", _heaviside),
    "sign": (1, 1, "sign", _sign),
    "min": (2, None, "Min", min),
    "max": (2, None, "Max", max),
    "atan2": (2, 2, "atan2", _atan2),
    "sinh": (1, 1, "sinh", math.sinh),
    "cosh": (1, 1, "cosh", math.cosh),
    "tanh": (1, 1, "tanh", math.tanh),
}
assert set(_FUNCTIONS) == set(ALLOWED_FUNCTIONS)


def _exact_bits(sp: Any, expr: Any) -> int:
    """Bits of the exact rationals in a constant (what an integer power multiplies)."""
    return sum(max(abs(r.p).bit_length(), r.q.bit_length()) for r in expr.atoms(sp.Rational))


def _short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _finite(value: float, what: str) -> float:
    if not math.isfinite(value):
        raise ValueError(f"{what} is too large (beyond the largest double, about 1.8e308)")
    return value


class _Parser:
    """Recursive descent over the tokens, building SymPy objects (see the module grammar)."""

    def __init__(self, tokens: list[_Token], symbols: dict[str, Any]) -> None:
        import sympy

        self.sp = sympy
        self.tokens = tokens
        self.pos = 0
        self.symbols = symbols

    # ---------------------------------------------------------------- token helpers
    @property
    def tok(self) -> _Token:
        return self.tokens[self.pos]

    def take(self) -> _Token:
        tok = self.tokens[self.pos]
        self.pos += 1
        return tok

    def at_op(self, *ops: str) -> bool:
        return self.tok.kind == "op" and self.tok.text in ops

    def expect_close(self, opened: _Token) -> None:
        if self.at_op(")"):
            self.take()
            return
        if self.at_op(","):
            raise ValueError(f"',' outside a function call (at character {self.tok.at})")
        if self.tok.kind == "end":
            raise ValueError(f"unbalanced parentheses: the '(' at character {opened.at} is never closed")
        raise ValueError(
            f"expected ')' (for the '(' at character {opened.at}) but found {_describe(self.tok)}"
            f"; write products with '*'"
        )

    # ---------------------------------------------------------------- grammar
    def parse(self) -> _Node:
        node = self.expr(0)
        if self.tok.kind != "end":
            tok = self.tok
            if tok.kind == "op" and tok.text == ")":
                raise ValueError(f"unbalanced parentheses: ')' at character {tok.at} closes nothing")
            if tok.kind == "op" and tok.text == ",":
                raise ValueError(f"',' outside a function call (at character {tok.at})")
            raise ValueError(f"unexpected {_describe(tok)} after a complete expression; write products with '*'")
        return node

    def expr(self, depth: int) -> _Node:
        node = self.term(depth)
        while self.at_op("+", "-"):
            op = self.take()
            node = self.binary(op, node, self.term(depth))
        return node

    def term(self, depth: int) -> _Node:
        node = self.unary(depth)
        while self.at_op("*", "/"):
            op = self.take()
            node = self.binary(op, node, self.unary(depth))
        return node

    def unary(self, depth: int) -> _Node:
        if depth > MAX_DEPTH:
            raise ValueError(
                f"it is nested too deeply (more than {MAX_DEPTH} levels of parentheses, "
                f"calls, signs or powers; at character {self.tok.at})"
            )
        if self.at_op("+", "-"):
            op = self.take()
            node = self.unary(depth + 1)
            if op.text == "+":
                return node
            return self.checked(-node.expr, None if node.value is None else -node.value, op, node.calls)
        return self.power(depth)

    def power(self, depth: int) -> _Node:
        base = self.atom(depth)
        if self.at_op("^", "**"):
            op = self.take()
            return self.pow(op, base, self.unary(depth + 1))
        return base

    def atom(self, depth: int) -> _Node:
        tok = self.take()
        if tok.kind == "number":
            return self.number(tok)
        if tok.kind == "name":
            return self.name(tok, depth)
        if tok.kind == "op" and tok.text == "(":
            if self.at_op(")"):
                raise ValueError(f"empty parentheses at character {tok.at}")
            node = self.expr(depth + 1)
            self.expect_close(tok)
            return node
        if tok.kind == "end":
            raise ValueError("the expression ends too early (an operand is missing)")
        if tok.text == ",":
            raise ValueError(f"',' outside a function call (at character {tok.at})")
        if tok.text == ")":
            raise ValueError(
                f"unbalanced parentheses: ')' at character {tok.at} closes nothing"
                if not any(t.text == "(" for t in self.tokens[: self.pos])
                else f"an operand is missing before ')' at character {tok.at}"
            )
        raise ValueError(f"an operand is missing before {tok.text!r} at character {tok.at}")

    def number(self, tok: _Token) -> _Node:
        sp = self.sp
        try:
            value = float(tok.text) if any(c in tok.text for c in ".eE") else float(int(tok.text))
        except OverflowError:
            value = math.inf
        if not math.isfinite(value):
            raise ValueError(f"the number {tok.text} is not a finite double (at character {tok.at})")
        if value == 0 and re.search(r"[1-9]", tok.text.split("e")[0].split("E")[0]):
            raise ValueError(
                f"the number {tok.text} is below the smallest double, about 5e-324 (at character {tok.at})"
            )
        # as SymPy's parser did: a decimal or exponent form is a Float (precision from its digits),
        # an integer literal an exact Integer
        return _Node(sp.Float(tok.text) if any(c in tok.text for c in ".eE") else sp.Integer(tok.text), value)

    def name(self, tok: _Token, depth: int) -> _Node:
        sp = self.sp
        name = tok.text
        calling = self.at_op("(")
        if name in _FUNCTIONS:
            if not calling:
                raise ValueError(f"{name} is a function: write {name}(...) (at character {tok.at})")
            return self.call(tok, depth)
        if name == "pi" or name in self.symbols:
            if calling:
                raise ValueError(f"{name} is not a function (at character {tok.at}); write {name}*(...) for a product")
            return _Node(sp.pi, math.pi) if name == "pi" else _Node(self.symbols[name], None)
        known = ", ".join(["tau", "pi", *sorted(n for n in self.symbols if n != "tau")])
        if calling:
            raise ValueError(
                f"unknown function {name!r} (at character {tok.at}); the functions are {', '.join(ALLOWED_FUNCTIONS)}"
            )
        raise ValueError(f"unknown name {name!r} (at character {tok.at}); the names are {known}")

    def call(self, tok: _Token, depth: int) -> _Node:
        opened = self.take()
        args: list[_Node] = []
        if not self.at_op(")"):
            args.append(self.expr(depth + 1))
            while self.at_op(","):
                self.take()
                args.append(self.expr(depth + 1))
        self.expect_close(opened)
        low, high, builder, value_of = _FUNCTIONS[tok.text]
        if len(args) < low or (high is not None and len(args) > high):
            wanted = f"{low} argument{'s' if low > 1 else ''}" if low == high else f"at least {low} arguments"
            raise ValueError(f"{tok.text} takes {wanted}, got {len(args)} (at character {tok.at})")
        value = None
        if all(a.value is not None for a in args):
            what = f"{tok.text}({', '.join(f'{a.value:g}' for a in args)})"
            try:
                value = _finite(float(value_of(*(a.value for a in args))), what)
            except OverflowError:
                raise ValueError(
                    f"{what} is too large (beyond the largest double, about 1.8e308) (at character {tok.at})"
                ) from None
            except ValueError as exc:
                raise ValueError(f"{exc} (at character {tok.at})") from None
        # SymPy's automatic evaluation of a function of something that holds function values
        # costs time growing fast with the nesting (sin(2*sin(2*sin(...2))) at depth 12: seconds,
        # log(3+log(3+...tau)): 20 ms a level): such a function is built unevaluated (it only
        # misses rewrites like exp(log(tau)) -> tau; numbers and tau alone evaluate as always)
        nested = any(a.calls for a in args)
        built = getattr(self.sp, builder)(*(a.expr for a in args), evaluate=not nested)
        return self.checked(built, value, tok, True)

    # ---------------------------------------------------------------- operations
    def binary(self, op: _Token, a: _Node, b: _Node) -> _Node:
        value = None
        if op.text == "/" and b.value == 0:
            raise ValueError(
                f"division by zero (at character {op.at})"
                if b.expr.is_zero
                else f"division by {_short(self.sp.sstr(b.expr))}, which is below the smallest "
                f"double (at character {op.at})"
            )
        if a.value is not None and b.value is not None:
            value = {
                "+": a.value + b.value,
                "-": a.value - b.value,
                "*": a.value * b.value,
                "/": a.value / b.value if b.value else math.inf,
            }[op.text]
            if not math.isfinite(value):
                raise ValueError(
                    f"{a.value:g} {op.text} {b.value:g} is too large (beyond the largest "
                    f"double, about 1.8e308) (at character {op.at})"
                )
        expr = {
            "+": lambda: a.expr + b.expr,
            "-": lambda: a.expr - b.expr,
            "*": lambda: a.expr * b.expr,
            "/": lambda: a.expr / b.expr,
        }[op.text]()
        return self.checked(expr, value, op, a.calls or b.calls)

    def pow(self, op: _Token, base: _Node, ex: _Node) -> _Node:
        at = f"(at character {op.at})"
        value = None
        if ex.value is not None and abs(ex.value) > MAX_EXPONENT:
            raise ValueError(f"the exponent {ex.value:g} is too large (at most {MAX_EXPONENT} in magnitude) {at}")
        if base.value is not None and ex.value is None and base.value < 0:
            raise ValueError(
                f"a negative base ({base.value:g}) needs a constant integer exponent: the power is not real {at}"
            )
        if base.value is not None and ex.value is not None:
            b, e = base.value, ex.value
            if ex.expr.is_Rational and abs(e) * _exact_bits(self.sp, base.expr) > MAX_EXACT_BITS:
                raise ValueError(
                    f"the exact value of {_short(self.sp.sstr(base.expr))}^{e:g} has too many "
                    f"digits; write the base as a decimal {at}"
                )
            if b == 0:
                if e < 0:
                    raise ValueError(f"division by zero: 0^{e:g} {at}")
                value = 1.0 if e == 0 else 0.0
            else:
                if b < 0 and e != int(e):
                    raise ValueError(f"({b:g})^{e:g} is not real {at}")
                if e * math.log(abs(b)) > _LOG_DBL_MAX:
                    raise ValueError(f"({b:g})^{e:g} is too large (beyond the largest double, about 1.8e308) {at}")
                try:
                    value = float(abs(b) ** e) * (-1.0 if b < 0 and int(e) % 2 else 1.0)
                except OverflowError:
                    raise ValueError(f"({b:g})^{e:g} is too large {at}") from None
        nested = base.calls or ex.calls  # see call()
        built = self.sp.Pow(base.expr, ex.expr, evaluate=not nested)
        return self.checked(built, value, op, base.calls or ex.calls)

    def checked(self, expr: Any, value: float | None, tok: _Token, calls: bool = False) -> _Node:
        """The node of a built SymPy object: a constant must be finite and real."""
        sp = self.sp
        if expr.is_Number:
            value, calls = float(expr), False  # e.g. 0*tau, tau - tau, sin(0)
        if value is not None:
            if expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
                raise ValueError(f"the constant at character {tok.at} is not finite (it is {_short(sp.sstr(expr))})")
            if expr.has(sp.I):
                raise ValueError(f"the constant at character {tok.at} is not real")
            _finite(value, f"the constant at character {tok.at}")
            if value == 0 and expr.is_Number and not expr.is_zero:
                raise ValueError(f"the constant at character {tok.at} is below the smallest double (about 5e-324)")
        for part in (expr, expr.as_coeff_Add()[0], expr.as_coeff_Mul()[0]):
            if part.is_Rational and _exact_bits(sp, part) > MAX_EXACT_BITS:
                raise ValueError(
                    f"an exact fraction with more than {MAX_EXACT_BITS} bits arises at "
                    f"character {tok.at}; write decimals"
                )
        return _Node(expr, value, calls)


def _symbols(names: Mapping[str, Any] | None) -> dict[str, Any]:
    """tau plus the caller's named parameters, each a valid name that shadows nothing."""
    symbols: dict[str, Any] = {"tau": tau_symbol()}
    for name, symbol in (names or {}).items():
        if not isinstance(name, str) or not _IDENTIFIER.fullmatch(name) or keyword.iskeyword(name):
            raise ValueError(
                f"parameter name {name!r} is not a plain name (letters, digits, '_', starting with a letter)"
            )
        if name in ("tau", "pi") or name in _FUNCTIONS:
            raise ValueError(f"parameter name {name!r} is reserved in expressions")
        symbols[name] = symbol
    return symbols


def parse_tau_expression(text: str, names: Mapping[str, Any] | None = None) -> Any:
    """Parse a scene expression of ``tau`` into a SymPy expression (never evaluating the text).

    Parameters
    ----------
    text : the expression as written in the scene file (grammar in the module docstring)
    names : optional named parameters the expression may use, name -> ``sympy.Symbol``
        (a name may not be ``tau``, ``pi`` or a function)

    Returns
    -------
    sympy.Expr whose free symbols are among ``tau`` (:func:`tau_symbol`) and ``names``' symbols.

    Raises
    ------
    ValueError
        With a short reason (and the character position) when the text is not such an
        expression, exceeds a bound, or has a constant part that is not a finite real double.
    """
    if not isinstance(text, str):
        raise ValueError(f"an expression must be text, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ValueError(f"it is too long ({len(text)} characters, at most {MAX_LENGTH})")
    if not text.strip():
        raise ValueError("the expression is empty")
    symbols = _symbols(names)
    tokens = _tokenize(text)
    import sympy

    try:
        expr = _Parser(tokens, symbols).parse().expr
    except (ArithmeticError, TypeError, RecursionError) as exc:  # from SymPy on an odd constant
        raise ValueError(f"cannot evaluate it ({type(exc).__name__}: {exc})") from None
    if expr.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
        raise ValueError("it is not finite")
    if expr.has(sympy.I):
        raise ValueError("it is not real")
    return expr


# -- SI scenes: expressions of t in seconds --------------------------------------------------
#: The time of an SI scene's expressions in seconds (tau = omega t, the model's time, is allowed too).
TIME_NAME = "t"
SECONDS_HINT = (
    "in an SI scene an expression is of t, the time in seconds (or of tau = omega t), its value in "
    "SI units, with numbers, t, tau, pi, + - * /, ^ (or **) for the power, parentheses and the "
    "functions " + " ".join(ALLOWED_FUNCTIONS)
)


def time_symbol() -> Any:
    """The SymPy symbol ``t`` (real, seconds) of an SI scene's expressions."""
    import sympy

    return sympy.Symbol(TIME_NAME, real=True)


def parse_seconds_expression(text: str) -> Any:
    """Parse an SI scene's expression of ``t`` (seconds; ``tau`` = omega t may appear too) into a
    SymPy expression of :func:`time_symbol` and :func:`tau_symbol`, with the grammar and bounds
    of :func:`parse_tau_expression`.

    >>> parse_seconds_expression("2*sin(50*t)")
    2*sin(50*t)
    """
    return parse_tau_expression(text, {TIME_NAME: time_symbol()})


def seconds_to_tau_text(text: str, omega: float, scale: float = 1.0) -> str:
    """The model's expression of tau for an SI scene's expression of ``t`` in seconds (and of
    tau = omega t) whose value is in SI: ``t`` becomes ``(tau/omega)`` and the whole is divided
    by ``scale`` (the SI value of one model unit: 1 for an angle, m_ref l0^3 omega^2 for a
    moment, ...), the same double operations as the loader's conversion of a number. The text
    is spliced, token by token, so that the result is an expression of the same grammar (never
    built from SymPy's printing); an expression without ``t`` and a scale of 1 is returned as
    it is. ValueError when ``text`` is not such an expression, or when the converted text
    exceeds the grammar's bounds.

    >>> seconds_to_tau_text("0.5*sin(2*t)", 10.0, 4.0)
    '(0.5*sin(2*(tau/10.0)))/4.0'
    """
    parse_seconds_expression(text)
    converted = splice_seconds(text, omega, scale)
    try:
        parse_tau_expression(converted)
    except ValueError as exc:
        raise ValueError(f"converted to the model's time (t = tau/omega) {exc}") from None
    return converted


def splice_seconds(text: str, omega: float, scale: float = 1.0) -> str:
    """The text of :func:`seconds_to_tau_text` without its checks (no SymPy): ``t`` spliced into
    ``(tau/omega)`` token by token, the whole divided by ``scale``. For text that
    :func:`seconds_to_tau_text` accepted (a cached run's verdict,
    :func:`symgen.scene.verdicts.seconds_error`).

    >>> splice_seconds("0.5*sin(2*t)", 10.0, 4.0)
    '(0.5*sin(2*(tau/10.0)))/4.0'
    """
    pieces, end = [], 0
    for tok in _tokenize(text):
        if tok.kind == "name" and tok.text == TIME_NAME:
            pieces += [text[end : tok.at - 1], f"(tau/{float(omega)!r})"]
            end = tok.at  # the name t is one character
    pieces.append(text[end:])
    converted = "".join(pieces)
    if scale != 1.0:
        converted = f"({converted})/{float(scale)!r}"
    return converted
