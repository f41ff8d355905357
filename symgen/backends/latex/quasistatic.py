"""LaTeX of the quasi-static response (18)-(20) (seed section 5), for ``symgen latex``.

Per elastic bar: the origin acceleration (10) with every deformation rate and acceleration
zero ([x_A'']*, tag ``10*``), and the Galerkin equations (16)-(17) with f' = g' = f'' = g'' = 0,
which are (18)-(19). Each of those is written already in the form of (20): terms linear in
the unknowns y (amplitudes, and the reactions B_K, Gamma_K acting on the bar, which are
linear in the multipliers) on the left, the known load terms (B) and, in brackets, the
nonlinear terms f(y) on the right. Then (20) itself: how symgen assembles A, B and f(y) from
the generated residual and solves it (``symgen quasistatic``).

The bar equations are derived again here with symbolic inner products, exactly as the bar
section of the document does (same ``bar_equations``, same point-force labels).
"""
from __future__ import annotations

import sympy as sp

from symgen.model.bars import IPTable, PointForce, bar_equations
from symgen.backends.latex import document as L

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
    const, lin, nonlin = [], [], []
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


def _row20(expr: sp.Expr, unknowns: set, pr, tag: str):
    """``A y = B + [f(y)]`` for one residual row ``expr`` = 0."""
    const, lin, nonlin = _split(expr, unknowns)
    lhs = _signed(lin, pr) or ["0"]
    rhs = _signed([-c for c in const], pr)
    if nonlin:
        f = _signed([-t for t in nonlin], pr)
        f[0] = ("+ " if rhs else "") + r"\Bigl[" + (f[0] if not f[0].startswith("+ ") else f[0][2:])
        f[-1] = f[-1] + r"\Bigr]_{f}"
        rhs = rhs + f
    return L._term_row(lhs, rhs or ["0"], tag)


def quasi_static_context(scene, model, pr) -> dict:
    """Context of ``symgen/backends/latex/templates/quasistatic.tex.jinja``."""
    eff = scene.effects
    prog = model.program
    assigned = dict(prog.assignments)
    zero_rates = {}
    for bm in model.bars.values():
        s = bm.sym
        for x in (*s.df, *s.ddf, *s.dg, *s.ddg):
            zero_rates[x] = 0
    bars, guides = [], []
    for name in model.topology.order:
        bm = model.bars[name]
        s = bm.sym
        tn = L.tex_escape(name)
        B = L._rm(name)
        na, nt = len(s.f), len(s.g)
        star = {s.xa_dd: sp.Symbol(rf"[\ddot x_A]^{{*}}_{{{B}}}"), s.ya_dd: sp.Symbol(rf"[\ddot y_A]^{{*}}_{{{B}}}")}
        acc = [L._row(pr, pr(star[s.xa_dd]), assigned[s.xa_dd].xreplace(zero_rates), f"10*.x, {tn}"),
               L._row(pr, pr(star[s.ya_dd]), assigned[s.ya_dd].xreplace(zero_rates), f"10*.y, {tn}")]
        if _is_guide(bm):
            guides.append(tn)
            continue
        if na == 0 and nt == 0:
            continue
        # display point forces exactly as the bar section does
        used: set = set()
        points, unknown_forces = [], set()
        for p in bm.inputs["points"]:
            label = L._point_label(p, scene, used)
            if p.ground is not None:
                Bs, Gs = sp.Symbol(rf"B_{{{label}}}"), sp.Symbol(rf"\Gamma_{{{label}}}")
                points.append(PointForce(p.xi, bar=(Bs, Gs)))
                unknown_forces |= {Bs, Gs}
            else:
                points.append(p)
        inputs = dict(bm.inputs)
        inputs["points"] = tuple(points)
        if bm.inputs["loads"] or bm.inputs["gravity"] is not None:
            inputs["loads"] = ((sp.Symbol(rf"\bar\beta_{{{B}}}"), sp.Symbol(rf"\bar\gamma_{{{B}}}")),)
        else:
            inputs["loads"] = ()
        inputs["gravity"] = None
        eqs = bar_equations(s, bm.basis_a, bm.basis_t, IPTable(bm.ipt.ip, symbolic=True), eff, **inputs)
        unknowns = set(s.f) | set(s.g) | unknown_forces | set(bm.inputs.get("axial_force", ()))
        rows = [_row20(e.xreplace(zero_rates).xreplace(star), unknowns, pr, f"18.{k + 1}, {tn}")
                for k, e in enumerate(eqs.eq16)]
        rows += [_row20(e.xreplace(zero_rates).xreplace(star), unknowns, pr, f"19.{k + 1}, {tn}")
                 for k, e in enumerate(eqs.eq17)]
        bars.append({"name": tn, "acc": L._block(acc), "eqs": L._block(rows),
                     "forces": ", ".join(f"${pr(x)}$" for x in sorted(unknown_forces, key=str))})
    amps = [x for c, x in zip(model.coords, model.q) if c.kind in ("f", "g")]
    y = [pr(x) for x in amps] + [pr(x) for x in model.lam]
    return {"bars": bars, "guides": guides, "y": ", ".join(f"${x}$" for x in y), "n_amp": len(amps), "n_lam": len(model.lam),
            "has_lam": bool(model.lam)}
