"""A run on a cached model imports neither SymPy nor jinja2 nor matplotlib (issue 20, item 1).

Each case runs twice in fresh interpreters: the first fills the model cache (it may derive, and
so import SymPy), the second runs again from the cache and reports ``sys.modules`` after each
command. Covered: ``symgen simulate`` and ``symgen check`` on every example, the Python API's
``simulate_scene`` (with and without files), and scenes with user expressions (a driver ``law``,
load and torque expressions), whose checks are answered from the signed cache on the second run
(``symgen.scene.verdicts``). A plot is the one thing that may import matplotlib.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.oracles import write_scene

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted(str(p) for p in (ROOT / "examples").glob("*.toml"))
#: tqdm too: a bar that is not shown (stderr not a terminal) does not import it (symgen.progress)
HEAVY = ("sympy", "jinja2", "matplotlib", "tqdm")


def short(scene: str) -> str:
    """The override that shortens a run of ``scene`` (a value, not the structure: the same
    cached model)."""
    with open(scene, "rb") as fh:
        given = tomllib.load(fh)["simulation"]
    return "simulation.cycles=0.05" if "cycles" in given else "simulation.t_end=0.3"


LAW_SCENE = """
[scene]
name = "driven_flexible_bar"
[[bodies]]
name = "bar"
length = 1.0
frame = "cantilever"
axial_modes = 1
transverse_modes = 2
lambda = 1000.0
mu = 50.0
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "angle"
body = "bar"
initial = 0.1
law = "0.3*sin(2*tau) + 0.1*tau^2"
[[loads]]
body = "bar"
kind = "distributed"
transverse = "0.05*sin(3*tau)*exp(-tau/4)"
[[loads]]
body = "bar"
kind = "point"
at = 1.0
axial = "0.01*cos(tau)"
[effects]
gravity = [0.0, -2.0]
[outputs]
theta = { kind = "angle", body = "bar" }
tip = { kind = "deflection", body = "bar", at = 1.0 }
torque = { kind = "driver_torque" }
[simulation]
t_end = 1.0
output_step = 0.05
"""

TORQUE_SCENE = """
[scene]
name = "torqued_bar"
[[bodies]]
name = "bar"
length = 1.0
frame = "cantilever"
axial_modes = 0
transverse_modes = 1
mu = 50.0
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "torque"
body = "bar"
value = "0.5*Heaviside(tau - 0.2) + 0.1*sqrt(1 + tau)"
[outputs]
theta = { kind = "angle", body = "bar" }
tip = { kind = "deflection", body = "bar", at = 1.0 }
[simulation]
t_end = 1.0
output_step = 0.05
"""

SI_SCENE = """
[scene]
name = "si_arm"
units = "SI"
omega = 20.0
[[bodies]]
name = "arm"
length = 0.5
E = 70e9
area = 1e-4
inertia = 1e-9
density = 2700.0
frame = "cantilever"
axial_modes = 0
transverse_modes = 2
[[bodies]]
name = "link"
length = 0.4
E = 70e9
area = 1e-4
inertia = 1e-9
density = 2700.0
frame = "cantilever"
axial_modes = 0
transverse_modes = 1
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "P"
kind = "pin"
bodies = ["link", "ground"]
at = [0.0, [0.6, 0.0]]
[[drivers]]
kind = "angle"
body = "arm"
law = "0.4*sin(10*t)"
[[drivers]]
kind = "torque"
body = "link"
value = "0.2*tanh(t/0.05)"
[[loads]]
body = "arm"
kind = "point"
at = 1.0
transverse = "1.5*sin(30*t)"
[outputs]
theta = { kind = "angle", body = "arm" }
tip = { kind = "deflection", body = "arm", at = 1.0 }
[simulation]
duration = 0.05
output_interval = 0.005
"""

# Runs each step (a list: "cli", argv... | "api", scene, override, out or None) and prints, per step, the
# heavy modules loaded so far and, for the first import of each, the symgen frames that made it.
DRIVER = r"""
import json, sys, traceback
HEAVY = {heavy!r}
# what the interpreter's start already loaded (a site .pth file may import importlib.resources or
# zipfile before any symgen code runs) is not symgen's import
BEFORE = {{m for m in HEAVY if m in sys.modules}}
first = {{}}

class Watch:
    def find_spec(self, name, path, target=None):
        top = name.split(".")[0]
        if top in HEAVY and top not in first:
            first[top] = [f"{{f.filename.rsplit('/symgen/', 1)[-1]}}:{{f.lineno}}"
                          for f in traceback.extract_stack() if "/symgen/" in f.filename]
        return None

