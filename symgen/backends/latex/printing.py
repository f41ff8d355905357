"""Printing helpers shared by the LaTeX sections (``document``, ``slot``, ``quasistatic``).

Text (``tex_escape``, ``rm``, ``num_text``), symbol names (``Namer``: the model's table of LaTeX
names), expressions (``Printer``, ``tex_lines``: floats to 6 significant digits, long sums and
products broken over lines, inside nested brackets and function arguments too, nothing
simplified), displayed equations (``Row``, ``eq_row``, ``term_row``, ``eq_block``), and what
every section shows of a bar's equations alike: the sides of a residual (``split_sides``), the
acceleration field (``kin_terms``) and the labels of the applied forces of the model's display
form (``shown_forces``). The section modules import this module only;
``document`` imports the sections.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import sympy as sp

from symgen.ir import names
from symgen.outputs import printable
from symgen.ir.names import Name
from symgen.model.bars import PointForce

LINE_WIDTH = 88  # estimated printed width of a full display line (units of printed_width)
TAG_WIDTH = 12  # room kept for an equation tag
LHS_MAX = 34  # a longer left side gets a line of its own
SIG_DIGITS = 6


# --------------------------------------------------------------------------- text helpers
_TEXT_ESCAPES = {
    "\\": r"\textbackslash{}",
    "_": r"\_",
    "%": r"\%",
    "&": r"\&",
    "#": r"\#",
    "$": r"\$",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\^{}",
}


def tex_escape(text: object) -> str:
    """Escape a string for LaTeX text mode (a character that is not printable, such as a line
    break in a file name, becomes a visible ``?``)."""
    return "".join(_TEXT_ESCAPES.get(c, c) for c in printable(text))


def rm(name: str) -> str:
    """An identifier as upright math text (underscores escaped), as ``symgen.ir.names`` writes it."""
    return names.upright(name)


def num_text(x: float | None) -> str:
    """A number for a table cell (math mode), 6 significant digits."""
    if x is None:
        return r"\text{--}"
    return sp.latex(_round_floats(sp.Float(float(x))))


# --------------------------------------------------------------------------- symbol names
class Namer:
    """The LaTeX name of each of a model's symbols, from the model's table (``model.latex``,
    made beside each symbol by ``symgen.ir.names``); :meth:`symbol` adds one made here.

    Symbols whose name already is LaTeX (display symbols such as the inner products
    ``\\left(\\phi_{1},\\psi_{1}\\right)`` or ``B_{\\mathrm{B}}``) print as they are;
    any other name prints upright.
    """

    def __init__(self, table: dict) -> None:
        self._table = dict(table)

    def symbol(self, name: Name, **assumptions) -> sp.Symbol:
        """The symbol of ``name``, its LaTeX name known from here on."""
        self._table[name.text] = name.latex
        return name.symbol(**assumptions)

    def __call__(self, name: str) -> str:
        hit = self._table.get(name)
        if hit is not None:
            return hit
        return name if name.startswith("\\") or "{" in name else rm(name)


# --------------------------------------------------------------------------- expressions
#: An exact fraction with a larger denominator is printed as a decimal: it is a double of the
#: scene made exact (0.4 is 3602879701896397/9007199254740992) or a product of such, never a
#: fraction a reader wants to see.
MAX_SHOWN_DENOMINATOR = 10**6


def _round_floats(expr: sp.Expr, digits: int = SIG_DIGITS) -> sp.Expr:
    """Floats to ``digits`` significant digits; integral floats (1.0, -2.0) to integers; exact
    fractions with a denominator above :data:`MAX_SHOWN_DENOMINATOR` as decimals like floats."""
    expr = sp.sympify(expr)
    floats = expr.atoms(sp.Float) | {r for r in expr.atoms(sp.Rational) if r.q > MAX_SHOWN_DENOMINATOR}
    if not floats:
        return expr
    rep = {}
    for f in floats:
        v = float(f)
        if abs(v - round(v)) <= 1e-12 * max(1.0, abs(v)):
            rep[f] = sp.Integer(int(round(v)))
        else:
            rep[f] = sp.Float(v, digits)
    return expr.xreplace(rep)


_STRIP = re.compile(
    r"\\(mathrm|operatorname|left|right|Bigl|Bigr|bigl|bigr|dot|ddot|bar|hat|"
    r"frac|tfrac|,|;|!|mathbf)(?![A-Za-z])"
)
_CMD = re.compile(r"\\[A-Za-z]+")
_FUNCS = {"sin", "cos", "tan", "exp", "log", "sinh", "cosh", "tanh", "max", "min", "mathcal"}


def printed_width(s: str) -> float:
    """Rough printed width of a LaTeX math string, in units of about one digit (5 pt at 10 pt).

    Commands count as one glyph (a few, like ``\\mathrm`` or ``\\left``, as none), sub- and
    superscripts at 0.7, binary operators with their spacing as 3.
    """
    s = _STRIP.sub("", s)
    s = s.replace(r"\quad", "QQ")
    s = _CMD.sub(lambda m: "xxx" if m[0][1:] in _FUNCS else "x", s)
    width, stack, i, pending = 0.0, [1.0], 0, None
    while i < len(s):
        c = s[i]
        scale = stack[-1]
        if c in "_^":
            pending = scale * 0.7
        elif c == "{":
            stack.append(pending if pending is not None else scale)
            pending = None
        elif c == "}":
            if len(stack) > 1:
                stack.pop()
        elif not c.isspace():
            cur = pending if pending is not None else scale
            pending = None
            width += (3.0 if c in "+-=" and cur == 1.0 else 1.0) * cur
        i += 1
    return width


class Printer:
    """LaTeX of expressions with the scene's symbol names and rounded floats."""

    def __init__(self, namer: Namer, width: float = LINE_WIDTH, subs: dict | None = None) -> None:
        self.namer, self.width, self.subs = namer, width, subs or {}

    def _tidy(self, expr):
        """``subs`` applied (e.g. a slot's beta as a positive symbol: Piecewise branches decided)."""
        return sp.sympify(expr).xreplace(self.subs) if self.subs else expr

    def __call__(self, expr) -> str:
        expr = _round_floats(self._tidy(expr))
        names = {s: self.namer(s.name) for s in expr.free_symbols if isinstance(s, sp.Symbol)}
        return sp.latex(expr, symbol_names=names, fold_func_brackets=True)

    def lines(self, expr, width: float | None = None) -> list[str]:
        """``expr`` split over several lines at sums, inside brackets (see :func:`tex_lines`)."""
        return tex_lines(_round_floats(self._tidy(expr)), self, self.width if width is None else width)


