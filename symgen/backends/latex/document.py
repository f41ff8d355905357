"""Emit a derived model as a LaTeX document: every equation labelled with the paper's number.

``latex_document(scene, model)`` renders ``templates/latex/document.tex.jinja`` from a plain
context (strings and lists) built here. The document shows, per bar, the acceleration field
(1), the strong forms (8)-(9) with only the scene's effects, the origin acceleration (10) and
the Galerkin equations (16)-(17) and rigid-body equations with *symbolic* inner products (the
derived model's display form, ``model.bars[name].equations.display``: nothing is derived again
here), then the closed-form values of those inner products; per loop the closure rows (11); per pin between
two bars the joint equilibrium (13); and the assembled residual of every coordinate.

Display rules: expressions are never simplified; top-level sums are broken over several lines
(``tex_lines``); floats are shown with 6 significant digits (integral ones as integers); symbol
names map to LaTeX through the model's table (``symgen.ir.names``: ``theta_rod`` -> ``\\theta_{\\mathrm{rod}}``).

Examples
--------
>>> from symgen.scene import load_scene          # doctest: +SKIP
>>> from symgen.model.derive import derive                 # doctest: +SKIP
>>> scene = load_scene("examples/slider_crank.toml")   # doctest: +SKIP
>>> tex = latex_document(scene, derive(scene))    # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import jinja2
import sympy as sp

from symgen import __version__
from symgen.backends import templates
from symgen.backends.latex import quasistatic as latex_quasistatic
from symgen.backends.latex import slot as latex_slot
from symgen.backends.latex.printing import (
    driver_force_tex,
    torque_tex,
    driven_text,
    LINE_WIDTH,
    Namer,
    Printer,
    Row,
    eq_block,
    eq_row,
    equation_rows,
    kin_terms,
    num_text,
    rm,
    shown_forces,
    term_row,
    tex_escape,
    tex_lines,
)
from symgen.ir import names
from symgen.outputs import printable
from symgen.ir.records import GENERALIZED_FORCE, SUBTREE_FORCE
from symgen.scene.model import GROUND
from symgen.model.shape_cache import curvature_products, sixth_order_products
from symgen.model.structure import QUASI_STATIC, axial_treatments
from symgen.scene.motion import driver_angle

TEMPLATES = templates.folder("latex")  # templates/latex/ (symgen.backends.templates)

__all__ = ["latex_document", "tex_lines", "Namer", "TEMPLATES"]


def _driver_angle_tex(drv, pr, i: int = 0) -> str:
    """theta(tau) of angle driver ``i`` (0-based) with its parameters as symbols (the law's
    numbers as written)."""
    if drv.law is None and drv.ramp is None:
        if i == 0:
            return r"\theta^0_{\mathrm{drv}} + \Omega_{\mathrm{drv}}\tau"
        return rf"\theta^0_{{\mathrm{{drv}},{i + 1}}} + \Omega_{{\mathrm{{drv}},{i + 1}}}\tau"
    from symgen.model.derive import TAU

    sym = {k: pr.namer.symbol(names.driver_parameter(k, i)) for k in ("theta0", "rate", "ramp")}
    return pr(driver_angle(drv, TAU, sym["theta0"], sym["rate"], sym["ramp"]))


def _rotor_note(drv, pr, i: int = 0) -> str:
    """Driver ``i``'s rotor inertia (empty without one): where it enters the equations."""
    if not drv.rotor_inertia:
        return ""
    th = names.bar_angle(drv.body).latex
    J = names.driver_parameter("J_rotor", i).latex
    return (
        rf"; with the rotor inertia ${J} = {drv.rotor_inertia:.6g}$ (motor rotor and gears "
        rf"reflected to the shaft), which adds ${J}\,\ddot{{{th}}}$ to the residual of "
        rf"${th}$ and $\tfrac12 {J}\dot{{{th}}}^2$ to the kinetic energy"
        + (r" (the reported driver torque is the motor's, rotor included)" if drv.kind == "angle" else "")
    )


def rotary_notes(scene, pr) -> list[str]:
    """One sentence per joint with a lumped rotary inertia (the section rotation it turns with),
    then one per ``[[masses]]`` entry."""
    out = []
    for j in scene.joints:
        if not j.inertia:
            continue
        end = next(x for x in j.ends if x.body != GROUND)
        b = scene.body(end.body)
        th = names.bar_angle(b.name).latex
        J = rf"I_{{{rm(j.name)}}}"
        rot_ = th if b.rigid else rf"{th} + \eta_{{{rm(b.name)}}}'({num_text(end.xi)})"
        out.append(
            rf"Joint {tex_escape(j.name)}: a lumped rotary inertia ${J}$ on {tex_escape(b.name)} at "
            rf"$\xi = {num_text(end.xi)}$ turning with $\varphi_{{{rm(j.name)}}} = {rot_}$; it adds "
            rf"${J}\,\ddot\varphi_{{{rm(j.name)}}}\,\partial\varphi_{{{rm(j.name)}}}/\partial q$ to "
            rf"$E_q$ of every coordinate $q$ of that bar and $\tfrac12 {J}\dot\varphi_{{{rm(j.name)}}}^2$ "
            "to the kinetic energy."
        )
    for i, pm in enumerate(scene.masses):
        out.append(_mass_note(scene, pm, i))
    return out


