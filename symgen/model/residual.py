"""The residual of every coordinate by virtual work through the spanning tree.

For each bar (tree order) the program first assigns [x_A'']_i, [y_A'']_i of (10), then the
bar's generalized forces E (its equations (16)-(17) and rigid-body equations from
``symgen.model.bars``, plus a slot's contact force and the lumped rotary inertias it carries).
The subtree resultants S of the tree joints (leaves first) are the reactions a bar's parent
exerts on it, summed from the bars beyond: route 2 of the seed, they never become unknowns.
The residual of a coordinate of bar i is then

    res = E_i,q - (d rho_i(xi_K) / d q) . S_i + sum over children c of (d rho_i(xi_c) / d q) . S_c

(minus the driver's moment and plus its rotor's J theta'' on the driven angle), and the
residual of a slider's travel is d . S of the bar on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from symgen.ir import names
from symgen.ir.records import (
    GENERALIZED_FORCE,
    ORIGIN_ACCELERATION,
    SUBTREE_FORCE,
    Block,
    BlockCall,
    CoordKind,
    Coordinate,
    Program,
)
from symgen.model.bars import SharedBarEquations
from symgen.model.constraints import Constraints
from symgen.model.kinematics import TreeKinematics
from symgen.model.loads import Loads
from symgen.model.rotary import add_lumped_rotary
from symgen.model.topology import Topology


@dataclass(frozen=True)
class BarForces:
    """The generalized forces E of one bar (program symbols, common units)."""

    XY: tuple  # resultant force, ground axes
    th: sp.Symbol
    f: list
    g: list
    beta: sp.Symbol | None = None

    def of(self, c: Coordinate) -> sp.Symbol:
        """E of the bar's own coordinate ``c`` (theta, an amplitude, a slot's beta)."""
        if c.kind is CoordKind.THETA:
            return self.th
        if c.kind is CoordKind.F:
            return self.f[c.index]
        if c.kind is CoordKind.G:
            return self.g[c.index]
        if c.kind is CoordKind.BETA:
            return self.beta
        raise ValueError(f"{c.kind!r} is not a coordinate of a bar")


def generalized_forces(
    prog: Program,
    topo: Topology,
    bars: dict,
    tree: TreeKinematics,
    effects,
    loads: Loads,
    cons: Constraints,
    axial_force: dict,
) -> dict:
    """bar -> :class:`BarForces`: (10) and the bar equations of every bar, in tree order,
    assigned in ``prog``; each ``BarModel`` keeps its ``equations`` and their ``inputs``."""
    E: dict[str, BarForces] = {}
    bar_equations = SharedBarEquations()  # bars of one structure: derived once
    plain: set[str] = set()  # the bars whose E are their equations' own (no slot force, no lumped inertia)
    for name in topo.order:
        bm = bars[name]
        s = bm.sym
        acc = tree.origin_acc_local(name)
        prog.add(s.xa_dd, acc[0], ORIGIN_ACCELERATION)
        prog.add(s.ya_dd, acc[1], ORIGIN_ACCELERATION)
        bm.inputs = {
            "loads": tuple(loads.distributed[name]),
            "points": tuple(cons.point_forces[name]) + tuple(loads.points[name]),
            "gravity": loads.gravity,
            "damping": loads.damping,
        }
        if name in axial_force:
            bm.inputs["axial_force"] = axial_force[name]
        bm.equations = bar_equations(s, bm.basis_a, bm.basis_t, bm.ipt, effects, **bm.inputs)
        gen = bm.equations.generalized()
        if name not in cons.slot_force and not loads.rotary[name]:
            plain.add(name)
        if name in cons.slot_force:
            gen = contact_force(gen, bm.kin, cons.slot_force[name])
        gen = add_lumped_rotary(gen, s, bm.kin, loads.rotary[name])
        E[name] = BarForces(
            XY=tuple(
                prog.assign(names.generalized_force(ax, name), gen["XY"][k], GENERALIZED_FORCE)
                for k, ax in enumerate("XY")
            ),
            th=prog.assign(names.generalized_force("th", name), gen["th"], GENERALIZED_FORCE),
            f=[
                prog.assign(names.generalized_force("f", name, k), e, GENERALIZED_FORCE) for k, e in enumerate(gen["f"])
            ],
            g=[
                prog.assign(names.generalized_force("g", name, k), e, GENERALIZED_FORCE) for k, e in enumerate(gen["g"])
            ],
            beta=(
                prog.assign(names.generalized_force("beta", name), gen["beta"], GENERALIZED_FORCE)
                if gen.get("beta") is not None
                else None
            ),
        )
    prog.blocks = bar_blocks(bar_equations, E, plain)
    return E


def _flat(E: BarForces) -> tuple:
    return (*E.XY, E.th, *E.f, *E.g)


def bar_blocks(shared: SharedBarEquations, E: dict, plain: set) -> list[Block]:
    """A :class:`Block` per bar structure whose equations 2+ bars (``plain``: their E are the
    equations' own) share: the first bar's E and the bars' renamed inputs. The renamed equations are
    the shared ones by construction (``SharedBarEquations``), so each call's E is the block's outputs
    with its inputs (tested: tests/test_bar_blocks.py)."""
    members: dict[str, list] = {first: [(first, None)] if first in plain else [] for first in shared.derived}
    for bar, (first, rule) in shared.shared.items():
        if bar in plain:
            members[first].append((bar, rule))
    blocks = []
    for first, bars in members.items():
        if len(bars) < 2:
            continue
        gen = shared.derived[first].generalized()
        outputs = tuple(sp.sympify(e) for e in (*gen["XY"], gen["th"], *gen["f"], *gen["g"]))
        inputs = tuple(sorted(set().union(*[e.free_symbols for e in outputs]), key=str))
        calls = tuple(
            BlockCall(bar, inputs if rule is None else tuple(rule.get(x, x) for x in inputs), _flat(E[bar]))
            for bar, rule in bars
        )
        blocks.append(Block(first, inputs, outputs, calls))
    return blocks


def contact_force(gen: dict, kin, force: tuple) -> dict:
    """Generalized forces of a force applied at the guide's moving contact (xi = beta):
    E -= (d r_contact / d coordinate) . F for the translation, theta and beta (the
    amplitudes do no work there: eta(beta) = 0 in the guide's frame)."""
    F = sp.Matrix(force)
    arms = kin.contact_partials()
    s = kin.sym
    out = dict(gen)
    out["XY"] = (gen["XY"][0] - F[0], gen["XY"][1] - F[1])
    out["th"] = gen["th"] - arms[s.th].dot(F)
    out["beta"] = gen["beta"] - arms[s.beta[0]].dot(F)
    if any(gk in arms for gk in s.g):  # the foreshortened contact (slot.SlotBarKinematics)
        out["g"] = tuple(e - arms[gk].dot(F) if gk in arms else e for e, gk in zip(gen["g"], s.g))
    return out


def subtree_resultants(prog: Program, topo: Topology, E: dict) -> dict:
    """bar -> S (2 program symbols): the resultant of the bar and every bar beyond it, the
    force its tree joint transmits; leaves first."""
    S: dict[str, sp.Matrix] = {}
    for name in reversed(topo.order):
        tot = sp.Matrix(E[name].XY)
        for ch in topo.children[name]:
            tot += S[ch.body]
        S[name] = sp.Matrix(
            [prog.assign(names.subtree_force(ax, name), tot[k], SUBTREE_FORCE) for k, ax in enumerate("xy")]
        )
    return S


def residuals(
    coords: list,
    q: tuple,
    topo: Topology,
    bars: dict,
    tree: TreeKinematics,
    E: dict,
    S: dict,
    moments: dict,
    rotors: dict,
) -> list:
    """One residual per coordinate (virtual work through the tree). ``moments``: driven bar ->
    applied moment (a torque driver's torque, or an angle driver's multiplier); ``rotors``:
    driven bar -> J of its rotor."""
    res = []
    for c, var in zip(coords, q):
        if c.kind is CoordKind.S:
            e = topo.edges[c.body]
            res.append(tree.slider_dir(e.joint).dot(S[c.body]))
            continue
        bm = bars[c.body]
        e = topo.edges[c.body]
        r = E[c.body].of(c) - bm.kin.partials(e.body_xi)[var].dot(S[c.body])
        for ch in topo.children[c.body]:
            r += bm.kin.partials(ch.parent_xi)[var].dot(S[ch.body])
        if c.kind is CoordKind.THETA and c.body in moments:
            r -= moments[c.body]  # applied moment
            if c.body in rotors:
                r += rotors[c.body] * bm.sym.ddth  # the rotor's inertial moment J theta''
        res.append(r)
    return res
