"""Render the C templates (``templates/c/``: ``symgen.backends.templates``) from a context built by
``context.c_context``, and copy the C runtime (``symgen/backends/c/runtime/``, package data) beside them."""

from __future__ import annotations

from importlib import resources

import jinja2

from symgen.backends import templates

TEMPLATES = templates.folder("c")

# output file name (after the prefix) -> template
C_FILES = {
    "{p}.h": "model.h.jinja",
    "{p}.c": "model.c.jinja",
    "{p}_jac.c": "model_jac.c.jinja",
    "{p}_solver.h": "solver.h.jinja",
    "{p}_solver.c": "solver.c.jinja",
    "{p}_sim.c": "sim.c.jinja",
    "CMakeLists.txt": "CMakeLists.txt.jinja",
}


#: the model library's translation units (after the prefix): the model functions, their Jacobians
#: (a unit of their own: compiled with cold flags by the in-process build, ``symgen.numerics.csolver``)
#: and the solver (which includes the C runtime)
JAC_UNIT = "_jac"
LIBRARY_UNITS = ("", JAC_UNIT, "_solver")


def library_sources(prefix: str) -> list[str]:
    """The C files of the model library ``prefix`` (the driver ``PREFIX_sim.c`` and an FMU's
    ``PREFIX_fmi2.c`` link with them)."""
    return [f"{prefix}{unit}.c" for unit in LIBRARY_UNITS]


def environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=templates.loader("c"),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )


def render(template: str, ctx: dict) -> str:
    return environment().get_template(template).render(ctx=ctx)


RUNTIME = resources.files("symgen.backends.c") / "runtime"  # the C runtime (package data), copied as is
RUNTIME_FILES = ("symgen_runtime.h", "symgen_linalg.c", "symgen_solver.c")


def runtime_files() -> dict:
    """{file name: text} of the C runtime, the numerics every emitted solver includes."""
    return {name: (RUNTIME / name).read_text() for name in RUNTIME_FILES}


def render_files(ctx: dict, files: dict | None = None) -> dict:
    """{file name: text} of every file in ``files`` (default: the C library, driver, CMake) and
    of the C runtime beside them (the emitted solver includes it)."""
    env = environment()
    out = {}
    for pattern, template in (files or C_FILES).items():
        out[pattern.format(p=ctx["prefix"])] = env.get_template(template).render(ctx=ctx)
    out.update(runtime_files())
    return out
