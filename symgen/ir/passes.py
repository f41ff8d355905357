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

    def gradient(expr: sp.Expr) -> dict[int, sp.Expr]:
        g: dict[int, sp.Expr] = {}
        for y in expr.free_symbols:
            if y in col:
                d = sp.diff(expr, y)
                if d != 0:
                    g[col[y]] = g.get(col[y], 0) + d
            elif grad.get(y):
                d = sp.diff(expr, y)
                if d == 0:
                    continue
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
    entries: dict[tuple[int, int], sp.Expr] = {}
    for r, e in enumerate(exprs):
        for c, d in sorted(gradient(e).items()):
            entries[(r, c)] = d
    return out_stmts, entries