def _mass_note(scene, pm, i: int) -> str:
    """The sentence of ``[[masses]]`` entry ``i``: where it sits, what it adds to the equations."""
    b = scene.body(pm.body)
    lab = rf"\mathrm{{M}}{i + 1}"
    th = names.bar_angle(b.name).latex
    at = num_text(pm.xi)
    rot_ = th if b.rigid or not b.transverse_modes else rf"{th} + \eta_{{{rm(b.name)}}}'({at})"
    m, J = (names.mass_parameter(k, i).latex for k in ("m", "I"))
    text = rf"Point mass M{i + 1} (masses[{i}]): ${m}$ on {tex_escape(b.name)} at $\xi = {at}$"
    if pm.offset is not None:
        a, c = (names.mass_parameter(k, i).latex for k in ("along", "across"))
        text += (
            rf", its centre at the offset $({a}, {c})$ from the axis in the axes of the cross-section, which "
            rf"turn by $\varphi_{{{lab}}} = {rot_}$ (a rigid attachment): its inertia and weight "
            rf"$(B_{{{lab}}}, \Gamma_{{{lab}}})$ act at $\xi = {at}$ with the couple of their arm "
            rf"through $\partial\varphi_{{{lab}}}/\partial q$"
        )
    else:
        text += rf": its inertia and weight are the point force $(B_{{{lab}}}, \Gamma_{{{lab}}})$ there"
    if pm.inertia:
        text += (
            rf"; its rotary inertia ${J}$ turns with $\varphi_{{{lab}}} = {rot_}$ and adds "
            rf"${J}\,\ddot\varphi_{{{lab}}}\,\partial\varphi_{{{lab}}}/\partial q$ to $E_q$"
        )
    return text + "; it adds its kinetic and potential energy to the energy."


def _driver_law_note(drv, i: int = 0) -> str:
    if drv.law is not None:
        return f" (driver.law = \\texttt{{{tex_escape(drv.law)}}}; its derivatives taken exactly)"
    if drv.ramp is not None:
        rate, ramp = (names.driver_parameter(k, i).latex for k in ("rate", "ramp"))
        return f" (the smooth spin-up of Kane, Ryan \\& Banerjee 1987 from rest to the rate ${rate}$ over ${ramp}$)"
    return ""


# --------------------------------------------------------------------------- inner products
_IP_ORDER = {
    "gram": 0,
    "Pd": 1,
    "psid1": 2,
    "Ka": 3,
    "KaInv": 4,
    "Kt": 5,
    "C3": 6,
    "D4": 7,
    "E4": 8,
    "G3": 9,
    "E6": 10,
    "C5": 11,
    "H4": 12,
    "Q4": 13,
}
#: the exact bar's tables (``effects.strain = "exact"``): in their own shape-cache entry
_CURVATURE = ("E4", "G3")
#: strains whose axial strain is von Karman's (the exact bar adds the curvature terms)
VON_KARMAN = ("von_karman", "exact")
STRAIN_TEXT = {
    "von_karman": "von K\\'arm\\'an",
    "linear": "linear (the seed's)",
    "exact": "exact strain to fourth order, exact curvature to sixth order (docs/exact-bars.md)",
}


def _strain_reason(scene) -> str:
    """Why the scene has its strain, when it was chosen (``effects.strain = "auto"``:
    :mod:`symgen.scene.strain`): a sentence under the effects table ("" when written)."""
    choice = scene.strain_choice
    if choice is None or choice.requested != "auto":
        return ""
    return tex_escape(choice.reason)


#: a generalized force of more operations than this is not written out in the assembled section:
#: a slot guide of 9 functions has rows of 4000-11000 (its fourth-order geometry expanded over its
#: tables), 5000 lines of LaTeX that pdflatex cannot hold in one display; its bar's section above
#: shows it with the tables as symbols
ASSEMBLED_OPS_MAX = 2000


def _assembled_row(pr, sym, expr) -> Row:
    """``sym = expr`` of the assembled section, or a note where ``expr`` is too long to read."""
    ops = sp.count_ops(expr)
    if ops <= ASSEMBLED_OPS_MAX:
        return eq_row(pr, pr(sym), expr)
    return Row(
        pr(sym),
        [
            rf"\text{{its bar's equation above, with the tables' values, scaled back: {ops} operations, not written out}}"
        ],
    )


def _ip_table(bm, used: set) -> list[dict]:
    """Rows (symbol, exact value, decimal, kind) of the inner products of bar ``bm``'s display
    form that the shown equations use."""
    exact_ka_inv = None
    rows = []
    for sym, (name, idx) in bm.equations.inner_products.items():
        if sym not in used:
            continue
        if name == "KaInv":
            if exact_ka_inv is None:
                exact_ka_inv = sp.ImmutableMatrix(bm.ipt.ip.exact["Ka"]).inv()
            exact = exact_ka_inv[idx]
        elif name in _CURVATURE:
            table: Any = curvature_products(bm.basis_a, bm.basis_t).exact[name]
            exact = table[idx]
        elif name in ("E6", "C5", "H4", "Q4"):  # the exact bar's quadrature tables (docs/exact-bars.md)
            value = float(getattr(sixth_order_products(bm.basis_a, bm.basis_t), name)[idx])
            ex = sp.latex(sp.Float(value, 15))
            rows.append(
                {
                    "symbol": sym.name,
                    "exact": ex,
                    "decimal": num_text(value),
                    "kind": "quadrature (double)",
                    "key": (_IP_ORDER[name], idx),
                }
            )
            continue
        else:
            exact = bm.ipt.ip.exact[name][idx]
        value = float(exact)
        if exact.atoms(sp.Float):
            ex = sp.latex(sp.Float(value, 15))
            kind = "numeric (50 digits)"
        else:
            ex = sp.latex(exact)
            kind = "closed form"
        rows.append(
            {"symbol": sym.name, "exact": ex, "decimal": num_text(value), "kind": kind, "key": (_IP_ORDER[name], idx)}
        )
    rows.sort(key=lambda r: r["key"])
    for r in rows:
        del r["key"]
    return rows


