"""The error estimate's axial part (symgen.numerics.axial_drift): the stretch's inertia that a
quasi-static axial treatment leaves out, against the closed form of a spinning elastic arm and
against runs that keep the axial dynamics."""

from __future__ import annotations

import numpy as np
import pytest

from symgen.cli import _say_estimate
from symgen.numerics import axial_drift
from symgen.numerics.error_estimate import estimate_errors
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from tests.scenes import pinned_arm

#: a soft cantilever arm (lambda 3000, mu 1.2, tip mass 0.5), spun up from rest by a smooth torque
#: pulse to about 1.19 rad/tau, then spinning freely (the kept-out scene of issue 19)
ARM = pinned_arm(
    "soft_arm_pulse",
    "lambda = LAMBDA\nmu = 1.2",
    """
[driver]
kind = "torque"
body = "arm"
value = "0.8*exp(-((tau - 1.5)/0.7)^2)"
initial = 0.0
rate = 0.0

[effects]
damping = 0.01
strain = "von_karman"
axial = "quasi_static"

[outputs]
tip = { kind = "deflection", body = "arm", at = 1.0 }
theta = { kind = "angle", body = "arm" }
tip_x = { kind = "position", body = "arm", at = 1.0, component = "x" }

[simulation]
t_end = 10.0
output_step = 0.01
""",
    tip_mass="0.5",
)
LAMBDA, TIP_MASS = 3000.0, 0.5


def _arm(tmp_path, lam: float = LAMBDA, axial: str = "quasi_static"):
    path = tmp_path / f"arm_{lam:g}_{axial}.toml"
    path.write_text(ARM.replace("LAMBDA", repr(lam)).replace('axial = "quasi_static"', f'axial = "{axial}"'))
    mech = load_mechanism(str(path))
    return mech, simulate(mech)


def _closed_form_share(w: float, lam: float) -> float:
    """dJ / J of the spinning arm: its centrifugal stretch N / lambda raises the moment of
    inertia about the pin by dJ = (2 w^2 / lambda) (M^2 + 2M/3 + 2/15) (uniform arm of unit mass
    and length, tip mass M: u(x) = (w^2/lambda)((M + 1/2) x - x^3/6), dJ = 2 int x u + 2 M u(1)),
    J = 1/3 + M."""
    M = TIP_MASS
    return (2 * w**2 / lam) * (M**2 + 2 * M / 3 + 2 / 15) / (1 / 3 + M)


@pytest.fixture(scope="module")
def soft(tmp_path_factory):
    return _arm(tmp_path_factory.mktemp("soft"))


def test_the_stretch_inertia_is_the_spinning_arms_closed_form(soft):
    """At the end of the run (free spin, the pulse's vibration damped) dT / T of the stretch is
    the closed form's dJ / J (the arm's slight bending is all that J adds)."""
    mech, res = soft
    bars = axial_drift.quasi_static_bars(mech)
    assert set(bars) == {"arm"}
    th = mech.coords.index(next(c for c in mech.coords if c.body == "arm" and not c.elastic))
    last = slice(len(res.tau) - 1, len(res.tau))
    T, dT = axial_drift.stretch_inertia(mech, res.tau[last], res.q[last], res.v[last], res.lam[last], bars)
    w = float(res.v[-1, th])
    assert 1.1 < w < 1.3
    expected = _closed_form_share(w, LAMBDA)
    assert dT[0] / T[0] == pytest.approx(expected, rel=0.02)


