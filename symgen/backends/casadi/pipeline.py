"""Scene -> derived model -> CasADi Functions, with the on-disk model cache.

The cache is keyed by the *structure* of a scene (topology, effects, mode counts, shape
families, outputs): a change of parameter values (lambda, mu, lengths, rates, loads...) reuses
the cached Functions; nothing is re-derived. Entries are verified before use and re-derived
when they do not verify (:mod:`symgen.cache`, :mod:`symgen.backends.casadi.store`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from symgen import cache
from symgen.ir.info import ModelInfo
from symgen.scene.model import Scene

if TYPE_CHECKING:
    from symgen.ir.records import DerivedModel  # SymPy: not imported on a cached run


def cache_dir() -> Path:
    """Root of the on-disk caches (``$SYMGEN_CACHE_DIR``, default ``~/.cache/symgen``)."""
    return cache.cache_root()


@dataclass
class CompiledModel:
    funcs: Mapping  # name -> CasADi Function (store.LazyFunctions: read on first use)
    info: ModelInfo
    derive_s: float  # time the derivation took (when it was done)
    build_s: float  # CasADi build, or load from cache, in this process
    cached: bool


def compile_scene(scene: Scene, use_cache: bool = True, lazy: bool = False) -> CompiledModel:
    """Derived model of ``scene`` as CasADi Functions (from the cache when possible; ``lazy``: a
    cached model's Functions read by CasADi on first use, :func:`store.load_lazy`)."""
    from symgen.model.structure import structure_key, structure_of

    key = structure_key(structure_of(scene))
    compiled, replace = _cached(key, lazy) if use_cache else (None, False)
    if compiled is not None:
        return compiled
    from symgen.model.derive import derive

    model = derive(scene)
    if use_cache:
        _sample_shapes(model.structure)
    _DERIVED[(scene.hash, key)] = model
    while len(_DERIVED) > DERIVED_KEPT:
        _DERIVED.popitem(last=False)
    return _build(model, use_cache, replace)


#: the models :func:`compile_scene` derived last in this process, by (the scene's hash, the model's
#: structure key), at most ``DERIVED_KEPT``, until :func:`take_derived` takes one: the emitted C
#: solver's first build (``symgen.numerics.csolver``) renders its C from the model the run derived,
#: instead of deriving the scene again (slot_dyad: 12.6 s twice; "derive once")
_DERIVED: OrderedDict[tuple[str, str], DerivedModel] = OrderedDict()
DERIVED_KEPT = 2


def take_derived(scene: Scene, key: str) -> DerivedModel | None:
    """The model of ``scene`` (structure ``key``) that :func:`compile_scene` derived in this
    process, once (it is then dropped), or None."""
    return _DERIVED.pop((scene.hash, key), None)


def _sample_shapes(structure: dict) -> None:
    """The bars' shape functions at quadrature nodes, into the signed cache, where the
    model-form estimate and the range check (the bars' slopes and stretches,
    ``symgen.numerics.checks.range_tables``) of the model's runs read them without SymPy
    (:mod:`symgen.model.shape_samples`): every elastic bar."""
    from symgen.model.shape_samples import remember_samples

    remember_samples(structure)


def compile_model(model, use_cache: bool = True) -> CompiledModel:
    """The CasADi Functions of a model already derived (``symgen.model.derive.derive``): from the
    cache when it holds the model's structure, else built from ``model`` (and stored); the
    model is never derived again."""
    compiled, replace = _cached(model.key) if use_cache else (None, False)
    return compiled if compiled is not None else _build(model, use_cache, replace)


def _cached(key: str, lazy: bool = False) -> tuple[CompiledModel | None, bool]:
    """(the verified cache entry of ``key`` or None, whether a bad entry is to be replaced)."""
    from symgen.backends.casadi import store as casadi_io

    where = cache.models_dir() / key
    if not (where.exists() or where.is_symlink()):
        return None, False
    t0 = time.perf_counter()
    try:
        funcs, info = casadi_io.load_lazy(where, key) if lazy else casadi_io.load(where, key)
        return CompiledModel(funcs, info, info.timings["derive_s"], time.perf_counter() - t0, True), False
    except cache.InvalidEntry as exc:
        cache.report_invalid(where, exc)
        return None, True
    except FileNotFoundError:  # removed meanwhile (symgen cache clear): derive it
        return None, False
    except Exception as exc:  # unreadable: never trusted, never fatal
        cache.report_invalid(where, f"cannot be read ({type(exc).__name__}: {exc})")
        return None, True


def _build(model, use_cache: bool, replace: bool) -> CompiledModel:
    from symgen.backends.casadi import functions as casadi_emit

    t0 = time.perf_counter()
    funcs = casadi_emit.build_functions(model)
    build_s = time.perf_counter() - t0
    info = ModelInfo.of(model).with_timings(build_s=build_s)
    if use_cache:
        where = cache.models_dir() / model.key
        try:
            casadi_emit.save(funcs, info, where, replace=replace)
        except (OSError, ValueError) as exc:
            cache.report_unwritable(where, exc)
    return CompiledModel(funcs, info, model.timings["derive_s"], build_s, False)
