"""Assemble the mechanism's equations: closure (11) at position, velocity and acceleration
level, joint reactions, and the generalized-force residual of every coordinate.

The model is a ``Program``: an ordered list of assignments (intermediate symbol = expression
of earlier symbols) and named output vectors, over the inputs

    t (tau), q (coordinates), v = q', a = q'', lam (multipliers), p (parameters).

Equations of motion (index-3 form, reduced to index 1 by the runner):

    res(t, q, v, a, lam, p) = 0      (one row per coordinate)
    phi(t, q, p) = 0, phid = 0, phidd = 0   (closure (11) of each loop, the angle driver)

Reactions of cut joints (and the driver torque) are the multipliers ``lam``; those of tree
joints are the subtree resultants ``S`` (route 2 of the seed: global equilibrium of the bars
beyond the joint), which never enter the motion: only reactions that do work are unknowns.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import sympy as sp

from symgen.model.bars import BarEquations, BarSymbols, IPTable, PointForce, bar_equations, rot
from symgen.errors import SceneError
from symgen.model.kinematics import BarKinematics
from symgen.scene.expressions import parse_tau_expression, tau_symbol
from symgen.scene.model import GROUND, Scene
from symgen.scene.motion import driver_angle
from symgen.model.rotary import LumpedRotary, add_lumped_rotary, rotary_energy
from symgen.model.shapes import Basis, axial_basis, inner_products, transverse_basis
from symgen.model.slot import SlotBarKinematics, SlotBasis, SlotIPTable
from symgen.model.static_shapes import bar_bases
from symgen.model.structure import INEXTENSIBLE, QUASI_STATIC, _tip_joint, axial_treatments, basis_sizes, effective_modes, overhang_modes, structure_key, structure_of
from symgen.model.topology import Topology, build_topology
from symgen.ir import names
from symgen.ir.names import Name
from symgen.ir.records import (GENERALIZED_FORCE, ORIGIN_ACCELERATION, SUBTREE_FORCE, ConstraintRow, Coordinate,
                               DerivedModel, Program)

TAU = tau_symbol()


@dataclass
class BarModel:
    body: str
    sym: BarSymbols
    basis_a: Basis
    basis_t: Basis
    kin: BarKinematics
    ipt: IPTable
    equations: BarEquations | None = None
    inputs: dict = field(default_factory=dict)    # keyword arguments given to bar_equations


# --------------------------------------------------------------------------- derivation
def derive(scene: Scene) -> DerivedModel:
    """Derive the mechanism's equations symbolically (parameters stay symbols)."""
    t0 = time.perf_counter()
    with names.recording() as table:
        model = _derive(scene)
    model.latex = dict(table)
    model.timings = {"derive_s": time.perf_counter() - t0}
    return model


