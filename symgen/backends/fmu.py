"""FMI 2.0 Co-Simulation FMU of a scene: ``modelDescription.xml`` (variables named after the
scene's outputs and parameters), the C sources, and ``binaries/linux64/<prefix>.so``.

The FMU's time is the model's tau for a dimensionless scene. Outputs are ``causality="output"``
(value references 0..n_out-1), parameters ``causality="parameter"``, ``variability="fixed"``
with the scene's values as start values (value references after the outputs), except the
applied moment of each torque driver given as a number: a ``causality="input"`` (continuous,
held over a communication step, in the model's units), settable between steps.

An SI scene's FMU is in SI: its time is t in seconds (tau = omega t; the default experiment in
seconds), its outputs in SI (the factors of ``symgen simulate``'s SI columns, computed in the C
from the physical inputs: symgen.ir.physical), and its physical inputs (E, area, inertia,
density or mass per length, lengths, omega) are parameters too, after the model's, in SI; the
model parameters computed from those set follow them. Every SI variable has its ``unit``
(``UnitDefinitions`` give their SI base units), and the time is the independent variable. ``fmi2DoStep`` runs the emitted
Radau IIA solver to the next communication point; the tolerance comes from
``fmi2SetupExperiment`` (else the scene's ``rtol``; ``atol`` keeps the scene's ratio).
"""

from __future__ import annotations

import math
import os
import platform
import tempfile
import uuid
import zipfile
from pathlib import Path

from symgen.errors import SceneError
from symgen.ir import names as symbol_names
from symgen.ir.parameters import parameter_records
from symgen.backends.c.build import BuildError, compile_shared
from symgen.backends.c.files import new_file
from symgen.backends.c.names import c_string, xml_attr
from symgen.backends.c.printer import c_double
from symgen.backends.c.render import TEMPLATES, environment

FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")


def fmu_guid(ctx: dict) -> str:
    """A GUID fixed by the scene (hash), the generator version and the emitted equations."""
    key = "|".join([ctx["scene_hash"], ctx["version"], *ctx["ops"]])
    return "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "symgen:" + key)) + "}"


def torque_inputs(scene) -> dict[str, str]:
    """{parameter name: driven bar} of the FMU's inputs: the applied moment of every torque
    driver given as a number (one real input each; an expression of tau is the FMU's own)."""
    return {
        symbol_names.driver_parameter("torque", i).text: d.body
        for i, d in enumerate(scene.drivers)
        if d.kind == "torque" and not isinstance(d.torque, str)
    }


def fmu_context(scene, ctx: dict) -> dict:
    outputs = [o.name for o in scene.outputs]
    params = list(ctx["parameter_plain"])
    taken = set(outputs)
    variables = []
    for k, o in enumerate(scene.outputs):
        where = o.body or o.joint or ""
        desc = (
            f"{o.kind}"
            + (f" of {where}" if where else "")
            + (f" at {o.xi:g}" if getattr(o, "xi", None) is not None else "")
        )
        variables.append(
            {"name": xml_attr(o.name), "vr": k, "causality": "output", "unit": None, "description": xml_attr(desc)}
        )
    records = parameter_records(scene, params)
    inputs = torque_inputs(scene)
    for k, (name, value, rec) in enumerate(zip(params, ctx["parameter_values"], records)):
        fmu_name = name
        while fmu_name in taken:  # a parameter named like an output
            fmu_name = "parameter_" + fmu_name
        taken.add(fmu_name)
        valid = rec.valid  # FMI min / max are inclusive: closed bounds only
        variables.append(
            {
                "name": xml_attr(fmu_name),
                "vr": len(outputs) + k,
                "causality": "input" if name in inputs else "parameter",
                "start": c_double(value),
                "min": c_double(valid.lower) if math.isfinite(valid.lower) and not valid.lower_open else None,
                "max": c_double(valid.upper) if math.isfinite(valid.upper) and not valid.upper_open else None,
                "unit": None,
                "description": xml_attr(
                    f"applied moment of the torque driver on {inputs[name]} (dimensionless, {valid.text()})"
                    if name in inputs
                    else f"model parameter {name} (dimensionless, {valid.text()})"
                ),
            }
        )
    phys = ctx["physical"]
    si = bool(phys["si"])
    if si:
        for v, unit in zip(variables, phys["output_units"]):
            v["unit"] = unit
        for j, (name, value, unit) in enumerate(zip(_physical_keys(scene, ctx), phys["defaults"], phys["units"])):
            fmu_name = name
            while fmu_name in taken:
                fmu_name = "parameter_" + fmu_name
            taken.add(fmu_name)
            variables.append(
                {
                    "name": xml_attr(fmu_name),
                    "vr": len(outputs) + len(params) + j,
                    "causality": "parameter",
                    "start": value,
                    "min": None,
                    "max": None,
                    "unit": unit,
                    "description": xml_attr(f"physical input {name} (SI, > 0)"),
                }
            )
        time_name = "time"
        while time_name in taken:
            time_name = "fmu_" + time_name
        variables.append(
            {
                "name": time_name,
                "vr": len(outputs) + len(params) + len(phys["defaults"]),
                "causality": "independent",
                "unit": "s",
                "description": "time t in seconds (the model's tau = omega t)",
            }
        )
    used = sorted({str(v["unit"]) for v in variables if v["unit"]})
    sim = scene.simulation
    seconds = 1.0 / scene.omega if si else 1.0
    guid = fmu_guid(ctx)
    prefix = ctx["prefix"]
    return {
        "guid": guid,
        "guid_c": c_string(guid),
        "model_name": xml_attr(scene.name),
        "description": xml_attr(
            f"symgen model of the scene {scene.name}: planar mechanism with elastic bars; "
            + ("time is t in seconds, values in SI" if si else "time is tau = omega t")
        ),
        "scene_file_xml": xml_attr(Path(str(scene.path)).name).replace("--", "- -"),
        "stop_time": c_double(sim.t_end * seconds),
        "step_size": c_double(sim.output_step * seconds),
        "units": [{"name": u, "base": UNIT_BASES[u]} for u in used],
        "tolerance": c_double(sim.tolerances("c")[0]),  # the emitted C solver's
        "variables": variables,
        "input_flags": [1 if name in inputs else 0 for name in params],
        "output_indices": list(range(1, len(outputs) + 1)),
        "sources": ctx_sources(prefix),
    }


