"""Driver rotor inertia and lumped rotary inertia at joints (issue 12, Deliver 3).

Oracles, independent of the derivation:

* a rigid bar (alpha = 1, nu = 1) pinned to ground, driven by a constant torque T with a rotor
  J: (I + J) theta'' = T, I = nu alpha^3 / 3, so theta = T tau^2 / (2 (I + J)) exactly (no gravity);
  under gravity g (ground -y) (I + J) theta'' = T - nu alpha g (alpha / 2) cos(theta), integrated
  here with scipy's DOP853 at 1e-12;
* the same rotor given as a lumped rotary inertia at the pivot (joint ``inertia``): the same
  numbers (two routes);
* an elastic double pendulum with a rotor, a lumped inertia at the elastic bar's tip (where it
  turns with theta + eta'(1)), gravity and a constant torque: kinetic + elastic + potential
  energy minus the torque's work T (theta - theta0) is constant to the solver's tolerance;
* an elastic pendulum with a rotor, stiff (mu = 1e7): the rigid closed form;
* SI and dimensionless scenes give the same dimensionless parameters (J / (m_ref l0^3)).
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from symgen.api import mechanism, simulate_scene
from symgen.errors import SceneError
from symgen.scene import load_scene

T, J = 0.5, 0.2
I_BAR = 1.0 / 3.0

HEAD = """[scene]
name = "{name}"
reference_length = 1.0
omega = 1.0
units = "dimensionless"
"""
RIGID = """
[[bodies]]
name = "crank"
length = 1.0
rigid = true
"""
ELASTIC = """
[[bodies]]
name = "crank"
length = 1.0
lambda = {lam}
mu = {mu}
frame = "cantilever"
axial_modes = 1
transverse_modes = 2
"""
PIVOT = """
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
inertia = {pivot}
"""
DRIVER = """
[driver]
kind = "torque"
body = "crank"
value = {torque}
initial = 0.0
rotor_inertia = {rotor}
"""
TAIL = """
[effects]
gravity = [0.0, {g}]

[outputs]
theta = {{ kind = "angle", body = "crank" }}
energy = {{ kind = "energy" }}

[simulation]
t_end = {t_end}
output_step = {step}
rtol = 1e-10
atol = 1e-12
"""


def _scene(
    tmp_path,
    name="rotor_pendulum",
    bar=RIGID,
    extra="",
    *,
    pivot=0.0,
    rotor=J,
    torque=T,
    g=0.0,
    t_end=2.0,
    step=0.25,
    lam=1e3,
    mu=2.0,
):
    text = (
        HEAD.format(name=name)
        + bar.format(lam=lam, mu=mu)
        + PIVOT.format(pivot=pivot)
        + extra
        + DRIVER.format(torque=torque, rotor=rotor)
        + TAIL.format(g=g, t_end=t_end, step=step)
    )
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def test_rigid_rotor_under_constant_torque_is_the_closed_form(tmp_path):
    res = simulate_scene(_scene(tmp_path))
    exact = T * res.tau**2 / (2 * (I_BAR + J))
    assert np.abs(res.column("theta") - exact).max() < 1e-6 * exact.max()
    # no gravity, no elasticity: the energy is the torque's work
    assert np.abs(res.column("energy") - T * res.column("theta")).max() < 1e-6 * (T * exact.max())
    # the rotor counts: without it the bar turns faster, by (I + J) / I
    bare = simulate_scene(_scene(tmp_path, "bare", rotor=0.0))
    assert bare.column("theta")[-1] == pytest.approx(exact[-1] * (I_BAR + J) / I_BAR, rel=1e-6)


def _rigid_gravity_reference(tau, g, inertia):
    def rhs(_, y):
        return [y[1], (T - 0.5 * g * math.cos(y[0])) / inertia]

    sol = solve_ivp(rhs, (0.0, tau[-1]), [0.0, 0.0], method="DOP853", t_eval=tau, rtol=1e-12, atol=1e-14)
    return sol.y[0]


@pytest.mark.parametrize("route", ["rotor", "pivot"])
def test_rigid_rotor_under_gravity_matches_the_rigid_ode(tmp_path, route):
    """Both routes, the driver's rotor and a lumped inertia at the pivot, give the ODE's theta."""
    g = 1.5  # T - g/2 < 0 at theta = 0: it first swings back
    kw = {"rotor": J} if route == "rotor" else {"rotor": 0.0, "pivot": J}
    res = simulate_scene(_scene(tmp_path, f"grav_{route}", g=-g, t_end=6.0, step=0.5, **kw))
    ref = _rigid_gravity_reference(res.tau, g, I_BAR + J)
    theta = res.column("theta")
    assert np.abs(theta - ref).max() < 1e-6 * np.abs(ref).max()
    assert theta.min() < -0.05  # the swing back happened
    # energy: (I + J) theta'^2 / 2 + g sin(theta) / 2 - T theta = 0 along the motion
    assert np.abs(res.column("energy") - T * theta).max() < 1e-6


def test_elastic_double_pendulum_conserves_energy_with_rotary_inertias(tmp_path):
    """A tip inertia on an elastic cantilever turns with theta + eta'(1); a rigid link hangs there."""
    extra = """
[[bodies]]
name = "link"
length = 0.6
rigid = true

[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "link"]
at = [1.0, 0.0]
mass = 0.3
inertia = 0.05
"""
    path = _scene(tmp_path, "elastic_double", ELASTIC, extra, rotor=J, g=-0.5, t_end=8.0, step=0.05, lam=2e3, mu=3.0)
    res = simulate_scene(path)
    theta = res.column("theta")
    energy = res.column("energy") - T * theta
    scale = np.abs(res.column("energy")).max()
    assert np.abs(theta).max() > 1.0  # a real motion
    assert np.abs(energy - energy[0]).max() < 1e-6 * scale
    # the rotary inertias are in the derived model
    mech = mechanism(path)
    assert {"I_A", "J_rotor"} <= set(map(str, mech.info.params))


