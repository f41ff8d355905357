"""Quasi-static transverse functions in the emitted C solver (``--solver c``, emit-c, emit-fmu;
issue 20 item 3): the C runtime's DAE has the IDAS path's partition (``Mechanism.quasi``, one
home): the quasi-static amplitudes are algebraic (no inertia rows, v_h = a_h = 0, q_h in the slot
of a_h), solved from their rows after the full model's start (docs/quasi-static-modes.md).

Scenes: the turning cantilever of tests/test_quasi_static_modes.py (dimensionless, a quasi-static
start, 4 transverse functions, the highest 2 quasi-static: the closed form of a uniformly loaded
cantilever is the oracle, its own tolerance argued there), and examples/slider_crank.toml with 3
transverse functions on the rod, the highest quasi-static (an unstressed start: the start's joint
forces are the model's own where a function is quasi-static, ``free_inertia_parameters``).

Oracles: the closed form; IDAS on the same partition (another integrator of the same DAE, at the
same tolerances: both within their own integration error of each other); the step counts of the
same C solver with every function dynamic.
"""

from __future__ import annotations

import dataclasses
import shutil
import warnings

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.ir.plan import StartPlan
from symgen.numerics import csolver
from symgen.numerics.csolver import simulate_c
from symgen.numerics.simulate import simulate
from symgen.numerics.start import start_plan
from test_quasi_static_modes import _arm

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")

SLIDER = "examples/slider_crank.toml"
#: the rod with 3 transverse functions, the highest quasi-static, over one crank turn
SLIDER_QS = ["bodies.rod.transverse_modes=3", "bodies.rod.quasi_static_transverse=1", "simulation.cycles=1"]


@pytest.fixture(autouse=True)
def _own_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "c-quasi-cache"))


def _mech(path, overrides=()):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the bases' warnings: not what is tested here
        return mechanism(path, list(overrides))


def _peak_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_c_and_idas_agree_on_stated_quasi_static_functions_and_the_closed_form(tmp_path):
    """The turning cantilever, its highest 2 of 4 transverse functions quasi-static, from its
    quasi-static start: the C run's tip deflection is the closed form's (the bound of
    tests/test_quasi_static_modes.py) and IDAS's; the quasi-static amplitudes follow the load
    with zero rates in both, the same values at the start. (Steps: with the start's deformation
    solved at zero rates, the C solver took 35485 steps with every function dynamic and 11575
    with 2 quasi-static at lambda = 1e4, 1366 and 1166 at 1e6: the dynamic run rang axially from
    the start. With the consistent start, the deformation solved again with its rates held
    (tests/test_qs_start_consistent.py), 2677 and 3519 at 1e4, 2789 and 3515 at 1e6: the
    quasi-static functions no longer save steps on this arm; not a claim of this test.)"""
    mu, g, lam = 1e4, 10.0, 1e4
    kw = dict(lam=lam, mu=mu, g=g, nt=4, t_end=1.6, rtol=1e-7)
    mech = _mech(_arm(tmp_path, qs=2, **kw))
    assert [mech.coords[i].name for i in mech.quasi] == ["g_arm_3", "g_arm_4"]
    plan = start_plan(mech)
    assert plan.quasi == mech.quasi and not set(plan.quasi) & set(plan.independent)
    c, idas = simulate_c(mech), simulate(mech)
    assert c.complete and idas.complete
    exact = -g * np.cos(c.column("angle")) / (8 * mu)
    assert _peak_error(c.column("tip"), exact) < 1.5e-4 + 2.0 / lam
    # the same DAE by two integrators: measured 1.5e-7 of peak at rtol 1e-8, 3.2 tau
    assert _peak_error(c.column("tip"), idas.column("tip")) < 1e-5
    h = list(mech.quasi)
    assert np.all(c.v[:, h] == 0.0) and np.all(idas.v[:, h] == 0.0)
    assert np.abs(c.q[:, h]).max() > 0.0
    scale = np.abs(idas.q[:, h]).max()
    assert np.abs(c.q[0, h] - idas.q[0, h]).max() < 1e-8 * scale  # the quasi start: one Newton, two codes
    assert np.abs(c.q[:, h] - idas.q[:, h]).max() < 1e-5 * scale
    dynamic = simulate_c(_mech(_arm(tmp_path, qs=0, **kw)))
    assert _peak_error(dynamic.column("tip"), exact) < 1.5e-4 + 2.0 / lam


