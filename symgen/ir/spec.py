"""The typed input of a derivation: what shapes the derived equations, and nothing that is
only a value.

:class:`ModelSpec` holds the scene's *structure* (per bar its kind, function counts, shape
families, static correction points; the joints, the driver, the effects, the loads and the
outputs as far as they shape the equations). ``symgen.model.structure.model_spec`` builds it
from a scene; the derivation reads it; its canonical JSON (:meth:`ModelSpec.to_json`) is what
the model cache's key hashes (:meth:`ModelSpec.key`) and what a derived model carries as its
``structure``. Values (lambda, mu, lengths, rates, masses, load values) are not part of it:
they become parameter symbols, so changing them reuses the cached model.

The JSON keeps the layout the cache keys were first made from: fields that were added later
(static correction points, a joint's rotary inertia, a driver's law, ramp or rotor, the
per-bar axial treatment, the ``[[masses]]``) appear only when they are set, so the key of a scene without them is
unchanged. Kept free of SymPy, so a cached run never imports it.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

__all__ = [
    "DYNAMIC",
    "INEXTENSIBLE",
    "OFF",
    "QUASI_STATIC",
    "BodySpec",
    "DriverSpec",
    "EffectsSpec",
    "EndSpec",
    "JointSpec",
    "LoadSpec",
    "MassSpec",
    "ModelSpec",
    "OutputSpec",
    "spec_key",
]

#: the axial treatments of an elastic bar (``symgen.model.structure.AxialTreatment``)
DYNAMIC = "dynamic"
QUASI_STATIC = "quasi_static"
INEXTENSIBLE = "inextensible"
OFF = "off"


@dataclass(frozen=True)
class BodySpec:
    """One bar. ``na``, ``nt``: its standard axial and transverse functions with the effects
    applied (a slot guide's ``nt`` includes its overhang's own functions); ``axial_shapes``,
    ``transverse_shapes``: their families ("" when there are none); ``tip_joint``: a joint acts
    at its free end (transverse functions only); ``static_axial``, ``static_transverse``: the
    interior points whose static correction functions close its bases; ``static_moment``: the
    interior points (a rigid body with a rotary inertia or an arm, a joint's rotary inertia)
    whose transverse moment correction functions follow those."""

    name: str
    rigid: bool
    frame: str  # "pinned-pinned" | "cantilever" | "" (rigid)
    na: int
    nt: int
    axial_shapes: str
    transverse_shapes: str
    tip_joint: bool
    static_axial: tuple[float, ...] = ()
    static_transverse: tuple[float, ...] = ()
    static_moment: tuple[float, ...] = ()

    @property
    def sizes(self) -> tuple[int, int]:
        """(axial, transverse) numbers of amplitudes: the functions and the static corrections."""
        return self.na + len(self.static_axial), self.nt + len(self.static_transverse) + len(self.static_moment)

    def to_json(self) -> dict[str, Any]:
        out = {
            "name": self.name,
            "rigid": self.rigid,
            "frame": self.frame,
            "na": self.na,
            "nt": self.nt,
            "axial_shapes": self.axial_shapes,
            "transverse_shapes": self.transverse_shapes,
            "tip_joint": self.tip_joint,
        }
        pts = {
            k: list(v)
            for k, v in (
                ("transverse", self.static_transverse),
                ("axial", self.static_axial),
                ("moment", self.static_moment),
            )
            if v
        }
        if pts:  # only then: the keys of scenes without them are unchanged
            out["static_points"] = pts
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> BodySpec:
        pts = d.get("static_points") or {}
        return cls(
            d["name"],
            d["rigid"],
            d["frame"],
            d["na"],
            d["nt"],
            d["axial_shapes"],
            d["transverse_shapes"],
            d["tip_joint"],
            tuple(pts.get("axial", ())),
            tuple(pts.get("transverse", ())),
            tuple(pts.get("moment", ())),
        )


@dataclass(frozen=True)
class EndSpec:
    """One side of a joint: a bar at ``xi``, or the ground (``xi`` None; also for a slot's
    guide, whose point is the moving support)."""

    body: str
    xi: float | None


@dataclass(frozen=True)
class JointSpec:
    """One joint: its ends in the scene's order, whether it carries a lumped mass or rotary
    inertia, a slot's overhang ``(kind, functions)``."""

    name: str
    kind: str  # "pin" | "slider" | "slot"
    ends: tuple[EndSpec, ...]
    mass: bool
    inertia: bool = False
    overhang: tuple[str, int] | None = None  # slots only

    def to_json(self) -> dict[str, Any]:
        out = {"name": self.name, "kind": self.kind, "ends": [[e.body, e.xi] for e in self.ends], "mass": self.mass}
        if self.inertia:  # only then: the keys of scenes without it are unchanged
            out["inertia"] = True
        if self.overhang is not None:
            out["overhang"] = list(self.overhang)
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> JointSpec:
        oh = d.get("overhang")
        return cls(
            d["name"],
            d["kind"],
            tuple(EndSpec(b, xi) for b, xi in d["ends"]),
            d["mass"],
            bool(d.get("inertia")),
            None if oh is None else (oh[0], oh[1]),
        )


@dataclass(frozen=True)
class MassSpec:
    """A ``[[masses]]`` entry: a point mass at ``xi`` of bar ``body``; whether it has a mass, a
    rotary inertia and an offset from the bar's axis (a rigid attachment turning with the
    cross-section). Its parameters are named by its position in the list."""

    body: str
    xi: float
    mass: bool
    inertia: bool = False
    offset: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"body": self.body, "xi": self.xi, "mass": self.mass, "inertia": self.inertia, "offset": self.offset}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> MassSpec:
        return cls(d["body"], d["xi"], d["mass"], d["inertia"], d["offset"])


