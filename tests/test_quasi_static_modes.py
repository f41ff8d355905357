"""Quasi-static (residual-flexibility) transverse functions: ``bodies.<name>.quasi_static_transverse``
(issue 19 item 1, issue 20 item 2; docs/quasi-static-modes.md).

Scene (written here, dimensionless): one cantilever bar, length 1, mass per length 1, pinned to
ground and turned by an angle driver at rate 1 from theta = 0, under gravity (0, -g), started on
its quasi-static deformation, undamped. In the bar's frame gravity is a slow harmonic load: the
transverse component -g cos(theta) per unit length at frequency 1, far below the bending modes
(the k-th at beta_k^2 sqrt(mu), beta_1^2 = 3.5160, beta_2^2 = 22.0345).

Oracles:
* the Euler-Bernoulli closed form of a uniformly loaded cantilever: tip deflection q l^4 / (8 EI),
  i.e. eta(1) = -g cos(theta) / (8 mu) (mu = 1e4: the rotation's centrifugal stiffening and the
  dynamic amplification are O(1/mu) and O(1e-5), the stretch O(1/lambda); measured 7.7e-5 of peak
  at lambda = 1e6 and 1e10, 1.46e-3 at 1e3, for both treatments; they differ by 2e-8 to 2.4e-7);
* the amplification of a mode forced at a frequency ratio r = 1 / (beta_2^2 sqrt(mu)): its
  dynamic amplitude differs from its static one by about r^2 of it, and the dynamic run's start
  (matched to the static state) rings it with the same amplitude, so the highest function's
  amplitude of the dynamic and the quasi-static treatments differ by about 2 r^2 of its peak:
  measured 1.85 r^2 at mu = 1, 1.89 at mu = 4, 1.80 at mu = 16;
* IDAS's steps: the quasi-static functions add no eigenvalues for BDF to follow (fewer steps).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.cli import main
from symgen.errors import SceneError
from symgen.numerics.simulate import simulate

BETA2_SQ = 22.034491  # second clamped-free eigenvalue beta_2^2 (beta_2 l = 4.694091)


def _arm(path, *, lam, mu, g, nt, qs, t_end, rtol, name="arm"):
    text = f"""
[scene]
name = "turning_arm"
units = "dimensionless"

[[bodies]]
name = "arm"
length = 1.0
mass_per_length = 1.0
lambda = {float(lam)!r}
mu = {float(mu)!r}
frame = "cantilever"
axial_modes = 1
transverse_modes = {nt}
quasi_static_transverse = {qs}

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]

[driver]
kind = "angle"
body = "arm"
initial = 0.0
rate = 1.0

[initial]
deformation = "quasi-static"

[effects]
gravity = [0.0, {-float(g)!r}]

[outputs]
tip = {{ kind = "deflection", body = "arm", at = 1.0 }}
angle = {{ kind = "angle", body = "arm" }}

