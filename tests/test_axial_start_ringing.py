"""The error estimate's start-ringing charge (symgen.numerics.axial_drift.ringing): a bar whose
axial dynamics are quasi-static, started undeformed at speed, against the closed form (a bar
started undeformed under a steady inertia load rings axially with the amplitude of its static
stretch) and against the run that keeps the axial dynamics (the oracle)."""

from __future__ import annotations

import numpy as np
import pytest

from symgen.numerics import axial_drift
from symgen.numerics.error_estimate import estimate_errors
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from tests.scenes import pinned_arm

#: a stiff cantilever arm (lambda 1e4) with a tip mass spun at a constant rate 1 from an undeformed
#: start: the centrifugal load is steady, N(x) = M + (1 - x^2) / 2, its static tip stretch
#: (M + 1/3) / lambda; the first axial mode ~80 per unit tau, 20 x the driver's harmonics
ARM = pinned_arm(
    "spun_arm",
    "lambda = LAMBDA\nmu = 1.0",
    """
[driver]
kind = "angle"
body = "arm"
initial = 0.0
rate = 1.0

[effects]
strain = "von_karman"
axial = "AXIAL"
INITIAL
[outputs]
stretch = { kind = "axial", body = "arm", at = 1.0 }
tip_x = { kind = "position", body = "arm", at = 1.0, component = "x" }
Ox = { kind = "reaction", joint = "O", component = "x" }
torque = { kind = "driver_torque" }

[simulation]
t_end = 0.6
output_step = 0.002
""",
    tip_mass="TIP",
)
LAMBDA, TIP = 1.0e4, 1.0


def _arm(tmp_path, axial: str = "auto", quasi_static_start: bool = False):
    text = (
        ARM.replace("LAMBDA", f"{LAMBDA:g}")
        .replace("TIP", f"{TIP:g}")
        .replace("AXIAL", axial)
        .replace("INITIAL", '\n[initial]\ndeformation = "quasi-static"\n' if quasi_static_start else "")
    )
    path = tmp_path / f"arm_{axial}_{quasi_static_start}.toml"
    path.write_text(text)
    mech = load_mechanism(path)
    return mech, simulate(mech)


@pytest.fixture(scope="module")
def spun(tmp_path_factory):
    return _arm(tmp_path_factory.mktemp("spun"))


def test_the_arm_is_quasi_static_by_the_auto_rule_and_stretched_as_the_closed_form(spun):
    mech, res = spun
    assert "arm" in axial_drift.quasi_static_bars(mech)
    static = (TIP + 1.0 / 3.0) / LAMBDA
    assert float(np.median(res.column("stretch"))) == pytest.approx(static, rel=0.02)


def test_the_ringing_is_the_static_stretch_and_the_dynamic_runs_difference(spun, tmp_path):
    """Closed form: started undeformed, the tip stretch rings about its static value with that
    value as amplitude: the charge on the stretch is 1 of its peak (undamped, one mode dominant
    with the tip mass). Oracle: the whole run with the axial dynamics kept (effects.axial =
    "dynamic"), every output within [0.5, 2] of its largest difference to the run."""
    mech, res = spun
    ring, how = axial_drift.ringing(mech, res)
    assert how.startswith("the start's axial ringing")
    assert ring["stretch"] == pytest.approx(1.0, rel=0.1)
    _, dyn = _arm(tmp_path, axial="dynamic")
    # (the driver torque is 0 in the quasi-static run at a constant rate: no peak to charge against)
    for name in ("stretch", "tip_x", "Ox"):
        a, b = res.column(name), dyn.column(name)
        true = float(np.max(np.abs(a - b)) / np.max(np.abs(a)))
        assert true > 1e-5, name  # above the tolerances: the ringing is what differs
        assert 0.5 <= ring[name] / true <= 2.0, f"{name}: charge {ring[name]:.3g}, dynamic run {true:.3g}"


