"""A plain (not editable) install works: the templates are package data.

The wheel is built from a copy of the sources (nothing written into the checkout), installed
without dependencies into a fresh virtual environment that sees this interpreter's packages
(sympy, casadi, ... but the venv's own symgen comes first), and the commands that render
templates run from a folder outside the repository: ``derive``, ``latex``, ``emit-c`` and
``emit-fmu``. Each must succeed and write what it says.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "slider_crank.toml"


def _run(cmd, **kw):
    proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=600, **kw)
    assert proc.returncode == 0, f"{cmd}:\n{proc.stdout}\n{proc.stderr}"
    return proc


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pkg")
    src = tmp / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    shutil.copytree(ROOT / "symgen", src / "symgen", ignore=shutil.ignore_patterns("__pycache__"))
    wheels = tmp / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", wheels, src])
    (wheel,) = wheels.glob("symgen-*.whl")
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", venv])
    bindir = venv / ("Scripts" if os.name == "nt" else "bin")
    # --ignore-installed: a symgen seen through the system site-packages (an editable install,
    # possibly of another checkout) must not make pip skip the wheel
    _run([bindir / "python", "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--ignore-installed", wheel])
    return wheel, bindir, tmp


def test_wheel_carries_the_templates(installed):
    wheel, _, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    for t in ("symgen/backends/c/templates/model.c.jinja", "symgen/backends/c/templates/sim.c.jinja",
              "symgen/backends/c/templates/fmi2/fmi2Functions.h", "symgen/backends/latex/templates/document.tex.jinja"):
        assert t in names, f"{t} missing from {wheel.name}"


def test_installed_commands_render_their_templates(installed):
    _, bindir, tmp = installed
    work = tmp / "work"
    work.mkdir()
    env = {**os.environ, "SYMGEN_CACHE_DIR": str(tmp / "cache"), "MPLBACKEND": "Agg"}
    env.pop("PYTHONPATH", None)
    where = _run([bindir / "python", "-c", "import symgen; print(symgen.__file__)"], cwd=work, env=env)
    assert Path(where.stdout.strip()).is_relative_to(tmp / "venv"), where.stdout
    symgen = bindir / "symgen"
    _run([symgen, "derive", SCENE, "-o", work / "generated"], cwd=work, env=env)
    assert (work / "generated" / "slider_crank").is_dir()
    assert any((work / "generated" / "slider_crank").rglob("*.c"))
    _run([symgen, "latex", SCENE, "-o", work / "eq.tex"], cwd=work, env=env)
    assert "\\begin{document}" in (work / "eq.tex").read_text()
    _run([symgen, "emit-c", SCENE, "-o", work / "c"], cwd=work, env=env)
    assert (work / "c" / "CMakeLists.txt").is_file() and any((work / "c").glob("*_solver.c"))
    if shutil.which("cc") or shutil.which("gcc"):
        _run([symgen, "emit-fmu", SCENE, "-o", work / "sc.fmu"], cwd=work, env=env)
        names = zipfile.ZipFile(work / "sc.fmu").namelist()
        assert "modelDescription.xml" in names and "sources/fmi2Functions.h" in names