sys.meta_path.insert(0, Watch())
from symgen.cli import main
from symgen.api import simulate_scene
report = []
for step in json.loads(sys.argv[1]):
    if step[0] == "cli":
        try:
            main(step[1:])
        except SystemExit as exc:
            assert not exc.code, (step, exc.code)
    else:  # ["api", scene, override, out or None(, solver, estimate)]
        simulate_scene(step[1], [step[2]], out=step[3], **dict(zip(("solver", "estimate"), step[4:])))
    import symgen.classcode
    report.append({{"step": step, "heavy": sorted(m for m in HEAVY if m in sys.modules and m not in BEFORE), "via": dict(first),
                   "compiled": symgen.classcode.stats()["compiled"]}})
print("REPORT " + json.dumps(report))
"""


def _run(steps: list[list], cwd: Path, heavy: tuple[str, ...] = HEAVY) -> list[dict]:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    code = DRIVER.format(heavy=heavy)
    proc = subprocess.run(
        [sys.executable, "-c", code, json.dumps(steps)], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("REPORT "))
    return list(json.loads(line[len("REPORT ") :]))


def _lean(steps: list[list], cwd: Path, heavy: tuple[str, ...] = HEAVY) -> None:
    _run(steps, cwd, heavy)  # fills the cache (derives what it does not hold)
    for entry in _run(steps, cwd, heavy):
        assert entry["heavy"] == [], f"{entry['step']} imported {entry['heavy']} via {entry['via']}"
        # symgen's dataclasses' methods recalled compiled, none compiled again (symgen.classcode)
        assert entry["compiled"] == 0, entry


@pytest.mark.parametrize("scene", EXAMPLES, ids=lambda p: Path(p).stem)
def test_cached_example_runs_import_no_sympy(scene, tmp_path):
    over = short(scene)
    _lean(
        [
            ["cli", "check", scene],
            ["cli", "simulate", scene, "--set", over, "-o", str(tmp_path / "cli.csv")],
            ["api", scene, over, str(tmp_path / "api.csv")],
            ["api", scene, over, None],
        ],
        tmp_path,
    )


@pytest.mark.parametrize(
    "text", [LAW_SCENE, TORQUE_SCENE, SI_SCENE], ids=["law-and-loads", "torque", "si-expressions-two-drivers"]
)
def test_cached_runs_with_user_expressions_import_no_sympy(text, tmp_path):
    scene = str(write_scene(tmp_path / "expr.toml", text))
    _lean(
        [
            ["cli", "check", scene],
            ["cli", "simulate", scene, "-o", str(tmp_path / "cli.csv")],
            ["api", scene, "simulation.rtol=1e-7", str(tmp_path / "api.csv")],
        ],
        tmp_path,
    )


def test_a_cached_c_solver_run_is_lean(tmp_path):
    """``simulate --solver c`` from the cache (its model, its start plan and its C solver) imports
    none of them, nor CasADi (the library holds the model, the start and the outputs): the whole
    process Exudyn is measured against (benchmarks/bench_exudyn.py)."""
    scene = str(ROOT / "examples" / "slider_crank.toml")
    out = str(tmp_path / "c.csv")
    _lean(
        [
            ["cli", "simulate", scene, "--set", short(scene), "--solver", "c", "--estimate", "off", "-o", out],
            ["api", scene, short(scene), str(tmp_path / "api.csv"), "c", "off"],
            ["api", scene, short(scene), None, "c"],
        ],
        tmp_path,
        (*HEAVY, "casadi"),
    )


def test_a_cached_c_run_without_estimate_imports_no_numpy(tmp_path):
    """``simulate --solver c --estimate off`` from the cache (with the states too) imports no
    numpy: the scene with its remembered bases, the parameters as floats, the library's rows in a
    ctypes buffer, the CSV and the sidecar written from them (``symgen.lazy``,
    ``SimResult.of_rows``; the arrays made on first read: tests/test_run_rows.py), the sidecar's
    range record from the maxima the C library kept during the run (``SimResult.range_maxima``,
    ``checks.range_record``), and starts no process (the compiler's ``--version`` remembered: no
    subprocess); the library's key digests the C templates and runtime from the package's folder,
    without importlib.resources (``templates.package_files``), and symgen's dataclasses'
    methods are recalled compiled (``symgen.classcode``; every ``_lean`` case checks that). The error estimate (its reruns, CasADi) and the Python API (its bases chosen
    again) do import numpy."""
    scene = str(ROOT / "examples" / "slider_crank.toml")
    over = short(scene)
    c_off = ["--solver", "c", "--estimate", "off"]
    heavy = (
        *HEAVY,
        "casadi",
        "numpy",
        "subprocess",  # no process started (the compiler's version remembered)
        "importlib.resources",  # the templates' digest reads the package's folder (on disk)
        "zipfile",
        "shlex",  # the default compiler flags split without it (compiled._split)
        "secrets",  # only a first use makes a cache key
    )
    _lean(
        [
            ["cli", "simulate", scene, "--set", over, *c_off, "-o", str(tmp_path / "c.csv")],
            ["cli", "simulate", scene, "--set", over, *c_off, "--states", "-o", str(tmp_path / "s.csv")],
        ],
        tmp_path,
        heavy,
    )


def test_a_cached_c_run_gives_the_first_runs_results(tmp_path, monkeypatch):
    """The cached ``--solver c`` run (its start plan recalled, its model's Functions never read)
    writes the same CSV as the first run (which planned the start through CasADi), and an IDAS
    run of the same cache still reads the Functions; the watch sees casadi there. A cache of its
    own: the first run plans."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    scene = str(ROOT / "examples" / "slider_crank.toml")
    c1, c2, idas = (str(tmp_path / f"{k}.csv") for k in ("c1", "c2", "idas"))
    run = ["cli", "simulate", scene, "--set", short(scene), "--solver", "c", "--estimate", "off", "-o"]
    heavy = (*HEAVY, "casadi")
    (first,) = _run([[*run, c1]], tmp_path, heavy)
    assert "casadi" in first["heavy"]  # planned the start: CasADi's Functions
    (again,) = _run([[*run, c2]], tmp_path, heavy)
    assert again["heavy"] == []
    assert Path(c1).read_text() == Path(c2).read_text()
    (other,) = _run(
        [["cli", "simulate", scene, "--set", short(scene), "--estimate", "off", "-o", idas]], tmp_path, heavy
    )
    assert "casadi" in other["heavy"]


BLAS_CHECK = r"""
import json, os, sys
import symgen.cli
before = "numpy" in sys.modules  # the command sets its BLAS threads before numpy's first import
symgen.cli.main(["schema"])
import numpy
print("BLAS " + json.dumps({"numpy_before_main": before, "threads": os.environ.get("OPENBLAS_NUM_THREADS")}))
"""


@pytest.mark.parametrize("given", [None, "2"])
def test_a_command_runs_numpy_with_one_blas_thread_unless_told(given, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    proc = subprocess.run(
        [sys.executable, "-c", BLAS_CHECK], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("BLAS "))
    report = json.loads(line[len("BLAS ") :])
    assert report == {"numpy_before_main": False, "threads": given or "1"}


def test_the_watch_sees_a_heavy_import(tmp_path):
    """The check can fail: a run that plots imports matplotlib, and the report names it."""
    scene = EXAMPLES[0]
    plot = ["--plot", str(tmp_path / "a.png")]
    steps = [["cli", "simulate", scene, "--set", short(scene), "-o", str(tmp_path / "a.csv"), *plot]]
    _run(steps, tmp_path)
    (entry,) = _run(steps, tmp_path)
    assert "matplotlib" in entry["heavy"] and entry["via"]["matplotlib"]


# ----------------------------------------------------------------------------- remembered verdicts
def test_a_verdict_is_recalled_only_as_written_for_its_own_question(tmp_path, monkeypatch, capsys):
    from symgen import cache

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    q1 = {"check": "finite", "text": "sin(tau)", "t_end": 2.0, "symgen": "x"}
    q2 = dict(q1, t_end=3.0)
    assert cache.recall(q1) == (False, None)
    cache.remember(q1, None)
    assert cache.recall(q1) == (True, None) and cache.recall(q2) == (False, None)
    (f1,) = cache.checks_dir().iterdir()
    # moved to the name of another question: it verifies, but holds another question
    cache.remember(q2, None)
    f2 = next(f for f in cache.checks_dir().iterdir() if f != f1)
    f2.write_bytes(f1.read_bytes())
    capsys.readouterr()
    assert cache.recall(q2) == (False, None)
    assert "holds the verdict of another question" in capsys.readouterr().err
    # changed bytes: the keyed hash does not match
    data = bytearray(f1.read_bytes())
    data[-3] ^= 0x01
    f1.write_bytes(bytes(data))
    assert cache.recall(q1) == (False, None)
    assert "does not match the keyed hash" in capsys.readouterr().err
    assert "checks" in cache.info()
    cache.clear()
    assert not cache.checks_dir().exists()


def test_only_a_passed_check_is_remembered(tmp_path, monkeypatch):
    from symgen import cache
    from symgen.scene import verdicts

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    assert verdicts.expression_error("sin(tau") is not None
    assert verdicts.expression_not_finite("1/(tau - 0.5)", 1.0) == pytest.approx(0.5)
    assert not cache.checks_dir().exists() or not list(cache.checks_dir().iterdir())
    assert verdicts.expression_error("sin(tau)") is None
    assert verdicts.expression_not_finite("1/(tau - 0.5)", 0.4) is None
    assert len(list(cache.checks_dir().iterdir())) == 2
