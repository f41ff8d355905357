"""Expressions of tau in a scene (loads, driver torque): one parser for every stage.

An expression is Python/SymPy syntax in the single symbol ``tau`` using only
``sin cos tan exp log sqrt pi Abs Heaviside Piecewise`` (``**`` is the power).
Later stages should parse the stored strings with :func:`parse_tau_expression` too,
so that they read exactly what the loader accepted.

Examples
--------
>>> parse_tau_expression("0.1*sin(2*tau)")
0.1*sin(2*tau)
"""
from __future__ import annotations

import io
import tokenize
from typing import Any

ALLOWED_FUNCTIONS = ("sin", "cos", "tan", "exp", "log", "sqrt", "Abs", "Heaviside", "Piecewise")
ALLOWED_NAMES = ("tau", "pi") + ALLOWED_FUNCTIONS
EXPRESSION_HINT = ("write a SymPy expression of tau using only "
                   + ", ".join(ALLOWED_NAMES) + "; ** is the power")


def tau_symbol() -> Any:
    """The SymPy symbol ``tau`` used in every scene expression."""
    import sympy

    return sympy.Symbol("tau")


def _check_tokens(text: str) -> None:
    """Reject Python constructs that have no place in a formula (attribute access, dunders)."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    except (tokenize.TokenError, SyntaxError):
        raise ValueError("cannot parse it: unbalanced brackets or an unfinished expression") from None
    for tok in tokens:
        if tok.type == tokenize.OP and tok.string in (".", ";", ":=", "=", "@", "[", "]", "{", "}"):
            raise ValueError(f"{tok.string!r} is not allowed in an expression")
        if tok.type == tokenize.NAME and tok.string.startswith("_"):
            raise ValueError(f"name {tok.string!r} is not allowed")


def parse_tau_expression(text: str) -> Any:
    """Parse a scene expression of ``tau`` into a SymPy expression.

    Parameters
    ----------
    text : the expression as written in the scene file

    Returns
    -------
    sympy.Expr whose only free symbol (if any) is ``tau``.

    Raises
    ------
    ValueError
        With a short reason when the text is not such an expression.
    """
    import sympy
    from sympy.core.function import AppliedUndef
    from sympy.parsing.sympy_parser import parse_expr, standard_transformations

    if not text.strip():
        raise ValueError("the expression is empty")
    _check_tokens(text)
    local = {name: getattr(sympy, name) for name in ALLOWED_FUNCTIONS}
    local.update(pi=sympy.pi, tau=tau_symbol())
    builtins = {"__builtins__": {}, "Symbol": sympy.Symbol, "Function": sympy.Function,
                "Integer": sympy.Integer, "Float": sympy.Float, "Rational": sympy.Rational}
    try:
        expr = parse_expr(text, local_dict=local, global_dict=builtins,
                          transformations=standard_transformations)
    except Exception as exc:  # parse_expr raises anything eval can raise
        raise ValueError(f"cannot parse it ({type(exc).__name__}: {exc})") from None
    if isinstance(expr, (int, float)):
        expr = sympy.sympify(expr)
    if not isinstance(expr, sympy.Expr):
        raise ValueError(f"it is not a numeric expression (got {type(expr).__name__})")
    unknown_functions = sorted(f.func.__name__ for f in expr.atoms(AppliedUndef))
    if unknown_functions:
        raise ValueError(f"unknown function(s) {', '.join(unknown_functions)}")
    unknown = sorted(str(s) for s in expr.free_symbols if s != tau_symbol())
    if unknown:
        raise ValueError(f"unknown symbol(s) {', '.join(unknown)} (only tau is allowed)")
    if expr.has(sympy.zoo, sympy.oo, -sympy.oo, sympy.nan):
        raise ValueError("it is not finite")
    return expr