def test_stiff_elastic_pendulum_with_rotor_approaches_the_rigid_closed_form(tmp_path):
    """The elastic lag of the tip behind the rigid closed form falls like 1 / mu."""
    errors = []
    for mu in (1e4, 1e5):
        res = simulate_scene(_scene(tmp_path, f"stiff{int(mu)}", ELASTIC, lam=10 * mu, mu=mu, t_end=2.0, step=0.25))
        exact = T * res.tau**2 / (2 * (I_BAR + J))
        errors.append(np.abs(res.column("theta") - exact).max() / exact.max())
    assert errors[0] < 1e-5 and errors[1] < 1e-6
    assert errors[1] < errors[0] / 5


def test_si_and_dimensionless_give_the_same_groups(tmp_path):
    l0, m_ref, omega = 0.4, 2.5, 30.0
    si = f"""[scene]
name = "si_rotor"
reference_length = {l0}
omega = {omega}
units = "SI"

[[bodies]]
name = "crank"
length = {l0}
rigid = true
mass_per_length = {m_ref}

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
inertia = {0.03 * m_ref * l0**3}

[driver]
kind = "torque"
body = "crank"
value = {T * m_ref * l0**3 * omega**2}
rotor_inertia = {J * m_ref * l0**3}

[outputs]
theta = {{ kind = "angle", body = "crank" }}

[simulation]
t_end = 1.0
output_step = 0.5
"""
    (tmp_path / "si.toml").write_text(si)
    dimless = _scene(tmp_path, "dimless", pivot=0.03)
    a, b = mechanism(tmp_path / "si.toml"), mechanism(dimless)
    assert a.scene.driver.rotor_inertia == pytest.approx(J, rel=1e-12)
    assert a.scene.joint("O").inertia == pytest.approx(0.03, rel=1e-12)
    pa = dict(zip(map(str, a.info.params), a.p))
    pb = dict(zip(map(str, b.info.params), b.p))
    for key in ("J_rotor", "I_O", "torque", "alpha_crank", "nu_crank"):
        assert pa[key] == pytest.approx(pb[key], rel=1e-12), key


@pytest.mark.parametrize(
    "where, key, value",
    [
        ("driver", "rotor_inertia", "-0.1"),
        ("driver", "rotor_inertia", "inf"),
        ("driver", "rotor_inertia", '"0.1"'),
        ("driver", "hub_inertia", "0.1"),
        ("joint", "inertia", "-1.0"),
        ("joint", "inertia", "nan"),
    ],
)
def test_bad_rotary_inertia_is_a_scene_error(tmp_path, where, key, value):
    path = _scene(tmp_path)
    text = path.read_text()
    if where == "driver":
        text = text.replace(f"rotor_inertia = {J}", f"{key} = {value}")
        dotted = f"driver.{key}"
    else:
        text = text.replace("inertia = 0.0", f"{key} = {value}")
        dotted = f"joints.O.{key}"
    path.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert str(path) in str(err.value) or path.name in str(err.value)
    assert dotted in str(err.value)


def test_bad_rotor_inertia_exits_2_from_the_cli(tmp_path):
    path = _scene(tmp_path)
    path.write_text(path.read_text().replace(f"rotor_inertia = {J}", "rotor_inertia = -2.0"))
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "symgen.cli", "derive", str(path), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert "driver.rotor_inertia" in proc.stderr
    assert not out.exists() or not any(out.iterdir())


