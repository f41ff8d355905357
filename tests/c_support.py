"""Shared, cached pieces of the C / FMU tests: emitted sources, compiled libraries, and the
converged IDAS references the C solver is compared with (computed once per test session)."""

from __future__ import annotations

import atexit
import ctypes
import functools
import io
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = {"slider_crank": ROOT / "examples" / "slider_crank.toml", "four_bar": ROOT / "examples" / "four_bar.toml"}
# every example scene (the helpers below take any of them; EXAMPLES are the ones compared with IDAS)
ALL_EXAMPLES = {p.stem: p for p in sorted((ROOT / "examples").glob("*.toml"))}
# IDAS at tolerances tight enough to be converged to ~1e-6 of each output's peak (the scene's
# own tolerances are not: the slider-crank's axial ringing is 1e-3 off at rtol 1e-8); the
# four-bar's IDAS fails below atol 1e-12
IDAS_TOL = {"slider_crank": (1e-12, 1e-14), "four_bar": (1e-10, 1e-12)}
WORK = Path(tempfile.mkdtemp(prefix="symgen-c-tests-"))
atexit.register(shutil.rmtree, WORK, ignore_errors=True)

needs_cc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
needs_cxx = pytest.mark.skipif(shutil.which("g++") is None, reason="g++ is not installed")


@functools.cache
def mechanism(name: str):
    from symgen.api import mechanism as mech

    return mech(ALL_EXAMPLES[name])


@functools.cache
def model(name: str):
    from symgen.model.derive import derive

    return derive(mechanism(name).scene)


@functools.cache
def plan(name: str):
    """The start plan of an example (symgen.numerics.start.start_plan), the C emitter's input."""
    from symgen.numerics.start import start_plan

    return start_plan(mechanism(name))


@functools.cache
def context(name: str) -> dict:
    from symgen.backends.c import c_context

    mech = mechanism(name)
    return c_context(mech.scene, model(name), plan(name), mech.info)


def golden_c(name: str) -> Path | None:
    """``generated/<name>/c``, the checked-in output of ``symgen emit-c`` for an example, when it
    is the text this checkout emits: under the SymPy version it was written with (its printing and
    CSE decide the text), tests/test_generated.py holds it equal to a fresh emission, so the C
    tests compile it instead of deriving and lowering the same model again. None otherwise."""
    import json

    import sympy

    folder = ROOT / "generated" / name
    try:
        recorded = json.loads((folder / "model.json").read_text())["versions"]["sympy"]
    except (OSError, ValueError, KeyError):
        return None
    return folder / "c" if recorded == sympy.__version__ and (folder / "c").is_dir() else None


@functools.cache
def sources(name: str) -> Path:
    """The folder of ``symgen emit-c`` for an example (the checked-in one when it is current)."""
    from symgen.backends.c import write_tree
    from symgen.backends.c.render import render_files

    golden = golden_c(name)
    if golden is not None:
        return write_tree({p.name: p.read_text() for p in golden.iterdir()}, WORK / f"{name}_c")
    return write_tree(render_files(context(name)), WORK / f"{name}_c")


def parameter_names(name: str) -> list[str]:
    """The model parameters of an example in the emitted C's order (the model's)."""
    return list(mechanism(name).info.params)


@functools.cache
def library(name: str) -> ctypes.CDLL:
    """Model + solver as a shared library (strict flags)."""
    from symgen.backends.c.build import compile_shared

    src = sources(name)
    so = compile_shared(
        [src / f"{name}.c", src / f"{name}_jac.c", src / f"{name}_solver.c"], WORK / f"lib{name}.so", include=[src]
    )
    return ctypes.CDLL(str(so))


@functools.cache
def simulator(name: str) -> Path:
    from symgen.backends.c.build import compile_executable

    src = sources(name)
    return compile_executable(
        [src / f"{name}.c", src / f"{name}_jac.c", src / f"{name}_solver.c", src / f"{name}_sim.c"],
        WORK / f"{name}_sim",
        include=[src],
    )


def run_sim(exe: Path, *args: str) -> tuple[list[str], np.ndarray, str]:
    proc = subprocess.run([str(exe), "--stats", *args], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    header = proc.stdout.splitlines()[0].split(",")
    data = np.loadtxt(io.StringIO(proc.stdout), delimiter=",", skiprows=1, ndmin=2)
    return header, data, proc.stderr


@functools.cache
def idas_reference(name: str):
    """(tau, outputs) of the Python path (IDAS) at converged tolerances."""
    from symgen.numerics.simulate import simulate

    rtol, atol = IDAS_TOL[name]
    res = simulate(mechanism(name), rtol=rtol, atol=atol)
    return res.tau, res.outputs


def closure_columns(name: str) -> list[int]:
    return [k for k, o in enumerate(mechanism(name).scene.outputs) if o.kind == "closure_residual"]
