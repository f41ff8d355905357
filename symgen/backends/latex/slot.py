"""LaTeX of slot joints: the guide bar with variable span psi(xi, beta) (seed 6.3).

Used by :mod:`symgen.backends.latex.document` for scenes with ``kind = "slot"`` joints (see
:mod:`symgen.model.slot`). The guide of a slot gets its own section (template
``guide.tex.jinja``): its shape functions on the span and the overhang, eta and its time
derivatives with the psi_beta / psi_betabeta terms of the formulation's "Variable span"
paragraph, (1), the strong form (9) with those terms, the rigid-body equations, (17) and the
equation of the support distance beta (tagged ``17.beta``) with symbolic inner products, and
the inner products in closed form as functions of beta. The slot's closure rows are shown in
the form of (11) with the guide's term [beta + zeta*, eta*].

The guide's equations are the model's display form (``model.bars[guide].equations.display``,
inner products from ``symgen.model.slot.SlotDisplayIPTable``). The slot force acts on the guide
at its moving support xi = beta (``derive._add_contact_force`` adds it to the guide's
generalized forces, not to ``bar_equations``); it is written here into the guide's rigid-body
and beta equations as the point force (B, Gamma) at xi = beta, where it does no work on the
amplitudes (psi(beta, beta) = 0).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import sympy as sp

from symgen.backends.latex.printing import (
    driven_text,
    eq_block,
    eq_row,
    equation_rows,
    kin_terms,
    num_text,
    rm,
    shown_forces,
    term_row,
    tex_escape,
)
from symgen.ir import names
from symgen.ir.records import CoordKind, find_coordinate
from symgen.model.bars import point_force_groups
from symgen.model.slot import CURVATURE, SHORTENING, SPAN_TENSION
from symgen.scene.model import GROUND

__all__ = ["is_guide", "guide_context", "guide_display_equations", "slot_closure", "slot_notes", "beta_positive"]


def is_guide(bm) -> bool:
    """A bar carrying a slot (variable span): its symbols have (beta, beta', beta'')."""
    return bool(getattr(bm.sym, "beta", ()))


def beta_positive(model) -> dict:
    """beta -> the same-named positive symbol, for display only: the guide's shape functions
    are written with Piecewise branches (span / overhang) whose conditions, at the pin
    xi = 0, are decided by beta >= 0 (always true: beta is a distance along the guide)."""
    out = {}
    for bm in model.bars.values():
        if is_guide(bm):
            b = bm.sym.beta[0]
            out[b] = sp.Symbol(b.name, positive=True)
    return out


def _slot_of(scene, guide: str):
    for j in scene.joints:
        if j.kind == "slot" and j.ends[1].body == guide:
            return j
    raise KeyError(f"{guide!r} guides no slot")


def _beta0(scene, joint: str) -> float | None:
    return dict(scene.initial.guess).get(joint) if scene.initial is not None else None


# --------------------------------------------------------------------------- inner products
def _shortest(expr: sp.Expr, pos: dict) -> sp.Expr:
    """The shortest printed of a few equivalent forms (beta taken positive)."""
    e = sp.sympify(expr).xreplace(pos)
    forms = [e]
    for fn in (sp.factor, sp.cancel, sp.simplify):
        try:
            forms.append(fn(e))
        except Exception:  # pragma: no cover - a form sympy cannot produce
            pass
    return min(forms, key=lambda x: (len(sp.latex(x)), forms.index(x)))


_KIND_ORDER = {name: i for i, name in enumerate(["gram", "Kt", "dKt", "T1", "dT1", "T2", "dT2", "Kb", "Kbb"])}


def _ip_rows(eqs, beta: sp.Symbol, used: set, pr, beta0: float | None, pos: dict) -> list[dict]:
    """Rows of the inner products of the guide's display form ``eqs`` that the shown equations
    use: each symbol's closed form in beta (``eqs.values``), decimal at the initial beta."""
    rows = []
    for sym, (kind, idx) in eqs.inner_products.items():
        if sym not in used:
            continue
        exact = eqs.values[sym]
        form = _shortest(exact, pos)
        const = not form.has(beta) and not form.has(pos.get(beta, beta))
        val = None
        if beta0 is not None or const:
            val = float(exact.subs(beta, beta0 if beta0 is not None else 0))
        rows.append(
            {
                "symbol": sym.name,
                "exact": pr(form),
                "decimal": num_text(val),
                "kind": "constant"
                if const
                else ("derivative in $\\beta$" if kind.startswith("d") else "function of $\\beta$"),
                "key": (_KIND_ORDER.get(kind, len(_KIND_ORDER)), kind, idx),
            }
        )
    rows.sort(key=lambda r: r["key"])
    for r in rows:
        del r["key"]
    return rows


# --------------------------------------------------------------------------- shape functions
_FAMILY = [  # psi_k, psi_k,beta, psi_k,betabeta of slot.SlotBasis: (LaTeX span, overhang)
    ("", r"\sin(k\pi\xi/\beta)", r"(-1)^{k}\,\frac{k\pi}{\beta}\,(\xi - \beta)"),
    (r",\beta", r"-\frac{k\pi\xi}{\beta^{2}}\cos(k\pi\xi/\beta)", r"(-1)^{k+1}\,\frac{k\pi\xi}{\beta^{2}}"),
    (
        r",\beta\beta",
        r"\frac{2k\pi\xi}{\beta^{3}}\cos(k\pi\xi/\beta) - \Bigl(\frac{k\pi\xi}{\beta^{2}}\Bigr)^{2}\sin(k\pi\xi/\beta)",
        r"(-1)^{k}\,\frac{2k\pi\xi}{\beta^{3}}",
    ),
]


def _family_exprs(k: int, xi: sp.Symbol, b: sp.Symbol) -> list[tuple]:
    """The expressions that ``_FAMILY`` writes, for mode k (to check them against the basis)."""
    a = k * sp.pi * xi / b
    return [
        (sp.sin(a), (-1) ** k * k * sp.pi / b * (xi - b)),
        (-k * sp.pi * xi / b**2 * sp.cos(a), (-1) ** (k + 1) * k * sp.pi * xi / b**2),
        (
            2 * k * sp.pi * xi / b**3 * sp.cos(a) - (k * sp.pi * xi / b**2) ** 2 * sp.sin(a),
            (-1) ** k * 2 * k * sp.pi * xi / b**3,
        ),
    ]


def _shape_rows(basis, b: sp.Symbol, pr) -> tuple[list[dict], bool]:
    """Rows (k, sub, span, overhang) of the guide's functions: the family's formulas in k when
    every function of ``basis`` is that family (checked symbolically), else one row per mode
    and derivative, printed from the basis' own expressions."""
    xi = next((x for fn in basis.functions for x in fn.span.free_symbols if x.name == "xi"), sp.Symbol("xi", real=True))
    nspan = getattr(basis, "nspan", len(basis.functions))
    sines, own = basis.functions[:nspan], basis.functions[nspan:]  # own: the overhang's chi_m
    ok = bool(sines)
    for k, fn in enumerate(sines, start=1):
        want = _family_exprs(k, xi, b)
        for order in range(3):
            got = (sp.diff(fn.span, b, order), sp.diff(fn.overhang, b, order))
            if any(sp.simplify(g - w) != 0 for g, w in zip(got, want[order])):
                ok = False
    bb = sp.Symbol(r"\beta")
    rows: list[dict[str, Any]] = []
    if ok:
        rows = [{"k": "k", "sub": sub, "span": span, "over": over} for sub, span, over in _FAMILY]
    for k, fn in enumerate(basis.functions if not ok else own, start=1 if not ok else nspan + 1):
        for order, (sub, _, _) in enumerate(_FAMILY):
            span, over = sp.diff(fn.span, b, order), sp.diff(fn.overhang, b, order)
            rows.append({"k": k, "sub": sub, "span": pr(span.xreplace({b: bb})), "over": pr(over.xreplace({b: bb}))})
    return rows, ok


# --------------------------------------------------------------------------- the guide's equations
def _contact_symbols(joint: str) -> tuple:
    return sp.Symbol(rf"B_{{{rm(joint)}}}"), sp.Symbol(rf"\Gamma_{{{rm(joint)}}}")


def _contact_definitions(model, guide: str, joint: str) -> tuple:
    """(B, Gamma) of the slot force on the guide, bar axes / nu alpha^2: the force is
    -(Lx, Ly) in ground axes (the crank's point receives +(Lx, Ly))."""
    Fx, Fy = (-names.joint_force(joint, ax).symbol() for ax in "xy")
    return point_force_groups(model.bars[guide].sym, Fx, Fy)


def guide_display_equations(scene, model, name: str, relabel: dict | None = None) -> dict:
    """The guide's rigid-body equations, (17) and the beta equation of the model's display form
    (symbolic inner products), with the slot force as (B, Gamma) at xi = beta.

    Returns a dict with keys "fx", "fy", "mom", "eq17", "eqbeta" (residuals, inertia minus
    forces, divided by nu alpha^2 / nu alpha^3 as in ``bars.bar_equations``), ``relabel``
    applied (``xreplace``); ``model.bars[name].equations.values`` gives each display symbol's
    value (the inner products' closed forms), ``_contact_definitions`` the slot force's.
    """
    s = model.bars[name].sym
    eqs = model.bars[name].equations.display.map(lambda e: e.xreplace(relabel or {}))
    Bc, Gc = _contact_symbols(_slot_of(scene, name).name)
    b = s.beta[0]
    u, rep, values = _contact_shortening(model, name)
    return {
        "fx": eqs.force[0] - Bc,
        "fy": eqs.force[1] - Gc,
        "mom": eqs.moment - (b + u.xreplace(rep)) * Gc,  # arm: the contact is at (beta + u(beta), 0)
        # psi_k(beta) = 0: the slot force does work on g only through the chord's shortening u(beta)
        "eq17": [e - Bc * sp.diff(u, gk).xreplace(rep) for e, gk in zip(eqs.eq17, s.g)],
        "eqbeta": eqs.eqbeta - Bc * (1 + sp.diff(u, b).xreplace(rep)),
        "values": values,
    }  # d r_contact / d beta = alpha R e_x (1 + du/dbeta)


def _contact_shortening(model, name: str) -> tuple[sp.Expr, dict, dict]:
    """The foreshortened contact's display form (``slot.SlotBarKinematics.contact_display``);
    (0, {}, {}) without."""
    kin = model.bars[name].kin
    if not hasattr(kin, "contact_display"):
        return sp.Integer(0), {}, {}
    u, rep, values = kin.contact_display()
    return u, rep, values


def guide_context(scene, model, name: str, pr) -> dict:
    """Context of ``guide.tex.jinja`` for the guide bar ``name``."""
    eff = scene.effects
    body = scene.body(name)
    bm = model.bars[name]
    s = bm.sym
    nt = len(s.g)
    B = rm(name)
    j = _slot_of(scene, name)
    J = rm(j.name)
    b, db, ddb = s.beta
    bt, dbt, ddbt = pr(b), pr(db), pr(ddb)
    pos = beta_positive(model)
    tn = tex_escape(name)
    ctx: dict = {
        "name": name,
        "tex": B,
        "text": tn,
        "rigid": False,
        "na": 0,
        "nt": nt,
        "slot": True,
        "frame": body.frame,
        "joint": tex_escape(j.name),
        "joint_tex": J,
        "beta": bt,
        "follower": tex_escape(j.ends[0].body),
        "follower_xi": num_text(j.ends[0].xi),
    }
    beta0 = _beta0(scene, j.name)
    ctx["beta0"] = num_text(beta0) if beta0 is not None else ""

    # ---- shape functions: span and overhang, and their beta derivatives
    ctx["psi"], ctx["psi_family"] = _shape_rows(bm.basis_t, b, pr)
    ctx["nover"] = getattr(bm.basis_t, "nover", 0)
    ctx["nspan"] = nt - ctx["nover"]
    ns = ctx["nspan"]
    ctx["k_range_span"] = ", ".join(str(k) for k in range(1, ns + 1)) if ns <= 3 else rf"1, \dots, {ns}"
    ctx["k_range"] = ", ".join(str(k) for k in range(1, nt + 1)) if nt <= 3 else rf"1, \dots, {nt}"
    g = [pr(x) for x in s.g]
    ctx["amplitudes"] = ", ".join(g)
    gk, dgk, ddgk = rf"g_{{{B},k}}", rf"\dot g_{{{B},k}}", rf"\ddot g_{{{B},k}}"
    sm = rf"\sum_{{k=1}}^{{{nt}}}"
    ctx["expansion"] = [
        rf"\eta_{{{B}}}(\xi,\tau) = {sm} \psi_k\bigl(\xi,{bt}(\tau)\bigr)\, {gk}(\tau)",
        rf"\dot\eta_{{{B}}} = {sm} \bigl({dgk}\,\psi_k + {gk}\,\psi_{{k,\beta}}\,{dbt}\bigr)",
        rf"\ddot\eta_{{{B}}} = {sm} \Bigl({ddgk}\,\psi_k + 2{dgk}\,\psi_{{k,\beta}}\,{dbt}"
        rf" + {gk}\bigl(\psi_{{k,\beta\beta}}\,{dbt}^{{2}} + \psi_{{k,\beta}}\,{ddbt}\bigr)\Bigr)",
    ]
    ctx["bc"] = rf"\zeta_{{{B}}} \equiv 0,\quad \eta_{{{B}}}(0) = \eta_{{{B}}}({bt}) = 0"

    # ---- (1)
    ax, ay = kin_terms({"B": B}, 0, nt, eff.coriolis)
    ctx["eq1"] = eq_block(
        [term_row([rf"a_{{x,{B}}}"], ax, f"1.x, {tn}"), term_row([rf"a_{{y,{B}}}"], ay, f"1.y, {tn}")]
    )

    # ---- applied forces: the guide's own point forces and loads, then the slot force at xi = beta
    forces = shown_forces(scene, bm, pr, reserved=(J,))
    pts_tex = [(pr(g), x) for _, g, x in forces.points]
    Bc, Gc = _contact_symbols(j.name)
    Bdef, Gdef = _contact_definitions(model, name, j.name)
    point_defs = [eq_row(pr, pr(Bc), Bdef), eq_row(pr, pr(Gc), Gdef)] + forces.point_defs
    ext = forces.external | {Bc, Gc}
    pts_tex.insert(0, (pr(Gc), bt))
    disp_loads = forces.loads
    ctx["point_defs"] = eq_block(point_defs)
    ctx["load_defs"] = eq_block(forces.load_defs) if forces.load_defs else ""

    # ---- (9) with the variable-span terms of eta''
    damp = bm.inputs["damping"] is not None
    c = r"c_{\mathrm{KV}}"
    left = [rf"-\mu_{{{B}}}\eta_{{{B}}}''''"]
    if damp:
        left.append(rf"- {c}\,\mu_{{{B}}}\dot\eta_{{{B}}}''''")
    if disp_loads:
        left.append(rf"+ \bar\gamma_{{{B}}}")
    left += [rf"+ {G}\,\delta(\xi - {x})" for G, x in pts_tex]
    sk = r"\sum_k"
    right = [
        rf"[\ddot y_A]_{{{B}}}",
        rf"+ {sk}\ddot g_{{{B},k}}\psi_k",
        rf"+ 2{dbt}{sk}\dot g_{{{B},k}}\psi_{{k,\beta}}",
        rf"+ {sk} g_{{{B},k}}\bigl(\psi_{{k,\beta\beta}}\,{dbt}^{{2}} + \psi_{{k,\beta}}\,{ddbt}\bigr)",
        rf"+ \ddot\theta_{{{B}}}\,\xi",
        rf"- \dot\theta_{{{B}}}^{{2}}\eta_{{{B}}}",
    ]
    ctx["strong"] = eq_block([term_row(left, right, f"9, {tn}")])
    ctx["damped"] = damp

    # ---- rigid-body equations, (17), (17.beta)
    eqs = guide_display_equations(scene, model, name, forces.relabel)
    elastic = {s.mu} if s.mu is not None else set()
    if damp:
        elastic.add(bm.inputs["damping"])
    used: set = set()

    def rows(exprs, tags):
        return equation_rows(pr, exprs, tags, elastic, ext, None, used)

    ctx["rb"] = eq_block(rows([eqs["fx"], eqs["fy"], eqs["mom"]], [f"RB.x, {tn}", f"RB.y, {tn}", f"RB.M, {tn}"]))
    ctx["eq17"] = eq_block(rows(eqs["eq17"], [f"17.{k + 1}, {tn}" for k in range(nt)])) if nt else ""
    ctx["eqbeta"] = eq_block(rows([eqs["eqbeta"]], [rf"17.$\beta$, {tn}"]))
    # the inner products of the equations and of the foreshortened contact (its own symbols)
    short = {
        sym: ("d" + SPAN_TENSION if sym.name.startswith(r"\partial") else SPAN_TENSION, (0, 0)) for sym in eqs["values"]
    }
    table = SimpleNamespace(
        inner_products={**bm.equations.inner_products, **short}, values={**bm.equations.values, **eqs["values"]}
    )
    ctx["ip_table"] = _ip_rows(table, b, used, pr, beta0, pos)
    ctx["tension"] = _tension_text(scene, model, name, pr) if eff.geometric_stiffening and nt else ""
    if ctx["tension"] and sp.Symbol(r"\mathcal{E}") in bm.equations.values:
        ctx["tension"] += _curvature_text(bm.ipt)
    topo = model.topology
    tj = [topo.edges[name].joint] + [e.joint for e in topo.children.get(name, ())]
    ctx["tree_joints"] = ", ".join(tex_escape(x) for x in tj)
    ctx["driven"] = driven_text(scene, name)
    return ctx


# --------------------------------------------------------------------------- (11) and (13)
def _chain(model, body: str) -> list[str]:
    topo = model.topology
    path, n = [], body
    while n != GROUND:
        path.append(n)
        n = topo.edges[n].parent
    return list(reversed(path))


def _vec(top: str, bottom: str) -> str:
    return rf"\begin{{bmatrix}} {top} \\ {bottom} \end{{bmatrix}}"


def _at(model, bar: str, xi: float) -> tuple[str, str, str]:
    """(xi, zeta(xi), eta(xi)) of a bar point as LaTeX (hats at xi = 1, zeros where the
    frame or the basis makes them vanish)."""
    B = rm(bar)
    s = model.bars[bar].sym
    one = abs(xi - 1.0) < 1e-12
    zero = abs(xi) < 1e-12
    x = "1" if one else num_text(xi)
    shortened = getattr(model.bars[bar].kin, "foreshortening", False) and bool(s.g)  # a guide: u(xi)
    z = "" if (not (s.f or shortened) or zero) else (rf"\hat\zeta_{{{B}}}" if one else rf"\zeta_{{{B}}}({x})")
    e = "0" if (not s.g or zero) else (rf"\hat\eta_{{{B}}}" if one else rf"\eta_{{{B}}}({x})")
    return x, z, e


def _chain_terms(model, body: str, end) -> tuple[str, list[str]]:
    """(root point, terms alpha_j R(theta_j) [...]) from ground to the end ``end`` of ``body``."""
    topo = model.topology
    path = _chain(model, body)
    root = topo.edges[path[0]]
    start = (
        rf"\mathbf r_{{A,{rm(path[0])}}}"
        if root.slider or root.ground_point is None
        else rf"\mathbf p_{{{rm(root.joint)}}}"
    )
    terms = []
    for k, bar in enumerate(path):
        B = rm(bar)
        edge = topo.edges[bar]
        rb = rf"\alpha_{{{B}}} R(\theta_{{{B}}})"
        if k + 1 < len(path):
            out_xi = topo.edges[path[k + 1]].parent_xi
            x, z, e = _at(model, bar, out_xi)
            top = f"{x} + {z}" if z else x
        elif end.variable:
            bt = pr_beta(model, bar)
            top, e = rf"{bt} + \zeta^*_{{{B}}}", rf"\eta^*_{{{B}}}"
        else:
            x, z, e = _at(model, bar, end.xi)
            top = f"{x} + {z}" if z else x
        term = rb + _vec(top, e)
        in_xi = edge.body_xi or 0.0
        if abs(in_xi) > 1e-12:
            x, z, e0 = _at(model, bar, in_xi)
            term = rb + r"\Bigl(" + _vec(top, e) + " - " + _vec(f"{x} + {z}" if z else x, e0) + r"\Bigr)"
        terms.append(term)
    return start, terms


def pr_beta(model, bar: str) -> str:
    """LaTeX of the support distance beta of the slot that ``bar`` guides."""
    return names.slot_support(model.coords[find_coordinate(model.coords, CoordKind.BETA, bar)].joint).latex


def slot_closure(scene, model, joint: str) -> dict:
    """The text and the symbolic (11) of a slot: sum of the follower's chain minus the
    guide's chain, with [beta + zeta*, eta*] for the guide, equal to the ground vector K."""
    j = next(x for x in scene.joints if x.name == joint)
    a, g = j.ends
    J = rm(joint)
    sa, ta = _chain_terms(model, a.body, a)
    sb, tb = _chain_terms(model, g.body, g)
    G = rm(g.body)
    bt = pr_beta(model, g.body)
    lhs = " + ".join(ta) + " - " + " - ".join(tb)
    K = rf"\mathbf K_{{{J}}} = {sb} - {sa}"
    short = getattr(model.bars[g.body].kin, "foreshortening", False) and bool(model.bars[g.body].sym.g)
    zstar = (
        rf"\zeta_{{{G}}}({bt}) = -\tfrac12\sum_{{j,k}} g_{{{G},j}} g_{{{G},k}}\,(\psi'_j,\psi'_k)_{{[0,\beta]}}"
        if short
        else "0"
    )
    star = rf"\zeta^*_{{{G}}} = {zstar},\quad \eta^*_{{{G}}} = \eta_{{{G}}}({bt}) = 0"
    text = (
        rf"Slot {tex_escape(joint)} (cut joint, multipliers $\Lambda_{{x,{J}}}$, $\Lambda_{{y,{J}}}$ = the slot "
        rf"force on {tex_escape(a.body)}), loop "
        + " -- ".join(tex_escape(x) for x in _loop(model, joint))
        + rf": the point $\xi = {num_text(a.xi)}$ of {tex_escape(a.body)} stays on {tex_escape(g.body)} at "
        rf"its support distance ${bt}(\tau)$. In (11) the guide's $[1 + \hat\zeta, \hat\eta]$ is replaced "
        rf"by $[{bt} + \zeta^*, \eta^*]$ with $\zeta^* = \zeta({bt})$, $\eta^* = \eta({bt})$; here "
        + (
            r"$\zeta^*$ the chord's shortening as the guide bends (its length kept; the paragraph ``Tension'' of "
            r"its section)"
            if short
            else r"$\zeta^* = 0$ (an axially rigid guide)"
        )
        + r" and $\eta^* = 0$ (the guide's frame is the chord from its pin to the slot)"
    )
    return {"text": text, "sym": rf"{lhs} = {K}", "star": star}


def _loop(model, joint: str) -> tuple:
    for c in model.topology.cuts:
        if c.joint == joint:
            return c.loop
    return ()


def slot_notes(scene, model) -> list[dict]:
    """(13) has no slot counterpart: what carries the slot force instead."""
    out = []
    for j in scene.joints:
        if j.kind != "slot":
            continue
        a, g = j.ends
        J = rm(j.name)
        out.append(
            {
                "name": tex_escape(j.name),
                "a": tex_escape(a.body),
                "xa": num_text(a.xi),
                "b": tex_escape(g.body),
                "beta": pr_beta(model, g.body),
                "tex": J,
                "mass": j.mass > 0,
            }
        )
    return out


def _curvature_text(ipt) -> str:
    """The guide's fourth-order geometry (``bars._guide_curvature``, ``bars._guide_shortening``),
    shown as the symbols of ``bars._shown_as``: what they are, and how many entries their tables
    have (not listed)."""
    count = {name: sum(1 for e in ipt.matrix(name) if e != 0) for name in (CURVATURE, SHORTENING)}
    return (
        r" Being inextensible, the guide bends with its exact curvature $\eta''/\sqrt{1-\eta'^2}$ to fourth order "
        r"in the amplitudes (the order of its shortening): its strain energy has $\mu\,\mathcal{E}$ beyond "
        r"$\tfrac12\mu\,(\eta'',\eta'')$, $\mathcal{E} = \tfrac12\int_0^1\eta'^2\eta''^2\,d\xi = "
        r"\tfrac12\sum g_a g_b g_c g_d\,(\psi'_a\psi'_b,\psi''_c\psi''_d)$, in (17) as "
        r"$\mu\,\mathcal{E}_k = \mu\,\partial\mathcal{E}/\partial g_k$ and in the equation of $\beta$ as "
        r"$\mu\,\mathcal{E}_\beta = \mu\,\partial\mathcal{E}/\partial\beta$. Its points move along the chord "
        r"as it bends: its kinetic energy has that motion's, $\mathcal{Z} = \tfrac12\int_0^1\bigl(\sum_{a,b} "
        r"g_a\dot g_b H_{ab}\bigr)^2 d\xi = \tfrac12\sum (H_{ab},H_{cd})\,g_a\dot g_b\,g_c\dot g_d$, "
        r"$H_{ab}(\xi) = \int_0^\xi\psi'_a\psi'_b\,d\xi$, whose Lagrange terms enter (17) as "
        r"$\mathcal{Z}_k = \frac{d}{d\tau}\frac{\partial\mathcal{Z}}{\partial\dot g_k} - "
        r"\frac{\partial\mathcal{Z}}{\partial g_k}$ and the equation of $\beta$ as "
        r"$\mathcal{Z}_\beta = -\partial\mathcal{Z}/\partial\beta$ (the rigid-body part of its axial inertia is "
        r"its tension's). Their tables, "
        + f"{count[CURVATURE]} entries $(\\psi'_a\\psi'_b,\\psi''_c\\psi''_d)$ and {count[SHORTENING]} "
        + r"$(H_{ab},H_{cd})$ over the pairs $a \le b$, $c \le d$, are not listed: each is a number times a power "
        r"of $\beta$ on the span plus one times a power of $1-\beta$ on the overhang (every function is a power "
        r"of $\beta$ times a fixed function of $\xi/\beta$ there, and of $1-\beta$ times one of "
        r"$(\xi-\beta)/(1-\beta)$ beyond), the numbers integrals of the fixed functions "
        r"(\texttt{symgen.model.slot}); the emitted model holds them."
    )


def _tension_text(scene, model, name: str, pr) -> str:
    """The guide's tension (``bars.bar_equations``) and its foreshortening
    (``slot.SlotBarKinematics``): what its N is made of and where it enters."""
    B = rm(name)
    text = (
        rf"The axially rigid guide keeps its length as it bends: its point $\xi$ lies at $\xi + \zeta_{{{B}}}(\xi)$ "
        rf"along the chord, $\zeta_{{{B}}}(\xi) = -\tfrac12\int_0^\xi \eta'^2_{{{B}}}\,d\xi = -\tfrac12\sum_{{j,k}} "
        rf"g_{{{B},j}} g_{{{B},k}}\,(\psi'_j,\psi'_k)_{{[0,\xi]}}$, at the joints and bars it carries (their "
        rf"positions above, $\hat\zeta_{{{B}}} = \zeta_{{{B}}}(1)$) and at the contact ($\beta + \zeta_{{{B}}}(\beta)$: "
        r"the terms of $B$ in (17) and in the equation of $\beta$). The forces there do virtual work on that "
        r"shortening: the tension they pull the guide with. Its own tension $N(\xi) = "
        rf"\bigl(\bar\beta_{{{B}}} - [\ddot x_A]_{{{B}}}\bigr)(1-\xi) + \dot\theta_{{{B}}}^{{2}}(1-\xi^2)/2 + "
        r"\sum_p B_p\,H(\xi_p - \xi)$ (its axial inertia and load, the point forces $B_p$ at $\xi_p$ given on it; its "
        r"far end free) does the same in (17) and the equation of $\beta$, through $(\psi'_j,(1-\xi)\,\psi'_k)$, "
        r"$(\psi'_j,\tfrac{1-\xi^2}{2}\,\psi'_k)$ and $(\psi'_j,\psi'_k)_{[0,\xi_p]} = \int_0^{\xi_p}\psi'_j\psi'_k\,d\xi$ "
        rf"(the kinetic energy's $-\dot\theta_{{{B}}}^{{2}}\eta_{{{B}}}$ is the spin's softening, this its stiffening)."
    )
    return text