_DELIMS = [(r"\Bigl(", r"\Bigr)"), (r"\bigl[", r"\bigr]"), (r"\bigl\{", r"\bigr\}"), ("(", ")")]
_FUNC_TEX = {sp.sin: r"\sin", sp.cos: r"\cos", sp.tan: r"\tan", sp.sinh: r"\sinh", sp.cosh: r"\cosh", sp.tanh: r"\tanh"}


def _opened(factor: sp.Expr) -> tuple[str, sp.Expr, str] | None:
    """A factor that can be broken inside brackets as (text before the opening bracket, the
    expression inside, text after the closing bracket): a sum, a sum to a positive integer
    power, a trigonometric or hyperbolic function of a sum; None for any other factor."""
    if isinstance(factor, sp.Add):
        return "", factor, ""
    if isinstance(factor, sp.Pow) and isinstance(factor.base, sp.Add) and factor.exp.is_Integer and factor.exp > 1:
        return "", factor.base, f"^{{{factor.exp}}}"
    if factor.func in _FUNC_TEX and isinstance(factor.args[0], sp.Add):
        return _FUNC_TEX[factor.func], factor.args[0], ""
    return None


def tex_lines(
    expr: sp.Expr, printer, width: float = LINE_WIDTH, depth: int = 0, first: float | None = None
) -> list[str]:
    """LaTeX of ``expr`` as lines of at most about ``width`` printed characters (the first line
    at most ``first``, the room left on a line begun by the caller; default ``width``).

    Sums are broken between terms (continuation lines start with their sign). A product is
    written as its other factors followed by its bracketed factors (sums, powers of sums, sines
    and cosines of sums), shortest first; a bracketed factor that does not fit on a line already
    a third full goes on a line of its own, else it is broken inside its brackets
    (``\\Bigl( ... \\Bigr)``, then ``\\bigl[``, ``\\bigl\\{``, plain brackets as they nest),
    beginning on the current line when half a line is left there. Nothing is simplified or
    expanded: the lines hold the factors and terms of the unbroken LaTeX. Lines after the first
    are indented by the caller (one ``\\quad`` per nesting level is added here and counted in
    the width).
    """
    first = width if first is None else min(first, width)
    s = printer(expr)
    if printed_width(s) <= first:
        return [s]
    if isinstance(expr, sp.Add):
        out: list[str] = []
        cur = ""
        for i, term in enumerate(expr.as_ordered_terms()):
            neg = term.could_extract_minus_sign()
            body = -term if neg else term
            sign = "- " if neg else ("+ " if i else "")
            piece = sign + printer(body)
            limit = width if out else first
            if printed_width(cur) + 1 + printed_width(piece) <= limit:
                cur = f"{cur} {piece}" if cur else piece
                continue
            if cur and printed_width(piece) <= width:
                out.append(cur)
                cur = piece
                continue
            room = limit - printed_width(cur) - printed_width(sign) - 1
            if cur and room < width / 2:
                out.append(cur)
                cur, room = "", width - printed_width(sign)
            sub = tex_lines(body, printer, width, depth, room)
            cur = f"{cur} {sign}{sub[0]}".strip()
            if len(sub) > 1:
                out.append(cur)
                out.extend(sub[1:-1])
                cur = sub[-1]
        out.append(cur)
        return out
    factors = list(expr.args) if isinstance(expr, sp.Mul) else [expr]
    opened = [f for f in factors if _opened(f) is not None]
    if not opened:
        return [s]
    others = sp.Mul(*[f for f in factors if _opened(f) is None])
    head = "" if others == 1 else ("-" if others == -1 else printer(others))
    op, cl = _DELIMS[min(depth, len(_DELIMS) - 1)]
    lines = [head]
    for f in sorted(opened, key=lambda f: (printed_width(printer(f)), printer(f))):
        before, inside, after = _opened(f)  # type: ignore[misc]
        whole = printer(f)
        if isinstance(f, sp.Add):
            whole = rf"\left({whole}\right)"
        limit = first if len(lines) == 1 else width
        if printed_width(lines[-1]) + 1 + printed_width(whole) <= limit:
            lines[-1] = f"{lines[-1]} {whole}".strip()
            continue
        if printed_width(whole) + 2 <= width and printed_width(lines[-1]) > width / 3:
            lines.append(rf"\quad {whole}")
            continue
        room = limit - printed_width(lines[-1]) - printed_width(before) - 3
        if room < width / 2 and lines[-1].strip() not in ("", "-", r"\quad"):
            lines.append(r"\quad")
            room = width - 2 - printed_width(before) - 3
        inner = tex_lines(inside, printer, width - 2, depth + 1, room)
        lines[-1] = f"{lines[-1]} {before} {op} {inner[0]}".replace("  ", " ").strip()
        lines += [r"\quad " + x for x in inner[1:]]
        lines[-1] += f" {cl}{after}"
    return lines


