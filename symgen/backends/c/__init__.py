"""Standalone C99 for a scene: model functions with analytic Jacobians, a DAE solver, a CSV
driver, CMake, and an FMI 2.0 Co-Simulation FMU.

    symgen emit-c examples/slider_crank.toml -o out/slider_crank_c
    symgen emit-fmu examples/slider_crank.toml -o out/slider_crank.fmu

Stages: ``codegen`` lowers the SymPy ``Program`` to straight-line C (forward-mode Jacobians,
one CSE per function), ``context`` collects plain data (sizes, names, partition, defaults),
the jinja2 templates of ``templates/c/`` render the files (glue: the model's functions and its
tables in one descriptor), ``render`` copies the C runtime (``runtime/``: the solver's numerics,
plain C99) beside them, ``fmu`` packs and compiles.

Files written by ``write_c`` (prefix = the scene name):

=====================  =========================================================
``PREFIX.h/.c``        model functions (residual, closure, outputs, Jacobians), names, defaults
``PREFIX_solver.h/.c`` the model descriptor; includes the runtime (internal linkage)
``symgen_*.h/.c``      the C runtime: consistent start, Radau IIA, closure polish, checks
``PREFIX_sim.c``       driver: prints ``tau,<outputs>`` CSV like ``symgen simulate``
``CMakeLists.txt``     library target ``PREFIX`` (``add_subdirectory``) + ``PREFIX_sim``
=====================  =========================================================
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

from symgen.backends.c.files import new_dir
from symgen.backends.c.names import c_prefix

__all__ = ["c_sources", "write_c", "write_fmu", "c_prefix"]


def _model_and_mechanism(scene, model=None, mech=None):
    """The derived model (derived here if not given) and the scene's ``Mechanism``, which the
    caller gives: the coordinate partition and the start come from the numerics, a layer above
    the emitters (``symgen.api.write_c`` / ``write_fmu`` build it)."""
    if mech is None:
        raise TypeError("the C emitter needs the scene's Mechanism (mech=): use symgen.api.write_c or "
                        "symgen.api.write_fmu, which build it")
    if model is None:
        from symgen.model.derive import derive
        model = derive(scene)
    return model, mech


def c_context(scene, model=None, mech=None) -> dict:
    """The template context of a scene (see ``context.c_context``)."""
    from symgen.backends.c.context import c_context as build
    c_prefix(scene)                      # reject a bad prefix before any work
    model, mech = _model_and_mechanism(scene, model, mech)
    return build(scene, model, mech)


def c_sources(scene, model=None, mech=None, ctx: dict | None = None) -> dict:
    """{file name: text} of the C library, its driver and CMakeLists.txt."""
    from symgen.backends.c.render import render_files
    return render_files(ctx if ctx is not None else c_context(scene, model, mech))


def write_tree(files: dict, out_dir: str | os.PathLike) -> Path:
    """Write ``files`` ({relative path: str or bytes}) into ``out_dir`` all or nothing: they are
    rendered into a temporary sibling folder first; a new folder appears only when complete."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        from symgen.errors import SceneError
        raise SceneError("command line", "-o", f"{str(out)!r} exists and is not a folder",
                         "give a folder name, e.g. out/model_c")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = new_dir(out.parent, f".{out.name}.")         # mode 0777 & ~umask, like any output folder
    try:
        for name, text in files.items():
            path = tmp / name
            path.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(text, bytes):
                path.write_bytes(text)
            else:
                path.write_text(text)
        if not out.exists():
            os.replace(tmp, out)
        else:
            for name in files:
                target = out / name
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(tmp / name, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def write_c(scene, out_dir: str | os.PathLike, model=None, mech=None) -> Path:
    """Render the C files of ``scene`` into ``out_dir`` (created; existing files replaced)."""
    return write_tree(c_sources(scene, model, mech), out_dir)


def write_fmu(scene, path: str | os.PathLike, model=None, mech=None, cc: str | None = None) -> Path:
    """Pack the FMI 2.0 Co-Simulation FMU of ``scene`` (sources + linux64 binary) into ``path``."""
    from symgen.backends.fmu import check_fmu_path, write_fmu as write
    check_fmu_path(Path(path))                         # before the derivation
    return write(scene, Path(path), c_context(scene, model, mech), cc=cc)
