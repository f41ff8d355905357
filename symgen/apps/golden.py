"""The checked-in derived artefacts of the example scenes (``generated/<scene>/``).

``symgen derive examples/*.toml -o generated`` writes, per scene:

* ``model.json``: coordinates, closure rows, parameters, outputs, modes, operation counts of
  every CasADi function, and a numeric *fingerprint*: every function evaluated at three seeded
  random points with the scene's parameter values;
* ``equations.tex``: the LaTeX document of the derived equations (``symgen latex``);
* ``c/``: the standalone C of ``symgen emit-c`` (model, Jacobians, solver, driver, CMake).

The golden test regenerates them into a temporary folder and compares: the metadata exactly,
the fingerprint numerically (1e-9 relative: robust to CAS versions, sensitive to any change of
the equations), and the LaTeX and C text only when the SymPy version matches the one recorded
(its printing and CSE change between releases).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from symgen.ir.info import ModelInfo
from symgen.scene.model import Scene

FINGERPRINT_POINTS = 3


def fingerprint(funcs: dict, info: ModelInfo, p: np.ndarray) -> dict:
    rng = np.random.default_rng(20261122)
    n, m = info.n, info.m
    out: dict[str, list] = {}
    for _ in range(FINGERPRINT_POINTS):
        t = float(rng.uniform(0, 2 * np.pi))
        q, v, a = (rng.uniform(-0.5, 0.5, n) for _ in range(3))
        lam = rng.uniform(-0.5, 0.5, m)
        for name, f in sorted(funcs.items()):
            val = np.array(f(t, q, v, a, lam, p)).ravel()
            out.setdefault(name, []).append([float(f"{x:.14g}") for x in val])
    return out


def generated_payload(scene: Scene) -> dict:
    """Everything ``write_generated`` writes, as data (used by the golden test too)."""
    import sympy

    from symgen import __version__
    from symgen.model.derive import derive
    from symgen.backends.casadi import functions as casadi_emit
    from symgen.backends.casadi.store import CASADI_VERSION
    from symgen.backends.latex.document import latex_document
    from symgen.ir.parameters import parameter_values

    model = derive(scene)
    funcs = casadi_emit.build_functions(model)
    funcs = {name: funcs[name] for name in casadi_emit.FUNCTION_NAMES}  # the model's (bar blocks inline)
    info = ModelInfo.of(model)
    record = info.to_json()
    record.pop("timings", None)
    record["scene_name"] = scene.name
    p = parameter_values(scene, info.params)
    record["parameter_values"] = [float(x) for x in p]
    record["operations"] = {
        name: {"instructions": int(f.n_instructions()), "nodes": int(f.n_nodes())} for name, f in sorted(funcs.items())
    }
    record["fingerprint"] = fingerprint(funcs, info, p)
    record["versions"] = {"symgen": __version__, "sympy": sympy.__version__, "casadi": CASADI_VERSION}
    record["scene_file"] = Path(scene.path).name
    payload = {
        "model.json": json.dumps(record, indent=1, sort_keys=True) + "\n",
        "equations.tex": latex_document(scene, model),
    }
    payload.update({f"c/{name}": text for name, text in _c_payload(scene, model, funcs, info).items()})
    return payload


def _c_payload(scene: Scene, model, funcs: dict, info: ModelInfo) -> dict:
    """The files of ``symgen emit-c`` (the solver's start plan from the CasADi Functions)."""
    from symgen.backends.c import c_sources
    from symgen.backends.casadi.pipeline import CompiledModel
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.start import start_plan

    mech = Mechanism(CompiledModel(funcs, info, 0.0, 0.0, False), scene)
    return c_sources(scene, model, start_plan(mech), info=info)


def write_generated(scene: Scene, root: Path) -> Path:
    from symgen.numerics.results import atomic_write

    target = Path(root) / scene.name
    for name, text in generated_payload(scene).items():
        atomic_write(target / name, text)
    return target
