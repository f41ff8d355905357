"""A plain (not editable) install works: the templates (the top-level templates/ folder) and the
C runtime are package data.

The wheel is built from a copy of the sources (nothing written into the checkout), installed
without dependencies into a fresh virtual environment (without system site-packages: this
interpreter may itself be a virtual environment without them) that sees this interpreter's
site-packages through a .pth file (sympy, casadi, ... but the venv's own symgen comes first),
and the commands that render templates run from a folder outside the repository: ``derive``,
``latex``, ``emit-c`` and ``emit-fmu``. Each must succeed and write what it says.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
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
    for name in ("symgen", "templates"):
        shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
    wheels = tmp / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", wheels, src])
    (wheel,) = wheels.glob("symgen-*.whl")
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", venv])
    bindir = venv / ("Scripts" if os.name == "nt" else "bin")
    # this interpreter's site-packages, after the venv's own (a .pth line only adds its folder to
    # sys.path: the .pth files in it, e.g. an editable symgen's finder, are not run)
    inner = _run([bindir / "python", "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
    outer = [
        p
        for p in dict.fromkeys(
            [
                *site.getsitepackages(),
                site.getusersitepackages(),
                sysconfig.get_paths()["purelib"],
                sysconfig.get_paths()["platlib"],
            ]
        )
        if Path(p).is_dir()
    ]
    (Path(inner) / "outer_site_packages.pth").write_text("".join(f"{p}\n" for p in outer))
    # --ignore-installed: a symgen seen through the system site-packages (an editable install,
    # possibly of another checkout) must not make pip skip the wheel
    _run([bindir / "python", "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--ignore-installed", wheel])
    return wheel, bindir, tmp


def test_wheel_carries_the_templates(installed):
    wheel, _, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    for folder, prefix in (
        (ROOT / "templates", "symgen/templates"),
        (ROOT / "symgen" / "backends" / "c" / "runtime", "symgen/backends/c/runtime"),
    ):
        files = [p for p in folder.rglob("*") if p.is_file() and "__pycache__" not in p.parts]
        assert files
        for path in files:
            t = f"{prefix}/{path.relative_to(folder).as_posix()}"
            assert t in names, f"{t} missing from {wheel.name}"
    # every package of the checkout (pyproject.toml lists them)
    for init in (ROOT / "symgen").rglob("__init__.py"):
        t = init.relative_to(ROOT).as_posix()
        assert t in names, f"{t} missing from {wheel.name}: add its package to pyproject.toml"


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