# --------------------------------------------------------------------------- bar equations
def _bar_context(scene, model, name: str, pr: Printer) -> dict:
    eff = scene.effects
    body = scene.body(name)
    bm = model.bars[name]
    s = bm.sym
    na, nt = len(s.f), len(s.g)
    B = rm(name)
    kin_names = {"B": B}
    ctx: dict = {
        "name": name,
        "tex": B,
        "rigid": body.rigid,
        "na": na,
        "nt": nt,
        "frame": body.frame,
        "text": tex_escape(name),
    }
    # ---- shape functions
    ctx["phi"] = [
        {"k": k + 1, "label": fn.label, "expr": pr(fn.expr), "extra": ""} for k, fn in enumerate(bm.basis_a.functions)
    ]
    ctx["psi"] = [
        {"k": k + 1, "label": fn.label, "expr": pr(fn.expr), "extra": ""} for k, fn in enumerate(bm.basis_t.functions)
    ]
    tfun = bm.basis_t.functions
    tfun = tfun[: len(tfun) - len(getattr(bm.basis_t, "points", ()))]  # static corrections: below
    if (
        getattr(bm.basis_t, "tip_joint", False)
        and len(tfun) > 1
        and tfun[0].beta is None
        and all(fn.beta is not None for fn in tfun[1:])
    ):
        # the orthogonalised tip-load shape: printed factored (its expanded form is a line of
        # ~13 exponential and trigonometric terms), the coefficients on the next line
        from symgen.model.shapes import tip_load_coefficients

        coef, t = tip_load_coefficients(list(tfun[1:]))
        m = len(coef)
        ctx["psi"][0]["expr"] = (
            rf"\frac{{1}}{{t}}\Bigl(\frac{{\xi^2(3-\xi)}}{{2}} - "
            rf"\sum_{{k=1}}^{{{m}}} c_k X_k(\xi)\Bigr)"
        )
        # t = 1 - sum c_k is a small difference: the c_k to 10 digits keep psi_1 to ~1e-6
        nums = [rf"c_{{{k + 1}}} = {_g6(ck, 10)}" for k, ck in enumerate(coef)] + [rf"t = {_g6(t, 10)}"]
        lines = [r",\ ".join(nums[i : i + 3]) for i in range(0, len(nums), 3)]
        ctx["psi"][0]["extra"] = (
            r"\text{with } " + r", \\ &\qquad ".join(lines) + r", \\ &\qquad "
            r"c_k = (P, X_k)/(X_k, X_k),\ P(\xi) = \xi^2(3-\xi)/2,\ t = 1 - \textstyle\sum_k c_k"
        )
    for key, basis, sym_ in (("phi", bm.basis_a, r"\phi"), ("psi", bm.basis_t, r"\psi")):
        for row, fn in zip(ctx[key], basis.functions):
            if getattr(fn, "xi_k", None) is not None and getattr(fn, "left", None) is not None:
                row["expr"], row["extra"] = _static_correction_tex(fn, sym_, pr)
    ctx["axial_family"] = bm.basis_a.family if na else ""
    ctx["transverse_family"] = bm.basis_t.family if nt else ""
    ctx["tip_joint"] = bm.basis_t.tip_joint
    ctx["eigen"] = any(fn.beta is not None for fn in bm.basis_t.functions)
    topo = model.topology
    tj = [topo.edges[name].joint] + [e.joint for e in topo.children.get(name, ())]
    ctx["tree_joints"] = ", ".join(tex_escape(x) for x in tj)
    ctx["driven"] = driven_text(scene, name)
    fs = r",\allowbreak ".join(pr(x) for x in s.f)
    gs = r",\allowbreak ".join(pr(x) for x in s.g)
    ctx["expansion"] = []
    if na:
        ctx["expansion"].append(rf"\zeta_{{{B}}}(\xi,\tau) = \sum_{{k=1}}^{{{na}}} \phi_k(\xi)\, f_{{{B},k}}(\tau)")
    if nt:
        ctx["expansion"].append(rf"\eta_{{{B}}}(\xi,\tau) = \sum_{{k=1}}^{{{nt}}} \psi_k(\xi)\, g_{{{B},k}}(\tau)")
    ctx["amplitudes"] = r",\allowbreak ".join(x for x in (fs, gs) if x)  # a long list may break after a comma

    # ---- (1)
    ax, ay = kin_terms(kin_names, na, nt, eff.coriolis)
    ctx["eq1"] = eq_block(
        [
            term_row([rf"a_{{x,{B}}}"], ax, f"1.x, {tex_escape(name)}"),
            term_row([rf"a_{{y,{B}}}"], ay, f"1.y, {tex_escape(name)}"),
        ]
    )

    # ---- point forces and distributed loads of the model's display form, labelled
    forces = shown_forces(scene, bm, pr)
    disp_loads = forces.loads
    pts_tex = [(pr(b), pr(g), x) for b, g, x in forces.points]
    ctx["point_defs"] = eq_block(forces.point_defs) if forces.point_defs else ""
    ctx["load_defs"] = eq_block(forces.load_defs) if forces.load_defs else ""
    ctx["points"] = [{"B": b, "G": g, "xi": x} for b, g, x in pts_tex]

    # ---- (8), (9): strong forms with the switched-on effects
    gs_on = eff.geometric_stiffening and na and nt
    vk = gs_on and eff.strain in VON_KARMAN
    damp = bm.inputs["damping"] is not None
    c = r"c_{\mathrm{KV}}"
    ctx["vk"] = bool(vk)
    # the exact bar: its sixth-order bending energy, whose inner products E, G appear in (16), (17)
    ctx["exact"] = bool(eff.strain == "exact" and nt and not body.rigid and not s.beta)
    ctx["exact_g"] = bool(ctx["exact"] and vk and na and "axial_force" not in bm.inputs)
    ctx["strain_def"] = rf"\varepsilon_{{{B}}} = \zeta_{{{B}}}' + \tfrac{{1}}{{2}}\,\eta_{{{B}}}'^{{2}}" if vk else ""
    if vk and ctx["exact"]:  # the exact strain |r'| - 1 to fourth order (docs/exact-bars.md)
        ctx["strain_def"] += rf" + \tfrac{{1}}{{8}}\,\eta_{{{B}}}'^{{4}}"
    pt_a = [rf"+ {b}\,\delta(\xi - {x})" for b, _, x in pts_tex]
    pt_t = [rf"+ {g}\,\delta(\xi - {x})" for _, g, x in pts_tex]
    strong = []
    inext = "axial_force" in bm.inputs
    ctx["inext"] = inext
    if na and not body.rigid:
        left = [rf"\lambda_{{{B}}}\varepsilon_{{{B}}}'" if vk else rf"\lambda_{{{B}}}\zeta_{{{B}}}''"]
        if inext:
            left = [rf"N_{{{B}}}'"]
        if damp and not inext:
            left.append(rf"+ {c}\,\lambda_{{{B}}}\dot\zeta_{{{B}}}''")
        if disp_loads:
            left.append(rf"+ \bar\beta_{{{B}}}")
        if pt_a:
            left.extend(pt_a)
        strong.append(term_row(left, ax, f"8, {tex_escape(name)}"))
    if nt and not body.rigid:
        left = [rf"-\mu_{{{B}}}\eta_{{{B}}}''''"]
        if damp:
            left.append(rf"- {c}\,\mu_{{{B}}}\dot\eta_{{{B}}}''''")
        # the virtual strain of eta': eta' (von Karman), eta' (1 + eta'^2 / 2) (the exact bar's strain)
        deta = (
            rf"\eta_{{{B}}}'\bigl(1 + \tfrac{{1}}{{2}}\eta_{{{B}}}'^{{2}}\bigr)" if ctx["exact"] else rf"\eta_{{{B}}}'"
        )
        if gs_on and inext:
            left.append(rf"+ \bigl(N_{{{B}}}{deta}\bigr)'")
        elif gs_on:
            left.append(
                rf"+ \lambda_{{{B}}}\bigl(\varepsilon_{{{B}}}{deta}\bigr)'"
                if vk
                else rf"+ \lambda_{{{B}}}\bigl(\zeta_{{{B}}}'\eta_{{{B}}}'\bigr)'"
            )
        if eff.rotary_inertia and na:
            left.append(rf"+ \rho_{{{B}}}\ddot\eta_{{{B}}}''")
        if disp_loads:
            left.append(rf"+ \bar\gamma_{{{B}}}")
        if pt_t:
            left.extend(pt_t)
        strong.append(term_row(left, ay, f"9, {tex_escape(name)}"))
    ctx["strong"] = eq_block(strong) if strong else ""
    ctx["rotary"] = bool(eff.rotary_inertia and na and nt and not body.rigid)
    ctx["bc"] = {
        "pinned-pinned": rf"\zeta_{{{B}}}(0) = 0,\quad \eta_{{{B}}}(0) = \eta_{{{B}}}(1) = 0",
        "cantilever": rf"\zeta_{{{B}}}(0) = 0,\quad \eta_{{{B}}}(0) = \eta_{{{B}}}'(0) = 0",
    }.get(body.frame, "")

    # ---- (16), (17), rigid-body equations: the model's display form (symbolic inner products)
    eqs = bm.equations.display.map(forces.show)
    ext = forces.external
    elastic = {x for x in (s.lam, s.mu) if x is not None} | set(bm.inputs.get("axial_force", ()))
    if damp:
        elastic.add(bm.inputs["damping"])
    rho_pair = (
        (s.mu, s.lam, pr.namer.symbol(names.bar_parameter("rho", name), positive=True)) if ctx["rotary"] else None
    )
    used_ip: set = set()

    def rows(exprs, tags):
        return equation_rows(pr, exprs, tags, elastic, ext, rho_pair, used_ip)

    tn = tex_escape(name)
    ctx["rb"] = eq_block(rows([eqs.force[0], eqs.force[1], eqs.moment], [f"RB.x, {tn}", f"RB.y, {tn}", f"RB.M, {tn}"]))
    ctx["eq16"] = eq_block(rows(eqs.eq16, [f"16.{k + 1}, {tn}" for k in range(na)])) if na else ""
    ctx["eq17"] = eq_block(rows(eqs.eq17, [f"17.{k + 1}, {tn}" for k in range(nt)])) if nt else ""
    ctx["ip_table"] = _ip_table(bm, used_ip)
    return ctx


