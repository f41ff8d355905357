"""Several drivers (issue 21, deliver 1): ``[[drivers]]``, mixed angle and torque drivers.

Oracles, independent of symgen's derivation:

* the closed-form laws theta_i(tau) = initial_i + rate_i tau of the five-bar's two angle
  drivers (``examples/five_bar.toml``);
* the energy balance: without gravity, damping or other loads the change of the mechanism's
  energy equals the work of the drivers, E(tau) - E(0) = int_0^tau sum_i M_i theta_i' dtau
  (each driver's moment times its bar's angular rate). The integral is taken by the trapezoid
  rule on the output grid, whose error is O(h^2): the test asserts a small relative mismatch
  AND that halving the output step divides it by about 4 (> 3), which shows that what is left
  is the quadrature's error, not a physics mismatch (measured on the five-bar over one turn of
  crank A: 6.1e-3 at h = 0.005 and 1.5e-3 at h = 0.0025, for max |work| = 50);
* the emitted C solver against the Python (IDAS) run, and the FMU's two torque inputs
  against Python runs with the same moments set in the scene.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.cli import main
from symgen.ir.records import CoordKind
from symgen.model.structure import model_spec
from symgen.numerics.simulate import simulate
from symgen.scene.loader import load_scene

ROOT = Path(__file__).resolve().parents[1]
FIVE_BAR = ROOT / "examples" / "five_bar.toml"

# A dimensionless five-bar (ground pins 3 apart, cranks 1, links 3: the tips stay 1..5 apart,
# the links never fold or stretch out); one elastic link keeps it a small model.
BASE = """
[scene]
name = "five_bar_test"
units = "dimensionless"

[[bodies]]
name = "crank_a"
length = 1.0
rigid = true
mass_per_length = 1.0

[[bodies]]
name = "crank_b"
length = 1.0
rigid = true
mass_per_length = 1.0

[[bodies]]
name = "link_a"
length = 3.0
lambda = 1e4
mu = 20.0
frame = "pinned-pinned"
axial_modes = 0
transverse_modes = 2

[[bodies]]
name = "link_b"
length = 3.0
rigid = true
mass_per_length = 1.0

[[joints]]
name = "O1"
kind = "pin"
bodies = ["ground", "crank_a"]
at = [[0.0, 0.0], 0.0]

[[joints]]
name = "O2"
kind = "pin"
bodies = ["ground", "crank_b"]
at = [[3.0, 0.0], 0.0]

[[joints]]
name = "A"
kind = "pin"
bodies = ["crank_a", "link_a"]
at = [1.0, 0.0]

[[joints]]
name = "B"
kind = "pin"
bodies = ["crank_b", "link_b"]
at = [1.0, 0.0]

[[joints]]
name = "P"
kind = "pin"
bodies = ["link_a", "link_b"]
at = [1.0, 1.0]

{drivers}

[initial]
guess = {{ link_a = 1.65, link_b = 2.42 }}

[outputs]
{outputs}

