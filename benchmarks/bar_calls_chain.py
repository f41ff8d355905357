"""Prototype (benchmarks only) of ``bench_bar_calls.py``: each bar structure's generalized forces
as one CasADi Function (``never_inline``: a call node in the SX graph) called per bar
(``build_functions``, ``bar_calls``), and the runner whose Jacobians go through each bar
structure's own Jacobian Function (chain rule, ``runner``) instead of CasADi's AD through the call
nodes. With the bar forces E as symbols the rest of the residual R(w, E) is SX inline; E_k =
bar_S(X_k(w)) and

    dR/dw = R_w + R_E . blockdiag(J_S(X_k)) . dX/dw,

one call of ``bar_S`` and one of its Jacobian ``jac_bar_S`` per bar and evaluation. ``same_jacobian``:
the virtual machine's IDAS gets that Jacobian too (an MX oracle calling ``dae``, whose
``custom_jacobian`` is ``jac_dae``), as the compiled library's ``external`` does."""

from __future__ import annotations

import casadi as ca

from symgen.backends.casadi.functions import SympyToCasadi, input_symbols, output_functions
from symgen.backends.casadi.store import INPUT_NAMES
from symgen.numerics.index1 import index1

#: the options of a bar structure's Function
CALLEE_OPTS: dict = {"never_inline": True, "cse": True}


def build_functions(model) -> dict:
    """``functions.build_functions`` with each bar structure's generalized forces as one Function
    called per bar (a call node)."""
    prog = model.program
    sx, env = input_symbols(prog)
    conv = SympyToCasadi(env)
    shared = bar_calls(model)
    for sym, expr in prog.assignments:
        if sym in shared:
            if sym not in conv.env:
                call = shared[sym]
                outs = call.callee(ca.vertcat(*[conv.env[x] for x in call.args]))
                for k, e in enumerate(call.outputs):
                    conv.env[e] = outs[k]
            continue
        conv.env[sym] = conv(expr)
    return output_functions(prog, sx, conv)


class _Call:
    """One bar's generalized forces ``outputs`` (program symbols) as ``callee(args)``."""

    def __init__(self, callee: ca.Function, args: list, outputs: list, sx: tuple) -> None:
        self.callee, self.args, self.outputs = callee, args, outputs
        self.sx = sx  # (the callee's input, its output expression): what its Jacobian is made of


def bar_calls(model) -> dict:
    """program symbol -> :class:`_Call` for the generalized forces E of every bar whose E are those
    of an earlier bar of the same structure with that bar's symbols renamed (``bars.renamed``):
    both are calls of one Function made from the first bar's E (never inlined). A bar whose E
    differ otherwise (a slot's contact force, a lumped rotary inertia, its own loads) stays inline."""
    from symgen.ir import names
    from symgen.ir.records import GENERALIZED_FORCE
    from symgen.model.bars import _OWN, renamed

    assigned = {sym: e for sym, e in model.program.assignments if model.program.groups.get(sym) == GENERALIZED_FORCE}

    def forces(bar: str, s) -> list:
        parts = [names.generalized_force(ax, bar) for ax in "XY"] + [names.generalized_force("th", bar)]
        parts += [names.generalized_force("f", bar, k) for k in range(len(s.f))]
        parts += [names.generalized_force("g", bar, k) for k in range(len(s.g))]
        syms = [p.symbol() for p in parts]
        return syms if all(x in assigned for x in syms) else []

    def own(bar: str, s) -> list:
        out: list = []
        for name in _OWN:
            v = getattr(s, name)
            out += list(v) if isinstance(v, tuple) else ([] if v is None else [v])
        out += [names.origin_velocity(ax, bar).symbol() for ax in "xy"]
        return out

    templates: list = []  # (first bar's E symbols, its own symbols, the callee, its args, sx)
    made: dict = {}
    for bar, bm in model.bars.items():
        s = getattr(bm, "sym", None)
        if s is None or s.beta:
            continue
        E = forces(bar, s)
        if not E:
            continue
        mine = own(bar, s)
        hit = None
        for E0, own0, callee, args0, sx0 in templates:
            if len(E0) != len(E) or len(own0) != len(mine):
                continue
            rule = dict(zip(own0, mine))
            memo: dict = {}
            if all(renamed(assigned[a], rule, memo) == assigned[b] for a, b in zip(E0, E)):
                hit = (callee, [rule.get(x, x) for x in args0], sx0)
                break
        if hit is None:
            free = sorted(set().union(*[assigned[x].free_symbols for x in E]), key=str)
            xin = ca.SX.sym(f"in_{bar}", len(free))
            sub = SympyToCasadi({x: xin[k] for k, x in enumerate(free)})
            expr = ca.vertcat(*[sub(assigned[x]) for x in E])
            callee = ca.Function(f"bar{len(templates)}", [xin], [expr], dict(CALLEE_OPTS))
            templates.append((E, mine, callee, free, (xin, expr)))
            hit = (callee, free, (xin, expr))
        call = _Call(hit[0], hit[1], E, hit[2])
        made.update({x: call for x in E})
    return made