# --------------------------------------------------------------------------- (13)
def _section_force(scene, model, body: str, xi: float, pr: Printer) -> dict:
    """Section force of bar ``body`` at its end ``xi`` (common units, ground axes).

    Returns the sign with which it enters the pin balance (+1 at xi = 1, -1 at xi = 0: the
    force the pin exerts on the bar is +F at the far end, -F at the origin), the LaTeX
    name of F and the rows defining N, Q (symbolic, then in the bar's amplitudes) and F.
    """
    eff = scene.effects
    bm = model.bars[body]
    s = bm.sym
    B = rm(body)
    na, nt = len(s.f), len(s.g)
    at_one, at_zero = abs(xi - 1.0) < 1e-12, abs(xi) < 1e-12
    xs = "1" if at_one else ("0" if at_zero else num_text(xi))
    F = rf"\mathbf F_{{{B}}}({xs})"
    out: dict[str, Any] = {"sign": 1 if at_one else -1, "F": F, "rows": [], "rigid": False, "end": at_one or at_zero}
    if not out["end"]:
        out["F"] = rf"\bigl(\mathbf F_{{{B}}}({xs}^-) - \mathbf F_{{{B}}}({xs}^+)\bigr)"
        out["sign"] = 1
    Nn, Qn = rf"N_{{{B}}}({xs})", rf"Q_{{{B}}}({xs})"
    frow = Row(
        F,
        [
            rf"\nu_{{{B}}}\alpha_{{{B}}}^{{2}} R(\theta_{{{B}}})"
            rf"\begin{{bmatrix}} {Nn} \\ {Qn} \end{{bmatrix}}"
        ],
    )
    if scene.body(body).rigid or (na == 0 and nt == 0) or not out["end"]:
        out["rigid"] = scene.body(body).rigid or (na == 0 and nt == 0)
        out["rows"] = [frow] if out["end"] else []
        return out
    gs_on = eff.geometric_stiffening and na and nt
    vk = gs_on and eff.strain in VON_KARMAN
    kin = bm.kin
    zp, ep, e3 = kin.zeta(xi, 1), kin.eta(xi, 1), kin.eta(xi, 3)
    p1, p3 = "'", "'''"
    rows = []
    if na and "axial_force" in bm.inputs:
        rows.append(
            Row(
                Nn,
                [
                    rf"\sum_k N_{{{B},k}}\,\phi'_k({xs})"
                    r"\text{ (the multiplier of the inextensibility rows)}"
                ],
            )
        )
        rows.append(
            Row(
                "",
                pr.lines(
                    sp.Add(*[c * n for c, n in zip(kin._vals(bm.basis_a, xi, 1), bm.inputs["axial_force"])]),
                    LINE_WIDTH - 10,
                ),
            )
        )
    elif na:
        n_sym = (
            rf"\lambda_{{{B}}}\bigl(\zeta_{{{B}}}{p1}({xs}) + \tfrac12\eta_{{{B}}}{p1}({xs})^{{2}}\bigr)"
            if vk
            else rf"\lambda_{{{B}}}\zeta_{{{B}}}{p1}({xs})"
        )
        N = s.lam * (zp + ep**2 / 2) if vk else s.lam * zp
        rows.append(Row(Nn, [n_sym]))
        rows.append(Row("", pr.lines(N, LINE_WIDTH - 10)))
    else:
        rows.append(Row(Nn, [r"\text{a reaction of the axially rigid bar (no constitutive law)}"]))
    q_sym, Q = [], sp.Integer(0)
    if nt:
        q_sym.append(rf"-\mu_{{{B}}}\eta_{{{B}}}{p3}({xs})")
        Q += -s.mu * e3
    if gs_on:
        q_sym.append(rf"+ {Nn}\,\eta_{{{B}}}{p1}({xs})")
        Q += sp.Symbol(Nn) * ep
    if q_sym:
        rows.append(Row(Qn, [" ".join(q_sym)]))
        rows.append(Row("", pr.lines(Q, LINE_WIDTH - 10)))
    else:
        rows.append(Row(Qn, ["0"]))
    out["rows"] = rows + [frow]
    return out