def test_zero_inertias_are_allowed_and_change_nothing(tmp_path):
    res = simulate_scene(_scene(tmp_path, "zero", rotor=0.0, pivot=0.0))
    exact = T * res.tau**2 / (2 * I_BAR)
    assert np.abs(res.column("theta") - exact).max() < 1e-6 * exact.max()


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_emitted_c_with_rotary_inertias_matches_python(tmp_path):
    from symgen.model.derive import derive
    from symgen.backends.c import c_context, write_tree
    from symgen.backends.c.build import compile_executable
    from symgen.backends.c.render import render_files
    from symgen.numerics.start import start_plan

    path = _scene(tmp_path, "c_rotor", g=-0.8, pivot=0.1, t_end=4.0, step=0.5)
    mech = mechanism(path)
    src = write_tree(
        render_files(c_context(mech.scene, derive(mech.scene), start_plan(mech), mech.info)), tmp_path / "c"
    )
    exe = compile_executable(
        [src / "c_rotor.c", src / "c_rotor_jac.c", src / "c_rotor_solver.c", src / "c_rotor_sim.c"],
        tmp_path / "c_rotor_sim",
        include=[src],
    )
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    header = proc.stdout.splitlines()[0].split(",")
    data = np.loadtxt(proc.stdout.splitlines()[1:], delimiter=",", ndmin=2)
    theta_c = data[:, header.index("theta")]
    tau_c = data[:, 0]
    ref = _rigid_gravity_reference(tau_c, 0.8, I_BAR + J + 0.1)
    assert np.abs(theta_c - ref).max() < 1e-5 * np.abs(ref).max()


