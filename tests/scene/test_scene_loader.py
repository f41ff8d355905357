"""Valid scenes load into the right dimensionless numbers."""

from __future__ import annotations

import hashlib
import json
import math
import tomllib

import pytest

from symgen.errors import SceneError
from symgen.policy import tolerances
from symgen.scene import GROUND, OUTPUT_KINDS, BodyDeformation, Effects, JointEnd, load_scene
from symgen.scene.outputs import KIND_KEYS

MINIMAL = """
[scene]
name = "pendulum"

[[bodies]]
name = "arm"
length = 1.5
rigid = true

[[bodies]]
name = "tip"
length = 0.5
rigid = true

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]

[[joints]]
name = "A"
kind = "pin"
bodies = ["arm", "tip"]
at = [1.0, 0.0]

[outputs]
th = { kind = "angle", body = "arm" }

[simulation]
cycles = 1
"""


def test_dimensionless_slider_crank(dimless_path):
    # l0 = first flexible bar's length = rod.length = 2.0; m_ref = rod's mass_per_length = 4.0.
    scene = load_scene(dimless_path)
    assert (scene.name, scene.units, scene.l0, scene.omega, scene.m_ref) == (
        "slider_crank",
        "dimensionless",
        2.0,
        1.0,
        4.0,
    )
    crank, rod = scene.bodies
    assert (crank.name, crank.rigid, crank.alpha, crank.nu) == ("crank", True, 0.25, 0.5)
    assert (crank.lam, crank.mu, crank.rho, crank.frame) == (None, None, None, "")
    assert (crank.axial_modes, crank.transverse_modes, crank.axial_shapes) == (0, 0, "")
    assert (rod.alpha, rod.nu, rod.lam, rod.mu) == (1.0, 1.0, 18246.0, 0.495)
    assert rod.rho == pytest.approx(0.495 / 18246.0, rel=1e-15)
    assert rod.frame == "pinned-pinned"  # "pinned-sliding" is an alias
    assert (rod.axial_modes, rod.transverse_modes) == (1, 2)
    assert (rod.axial_shapes, rod.transverse_shapes) == ("complete", "modes")

    O, A, B = scene.joints
    assert O.ends == (JointEnd(GROUND, point=(0.0, 0.25)), JointEnd("crank", xi=0.0))  # 0.5 / l0
    assert (O.kind, O.direction, O.mass) == ("pin", None, 0.0)
    assert A.ends == (JointEnd("crank", xi=1.0), JointEnd("rod", xi=0.0))
    assert B.kind == "slider" and B.ends[1] == JointEnd(GROUND, point=(0.0, 0.25))
    assert B.direction == pytest.approx((0.6, 0.8))  # [3, 4] / 5
    assert B.mass == 0.25

    d = scene.driver
    assert (d.kind, d.body, d.initial, d.rate) == ("angle", "crank", 0.1, 2.0)
    assert scene.initial.guess == (("rod", -0.2),)
    assert scene.initial.deformation == (
        ("rod", BodyDeformation(f=(0.0,), g=(0.01, 0.0), fdot=(0.0,), gdot=(0.0, 0.0))),
    )
    assert not scene.initial.quasi_static
    assert scene.effects == Effects(axial=True, coriolis=False, gravity=(0.0, -0.5), damping=0.01)
    dist, point = scene.loads
    assert (dist.kind, dist.xi, dist.axial, dist.transverse) == ("distributed", None, 0.0, "0.1*sin(tau)")
    assert (point.kind, point.xi, point.axial, point.transverse) == ("point", 0.5, 0.0, 1.5)
    assert [o.name for o in scene.outputs] == [
        "eta_mid",
        "eps_ax",
        "xB",
        "theta_rod",
        "RBy",
        "M0",
        "E",
        "res",
    ]  # file order
    assert (scene.outputs[0].body, scene.outputs[0].xi) == ("rod", 0.5)
    assert (scene.outputs[2].component, scene.outputs[4].joint) == ("x", "B")
    # cycles = 2 with an angle driver at rate 2: t_end = 2 * 2 pi / 2
    assert scene.simulation.t_end == pytest.approx(2.0 * math.pi)
    assert (scene.simulation.output_step, scene.simulation.rtol, scene.simulation.atol) == (0.01, 1e-7, 1e-9)