def _joints_context(scene, model, pr: Printer) -> list[dict]:
    out = []
    tree = {e.joint: e for e in model.topology.edges.values()}
    cut = {c.joint for c in model.topology.cuts}
    for j in scene.joints:
        if j.kind != "pin" or any(e.body == GROUND for e in j.ends):
            continue
        (a, b) = j.ends
        fa = _section_force(scene, model, a.body, a.xi, pr)
        fb = _section_force(scene, model, b.body, b.xi, pr)
        lhs = fa["F"] if fa["sign"] == 1 else "-" + fa["F"]
        rhs = "-" + fb["F"] if fb["sign"] == 1 else fb["F"]
        if j.mass > 0:
            rhs += rf" - m_{{{rm(j.name)}}}\bigl(\ddot{{\mathbf r}}_{{{rm(j.name)}}} - \mathbf g\bigr)"
        rows = [Row(lhs, [rhs], f"13, {tex_escape(j.name)}")]
        defs = fa["rows"] + fb["rows"]
        if j.name in tree:
            body = rm(tree[j.name].body)
            how = (
                rf"{tex_escape(j.name)} is a tree joint: its force is the resultant "
                rf"$\mathbf S_{{{body}}} = (S_{{X,{body}}}, S_{{Y,{body}}})$ of the subtree hanging "
                rf"from it (route 2 of the seed)"
            )
        elif j.name in cut:
            how = (
                rf"{tex_escape(j.name)} is a cut joint: its force is carried by the multipliers "
                rf"$\Lambda_{{x,{rm(j.name)}}}$, $\Lambda_{{y,{rm(j.name)}}}$"
            )
        else:
            how = ""
        out.append(
            {
                "name": tex_escape(j.name),
                "a": tex_escape(a.body),
                "b": tex_escape(b.body),
                "xa": num_text(a.xi),
                "xb": num_text(b.xi),
                "eq": eq_block(rows),
                "defs": eq_block(defs) if defs else "",
                "how": how,
                "rigid": [tex_escape(x) for x, d in ((a.body, fa), (b.body, fb)) if d["rigid"]],
                "interior": not (fa["end"] and fb["end"]),
                "mass": j.mass > 0,
            }
        )
    return out


