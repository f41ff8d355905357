"""Scene -> derived model -> CasADi Functions, with the on-disk model cache.

The cache is keyed by the *structure* of a scene (topology, effects, mode counts, shape
families, outputs): a change of parameter values (lambda, mu, lengths, rates, loads...) reuses
the cached Functions; nothing is re-derived. Entries are verified before use and re-derived
when they do not verify (:mod:`symgen.cache`, :mod:`symgen.emit.casadi_io`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import cache
from .scene.model import GROUND, Scene


def cache_dir() -> Path:
    """Root of the on-disk caches (``$SYMGEN_CACHE_DIR``, default ``~/.cache/symgen``)."""
    return cache.cache_root()


@dataclass
class CompiledModel:
    funcs: dict
    meta: dict
    derive_s: float          # time the derivation took (when it was done)
    build_s: float           # CasADi build, or load from cache, in this process
    cached: bool


def compile_scene(scene: Scene, use_cache: bool = True) -> CompiledModel:
    """Derived model of ``scene`` as CasADi Functions (from the cache when possible)."""
    from .emit import casadi_io
    from .structure import structure_key, structure_of

    key = structure_key(structure_of(scene))
    where = cache.models_dir() / key
    replace = False
    if use_cache and (where.exists() or where.is_symlink()):
        t0 = time.perf_counter()
        try:
            funcs, meta = casadi_io.load(where, key)
            return CompiledModel(funcs, meta, meta["timings"]["derive_s"], time.perf_counter() - t0, True)
        except cache.InvalidEntry as exc:
            cache.report_invalid(where, exc.reason)
            replace = True
        except FileNotFoundError:  # removed meanwhile (symgen cache clear): derive it
            pass
        except Exception as exc:  # unreadable: never trusted, never fatal
            cache.report_invalid(where, f"cannot be read ({type(exc).__name__}: {exc})")
            replace = True
    from .dae import derive
    from .emit import casadi_emit
    model = derive(scene)
    t0 = time.perf_counter()
    funcs = casadi_emit.build_functions(model)
    build_s = time.perf_counter() - t0
    meta = casadi_emit.model_meta(model)
    meta["timings"]["build_s"] = build_s
    if use_cache:
        try:
            casadi_emit.save(funcs, meta, where, replace=replace)
        except (OSError, ValueError) as exc:
            cache.report_unwritable(where, exc)
    return CompiledModel(funcs, meta, model.timings["derive_s"], build_s, False)


def parameter_values(scene: Scene, names: list[str]) -> np.ndarray:
    """Numeric values, in ``names`` order, of a model's parameters for this scene."""
    vals: dict[str, float] = {}
    for b in scene.bodies:
        vals[f"alpha_{b.name}"] = b.alpha
        vals[f"nu_{b.name}"] = b.nu
        if b.lam is not None:
            vals[f"lambda_{b.name}"] = b.lam
        if b.mu is not None:
            vals[f"mu_{b.name}"] = b.mu
    eff = scene.effects
    vals["gx"], vals["gy"] = eff.gravity
    vals["damping"] = eff.damping
    for j in scene.joints:
        for e in j.ends:
            if e.body == GROUND:
                vals[f"px_{j.name}"], vals[f"py_{j.name}"] = e.point
        if j.direction is not None:
            vals[f"dx_{j.name}"], vals[f"dy_{j.name}"] = j.direction
        vals[f"m_{j.name}"] = j.mass
    d = scene.driver
    if d is not None:
        if d.kind == "angle":
            vals["theta0"], vals["rate"] = d.initial, d.rate
            if d.ramp is not None:
                vals["ramp"] = d.ramp
        elif not isinstance(d.torque, str):
            vals["torque"] = float(d.torque)
    for i, ld in enumerate(scene.loads):
        for comp in ("axial", "transverse"):
            val = getattr(ld, comp)
            if not isinstance(val, str):
                vals[f"load{i + 1}_{comp}"] = float(val)
    missing = [n for n in names if n not in vals]
    if missing:
        raise KeyError(f"no value for parameters {missing}")
    return np.array([vals[n] for n in names], dtype=float)