@dataclass(frozen=True)
class DriverSpec:
    """The driver: ``torque`` is "const" or the expression of tau a torque driver applies;
    ``law`` the expression of tau of a prescribed angle (None: constant speed); ``ramp``: a
    spin-up; ``rotor_inertia``: a rotor on the driven shaft."""

    kind: str  # "angle" | "torque"
    body: str
    torque: str = "const"
    law: str | None = None
    ramp: bool = False
    rotor_inertia: bool = False

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind, "body": self.body, "torque": self.torque}
        if self.law is not None:  # only then: the keys of constant-speed scenes are unchanged
            out["law"] = self.law
        if self.ramp:
            out["ramp"] = True
        if self.rotor_inertia:
            out["rotor_inertia"] = True
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> DriverSpec:
        return cls(d["kind"], d["body"], d["torque"], d.get("law"), bool(d.get("ramp")), bool(d.get("rotor_inertia")))


@dataclass(frozen=True)
class LoadSpec:
    """A load: its components are "const" (a parameter) or an expression of tau."""

    body: str
    kind: str  # "distributed" | "point"
    xi: float | None
    axial: str
    transverse: str

    def to_json(self) -> dict[str, Any]:
        return {"body": self.body, "kind": self.kind, "xi": self.xi, "axial": self.axial, "transverse": self.transverse}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> LoadSpec:
        return cls(d["body"], d["kind"], d["xi"], d["axial"], d["transverse"])


@dataclass(frozen=True)
class OutputSpec:
    name: str
    kind: str
    body: str | None = None
    joint: str | None = None
    xi: float | None = None
    component: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "body": self.body,
            "joint": self.joint,
            "xi": self.xi,
            "component": self.component,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> OutputSpec:
        return cls(d["name"], d["kind"], d["body"], d["joint"], d["xi"], d["component"])


@dataclass(frozen=True)
class EffectsSpec:
    """The effects that shape the equations: the flags of the bar equations, whether gravity
    and damping act, and ``axial``: every elastic bar's axial treatment ``(bar, treatment)``,
    sorted by bar, when one of them is quasi-static or inextensible (otherwise None: a bar with
    axial functions is then dynamic, one without is off)."""

    coriolis: bool
    geometric_stiffening: bool
    rotary_inertia: bool
    strain: str  # "von_karman" | "linear" | "exact"
    gravity: bool
    damping: bool
    axial: tuple[tuple[str, str], ...] | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "coriolis": self.coriolis,
            "geometric_stiffening": self.geometric_stiffening,
            "rotary_inertia": self.rotary_inertia,
            "strain": self.strain,
            "gravity": self.gravity,
            "damping": self.damping,
        }
        if self.axial is not None:  # only then: the keys of every other scene are unchanged
            out["axial"] = dict(self.axial)
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> EffectsSpec:
        ax = d.get("axial")
        return cls(
            d["coriolis"],
            d["geometric_stiffening"],
            d["rotary_inertia"],
            d["strain"],
            d["gravity"],
            d["damping"],
            None if ax is None else tuple(sorted(ax.items())),
        )