def test_the_axial_part_is_the_difference_to_the_dynamic_axial_run(soft, tmp_path):
    """The part, through the error estimate, against the run that keeps the axial dynamics (whose
    stretch carries its inertia): within [0.5, 2] of the difference on the angle, the tip's
    position and the deflection (charged by its rate along the run: it moves during the spin-up,
    2.3e-4 of its peak off then, and stays steady in the free spin, where the lead grows but
    charges nothing: 4 % of tip_x's share)."""
    mech, res = soft
    _, dyn = _arm(tmp_path, axial="dynamic")
    est = estimate_errors(mech, res, 1e-8, 1e-10, truncation="linearized")
    assert est.methods["axial"].startswith("the phase drift of the free motion")
    assert 'effects.axial = "dynamic"' in est.methods["axial"]
    for name in ("theta", "tip_x", "tip"):
        a, b = res.column(name), dyn.column(name)
        true = float(np.max(np.abs(a - b)) / np.max(np.abs(b)))
        part = est.parts["axial"][name]
        assert part is not None and 0.5 <= part / true <= 2.0, f"{name}: part {part:.3g}, true {true:.3g}"
    assert est.parts["axial"]["tip"] < 0.05 * est.parts["axial"]["tip_x"]
    assert est.parts["axial"]["tip_x"] > 3e-3  # 0.6 % of peak: a charge the other parts did not see


def test_the_drift_charges_each_output_its_whole_rate_along_the_run(soft, monkeypatch):
    """Closed form of the charge: with the inertia's share dT/T held at s, the run is ahead by
    dt(t) = s t; a forced deflection y = A sin(w t), read from the elastic amplitudes alone, is
    off by |y(t) - y(t - dt)| ~ A w |cos(w t)| dt(t), largest at the run's end (w t a whole number
    of turns): charged w s t_end of its peak. A steady output is charged nothing, and an output
    whose first sample is the continuum's start force is differentiated from its second."""
    from dataclasses import replace

    mech, res = soft
    share = 1e-4
    monkeypatch.setattr(
        axial_drift, "stretch_inertia", lambda m, tau, *a: (np.ones(len(tau)), share * np.ones(len(tau)))
    )
    tau = np.asarray(res.tau, dtype=float)
    A, w = 0.03, 2 * np.pi  # ten periods over the run's 10 tau
    forced = A * np.sin(w * tau)
    steady = np.full_like(tau, 0.7)
    kicked = steady.copy()
    kicked[0] = 5.0  # the continuum's joint force at the start, not the model's
    fake = replace(res, outputs=np.column_stack([forced, steady, kicked]), start_forces=("tip_x",))
    part, how = axial_drift.drift(mech, fake)
    t_end = float(tau[-1])
    assert t_end == pytest.approx(10.0)
    # the rate from second-order differences on the output grid h: one-sided at the end, off by
    # (w h)^2 / 3 = 1.3e-3
    h = float(tau[1] - tau[0])
    assert part["tip"] == pytest.approx(w * share * t_end, rel=0.5 * (w * h) ** 2)
    shifted = A * np.sin(w * (tau - share * tau))
    assert part["tip"] == pytest.approx(float(np.max(np.abs(forced - shifted))) / A, rel=0.5 * (w * h) ** 2)
    assert part["theta"] < 1e-12  # round-off of the differences
    assert part["tip_x"] < 1e-12
    assert "each output's rate along the run" in how


def test_the_drift_charges_a_free_chains_deflections_as_the_dynamic_run_moves_them():
    """The aluminium double pendulum of the validation suite, released free, both bars
    quasi-static against the same scene with the axial dynamics kept: the drift within [0.5, 2] of
    the difference on the angles and on the tip deflections, which read only the elastic
    amplitudes (their rate along the free rigid coordinates is zero; their histories, forced by
    the free motion, shift with it: measured 1.4 x the difference)."""
    path = "benchmarks/validation/double_pendulum_alu.toml"
    quasi = load_mechanism(path, ["effects.axial=quasi_static"])
    dynamic = load_mechanism(path, ["effects.axial=dynamic"])
    res, dyn = simulate(quasi), simulate(dynamic)
    part, _ = axial_drift.drift(quasi, res)
    k = min(len(res.tau), len(dyn.tau))
    for name in ("upper_angle", "lower_angle", "upper_tip", "lower_tip"):
        a, b = res.column(name)[:k], dyn.column(name)[:k]
        true = float(np.max(np.abs(a - b)) / np.max(np.abs(b)))
        assert 0.5 <= part[name] / true <= 2.0, f"{name}: part {part[name]:.3g}, true {true:.3g}"