@dataclass
class Row:
    """One displayed equation: ``lhs = lines`` (rhs broken over lines), optional tag."""

    lhs: str
    lines: list
    tag: str | None = None
    rel: str = "="

    def tex(self) -> str:
        out = []
        for k, line in enumerate(self.lines):
            if k == 0:
                t = f"{self.lhs} &{self.rel} {line}"
                t += rf" \tag{{{self.tag}}}" if self.tag else ""
            else:
                t = rf"&\quad {line}"
            out.append(t)
        return " \\\\\n".join(out)


class _RawRow(Row):
    """Rows already laid out (a long left side on lines of its own)."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__("", lines)

    def tex(self) -> str:
        return " \\\\\n".join(self.lines)


def eq_block(rows: list[Row]) -> str:
    return " \\\\\n".join(r.tex() for r in rows)


def eq_row(pr: Printer, lhs, rhs, tag: str | None = None) -> Row:
    """``lhs = rhs`` with the right side broken to fit beside the left side and the tag.

    ``lhs`` is LaTeX or an expression; a left side too long to share a line becomes a
    left-aligned block of its own lines followed by ``= rhs``.
    """
    avail = LINE_WIDTH - (TAG_WIDTH if tag else 0)
    if isinstance(lhs, str):
        lhs_lines = [lhs]
    else:
        lhs_lines = pr.lines(lhs, avail - 4) if lhs != 0 else ["0"]
    if len(lhs_lines) == 1 and printed_width(lhs_lines[0]) <= LHS_MAX:
        return Row(lhs_lines[0], pr.lines(rhs, max(avail - printed_width(lhs_lines[0]) - 3, 40)), tag)
    rr = pr.lines(rhs, avail - 8)
    lines = [f"&{lhs_lines[0]}" + (rf" \tag{{{tag}}}" if tag else "")]
    lines += [rf"&\quad {x}" for x in lhs_lines[1:]]
    lines += [rf"&\quad = {rr[0]}"] + [rf"&\qquad {x}" for x in rr[1:]]
    return _RawRow(lines)


def _pack(terms: list[str], width: float) -> list[str]:
    """Join LaTeX terms (each with its leading sign) into lines of about ``width``."""
    out, cur = [], ""
    for t in terms:
        if cur and printed_width(cur) + printed_width(t) > width:
            out.append(cur)
            cur = t
        else:
            cur = f"{cur} {t}" if cur else t
    out.append(cur)
    return out


def term_row(lhs: list[str], rhs: list[str], tag: str | None = None) -> Row:
    """Like :func:`eq_row` for sides given as lists of LaTeX terms."""
    avail = LINE_WIDTH - (TAG_WIDTH if tag else 0)
    lhs_lines = _pack(lhs, avail - 4)
    if len(lhs_lines) == 1 and printed_width(lhs_lines[0]) <= LHS_MAX:
        return Row(lhs_lines[0], _pack(rhs, max(avail - printed_width(lhs_lines[0]) - 3, 40)), tag)
    rr = _pack(rhs, avail - 8)
    lines = [f"&{lhs_lines[0]}" + (rf" \tag{{{tag}}}" if tag else "")]
    lines += [rf"&\quad {x}" for x in lhs_lines[1:]]
    lines += [rf"&\quad = {rr[0]}"] + [rf"&\qquad {x}" for x in rr[1:]]
    return _RawRow(lines)


# --------------------------------------------------------------------------- bar equations
def split_sides(expr: sp.Expr, elastic: set, external: set, rho_pair) -> tuple:
    """Split a residual ``inertia + internal - external`` into (paper left side, right side).

    The paper writes loads and elastic forces on the left and inertia on the right:
    ``left = -(internal + external terms)``, ``right = inertia terms``. A rotary-inertia term
    (mu/lambda) is inertia.
    """
    left, right = [], []
    for term in sp.Add.make_args(sp.sympify(expr)):
        free = term.free_symbols
        if rho_pair is not None and {rho_pair[0], rho_pair[1]} <= free:
            mu, lam, rho = rho_pair
            right.append(term.subs(mu / lam, rho))
        elif free & elastic or free & external:
            left.append(-term)
        else:
            right.append(term)
    return sp.Add(*left), sp.Add(*right)


def equation_rows(pr: Printer, exprs, tags, elastic: set, external: set, rho_pair, used: set) -> list[Row]:
    """One row per residual, split into the paper's two sides (``split_sides``); the symbols
    the rows print join ``used`` (the inner-product table lists those)."""
    out = []
    for e, tag in zip(exprs, tags):
        used.update(e.free_symbols)
        left, right = split_sides(e, elastic, external, rho_pair)
        out.append(eq_row(pr, left, right, tag))
    return out


def point_label(p: PointForce, scene, used: set) -> str:
    """The label K of a point force in B_K, Gamma_K: its joint (cut-joint reaction), the joint
    and ",m" (a lumped mass), M1, M2, ... (a ``[[masses]]`` entry), else its position; made unique within ``used`` (which it joins)."""
    used_names = {s.name for part in (p.ground or p.bar or ()) for s in sp.sympify(part).free_symbols}
    label = None
    for j in scene.joints:
        if {names.joint_force(j.name, ax).text for ax in ("x", "y", None)} & used_names:
            label = rm(j.name)
            break
        if names.joint_parameter("m", j.name).text in used_names:
            label = rm(j.name) + r",m"
            break
    for i in range(len(getattr(scene, "masses", ())) if label is None else 0):
        if names.mass_parameter("m", i).text in used_names:
            label = rf"\mathrm{{M}}{i + 1}"
            break
    if label is None:
        label = rf"\xi={num_text(p.xi)}"
    base, k = label, 2
    while label in used:
        label, k = f"{base},{k}", k + 1
    used.add(label)
    return label


def kin_terms(s: dict, na: int, nt: int, coriolis: bool) -> tuple[list, list]:
    """Right sides of (1) / (8)-(9): the acceleration field in bar axes over l_i w^2."""
    B = s["B"]
    ax = [rf"[\ddot x_A]_{{{B}}}"]
    ay = [rf"[\ddot y_A]_{{{B}}}"]
    pos = rf"(\xi + \zeta_{{{B}}})" if na else r"\xi"
    if na:
        ax.append(rf"+ \ddot\zeta_{{{B}}}")
    if nt and coriolis:
        ax.append(rf"- 2\dot\theta_{{{B}}}\dot\eta_{{{B}}}")
    if nt:
        ax.append(rf"- \ddot\theta_{{{B}}}\eta_{{{B}}}")
    ax.append(rf"- \dot\theta_{{{B}}}^{{2}}{pos}")
    if nt:
        ay.append(rf"+ \ddot\eta_{{{B}}}")
    if na and coriolis:
        ay.append(rf"+ 2\dot\theta_{{{B}}}\dot\zeta_{{{B}}}")
    ay.append(rf"+ \ddot\theta_{{{B}}}{pos}")
    if nt:
        ay.append(rf"- \dot\theta_{{{B}}}^{{2}}\eta_{{{B}}}")
    return ax, ay


@dataclass
class ShownForces:
    """The applied forces of a bar's display form as a section shows them."""

    relabel: dict = field(default_factory=dict)  # display symbol (B_k, Gamma_k) -> B_K, Gamma_K
    point_defs: list = field(default_factory=list)  # rows B_K = ..., Gamma_K = ...
    load_defs: list = field(default_factory=list)  # rows beta-bar = ..., gamma-bar = ...
    points: list = field(default_factory=list)  # (B, Gamma, xi as LaTeX) of every point force
    loads: tuple = ()  # (beta-bar, gamma-bar) symbols, or ()
    external: set = field(default_factory=set)  # symbols of the applied forces (left side)
    reactions: set = field(default_factory=set)  # B_K, Gamma_K of the forces given in ground axes

    def show(self, expr: sp.Expr) -> sp.Expr:
        """An expression of the display form with the labelled symbols."""
        return sp.sympify(expr).xreplace(self.relabel)