def test_the_axial_part_carries_the_ringing_through_the_estimate(spun):
    """The driven arm has no free motion to drift: the axial part is the ringing, and says so."""
    mech, res = spun
    ring, _ = axial_drift.ringing(mech, res)
    est = estimate_errors(mech, res, 1e-8, 1e-10, truncation="linearized")
    assert est.methods["axial"].startswith("the start's ringing on")
    assert 'initial.deformation = "quasi-static"' in est.methods["axial"]
    # the driver torque of the quasi-static run at a constant rate is 0 (no peak to charge
    # against): zero to round-off, so no part estimates it (SimResult.peaks)
    assert set(est.zero) == {"torque"} and ring["torque"] == 0.0
    assert all(est.parts[p]["torque"] is None for p in est.parts)
    for name, value in ring.items():
        if name not in est.zero:
            assert est.parts["axial"][name] == pytest.approx(value)


def test_no_ringing_from_a_quasi_static_start(tmp_path):
    """At a steady spin the quasi-static start sets no deformation rate: its axial force is the
    run's N(0) (the a-priori bound ~0), the window is not run; the whole run with the axial
    dynamics kept reads the quasi-static treatment's steady error instead, the stretch's own
    centrifugal load: relative w^2 / lambda (1e-4) of the stretch, and as little on the others.
    (Under a varying load: tests/test_axial_qs_start_ringing.py.)"""
    mech, res = _arm(tmp_path, quasi_static_start=True)
    bars = axial_drift.quasi_static_bars(mech)
    assert "arm" in bars
    assert axial_drift.ringing_bound(mech, res, bars) < 1e-6
    ring, how = axial_drift.ringing(mech, res)
    # (the driver torque is 0 at a constant rate in both runs, to round-off: no peak to charge against)
    assert max(v for n, v in ring.items() if n != "torque") < 1e-3
    assert "the quasi-static start's axial force" in how and "the start's ringing not run" in how
    assert "the whole run with the axial dynamics of arm kept" in how


def test_a_start_from_rest_skips_the_window_by_its_a_priori_bound():
    """slider_crank_steel_rest spins up from rest: no axial force at the start, no window run."""
    steel = load_mechanism("benchmarks/validation/slider_crank_steel_rest.toml", ["simulation.duration=0.05"])
    res = simulate(steel)
    assert axial_drift.ringing_bound(steel, res, axial_drift.quasi_static_bars(steel)) < 1e-3
    ring, how = axial_drift.ringing(steel, res)
    assert set(ring.values()) == {0.0}
    assert "not run" in how


def test_the_warning_names_the_start_ringing_and_its_keys(capsys):
    from symgen.cli import _say_estimate

    sidecar = {
        "error_estimate": {"torque": 0.074},
        "error_estimate_detail": {
            "parts": {
                "truncation": {"torque": 4e-5},
                "axial": {"torque": 0.0736},
                "time_integration": {"torque": 7e-7},
            },
            "methods": {
                "axial": "the start's ringing on torque (the larger there; the phase drift on the others): ..."
            },
        },
        "accuracy": 0.01,
    }
    _say_estimate(sidecar, "press.json", "press.toml")
    err = capsys.readouterr().err
    assert "the start's axial ringing" in err
    assert 'initial.deformation = "quasi-static" removes it where' in err and 'effects.axial = "dynamic"' in err


def test_a_failed_window_leaves_the_drift_and_says_why(spun, monkeypatch):
    """The window's runs failing (here: the axial-dynamic model's run raises) is no internal
    error: the part is the drift alone and its method says the ringing was not estimated."""
    from symgen.errors import SimulationError

    mech, res = spun

    def failing(*args, **kwargs):
        raise SimulationError(0.01, "IDAS stopped")

    monkeypatch.setattr("symgen.numerics.simulate.simulate", failing)
    values, how = axial_drift.estimate(mech, res)
    # driven: no drift; the ringing not estimated: the stretch's own inertia alone
    assert set(axial_drift.drift(mech, res)[0].values()) == {0.0}
    assert values == axial_drift.own_inertia(mech, res)[0]
    assert (
        "not estimated (the window with the axial dynamics kept failed: SimulationError: at tau = 0.01: IDAS stopped)"
        in how
    )