[simulation]
t_end = {float(t_end)!r}
output_step = 0.05
rtol = {float(rtol)!r}
atol = 1e-12
"""
    file = path / f"{name}_{nt}_{qs}.toml"
    file.write_text(text)
    return str(file)


def _run(file):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the bases' warnings: not what is tested here
        mech = mechanism(file)
    return mech, simulate(mech)


@pytest.mark.parametrize("lam", [1e3, 1e6, 1e10])
def test_static_shape_is_the_closed_form_and_costs_fewer_steps(tmp_path, lam):
    """4 transverse functions, the highest 2 quasi-static, against the closed form and against
    the same model with every function dynamic."""
    mu, g = 1e4, 10.0
    kw = dict(lam=lam, mu=mu, g=g, nt=4, t_end=3.2, rtol=1e-8)
    _, dyn = _run(_arm(tmp_path, qs=0, **kw))
    mech, qs = _run(_arm(tmp_path, qs=2, **kw))
    assert [mech.coords[i].name for i in mech.quasi] == ["g_arm_3", "g_arm_4"]
    exact = -g * np.cos(qs.column("angle")) / (8 * mu)
    peak = np.abs(exact).max()
    # the bar's stretch under the centrifugal tension adds O(1/lambda): measured 1.46e-3 at
    # lambda = 1e3, 7.7e-5 at 1e6 and 7.8e-5 at 1e10 (inextensible), both treatments alike
    tol = 1.5e-4 + 2.0 / lam
    assert np.abs(qs.column("tip") - exact).max() / peak < tol
    assert np.abs(dyn.column("tip") - exact).max() / peak < tol
    # the same static shape: the difference is integration error and r^2 ~ 1e-6 of the functions
    assert np.abs(qs.column("tip") - dyn.column("tip")).max() / peak < 2e-5
    # rates of quasi-static amplitudes read 0; their values follow the load
    assert np.all(qs.v[:, list(mech.quasi)] == 0.0)
    assert np.abs(qs.q[:, mech.quasi[0]]).max() > 0.0
    assert qs.steps < dyn.steps


@pytest.mark.parametrize("mu", [1.0, 4.0])
def test_highest_amplitude_differs_by_twice_its_amplification(tmp_path, mu):
    """2 transverse functions, the second quasi-static: its amplitude differs from the dynamic
    one by its amplification, r^2 of its peak (r = 1 / (beta_2^2 sqrt(mu)), the forcing at
    frequency 1: the forced response is the static one over 1 - r^2). Measured 0.999 / 1.043 r^2
    at mu 1 / 4 from the quasi-static start that holds its deformation's rates and accelerations
    (docs/exact-bars.md); 1.85 / 1.89 r^2 from the start with both zero, whose ringing the dynamic
    run added."""
    kw = dict(lam=1e4, mu=mu, g=1e-3, nt=2, t_end=6.3, rtol=1e-9)
    mech, dyn = _run(_arm(tmp_path, qs=0, **kw))
    _, qs = _run(_arm(tmp_path, qs=1, **kw))
    i = [c.name for c in mech.coords].index("g_arm_2")
    rel = np.abs(qs.q[:, i] - dyn.q[:, i]).max() / np.abs(dyn.q[:, i]).max()
    r2 = 1.0 / (BETA2_SQ**2 * mu)
    assert 0.9 * r2 < rel < 1.3 * r2


def test_count_beyond_the_functions_is_refused_with_exit_2(tmp_path, capsys):
    file = tmp_path / "bad.toml"
    text = open(_arm(tmp_path, lam=1e4, mu=1.0, g=1e-3, nt=2, qs=1, t_end=0.1, rtol=1e-6)).read()
    file.write_text(text.replace("quasi_static_transverse = 1", "quasi_static_transverse = 3"))
    assert main(["simulate", str(file), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "bodies.arm.quasi_static_transverse" in err and "transverse_modes" in err


def test_c_solver_runs_them_as_idas_does(tmp_path):
    """``--solver c`` treats the stated functions quasi-statically too (exit 0; the C path's own
    tests: tests/test_c_quasi.py): its CSV's tip deflection is IDAS's run of the same partition
    (two integrators of one DAE at rtol 1e-8)."""
    import csv

    file = _arm(tmp_path, lam=1e4, mu=1.0, g=1e-3, nt=2, qs=1, t_end=0.5, rtol=1e-8)
    out = tmp_path / "o.csv"
    assert main(["simulate", file, "--solver", "c", "--estimate", "off", "-o", str(out)]) == 0
    tip = np.array([float(r["tip"]) for r in csv.DictReader(out.open())])
    _, idas = _run(file)
    assert tip.shape == idas.column("tip").shape
    assert np.abs(tip - idas.column("tip")).max() < 1e-5 * np.abs(idas.column("tip")).max()


def test_a_function_that_moves_an_interior_pin_is_refused():
    """examples/six_bar.toml: the coupler's pin D at xi = 0.5; sin(3 pi xi) moves it (sin(4 pi xi)
    does not)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mech = mechanism("examples/six_bar.toml", ["bodies.coupler.quasi_static_transverse=1"])
        assert [mech.coords[i].name for i in mech.quasi] == ["g_coupler_4"]
        with pytest.raises(SceneError, match="g_coupler_3 moves a joint"):
            mechanism("examples/six_bar.toml", ["bodies.coupler.quasi_static_transverse=2"])


def test_steel_slider_crank_within_the_amplification_of_its_second_mode():
    """benchmarks/scenes/slider_crank_steel.toml (a loop, the rod's axial amplitudes constrained
    by its inextensibility rows), 1 turn from the quasi-static start, 4 transverse functions:
    the top 3 quasi-static against all 4 dynamic. The rod's second bending mode (235.8 per tau,
    BasisChoice.omega_bending) against the run's content up to 4 per tau (the driver's 4th
    harmonic): r^2 = (4 / 235.8)^2 = 2.9e-4 bounds the difference (measured 9.7e-5 of peak);
    IDAS takes 3x fewer steps (measured 2698 -> 788)."""
    base = [
        "simulation.cycles=1",
        "bodies.rod.axial_modes=3",
        "bodies.rod.transverse_modes=4",
        "initial.deformation=quasi-static",
    ]
    _, dyn = _run_file("benchmarks/scenes/slider_crank_steel.toml", base)
    mech, qs = _run_file("benchmarks/scenes/slider_crank_steel.toml", base + ["bodies.rod.quasi_static_transverse=3"])
    assert [mech.coords[i].name for i in mech.quasi] == ["g_rod_2", "g_rod_3", "g_rod_4"]
    y, ref = qs.column("rod_mid"), dyn.column("rod_mid")
    assert np.abs(y - ref).max() / np.abs(ref).max() < (4 / 235.8) ** 2
    assert 2 * qs.steps < dyn.steps


def _run_file(path, overrides):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mech = mechanism(path, overrides)
    return mech, simulate(mech)


def test_steel_slider_crank_from_rest_against_its_converged_reference():
    """benchmarks/validation/slider_crank_steel_rest.toml (the counts symgen chooses: rod 3 + 3,
    one bending mode in its dynamic band) with its top two transverse functions quasi-static,
    against the committed converged Exudyn ANCF reference: measured 3.3e-4 of peak (every
    function dynamic: 3.9e-4) in 1625 IDAS steps (every function dynamic: 9973)."""
    import sys
    from pathlib import Path

    from symgen.numerics.units import result_units

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
    import bench_validation as V

    t_ref, ref = V.read_reference("slider_crank_steel_rest")
    mech, res = _run_file(str(V.scene_path("slider_crank_steel_rest")), ["bodies.rod.quasi_static_transverse=2"])
    assert [mech.coords[i].name for i in mech.quasi] == ["g_rod_2", "g_rod_3"]
    t, vals = result_units(mech.scene).convert(res.tau, res.outputs)
    y = np.interp(t_ref, t, vals[:, res.output_names.index("rod_mid")])
    r = ref["rod_mid"]
    assert np.abs(y - r).max() / np.abs(r).max() < 1e-3
    assert res.steps < 3000