def test_groups_are_json_and_complete(dimless_path):
    scene = load_scene(dimless_path)
    groups = json.loads(json.dumps(scene.groups))
    assert groups["rod"] == {
        "alpha": 1.0,
        "nu": 1.0,
        "lambda": 18246.0,
        "mu": 0.495,
        "rho": pytest.approx(0.495 / 18246.0),
    }
    assert groups["crank"] == {"alpha": 0.25, "nu": 0.5, "lambda": None, "mu": None, "rho": None}
    assert groups["_scene"] == {"l0": 2.0, "omega": 1.0, "m_ref": 4.0, "units": "dimensionless", "gravity": [0.0, -0.5]}


def test_hash_is_sha256_of_canonical_json(dimless_path):
    with open(dimless_path, "rb") as f:
        raw = tomllib.load(f)
    expected = hashlib.sha256(json.dumps(raw, sort_keys=True).encode()).hexdigest()
    assert load_scene(dimless_path).hash == expected
    assert load_scene(str(dimless_path)).hash == expected  # str and PathLike
    assert load_scene(dimless_path, ["simulation.rtol=1e-6"]).hash != expected


def test_si_scene_groups(si_path):
    """Hand computation (omega = 100 rad/s, l0 = rod length 0.3 m):

    rod:   m = density * area = 7800 * 1e-4 = 0.78 kg/m  (m_ref, the first flexible bar)
           lambda = E A / (m l^2 w^2) = 2e11 * 1e-4 / (0.78 * 0.09 * 1e4)   = 2e7 / 702  = 28490.0285
           mu     = E I / (m l^4 w^2) = 2e11 * 1e-9 / (0.78 * 0.0081 * 1e4) = 200 / 63.18 = 3.16556
           rho    = mu / lambda = I / (A l^2) = 1e-9 / (1e-4 * 0.09) = 1.1111e-4
    crank: alpha = 0.1 / 0.3 = 1/3;  nu = 1.56 / 0.78 = 2
    slider B ground point 0.06 m / 0.3 = 0.2;  lumped mass 0.05 kg / (0.78 * 0.3) = 0.213675
    gravity -9.81 / (0.3 * 1e4) = -3.27e-3
    distributed 2 N/m / (0.78 * 0.3 * 1e4) = 8.547e-4;  point 10 N / (0.78 * 0.09 * 1e4) = 0.0142450
    driver rate, t_end, output_step are in tau in both unit systems: 1, 10, 0.1
    """
    scene = load_scene(si_path)
    assert (scene.units, scene.l0, scene.omega, scene.m_ref) == ("SI", 0.3, 100.0, pytest.approx(0.78))
    g = scene.groups
    assert g["rod"]["lambda"] == pytest.approx(2e7 / 702.0, rel=1e-12)
    assert g["rod"]["lambda"] == pytest.approx(28490.0285, rel=1e-9)
    assert g["rod"]["mu"] == pytest.approx(200.0 / 63.18, rel=1e-12)
    assert g["rod"]["mu"] == pytest.approx(3.165559, rel=1e-6)
    assert g["rod"]["rho"] == pytest.approx(1e-9 / (1e-4 * 0.09), rel=1e-12)
    assert (g["rod"]["alpha"], g["rod"]["nu"]) == (1.0, 1.0)
    assert g["crank"] == {
        "alpha": pytest.approx(1 / 3),
        "nu": pytest.approx(2.0),
        "lambda": None,
        "mu": None,
        "rho": None,
    }
    assert g["_scene"]["gravity"] == [0.0, pytest.approx(-3.27e-3)]
    assert scene.joint("B").ends[1].point == pytest.approx((0.0, 0.2))
    assert scene.joint("B").mass == pytest.approx(0.05 / (0.78 * 0.3))
    dist, point = scene.loads
    assert dist.transverse == pytest.approx(2.0 / 2340.0) and dist.axial == 0.0
    assert point.axial == pytest.approx(10.0 / 702.0) and point.transverse == 0.0
    assert scene.driver.rate == pytest.approx(1.0)
    assert scene.simulation.t_end == pytest.approx(10.0)
    assert scene.simulation.output_step == pytest.approx(0.1)


def test_si_torque_driver_and_cycles(si_path, write_scene):
    # torque 3 N m / (m_ref l0^3 w^2) = 3 / (0.78 * 0.027 * 1e4) = 3 / 210.6
    text = si_path.read_text().replace(
        "t_end = 10.0                  # in tau, as the contract says, also for SI", "cycles = 3"
    )
    scene = load_scene(write_scene(text), ['driver={kind = "torque", body = "crank", value = 3.0, rate = 50.0}'])
    assert scene.driver.kind == "torque" and scene.driver.initial is None
    assert scene.driver.torque == pytest.approx(3.0 / 210.6)
    assert scene.driver.rate == pytest.approx(50.0)  # per tau, as written
    # no angle driver: t_end = cycles * 2 pi (in tau)
    assert scene.simulation.t_end == pytest.approx(6.0 * math.pi)


