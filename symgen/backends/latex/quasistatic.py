"""LaTeX of the quasi-static response (18)-(20) (seed section 5), for ``symgen latex``.

Per elastic bar: the origin acceleration (10) with every deformation rate and acceleration
zero ([x_A'']*, tag ``10*``), and the Galerkin equations (16)-(17) with f' = g' = f'' = g'' = 0,
which are (18)-(19). Each of those is written already in the form of (20): terms linear in
the unknowns y (amplitudes, and the reactions B_K, Gamma_K acting on the bar, which are
linear in the multipliers) on the left, the known load terms (B) and, in brackets, the
nonlinear terms f(y) on the right. Then (20) itself: how symgen assembles A, B and f(y) from
the generated residual and solves it (``symgen quasistatic``).

The bar equations are the model's display form (``model.bars[name].equations.display``),
with the point forces labelled as in the bar section of the document (``printing.shown_forces``).
"""

from __future__ import annotations

import sympy as sp

from symgen.backends.latex.printing import eq_block, eq_row, rm, shown_forces, term_row, tex_escape

__all__ = ["quasi_static_context"]


def _is_guide(bm) -> bool:
    return bool(getattr(bm.sym, "beta", ()))


def _signed(terms: list, pr) -> list[str]:
    """LaTeX of a list of additive terms, each with its sign (the first without '+')."""
    out = []
    for k, t in enumerate(terms):
        neg = t.could_extract_minus_sign()
        body = pr(-t if neg else t)
        out.append(("- " if neg else ("+ " if k else "")) + body)
    return out


def _split(expr: sp.Expr, unknowns: set) -> tuple[list, list, list]:
    """Terms of ``expr`` (expanded) by degree in ``unknowns``: (constant, linear, nonlinear)."""
    const: list[sp.Expr] = []
    lin: list[sp.Expr] = []
    nonlin: list[sp.Expr] = []
    gens = sorted(unknowns, key=str)
    for term in sp.Add.make_args(sp.expand(expr)):
        if term == 0:
            continue
        free = term.free_symbols & unknowns
        if not free:
            const.append(term)
            continue
        deg = sp.Poly(term, *gens).total_degree()
        (lin if deg == 1 else nonlin).append(term)
    return const, lin, nonlin


def _split_compact(expr: sp.Expr, unknowns: set) -> tuple[list, list, bool]:
    """The exact bar's rows (polynomials of degree 10 in the amplitudes: expanded they run to
    hundreds of thousands of terms): (constant, linear, whether a nonlinear rest is left), the
    constant and linear parts from the value and the derivatives at y = 0, the rest named."""
    gens = sorted(unknowns, key=str)
    zero = dict.fromkeys(gens, sp.S.Zero)
    const = [t for t in sp.Add.make_args(sp.expand(expr.xreplace(zero))) if t != 0]
    lin = [t for u in gens for t in sp.Add.make_args(sp.expand(u * sp.diff(expr, u).xreplace(zero))) if t != 0]
    return const, lin, bool(expr.free_symbols & unknowns)


def _row20(expr: sp.Expr, unknowns: set, pr, tag: str, compact: bool = False):
    """``A y = B + [f(y)]`` for one residual row ``expr`` = 0; ``compact``: the exact bar's
    nonlinear part named ``f(y)`` instead of written out (:func:`_split_compact`)."""
    if compact:
        const, lin, rest = _split_compact(expr, unknowns)
        lhs = _signed(lin, pr) or ["0"]
        rhs = _signed([-c for c in const], pr)
        if rest:
            rhs = rhs + [("+ " if rhs else "") + r"\Bigl[f(\mathbf{y})\Bigr]_{f}"]
        return term_row(lhs, rhs or ["0"], tag)
    const, lin, nonlin = _split(expr, unknowns)
    lhs = _signed(lin, pr) or ["0"]
    rhs = _signed([-c for c in const], pr)
    if nonlin:
        f = _signed([-t for t in nonlin], pr)
        f[0] = ("+ " if rhs else "") + r"\Bigl[" + (f[0] if not f[0].startswith("+ ") else f[0][2:])
        f[-1] = f[-1] + r"\Bigr]_{f}"
        rhs = rhs + f
    return term_row(lhs, rhs or ["0"], tag)


def quasi_static_context(scene, model, pr) -> dict:
    """Context of ``templates/latex/quasistatic.tex.jinja``."""
    prog = model.program
    assigned = dict(prog.assignments)
    exact = scene.effects.strain == "exact"  # its nonlinear terms named, not expanded (_split_compact)
    zero_rates = {}
    for bm in model.bars.values():
        s = bm.sym
        for x in (*s.df, *s.ddf, *s.dg, *s.ddg):
            zero_rates[x] = 0
    bars, guides = [], []
    for name in model.topology.order:
        bm = model.bars[name]
        s = bm.sym
        tn = tex_escape(name)
        B = rm(name)
        na, nt = len(s.f), len(s.g)
        star = {s.xa_dd: sp.Symbol(rf"[\ddot x_A]^{{*}}_{{{B}}}"), s.ya_dd: sp.Symbol(rf"[\ddot y_A]^{{*}}_{{{B}}}")}
        acc = [
            eq_row(pr, pr(star[s.xa_dd]), assigned[s.xa_dd].xreplace(zero_rates), f"10*.x, {tn}"),
            eq_row(pr, pr(star[s.ya_dd]), assigned[s.ya_dd].xreplace(zero_rates), f"10*.y, {tn}"),
        ]
        if _is_guide(bm):
            guides.append(tn)
            continue
        if na == 0 and nt == 0:
            continue
        # the display form, point forces labelled exactly as the bar section does
        forces = shown_forces(scene, bm, pr, definitions=False)
        unknown_forces = forces.reactions
        eqs = bm.equations.display.map(forces.show)
        unknowns = set(s.f) | set(s.g) | unknown_forces | set(bm.inputs.get("axial_force", ()))
        rows = [
            _row20(e.xreplace(zero_rates).xreplace(star), unknowns, pr, f"18.{k + 1}, {tn}", exact)
            for k, e in enumerate(eqs.eq16)
        ]
        rows += [
            _row20(e.xreplace(zero_rates).xreplace(star), unknowns, pr, f"19.{k + 1}, {tn}", exact)
            for k, e in enumerate(eqs.eq17)
        ]
        bars.append(
            {
                "name": tn,
                "acc": eq_block(acc),
                "eqs": eq_block(rows),
                "forces": ", ".join(f"${pr(x)}$" for x in sorted(unknown_forces, key=str)),
            }
        )
    amps = [x for c, x in zip(model.coords, model.q) if c.elastic]
    y = [pr(x) for x in amps] + [pr(x) for x in model.lam]
    return {
        "bars": bars,
        "guides": guides,
        "y": ", ".join(f"${x}$" for x in y),
        "n_amp": len(amps),
        "n_lam": len(model.lam),
        "has_lam": bool(model.lam),
        "compact": exact,
    }