def test_unstressed_start_keeps_the_models_own_joint_forces_as_idas_does():
    """examples/slider_crank.toml, the rod's highest of 3 transverse functions quasi-static, from
    the unstressed start: no continuum start (a quasi-static function makes the bar rigid in
    that direction at the start: ``free_inertia_parameters``), in the plan and in the C run;
    the first row (torque included) is IDAS's, and the whole run within the accuracy the scene's
    tolerances buy (as tests/test_c_parity.py: against IDAS at 1000 times tighter tolerances,
    the C solver's error at most twice IDAS's own or below 1e-5 of the peak; the undamped axial
    ringing of this model is the largest part of both)."""
    mech = _mech(SLIDER, SLIDER_QS)
    assert [mech.coords[i].name for i in mech.quasi] == ["g_rod_3"]
    plan = start_plan(mech)
    assert plan.free_inertia == plan.start_forces == ()
    sim = mech.scene.simulation
    c, idas = simulate_c(mech), simulate(mech)
    oracle = simulate(mech, rtol=sim.rtol * 1e-3, atol=sim.atol * 1e-3)
    assert c.complete and idas.complete and c.start_forces == idas.start_forces == ()
    peak = np.abs(oracle.outputs).max(axis=0)
    k = c.output_names.index("torque")
    assert abs(c.outputs[0, k] - idas.outputs[0, k]) < 1e-9 * peak[k]
    for name in ("eta_mid", "eps_ax", "torque"):
        j = c.output_names.index(name)
        e_c = np.abs(c.outputs[:, j] - oracle.outputs[:, j]).max() / peak[j]
        e_idas = np.abs(idas.outputs[:, j] - oracle.outputs[:, j]).max() / peak[j]
        assert e_c <= max(2 * e_idas, 1e-5), (name, e_c, e_idas)
    assert np.all(c.v[:, list(mech.quasi)] == 0.0)


def test_the_library_and_the_plan_are_keyed_by_the_quasi_static_functions():
    """The emitted library's key holds the partition with its quasi-static amplitudes (a scene
    that differs only in them is another library), and a start plan's quasi set round-trips
    through JSON and must split the coordinates with the independent and dependent ones."""
    qs, dyn = _mech(SLIDER, SLIDER_QS), _mech(SLIDER, SLIDER_QS[:1] + SLIDER_QS[2:])
    p_qs, p_dyn = start_plan(qs), start_plan(dyn)
    assert p_dyn.quasi == () and p_qs.quasi == qs.quasi
    assert set(p_qs.independent) | set(p_qs.quasi) == set(p_dyn.independent)
    assert csolver.emitted_key(qs, p_qs) != csolver.emitted_key(dyn, p_dyn)
    assert csolver._plan_question(qs) != csolver._plan_question(dyn)
    assert StartPlan.from_json(p_qs.to_json()) == p_qs
    data = p_qs.to_json()
    with pytest.raises(ValueError, match="quasi"):
        StartPlan.from_json({k: v for k, v in data.items() if k != "quasi"})
    with pytest.raises(ValueError, match="does not split"):  # a quasi-static amplitude also independent
        dataclasses.replace(p_qs, independent=p_qs.independent + p_qs.quasi)
    with pytest.raises(ValueError, match="does not split"):  # ... or left out
        dataclasses.replace(p_qs, quasi=())


def test_the_fmu_runs_the_quasi_static_functions(tmp_path):
    """The FMU shares the runtime: its run of the slider-crank with a quasi-static function is
    the C solver's (FMPy's master, the output grid of the scene; both Radau IIA with the same
    tolerances, but the FMU lands on each communication point: within the integration error)."""
    fmpy = pytest.importorskip("fmpy", reason="fmpy is not installed")
    from symgen.backends.c import c_context
    from symgen.backends.fmu import write_fmu
    from symgen.model.derive import derive

    mech = _mech(SLIDER, SLIDER_QS)
    path = tmp_path / "slider_qs.fmu"
    write_fmu(mech.scene, path, c_context(mech.scene, derive(mech.scene), start_plan(mech), mech.info))
    step = mech.scene.simulation.output_step
    stop = 40 * step
    res = fmpy.simulate_fmu(str(path), stop_time=stop, output_interval=step)
    c = simulate_c(mech, t_end=stop)
    n = min(len(res), len(c.tau))
    assert n > 30
    for name in ("eta_mid", "torque"):
        j = c.output_names.index(name)
        assert np.abs(res[name][:n] - c.outputs[:n, j]).max() < 1e-4 * np.abs(c.outputs[:n, j]).max(), name


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("g++") is None, reason="gcc and g++ are needed")
def test_emit_c_compiles_strict_and_runs_the_quasi_static_functions(tmp_path):
    """``symgen emit-c`` of the slider-crank with a quasi-static function: the emitted model,
    solver and driver compile as strict C99 and as C++, and the driver's rows are the in-process
    C solver's (the same library code, the same tolerances: to round-off of the outputs)."""
    import subprocess

    from c_support import run_sim
    from symgen.api import write_c

    mech = _mech(SLIDER, SLIDER_QS)
    scene = mech.scene
    out = write_c(scene, tmp_path / "c")
    n = scene.name
    files = [str(out / f) for f in (f"{n}.c", f"{n}_jac.c", f"{n}_solver.c", f"{n}_sim.c")]
    for cmd in (["gcc", "-std=c99"], ["g++", "-x", "c++"]):
        flags = ["-Wall", "-Wextra", "-pedantic", "-Werror", "-O1", f"-I{out}"]
        proc = subprocess.run(
            [*cmd, *flags, *files, "-o", str(tmp_path / "sim"), "-lm"], capture_output=True, text=True
        )
        assert proc.returncode == 0, proc.stderr
    header, data, _ = run_sim(tmp_path / "sim")
    c = simulate_c(mech)
    assert data.shape == (len(c.tau), 1 + c.outputs.shape[1])
    for name in ("eta_mid", "eps_ax", "torque"):
        j = c.output_names.index(name)
        col = data[:, header.index(name)]
        assert np.abs(col - c.outputs[:, j]).max() < 1e-6 * np.abs(c.outputs[:, j]).max(), name