[simulation]
t_end = {t_end}
output_step = 0.01
rtol = 1e-9
atol = 1e-11
"""
ANGLE_A = '[[drivers]]\nkind = "angle"\nbody = "crank_a"\nrate = 1.0\n'
ANGLE_B = '[[drivers]]\nkind = "angle"\nbody = "crank_b"\ninitial = 1.5707963267948966\nrate = 2.0\n'
TORQUE_A = '[[drivers]]\nkind = "torque"\nbody = "crank_a"\nvalue = 0.5\n'
TORQUE_B = '[[drivers]]\nkind = "torque"\nbody = "crank_b"\ninitial = 1.5707963267948966\nvalue = -0.3\n'
ANGLES = 'ta = { kind = "angle", body = "crank_a" }\ntb = { kind = "angle", body = "crank_b" }'
ENERGY = 'energy = { kind = "energy" }'


def scene_file(tmp_path, drivers: str, outputs: str = ANGLES, t_end: float = 1.0, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(BASE.format(drivers=drivers, outputs=outputs, t_end=t_end))
    return path


def columns(res) -> dict:
    return dict(zip(res.output_names, np.asarray(res.outputs).T))


def work_mismatch(tau, energy, power) -> float:
    """max |E(tau) - E(0) - int_0^tau power| (trapezoid rule on the output grid)."""
    work = np.concatenate([[0.0], np.cumsum((power[1:] + power[:-1]) / 2 * np.diff(tau))])
    return float(np.abs(energy - energy[0] - work).max()), float(np.abs(work).max())


# --------------------------------------------------------------------------- the scene contract
def test_one_drivers_entry_is_the_driver_table(tmp_path):
    """[[drivers]] with one table is [driver]: the same model (its cache key) and drivers."""
    a = load_scene(scene_file(tmp_path, ANGLE_A, name="a.toml"))
    b = load_scene(scene_file(tmp_path, ANGLE_A.replace("[[drivers]]", "[driver]"), name="b.toml"))
    assert a.drivers == b.drivers and len(a.drivers) == 1
    assert model_spec(a).key() == model_spec(b).key()
    assert "drivers" not in model_spec(a).to_json()


def test_two_drivers_load_in_order_and_serialise(tmp_path):
    scene = load_scene(scene_file(tmp_path, ANGLE_A + ANGLE_B))
    assert [(d.kind, d.body, d.rate) for d in scene.drivers] == [("angle", "crank_a", 1.0), ("angle", "crank_b", 2.0)]
    spec = model_spec(scene)
    js = spec.to_json()
    assert js["driver"] is None and [d["body"] for d in js["drivers"]] == ["crank_a", "crank_b"]
    assert type(spec).from_json(js) == spec
    with pytest.raises(ValueError, match="drivers"):
        _ = scene.driver  # no single driver to read: code must handle Scene.drivers


BAD = [
    (ANGLE_A + ANGLE_B.replace("[[drivers]]", "[driver]"), ANGLES, "drivers", "not both"),
    (ANGLE_A + ANGLE_B.replace("crank_b", "crank_a"), ANGLES, "drivers[1].body", "already driven by drivers[0]"),
    (ANGLE_A + ANGLE_B.replace('"crank_b"', '"link_b"'), ANGLES, "drivers[1].body", 'no pin joint with "ground"'),
    (ANGLE_A + ANGLE_B.replace('kind = "angle"', 'kind = "spin"'), ANGLES, "drivers[1].kind", "spin"),
    (ANGLE_A + TORQUE_B.replace("value = -0.3", 'value = "1/(tau - 0.5)"'), ANGLES, "drivers[1].value", "finite"),
    (ANGLE_A + ANGLE_B, 'm = { kind = "driver_torque" }', "outputs.m.body", "must say which"),
    (ANGLE_A + TORQUE_B, 'm = { kind = "driver_torque", body = "crank_b" }', "outputs.m.body", "no angle driver"),
    (TORQUE_A + TORQUE_B, 'm = { kind = "driver_torque" }', "outputs.m.kind", "every driver is a torque driver"),
]


@pytest.mark.parametrize("drivers,outputs,key,fragment", BAD)
def test_bad_drivers_exit_2_naming_the_key(tmp_path, capsys, drivers, outputs, key, fragment):
    path = scene_file(tmp_path, drivers, outputs)
    code = main(["check", str(path)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert key in err and fragment in err and str(path) in err, err
    assert "Traceback" not in err


def test_cycles_count_the_turns_of_the_first_turning_angle_driver(tmp_path):
    text = BASE.format(drivers=ANGLE_A.replace("rate = 1.0", "rate = 0.5") + ANGLE_B, outputs=ANGLES, t_end=1.0)
    path = tmp_path / "c.toml"
    path.write_text(text.replace("t_end = 1.0", "cycles = 2"))
    assert load_scene(path).simulation.t_end == pytest.approx(2 * 2 * math.pi / 0.5)


# --------------------------------------------------------------------------- the five-bar
@pytest.fixture(scope="module")
def five_bar_runs():
    """The example at two output steps h and h / 2 (one turn of crank A each)."""
    return {h: simulate(mechanism(FIVE_BAR, [f"simulation.output_step={h!r}"])) for h in (0.005, 0.0025)}


def test_five_bar_cranks_follow_their_laws(five_bar_runs):
    """theta_a = 0 + 1 tau and theta_b = pi/2 + 2 tau (the scene's laws) at every output."""
    res = five_bar_runs[0.005]
    out = columns(res)
    assert res.tau[-1] == pytest.approx(2 * math.pi, abs=0.006)
    np.testing.assert_allclose(out["theta_a"], res.tau, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["theta_b"], math.pi / 2 + 2 * res.tau, rtol=0, atol=1e-12)
    assert np.abs(out["closure"]).max() < 1e-12
    assert np.abs(out["link_mid"]).max() > 1e-4  # the elastic link does bend


def test_five_bar_energy_balances_the_work_of_both_drivers(five_bar_runs):
    """E(tau) - E(0) = int (M_a theta_a' + M_b theta_b') dtau with theta_a' = 1, theta_b' = 2."""
    miss = {}
    for h, res in five_bar_runs.items():
        out = columns(res)
        miss[h], peak = work_mismatch(res.tau, out["energy"], 1.0 * out["torque_a"] + 2.0 * out["torque_b"])
        assert peak > 10.0  # both drivers do work: the balance is not trivially zero
        assert miss[h] < 2e-4 * peak, (h, miss[h], peak)
    # only the trapezoid rule's O(h^2) is left: halving h divides it by about 4
    assert miss[0.0025] < miss[0.005] / 3, miss
    # each driver alone does not balance it: both are needed
    res = five_bar_runs[0.0025]
    out = columns(res)
    for alone in (out["torque_a"], 2.0 * out["torque_b"]):
        assert work_mismatch(res.tau, out["energy"], alone)[0] > 100 * miss[0.0025]


def test_mixed_angle_and_torque_drivers_balance_their_work(tmp_path):
    """Crank A prescribed, crank B under a constant moment (its angle free): the run completes
    and the energy changes by the work of the angle driver's torque and of the applied moment
    M_b theta_b' (theta_b' read from the states)."""
    path = scene_file(tmp_path, ANGLE_A + TORQUE_B, f'{ANGLES}\nma = {{ kind = "driver_torque" }}\n{ENERGY}', 2.0)
    mech = mechanism(path, ["simulation.output_step=0.002"])
    res = simulate(mech)
    out = columns(res)
    assert res.tau[-1] == pytest.approx(2.0)
    np.testing.assert_allclose(out["ta"], res.tau, atol=1e-12)
    ib = mech.info.coordinate(CoordKind.THETA, "crank_b")
    rate_b = np.asarray(res.v)[:, ib]
    assert np.abs(out["tb"] - math.pi / 2).max() > 0.05  # crank B moves under its moment
    miss, peak = work_mismatch(res.tau, out["energy"], out["ma"] * 1.0 + (-0.3) * rate_b)
    assert peak > 0.1 and miss < 1e-4 * peak, (miss, peak)


# --------------------------------------------------------------------------- C and FMU
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")


@needs_cc
def test_emitted_c_of_the_five_bar_agrees_with_python(tmp_path):
    """The emitted C (compiled) integrates both angle drivers as the Python run does: the crank
    angles exactly, the rest within its tolerance (rtol 1e-7: the torques to 5e-4 of their
    peak, measured 8.5e-5; the deflection, position and energy to 1e-5, measured <= 4e-7)."""
    from symgen.api import write_c
    from symgen.backends.c.build import compile_executable

    mech = mechanism(FIVE_BAR, ["simulation.cycles=0.5"])
    src = write_c(FIVE_BAR, tmp_path / "c", ["simulation.cycles=0.5"])
    exe = compile_executable(
        [src / f"five_bar{x}.c" for x in ("", "_jac", "_solver", "_sim")], tmp_path / "five_bar_sim", include=[src]
    )
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[0].split(",") == ["tau", *mech.info.outputs]
    c = np.array([[float(x) for x in row.split(",")] for row in lines[1:]])
    res = simulate(mech)
    py = np.column_stack([res.tau, res.outputs])
    assert c.shape == py.shape and c.shape[0] > 150
    np.testing.assert_allclose(c[:, 0], py[:, 0], atol=1e-12)
    names = ["tau", *mech.info.outputs]
    for k, name in enumerate(names[1:], 1):
        peak = np.abs(py[:, k]).max()
        tol = {"theta_a": 1e-12, "theta_b": 1e-12, "torque_a": 5e-4, "torque_b": 5e-4, "closure": None}.get(name, 1e-5)
        if tol is None:
            assert np.abs(c[:, k]).max() < 1e-12
        else:
            assert np.abs(c[:, k] - py[:, k]).max() <= tol * max(peak, 1.0), name


@needs_cc
def test_fmu_has_one_input_per_torque_driver(tmp_path, capsys):
    """Two torque drivers: two real inputs (the moments), settable, and they act: the FMU run
    with moments given as input signals matches the Python runs with those moments in the
    scene (rtol 1e-9 of the scene: to 1e-6 of the angles' swing)."""
    fmpy = pytest.importorskip("fmpy")
    path = scene_file(tmp_path, TORQUE_A + TORQUE_B, ANGLES, 1.0)
    fmu = tmp_path / "two_torques.fmu"
    assert main(["emit-fmu", str(path), "-o", str(fmu)]) == 0, capsys.readouterr().err
    md = fmpy.read_model_description(str(fmu))
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    assert [v.name for v in inputs] == ["torque", "torque_2"]
    assert [float(v.start) for v in inputs] == [0.5, -0.3]
    assert all(v.variability == "continuous" for v in inputs)
    assert "torque" not in [v.name for v in md.modelVariables if v.causality == "parameter"]

    signal = np.array(
        [(0.0, 0.8, 0.2), (1.0, 0.8, 0.2)], dtype=[("time", float), ("torque", float), ("torque_2", float)]
    )
    got = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.1, input=signal)
    ref = simulate(mechanism(path, ["drivers.0.value=0.8", "drivers.1.value=0.2", "simulation.output_step=0.1"]))
    out = columns(ref)
    for name in ("ta", "tb"):
        swing = np.ptp(out[name])
        assert swing > 0.05
        assert np.abs(got[name] - out[name]).max() < 1e-6 * swing + 1e-9, name
    default = columns(simulate(mechanism(path, ["simulation.output_step=0.1"])))
    assert np.abs(got["ta"] - default["ta"]).max() > 1e-3  # the inputs, not the scene's moments, acted