def test_latex_shows_the_rotary_inertias_and_compiles(tmp_path):
    from symgen.model.derive import derive
    from symgen.backends.latex.document import latex_document

    path = _scene(
        tmp_path,
        "tex_rotor",
        ELASTIC,
        """
[[bodies]]
name = "link"
length = 0.6
rigid = true

[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "link"]
at = [1.0, 0.0]
inertia = 0.05
""",
    )
    scene = load_scene(path)
    tex = latex_document(scene, derive(scene))
    assert r"J_{\mathrm{rot}} \ddot \theta_{\mathrm{crank}}" in tex  # in the crank's residual
    assert r"\varphi_{\mathrm{A}} = \theta_{\mathrm{crank}} + \eta_{\mathrm{crank}}'(1)" in tex
    eth = next(line for line in tex.splitlines() if line.startswith(r"E_{\theta,\mathrm{crank}} &="))
    assert r"I_{\mathrm{A}}" in eth
    if shutil.which("pdflatex"):
        (tmp_path / "doc.tex").write_text(tex)
        run = subprocess.run(
            ["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "doc.tex"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0, run.stdout[-2000:]


def _pinned_beam_with_end_inertias(b, inertia):
    """Frequency determinant of a pinned-pinned Euler-Bernoulli beam (EI = m = l = 1) carrying a
    rotary inertia ``inertia`` at each end: w(0) = w(1) = 0, w''(0) = -J w^2 w'(0),
    w''(1) = J w^2 w'(1), w^2 = b^4; w = A sin bx + B cos bx + C sinh bx + D cosh bx."""
    s, c, sh, ch = np.sin(b), np.cos(b), np.sinh(b), np.cosh(b)
    k = inertia * b**4
    rows = [
        [0, 1, 0, 1],
        [s, c, sh, ch],
        [k * b, -b * b, k * b, b * b],
        [-b * b * s - k * b * c, -b * b * c + k * b * s, b * b * sh - k * b * ch, b * b * ch - k * b * sh],
    ]
    return np.linalg.det(np.array(rows)) / ch**2


def test_end_rotary_inertias_lower_the_pinned_beams_frequencies_as_the_closed_form(tmp_path):
    """A bar pinned at 0 and on a roller at 1, a rotary inertia J at both joints: the inertias
    turn with the end slopes eta'(0), eta'(1) only (theta is held), so the frequencies follow the
    beam's frequency equation; J = 0 would give pi^2 n^2."""
    from scipy.optimize import brentq

    from symgen.numerics.modes import modes

    inertia, mu = 0.01, 1.0
    path = tmp_path / "pinned_rotary.toml"
    path.write_text(
        HEAD.format(name="pinned_rotary")
        + f"""
[[bodies]]
name = "beam"
length = 1.0
lambda = 1e4
mu = {mu}
frame = "pinned-pinned"
axial_modes = 1
transverse_modes = 6
transverse_shapes = "polynomial"

[[joints]]
name = "O"
kind = "pin"
bodies = ["beam", "ground"]
at = [0.0, [0.0, 0.0]]
inertia = {inertia}

[[joints]]
name = "T"
kind = "slider"
bodies = ["beam", "ground"]
at = [1.0, [1.0, 0.0]]
direction = [1.0, 0.0]
inertia = {inertia}

[outputs]
e = {{ kind = "energy" }}

[simulation]
t_end = 1.0
output_step = 0.5
"""
    )
    grid = np.linspace(0.5, 7.0, 2000)
    d = [_pinned_beam_with_end_inertias(b, inertia) for b in grid]
    roots = [
        brentq(_pinned_beam_with_end_inertias, grid[i], grid[i + 1], args=(inertia,))
        for i in range(len(grid) - 1)
        if d[i] * d[i + 1] < 0
    ]
    exact = np.array(roots[:3]) ** 2 * math.sqrt(mu)
    assert exact[0] < 0.9 * math.pi**2  # the inertias matter
    got = modes(mechanism(path), 0.0, shapes=False).frequencies("transverse", "beam")[:3]
    rel = got / exact - 1
    assert np.abs(rel[:2]).max() < 1e-6 and 0 <= rel[2] < 5e-4, (got, exact)  # Ritz: from above


def test_angle_driver_reports_the_motor_torque_rotor_included(tmp_path):
    """theta = 0.5 sin(tau) prescribed: the motor supplies (I + J) theta'' (no gravity)."""
    path = _scene(tmp_path, "angle_rotor")
    text = path.read_text().replace('kind = "torque"', 'kind = "angle"').replace(f"value = {T}\n", "")
    text = text.replace("initial = 0.0\nrotor_inertia", 'law = "0.5*sin(tau)"\nrotor_inertia')
    text = text.replace(
        'energy = { kind = "energy" }', 'energy = { kind = "energy" }\ntorque = { kind = "driver_torque" }'
    )
    path.write_text(text)
    res = simulate_scene(path)
    exact = -(I_BAR + J) * 0.5 * np.sin(res.tau)
    assert np.abs(res.column("torque") - exact).max() < 1e-8
    theta_d = 0.5 * np.cos(res.tau)
    assert np.abs(res.column("energy") - (I_BAR + J) * theta_d**2 / 2).max() < 1e-10


FOUR_BAR = (
    HEAD.format(name="{name}")
    + """
[[bodies]]
name = "crank"
length = 0.3
rigid = true

[[bodies]]
name = "coupler"
length = 1.0
rigid = true

[[bodies]]
name = "rocker"
length = 0.8
rigid = true

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
inertia = {pivot}

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
bodies = ["ground", "rocker"]
at = [[1.0, 0.0], 0.0]

[driver]
kind = "torque"
body = "crank"
value = 0.05
initial = 1.0
rotor_inertia = {rotor}

[initial]
guess = {{ coupler = 0.6, rocker = 1.9 }}

[outputs]
theta = {{ kind = "angle", body = "crank" }}
rocker = {{ kind = "angle", body = "rocker" }}
energy = {{ kind = "energy" }}

[simulation]
t_end = 8.0
output_step = 0.5
rtol = 1e-12
atol = 1e-14
"""
)


def test_four_bar_rotor_equals_the_same_inertia_lumped_at_the_crank_pivot(tmp_path):
    """A rigid four-bar spun up by a torque: the rotor J on the crank and J lumped at the crank's
    ground pivot are the same body, so the same motion; the torque's work goes into kinetic energy."""
    runs = {}
    for route, (rotor, pivot) in {"rotor": (0.05, 0.0), "pivot": (0.0, 0.05), "bare": (0.0, 0.0)}.items():
        path = tmp_path / f"fb_{route}.toml"
        path.write_text(FOUR_BAR.format(name=f"fb_{route}", rotor=rotor, pivot=pivot))
        runs[route] = simulate_scene(path)
    a, b, bare = runs["rotor"], runs["pivot"], runs["bare"]
    for col in ("theta", "rocker", "energy"):  # equal to the integration's error (rtol 1e-10)
        assert np.abs(a.column(col) - b.column(col)).max() < 1e-8 * np.abs(a.column(col)).max(), col
    theta = a.column("theta")
    assert theta[-1] - theta[0] > 1.0  # a real motion
    assert np.abs(a.column("energy") - a.column("energy")[0] - 0.05 * (theta - theta[0])).max() < 1e-7
    assert bare.column("theta")[-1] > theta[-1] + 0.05  # the inertia counts