#: FMI 2.0 BaseUnit exponents of every unit an SI FMU uses (symgen.ir.physical's unit names)
UNIT_BASES = {
    "s": {"s": 1},
    "m": {"m": 1},
    "rad": {"rad": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "m2": {"m": 2},
    "m4": {"m": 4},
    "kg/m3": {"kg": 1, "m": -3},
    "kg/m": {"kg": 1, "m": -1},
    "rad/s": {"rad": 1, "s": -1},
}


def _physical_keys(scene, ctx: dict) -> list[str]:
    """The physical inputs' scene keys, in the C's order (symgen.ir.physical)."""
    from symgen.ir.physical import physical_map

    return [k for k, _ in physical_map(scene, list(ctx["parameter_plain"])).inputs]


def fmu_files(scene, ctx: dict) -> dict:
    """{path inside the FMU: text} of everything but the binary."""
    from symgen.backends.c.render import render_files

    ctx = dict(ctx)
    ctx["fmu"] = fmu_context(scene, ctx)
    prefix = ctx["prefix"]
    sources = render_files(
        ctx,
        {
            "{p}.h": "model.h.jinja",
            "{p}.c": "model.c.jinja",
            "{p}_jac.c": "model_jac.c.jinja",
            "{p}_solver.h": "solver.h.jinja",
            "{p}_solver.c": "solver.c.jinja",
            "{p}_fmi2.c": "fmi2.c.jinja",
        },
    )
    files = {"modelDescription.xml": environment().get_template("modelDescription.xml.jinja").render(ctx=ctx)}
    for name, text in sources.items():
        files[f"sources/{name}"] = text
    for header in FMI_HEADERS:
        files[f"sources/{header}"] = (TEMPLATES / "fmi2" / header).read_text()
    files["documentation/index.html"] = _documentation(scene, ctx, prefix)
    return files


def _documentation(scene, ctx: dict, prefix: str) -> str:
    rows = "".join(f"<li>{v['name']} ({v['causality']})</li>" for v in ctx["fmu"]["variables"])
    return (
        f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{xml_attr(scene.name)}</title></head><body>'
        f"<h1>{xml_attr(scene.name)}</h1><p>Generated by symgen {ctx['version']} from "
        f"{ctx['fmu']['scene_file_xml']} (sha256 {ctx['scene_hash']}). FMI 2.0 Co-Simulation; time is "
        + ("t in seconds, values in SI (tau = omega t inside)" if ctx["physical"]["si"] else "tau = omega t")
        + f". The C sources are in <code>sources/</code>; the Radau IIA solver lands on every "
        f"communication point.</p><ul>{rows}</ul></body></html>\n"
    )


def check_fmu_path(path: Path) -> None:
    """Reject an FMU path that cannot be written (before any work)."""
    if path.suffix.lower() != ".fmu":
        raise SceneError(
            "command line", "-o", f"{str(path)!r} should end in .fmu", "give a file name like out/model.fmu"
        )
    if path.is_dir():
        raise SceneError("command line", "-o", f"{str(path)!r} is a folder", "give a file name like out/model.fmu")
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        raise BuildError(
            f"emit-fmu builds a linux64 binary; this machine is {platform.system()} "
            f"{platform.machine()} (use emit-c and build the sources there)"
        )


def write_fmu(scene, path: Path, ctx: dict, cc: str | None = None) -> Path:
    """Render, compile and zip the FMU; ``path`` appears only when complete, written atomically
    (a temporary sibling renamed onto it) with the mode of any other output (0666 & ~umask)."""
    path = Path(path)
    check_fmu_path(path)
    files = fmu_files(scene, ctx)
    prefix = ctx["prefix"]
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".fmu-", dir=path.parent) as tmpdir:
        tmp = Path(tmpdir)
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)
        src = tmp / "sources"
        binary = tmp / "binaries" / "linux64" / f"{prefix}.so"
        compile_shared(
            [src / f for f in ctx_sources(prefix)], binary, include=[src], cc=cc, extra=("-fvisibility=hidden",)
        )
        zpath = new_file(path.parent, f".{path.name}.")  # mode 0666 & ~umask, like any output
        try:
            with zipfile.ZipFile(zpath, "w", zipfile.ZIP_DEFLATED) as zf:
                for name in sorted(files):
                    zf.write(tmp / name, name)
                zf.write(binary, f"binaries/linux64/{prefix}.so")
            os.replace(zpath, path)
        except BaseException:
            zpath.unlink(missing_ok=True)
            raise
    return path


def ctx_sources(prefix: str) -> list[str]:
    """The C sources of an FMU of the model ``prefix`` (its ``sources/`` folder)."""
    from symgen.backends.c.render import library_sources

    return [*library_sources(prefix), f"{prefix}_fmi2.c"]
