"""Render the C templates (``symgen/backends/c/templates/``, package data) from a context built by ``context.c_context``."""
from __future__ import annotations

from importlib import resources

import jinja2

TEMPLATES = resources.files("symgen.backends.c") / "templates"     # package data (pyproject: package-data)

# output file name (after the prefix) -> template
C_FILES = {
    "{p}.h": "model.h.jinja",
    "{p}.c": "model.c.jinja",
    "{p}_solver.h": "solver.h.jinja",
    "{p}_solver.c": "solver.c.jinja",
    "{p}_sim.c": "sim.c.jinja",
    "CMakeLists.txt": "CMakeLists.txt.jinja",
}


def environment() -> jinja2.Environment:
    return jinja2.Environment(loader=jinja2.PackageLoader("symgen.backends.c", "templates"), undefined=jinja2.StrictUndefined,
                              trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True,
                              autoescape=False)


def render(template: str, ctx: dict) -> str:
    return environment().get_template(template).render(ctx=ctx)


def render_files(ctx: dict, files: dict | None = None) -> dict:
    """{file name: text} of every file in ``files`` (default: the C library, driver, CMake)."""
    env = environment()
    out = {}
    for pattern, template in (files or C_FILES).items():
        out[pattern.format(p=ctx["prefix"])] = env.get_template(template).render(ctx=ctx)
    return out
