"""Derive a mechanism's equations: the orchestration of the model's stages.

The model is a ``Program``: an ordered list of assignments (intermediate symbol = expression
of earlier symbols) and named output vectors, over the inputs

    t (tau), q (coordinates), v = q', a = q'', lam (multipliers), p (parameters).

Equations of motion (index-3 form, reduced to index 1 by the runner):

    res(t, q, v, a, lam, p) = 0      (one row per coordinate)
    phi(t, q, p) = 0, phid = 0, phidd = 0   (closure (11) of each loop, the angle drivers)

Reactions of cut joints (and the angle drivers' torques) are the multipliers ``lam``; those of tree
joints are the subtree resultants ``S`` (route 2 of the seed: global equilibrium of the bars
beyond the joint), which never enter the motion: only reactions that do work are unknowns.

Each stage has its own module: the bars and their coordinates are made here, the tree
kinematics (10) in ``kinematics``, the constraints (11) in ``constraints``, the loads and
lumped masses in ``loads`` (rotary inertias and the driver's rotor in ``rotary``), the
generalized forces, subtree resultants and residuals in ``residual``, the energy and the
scene's outputs in ``quantities``. The order of the calls below is the order in which symbols,
assignments, rows and outputs are made (it decides the CSE order of the emitted code).

The derivation's input is the typed :class:`symgen.ir.spec.ModelSpec` of the scene
(``structure.model_spec``; its canonical JSON is the model's cache key): the bars (function
counts, shape families, static corrections, axial treatment, a guide's overhang), the effects,
the joints of the loop closure, the loads, lumped masses and inertias, the drivers' rotors and
moments, the outputs. Two stages still read the scene itself: the topology (``build_topology``,
which the numerics' geometry calls with the scene too: its tree edges carry the ground points'
values, and its error names the scene file) and the angle drivers (``angle_drivers``: the
guidance law has one home, ``symgen.scene.motion.driver_angle``, which the runners evaluate too
and which reads the scene's driver, whose ramp time the spec only records as present). The
scene's path also names the file in the errors of the slot guides and of the outputs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import sympy as sp

from symgen.errors import SceneError
from symgen.ir import names
from symgen.ir.names import Name
from symgen.ir.records import CoordKind, Coordinate, DerivedModel, Program
from symgen.ir.spec import ModelSpec
from symgen.model.bars import BarEquations, BarSymbols, IPTable
from symgen.model.constraints import angle_drivers, axial_forces, inextensibility, loop_closure, quasi_static_stretch
from symgen.model.kinematics import BarKinematics, TreeKinematics
from symgen.model.loads import applied_loads
from symgen.model.quantities import BAR_SHAPE_OUTPUTS, energy, scene_outputs
from symgen.model.residual import generalized_forces, residuals, subtree_resultants
from symgen.model.rotary import driver_rotors
from symgen.model.shape_cache import inner_products
from symgen.model.shapes import Basis, axial_basis
from symgen.model.slot import SlotBarKinematics, SlotBasis, SlotIPTable
from symgen.model.static_shapes import bar_bases
from symgen.model.structure import INEXTENSIBLE, model_spec, structure_key, structure_of
from symgen.model.topology import Topology, build_topology
from symgen.scene.expressions import tau_symbol
from symgen.scene.model import Scene

TAU = tau_symbol()

__all__ = ["BAR_SHAPE_OUTPUTS", "INEXTENSIBLE", "TAU", "BarModel", "derive", "structure_key", "structure_of"]


@dataclass
class BarModel:
    body: str
    sym: BarSymbols
    basis_a: Basis
    basis_t: Basis | SlotBasis  # a slot's guide: the variable span's functions
    kin: BarKinematics | SlotBarKinematics
    ipt: IPTable | SlotIPTable
    equations: BarEquations | None = None
    inputs: dict = field(default_factory=dict)  # keyword arguments given to bar_equations


class Parameters:
    """The parameter symbols of a derivation, made once each from their names."""

    def __init__(self) -> None:
        self.symbols: dict[str, sp.Symbol] = {}

    def __call__(self, name: Name) -> sp.Symbol:
        if name.text not in self.symbols:
            self.symbols[name.text] = name.symbol()
        return self.symbols[name.text]

    def add(self, *syms: sp.Symbol | None) -> None:
        """Symbols made elsewhere (a bar's own parameters); None is skipped."""
        for s in syms:
            if s is not None:
                self.symbols[str(s)] = s

    def sorted(self) -> tuple:
        return tuple(sorted(self.symbols.values(), key=lambda x: str(x)))


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
    spec = model_spec(scene)
    topo = build_topology(scene)
    param = Parameters()
    treatment = spec.axial_treatments()
    bars, slot_of = _bars(spec, scene.path, treatment, param)
    coords, (q, v, a), slider_s = _coordinates(topo, bars, slot_of)
    kins = {name: bm.kin for name, bm in bars.items()}
    tree = TreeKinematics(topo, kins, param, slider_s)  # (10)
    cons = loop_closure(topo, {j.name: j for j in spec.joints}, kins, tree)  # (11)
    rotors = driver_rotors(spec.drivers, param)
    angle_drivers(cons, scene.drivers, kins, param)
    loads = applied_loads(spec, kins, param)
    axial_force = axial_forces(kins, treatment)

    prog = Program(inputs={})
    E = generalized_forces(prog, topo, bars, tree, spec.effects, loads, cons, axial_force)
    inextensibility(cons, topo, bars, axial_force)
    S = subtree_resultants(prog, topo, E)
    # each driven bar's applied moment: a torque driver's torque, an angle driver's multiplier
    moments = dict(loads.torques) | {body: cons.lam[row] for body, row in cons.driver_rows.items()}
    res = residuals(coords, q, topo, bars, tree, E, S, moments, rotors)

    prog.inputs = {"t": (TAU,), "q": q, "v": v, "a": a, "lam": tuple(cons.lam)}
    prog.outputs.update(phi=cons.phi, phid=cons.phid, phidd=cons.phidd, res=res)
    prog.outputs["energy"] = [energy(bars, topo, tree, loads, rotors)]
    out_names, prog.outputs["out"] = scene_outputs(
        spec,
        scene.path,
        bars,
        topo,
        tree,
        S,
        cons,
        prog.outputs["energy"][0],
        quasi_static_stretch(axial_force, treatment),
    )
    prog.outputs["closure"] = cons.closure
    prog.inputs["p"] = params = param.sorted()
    return DerivedModel(
        key=spec.key(),
        scene_name=scene.name,
        structure=spec.to_json(),
        topology=topo,
        bars=bars,
        coords=coords,
        q=q,
        v=v,
        a=a,
        lam=tuple(cons.lam),
        lam_rows=cons.rows,
        params=params,
        program=prog,
        output_names=out_names,
        driver_row=cons.driver_row,
        timings={},
    )


def _bars(spec: ModelSpec, path: str, treatment: dict, param: Parameters) -> tuple[dict, dict]:
    """(bar -> BarModel, guide bar -> its slot joint): symbols, shape functions and inner
    products of every bar of ``spec``; a slot's guide gets the variable span psi(xi, beta).
    (``path``: the scene file, named when a bar guides two slots.)"""
    bars: dict[str, BarModel] = {}
    slot_of = _slot_guides(spec, path)
    for b in spec.bodies:
        na, nt = b.sizes  # the bar's functions and its static corrections
        # lambda: the strain energy (dynamic), the stretch N / lambda (quasi-static), rho = mu / lambda
        sym = BarSymbols.make(
            b.name,
            na,
            nt,
            elastic=not b.rigid,
            lam=treatment.get(b.name) != INEXTENSIBLE or spec.effects.rotary_inertia,
        )
        if b.name in slot_of:
            beta = tuple(names.slot_support(slot_of[b.name], o).symbol() for o in range(3))
            sym = replace(sym, beta=beta)
            basis = SlotBasis(nt, beta[0], spec.overhang_modes(b.name))
            param.add(sym.alpha, sym.nu, sym.mu)
            ba = axial_basis("complete", 0)
            kin = SlotBarKinematics(sym, basis, beta, foreshortening=spec.effects.geometric_stiffening)
            bars[b.name] = BarModel(b.name, sym, ba, basis, kin, SlotIPTable(basis))
            continue
        param.add(sym.alpha, sym.nu, sym.lam, sym.mu)
        ba, bt = bar_bases(b)
        assert (len(ba), len(bt)) == (na, nt), (b.name, len(ba), len(bt), na, nt)
        ipt = IPTable(inner_products(ba, bt))
        bars[b.name] = BarModel(b.name, sym, ba, bt, BarKinematics(sym, ba, bt), ipt)
    return bars, slot_of


def _coordinates(topo: Topology, bars: dict, slot_of: dict) -> tuple[list, tuple, dict]:
    """(Coordinate records, (q, v, a), slider joint -> (s, s', s'')) in tree order: per bar its
    slider travel, theta, the f, the g, a guide's beta."""
    coords: list[Coordinate] = []
    q: list[sp.Symbol] = []
    v: list[sp.Symbol] = []
    a: list[sp.Symbol] = []
    slider_s: dict[str, tuple] = {}

    def put(x: sp.Symbol, dx: sp.Symbol, ddx: sp.Symbol) -> None:
        """A coordinate and its rates into q, v, a."""
        q.append(x)
        v.append(dx)
        a.append(ddx)

    for name in topo.order:
        e = topo.edges[name]
        if e.slider:
            s_ = tuple(names.slider_travel(e.joint, o).symbol() for o in range(3))
            slider_s[e.joint] = s_
            coords.append(Coordinate(str(s_[0]), CoordKind.S, name, joint=e.joint))
            put(s_[0], s_[1], s_[2])
        sym = bars[name].sym
        coords.append(Coordinate(str(sym.th), CoordKind.THETA, name))
        put(sym.th, sym.dth, sym.ddth)
        for k in range(len(sym.f)):
            coords.append(Coordinate(str(sym.f[k]), CoordKind.F, name, k))
            put(sym.f[k], sym.df[k], sym.ddf[k])
        for k in range(len(sym.g)):
            coords.append(Coordinate(str(sym.g[k]), CoordKind.G, name, k))
            put(sym.g[k], sym.dg[k], sym.ddg[k])
        if sym.beta:
            coords.append(Coordinate(str(sym.beta[0]), CoordKind.BETA, name, joint=slot_of[name]))
            put(sym.beta[0], sym.beta[1], sym.beta[2])
    return coords, (tuple(q), tuple(v), tuple(a)), slider_s


def _slot_guides(spec: ModelSpec, path: str) -> dict:
    """guide bar -> slot joint name (one slot per guide)."""
    out: dict[str, str] = {}
    for j in spec.joints:
        if j.kind == "slot":
            guide = j.ends[1].body
            if guide in out:
                raise SceneError(
                    path,
                    f"joints.{j.name}",
                    f"bar {guide!r} already guides slot {out[guide]!r}; symgen supports one slot per guide bar",
                    "split the guide into two bars joined by a pin",
                )
            out[guide] = j.name
    return out