def _arm_text(axial: str, outputs: tuple[str, ...] = ("stretch", "tip_x", "Ox", "torque")) -> str:
    text = (
        ARM.replace("LAMBDA", f"{LAMBDA:g}").replace("TIP", f"{TIP:g}").replace("AXIAL", axial).replace("INITIAL", "")
    )
    lines = text.splitlines()
    return "\n".join(ln for ln in lines if not ln.endswith("}") or ln.split(" = ")[0] in outputs) + "\n"


def test_auto_keeps_the_axial_dynamics_for_the_start_ringing(tmp_path, monkeypatch):
    """effects.axial = "auto" on the spun arm (quasi-static by the frequencies, started undeformed,
    driven: nothing drifts): the start's ringing (about 1 of the stretch's peak) exceeds the
    accuracy, so the run is made again with the arm's axial dynamics kept: the sidecar says why,
    the axial part is then 0, and the result is the run of effects.axial = "dynamic" (the oracle
    of the ringing: test_the_ringing_is_the_static_stretch_and_the_dynamic_runs_difference)."""
    import json

    from symgen.cli import main

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))  # nothing decided yet
    auto, dyn = tmp_path / "auto.toml", tmp_path / "dyn.toml"
    auto.write_text(_arm_text("auto", outputs=("stretch", "tip_x")))
    dyn.write_text(_arm_text("dynamic", outputs=("stretch", "tip_x")))
    assert main(["simulate", str(auto), "-o", str(tmp_path / "a.csv"), "--estimate", "linearized"]) == 0
    side = json.loads((tmp_path / "a.json").read_text())
    why = side["axial_treatment"]["arm"]
    assert why["treatment"] == "dynamic", why
    assert "the start's axial ringing" in why["reason"] and "of peak on stretch" in why["reason"]
    assert "above simulation.accuracy 0.01" in why["reason"]
    assert set(side["error_estimate_detail"]["parts"]["axial"].values()) == {0.0}
    assert main(["simulate", str(dyn), "-o", str(tmp_path / "d.csv"), "--estimate", "off"]) == 0
    a = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    d = np.loadtxt(tmp_path / "d.csv", delimiter=",", skiprows=1)
    assert np.allclose(a, d, rtol=0, atol=1e-9 * np.abs(d).max())


def test_a_run_kept_quasi_static_is_estimated_from_the_windows_its_decision_ran(tmp_path, monkeypatch):
    """The arm read at its tip's position alone: the ringing (the stretch, ~1e-4 of the tip's
    travel) is within the accuracy, so auto keeps it quasi-static; the decision's windows serve
    the run's error estimate: the ringing is measured once, and the sidecar carries it. A rerun
    of the same scene does not decide again (remembered): without an estimate, no window."""
    import json

    from symgen.cli import main

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "tip.toml"
    path.write_text(_arm_text("auto", outputs=("tip_x",)))
    calls = []
    measured = axial_drift.ringing

    def counted(*args, **kwargs):
        calls.append(args)
        return measured(*args, **kwargs)

    monkeypatch.setattr(axial_drift, "ringing", counted)
    assert main(["simulate", str(path), "-o", str(tmp_path / "t.csv"), "--estimate", "linearized"]) == 0
    side = json.loads((tmp_path / "t.json").read_text())
    assert side["axial_treatment"]["arm"]["treatment"] == "quasi_static"
    assert len(calls) == 1
    ring = side["error_estimate_detail"]["parts"]["axial"]["tip_x"]
    assert 0 < ring < 0.01
    assert side["error_estimate_detail"]["methods"]["axial"].startswith("the start's ringing on tip_x")
    assert main(["simulate", str(path), "-o", str(tmp_path / "u.csv"), "--estimate", "off"]) == 0
    assert len(calls) == 1
    assert json.loads((tmp_path / "u.json").read_text())["axial_treatment"]["arm"]["treatment"] == "quasi_static"
