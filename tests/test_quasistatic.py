"""Quasi-static response (18)-(20) (``symgen quasistatic``).

Oracles:

* the damped dynamic response: with Kelvin-Voigt damping the start transient dies out and what
  remains differs from the quasi-static response only by the bars' own inertia, a fraction
  ~(harmonic / first bending frequency)^2. The acceptance check (within 2 % of the peak over a
  cycle) is made where the quasi-static idealisation is meant to hold, the crank turning well
  below the first bending frequency: the seed's slider-crank at 1/sqrt(10) of its speed (lambda
  and mu times 10: first bending frequency 22 times the crank speed) and the four-bar at 1/6 of
  its 2196 rpm (coupler bending 42 times the crank speed). At the paper's own speed the rod's
  first bending frequency is only 7 times the crank speed (and lowered further by the axial
  compression, 80 % of the Euler load at times): there the damped steady state is ~9 % of the
  peak away from the quasi-static one, and that gap shrinks with the square of the speed;
* a second, independent Newton solver of the same quasi-static state (``Mechanism.quasi_static``,
  written for the quasi-static start of the dynamic runner);
* the closure (11): with the rigid kinematics substituted as they are (the paper's literal
  reading) the loop misses by the bars' deformation.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.cli import main
from symgen.model.derive import derive
from symgen.backends.latex.document import latex_document
from symgen.numerics import start
from symgen.numerics.quasistatic import FP_MAXIT, RES_TOL, RHO_MAX, QuasiStaticSystem, quasi_static
from symgen.numerics.simulate import simulate
from symgen.scene import load_scene
from tests.oracles import write_scene

SC = "examples/slider_crank.toml"
FB = "examples/four_bar.toml"
# the rod's axial dynamics kept (effects.axial = true): "auto" would make it quasi-static, whose
# axial force is a multiplier and needs no Newton on the geometric coupling
ACCURATE = [
    "effects.axial=true",
    "effects.strain=von_karman",
    "bodies.rod.axial_shapes=complete",
    "bodies.rod.axial_modes=3",
    "bodies.rod.transverse_modes=4",
]


def _steady_gap(scene: str, overrides: list, damping: float, cycles: int) -> dict:
    """max |dynamic - quasi-static| / peak(quasi-static) over the last turn of a damped run
    started on the quasi-static state, per output."""
    mech = mechanism(
        scene,
        [*overrides, f"effects.damping={damping}", f"simulation.cycles={cycles}", "initial.deformation=quasi-static"],
    )
    dyn = simulate(mech)
    qs = quasi_static(mech)
    last = dyn.tau >= dyn.tau[-1] - 2 * math.pi - 1e-9
    out = {}
    for name in dyn.output_names:
        if name == "closure":
            continue
        ref = np.interp(np.mod(dyn.tau[last], 2 * math.pi), qs.tau, qs.column(name))
        out[name] = float(np.abs(dyn.column(name)[last] - ref).max() / np.abs(qs.column(name)).max())
    return out


@pytest.mark.parametrize(
    "scene,overrides,damping,cycles",
    [
        (SC, ["bodies.rod.lambda=182460", "bodies.rod.mu=4.95"], 0.005, 6),  # crank at 1/sqrt(10) of 6.1's speed
        (FB, ["scene.omega=38.333333333333336"], 0.003, 4),  # 366 rpm instead of 2196
    ],
    ids=["slider_crank", "four_bar"],
)
def test_quasi_static_is_the_damped_steady_state(scene, overrides, damping, cycles):
    gaps = _steady_gap(scene, overrides, damping, cycles)
    assert max(gaps.values()) < 0.02, gaps


def test_at_the_papers_speed_the_gap_is_the_bars_inertia():
    """Same slider-crank, damped, at the paper's speed and at 1/sqrt(10) of it: the quasi-static
    response misses the dynamic one by several per cent at full speed, and ten times less
    speed squared makes the gap several times smaller (inertia ~ speed^2; the damping lag
    c * omega does not scale the same way, hence 'several', not 10)."""
    fast = _steady_gap(SC, [], 0.005, 8)["eta_mid"]
    slow = _steady_gap(SC, ["bodies.rod.lambda=182460", "bodies.rod.mu=4.95"], 0.005, 6)["eta_mid"]
    assert 0.04 < fast < 0.2
    assert fast / slow > 4


def test_fixed_point_of_20_is_the_newton_quasi_static_state():
    """(20) by fixed-point iteration = the quasi-static start's own Newton solve (another code
    path), to round-off; and the split A y = B + f(y) is what it says: f(0) = 0 and f is of
    second order (halving y quarters f)."""
    mech = mechanism(SC)
    res = quasi_static(mech, output_step=2 * math.pi / 24)
    _, _, _, _, part = mech.initial_state()
    for t, q, v in zip(res.tau, res.q, res.v):
        qq, vv, _ = start.quasi_static(mech, t, q, v, part)
        assert np.abs(qq - q).max() < 1e-10 and np.abs(vv - v).max() < 1e-10
    assert all(r.method == "fixed-point" for r in res.reports)
    assert max(r.residual for r in res.reports) < 1e-11
    sysq = QuasiStaticSystem(mech, part)
    t = 1.0
    qr, vr, ar = sysq.rigid_state(t, res.q[0])
    y, _ = sysq.solve(t, qr, vr, ar)
    A, B = sysq.linear_system(t, qr, vr, ar)
    assert np.abs(sysq.nonlinear_rest(t, qr, vr, ar, 0 * y, A, B)).max() == 0.0
    f1 = np.abs(sysq.nonlinear_rest(t, qr, vr, ar, y, A, B)).max()
    f2 = np.abs(sysq.nonlinear_rest(t, qr, vr, ar, y / 2, A, B)).max()
    assert f1 > 0 and f2 / f1 == pytest.approx(0.25, rel=0.02)
    assert np.abs(A @ y - B - sysq.nonlinear_rest(t, qr, vr, ar, y, A, B)).max() < 1e-11


def test_newton_takes_over_where_the_iteration_does_not_contract():
    """The accurate model's rod is loaded to ~80 % of its Euler load at times: the geometric
    coupling in f(y) is then nearly as strong as the bending stiffness in A and the fixed-point
    iteration contracts too slowly; Newton finishes those positions, reported per position."""
    mech = mechanism(SC, ACCURATE)
    res = quasi_static(mech, output_step=2 * math.pi / 72)
    info = res.solver_info()
    newton = [r for r in res.reports if r.method == "newton"]
    assert info["newton_used"] and 0 < info["newton_positions"] == len(newton) < len(res.reports)
    for r in newton:
        assert (r.contraction is not None and r.contraction > RHO_MAX) or r.iterations >= FP_MAXIT
        assert r.reason
    assert info["residual_max"] < 1e-9
    # the positions Newton solved agree with the independent Newton of the quasi-static start
    _, _, _, _, part = mech.initial_state()
    for r in newton[:5]:
        k = int(np.argmin(np.abs(res.tau - r.tau)))
        qq, _, _ = start.quasi_static(mech, res.tau[k], res.q[k], res.v[k], part)
        assert np.abs(qq - res.q[k]).max() < 1e-10


def test_rigid_kinematics_leave_the_loop_open_by_the_deformation():
    mech = mechanism(SC)
    step = 2 * math.pi / 36
    deformed = quasi_static(mech, output_step=step)
    rigid = quasi_static(mech, output_step=step, kinematics="rigid")
    eps = np.abs(deformed.column("eps_ax")).max()
    assert deformed.closure_max < 1e-13
    assert 0.05 * eps < rigid.closure_max < 2 * eps  # the rod's elongation is missing
    peak = np.abs(deformed.column("eta_mid")).max()
    assert np.abs(rigid.column("eta_mid") - deformed.column("eta_mid")).max() < 1e-3 * peak


def test_cli_quasistatic_writes_the_simulate_contract(tmp_path):
    out = tmp_path / "qs.csv"
    assert (
        main(
            [
                "quasistatic",
                SC,
                "-o",
                str(out),
                "--set",
                "simulation.output_step=0.05235987755982988",
                *[x for o in ACCURATE for x in ("--set", o)],
                "--plot",
                str(tmp_path / "qs.png"),
            ]
        )
        == 0
    )
    lines = out.read_text().splitlines()
    assert lines[0] == "tau,eta_mid,eps_ax,torque,closure"
    assert len(lines) == 1 + 121  # one turn in steps of 3 degrees, both ends
    meta = json.loads(out.with_suffix(".json").read_text())
    for key in ("scene_hash", "groups", "effects", "modes", "solver", "timings", "closure_residual_max"):
        assert key in meta
    assert {"derive_s", "build_s", "simulate_s"} <= set(meta["timings"])
    sol = meta["solver"]
    assert sol["newton_used"] is True and sol["newton_positions"] > 0
    assert len(sol["per_position"]) == 121
    assert all(p["residual"] <= RES_TOL * 1e3 for p in sol["per_position"])
    assert {p["method"] for p in sol["per_position"]} == {"fixed-point", "newton"}
    assert meta["closure_residual_max"] < 1e-13
    assert (tmp_path / "qs.png").stat().st_size > 10_000


TORQUE = """
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
[outputs]
tip = { kind = "deflection", body = "crank", at = 1.0 }
[simulation]
t_end = 1.0
output_step = 0.1
"""


def test_a_torque_driven_mechanism_gets_its_static_equilibrium(tmp_path, capsys):
    """A torque-driven crank has no quasi-static response (18)-(20) (its motion is not
    prescribed): quasistatic gives its static equilibrium at each position instead, and refuses
    (exit 2, no file) where there is none, naming the unbalanced coordinate."""
    path = write_scene(tmp_path / "free.toml", TORQUE)
    out = tmp_path / "free.csv"
    assert main(["quasistatic", str(path), "-o", str(out)]) == 0  # no torque, no gravity: at rest anywhere
    assert "static equilibrium" in capsys.readouterr().out
    assert json.loads(out.with_suffix(".json").read_text())["solver"]["kinematics"] == "equilibrium"
    out.unlink()
    assert main(["quasistatic", str(path), "-o", str(out), "--set", "driver.value=1.0"]) == 2
    err = capsys.readouterr().err
    assert "no static equilibrium" in err and "theta_crank" in err and "driver torque" in err
    assert not out.exists()


def test_latex_shows_18_19_20():
    scene = load_scene(SC)
    doc = latex_document(scene, derive(scene))
    tags = set(re.findall(r"\\tag\{([^}]*)\}", doc))
    assert {"10*.x, rod", "10*.y, rod", "18.1, rod", "19.1, rod", "20"} <= tags
    section = doc[doc.index(r"\section{Quasi-static response (18)--(20)}") :]
    assert r"\Bigr]_{f}" in section  # the nonlinear rest f(y) of (19)
    for rate in (r"\dot f_{", r"\ddot f_{", r"\dot g_{", r"\ddot g_{"):
        assert rate not in section  # deformation rates and accelerations are zero
