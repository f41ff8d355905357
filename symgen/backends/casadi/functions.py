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

from symgen.backends.casadi.store import CALL_NAMES, FUNCTION_NAMES, INPUT_NAMES, load, save  # noqa: F401  (re-exported)

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


def output_functions(prog, sx: dict, conv: SympyToCasadi, names: tuple = FUNCTION_NAMES) -> dict:
    """The Functions ``names`` (of ``FUNCTION_NAMES``) of the program's outputs, converted by
    ``conv`` (its environment holding the assignments), of the inputs ``sx``."""
    args = [sx[n] for n in INPUT_NAMES]
    funcs = {}
    for fname in names:
        exprs = prog.outputs[fname]
        vec = ca.vertcat(*[conv(e) for e in exprs]) if exprs else ca.SX(0, 1)
        funcs[fname] = ca.Function(fname, args, [vec], list(INPUT_NAMES), [fname], {"cse": True})
    return funcs


def build_functions(model) -> dict:
    """CasADi Functions of a ``DerivedModel`` (see module docstring); where the bars' blocks pay
    (:func:`paying_blocks`), with the Functions ``CALL_NAMES`` of :func:`call_functions` too."""
    prog = model.program
    sx, env = input_symbols(prog)
    conv = SympyToCasadi(env)
    for sym, expr in prog.assignments:
        conv.env[sym] = conv(expr)
    out = output_functions(prog, sx, conv)
    blocks = paying_blocks(model)
    if blocks:
        out.update(call_functions(model, blocks, (sx, conv.env)))
    return out


#: The strains whose bar blocks a runner evaluates as calls (:func:`paying_blocks`)
CALL_STRAINS = ("exact",)


def paying_blocks(model) -> list:
    """The program's blocks a runner evaluates as calls: those of 2+ bars of the exact strain.
    Measured (benchmarks/RESULTS.md, "One Function per bar structure"): exact chains, 12 bars, the
    library's C -40 %, its compile CPU -50 %, the runner's construction -45..-60 %, the step the
    inline one's; von Karman chains gain nothing by 12 bars (the chain rule's kinematic products
    dominate), so their blocks stay inline."""
    effects = model.structure.get("effects", {}) if isinstance(model.structure, dict) else {}
    if effects.get("strain") not in CALL_STRAINS:
        return []
    return [b for b in model.program.blocks if len(b.calls) >= 2]


def call_functions(model, blocks, inline: tuple[dict, dict] | None = None) -> dict:
    """The Functions ``CALL_NAMES``: ``res_E`` and ``out_E`` of (t, q, v, a, lam, p, E) (the
    blocks' outputs E as an input, stacked as ``BlockFunctions.outputs``), ``xin`` of (t, q, v, a,
    lam, p) (the calls' stacked inputs X), ``bars`` (E of X: each call one call node of its block's
    Function) and ``jac_bars`` (dE/dX, block diagonal: one call of each block's Jacobian per call).
    So res = res_E(w, bars(xin(w))) and its Jacobian is the chain rule
    res_E_w + res_E_E . jac_bars . xin_w (``numerics.simulate``). ``inline``: the inline
    conversion's (input symbols, environment), whose assignments free of E are reused
    (:func:`split_functions`)."""
    split, bf = split_functions(model, blocks, inline, ("res", "out"))
    prog = model.program
    ins = [ca.SX.sym(n, len(prog.inputs[n])) for n in INPUT_NAMES]
    E = ca.SX.sym("E", len(bf.outputs))
    out = {}
    for name in ("res", "out"):
        expr = split[name](*ins[:5], ca.vertcat(ins[5], E))
        out[f"{name}_E"] = ca.Function(f"{name}_E", [*ins, E], [expr], [*INPUT_NAMES, "E"], [name], {"cse": True})
    out["xin"] = split["xin"]
    X = ca.SX.sym("X", split["xin"].size1_out(0))
    Ek, Jk = _called(bf, X)
    out["bars"] = ca.Function("bars", [X], [ca.vertcat(*Ek)], ["X"], ["E"])
    out["jac_bars"] = ca.Function("jac_bars", [X], [ca.diagcat(*Jk)], ["X"], ["jac_E_X"])
    return out


#: the options of a block's Function and its Jacobian's: call nodes, never inlined into the caller
BLOCK_OPTS: dict = {"never_inline": True, "cse": True}


class BlockFunctions:
    """A program's blocks (``Program.blocks``) as CasADi Functions: per block ``bar_<k>`` (the
    block's outputs of its stacked inputs) and its Jacobian ``jac_bar_<k>``, and per call the
    program symbols it assigns and those it reads."""

    def __init__(self, blocks) -> None:
        self.blocks = list(blocks)
        self.functions: list[ca.Function] = []
        self.jacobians: list[ca.Function] = []
        for k, b in enumerate(self.blocks):
            xin = ca.SX.sym(f"in_{k}", len(b.inputs))
            conv = SympyToCasadi({x: xin[i] for i, x in enumerate(b.inputs)})
            out = ca.vertcat(*[conv(e) for e in b.outputs])
            self.functions.append(ca.Function(f"bar_{k}", [xin], [out], dict(BLOCK_OPTS)))
            self.jacobians.append(ca.Function(f"jac_bar_{k}", [xin], [ca.jacobian(out, xin)], dict(BLOCK_OPTS)))
        #: (block index, call) in the blocks' order
        self.calls = [(k, c) for k, b in enumerate(self.blocks) for c in b.calls]
        self.assigned = {x: (k, c) for k, c in self.calls for x in c.assigns}

    @property
    def outputs(self) -> list:
        """The program symbols the calls assign, stacked in the calls' order."""
        return [x for _, c in self.calls for x in c.assigns]