def shown_forces(scene, bm, pr: Printer, reserved: tuple = (), definitions: bool = True) -> ShownForces:
    """Label the point forces and loads of bar ``bm``'s display form (``bm.equations``).

    A point force given in ground axes (a reaction, a lumped mass) is the display symbol pair
    (B_k, Gamma_k) of the model, renamed B_K, Gamma_K after its joint (``point_label``; labels in
    ``reserved`` are taken) and defined by its value in the model (``bars.point_force_groups``);
    one given in bar axes (a point load) shows as given. The distributed loads are the model's
    (beta-bar, gamma-bar), defined by their values (rows left out with ``definitions=False``).
    """
    eqs = bm.equations
    out = ShownForces(loads=tuple(eqs.loads))
    used = set(reserved)
    for p, (B, G) in zip(bm.inputs["points"], eqs.points):
        label = point_label(p, scene, used)
        if p.ground is not None:
            Bs, Gs = sp.Symbol(rf"B_{{{label}}}"), sp.Symbol(rf"\Gamma_{{{label}}}")
            out.relabel.update({B: Bs, G: Gs})
            if definitions:
                out.point_defs += [eq_row(pr, pr(Bs), eqs.values[B]), eq_row(pr, pr(Gs), eqs.values[G])]
            out.reactions |= {Bs, Gs}
            B, G = Bs, Gs
        out.external |= sp.sympify(B).free_symbols | sp.sympify(G).free_symbols
        out.points.append((B, G, num_text(p.xi)))
    for sym in out.loads:
        if definitions:
            out.load_defs.append(eq_row(pr, pr(sym), eqs.values[sym]))
        out.external.add(sym)
    return out


# --------------------------------------------------------------------------- drivers
def driven_text(scene, body: str) -> str:
    """What a driver applies to bar ``body`` (empty: the bar is not driven)."""
    for i, drv in enumerate(scene.drivers):
        if drv.body == body:
            if drv.kind == "angle":
                return rf"the driver torque ${names.driver_force(i).latex}$"
            return rf"the applied moment ${torque_tex(i)}$ (12)"
    return ""


def driver_force_tex(scene, body: str) -> str:
    """The multiplier of the angle driver of bar ``body``: Lambda_drv (the first driver), Lambda_{drv,i+1}."""
    i = next(k for k, d in enumerate(scene.drivers) if d.body == body)
    return names.driver_force(i).latex


def torque_tex(i: int) -> str:
    """The applied moment of torque driver ``i``: M_0 (the first driver), M_{0,i+1}."""
    return "M_0" if i == 0 else names.driver_parameter("torque", i).latex