# --------------------------------------------------------------------------- document
def _env() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=templates.loader("latex"),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        block_start_string="<%",
        block_end_string="%>",
        variable_start_string="<<",
        variable_end_string=">>",
        comment_start_string="<#",
        comment_end_string="#>",
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["e"] = tex_escape
    return env


def _static_correction_tex(fn, sym_: str, pr) -> tuple[str, str]:
    """A static correction function printed factored: (w_K - sum_k c_k f_k) / t, then the
    piecewise static shape w_K and the coefficients (10 digits: t can be a small difference).
    A moment correction (unit couple) prints its static shape as w^M_K, scaled to the slope 1."""
    import sympy as sp

    from symgen.model.shapes import XI

    def poly(cs) -> str:
        return pr(sp.Add(*[sp.Rational(c.numerator, c.denominator) * XI**p for p, c in enumerate(cs) if c]))

    a = sp.Rational(fn.a.numerator, fn.a.denominator)
    m = len(fn.coeffs)
    k = "K"
    moment = getattr(fn, "load", "force") == "moment"
    w_name = rf"w^{{M}}_{{{k}}}" if moment else rf"w_{{{k}}}"
    expr = (
        rf"\frac{{1}}{{t}}\Bigl({w_name}(\xi)"
        + (rf" - \sum_{{k=1}}^{{{m}}} c_k\,{sym_}_k(\xi)" if m else "")
        + r"\Bigr)"
    )
    what = {
        "axial": "unit axial force",
        "pinned-pinned": "unit transverse force, pinned-pinned",
        "cantilever": "unit transverse force, cantilever",
    }[fn.kind]
    if moment:
        what = f"unit couple, {fn.kind}"
    w = (
        rf"{w_name}(\xi) = \begin{{cases}} {poly(fn.left)} & \xi \le {pr(a)} \\ {poly(fn.right)} & \xi > {pr(a)}"
        rf"\end{{cases}} \\ &\qquad \text{{(static shape, {what} at }}\xi_{{{k}}} = {_g6(fn.xi_k, 10)}\text{{)}}"
    )
    nums = [rf"c_{{{i + 1}}} = {_g6(c, 10)}" for i, c in enumerate(fn.coeffs) if abs(c) > 1e-14] + [
        rf"t = {_g6(fn.scale, 10)}"
    ]
    rows = [r",\ ".join(nums[i : i + 3]) for i in range(0, len(nums), 3)]
    norm = rf"{fn.label}{{}}'(\xi_{{{k}}}) = 1" if moment else rf"{fn.label}(\xi_{{{k}}}) = 1"
    extra = (
        w
        + r", \\ &\qquad \text{with } "
        + r", \\ &\qquad ".join(rows)
        + rf", \\ &\qquad (c_k\text{{: mass inner-product projections, zero ones omitted; }}{norm})"
    )
    return expr, extra


def _g6(x: float, digits: int = 6) -> str:
    """A number to ``digits`` significant digits in LaTeX (powers of ten as \\cdot 10^{n})."""
    text = f"{x:.{digits}g}"
    if "e" in text:
        mant, exp = text.split("e")
        return rf"{mant}\cdot 10^{{{int(exp)}}}"
    return text


