"""What shapes a derived model: the scene's *structure* (topology, effects, mode counts, shape
families, outputs), and the cache key made from it. Values (lambda, mu, lengths, rates, loads)
are not part of it: changing them reuses the cached model.

Kept free of SymPy so that a cached run never imports it.
"""
from __future__ import annotations

import hashlib
import json

from . import __version__
from .scene.model import Scene

DERIVE_VERSION = "3"


def effective_modes(scene: Scene, body) -> tuple[int, int]:
    """(axial, transverse) function counts of a bar; a slot guide's transverse count includes
    its overhang's own functions (``overhang_modes``, appended after the span's)."""
    if body.rigid:
        return 0, 0
    na = body.axial_modes if scene.effects.axial else 0
    nt = body.transverse_modes if scene.effects.transverse else 0
    return na, nt + (overhang_modes(scene, body) if nt else 0)


def overhang_modes(scene: Scene, body) -> int:
    """Number of the overhang's own bending functions of a slot guide (0: rigid overhang, the
    seed's form, no bending, or not a guide)."""
    if body.rigid or not (scene.effects.transverse and body.transverse_modes):
        return 0
    return sum(j.overhang_modes for j in scene.joints if j.kind == "slot" and j.ends[1].body == body.name)


INEXTENSIBLE = "inextensible"


def inextensible(scene: Scene) -> bool:
    """``effects.axial = "inextensible"``: every elastic bar's axial functions carry the
    constraint (phi'_k, eps) = 0 and its multipliers (the axial force), not lambda eps."""
    return scene.effects.axial == INEXTENSIBLE


def _tip_joint(scene: Scene, name: str) -> bool:
    return any(e.body == name and e.xi is not None and abs(e.xi - 1.0) < 1e-12
               for j in scene.joints for e in j.ends)


def structure_of(scene: Scene) -> dict:
    """Everything that shapes the derived equations (and nothing that is only a value)."""
    eff = scene.effects
    bodies = []
    for b in scene.bodies:
        na, nt = effective_modes(scene, b)
        bodies.append({"name": b.name, "rigid": b.rigid, "frame": b.frame, "na": na, "nt": nt,
                       "axial_shapes": b.axial_shapes if na else "", "transverse_shapes": b.transverse_shapes if nt else "",
                       "tip_joint": _tip_joint(scene, b.name) if nt else False})
    joints = [{"name": j.name, "kind": j.kind, "ends": [[e.body, e.xi] for e in j.ends],
               "mass": j.mass > 0} for j in scene.joints]
    for j, entry in zip(scene.joints, joints):
        if j.kind == "slot":
            entry["overhang"] = [j.overhang, j.overhang_modes]
    drv = None
    if scene.driver is not None:
        d = scene.driver
        drv = {"kind": d.kind, "body": d.body,
               "torque": d.torque if isinstance(d.torque, str) else "const"}
        if d.law is not None:          # only then: the keys of constant-speed scenes are unchanged
            drv["law"] = d.law
        if d.ramp is not None:
            drv["ramp"] = True
    loads = [{"body": ld.body, "kind": ld.kind, "xi": ld.xi,
              "axial": ld.axial if isinstance(ld.axial, str) else "const",
              "transverse": ld.transverse if isinstance(ld.transverse, str) else "const"} for ld in scene.loads]
    outputs = [{"name": o.name, "kind": o.kind, "body": o.body, "joint": o.joint, "xi": o.xi,
                "component": o.component} for o in scene.outputs]
    effects = {"coriolis": eff.coriolis, "geometric_stiffening": eff.geometric_stiffening,
               "rotary_inertia": eff.rotary_inertia, "strain": eff.strain,
               "gravity": any(x != 0 for x in eff.gravity), "damping": eff.damping > 0}
    if inextensible(scene):
        effects["axial"] = INEXTENSIBLE     # only then: the keys of every other scene are unchanged
    return {"version": [__version__, DERIVE_VERSION], "bodies": bodies, "joints": joints, "driver": drv,
            "effects": effects, "loads": loads, "outputs": outputs}


def structure_key(structure: dict) -> str:
    return hashlib.sha256(json.dumps(structure, sort_keys=True).encode()).hexdigest()[:20]