@needs_cc
def test_fmu_torque_input_set_between_steps_acts_from_then_on(tmp_path, capsys):
    """A moment switched off at tau = 0.5 between two communication steps (the FMU in step
    mode) gives the Python run whose moment is the same step function of tau."""
    fmpy = pytest.importorskip("fmpy")
    path = scene_file(tmp_path, TORQUE_A + TORQUE_B, ANGLES, 1.0)
    fmu = tmp_path / "two_torques.fmu"
    assert main(["emit-fmu", str(path), "-o", str(fmu)]) == 0, capsys.readouterr().err
    dtype = [("time", float), ("torque", float), ("torque_2", float)]
    signal = np.array([(0.0, 0.8, 0.2), (0.5, 0.8, 0.2), (0.5, 0.0, 0.2), (1.0, 0.0, 0.2)], dtype=dtype)
    got = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=0.1, input=signal)
    switched = scene_file(
        tmp_path,
        TORQUE_A.replace("value = 0.5", 'value = "0.8*Heaviside(0.5 - tau)"') + TORQUE_B,
        ANGLES,
        1.0,
        "h.toml",
    )
    ref = columns(simulate(mechanism(switched, ["drivers.1.value=0.2", "simulation.output_step=0.1"])))
    held = columns(
        simulate(mechanism(path, ["drivers.0.value=0.8", "drivers.1.value=0.2", "simulation.output_step=0.1"]))
    )
    for name in ("ta", "tb"):
        swing = np.ptp(ref[name])
        assert np.abs(got[name] - ref[name]).max() < 1e-5 * swing, name
    assert np.abs(got["ta"][-1] - held["ta"][-1]) > 1e-3  # the switch acted
