"""The model parameters of an SI scene as formulas of its physical inputs (E, area, inertia,
density or mass per length, lengths, omega): the one statement of that conversion for the
emitted code.

The loader turns an SI file into the model's dimensionless parameters with the formulas of
:mod:`symgen.scene.units` (``axial_group``, ``bending_group``, the :class:`Scales` methods) and
``alpha = l / l0``, ``nu = m / m_ref``. :func:`physical_map` calls the same formulas with SymPy
symbols for the physical inputs, so that the emitted C converts ``--set bodies.rod.E=...`` (and
the FMU its SI parameters) by the loader's own formulas, printed to C instead of retyped;
``tests/test_si_parameters.py`` checks that the map, evaluated at the scene's inputs, gives the
loader's values.

Inputs held fixed: the values the file gives in SI that are not bar properties (gravity, ground
points, lumped masses and inertias, the rotor inertia, numeric torques and loads) keep their SI
value: a parameter made from them follows l0, m_ref, omega and the loaded bar's properties. An
SI expression (a law, a torque or a load of t) is converted once, into the derived model, with
the scene's omega and scales: the inputs its conversion used are not offered (:func:`frozen_inputs`).

>>> from symgen.scene import load_scene                                      # doctest: +SKIP
>>> pm = physical_map(load_scene("examples/motor_arm.toml"))               # doctest: +SKIP
>>> pm.expressions["mu_arm"]                                                 # doctest: +SKIP
bodies.arm.E*bodies.arm.inertia/(bodies.arm.area*bodies.arm.density*bodies.arm.length**4*scene.omega**2)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from symgen.ir import names as symbol_names
from symgen.scene.model import GROUND, Scene
from symgen.scene.units import OUTPUT_SCALE, Scales, axial_group, bending_group, output_factor

#: the SI unit of each physical input, by the last part of its scene key (FMI unit names)
INPUT_UNITS = {
    "omega": "rad/s",
    "reference_length": "m",
    "length": "m",
    "E": "Pa",
    "area": "m2",
    "inertia": "m4",
    "density": "kg/m3",
    "mass_per_length": "kg/m",
}
#: the SI unit of each output kind (FMI unit names; "" for the closure check, a pure number)
OUTPUT_UNITS = {"bar": "m", "l0": "m", "one": "rad", "force": "N", "moment": "N.m", "energy": "J", "check": ""}


def output_unit(kind: str) -> str:
    """The SI unit (FMI unit name) of an output of ``kind``."""
    return OUTPUT_UNITS[OUTPUT_SCALE[kind]]


@dataclass(frozen=True)
class PhysicalMap:
    """The physical inputs of an SI scene and the model parameters they set.

    inputs : (scene key, SI value) of every input that may be changed (``--set KEY=VALUE``)
    symbols : scene key -> its SymPy symbol (those of the offered inputs are the free symbols
        of ``expressions``; the frozen ones are replaced by their values)
    expressions : model parameter name -> its SymPy expression of the input symbols (only the
        parameters that depend on at least one offered input)
    frozen : scene keys of inputs not offered (used by an SI expression's conversion)
    omega : omega (rad/s) as an expression of the inputs: tau = omega t
    output_factors : per scene output, in order, its SI factor (symgen.scene.units.output_factor)
        as an expression of the inputs
    """

    inputs: tuple[tuple[str, float], ...] = ()
    symbols: dict[str, sp.Symbol] = field(default_factory=dict)
    expressions: dict[str, sp.Expr] = field(default_factory=dict)
    frozen: tuple[str, ...] = ()
    omega: sp.Expr = sp.S.One
    output_factors: tuple[sp.Expr, ...] = ()

    def evaluate(self, expr: sp.Expr, overrides: dict[str, float] | None = None) -> float:
        """An expression of the inputs at their values (``overrides``: scene key -> new value)."""
        values = dict(self.inputs) | (overrides or {})
        return float(expr.xreplace({self.symbols[k]: sp.Float(v, 17) for k, v in values.items()}))

    def value(self, parameter: str, overrides: dict[str, float] | None = None) -> float:
        """The parameter at the inputs' values (``overrides``: scene key -> new value)."""
        return self.evaluate(self.expressions[parameter], overrides)


def _mass_keys(scene: Scene, bar: str) -> tuple[str, ...]:
    given = dict(scene.si_inputs)
    key = f"bodies.{bar}"
    return (f"{key}.mass_per_length",) if f"{key}.mass_per_length" in given else (f"{key}.density", f"{key}.area")


def frozen_inputs(scene: Scene, reference: str) -> set[str]:
    """Inputs an SI expression's conversion used (converted once, into the derived model): omega
    for any expression, l0's and m_ref's inputs for a torque expression, the loaded bar's length
    and mass for a load expression."""
    torque = any(isinstance(d.torque, str) for d in scene.drivers)
    law = any(d.law is not None for d in scene.drivers)
    loaded = {ld.body for ld in scene.loads if isinstance(ld.axial, str) or isinstance(ld.transverse, str)}
    frozen: set[str] = set()
    if torque or law or loaded:
        frozen.add("scene.omega")
    keys = dict(scene.si_inputs)
    if torque:
        frozen |= {"scene.reference_length"} if "scene.reference_length" in keys else {f"bodies.{reference}.length"}
        frozen |= set(_mass_keys(scene, reference))
    for bar in loaded:
        frozen |= {f"bodies.{bar}.length", *_mass_keys(scene, bar)}
    return frozen & set(keys)


def physical_map(scene: Scene, parameters: list[str] | tuple[str, ...] | None = None) -> PhysicalMap:
    """The model parameters of an SI scene as expressions of its physical inputs (module
    docstring); an empty map for a dimensionless scene. ``parameters``: the model's parameter
    names (default: all the scene defines)."""
    if scene.units != "SI" or not scene.si_inputs:
        return PhysicalMap()
    given = dict(scene.si_inputs)
    sym = {k: sp.Symbol(k, positive=True) for k in given}

    def mass(bar: str) -> sp.Expr:
        keys = _mass_keys(scene, bar)
        return sym[keys[0]] if len(keys) == 1 else sym[keys[0]] * sym[keys[1]]

    reference = _reference(scene)
    l0 = sym.get("scene.reference_length", sym[f"bodies.{reference}.length"])
    m_ref = mass(reference)
    omega = sym["scene.omega"]
    scales = Scales(si=True, l0=l0, omega=omega, m_ref=m_ref)  # the loader's formulas, on symbols
    # SI values of the fixed inputs, recovered from the scene's model values and scales
    l0_v, m_v, w_v = scene.l0, scene.m_ref, scene.omega
    out: dict[str, sp.Expr] = {}

    def put(name: symbol_names.Name, expr: sp.Expr) -> None:
        out[name.text] = expr

    for b in scene.bodies:
        length = sym[f"bodies.{b.name}.length"]
        put(symbol_names.bar_parameter("alpha", b.name), length / l0)
        put(symbol_names.bar_parameter("nu", b.name), mass(b.name) / m_ref)
        e_key = f"bodies.{b.name}.E"
        if b.lam is not None and e_key in sym:
            area = sym[f"bodies.{b.name}.area"]
            put(
                symbol_names.bar_parameter("lambda", b.name), axial_group(sym[e_key], area, mass(b.name), length, omega)
            )
        if b.mu is not None and e_key in sym:
            inertia = sym[f"bodies.{b.name}.inertia"]
            put(
                symbol_names.bar_parameter("mu", b.name),
                bending_group(sym[e_key], inertia, mass(b.name), length, omega),
            )
    gx, gy = scene.effects.gravity
    put(symbol_names.global_parameter("gx"), scales.gravity(sp.Float(gx * (l0_v * w_v**2), 17)))
    put(symbol_names.global_parameter("gy"), scales.gravity(sp.Float(gy * (l0_v * w_v**2), 17)))
    for j in scene.joints:
        for e in j.ends:
            if e.body == GROUND and e.point is not None:
                put(symbol_names.joint_parameter("px", j.name), scales.length(sp.Float(e.point[0] * l0_v, 17)))
                put(symbol_names.joint_parameter("py", j.name), scales.length(sp.Float(e.point[1] * l0_v, 17)))
        put(symbol_names.joint_parameter("m", j.name), scales.joint_mass(sp.Float(j.mass * m_v * l0_v, 17)))
        put(symbol_names.joint_parameter("I", j.name), scales.rotary_inertia(sp.Float(j.inertia * m_v * l0_v**3, 17)))
    for i, drv in enumerate(scene.drivers):
        put(
            symbol_names.driver_parameter("J_rotor", i),
            scales.rotary_inertia(sp.Float(drv.rotor_inertia * m_v * l0_v**3, 17)),
        )
        if drv.kind == "torque" and not isinstance(drv.torque, str):
            put(
                symbol_names.driver_parameter("torque", i),
                scales.torque(sp.Float(drv.torque * m_v * l0_v**3 * w_v**2, 17)),
            )
    for i, pm in enumerate(scene.masses):
        put(symbol_names.mass_parameter("m", i), scales.joint_mass(sp.Float(pm.mass * m_v * l0_v, 17)))
        put(symbol_names.mass_parameter("I", i), scales.rotary_inertia(sp.Float(pm.inertia * m_v * l0_v**3, 17)))
        if pm.offset is not None:
            put(symbol_names.mass_parameter("along", i), scales.length(sp.Float(pm.offset[0] * l0_v, 17)))
            put(symbol_names.mass_parameter("across", i), scales.length(sp.Float(pm.offset[1] * l0_v, 17)))
    for i, ld in enumerate(scene.loads):
        m_i, l_i = mass(ld.body), sym[f"bodies.{ld.body}.length"]
        m_iv = scene.body(ld.body).nu * m_v
        l_iv = scene.body(ld.body).alpha * l0_v
        for comp in ("axial", "transverse"):
            val = getattr(ld, comp)
            if isinstance(val, str):
                continue
            point = ld.kind != "distributed"
            unit_v = m_iv * l_iv**2 * w_v**2 if point else m_iv * l_iv * w_v**2
            convert = scales.point if point else scales.distributed
            put(symbol_names.load_parameter(i, comp, point=point), convert(sp.Float(val * unit_v, 17), m_i, l_i))
    frozen = frozen_inputs(scene, reference)
    offered = {sym[k] for k in given if k not in frozen}
    fixed = {sym[k]: sp.Float(given[k], 17) for k in frozen}
    wanted = set(parameters) if parameters is not None else set(out)
    expressions = {k: e.xreplace(fixed) for k, e in out.items() if k in wanted and e.free_symbols & offered}
    factors = []
    for o in scene.outputs:
        f = output_factor(o.kind, l0, omega, m_ref, sym[f"bodies.{o.body}.length"] if o.body is not None else None)
        factors.append(sp.Float(f) if isinstance(f, float) else f.xreplace(fixed))
    return PhysicalMap(
        inputs=tuple((k, v) for k, v in scene.si_inputs if k not in frozen),
        symbols=sym,
        expressions=expressions,
        frozen=tuple(k for k in given if k in frozen),
        omega=omega.xreplace(fixed),
        output_factors=tuple(factors),
    )


def _reference(scene: Scene) -> str:
    """The reference bar (symgen.scene.mechanism.reference_bar): the first elastic bar, else the first."""
    return next((b.name for b in scene.bodies if not b.rigid), scene.bodies[0].name)
