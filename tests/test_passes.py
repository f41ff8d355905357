"""``symgen.ir.passes.partials`` (the forward-mode Jacobians of the C emission) against
``sympy.diff``: every rule (sums, products, powers, functions by ``fdiff``, the rest by SymPy),
shared subexpressions, and symbols that are not among the targets."""

from __future__ import annotations

import numpy as np
import sympy as sp

from symgen.ir.passes import forward_jacobian, partials

x, y, z, w = sp.symbols("x y z w", real=True)
s = sp.Symbol("s", real=True)  # a parameter: not a target


def _same(a: sp.Expr, b: sp.Expr, symbols: tuple, rng: np.random.Generator) -> None:
    fa, fb = sp.lambdify(symbols, a, "math"), sp.lambdify(symbols, b, "math")
    for _ in range(20):
        point = rng.uniform(0.2, 1.7, len(symbols))
        assert abs(fa(*point) - fb(*point)) <= 1e-12 * (1.0 + abs(fb(*point)))


def test_partials_equal_sympy_diff():
    rng = np.random.default_rng(3)
    shared = sp.sin(x * y) + z**2
    exprs = [
        x**3 * y + s * sp.cos(z) * x,
        sp.sqrt(x**2 + y**2) * sp.exp(-z) / (1 + w**2),
        shared**2 * sp.log(x + 2) + shared * sp.atan2(y, x),
        x**y + sp.Abs(x - 0.3 * z) * s,
        sp.Piecewise((x * y, z < 1), (x**2 - y, True)) + sp.Max(x, z) * w,
        sp.tan(x) * sp.sinh(y) - sp.acos(z / 2) + 5,
    ]
    targets = {x, y, z, w}
    symbols = (x, y, z, w, s)
    for e in exprs:
        got = partials(e, targets)
        assert s not in got  # a symbol that is not a target has no entry
        for v in (x, y, z, w):
            want = sp.diff(e, v)
            if want == 0:
                assert v not in got, (e, v)
            else:
                _same(got[v], want, symbols, rng)


def test_forward_jacobian_through_statements():
    a, b = sp.Symbol("a", real=True), sp.Symbol("b", real=True)
    stmts = [(a, sp.sin(x) * y), (b, a**2 + s * z)]
    exprs = [b * x, a + w]
    out, entries = forward_jacobian(stmts, exprs, [x, y, z, w])
    values = dict(out)
    inline = [e.subs(b, stmts[1][1]).subs(a, stmts[0][1]) for e in exprs]

    def resolved(e: sp.Expr) -> sp.Expr:
        for _ in range(len(out) + 1):
            e = e.xreplace(values)
        return e

    rng = np.random.default_rng(4)
    for r, e in enumerate(inline):
        for c, v in enumerate((x, y, z, w)):
            want = sp.diff(e, v)
            got = resolved(entries[(r, c)]) if (r, c) in entries else sp.Integer(0)
            if want == 0:
                assert (r, c) not in entries
            else:
                _same(got, want, (x, y, z, w, s), rng)
