"""Modes and quasi-static runs of mechanisms with free rigid coordinates, about their static
equilibrium (``symgen.numerics.equilibrium``), against independent oracles:

* the rigid double pendulum of two uniform bars (lengths l1, l2, masses m1, m2, a lumped mass mA
  at the middle pin) hanging under gravity g: the linearised Lagrangian
      T = 1/2 th'^T M th',  V = 1/2 th^T K th,
      M = [[m1 l1^2/3 + (m2 + mA) l1^2, m2 l1 l2/2], [m2 l1 l2/2, m2 l2^2/3]],
      K = diag(g (m1/2 + m2 + mA) l1, g m2 l2/2),
  whose generalized eigenproblem K x = w^2 M x gives the two pendulum frequencies;
* its bending modes: a finite-element model of the hanging chain of Euler-Bernoulli bars with
  the geometric stiffness of the gravity tension (``tests.oracles.hanging_chain_frequencies``);
* the single elastic pendulum: w^2 = 3 g / (2 l), and the pinned-free bar's first bending
  frequency (beta l)^2 sqrt(mu), beta l = 3.9266 (tan(beta l) = tanh(beta l)), where gravity's
  tension is a 1e-4 correction;
* a torque-driven arm held against gravity: T = m g l/2 cos(theta), two equilibria
  theta = -+ arccos(2 T / (m g l)), the lower one stable with w^2 = m g l/2 |sin theta| / (m l^2/3 + J),
  the upper one unstable (a real eigenvalue of the same size);
* the inverted pendulum: a real eigenvalue sqrt(3 g / (2 l)), reported as instability;
* a crank turned by an angle driver with a free bar hanging from its tip: at every position
  the bar hangs straight down and the driver holds T = g (m1 l1/2 + m2 l1) cos(theta_crank);
  with the crank held, the bar swings at w^2 = 3 g / (2 l2);
* a four-bar (closed loop) with no driver hanging under gravity: the minimum of the rigid
  linkage's potential V(phi) along its one-parameter motion (closed-form circle intersection),
  and w^2 = V''(phi) / M(phi), M the generalized mass of the Lagrangian T = M(phi) phi'^2 / 2.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.linalg as sl

from symgen.api import mechanism
from symgen.cli import main
from symgen.errors import SceneError, SimulationError
from symgen.numerics.modes import modes
from symgen.numerics.quasistatic import QuasiStaticSystem, quasi_static
from tests.oracles import hanging_chain_frequencies, write_scene

G = 1.0
MU = 1.0e3
BETA_PINNED_FREE = 3.92660231204792  # first root of tan x = tanh x

DOUBLE = f"""
[scene]
name = "double_pendulum"
[[bodies]]
name = "upper"
length = 1.0
lambda = 1.0e6
mu = {MU}
frame = "cantilever"
axial_modes = 1
transverse_modes = 4
[[bodies]]
name = "lower"
length = 0.8
mass_per_length = 0.7
lambda = 1.0e6
mu = {MU}
frame = "cantilever"
axial_modes = 1
transverse_modes = 4
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "upper"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "A"
kind = "pin"
bodies = ["upper", "lower"]
at = [1.0, 0.0]
[effects]
gravity = [0.0, -{G}]
[outputs]
upper = {{ kind = "angle", body = "upper" }}
lower = {{ kind = "angle", body = "lower" }}
[simulation]
t_end = 1.0
output_step = 0.25
"""


def rigid_double_pendulum(l1: float, m1: float, l2: float, m2: float, ma: float, g: float) -> np.ndarray:
    M = np.array([[m1 * l1**2 / 3 + (m2 + ma) * l1**2, m2 * l1 * l2 / 2], [m2 * l1 * l2 / 2, m2 * l2**2 / 3]])
    K = np.diag([g * (m1 / 2 + m2 + ma) * l1, g * m2 * l2 / 2])
    return np.sqrt(sl.eigh(K, M, eigvals_only=True))


@pytest.fixture(scope="module")
def double(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("double") / "double.toml", DOUBLE)


@pytest.mark.parametrize("hub", [0.0, 0.3])
def test_hanging_double_pendulum_has_the_rigid_pendulum_frequencies(double, hub):
    res = modes(mechanism(double, [f"joints.A.mass={hub}"]), shapes=False)
    # no initial.guess: both bars start horizontal, where Newton's matrix is singular; the
    # damped solve settles in the stable equilibrium, hanging straight down
    assert res.equilibrium is not None
    assert res.equilibrium["free"] == pytest.approx({"theta_upper": -math.pi / 2, "theta_lower": -math.pi / 2})
    assert res.stable and res.stability()["kind"] == "stable"
    pendulum = res.frequencies("rigid")
    expected = rigid_double_pendulum(1.0, 1.0, 0.8, 0.56, hub, G)
    assert pendulum == pytest.approx(expected, rel=5e-3)
    # the dominant label: the two pendulum modes are the two lowest
    assert [m.dominant for m in res.modes[:2]] == ["upper rigid", "lower rigid"]


def test_hanging_double_pendulum_bending_modes_match_finite_elements(double):
    res = modes(mechanism(double), shapes=False)
    lateral = [m.natural_frequency for m in res.modes if not m.dominant.endswith(" axial")]
    fe = hanging_chain_frequencies([(1.0, 1.0, MU), (0.8, 0.7, MU * 0.7 * 0.8**4)], G, ne=20, count=6)
    # the pendulum modes (FE: from the tension's geometric stiffness alone) and the first four
    # bending modes of the chain
    assert lateral[:6] == pytest.approx(fe, rel=5e-3)
    assert lateral[2] > 100 * lateral[1]  # the bending modes are far above the pendulum's


SINGLE = f"""
[scene]
name = "elastic_pendulum"
[[bodies]]
name = "arm"
length = 1.0
lambda = 1.0e7
mu = 1.0e4
frame = "cantilever"
axial_modes = 1
transverse_modes = 5
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
[effects]
gravity = [0.0, -{G}]
[outputs]
theta = {{ kind = "angle", body = "arm" }}
tip = {{ kind = "deflection", body = "arm", at = 1.0 }}
[simulation]
t_end = 1.0
output_step = 0.5
"""


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("single") / "single.toml", SINGLE)


def test_elastic_single_pendulum(single):
    res = modes(mechanism(single), shapes=False)
    assert res.equilibrium is not None and res.equilibrium["free"]["theta_arm"] == pytest.approx(-math.pi / 2)
    assert res.frequencies("rigid") == pytest.approx([math.sqrt(1.5 * G)], rel=5e-3)
    bending = res.frequencies("transverse")
    # gravity's tension g l / mu = 1e-4 of the bending stiffness: the pinned-free bar's
    assert bending[0] == pytest.approx(BETA_PINNED_FREE**2 * math.sqrt(1.0e4), rel=5e-3)
    fe = hanging_chain_frequencies([(1.0, 1.0, 1.0e4)], G, ne=20, count=3)
    assert bending[:2] == pytest.approx(fe[1:], rel=5e-3)
    assert res.stable


def test_inverted_pendulum_is_reported_unstable(single, tmp_path, capsys):
    over = ["initial.guess={arm = 1.5707963267948966}"]
    res = modes(mechanism(single, over), shapes=False)
    assert res.equilibrium is not None and res.equilibrium["free"]["theta_arm"] == pytest.approx(math.pi / 2)
    verdict = res.stability()
    assert not res.stable and verdict["kind"] == "divergence"
    assert "inverted pendulum" in verdict["reason"] and "initial.guess" in verdict["reason"]
    # the falling motion: s = +- sqrt(3 g / (2 l)) (an imaginary frequency)
    assert max(res.real_eigenvalues) == pytest.approx(math.sqrt(1.5 * G), rel=5e-3)
    assert min(res.real_eigenvalues) == pytest.approx(-math.sqrt(1.5 * G), rel=5e-3)
    # the bending modes are still there, compressed by the weight: a little lower than hanging
    assert res.frequencies("transverse")[0] < modes(mechanism(single), shapes=False).frequencies("transverse")[0]
    out = tmp_path / "inverted.json"
    assert main(["modes", str(single), "--set", over[0], "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "UNSTABLE: the static equilibrium is unstable" in text
    assert "theta_arm = 90 deg" in text and "initial.guess.arm" in text
    doc = json.loads(out.read_text())
    assert doc["stable"] is False and doc["equilibrium"]["free"]["theta_arm"] == pytest.approx(math.pi / 2)
    assert doc["about"].startswith("static equilibrium")


ARM = f"""
[scene]
name = "held_arm"
[[bodies]]
name = "arm"
length = 1.0
lambda = 1.0e7
mu = 1.0e4
frame = "cantilever"
axial_modes = 1
transverse_modes = 3
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "torque"
body = "arm"
value = 0.25
rotor_inertia = 0.1
[effects]
gravity = [0.0, -{G}]
[outputs]
theta = {{ kind = "angle", body = "arm" }}
[simulation]
t_end = 1.0
output_step = 0.5
"""


@pytest.mark.parametrize("torque", [0.1, 0.25, 0.4])
def test_torque_driven_arm_is_held_where_its_torque_balances_gravity(tmp_path, torque):
    path = write_scene(tmp_path / "arm.toml", ARM)
    res = modes(mechanism(path, [f"driver.value={torque}"]), shapes=False)
    theta = -math.acos(2 * torque / (1.0 * G * 1.0))  # m g l/2 cos(theta) = T, the lower one
    assert res.equilibrium is not None
    assert res.equilibrium["free"]["theta_arm"] == pytest.approx(theta, abs=1e-3)
    w = math.sqrt(G / 2 * abs(math.sin(theta)) / (1 / 3 + 0.1))  # the rotor inertia J = 0.1 turns with it
    assert res.frequencies("rigid") == pytest.approx([w], rel=5e-3)
    assert res.stable
    # started near the upper balance, Newton finds that one: unstable, with the same |s|
    up = modes(mechanism(path, [f"driver.value={torque}", f"driver.initial={-theta + 0.05}"]), shapes=False)
    assert up.equilibrium is not None and up.equilibrium["free"]["theta_arm"] == pytest.approx(-theta, abs=1e-3)
    assert not up.stable and max(up.real_eigenvalues) == pytest.approx(w, rel=5e-3)


BOB = f"""
[scene]
name = "crank_and_bob"
reference_length = 1.0
[[bodies]]
name = "crank"
length = 1.0
rigid = true
[[bodies]]
name = "bob"
length = 0.6
mass_per_length = 0.5
lambda = 1.0e6
mu = 1.0e3
frame = "cantilever"
axial_modes = 1
transverse_modes = 2
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "bob"]
at = [1.0, 0.0]
[driver]
kind = "angle"
body = "crank"
initial = 0.3
rate = 1.0
[effects]
gravity = [0.0, -{G}]
[outputs]
crank = {{ kind = "angle", body = "crank" }}
bob = {{ kind = "angle", body = "bob" }}
torque = {{ kind = "driver_torque" }}
[simulation]
t_end = 1.0
output_step = 0.05
"""


def test_quasistatic_tracks_the_equilibrium_over_the_driven_motion(tmp_path):
    path = write_scene(tmp_path / "bob.toml", BOB)
    mech = mechanism(path)
    res = quasi_static(mech)
    assert res.kinematics == "equilibrium" and res.complete
    crank = res.column("crank")
    assert len(res.tau) == 126  # one turn at rate 1, step 0.05
    assert crank == pytest.approx(0.3 + res.tau, abs=1e-12)  # the prescribed angle
    bob = np.angle(np.exp(1j * res.column("bob")))
    assert bob == pytest.approx(np.full_like(bob, -math.pi / 2), abs=1e-4)  # hangs straight down
    # the torque that holds the crank still at each angle (counterclockwise positive); masses
    # relative to the reference bar's mass per length (the bob's, the first elastic bar): the
    # crank 1 / 0.5 = 2 (length 1), the bob 0.6
    m1, m2 = 2.0, 0.6
    hold = G * (m1 / 2 + m2) * np.cos(crank)
    assert res.column("torque") == pytest.approx(hold, abs=1e-4)


def test_modes_of_a_free_bar_on_a_held_crank(tmp_path):
    path = write_scene(tmp_path / "bob.toml", BOB)
    res = modes(mechanism(path), tau=1.0, shapes=False)
    assert res.equilibrium is not None and res.equilibrium["free"] == pytest.approx({"theta_bob": -math.pi / 2})
    assert res.state["theta_crank"] == pytest.approx(1.3)  # the angle driver's angle at tau = 1, held
    assert res.frequencies("rigid") == pytest.approx([math.sqrt(1.5 * G / 0.6)], rel=5e-3)
    assert res.stable


def test_quasistatic_cli_writes_the_equilibrium_run(tmp_path, capsys):
    path = write_scene(tmp_path / "bob.toml", BOB)
    out = tmp_path / "bob.csv"
    assert main(["quasistatic", str(path), "-o", str(out)]) == 0
    assert "static equilibrium at each" in capsys.readouterr().out
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["analysis"].startswith("static equilibrium at each input position")
    assert meta["solver"]["kinematics"] == "equilibrium" and meta["solver"]["positions"] == 126
    assert main(["quasistatic", str(path), "-o", str(out), "--kinematics", "rigid"]) == 2
    err = capsys.readouterr().err
    assert "--kinematics" in err and "theta_bob" in err


def test_the_guided_system_names_the_free_coordinate_and_the_real_reason(tmp_path):
    """The old message said "it has no angle driver" for a scene with one."""
    path = write_scene(tmp_path / "bob.toml", BOB)
    mech = mechanism(path)
    part = mech.initial_state(0.0)[4]
    with pytest.raises(SceneError) as info:
        QuasiStaticSystem(mech, part)
    text = str(info.value)
    assert "no angle driver" not in text
    assert "theta_bob" in text and "angle driver of 'crank'" in text


FREE = """
[scene]
name = "free_crank"
[[bodies]]
name = "crank"
length = 1.0
lambda = 1.0e4
mu = 1.0
frame = "cantilever"
axial_modes = 1
transverse_modes = 1
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "torque"
body = "crank"
value = 0.0
initial = 0.4
[outputs]
theta = { kind = "angle", body = "crank" }
[simulation]
t_end = 1.0
output_step = 0.1
"""


def test_a_crank_nothing_holds_is_neutral(tmp_path):
    path = write_scene(tmp_path / "free.toml", FREE)
    res = modes(mechanism(path), shapes=False)
    assert res.equilibrium is not None and res.equilibrium["free"]["theta_crank"] == pytest.approx(0.4)
    assert res.real_eigenvalues == [0.0, 0.0] and res.stable
    qs = quasi_static(mechanism(path))
    assert qs.column("theta") == pytest.approx(np.full(11, 0.4))


def test_an_unbalanced_torque_has_no_equilibrium(tmp_path, capsys):
    path = write_scene(tmp_path / "free.toml", FREE)
    with pytest.raises(SimulationError, match="no static equilibrium"):
        modes(mechanism(path, ["driver.value=0.5"]), shapes=False)
    out = tmp_path / "free.csv"
    assert main(["quasistatic", str(path), "--set", "driver.value=0.5", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no static equilibrium" in err and "theta_crank" in err and not out.exists()


def test_the_example_double_pendulum_in_hz(tmp_path, capsys):
    """examples/double_pendulum.toml (SI, swung-out guess): the equilibrium hangs straight down and
    its pendulum frequencies in Hz are the rigid double pendulum's of the two steel bars."""
    out = tmp_path / "modes.json"
    assert main(["modes", "examples/double_pendulum.toml", "-o", str(out)]) == 0
    assert "theta_upper = -90 deg, theta_lower = -90 deg" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    rigid = [m["natural_frequency_hz"] for m in doc["modes"] if m["dominant"].endswith(" rigid")]
    m1, m2 = 7850 * 1e-4 * 0.3, 7850 * 1e-4 * 0.25  # kg
    expected = rigid_double_pendulum(0.3, m1, 0.25, m2, 0.0, 9.81) / (2 * math.pi)
    assert rigid == pytest.approx(expected, rel=5e-3)
    assert doc["stable"] is True and doc["equilibrium"]["choose_with"] == ["initial.guess.upper", "initial.guess.lower"]


