"""Passes over a derived ``Program`` (``symgen.ir.records``) shared by the backends that lower it
statement by statement (the C backend, and with it the FMU): liveness (the assignments an output
needs; dead statements dropped) and forward-mode Jacobians through the assignment list.

Jacobians follow the chain rule through the assignments: for every intermediate ``s = e(y...)``
a derivative intermediate ``ds/dw_c = sum_y de/dy * dy/dw_c`` is introduced only where it is
structurally nonzero, so the cost grows with the size of the program, not with the size of its
expressions once inlined (no expression swell). CasADi differentiates its own graphs.
"""

from __future__ import annotations

import sympy as sp

from symgen.ir.records import Program

#: a statement of a program: (symbol, expression of earlier symbols and the inputs)
Statement = tuple[sp.Symbol, sp.Expr]

#: the inputs Jacobians are taken with respect to: w = [q; v; a; lam]
JAC_WRT = ("q", "v", "a", "lam")


def wrt_symbols(program: Program) -> list[sp.Symbol]:
    """The Jacobian columns w = [q; v; a; lam], as symbols."""
    return [s for name in JAC_WRT for s in program.inputs[name]]


def needed(assignments: list[Statement], exprs: list[sp.Expr]) -> list[Statement]:
    """The assignments that ``exprs`` depend on, in program order."""
    index = {sym: k for k, (sym, _) in enumerate(assignments)}
    live: set[sp.Symbol] = set()
    stack = [s for e in exprs for s in e.free_symbols if s in index]
    while stack:
        s = stack.pop()
        if s in live:
            continue
        live.add(s)
        stack.extend(y for y in assignments[index[s]][1].free_symbols if y in index and y not in live)
    return [assignments[k] for k in sorted(index[s] for s in live)]


def prune(stmts: list[Statement], exprs: list[sp.Expr]) -> list[Statement]:
    """Backward liveness on a statement list (drops unused value or derivative statements)."""
    live: set[sp.Symbol] = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
    kept: list[Statement] = []
    for sym, expr in reversed(stmts):
        if sym in live:
            kept.append((sym, expr))
            live |= expr.free_symbols
    kept.reverse()
    return kept


def forward_jacobian(
    stmts: list[Statement], exprs: list[sp.Expr], wrt: list[sp.Symbol]
) -> tuple[list[Statement], dict[tuple[int, int], sp.Expr]]:
    """Chain rule through ``stmts``: derivative statements and the Jacobian entries of ``exprs``.

    Returns the extended statement list and ``{(row, col): expr}`` of the nonzero entries.
    """
    col = {w: c for c, w in enumerate(wrt)}
    grad: dict[sp.Symbol, dict[int, sp.Expr]] = {}
    out_stmts: list[Statement] = []
    counter = 0
    targets: set[sp.Symbol] = set(col)  # the symbols a derivative is taken along: w and live intermediates

    def gradient(expr: sp.Expr) -> dict[int, sp.Expr]:
        g: dict[int, sp.Expr] = {}
        for y, d in partials(expr, targets).items():
            if y in col:
                g[col[y]] = g.get(col[y], 0) + d
            else:
                for c, gy in grad[y].items():
                    g[c] = g.get(c, 0) + d * gy
        return {c: e for c, e in g.items() if e != 0}

    for sym, expr in stmts:
        out_stmts.append((sym, expr))
        g = gradient(expr)
        gs: dict[int, sp.Expr] = {}
        for c in sorted(g):
            e = g[c]
            if e.is_Symbol or e.is_Number:
                gs[c] = e
            else:
                counter += 1
                d = sp.Dummy(f"d{counter}")
                out_stmts.append((d, e))
                gs[c] = d
        grad[sym] = gs
        if gs:
            targets.add(sym)
    entries: dict[tuple[int, int], sp.Expr] = {}
    for r, e in enumerate(exprs):
        for c, d in sorted(gradient(e).items()):
            entries[(r, c)] = d
    return out_stmts, entries


def partials(expr: sp.Expr, targets: set[sp.Symbol]) -> dict[sp.Symbol, sp.Expr]:
    """{y: d expr / d y} of every symbol y of ``targets`` that ``expr`` depends on (nonzero
    entries), in one pass over the expression's tree with each shared subexpression
    differentiated once: sums, products, powers and functions by their rules (a function's
    derivative along its argument is SymPy's own ``fdiff``), anything else by ``sympy.diff``.
    The same derivatives as ``sympy.diff(expr, y)`` for each y (their forms may differ:
    tests/test_passes.py, and the C Jacobians against CasADi's in tests/test_emit_c.py), whose every
    call walks the whole tree and asks each node for its free symbols: slot_dyad's Jacobians took
    186 s of the C emission that way (42 s in all since)."""
    memo: dict[sp.Basic, dict[sp.Symbol, sp.Expr]] = {}

    def add(into: dict[sp.Symbol, sp.Expr], y: sp.Symbol, d: sp.Expr) -> None:
        into[y] = into[y] + d if y in into else d

    def rec(e: sp.Basic) -> dict[sp.Symbol, sp.Expr]:
        got = memo.get(e)
        if got is not None:
            return got
        r: dict[sp.Symbol, sp.Expr] = {}
        if e.is_Symbol:
            if e in targets:
                r[e] = sp.Integer(1)
        elif e.is_Number or not e.args:
            pass
        elif e.is_Add:
            for a in e.args:
                for y, d in rec(a).items():
                    add(r, y, d)
        elif e.is_Mul:
            args = e.args
            for i, a in enumerate(args):
                da = rec(a)
                if da:
                    rest = sp.Mul(*args[:i], *args[i + 1 :])
                    for y, d in da.items():
                        add(r, y, d * rest)
        elif e.is_Pow:
            base, exp = e.args
            db, de = rec(base), rec(exp)
            if db:
                factor = exp * base ** (exp - 1)
                for y, d in db.items():
                    add(r, y, factor * d)
            if de:
                for y, d in de.items():
                    add(r, y, e * sp.log(base) * d)
        elif isinstance(e, sp.Function) and type(e).fdiff is not sp.Function.fdiff and not isinstance(e, sp.Piecewise):
            for i, a in enumerate(e.args):
                da = rec(a)
                if da:
                    outer = e.fdiff(i + 1)
                    for y, d in da.items():
                        add(r, y, outer * d)
        else:  # anything else (a Piecewise, a Max): SymPy's own rule along each target it holds
            for y in e.free_symbols & targets:
                d = sp.diff(e, y)
                if d != 0:
                    r[y] = d
        r = {y: d for y, d in r.items() if d != 0}
        memo[e] = r
        return r

    return rec(expr)
