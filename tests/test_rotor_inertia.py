"""Drivers with rotor inertia and lumped rotary inertias (issue 12, Deliver 3).

Oracles: the rigid pendulum's closed forms (constant torque without gravity: theta = T tau^2 /
(2 (I_bar + J)); the prescribed law theta = tau^2/2: driver torque = I_bar + J), an independent
SciPy integration of the rigid pendulum under gravity, the energy balance of elastic runs
(kinetic + elastic + potential - work of the torque constant to the solver's tolerance), and
SI input against the dimensionless groups.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from symgen.api import mechanism, simulate_scene
from symgen.cli import main
from symgen.dae import derive
from symgen.scene import load_scene
from tests.oracles import write_scene

PENDULUM = """
[scene]
name = "pendulum"
[[bodies]]
name = "bar"
length = 1.0
{bar}
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
{pin}
[driver]
{driver}
[effects]
gravity = [0.0, {g}]
[outputs]
angle = {{ kind = "angle", body = "bar" }}
energy = {{ kind = "energy" }}
[simulation]
t_end = {t_end}
output_step = 0.05
rtol = 1e-10
atol = 1e-12
"""
RIGID = "rigid = true"
ELASTIC = 'lambda = 1.0e4\nmu = 2.0\nframe = "{frame}"\naxial_modes = 2\ntransverse_modes = 3'


def _scene(tmp_path, name="p.toml", bar=RIGID, driver='kind = "torque"\nbody = "bar"\nvalue = 0.3\ninitial = 0.0',
           g=0.0, t_end=2.0, pin=""):
    return write_scene(tmp_path / name, PENDULUM.format(bar=bar, driver=driver, g=g, t_end=t_end, pin=pin))


def test_rigid_pendulum_with_rotor_under_constant_torque_is_the_closed_form(tmp_path):
    """I_bar = 1/3 (uniform bar about its end, m_ref l0^3 units); theta = T tau^2 / (2 (1/3 + J))."""
    T, J = 0.3, 0.5
    drv = f'kind = "torque"\nbody = "bar"\nvalue = {T}\ninitial = 0.0\nrotor_inertia = {J}'
    res = simulate_scene(_scene(tmp_path, driver=drv))
    np.testing.assert_allclose(res.column("angle"), T * res.tau ** 2 / (2 * (1 / 3 + J)), rtol=1e-8, atol=1e-12)
    without = simulate_scene(_scene(tmp_path, "q.toml"))        # the rotor is not ignored
    assert without.column("angle")[-1] > 1.5 * res.column("angle")[-1]


def test_rigid_pendulum_with_rotor_under_gravity_matches_an_independent_integration(tmp_path):
    from scipy.integrate import solve_ivp
    T, J, g = 0.8, 0.25, -1.0
    drv = f'kind = "torque"\nbody = "bar"\nvalue = {T}\ninitial = 0.0\nrotor_inertia = {J}'
    res = simulate_scene(_scene(tmp_path, driver=drv, g=g, t_end=4.0))
    # (1/3 + J) theta'' = T + g (1/2) cos(theta)   (gravity along y: moment of m g at the centre)
    sol = solve_ivp(lambda t, y: [y[1], (T + g * 0.5 * math.cos(y[0])) / (1 / 3 + J)], (0, 4.0), [0.0, 0.0],
                    t_eval=res.tau, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(res.column("angle"), sol.y[0], atol=1e-7)


def test_prescribed_angle_driver_torque_includes_the_rotor(tmp_path):
    """theta = tau^2 / 2 (theta'' = 1), no gravity: the driver supplies (I_bar + J) theta''."""
    J = 0.7
    drv = f'kind = "angle"\nbody = "bar"\ninitial = 0.0\nlaw = "tau^2/2"\nrotor_inertia = {J}'
    path = _scene(tmp_path, driver=drv, t_end=1.0)
    path.write_text(path.read_text().replace("[outputs]", '[outputs]\ntorque = { kind = "driver_torque" }'))
    res = simulate_scene(path)
    np.testing.assert_allclose(res.column("torque"), 1 / 3 + J, rtol=1e-9)


@pytest.mark.parametrize("frame", ["cantilever", "pinned-pinned"])
def test_elastic_pendulum_with_rotor_and_pin_inertia_conserves_energy(tmp_path, frame):
    """An elastic bar with a rotor on its shaft and a lumped rotary inertia at its pin (turning
    with the section there, theta + eta'(0): in the chord frame eta'(0) moves), under a torque
    and gravity: kinetic + elastic + potential energy minus the work of the torque
    T (theta - theta0) stays constant to the solver's tolerance (the rotary terms are in the
    equations and in the energy alike)."""
    T = 0.5
    drv = f'kind = "torque"\nbody = "bar"\nvalue = {T}\ninitial = 0.0\nrotor_inertia = 0.2'
    scene = _scene(tmp_path, bar=ELASTIC.format(frame=frame), driver=drv, g=-0.5, t_end=3.0,
                   pin="inertia = 0.05")
    res = simulate_scene(scene)
    work = T * (res.column("angle") - res.column("angle")[0])
    balance = res.column("energy") - work
    assert np.abs(balance - balance[0]).max() < 1e-7 * np.abs(res.column("energy")).max()
    assert np.abs(res.column("angle")).max() > 0.5                 # it did turn


def test_pin_inertia_and_rotor_enter_the_rigid_closed_form(tmp_path):
    """Rigid bar, rotor J and a lumped rotary inertia I at its pin: theta = T tau^2 / (2 (1/3 + I + J))."""
    T, J, inertia = 0.3, 0.1, 0.02
    drv = f'kind = "torque"\nbody = "bar"\nvalue = {T}\ninitial = 0.0\nrotor_inertia = {J}'
    res = simulate_scene(_scene(tmp_path, driver=drv, pin=f"inertia = {inertia}"))
    total = 1 / 3 + inertia + J
    np.testing.assert_allclose(res.column("angle"), T * res.tau ** 2 / (2 * total), rtol=1e-8, atol=1e-12)


def test_si_input_gives_the_dimensionless_groups(tmp_path):
    """J [kg m^2] / (m_ref l0^3) and a joint's inertia likewise."""
    si = """
[scene]
name = "si_rotor"
units = "SI"
omega = 10.0
[[bodies]]
name = "bar"
length = 0.5
rigid = true
mass_per_length = 2.0
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
mass = 0.1
inertia = 0.004
[driver]
kind = "torque"
body = "bar"
value = 1.0
rotor_inertia = 0.03
[outputs]
angle = { kind = "angle", body = "bar" }
[simulation]
t_end = 1.0
output_step = 0.1
"""
    scene = load_scene(write_scene(tmp_path / "si.toml", si))
    m_ref, l0 = scene.groups["_scene"]["m_ref"], scene.groups["_scene"]["l0"]
    assert scene.driver.rotor_inertia == pytest.approx(0.03 / (m_ref * l0 ** 3))
    assert scene.joints[0].inertia == pytest.approx(0.004 / (m_ref * l0 ** 3))