def split_functions(model):
    """(Functions of (t, q, v, a, lam, [p; E]) with the bar forces E as symbols, ``xin`` (the
    callees' stacked inputs), the calls in order)."""
    prog = model.program
    calls = bar_calls(model)
    uniq, seen = [], set()
    for sym, _ in prog.assignments:
        c = calls.get(sym)
        if c is not None and id(c) not in seen:
            seen.add(id(c))
            uniq.append(c)
    E_syms = [e for c in uniq for e in c.outputs]
    n_p = len(prog.inputs["p"])
    sx = {name: ca.SX.sym(name, len(prog.inputs[name])) for name in INPUT_NAMES if name != "p"}
    pE = ca.SX.sym("pE", n_p + len(E_syms))
    sx["p"] = pE
    env = {}
    for name in INPUT_NAMES:
        for k, s in enumerate(prog.inputs[name]):
            env[s] = sx[name][k]
    for k, e in enumerate(E_syms):
        env[e] = pE[n_p + k]
    conv = SympyToCasadi(env)
    for sym, expr in prog.assignments:
        if sym not in calls:
            conv.env[sym] = conv(expr)
    out = output_functions(prog, sx, conv)
    X = ca.vertcat(*[conv.env[x] for c in uniq for x in c.args])
    out["xin"] = ca.Function("xin", [sx[n] for n in INPUT_NAMES], [X])
    return out, uniq, len(E_syms)


def runner(model, mech, part, same_jacobian: bool = False) -> dict:
    """dae, jac_dae, g of ``simulate._symbolic`` / ``_dae_jacobian`` by the chain rule (split, rec
    as there)."""
    from symgen.numerics import simulate as sim

    fE, uniq, nE = split_functions(model)
    jacs: dict = {}
    for c in uniq:
        f = c.callee
        if f.name() not in jacs:
            xi, e = c.sx
            jacs[f.name()] = ca.Function(
                f"jac_{f.name()}", [xi], [ca.jacobian(e, xi)], {"never_inline": True, "cse": True}
            )
    n, m = mech.n, mech.m
    I = list(part.ind)
    nI = len(I)
    s = index1(n, m, part)
    t, x, z = ca.SX.sym("t"), s.x, s.z
    p = ca.SX.sym("p", len(mech.p) + 1)
    u = ca.SX.sym("u", 0)
    Es = ca.SX.sym("Es", nE)
    tt = t + p[-1]
    pE = ca.vertcat(p[:-1], Es)
    args = [tt, s.q, s.v, s.a, s.lam, pE]
    alg = s.alg(fE, tt, pE)
    ode = ca.vertcat(x[nI:], s.a[I] if I else ca.SX(0, 1))
    X = fE["xin"](*args)
    Jk, Ek, o = [], [], 0
    for c in uniq:
        k = len(c.args)
        Jk.append(jacs[c.callee.name()](X[o : o + k]))
        Ek.append(c.callee(X[o : o + k]))
        o += k
    B = ca.diagcat(*Jk)
    JE = ca.jacobian(alg, Es)
    dae_in = [t, x, z, p, u]
    dae_out = [ode, alg, ca.SX(0, 1), ca.SX(0, 1)]
    blocks, names = [], []
    for ko, e in zip(ca.dyn_out(), dae_out):
        for ki, w in zip(ca.dyn_in(), dae_in):
            J = ca.jacobian(e, w)
            if ko == "alg" and w.numel():
                J = J + ca.mtimes(JE, ca.mtimes(B, ca.jacobian(X, w)))
            blocks.append(J)
            names.append(f"jac_{ko}_{ki}")
    tmp = ca.Function("tmp", [*dae_in, Es], [ode, alg, *blocks])
    full = tmp.call([*dae_in, ca.vertcat(*Ek)])
    ode_f, alg_f, jb = full[0], full[1], full[2:]
    dae = ca.Function(
        "dae", dae_in, [ode_f, alg_f, ca.SX(0, 1), ca.SX(0, 1)], ca.dyn_in(), ca.dyn_out(), {"ad_weight": sim.AD_WEIGHT}
    )
    nominal = [ca.SX.sym(f"out_{k}", e.shape) for k, e in zip(ca.dyn_out(), dae_out)]
    jac = ca.Function("jac_dae", dae_in + nominal, jb, ca.dyn_in() + [f"out_{k}" for k in ca.dyn_out()], names)
    alg_z = jb[names.index("jac_alg_z")]
    base = sim._symbolic(mech, part)
    out = {
        "dae": dae,
        "jac_dae": jac,
        "g": ca.Function("g", [t, x, z, p], [alg_f, alg_z]),
        "split": base["split"],
        "rec": base["rec"],
    }
    if same_jacobian:
        # the virtual machine's IDAS with the library's Jacobian: an MX oracle calling ``dae``, whose
        # Jacobian is ``jac_dae`` (CasADi's factory of an SX oracle would differentiate it itself)
        for name in sim.COMPILED:
            out[f"compiled:{name}"] = sim._shared(out[name])
        cj = out["compiled:jac_dae"]
        opts = {"custom_jacobian": cj, "jac_penalty": 0, "never_inline": True, "ad_weight": sim.AD_WEIGHT}
        inner = ca.Function(
            "dae",
            out["compiled:dae"].sx_in(),
            out["compiled:dae"].call(out["compiled:dae"].sx_in()),
            ca.dyn_in(),
            ca.dyn_out(),
            opts,
        )
        mx = [ca.MX.sym(n, inner.sparsity_in(i)) for i, n in enumerate(ca.dyn_in())]
        out["dae"] = ca.Function("dae_vm", mx, inner.call(mx), ca.dyn_in(), ca.dyn_out())
    return out