def test_the_axial_part_is_negligible_on_a_stiff_arm_and_zero_where_the_motion_is_driven(soft, tmp_path):
    """lambda x 100: the part falls as 1 / lambda, as the closed form does; a driven mechanism
    (every rigid coordinate prescribed) has no free motion to drift."""
    mech, res = soft
    stiff_mech, stiff_res = _arm(tmp_path, lam=100 * LAMBDA)
    soft_part, _ = axial_drift.estimate(mech, res)
    stiff_part, _ = axial_drift.estimate(stiff_mech, stiff_res)
    assert stiff_part["tip_x"] < 1e-4
    assert stiff_part["tip_x"] / soft_part["tip_x"] == pytest.approx(0.01, rel=0.05)
    steel = load_mechanism("benchmarks/validation/slider_crank_steel_rest.toml", ["simulation.duration=0.05"])
    assert "rod" in axial_drift.quasi_static_bars(steel)
    part, how = axial_drift.estimate(steel, simulate(steel))
    assert set(part.values()) == {0.0}
    assert "every rigid coordinate is driven" in how


def test_the_warning_names_the_axial_part_and_its_key(capsys):
    sidecar = {
        "error_estimate": {"tip_x": 0.055},
        "error_estimate_detail": {
            "parts": {
                "truncation": {"tip_x": 3e-5},
                "model_form": {"tip_x": 2e-4},
                "axial": {"tip_x": 0.054},
                "time_integration": {"tip_x": 6e-6},
            }
        },
        "accuracy": 0.01,
    }
    _say_estimate(sidecar, "arm.json", "arm.toml")
    err = capsys.readouterr().err
    assert "axial 5.4e-02" in err
    assert (
        'its largest part, the axial, is lowered by keeping the bars\' axial dynamics: effects.axial = "dynamic"' in err
    )


def test_auto_keeps_the_axial_dynamics_when_the_part_exceeds_the_accuracy(tmp_path, capsys, monkeypatch):
    """effects.axial = "auto" on the arm spinning 60 tau (about 11 turns): the quasi-static run's
    axial part (5 % of tip_x's peak) exceeds the accuracy, so the run is made again with the arm's
    axial dynamics kept: the result is the run of effects.axial = "dynamic", the sidecar says why,
    and the decision is remembered (a second run loads the decided model directly)."""
    import json

    from symgen.cli import main
    from symgen.numerics import axial_choice
    from symgen.numerics.strain_choice import resolved
    from symgen.scene.loader import load_scene

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))  # nothing decided yet
    path = tmp_path / "arm_long.toml"
    text = ARM.replace("LAMBDA", repr(LAMBDA)).replace("t_end = 10.0", "t_end = 60.0")
    path.write_text(text.replace('axial = "quasi_static"\n', ""))
    assert main(["simulate", str(path), "-o", str(tmp_path / "a.csv"), "--estimate", "linearized", "-v"]) == 0
    assert "arm: auto: the run's axial estimate" in capsys.readouterr().err
    side = json.loads((tmp_path / "a.json").read_text())
    why = side["axial_treatment"]["arm"]
    assert why["treatment"] == "dynamic" and "the run's axial estimate" in why["reason"]
    assert side["error_estimate_detail"]["parts"]["axial"]["tip_x"] == 0.0
    dyn = tmp_path / "dyn.toml"
    dyn.write_text(text.replace('axial = "quasi_static"', 'axial = "dynamic"'))
    ran = load_scene(path)
    assert resolved(ran).axial_kept and dict(resolved(ran).axial_kept)["arm"] == why["reason"]
    assert main(["simulate", str(dyn), "-o", str(tmp_path / "d.csv"), "--estimate", "off"]) == 0
    a = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    d = np.loadtxt(tmp_path / "d.csv", delimiter=",", skiprows=1)
    assert np.allclose(a, d, rtol=0, atol=1e-9 * np.abs(d).max())
    monkeypatch.setattr(axial_choice, "decide", lambda *a: pytest.fail("decided again"))
    capsys.readouterr()
    assert main(["simulate", str(path), "-o", str(tmp_path / "b.csv"), "--estimate", "off", "-v"]) == 0
    assert "running it" not in capsys.readouterr().err
    assert json.loads((tmp_path / "b.json").read_text())["axial_treatment"]["arm"] == why