def latex_document(scene, model) -> str:
    """The derived equations of ``scene`` as a complete LaTeX document (pdflatex, amsmath).

    Parameters
    ----------
    scene : the loaded :class:`~symgen.scene.model.Scene`
    model : ``symgen.model.derive.derive(scene)``
    """
    namer = Namer(model.latex)
    pr = Printer(namer, subs=latex_slot.beta_positive(model))
    prog = model.program
    assigned = dict(prog.assignments)
    topo = model.topology
    treatments = axial_treatments(scene)  # effects.axial per bar, with the reason

    # ---- scene tables
    bodies = []
    for b in scene.bodies:
        bm = model.bars[b.name]
        g = scene.groups.get(b.name, {})
        bodies.append(
            {
                "name": tex_escape(b.name),
                "tex": rm(b.name),
                "kind": "rigid" if b.rigid else "elastic",
                "frame": tex_escape(b.frame or "--"),
                "na": len(bm.sym.f),
                "nt": len(bm.sym.g),
                "alpha": num_text(g.get("alpha")),
                "nu": num_text(g.get("nu")),
                "lam": num_text(g.get("lambda")),
                "mu": num_text(g.get("mu")),
                "rho": num_text(g.get("rho")),
            }
        )
    sg = scene.groups.get("_scene", {})
    scene_groups = [
        {
            "key": tex_escape(k),
            "value": tex_escape(", ".join(f"{x:.6g}" for x in v))
            if isinstance(v, (list, tuple))
            else (num_text(v) if isinstance(v, (int, float)) else tex_escape(v)),
        }
        for k, v in sg.items()
    ]
    eff = scene.effects
    effects = [
        (
            "axial deformation",
            "off"
            if not eff.axial
            else ", ".join(
                f"{tex_escape(n)}: {tex_escape(t.treatment.replace('_', '-'))}"
                + (
                    f" to $\\tau = {scene.axial_switch.tau:.6g}$, quasi-static after it (the start's damped "
                    "ringing ended: the equations below are the first part's; the second's are those of the "
                    "quasi-static axial response, as without the switch)"
                    if scene.axial_switch is not None and n in dict(scene.axial_kept)
                    else ""
                )
                for n, t in treatments.items()
                if t.treatment != "off"
            )
            or "on",
        ),
        ("transverse deformation", "on" if eff.transverse else "off"),
        ("geometric stiffening", "on" if eff.geometric_stiffening else "off"),
        ("Coriolis terms", "on" if eff.coriolis else "off"),
        ("rotary inertia", "on" if eff.rotary_inertia else "off"),
        ("axial strain", STRAIN_TEXT[eff.strain] + (" (auto)" if _strain_reason(scene) else "")),
        ("gravity $(g_x, g_y)$", "off" if not any(eff.gravity) else f"$({eff.gravity[0]:.6g}, {eff.gravity[1]:.6g})$"),
        ("Kelvin--Voigt damping", "off" if not eff.damping else f"${eff.damping:.6g}$"),
    ]
    quasi = [b for b in scene.bodies if not b.rigid and b.quasi_static_transverse]
    if quasi:  # bodies.<name>.quasi_static_transverse: applied by the run (docs/quasi-static-modes.md)
        effects.append(
            (
                "quasi-static transverse functions",
                "; ".join(
                    f"{tex_escape(b.name)}: the highest {b.quasi_static_transverse} of {b.transverse_modes}, "
                    "whose rates and accelerations are zero in every equation below (no inertia of their own)"
                    for b in quasi
                ),
            )
        )
    joints = []
    for j in scene.joints:
        ends = []
        for e in j.ends:
            if e.body == GROUND:
                ends.append(f"ground $({e.point[0]:.6g}, {e.point[1]:.6g})$")
            elif e.variable:
                ends.append(f"{tex_escape(e.body)} at $\\xi = \\beta_{{{rm(j.name)}}}(\\tau)$ (variable support)")
            else:
                ends.append(f"{tex_escape(e.body)} at $\\xi = {e.xi:.6g}$")
        role = "tree" if any(e.joint == j.name for e in topo.edges.values()) else "cut"
        joints.append(
            {
                "name": tex_escape(j.name),
                "kind": j.kind,
                "ends": ", ".join(ends),
                "role": role,
                "mass": (f"{j.mass:.6g}" if j.mass else "")
                + (f"; rotary inertia $I_{{{rm(j.name)}}} = {j.inertia:.6g}$" if j.inertia else ""),
            }
        )
    drivers = [
        {
            "kind": drv.kind,
            "body": tex_escape(drv.body),
            "text": (
                f"kinematic guidance: $\\theta_{{{rm(drv.body)}}} = {_driver_angle_tex(drv, pr, i)}$"
                + _driver_law_note(drv, i)
                if drv.kind == "angle"
                else f"dynamic guidance: applied moment ${torque_tex(i)}$ on {tex_escape(drv.body)} (12)"
            )
            + _rotor_note(drv, pr, i),
        }
        for i, drv in enumerate(scene.drivers)
    ]
    coords = [{"tex": pr(x), "kind": c.kind, "body": tex_escape(c.body)} for c, x in zip(model.coords, model.q)]
    mult = []
    for L, row in zip(model.lam, model.lam_rows):
        what = {
            "pin-x": "x force of pin",
            "pin-y": "y force of pin",
            "slider": "normal force of slider",
            "driver": "driver torque",
            "inextensible": "axial force amplitude of inextensible bar",
            "slot-x": "x force of slot",
            "slot-y": "y force of slot",
        }[row.kind]
        mult.append({"tex": pr(L), "text": f"{what} {tex_escape(row.joint) if row.kind != 'driver' else ''}".strip()})
    try:
        from symgen.ir.parameters import parameter_values

        values: Iterable[float | None] = parameter_values(scene, model.param_names)
    except KeyError:
        values = [None] * len(model.params)
    params = [{"tex": pr(p), "value": num_text(v)} for p, v in zip(model.params, values)]

    # ---- bars
    bars = [
        latex_slot.guide_context(scene, model, name, pr)
        if latex_slot.is_guide(model.bars[name])
        else _bar_context(scene, model, name, pr)
        for name in topo.order
    ]

    # ---- (10)
    chain = {}
    for name in topo.order:
        path, n = [], name
        while n != GROUND:
            path.append(n)
            n = topo.edges[n].parent
        chain[name] = " $\\to$ ".join(["ground"] + [tex_escape(x) for x in reversed(path)])
    eq10 = []
    for name in topo.order:
        s = model.bars[name].sym
        e = topo.edges[name]
        rows = [
            eq_row(pr, pr(s.xa_dd), assigned[s.xa_dd], f"10.x, {tex_escape(name)}"),
            eq_row(pr, pr(s.ya_dd), assigned[s.ya_dd], f"10.y, {tex_escape(name)}"),
        ]
        eq10.append(
            {
                "name": tex_escape(name),
                "chain": chain[name],
                "joint": tex_escape(e.joint),
                "root": e.parent == GROUND,
                "slider": e.slider,
                "eq": eq_block(rows),
            }
        )

    # ---- (11) and the driver
    closure = []
    phi = prog.outputs["phi"]
    slot_rows = {(row.joint, row.kind): expr for expr, row in zip(phi, model.lam_rows) if row.kind.startswith("slot-")}
    explained: set = set()
    for expr, row in zip(phi, model.lam_rows):
        if row.kind == "slot-y":
            continue  # shown with its slot-x row
        if row.kind == "slot-x":
            sc = latex_slot.slot_closure(scene, model, row.joint)
            jn = tex_escape(row.joint)
            rows = [eq_row(pr, r"0", slot_rows[(row.joint, c)], f"11.{c[-1]}, {jn}") for c in ("slot-x", "slot-y")]
            closure.append({"text": sc["text"], "sym": sc["sym"], "star": sc["star"], "eq": eq_block(rows)})
            continue
        if row.kind == "inextensible":
            tag = f"IN, {tex_escape(row.joint)}"
            how = treatments[row.joint]
            first = row.joint not in explained
            explained.add(row.joint)
            if how.treatment == QUASI_STATIC:
                text = f"Quasi-static axial response of {tex_escape(row.joint)}" + (
                    f" ({tex_escape(how.reason)}): no axial vibration: the axial amplitudes follow the "
                    "bending through $(\\phi'_k, \\varepsilon) = 0$ (their inertia kept), the multiplier "
                    "$N_k$ is the axial force amplitude, and outputs of the bar's shape read the "
                    "amplitudes $f_k + N_k/\\lambda$ (the stretch $P\\varepsilon = N/\\lambda$)"
                    if first
                    else ", next row"
                )
            else:
                text = f"Inextensibility of {tex_escape(row.joint)}" + (
                    f" ({tex_escape(how.reason)}): $(\\phi'_k, \\varepsilon) = 0$, multiplier $N_k$ = "
                    "axial force amplitude"
                    if first
                    else ", next row"
                )
        elif row.kind == "driver":
            tag = f"KG, {tex_escape(row.loop[-1])}"
            text = (
                "Kinematic guidance: the input bar's prescribed angle (added to the closure "
                f"system, multiplier ${driver_force_tex(scene, row.loop[-1])}$ = driver torque)"
            )
        else:
            comp = {"pin-x": ".x", "pin-y": ".y", "slider": ""}[row.kind]
            tag = f"11{comp}, {tex_escape(row.joint)}"
            loop = " -- ".join(tex_escape(x) for x in row.loop)
            text = f"Cut {'pin' if row.kind.startswith('pin') else 'slider'} {tex_escape(row.joint)}, loop {loop}"
        closure.append({"text": text, "eq": eq_block([eq_row(pr, r"0", expr, tag)])})

    # ---- (13)
    joint_eqs = _joints_context(scene, model, pr)

    # ---- assembled
    defs_e = [_assembled_row(pr, sym, expr) for sym, expr in prog.group(GENERALIZED_FORCE)]
    defs_s = [eq_row(pr, pr(sym), expr) for sym, expr in prog.group(SUBTREE_FORCE)]
    residuals = []
    for k, (x, r) in enumerate(zip(model.q, prog.outputs["res"])):
        lhs = rf"\mathcal R_{{{pr(x)}}}"
        residuals.append(eq_row(pr, lhs, r, f"EoM.{k + 1}"))

    ctx = {
        "version": __version__,
        "scene_path": printable(Path(scene.path).name),
        "scene_path_tex": tex_escape(Path(scene.path).name),
        "hash": scene.hash[:12],
        "name": tex_escape(scene.name),
        "units": tex_escape(scene.units),
        "bodies": bodies,
        "scene_groups": scene_groups,
        "effects": effects,
        "strain_reason": _strain_reason(scene),
        "joints": joints,
        "drivers": drivers,
        "angle_driver": any(d.kind == "angle" for d in scene.drivers),
        "coords": coords,
        "multipliers": mult,
        "params": params,
        "bars": bars,
        "eq10": eq10,
        "closure": closure,
        "joint_eqs": joint_eqs,
        "defs_e": eq_block(defs_e),
        "defs_s": eq_block(defs_s),
        "residuals": eq_block(residuals),
        "loops": len(topo.cuts),
        "vk": eff.strain in VON_KARMAN,
        "slot_notes": latex_slot.slot_notes(scene, model),
        "rotary_notes": rotary_notes(scene, pr),
    }
    ctx["qs"] = latex_quasistatic.quasi_static_context(scene, model, pr)
    return _env().get_template("document.tex.jinja").render(**ctx)
