"""The emitted C's --set by physical parameters (E, area, inertia, density, mass per length,
lengths, omega) of an SI scene, through the Python loader's own formulas (symgen.ir.physical).

Oracles: the loader itself, on the scene with the same override (every parameter, for a change
of each physical input in turn); the C built from the overridden scene (the same model
parameters, so the same run); and the Python (IDAS) run with the same override."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from symgen.ir.parameters import parameter_records
from symgen.ir.physical import physical_map
from symgen.scene import load_scene
from tests.c_support import ROOT, needs_cc, run_sim
from tests.oracles import write_scene

SI_EXAMPLES = [ROOT / "examples" / f"{n}.toml" for n in ("four_bar", "motor_arm", "six_bar")] + [
    ROOT / "tests" / "scene" / "data" / "si_slider_crank.toml"
]


@pytest.mark.parametrize("path", SI_EXAMPLES, ids=lambda p: p.stem)
def test_the_map_is_the_loader_for_a_change_of_each_input(path):
    """For each offered input, scaled by 1.3 (the loader reads the changed file): every model
    parameter the map computes equals the loader's, and every other keeps its value."""
    scene = load_scene(path)
    pm = physical_map(scene)
    assert pm.inputs and pm.expressions
    base = {r.name: r.value for r in parameter_records(scene)}
    for key, value in pm.inputs:
        changed = load_scene(path, [f"{key}={value * 1.3!r}"])
        loader = {r.name: r.value for r in parameter_records(changed)}
        assert set(loader) == set(base)
        moved = 0
        for name, ref in loader.items():
            if name in pm.expressions:
                got = pm.value(name, {key: value * 1.3})
                assert got == pytest.approx(ref, rel=1e-14, abs=1e-300), (key, name)
                moved += got != pytest.approx(base[name], rel=1e-12)
            else:
                assert ref == base[name], (key, name)  # not computed from the inputs: unchanged
        assert moved >= 1, key  # each input sets at least one parameter


def test_dimensionless_scene_has_no_physical_inputs():
    scene = load_scene(ROOT / "examples" / "slider_crank.toml")
    assert scene.si_inputs == () and physical_map(scene).inputs == ()


def test_inputs_of_an_si_expression_are_not_offered(tmp_path):
    text = (
        (ROOT / "examples" / "motor_arm.toml")
        .read_text()
        .replace("value = 4.0                     # N m at the arm's shaft", 'value = "4.0*tanh(t/0.05)"')
    )
    scene = load_scene(write_scene(tmp_path / "m.toml", text))
    pm = physical_map(scene)
    # the torque's conversion used omega, l0 (reference_length) and m_ref (the arm's density x area)
    assert set(pm.frozen) == {"scene.omega", "scene.reference_length", "bodies.arm.density", "bodies.arm.area"}
    assert {k for k, _ in pm.inputs} == {
        "bodies.arm.length",
        "bodies.arm.E",
        "bodies.arm.inertia",
        "bodies.link.length",
        "bodies.link.mass_per_length",
    }
    # lambda of the arm still follows E, with the frozen omega as a constant
    assert pm.value("lambda_arm", {"bodies.arm.E": 1e11}) == pytest.approx(
        load_scene(write_scene(tmp_path / "m.toml", text), ["bodies.arm.E=1e11"]).bodies[0].lam, rel=1e-14
    )


# ------------------------------------------------------------------ the emitted C
ARM = """
[scene]
name = "si_arm"
units = "SI"
omega = 20.0
[[bodies]]
name = "arm"
length = 0.5
E = 70e9
inertia = 2e-10
area = 1e-4
density = 2700.0
frame = "cantilever"
axial_modes = 0
transverse_modes = 2
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "torque"
body = "arm"
value = 0.3
initial = 0.0
[effects]
gravity = [0.0, -9.81]
[outputs]
tip = { kind = "deflection", body = "arm", at = 1.0 }
theta = { kind = "angle", body = "arm" }
[simulation]
duration = 0.3
output_interval = 0.005
rtol = 1e-10
atol = 1e-12
"""


def _simulator(scene_path, out, overrides=()):
    from symgen.api import write_c
    from symgen.backends.c.build import compile_executable

    src = write_c(scene_path, out, list(overrides))
    return compile_executable(
        [src / "si_arm.c", src / "si_arm_jac.c", src / "si_arm_solver.c", src / "si_arm_sim.c"],
        out / "si_arm_sim",
        include=[src],
    )


