"""Standalone C99 for a scene: model functions with analytic Jacobians, a DAE solver, a CSV
driver, CMake, and an FMI 2.0 Co-Simulation FMU.

    symgen emit-c examples/slider_crank.toml -o out/slider_crank_c
    symgen emit-fmu examples/slider_crank.toml -o out/slider_crank.fmu

The emitter takes data: the scene, its derived model (``symgen.ir.records.DerivedModel``), the
start of its run (``symgen.ir.plan.StartPlan``, made by ``symgen.numerics.start.start_plan``)
and optionally the model's ``symgen.ir.info.ModelInfo``; it derives nothing and runs no
numerics (``symgen.api.write_c`` / ``write_fmu`` derive once and make the plan).

Stages: ``codegen`` lowers the SymPy ``Program`` to straight-line C (forward-mode Jacobians,
one CSE per function), ``context`` collects plain data (sizes, names, partition, defaults),
the jinja2 templates of ``templates/c/`` render the files (glue: the model's functions and its
tables in one descriptor), ``render`` copies the C runtime (``runtime/``: the solver's numerics,
plain C99) beside them, ``fmu`` packs and compiles.

Files written by ``write_c`` (prefix = the scene name):

=====================  =========================================================
``PREFIX.h/.c``        model functions (residual, closure, outputs), names, defaults
``PREFIX_jac.c``       their Jacobians (a unit of their own: evaluated once per Jacobian
                       update, compiled with cold flags by ``symgen simulate --solver c``)
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


def c_context(scene, model, plan, info=None) -> dict:
    """The template context of a scene (see ``context.c_context``)."""
    from symgen.backends.c.context import c_context as build

    c_prefix(scene)  # reject a bad prefix before any work
    return build(scene, model, plan, info)


def c_sources(scene, model, plan, info=None) -> dict:
    """{file name: text} of the C library, its driver and CMakeLists.txt."""
    from symgen.backends.c.render import render_files

    return render_files(c_context(scene, model, plan, info))


def write_tree(files: dict, out_dir: str | os.PathLike) -> Path:
    """Write ``files`` ({relative path: str or bytes}) into ``out_dir`` all or nothing: they are
    rendered into a temporary sibling folder first; a new folder appears only when complete."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        from symgen.errors import SceneError

        raise SceneError(
            "command line", "-o", f"{str(out)!r} exists and is not a folder", "give a folder name, e.g. out/model_c"
        )
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = new_dir(out.parent, f".{out.name}.")  # mode 0777 & ~umask, like any output folder
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


def write_c(scene, out_dir: str | os.PathLike, model, plan, info=None) -> Path:
    """Render the C files of ``scene`` into ``out_dir`` (created; existing files replaced)."""
    return write_tree(c_sources(scene, model, plan, info), out_dir)


def write_fmu(scene, path: str | os.PathLike, model, plan, info=None, cc: str | None = None) -> Path:
    """Pack the FMI 2.0 Co-Simulation FMU of ``scene`` (sources + linux64 binary) into ``path``."""
    from symgen.backends.fmu import check_fmu_path, write_fmu as write

    check_fmu_path(Path(path))
    return write(scene, Path(path), c_context(scene, model, plan, info), cc=cc)