FOUR_BAR = f"""
[scene]
name = "hanging_four_bar"
reference_length = 1.0
[[bodies]]
name = "crank"
length = 0.5
rigid = true
[[bodies]]
name = "coupler"
length = 1.0
lambda = 1.0e6
mu = 1.0e4
frame = "pinned-pinned"
axial_modes = 1
transverse_modes = 3
[[bodies]]
name = "rocker"
length = 0.8
rigid = true
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "coupler"]
at = [1.0, 0.0]
[[joints]]
name = "B"
kind = "pin"
bodies = ["coupler", "rocker"]
at = [1.0, 1.0]
[[joints]]
name = "C"
kind = "pin"
bodies = ["rocker", "ground"]
at = [0.0, [1.2, 0.0]]
[initial]
guess = {{ crank = -1.2, coupler = 0.2, rocker = -1.5 }}
[effects]
gravity = [0.0, -{G}]
[outputs]
crank = {{ kind = "angle", body = "crank" }}
[simulation]
t_end = 1.0
output_step = 0.5
"""


def rigid_four_bar_rest(lengths: tuple[float, float, float], ground: float, g: float) -> tuple[float, float]:
    """(crank angle, circular frequency) of a rigid four-bar of uniform bars (mass = length)
    hanging under gravity: crank pinned at the origin, rocker at (ground, 0), the coupler's far
    end B on the lower branch of the two circles."""
    from scipy.optimize import brentq

    l1, l2, l3 = lengths
    C = np.array([ground, 0.0])

    def points(phi: float) -> tuple[np.ndarray, np.ndarray]:
        A = l1 * np.array([math.cos(phi), math.sin(phi)])
        d = C - A
        dist = float(np.hypot(*d))
        a = (l2**2 - l3**2 + dist**2) / (2 * dist)
        B = A + a * d / dist - math.sqrt(l2**2 - a**2) * np.array([-d[1], d[0]]) / dist
        return A, B

    def centroids(phi: float) -> np.ndarray:
        A, B = points(phi)
        return np.concatenate([A / 2, (A + B) / 2, (C + B) / 2])

    def angles(phi: float) -> np.ndarray:
        A, B = points(phi)
        return np.array([phi, math.atan2(*(B - A)[::-1]), math.atan2(*(B - C)[::-1])])

    m = np.array(lengths)

    def V(phi: float) -> float:
        return g * float(m @ centroids(phi)[1::2])

    h = 1e-5
    phi = brentq(lambda p: (V(p + h) - V(p - h)) / (2 * h), -1.6, -1.1)
    k = 1e-4
    Vpp = (V(phi + k) - 2 * V(phi) + V(phi - k)) / k**2
    dc = (centroids(phi + h) - centroids(phi - h)) / (2 * h)
    dth = (angles(phi + h) - angles(phi - h)) / (2 * h)
    M = float(m @ (dc[0::2] ** 2 + dc[1::2] ** 2) + (m * m**2 / 12) @ dth**2)
    return phi, math.sqrt(Vpp / M)


def test_a_hanging_four_bar_rests_at_its_potential_minimum(tmp_path):
    path = write_scene(tmp_path / "four_bar.toml", FOUR_BAR)
    res = modes(mechanism(path), shapes=False)
    phi, w = rigid_four_bar_rest((0.5, 1.0, 0.8), 1.2, G)
    assert res.equilibrium is not None and res.equilibrium["free"]["theta_crank"] == pytest.approx(phi, abs=1e-4)
    assert res.frequencies("rigid") == pytest.approx([w], rel=5e-3)
    assert res.stable and len(res.frequencies("transverse", "coupler")) == 3
