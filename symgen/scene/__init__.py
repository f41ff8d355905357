"""Scene stage: load and validate a TOML scene file into frozen, dimensionless dataclasses.

>>> from symgen.scene import load_scene
>>> scene = load_scene("examples/slider_crank.toml")   # doctest: +SKIP
"""

from __future__ import annotations

from symgen.scene.loader import load_scene, parse_scene, scene_hash, scene_of
from symgen.scene.model import (
    GROUND,
    OUTPUT_KINDS,
    Body,
    BodyDeformation,
    Driver,
    Effects,
    Initial,
    Joint,
    JointEnd,
    Load,
    Output,
    Scene,
    Simulation,
)
from symgen.scene.overrides import apply_overrides


def __getattr__(name: str) -> object:
    """The expressions' parser, imported on first use: a scene without expressions never needs it."""
    if name in ("parse_tau_expression", "tau_symbol"):
        from symgen.scene import expressions

        return getattr(expressions, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "load_scene",
    "scene_of",
    "apply_overrides",
    "parse_scene",
    "scene_hash",
    "parse_tau_expression",
    "tau_symbol",
    "GROUND",
    "OUTPUT_KINDS",
    "Body",
    "BodyDeformation",
    "Driver",
    "Effects",
    "Initial",
    "Joint",
    "JointEnd",
    "Load",
    "Output",
    "Scene",
    "Simulation",
]
