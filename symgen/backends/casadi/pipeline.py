"""Scene -> derived model -> CasADi Functions, with the on-disk model cache.

The cache is keyed by the *structure* of a scene (topology, effects, mode counts, shape
families, outputs): a change of parameter values (lambda, mu, lengths, rates, loads...) reuses
the cached Functions; nothing is re-derived. Entries are verified before use and re-derived
when they do not verify (:mod:`symgen.cache`, :mod:`symgen.backends.casadi.store`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from symgen import cache
from symgen.scene.model import Scene


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
    from symgen.backends.casadi import store as casadi_io
    from symgen.model.structure import structure_key, structure_of

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
    from symgen.model.derive import derive
    from symgen.backends.casadi import functions as casadi_emit
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