def _physical_parameters(tmp_path, sets) -> tuple[np.ndarray, np.ndarray]:
    """(p of the base scene's C from the physical inputs of ``sets`` by ``si_arm_physical_set``,
    p emitted for the scene with ``sets`` applied): the model C of both as shared libraries."""
    import ctypes

    from symgen.backends.c.build import compile_shared

    base = ctypes.CDLL(
        str(compile_shared([tmp_path / "c" / "si_arm.c"], tmp_path / "base.so", include=[tmp_path / "c"]))
    )
    over = ctypes.CDLL(
        str(compile_shared([tmp_path / "c2" / "si_arm.c"], tmp_path / "over.so", include=[tmp_path / "c2"]))
    )
    import re

    header = (tmp_path / "c" / "si_arm.h").read_text()
    n_p, n_x = (int(re.search(rf"#define si_arm_{m} (\d+)", header).group(1)) for m in ("N_P", "N_PHYSICAL"))
    x = (ctypes.c_double * n_x)()
    changed = (ctypes.c_int * n_x)()
    direct = (ctypes.c_int * max(n_p, 1))()
    p = (ctypes.c_double * n_p)()
    defaults = (ctypes.c_double * n_p).in_dll(base, "si_arm_parameter_defaults")
    x_defaults = (ctypes.c_double * n_x).in_dll(base, "si_arm_physical_defaults")
    index = base.si_arm_physical_index
    index.argtypes = [ctypes.c_char_p]
    for k in range(n_x):
        x[k] = x_defaults[k]
    for item in sets:
        key, value = item.split("=")
        j = index(key.encode())
        assert j >= 0, key
        x[j], changed[j] = float(value), 1
    for k in range(n_p):
        p[k] = defaults[k]
    message = ctypes.create_string_buffer(400)
    base.si_arm_physical_set.argtypes = [ctypes.c_void_p] * 5 + [ctypes.c_size_t]
    assert base.si_arm_physical_set(x, changed, direct, p, message, 400) == 0, message.value
    emitted = (ctypes.c_double * n_p).in_dll(over, "si_arm_parameter_defaults")
    return np.array(p[:]), np.array(emitted[:])


@needs_cc
def test_c_set_by_physical_parameters_matches_python(tmp_path):
    from symgen.api import mechanism
    from symgen.numerics.simulate import simulate

    path = write_scene(tmp_path / "si_arm.toml", ARM)
    exe = _simulator(path, tmp_path / "c")
    sets = ["bodies.arm.E=3.5e10", "bodies.arm.density=7800.0", "scene.omega=25.0"]
    grid = ["--t-end", "6", "--step", "0.1"]  # the C runs in tau (its defaults: the scene's)
    args = [a for s in sets for a in ("--set", s)]
    header, got, _ = run_sim(exe, *args, *grid)
    # the C emitted from the overridden scene: the same parameters, the same run
    exe2 = _simulator(path, tmp_path / "c2", sets)
    header2, ref_c, _ = run_sim(exe2, *grid)
    assert header == header2 == ["tau", "tip", "theta"]
    # the parameters: the C's formulas of the physical inputs give the overridden scene's own
    # parameters (printed by the Python loader) to round-off
    p_set, p_emitted = _physical_parameters(tmp_path, sets)
    np.testing.assert_allclose(p_set, p_emitted, rtol=4e-16, atol=0)
    # the runs: parameters equal to round-off, not to the bit, may part the step sequences of
    # the dense-output solver (its steps are its error control's, not reset at each output:
    # 5966 and 5967 accepted steps here), so the rows agree to the integration's accuracy
    # (rtol 1e-10 asked, 0.1 rtol^(2/3) = 2e-8 on the error estimate): measured 2e-9
    np.testing.assert_allclose(got, ref_c, rtol=2e-8, atol=1e-11)
    # the Python run with the same overrides (IDAS; the tolerances apart)
    res = simulate(mechanism(path, sets), t_end=6.0, output_step=0.1)
    np.testing.assert_allclose(got[:, 0], res.tau, atol=1e-12)
    for k, name in enumerate(("tip", "theta"), start=1):
        scale = np.abs(res.column(name)).max()
        assert scale > 0
        assert np.abs(got[:, k] - res.column(name)).max() < 1e-6 * scale, name
    # and the change is real: the default run differs
    _, default, _ = run_sim(exe, *grid)
    assert np.abs(default[:, 1] - got[:, 1]).max() > 1e-3 * np.abs(default[:, 1]).max()