def _derive(scene: Scene) -> DerivedModel:
    structure = structure_of(scene)
    topo = build_topology(scene)
    eff = scene.effects
    P: dict[str, sp.Symbol] = {}

    def param(name: Name) -> sp.Symbol:
        if name.text not in P:
            P[name.text] = name.symbol()
        return P[name.text]

    # ---- bars, shapes, inner products
    bars: dict[str, BarModel] = {}
    slot_of = _slot_guides(scene)          # guide bar -> its slot joint (variable span psi(xi, beta))
    treatment = {name: t.treatment for name, t in axial_treatments(scene).items()}
    records = {rec["name"]: rec for rec in structure["bodies"]}
    for b in scene.bodies:
        na, nt = basis_sizes(scene, b)       # the bar's functions and its static corrections
        # lambda: the strain energy (dynamic), the stretch N / lambda (quasi-static), rho = mu / lambda
        sym = BarSymbols.make(b.name, na, nt, elastic=not b.rigid,
                              lam=treatment.get(b.name) != INEXTENSIBLE or eff.rotary_inertia)
        if b.name in slot_of:
            beta = tuple(names.slot_support(slot_of[b.name], o).symbol() for o in range(3))
            sym = replace(sym, beta=beta)
            basis = SlotBasis(nt, beta[0], overhang_modes(scene, b))
            P[str(sym.alpha)], P[str(sym.nu)] = sym.alpha, sym.nu
            if sym.mu is not None:
                P[str(sym.mu)] = sym.mu
            ba = axial_basis("complete", 0)
            bars[b.name] = BarModel(b.name, sym, ba, basis, SlotBarKinematics(sym, basis, beta), SlotIPTable(basis))
            continue
        P[str(sym.alpha)] = sym.alpha
        P[str(sym.nu)] = sym.nu
        if sym.lam is not None:
            P[str(sym.lam)] = sym.lam
        if sym.mu is not None:
            P[str(sym.mu)] = sym.mu
        ba, bt = bar_bases(records[b.name])
        assert (len(ba), len(bt)) == (na, nt), (b.name, len(ba), len(bt), na, nt)
        ipt = IPTable(inner_products(ba, bt))
        bars[b.name] = BarModel(b.name, sym, ba, bt, BarKinematics(sym, ba, bt), ipt)

    # ---- coordinates in tree order
    coords: list[Coordinate] = []
    q, v, a = [], [], []
    slider_s: dict[str, tuple] = {}
    for name in topo.order:
        e = topo.edges[name]
        if e.slider:
            s_ = tuple(names.slider_travel(e.joint, o).symbol() for o in range(3))
            slider_s[e.joint] = s_
            coords.append(Coordinate(str(s_[0]), "s", name, joint=e.joint))
            q.append(s_[0]), v.append(s_[1]), a.append(s_[2])
        sym = bars[name].sym
        coords.append(Coordinate(str(sym.th), "theta", name))
        q.append(sym.th), v.append(sym.dth), a.append(sym.ddth)
        for k in range(len(sym.f)):
            coords.append(Coordinate(str(sym.f[k]), "f", name, k))
            q.append(sym.f[k]), v.append(sym.df[k]), a.append(sym.ddf[k])
        for k in range(len(sym.g)):
            coords.append(Coordinate(str(sym.g[k]), "g", name, k))
            q.append(sym.g[k]), v.append(sym.dg[k]), a.append(sym.ddg[k])
        if sym.beta:
            coords.append(Coordinate(str(sym.beta[0]), "beta", name, joint=slot_of[name]))
            q.append(sym.beta[0]), v.append(sym.beta[1]), a.append(sym.beta[2])

    joints = {j.name: j for j in scene.joints}

    def ground_point(jname: str, end) -> sp.Matrix:
        return sp.Matrix([param(names.joint_parameter("px", jname)), param(names.joint_parameter("py", jname))])

    def slider_dir(jname: str) -> sp.Matrix:
        return sp.Matrix([param(names.joint_parameter("dx", jname)), param(names.joint_parameter("dy", jname))])

    # ---- explicit kinematics along the tree (10): origin of each bar, and any bar point
    path_memo: dict[str, list] = {}

    def path(name: str) -> list:
        """Contributions to r_A of bar ``name``: (sign, body, xi) bar terms and ground/slider ends."""
        if name in path_memo:
            return path_memo[name]
        e = topo.edges[name]
        if e.parent == GROUND:
            terms = [("slider" if e.slider else "ground", e.joint)]
        else:
            terms = path(e.parent) + [(1, e.parent, e.parent_xi)]
        terms = terms + [(-1, name, e.body_xi)]
        path_memo[name] = terms
        return terms

    def ground_end(term) -> tuple:
        kind, jname = term
        j = joints[jname]
        end = next(x for x in j.ends if x.body == GROUND)
        p0 = ground_point(jname, end)
        if kind == "slider":
            s_, ds_, dds_ = slider_s[jname]
            d = slider_dir(jname)
            return p0 + s_ * d, ds_ * d, dds_ * d
        z = sp.zeros(2, 1)
        return p0, z, z

    def origin(name: str) -> tuple:
        """(r_A, r_A', r_A'') of bar ``name``, ground axes, explicit in q, v, a."""
        r, rd, rdd = sp.zeros(2, 1), sp.zeros(2, 1), sp.zeros(2, 1)
        for term in path(name):
            if isinstance(term[0], str):
                g0, g1, g2 = ground_end(term)
                r, rd, rdd = r + g0, rd + g1, rdd + g2
            else:
                sign, body, xi = term
                kin = bars[body].kin
                r, rd, rdd = r + sign * kin.rho(xi), rd + sign * kin.rho_d(xi), rdd + sign * kin.rho_dd(xi)
        return r, rd, rdd

    def origin_acc_local(name: str) -> sp.Matrix:
        """[r_A'']_i of (10): the origin's acceleration in bar ``name``'s axes / alpha_i."""
        th_i = bars[name].sym.th
        out = sp.zeros(2, 1)
        for term in path(name):
            if isinstance(term[0], str):
                out += rot(-th_i) * ground_end(term)[2]
            else:
                sign, body, xi = term
                rel = rot(bars[body].sym.th - th_i) if body != name else sp.eye(2)
                out += sign * rel * bars[body].kin.bracket_dd(xi)
        return out / bars[name].sym.alpha

    def point(name: str, xi: float) -> tuple:
        rA, vA, aA = origin(name)
        kin = bars[name].kin
        return rA + kin.rho(xi), vA + kin.rho_d(xi), aA + kin.rho_dd(xi)

    def end_point(jname: str, end) -> tuple:
        if end.body == GROUND:
            z = sp.zeros(2, 1)
            return ground_point(jname, end), z, z
        return point(end.body, end.xi)

    # ---- constraints: cut joints (11) and the angle driver
    lam, lam_rows, point_forces = [], [], {n: [] for n in bars}
    slot_force: dict[str, tuple] = {}
    phi, phid, phidd = [], [], []
    for cut in topo.cuts:
        j = joints[cut.joint]
        ra, va, aa = end_point(j.name, j.ends[0])
        rb, vb, ab = end_point(j.name, j.ends[1]) if j.kind != "slot" else (None, None, None)
        if j.kind == "pin":
            L = (names.joint_force(j.name, "x").symbol(), names.joint_force(j.name, "y").symbol())
            for k, comp in enumerate("xy"):
                phi.append(ra[k] - rb[k]), phid.append(va[k] - vb[k]), phidd.append(aa[k] - ab[k])
                lam.append(L[k]), lam_rows.append(ConstraintRow(j.name, f"pin-{comp}", cut.loop))
            for idx, sign in ((0, 1), (1, -1)):
                end = j.ends[idx]
                if end.body != GROUND:
                    point_forces[end.body].append(PointForce(end.xi, ground=(sign * L[0], sign * L[1])))
        elif j.kind == "slot":  # the point of ends[0] stays on the guide at its support distance beta
            guide = bars[j.ends[1].body]
            rA, vA, aA = origin(guide.body)
            c0, c1, c2 = guide.kin.contact()
            rb, vb, ab = rA + c0, vA + c1, aA + c2
            L = (names.joint_force(j.name, "x").symbol(), names.joint_force(j.name, "y").symbol())
            for k, comp in enumerate("xy"):
                phi.append(ra[k] - rb[k]), phid.append(va[k] - vb[k]), phidd.append(aa[k] - ab[k])
                lam.append(L[k]), lam_rows.append(ConstraintRow(j.name, f"slot-{comp}", cut.loop))
            point_forces[j.ends[0].body].append(PointForce(j.ends[0].xi, ground=(L[0], L[1])))
            slot_force[guide.body] = (-L[0], -L[1])      # on the guide, at the moving contact
        else:  # slider: the bar point stays on the ground line
            bar_idx = 0 if j.ends[0].body != GROUND else 1
            sign = 1 if bar_idx == 0 else -1
            d = slider_dir(j.name)
            n = sp.Matrix([-d[1], d[0]])
            p0 = ground_point(j.name, j.ends[1 - bar_idx])
            rb_, vb_, ab_ = (ra, va, aa) if bar_idx == 0 else (rb, vb, ab)
            phi.append(sign * (n.dot(rb_ - p0))), phid.append(sign * n.dot(vb_)), phidd.append(sign * n.dot(ab_))
            L = names.joint_force(j.name).symbol()
            lam.append(L), lam_rows.append(ConstraintRow(j.name, "slider", cut.loop))
            end = j.ends[bar_idx]
            point_forces[end.body].append(PointForce(end.xi, ground=(sign * L * n[0], sign * L * n[1])))
    n_loop_rows = len(phi)
    driver_row = None
    drv = scene.driver
    torque_expr = None
    rotor = None                     # (driven bar, J) when the driver carries a rotor inertia
    if drv is not None and drv.rotor_inertia > 0:
        rotor = (drv.body, param(names.global_parameter("J_rotor")))
    if drv is not None:
        th = bars[drv.body].sym
        if drv.kind == "angle":
            th0 = param(names.global_parameter("theta0"))
            if drv.law is None and drv.ramp is None:      # the contract's theta0 + rate tau
                rate = param(names.global_parameter("rate"))
                phi.append(th.th - th0 - rate * TAU), phid.append(th.dth - rate), phidd.append(th.ddth)
            else:                                          # law(tau) or the spin-up ramp: exact derivatives
                rate = param(names.global_parameter("rate")) if drv.law is None else None
                ramp = param(names.global_parameter("ramp")) if drv.ramp is not None else None
                angle = driver_angle(drv, TAU, th0, rate, ramp)
                phi.append(th.th - angle), phid.append(th.dth - sp.diff(angle, TAU))
                phidd.append(th.ddth - sp.diff(angle, TAU, 2))
            L = names.DRIVER_FORCE.symbol()
            driver_row = len(lam)
            lam.append(L), lam_rows.append(ConstraintRow("driver", "driver", (GROUND, drv.body)))
        else:
            torque_expr = parse_tau_expression(drv.torque) if isinstance(drv.torque, str) else param(names.global_parameter("torque"))

    # ---- lumped masses (carried by the first bar of their joint) and loads
    grav = (param(names.global_parameter("gx")), param(names.global_parameter("gy"))) if structure["effects"]["gravity"] else None
    G = sp.Matrix(grav) if grav else sp.zeros(2, 1)
    lumped = []
    rotary = {n: [] for n in bars}          # lumped rotary inertias, by the bar carrying them
    for j in scene.joints:
        if j.inertia > 0:
            end = next(x for x in j.ends if x.body != GROUND)
            rotary[end.body].append(LumpedRotary(j.name, end.body, end.xi, param(names.joint_parameter("I", j.name))))
        if j.mass > 0:
            end = next(x for x in j.ends if x.body != GROUND)
            m = param(names.joint_parameter("m", j.name))
            lumped.append((j.name, end.body, end.xi, m))
            bm = bars[end.body]
            s = bm.sym
            aA = s.alpha * rot(s.th) * sp.Matrix([s.xa_dd, s.ya_dd])
            acc = aA + bm.kin.rho_dd(end.xi) - G
            point_forces[end.body].append(PointForce(end.xi, ground=(-m * acc[0], -m * acc[1])))
    dist = {n: [] for n in bars}
    for i, ld in enumerate(scene.loads):
        vals = []
        for comp in ("axial", "transverse"):
            val = getattr(ld, comp)
            vals.append(parse_tau_expression(val) if isinstance(val, str) else param(names.load_parameter(i, comp, point=ld.kind != "distributed")))
        if ld.kind == "distributed":
            dist[ld.body].append(tuple(vals))
        else:
            point_forces[ld.body].append(PointForce(ld.xi, bar=tuple(vals)))
    damping = param(names.global_parameter("damping")) if structure["effects"]["damping"] else None
    # inextensible and quasi-static bars: multipliers N_k of (phi'_k, eps) = 0 (the axial force,
    # in lambda eps units); a quasi-static bar's stretch is P eps = N / lambda: amplitudes f + N / lambda
    axial_force = {name: tuple(names.axial_force(name, k).symbol() for k in range(len(bm.sym.f)))
                   for name, bm in bars.items()
                   if treatment.get(name) in (INEXTENSIBLE, QUASI_STATIC) and len(bm.sym.f)}
    stretch = {name: axial_force[name] for name in axial_force if treatment[name] == QUASI_STATIC}

    prog = Program(inputs={})
    # ---- bar equations (16)-(17) + rigid-body equations, then (10) for [r_A'']_i
    E: dict[str, dict] = {}
    for name in topo.order:
        bm = bars[name]
        s = bm.sym
        acc = origin_acc_local(name)
        prog.add(s.xa_dd, acc[0], ORIGIN_ACCELERATION)
        prog.add(s.ya_dd, acc[1], ORIGIN_ACCELERATION)
        bm.inputs = {"loads": tuple(dist[name]), "points": tuple(point_forces[name]),
                     "gravity": grav, "damping": damping}
        if name in axial_force:
            bm.inputs["axial_force"] = axial_force[name]
        bm.equations = bar_equations(s, bm.basis_a, bm.basis_t, bm.ipt, eff, **bm.inputs)
        gen = bm.equations.generalized()
        if name in slot_force:
            gen = _add_contact_force(gen, bm.kin, slot_force[name])
        gen = add_lumped_rotary(gen, s, bm.kin, rotary[name])
        E[name] = {
            "XY": tuple(prog.assign(names.generalized_force(ax, name), gen["XY"][k], GENERALIZED_FORCE)
                        for k, ax in enumerate("XY")),
            "th": prog.assign(names.generalized_force("th", name), gen["th"], GENERALIZED_FORCE),
            "f": [prog.assign(names.generalized_force("f", name, k), e, GENERALIZED_FORCE) for k, e in enumerate(gen["f"])],
            "g": [prog.assign(names.generalized_force("g", name, k), e, GENERALIZED_FORCE) for k, e in enumerate(gen["g"])],
        }
        if gen.get("beta") is not None:
            E[name]["beta"] = prog.assign(names.generalized_force("beta", name), gen["beta"], GENERALIZED_FORCE)
    # ---- inextensibility rows (after the loops and the driver): position, velocity, acceleration
    for name in topo.order:
        if name not in axial_force:
            continue
        s = bars[name].sym
        amp = [(x, dx, ddx) for x, dx, ddx in zip(s.f + s.g, s.df + s.dg, s.ddf + s.ddg)]
        for k, c in enumerate(bars[name].equations.constraint):
            grad = [sp.diff(c, x) for x, _, _ in amp]
            cd = sp.Add(*[gi * dx for gi, (_, dx, _) in zip(grad, amp)])
            cdd = sp.Add(*[gi * ddx for gi, (_, _, ddx) in zip(grad, amp)])
            cdd += sp.Add(*[sp.diff(gi, y) * dx * dy for gi, (_, dx, _) in zip(grad, amp) for y, dy, _ in amp])
            phi.append(c), phid.append(cd), phidd.append(cdd)
            lam.append(axial_force[name][k]), lam_rows.append(ConstraintRow(name, INEXTENSIBLE, (name,)))
    # ---- subtree resultants S (reactions of tree joints), leaves first
    S: dict[str, sp.Matrix] = {}
    for name in reversed(topo.order):
        tot = sp.Matrix(E[name]["XY"])
        for ch in topo.children[name]:
            tot += S[ch.body]
        S[name] = sp.Matrix([prog.assign(names.subtree_force(ax, name), tot[k], SUBTREE_FORCE) for k, ax in enumerate("xy")])
    # ---- residual of every coordinate (virtual work through the tree)
    res = []
    for c, var in zip(coords, q):
        if c.kind == "s":
            e = topo.edges[c.body]
            res.append(slider_dir(e.joint).dot(S[c.body]))
            continue
        bm = bars[c.body]
        s = bm.sym
        e = topo.edges[c.body]
        own = {"theta": E[c.body]["th"]}.get(c.kind)
        if c.kind == "f":
            own = E[c.body]["f"][c.index]
        elif c.kind == "g":
            own = E[c.body]["g"][c.index]
        elif c.kind == "beta":
            own = E[c.body]["beta"]
        r = own - bm.kin.partials(e.body_xi)[var].dot(S[c.body])
        for ch in topo.children[c.body]:
            r += bm.kin.partials(ch.parent_xi)[var].dot(S[ch.body])
        if c.kind == "theta" and drv is not None and drv.body == c.body:
            r -= torque_expr if torque_expr is not None else lam[driver_row]   # applied moment
            if rotor is not None:
                r += rotor[1] * s.ddth           # the rotor's inertial moment J theta''
        res.append(r)

    # ---- outputs
    q_t, v_t, a_t = tuple(q), tuple(v), tuple(a)
    prog.inputs = {"t": (TAU,), "q": q_t, "v": v_t, "a": a_t, "lam": tuple(lam)}
    prog.outputs["phi"] = phi
    prog.outputs["phid"] = phid
    prog.outputs["phidd"] = phidd
    prog.outputs["res"] = res
    prog.outputs["energy"] = [_energy(bars, topo, origin, point, lumped, G)
                              + rotary_energy(bars, [x for n in topo.order for x in rotary[n]], rotor)]
    out_names, out_exprs = [], []
    for o in scene.outputs:
        out_names.append(o.name)
        expr = _output(o, scene, bars, topo, joints, point, S, lam, lam_rows, driver_row,
                       prog.outputs["energy"][0], phi[:n_loop_rows], slider_dir)
        if o.kind in BAR_SHAPE_OUTPUTS and o.body in stretch:
            # what the bar's shape reads: the quasi-static stretch on top of the inextensible amplitudes
            s = bars[o.body].sym
            expr = expr.xreplace({fk: fk + nk / s.lam for fk, nk in zip(s.f, stretch[o.body])})
        out_exprs.append(expr)
    prog.outputs["out"] = out_exprs
    prog.outputs["closure"] = phi[:n_loop_rows]
    params = tuple(sorted(P.values(), key=lambda x: str(x)))
    prog.inputs["p"] = params
    timings: dict = {}
    return DerivedModel(key=structure_key(structure), scene_name=scene.name, structure=structure,
                        topology=topo, bars=bars, coords=coords, q=q_t, v=v_t, a=a_t, lam=tuple(lam),
                        lam_rows=lam_rows, params=params, program=prog, output_names=out_names,
                        driver_row=driver_row, timings=timings)


