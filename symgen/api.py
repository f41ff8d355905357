"""Python entry points: the same stages as the command line, for scripts and tests.

>>> from symgen.api import simulate_scene
>>> result = simulate_scene("examples/slider_crank.toml", ["simulation.cycles=0.5"])  # doctest: +SKIP
>>> result.column("eta_mid").max()                                                   # doctest: +SKIP
"""
from __future__ import annotations

import os
from typing import Sequence

from .pipeline import compile_scene
from .run.mechanism import Mechanism
from .run.simulate import SimResult, simulate
from .scene import load_scene
from .scene.model import Scene


def mechanism(scene: Scene | str | os.PathLike, overrides: Sequence[str] = (),
              use_cache: bool = True) -> Mechanism:
    """The compiled model of a scene with its parameter values, ready to run."""
    if not isinstance(scene, Scene):
        scene = load_scene(scene, overrides)
    elif overrides:
        raise ValueError("overrides apply to a scene file; pass the path, or load_scene(path, overrides)")
    return Mechanism(compile_scene(scene, use_cache=use_cache), scene)


def simulate_scene(scene: Scene | str | os.PathLike, overrides: Sequence[str] = (), **kwargs) -> SimResult:
    """Load (if needed), derive or load from cache, and simulate; kwargs go to ``simulate``."""
    return simulate(mechanism(scene, overrides), **kwargs)


def quasi_static_scene(scene: Scene | str | os.PathLike, overrides: Sequence[str] = (), **kwargs):
    """The quasi-static response (18)-(20) over a cycle; kwargs go to
    ``symgen.run.quasistatic.quasi_static`` (kinematics, cycles, output_step, taus)."""
    from .run.quasistatic import quasi_static
    return quasi_static(mechanism(scene, overrides), **kwargs)


def modes_scene(scene: Scene | str | os.PathLike, overrides: Sequence[str] = (), tau: float = 0.0, **kwargs):
    """Natural frequencies and mode shapes about the quasi-static state at input position tau."""
    from .run.modes import modes
    return modes(mechanism(scene, overrides), tau=tau, **kwargs)