def test_rotor_term_only_when_asked(tmp_path):
    """A scene without a rotor derives no J_rotor parameter (and keeps its model key)."""
    plain = derive(load_scene(_scene(tmp_path)))
    assert "J_rotor" not in plain.param_names
    drv = 'kind = "torque"\nbody = "bar"\nvalue = 0.3\ninitial = 0.0\nrotor_inertia = 0.5'
    with_rotor = derive(load_scene(_scene(tmp_path, "r.toml", driver=drv)))
    assert "J_rotor" in with_rotor.param_names and with_rotor.key != plain.key


@pytest.mark.parametrize("value, fragment", [("-1.0", ">= 0"), ('"big"', "number"), ("nan", "finite")])
def test_bad_rotor_inertia_names_the_key(tmp_path, capsys, value, fragment):
    drv = f'kind = "torque"\nbody = "bar"\nvalue = 0.3\nrotor_inertia = {value}'
    path = _scene(tmp_path, driver=drv)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "driver.rotor_inertia" in err and fragment in err


def test_emitted_c_matches_python_with_a_rotor(tmp_path):
    """The rotor is in the derived residual, hence in the emitted C: the C driver's angle
    matches IDAS."""
    import shutil
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler")
    from symgen.run.csolver import simulate_c
    drv = 'kind = "torque"\nbody = "bar"\nvalue = 0.3\ninitial = 0.0\nrotor_inertia = 0.5'
    mech = mechanism(_scene(tmp_path, bar=ELASTIC.format(frame="cantilever"), driver=drv, g=-0.5))
    from symgen.run.simulate import simulate
    a, c = simulate(mech), simulate_c(mech, use_cache=False)
    np.testing.assert_allclose(c.column("angle"), a.column("angle"), atol=1e-6)