def _slot_guides(scene: Scene) -> dict:
    """guide bar -> slot joint name (one slot per guide)."""
    out: dict[str, str] = {}
    for j in scene.joints:
        if j.kind == "slot":
            guide = j.ends[1].body
            if guide in out:
                raise SceneError(scene.path, f"joints.{j.name}", f"bar {guide!r} already guides slot "
                                 f"{out[guide]!r}; symgen supports one slot per guide bar",
                                 "split the guide into two bars joined by a pin")
            out[guide] = j.name
    return out


def _add_contact_force(gen: dict, kin, force: tuple) -> dict:
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
    return out


#: outputs read from a bar's own shape (its amplitudes): a quasi-static bar adds its stretch
BAR_SHAPE_OUTPUTS = ("chord_deflection", "chord_elongation", "deflection", "axial", "slope", "elastic_displacement")


def _energy(bars, topo, origin, point, lumped, G) -> sp.Expr:
    """Kinetic + elastic + gravity potential energy, common units m_ref l0^3 omega^2. A
    quasi-static bar counts as the inextensible bar its dynamics are (the energy those
    conserve); its stretch energy N^T Ka N / (2 lambda) is of order 1/lambda and left out."""
    total = sp.Integer(0)
    for name in topo.order:
        bm = bars[name]
        s, eq = bm.sym, bm.equations
        rA, vA, _ = origin(name)
        R = rot(s.th)
        vb = R.T * vA / s.alpha
        k3 = s.nu * s.alpha ** 3
        total += k3 * (eq.kinetic.xreplace({eq.xa_d: vb[0], eq.ya_d: vb[1]}) + eq.elastic)
        if G != sp.zeros(2, 1):
            t = bm.ipt
            na, nt = len(s.f), len(s.g)
            mean_x = sp.Rational(1, 2) + sp.Add(*[t.gram(0, 2 + k) * s.f[k] for k in range(na)])
            mean_y = sp.Add(*[t.gram(0, 2 + na + k) * s.g[k] for k in range(nt)])
            centroid = rA + s.alpha * R * sp.Matrix([mean_x, mean_y])
            total -= s.nu * s.alpha * G.dot(centroid)
    for _, body, xi, m in lumped:
        r, vv, _ = point(body, xi)
        total += m * vv.dot(vv) / 2 - m * G.dot(r)
    return total


