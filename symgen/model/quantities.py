"""What a run reports besides the state: the mechanism's energy and the scene's outputs
(``[outputs]``: bar shapes, positions, angles, reactions, the driver torque, the closure
residual), as expressions of t, q, v, a, lam and p.

(Not to be confused with ``symgen.outputs``, which writes output files atomically.)
"""

from __future__ import annotations

import sympy as sp

from symgen.errors import SceneError
from symgen.ir.spec import ModelSpec, OutputSpec
from symgen.model.bars import rot
from symgen.model.constraints import Constraints
from symgen.model.kinematics import TreeKinematics
from symgen.model.loads import Loads
from symgen.model.rotary import rotary_energy
from symgen.model.topology import Topology
from symgen.scene.model import GROUND

#: outputs read from a bar's own shape (its amplitudes): a quasi-static bar adds its stretch
BAR_SHAPE_OUTPUTS = ("chord_deflection", "chord_elongation", "deflection", "axial", "slope", "elastic_displacement")


def energy(bars: dict, topo: Topology, tree: TreeKinematics, loads: Loads, rotors: dict) -> sp.Expr:
    """Kinetic + elastic + gravity potential energy, common units m_ref l0^3 omega^2. A
    quasi-static bar counts as the inextensible bar its dynamics are (the energy those
    conserve); its stretch energy N^T Ka N / (2 lambda) is of order 1/lambda and left out.
    The lumped masses (at joints, ``[[masses]]`` with their arms) add their kinetic and
    potential energy, the lumped rotary inertias and the driver's rotor their kinetic energy
    (``symgen.model.rotary``)."""
    G = loads.G
    total = sp.Integer(0)
    for name in topo.order:
        bm = bars[name]
        s, eq = bm.sym, bm.equations
        rA, vA = tree.position(name), tree.velocity(name)
        R = rot(s.th)
        vb = R.T * vA / s.alpha
        k3 = s.nu * s.alpha**3
        total += k3 * (eq.kinetic.xreplace({eq.xa_d: vb[0], eq.ya_d: vb[1]}) + eq.elastic)
        if G != sp.zeros(2, 1):
            t = bm.ipt
            na, nt = len(s.f), len(s.g)
            mean_x = sp.Rational(1, 2) + sp.Add(*[t.gram(0, 2 + k) * s.f[k] for k in range(na)])
            mean_y = sp.Add(*[t.gram(0, 2 + na + k) * s.g[k] for k in range(nt)])
            centroid = rA + s.alpha * R * sp.Matrix([mean_x, mean_y])
            total -= s.nu * s.alpha * G.dot(centroid)
    for lm in loads.masses:
        r, vv = lm.point(tree, bars[lm.body].kin)
        total += lm.mass * vv.dot(vv) / 2 - lm.mass * G.dot(r)
    return total + rotary_energy(bars, [x for n in topo.order for x in loads.rotary[n]], rotors)


def scene_outputs(
    spec: ModelSpec,
    path: str,
    bars: dict,
    topo: Topology,
    tree: TreeKinematics,
    S: dict,
    cons: Constraints,
    total_energy: sp.Expr,
    stretch: dict,
) -> tuple[list, list]:
    """(names, expressions) of the outputs of the model ``spec`` (``path``: the scene file, for
    an error). ``stretch``: bar -> (N_1, ...) of the quasi-static bars, whose shape reads the
    stretch N / lambda on top of the inextensible amplitudes."""
    joints = {j.name: j for j in spec.joints}
    out_names, out_exprs = [], []
    for o in spec.outputs:
        out_names.append(o.name)
        expr = output(o, path, bars, topo, joints, tree, S, cons, total_energy)
        if o.kind in BAR_SHAPE_OUTPUTS and o.body in stretch:
            s = bars[o.body].sym
            expr = expr.xreplace({fk: fk + nk / s.lam for fk, nk in zip(s.f, stretch[o.body])})
        out_exprs.append(expr)
    return out_names, out_exprs


def output(
    o: OutputSpec,
    path: str,
    bars: dict,
    topo: Topology,
    joints: dict,
    tree: TreeKinematics,
    S: dict,
    cons: Constraints,
    total_energy: sp.Expr,
) -> sp.Expr:
    """The expression of one output ``o`` of the model (``joints``: name -> JointSpec)."""
    k = o.kind
    if k in BAR_SHAPE_OUTPUTS:
        kin = bars[o.body].kin
        if k == "deflection":
            return kin.eta(o.xi)
        if k == "axial":
            return kin.zeta(o.xi)
        if k == "slope":
            return kin.eta(o.xi, 1)
        if k == "elastic_displacement":
            s = kin.sym
            d = s.alpha * rot(s.th) * sp.Matrix([kin.zeta(o.xi), kin.eta(o.xi)])
            return d[0 if o.component == "x" else 1]
        l0x, l0y = kin.local(0.0)
        l1x, l1y = kin.local(1.0)
        cx, cy = l1x - l0x, l1y - l0y
        chord = sp.sqrt(cx**2 + cy**2)
        if k == "chord_elongation":
            return chord - 1
        px, py = kin.local(o.xi)
        return (cx * (py - l0y) - cy * (px - l0x)) / chord
    if k == "position":
        assert o.body is not None and o.xi is not None, "a position output names its bar and xi (symgen.scene.outputs)"
        r = tree.point(o.body, o.xi)[0]
        return r[0 if o.component == "x" else 1]
    if k == "angle":
        return bars[o.body].sym.th
    if k == "driver_torque":
        # the driven bar named, else the only angle driver (symgen.scene.outputs)
        row = cons.driver_rows[o.body] if o.body is not None else cons.driver_row
        assert row is not None, "driver_torque needs an angle driver (symgen.scene.outputs)"
        return cons.lam[row]
    if k == "energy":
        return total_energy
    if k == "closure_residual":
        loop_phi = cons.closure
        if not loop_phi:
            return sp.Integer(0)
        return sp.Max(*[sp.Abs(x) for x in loop_phi]) if len(loop_phi) > 1 else sp.Abs(loop_phi[0])
    if k == "reaction":
        j = joints[o.joint]
        comp = 0 if o.component == "x" else 1
        # force exerted by bodies[0] on bodies[1], ground axes
        for name, e in topo.edges.items():
            if e.joint == j.name:
                on_child = S[name][comp]
                return on_child if j.ends[1].body == name else -on_child
        rows = [i for i, r in enumerate(cons.rows) if r.joint == j.name]
        if j.kind in ("pin", "slot"):  # a slot's rows are its force's ground components, as a pin's
            return -cons.lam[rows[comp]]  # lam is the force on ends[0] from ends[1]
        d = tree.slider_dir(j.name)
        n = (-d[1], d[0])
        bar_idx = 0 if j.ends[0].body != GROUND else 1
        on_bar = cons.lam[rows[0]] * n[comp] * (1 if bar_idx == 0 else -1)  # force on the bar
        return on_bar if bar_idx == 1 else -on_bar
    raise SceneError(path, f"outputs.{o.name}.kind", f"unknown output kind {k!r}")