@needs_cc
def test_c_set_physical_refusals(tmp_path):
    path = write_scene(tmp_path / "si_arm.toml", ARM)
    exe = _simulator(path, tmp_path / "c")
    for args, fragment in (
        (["--set", "bodies.arm.E=-1"], "the physical input bodies.arm.E must be > 0"),
        (["--set", "bodies.arm.E=1e11", "--set", "mu_arm=2"], "also set it: give one or the other"),
        (["--set", "bodies.arm.Young=1"], "the physical inputs (SI): scene.omega, bodies.arm.length, bodies.arm.E"),
    ):
        proc = subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2 and proc.stdout == "", args
        assert fragment in proc.stderr, proc.stderr


# ------------------------------------------------------------------ the FMU in seconds and SI
@needs_cc
def test_si_fmu_runs_in_seconds_with_units_and_physical_parameters(tmp_path):
    """The FMU of an SI scene: its time in s, its outputs in SI with their units, its physical
    inputs as SI parameters; its run matches the Python run converted to SI (symgen simulate's
    units), also with a physical parameter changed (the Python run with the same override)."""
    import xml.etree.ElementTree as ET
    import zipfile

    fmpy = pytest.importorskip("fmpy")
    from fmpy.validation import validate_fmu

    from symgen.api import mechanism, write_fmu
    from symgen.numerics.simulate import simulate
    from symgen.numerics.units import result_units

    path = write_scene(tmp_path / "si_arm.toml", ARM)
    fmu = tmp_path / "si_arm.fmu"
    write_fmu(path, fmu)
    assert validate_fmu(str(fmu)) == []
    with zipfile.ZipFile(fmu) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    real = {v.get("name"): (v.get("causality"), v.find("Real").get("unit")) for v in root.iter("ScalarVariable")}
    assert real["tip"] == ("output", "m") and real["theta"] == ("output", "rad")
    assert real["bodies.arm.E"] == ("parameter", "Pa") and real["scene.omega"] == ("parameter", "rad/s")
    assert real["bodies.arm.inertia"] == ("parameter", "m4") and real["bodies.arm.density"] == ("parameter", "kg/m3")
    assert real["time"] == ("independent", "s") and real["mu_arm"] == ("parameter", None)
    units = {u.get("name") for u in root.iter("Unit")}
    assert {"s", "m", "rad", "Pa", "rad/s", "m4", "kg/m3"} <= units
    exp = root.find("DefaultExperiment")
    assert float(exp.get("stopTime")) == pytest.approx(6.0 / 20.0) and float(exp.get("stepSize")) == pytest.approx(
        0.1 / 20.0
    )

    for sets in ([], ["bodies.arm.E=3.5e10", "scene.omega=25.0"]):
        start = {k: float(v) for k, v in (s.split("=") for s in sets)}
        res = fmpy.simulate_fmu(str(fmu), start_values=start, output_interval=0.01)
        mech = mechanism(path, [*sets, "simulation.output_interval=0.01"])
        py = simulate(mech)
        t, values = result_units(mech.scene, "SI").convert(py.tau, py.outputs)
        np.testing.assert_allclose(res["time"], t, atol=1e-12)  # 0 to 0.3 s whatever omega is
        for k, name in enumerate(("tip", "theta")):
            scale = np.abs(values[:, k]).max()
            assert scale > 0
            assert np.abs(res[name] - values[:, k]).max() < 1e-5 * scale, (sets, name)


@needs_cc
def test_si_fmu_refuses_bad_physical_parameters(tmp_path):
    fmpy = pytest.importorskip("fmpy")
    from symgen.api import write_fmu

    fmu = write_fmu(write_scene(tmp_path / "si_arm.toml", ARM), tmp_path / "si_arm.fmu")
    for start, fragment in (
        ({"bodies.arm.E": -1.0}, "not a valid value of the physical input bodies.arm.E: it must be > 0"),
        ({"bodies.arm.E": 1e11, "mu_arm": 2.0}, "the parameter mu_arm was set, and the physical inputs set"),
    ):
        messages = []
        with pytest.raises(Exception):  # noqa: B017 - fmpy raises its own exception types
            fmpy.simulate_fmu(
                str(fmu), stop_time=0.01, start_values=start, logger=lambda *a: messages.append(a[-1].decode())
            )
        assert any(fragment in m for m in messages), messages
