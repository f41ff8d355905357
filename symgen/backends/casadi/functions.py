"""Emit a derived model as CasADi SX Functions, and save / load them with the model's
``symgen.ir.info.ModelInfo`` (no SymPy needed to load).

Every function has the signature ``F(t, q, v, a, lam, p)`` (unused inputs are ignored):

=========  ================================================================
``phi``    position closure (11) of every cut joint, then the angle drivers
``phid``   its first time derivative
``phidd``  its second time derivative (linear in a)
``res``    generalized-force residual, one row per coordinate (16), (17), rigid-body eqs.
``out``    the scene's outputs, in order
``energy`` kinetic + elastic + potential energy
``closure`` loop rows of ``phi`` only
=========  ================================================================
"""

from __future__ import annotations

import casadi as ca
import sympy as sp

from symgen.backends.casadi.store import FUNCTION_NAMES, INPUT_NAMES, load, save  # noqa: F401  (re-exported)

_UNARY = {
    sp.sin: ca.sin,
    sp.cos: ca.cos,
    sp.tan: ca.tan,
    sp.exp: ca.exp,
    sp.log: ca.log,
    sp.Abs: ca.fabs,
    sp.sinh: ca.sinh,
    sp.cosh: ca.cosh,
    sp.tanh: ca.tanh,
    sp.asin: ca.asin,
    sp.acos: ca.acos,
    sp.atan: ca.atan,
    sp.sign: ca.sign,
}


class SympyToCasadi:
    """Convert SymPy expressions to CasADi SX, sharing repeated sub-expressions."""

    def __init__(self, env: dict) -> None:
        self.env = dict(env)
        self.memo: dict = {}

    def __call__(self, expr):
        expr = sp.sympify(expr)
        hit = self.memo.get(expr)
        if hit is not None:
            return hit
        out = self._convert(expr)
        self.memo[expr] = out
        return out

    def _convert(self, e):
        if e.is_Symbol:
            try:
                return self.env[e]
            except KeyError:
                raise KeyError(f"symbol {e} has no value in the CasADi conversion") from None
        if e.is_Number or e.is_NumberSymbol:
            return ca.SX(float(e))
        if e.is_Add:
            terms = [self(a) for a in e.args]
            out = terms[0]
            for t in terms[1:]:
                out = out + t
            return out
        if e.is_Mul:
            facs = [self(a) for a in e.args]
            out = facs[0]
            for f in facs[1:]:
                out = out * f
            return out
        if e.is_Pow:
            base, ex = e.args
            b = self(base)
            if ex == sp.Rational(1, 2):
                return ca.sqrt(b)
            if ex == -sp.Rational(1, 2):
                return 1 / ca.sqrt(b)
            if ex.is_Integer:
                n = int(ex)
                if n == 2:
                    return b * b
                if n == -1:
                    return 1 / b
                return ca.constpow(b, n)
            return ca.power(b, self(ex))
        fn = type(e)
        if fn in _UNARY:
            return _UNARY[fn](self(e.args[0]))
        if fn is sp.Max:
            vals = [self(a) for a in e.args]
            out = vals[0]
            for x in vals[1:]:
                out = ca.fmax(out, x)
            return out
        if fn is sp.Min:
            vals = [self(a) for a in e.args]
            out = vals[0]
            for x in vals[1:]:
                out = ca.fmin(out, x)
            return out
        if fn is sp.atan2:
            return ca.atan2(self(e.args[0]), self(e.args[1]))
        if fn is sp.Heaviside:
            x = self(e.args[0])
            return ca.if_else(x > 0, 1, ca.if_else(x < 0, 0, 0.5))
        if fn is sp.Piecewise:
            out = ca.SX(float("nan"))
            for val, cond in reversed(e.args):
                out = ca.if_else(self._cond(cond), self(val), out)
            return out
        raise NotImplementedError(f"cannot convert {fn.__name__} to CasADi: {e}")

    def _cond(self, c):
        if c is sp.true or c == True:  # noqa: E712
            return ca.SX(1)
        if isinstance(c, sp.core.relational.Relational):
            lhs, rhs = self(c.lhs), self(c.rhs)
            return {
                "<": lhs < rhs,
                "<=": lhs <= rhs,
                ">": lhs > rhs,
                ">=": lhs >= rhs,
                "==": lhs == rhs,
                "!=": lhs != rhs,
            }[c.rel_op]
        if isinstance(c, sp.And):
            out = ca.SX(1)
            for a in c.args:
                out = ca.logic_and(out, self._cond(a))
            return out
        if isinstance(c, sp.Or):
            out = ca.SX(0)
            for a in c.args:
                out = ca.logic_or(out, self._cond(a))
            return out
        raise NotImplementedError(f"cannot convert condition {c}")


def input_symbols(prog) -> tuple[dict, dict]:
    """The Functions' SX inputs (name -> vector) and the program's input symbols bound to their
    entries (the environment a :class:`SympyToCasadi` starts from)."""
    sx = {name: ca.SX.sym(name, len(prog.inputs[name])) for name in INPUT_NAMES}
    env = {}
    for name in INPUT_NAMES:
        for k, s in enumerate(prog.inputs[name]):
            env[s] = sx[name][k]
    return sx, env


def output_functions(prog, sx: dict, conv: SympyToCasadi) -> dict:
    """The Functions ``FUNCTION_NAMES`` of the program's outputs, converted by ``conv`` (its
    environment holding the assignments), of the inputs ``sx``."""
    args = [sx[n] for n in INPUT_NAMES]
    funcs = {}
    for fname in FUNCTION_NAMES:
        exprs = prog.outputs[fname]
        vec = ca.vertcat(*[conv(e) for e in exprs]) if exprs else ca.SX(0, 1)
        funcs[fname] = ca.Function(fname, args, [vec], list(INPUT_NAMES), [fname], {"cse": True})
    return funcs


def build_functions(model) -> dict:
    """CasADi Functions of a ``DerivedModel`` (see module docstring)."""
    prog = model.program
    sx, env = input_symbols(prog)
    conv = SympyToCasadi(env)
    for sym, expr in prog.assignments:
        conv.env[sym] = conv(expr)
    return output_functions(prog, sx, conv)