@dataclass(frozen=True)
class ModelSpec:
    """Everything that shapes a derived model; ``version``: (symgen's version, the derivation's)."""

    version: tuple[str, str]
    bodies: tuple[BodySpec, ...]
    joints: tuple[JointSpec, ...]
    drivers: tuple[DriverSpec, ...]  # in the scene's order
    effects: EffectsSpec
    loads: tuple[LoadSpec, ...]
    outputs: tuple[OutputSpec, ...]
    masses: tuple[MassSpec, ...] = ()  # [[masses]]: point masses and rigid attachments on bars

    @property
    def driver(self) -> DriverSpec | None:
        """The only driver (None without one); several drivers are refused (read ``drivers``)."""
        if len(self.drivers) > 1:
            raise ValueError(f"the model has {len(self.drivers)} drivers; read ModelSpec.drivers")
        return self.drivers[0] if self.drivers else None

    def body(self, name: str) -> BodySpec:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    def axial_treatment(self, name: str) -> str:
        """The axial treatment of elastic bar ``name``: "dynamic", "quasi_static",
        "inextensible" or "off"."""
        b = self.body(name)
        if self.effects.axial is not None:
            return dict(self.effects.axial)[name]
        return DYNAMIC if b.na else OFF

    def axial_treatments(self) -> dict[str, str]:
        """bar -> axial treatment of every elastic bar, in the scene's order."""
        return {b.name: self.axial_treatment(b.name) for b in self.bodies if not b.rigid}

    def overhang_modes(self, name: str) -> int:
        """The overhang's own bending functions of slot guide ``name`` (0: none, or not a guide)."""
        b = self.body(name)
        if b.rigid or not b.nt:
            return 0
        return sum(  # the contact-slope function chi_0 and the overhang's own (symgen.model.structure.overhang_modes)
            j.overhang[1] + 1
            for j in self.joints
            if j.kind == "slot" and j.overhang is not None and j.overhang[1] and j.ends[1].body == name
        )

    def to_json(self) -> dict[str, Any]:
        """The canonical JSON (the layout of the cache keys; ``json.dumps(..., sort_keys=True)``
        of it is hashed)."""
        out: dict[str, Any] = {
            "version": list(self.version),
            "bodies": [b.to_json() for b in self.bodies],
            "joints": [j.to_json() for j in self.joints],
            "driver": self.drivers[0].to_json() if len(self.drivers) == 1 else None,
            "effects": self.effects.to_json(),
            "loads": [ld.to_json() for ld in self.loads],
            "outputs": [o.to_json() for o in self.outputs],
        }
        if self.masses:  # only then: the keys of scenes without them are unchanged
            out["masses"] = [m.to_json() for m in self.masses]
        if len(self.drivers) > 1:  # only then: a scene with one driver or none keeps its keys
            out["drivers"] = [d.to_json() for d in self.drivers]
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> ModelSpec:
        return cls(
            tuple(d["version"]),
            tuple(BodySpec.from_json(b) for b in d["bodies"]),
            tuple(JointSpec.from_json(j) for j in d["joints"]),
            _drivers_from_json(d),
            EffectsSpec.from_json(d["effects"]),
            tuple(LoadSpec.from_json(ld) for ld in d["loads"]),
            tuple(OutputSpec.from_json(o) for o in d["outputs"]),
            tuple(MassSpec.from_json(m) for m in d.get("masses", ())),
        )

    def key(self) -> str:
        """The model cache's key: :func:`spec_key` of the canonical JSON."""
        return spec_key(self.to_json())


def _drivers_from_json(d: dict[str, Any]) -> tuple[DriverSpec, ...]:
    """``drivers`` (several) or ``driver`` (one, or null: none) of a ModelSpec's JSON."""
    if "drivers" in d:
        if d["driver"] is not None or len(d["drivers"]) < 2:
            raise ValueError("a ModelSpec lists several drivers under 'drivers' and then has 'driver': null")
        return tuple(DriverSpec.from_json(x) for x in d["drivers"])
    return () if d["driver"] is None else (DriverSpec.from_json(d["driver"]),)


def spec_key(structure: dict[str, Any]) -> str:
    """The 20 hex digits of the sha256 of a structure's canonical JSON (sorted keys)."""
    return hashlib.sha256(json.dumps(structure, sort_keys=True).encode()).hexdigest()[:20]