def test_si_mass_per_length_instead_of_density(si_path, write_scene):
    text = si_path.read_text().replace("density = 7800.0", "mass_per_length = 0.78")
    scene = load_scene(write_scene(text))
    assert scene.m_ref == 0.78
    assert scene.groups == load_scene(si_path).groups


def test_si_initial_rates_are_per_tau(si_path):
    # amplitudes are dimensionless and their rates per tau, in SI files too
    scene = load_scene(si_path, ["initial.deformation.rod={f = [0.001], gdot = [5.0]}"])
    ((name, deformation),) = scene.initial.deformation
    assert name == "rod"
    assert deformation == BodyDeformation(f=(0.001,), g=(0.0,), fdot=(0.0,), gdot=(5.0,))


def test_defaults_of_a_minimal_scene(write_scene):
    scene = load_scene(write_scene(MINIMAL))
    # all bars rigid: l0 and m_ref come from the first bar
    assert (scene.units, scene.omega, scene.l0, scene.m_ref) == ("dimensionless", 1.0, 1.5, 1.0)
    assert [b.alpha for b in scene.bodies] == pytest.approx([1.0, 1 / 3])
    assert scene.driver is None and scene.loads == ()
    assert scene.effects == Effects()
    assert scene.initial.guess == () and scene.initial.deformation == ()
    sim = scene.simulation
    assert sim.t_end == pytest.approx(2.0 * math.pi)  # no driver: cycles * 2 pi
    assert sim.output_step == pytest.approx(2.0 * math.pi / 360.0)
    # no rtol, no atol: both from the default accuracy by IDAS's rule (symgen.policy.tolerances)
    assert sim.accuracy == 0.01 and sim.tolerances_from == "accuracy"
    assert (sim.rtol, sim.atol) == tolerances(0.01, "idas") == sim.tolerances("idas")


def test_flexible_defaults_and_reference_length(write_scene):
    text = MINIMAL.replace(
        'name = "tip"\nlength = 0.5\nrigid = true',
        'name = "tip"\nlength = 0.5\nframe = "cantilever"\naxial_modes = 0\ntransverse_modes = 2\nmu = 3.0',
    )
    text = text.replace('name = "pendulum"', 'name = "pendulum"\nreference_length = 0.25')
    scene = load_scene(write_scene(text))
    tip = scene.body("tip")
    assert (tip.frame, tip.axial_shapes, tip.transverse_shapes) == ("cantilever", "complete", "modes")
    assert (tip.lam, tip.mu, tip.rho, tip.nu) == (None, 3.0, None, 1.0)  # lambda not needed
    assert scene.l0 == 0.25 and tip.alpha == 2.0 and scene.body("arm").alpha == 6.0


def test_torque_driver_expression_and_quasi_static(dimless_path):
    scene = load_scene(
        dimless_path,
        [
            'driver={kind = "torque", body = "crank", value = "0.5*Heaviside(tau - 1)"}',
            'outputs.M0={kind = "energy"}',
            'initial.deformation="quasi-static"',
        ],
    )
    d = scene.driver
    assert (d.kind, d.torque, d.initial, d.rate) == ("torque", "0.5*Heaviside(tau - 1)", None, 0.0)
    assert scene.initial.quasi_static and scene.initial.deformation == ()
    assert scene.initial.guess == (("rod", -0.2),)
    assert scene.simulation.t_end == pytest.approx(4.0 * math.pi)  # cycles 2, no angle driver


def test_output_kinds_table_matches_model():
    assert set(KIND_KEYS) == set(OUTPUT_KINDS)


def test_message_format(tmp_path):
    path = tmp_path / "missing.toml"
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.key == "" and str(info.value).startswith(f"{path}: cannot read")


def test_error_string_names_file_key_message_and_hint(dimless_path):
    with pytest.raises(SceneError) as info:
        load_scene(dimless_path, ["bodies.rod.mu=-1"])
    err = info.value
    assert str(err) == (f"{dimless_path}: bodies.rod.mu: must be > 0, got -1 ({err.hint})")
    assert err.hint