def _output(o, scene, bars, topo, joints, point, S, lam, lam_rows, driver_row, energy, loop_phi, slider_dir):
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
        chord = sp.sqrt(cx ** 2 + cy ** 2)
        if k == "chord_elongation":
            return chord - 1
        px, py = kin.local(o.xi)
        return (cx * (py - l0y) - cy * (px - l0x)) / chord
    if k == "position":
        r = point(o.body, o.xi)[0]
        return r[0 if o.component == "x" else 1]
    if k == "angle":
        return bars[o.body].sym.th
    if k == "driver_torque":
        return lam[driver_row]
    if k == "energy":
        return energy
    if k == "closure_residual":
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
        rows = [i for i, r in enumerate(lam_rows) if r.joint == j.name]
        if j.kind == "pin":
            return -lam[rows[comp]]        # lam is the force on ends[0] from ends[1]
        d = slider_dir(j.name)
        n = (-d[1], d[0])
        bar_idx = 0 if j.ends[0].body != GROUND else 1
        on_bar = lam[rows[0]] * n[comp] * (1 if bar_idx == 0 else -1)   # force on the bar
        return on_bar if bar_idx == 1 else -on_bar
    raise SceneError(scene.path, f"outputs.{o.name}.kind", f"unknown output kind {k!r}")