def build_functions_with_calls(model, blocks=None) -> dict:
    """``build_functions`` with the generalized forces of each block's bars as calls of the
    block's Function (``BlockFunctions``; ``blocks``: the program's by default): the same
    expressions converted, so the same values, with each block's terms written once."""
    prog = model.program
    bf = BlockFunctions(prog.blocks if blocks is None else blocks)
    sx, env = input_symbols(prog)
    conv = SympyToCasadi(env)
    for sym, expr in prog.assignments:
        hit = bf.assigned.get(sym)
        if hit is None:
            conv.env[sym] = conv(expr)
        elif sym not in conv.env:
            k, c = hit
            outs = bf.functions[k](ca.vertcat(*[conv.env[x] for x in c.inputs]))
            for i, x in enumerate(c.assigns):
                conv.env[x] = outs[i]
    return output_functions(prog, sx, conv)


def split_functions(
    model, blocks=None, inline: tuple[dict, dict] | None = None, names: tuple = FUNCTION_NAMES
) -> tuple[dict, BlockFunctions]:
    """The Functions ``FUNCTION_NAMES`` with the blocks' outputs E as inputs: of (t, q, v, a, lam,
    [p; E]) (E stacked as ``BlockFunctions.outputs``), and ``xin`` of (t, q, v, a, lam, p): the
    calls' stacked inputs X. With these a Jacobian is the chain rule over the blocks' own
    Jacobians: dF/dw = F_w + F_E . blockdiag(jac_bar(X_c)) . dX/dw (:func:`chain_jacobian`).

    ``inline``: the input symbols and the environment of the inline conversion
    (:func:`build_functions`): its symbols are these Functions' (p those of the model's p), and
    each assignment that reads no E, directly or through others, is its conversion there (the same
    expression: converted once; measured in benchmarks/RESULTS.md, "Callees compiled once").
    ``names``: the Functions wanted (``call_functions`` uses ``res`` and ``out`` alone)."""
    prog = model.program
    bf = BlockFunctions(prog.blocks if blocks is None else blocks)
    E = bf.outputs
    n_p = len(prog.inputs["p"])
    if inline is None:
        sx = {name: ca.SX.sym(name, len(prog.inputs[name])) for name in INPUT_NAMES if name != "p"}
        p0 = ca.SX.sym("p", n_p)
    else:
        sx = {name: v for name, v in inline[0].items() if name != "p"}
        p0 = inline[0]["p"]
    sx["p"] = ca.vertcat(p0, ca.SX.sym("E", len(E)))
    env = {}
    for name in INPUT_NAMES:
        for k, s in enumerate(prog.inputs[name]):
            env[s] = sx[name][k]
    env.update({x: sx["p"][n_p + k] for k, x in enumerate(E)})
    conv = SympyToCasadi(env)
    reads_e = set(E)  # the assignments that read an E, directly or through others
    for sym, expr in prog.assignments:
        if sym in bf.assigned:
            continue
        if inline is not None and sym in inline[1] and reads_e.isdisjoint(expr.free_symbols):
            conv.env[sym] = inline[1][sym]
            continue
        reads_e.add(sym)
        conv.env[sym] = conv(expr)
    out = output_functions(prog, sx, conv, names)
    X = ca.vertcat(*[conv.env[x] for _, c in bf.calls for x in c.inputs])
    xin_args = [sx[n] for n in INPUT_NAMES[:-1]] + [p0]  # X is kinematics: of the model's p, not of E
    out["xin"] = ca.Function("xin", xin_args, [X], list(INPUT_NAMES), ["xin"], {"cse": True})
    return out, bf


def _called(bf: BlockFunctions, X: ca.SX) -> tuple[list, list]:
    """Each bar's E and its Jacobian, as calls of its block's Functions on its slice of the
    stacked callee inputs ``X`` (``xin``)."""
    Ek, Jk, o = [], [], 0
    for k, c in bf.calls:
        n = len(c.inputs)
        Ek.append(bf.functions[k](X[o : o + n]))
        Jk.append(bf.jacobians[k](X[o : o + n]))
        o += n
    return Ek, Jk


def chain_jacobian(split: dict, bf: BlockFunctions, name: str, args: list, wrt: ca.SX) -> tuple:
    """(F, dF/d wrt) of the Function ``name`` of :func:`split_functions` at the SX ``args``
    (t, q, v, a, lam, p: expressions of ``wrt``), the blocks as calls: F_E and the kinematics'
    dX/dw inline, each call's Jacobian one call of its block's ``jac_bar``."""
    X = split["xin"](*args)
    Es = ca.SX.sym("E", len(bf.outputs))
    Ek, Jk = _called(bf, X)
    inner = split[name](*args[:5], ca.vertcat(args[5], Es))
    J = ca.jacobian(inner, wrt) + ca.mtimes(ca.jacobian(inner, Es), ca.mtimes(ca.diagcat(*Jk), ca.jacobian(X, wrt)))
    E = ca.vertcat(*Ek) if Ek else ca.SX(0, 1)
    F, dF = ca.substitute([inner, J], [Es], [E])
    return F, dF
