"""The parameters of a derived model: their values for a scene, valid ranges and scene keys.

Part of the contract between the derivation and every consumer (the CasADi runs, the emitted C,
the FMU): ``parameter_records`` is the one statement of what each parameter is and may be.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import math
from collections.abc import Sequence
from dataclasses import dataclass

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.ir import names as symbol_names
from symgen.ir.names import Name
from symgen.scene.model import GROUND, Scene


@dataclass(frozen=True)
class ParameterRange:
    """The valid values of a model parameter: finite, above ``lower`` (strictly when
    ``lower_open``) and below ``upper`` (strictly when ``upper_open``).

    The one statement of what a parameter may be: the scene loader's checks of the keys the
    parameter comes from imply it, ``parameter_values`` verifies it, and the emitted C (``--set``
    of the driver, ``_solver_init``, ``fmi2SetReal``) is rendered from it.
    """

    lower: float = -math.inf
    upper: float = math.inf
    lower_open: bool = False
    upper_open: bool = False

    def contains(self, x: float) -> bool:
        if not math.isfinite(x):
            return False
        above = x > self.lower if self.lower_open else x >= self.lower
        below = x < self.upper if self.upper_open else x <= self.upper
        return above and below

    def text(self) -> str:
        """``"> 0"``, ``">= 0"``, ``"in [-1, 1]"`` or ``"finite"``."""
        lo, hi = math.isfinite(self.lower), math.isfinite(self.upper)
        if lo and hi:
            return (
                f"in {'(' if self.lower_open else '['}{self.lower:g}, {self.upper:g}{')' if self.upper_open else ']'}"
            )
        if lo:
            return f"{'>' if self.lower_open else '>='} {self.lower:g}"
        if hi:
            return f"{'<' if self.upper_open else '<='} {self.upper:g}"
        return "finite"


FINITE = ParameterRange()
POSITIVE = ParameterRange(lower=0.0, lower_open=True)
NON_NEGATIVE = ParameterRange(lower=0.0)
UNIT_COMPONENT = ParameterRange(lower=-1.0, upper=1.0)


@dataclass(frozen=True)
class Parameter:
    """One model parameter of a scene: its value, valid range and the scene key it comes from."""

    name: str
    value: float
    valid: ParameterRange
    key: str
    latex: str = ""  # its LaTeX name (symgen.ir.names)


def parameter_records(scene: Scene, names: Sequence[str] | None = None) -> list[Parameter]:
    """The parameters ``names`` of a model, for this scene (value, valid range, scene key);
    ``None``: every parameter the scene defines a value for."""
    recs: dict[str, Parameter] = {}

    def put(name: Name, value: float, valid: ParameterRange, key: str) -> None:
        recs[name.text] = Parameter(name.text, float(value), valid, key, name.latex)

    si = scene.units == "SI"  # lambda, mu from E, area, inertia and the mass per length
    for b in scene.bodies:
        key = f"bodies.{b.name}"
        put(symbol_names.bar_parameter("alpha", b.name), b.alpha, POSITIVE, f"{key}.length")  # length / l0
        put(
            symbol_names.bar_parameter("nu", b.name), b.nu, POSITIVE, key if si else f"{key}.mass_per_length"
        )  # mass / m_ref
        if b.lam is not None:
            put(symbol_names.bar_parameter("lambda", b.name), b.lam, POSITIVE, f"{key}.E" if si else f"{key}.lambda")
        if b.mu is not None:
            put(symbol_names.bar_parameter("mu", b.name), b.mu, POSITIVE, f"{key}.E" if si else f"{key}.mu")
    eff = scene.effects
    put(symbol_names.global_parameter("gx"), eff.gravity[0], FINITE, "effects.gravity")
    put(symbol_names.global_parameter("gy"), eff.gravity[1], FINITE, "effects.gravity")
    put(symbol_names.global_parameter("damping"), eff.damping, NON_NEGATIVE, "effects.damping")
    for j in scene.joints:
        key = f"joints.{j.name}"
        for e in j.ends:
            if e.body == GROUND:
                assert e.point is not None, "a ground end has its point (symgen.scene.mechanism)"
                put(symbol_names.joint_parameter("px", j.name), e.point[0], FINITE, f"{key}.at")
                put(symbol_names.joint_parameter("py", j.name), e.point[1], FINITE, f"{key}.at")
        if j.direction is not None:  # a unit vector
            put(symbol_names.joint_parameter("dx", j.name), j.direction[0], UNIT_COMPONENT, f"{key}.direction")
            put(symbol_names.joint_parameter("dy", j.name), j.direction[1], UNIT_COMPONENT, f"{key}.direction")
        put(symbol_names.joint_parameter("m", j.name), j.mass, NON_NEGATIVE, f"{key}.mass")
        put(symbol_names.joint_parameter("I", j.name), j.inertia, NON_NEGATIVE, f"{key}.inertia")
    for i, pm in enumerate(scene.masses):
        key = f"masses.{i}"  # as loads.{i}: a --set path
        put(symbol_names.mass_parameter("m", i), pm.mass, NON_NEGATIVE, f"{key}.mass")
        put(symbol_names.mass_parameter("I", i), pm.inertia, NON_NEGATIVE, f"{key}.inertia")
        along, across = pm.offset or (0.0, 0.0)
        put(symbol_names.mass_parameter("along", i), along, FINITE, f"{key}.offset")
        put(symbol_names.mass_parameter("across", i), across, FINITE, f"{key}.offset")
    for i, d in enumerate(scene.drivers):
        key = "driver" if len(scene.drivers) == 1 else f"drivers.{i}"

        def name(kind: str, i: int = i) -> Name:
            return symbol_names.driver_parameter(kind, i)

        put(name("J_rotor"), d.rotor_inertia, NON_NEGATIVE, f"{key}.rotor_inertia")
        if d.kind == "angle":
            assert d.initial is not None, "an angle driver has its initial angle (symgen.scene.excitation)"
            put(name("theta0"), d.initial, FINITE, f"{key}.initial")
            put(name("rate"), d.rate, FINITE, f"{key}.rate")
            if d.ramp is not None:
                put(name("ramp"), d.ramp, POSITIVE, f"{key}.ramp")
        elif not isinstance(d.torque, str):
            put(name("torque"), d.torque, FINITE, f"{key}.value")
    for i, ld in enumerate(scene.loads):
        for comp in ("axial", "transverse"):
            val = getattr(ld, comp)
            if not isinstance(val, str):
                put(
                    symbol_names.load_parameter(i, comp, point=ld.kind != "distributed"),
                    val,
                    FINITE,
                    f"loads.{i}.{comp}",
                )
    if names is None:
        return list(recs.values())
    missing = [n for n in names if n not in recs]
    if missing:
        raise KeyError(f"no value for parameters {missing}")
    return [recs[n] for n in names]


def parameter_values(scene: Scene, names: Sequence[str]) -> np.ndarray:
    """Numeric values, in ``names`` order, of a model's parameters for this scene (an array of
    :func:`checked_values`)."""
    return np.array(checked_values(scene, names), dtype=float)


def checked_values(scene: Scene, names: Sequence[str]) -> list[float]:
    """Numeric values, in ``names`` order, of a model's parameters for this scene, as floats
    (without numpy: a cached run of the C solver passes them to its library as they are).

    Raises SceneError when a value (a dimensionless group computed from the file's numbers, e.g.
    lambda from E, area, density and omega) is not finite or outside its valid range.
    """
    from symgen.errors import SceneError

    recs = parameter_records(scene, names)
    for r in recs:
        if not r.valid.contains(r.value):
            raise SceneError(
                scene.path,
                r.key,
                f"the model parameter {r.name} computed from it is {r.value!r}; it must be {r.valid.text()}",
                "check the magnitudes and units of the numbers this key depends on",
            )
    return [r.value for r in recs]
