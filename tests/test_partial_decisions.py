"""A run that stops early still gets the auto rules' run-time halves (symgen.numerics.results.decidable).

The soft free triple pendulum kept out of the repository (issue 19) whips beyond the bars' range at
tau 5.3 and stops there: before, its partial result was the first, provisional model's (von
Karman, axial quasi-static), because the strain and axial decisions were made only after a
complete run, and it was 1-5 % of peak off its converged ANCF reference from tau 2 on, where the
slopes are still small: the quasi-static bars leave their stretch N/lambda (~1e-3) out of the
chain's motion. Judged up to the stop, the run now keeps the axial dynamics (docs/exact-bars.md,
"A run that stops early").

Oracle here (not that scene): the soft spinning arm of tests/test_axial_drift.py, spun up by a
torque pulse and then turning freely, whose spin rate after the pulse is fixed by its angular
momentum H (the pulse's integral, closed form) and its moment of inertia, which the centrifugal
stretch raises by the closed form's dJ. A late torque step bends the arm beyond the model's range,
so the run stops at tau ~ 40 and is partial.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from symgen.errors import SimulationError
from tests.scenes import pinned_arm

LAMBDA, MU, TIP_MASS = 3000.0, 1.2, 0.5
#: the pulse 0.8 exp(-((tau - 1.5)/0.7)^2), then a torque rising smoothly to 40 around tau = STOP
#: (tanh) that bends the arm beyond the range of the model within a fraction of a tau
STOP = 40.0
SCENE = pinned_arm(
    "soft_arm_stops",
    f"lambda = {LAMBDA!r}\nmu = {MU!r}",
    f"""
[driver]
kind = "torque"
body = "arm"
value = "0.8*exp(-((tau - 1.5)/0.7)^2) + 20*(1 + tanh(5*(tau - {STOP!r})))"
initial = 0.0
rate = 0.0

[effects]
damping = 0.01
strain = "von_karman"
AXIAL

[outputs]
tip = {{ kind = "deflection", body = "arm", at = 1.0 }}
theta = {{ kind = "angle", body = "arm" }}
tip_x = {{ kind = "position", body = "arm", at = 1.0, component = "x" }}

[simulation]
t_end = 60.0
output_step = 0.01
""",
    tip_mass=repr(TIP_MASS),
)


def _closed_form_rate() -> tuple[float, float]:
    """(spin rate of the stretched arm, of the inextensible one) after the pulse: J(w) w = H with
    H = 0.8 * 0.7 sqrt(pi) (1 + erf(1.5 / 0.7)) / 2 (the pulse's integral from tau = 0), J = 1/3 + M
    + dJ(w), dJ = (2 w^2 / lambda)(M^2 + 2M/3 + 2/15) (u(x) = (w^2/lambda)((M + 1/2) x - x^3/6))."""
    M = TIP_MASS
    H = 0.8 * 0.7 * math.sqrt(math.pi) * (1 + math.erf(1.5 / 0.7)) / 2
    J0 = 1 / 3 + M
    w = H / J0
    for _ in range(50):
        w = H / (J0 + 2 * w**2 / LAMBDA * (M**2 + 2 * M / 3 + 2 / 15))
    return w, H / J0


def _run(tmp_path, axial: str) -> tuple[np.ndarray, dict, dict]:
    from symgen.api import simulate_scene

    path = tmp_path / f"arm_{axial or 'auto'}.toml"
    path.write_text(SCENE.replace("AXIAL", f'axial = "{axial}"' if axial else ""))
    out = tmp_path / f"arm_{axial or 'auto'}.csv"
    with pytest.raises(SimulationError, match="beyond the range of the model"):
        simulate_scene(str(path), out=out, estimate="off")
    part = out.with_name(out.stem + ".partial.csv")
    header = part.read_text().splitlines()[0].split(",")
    data = np.loadtxt(part, delimiter=",", skiprows=1)
    side = json.loads(part.with_suffix(".json").read_text())
    return data[:, 0], {h: data[:, i] for i, h in enumerate(header) if i}, side


def _rate(tau: np.ndarray, theta: np.ndarray) -> float:
    """The mean spin rate over the free spin (the pulse's vibration damped) before the step."""
    a, b = np.searchsorted(tau, [15.0, STOP - 2.0])
    return float((theta[b] - theta[a]) / (tau[b] - tau[a]))


@pytest.mark.slow
def test_a_run_that_stops_early_keeps_the_axial_dynamics_its_first_part_needs(tmp_path, monkeypatch):
    """effects.axial = "auto": the arm is quasi-static a priori (first axial frequency 86 = 18 x
    the run's fastest motion); the run stops at tau ~ 40 (the step), and its axial part up to
    there (the free spin's phase drift, ~3 % of tip_x's peak) exceeds the accuracy, so the run is
    made again with the axial dynamics kept: its partial result spins at the closed form's rate
    of the stretched arm (the quasi-static run at the inextensible one's, 8e-4 faster)."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))  # nothing decided yet
    w_stretched, w_rigid = _closed_form_rate()
    assert (w_rigid - w_stretched) / w_stretched > 5e-4  # the physics the test can tell apart
    tau, out, side = _run(tmp_path, "")
    assert side["status"] == "partial" and STOP - 1.0 < tau[-1] < STOP + 1.0
    why = side["axial_treatment"]["arm"]
    assert why["treatment"] == "dynamic" and "the run's axial estimate" in why["reason"], why
    assert _rate(tau, out["theta"]) == pytest.approx(w_stretched, rel=1e-4)
    # the quasi-static run, as the partial result was before: the inextensible arm's rate
    tau_q, out_q, side_q = _run(tmp_path, "quasi_static")
    assert side_q["axial_treatment"]["arm"]["treatment"] == "quasi_static"
    assert _rate(tau_q, out_q["theta"]) == pytest.approx(w_rigid, rel=1e-4)
    assert abs(_rate(tau_q, out_q["theta"]) / w_stretched - 1) > 5e-4


def test_decidable_runs():
    """Complete runs and runs stopped by a SimulationError with at least two samples are judged;
    interrupted runs and runs without a partial result are not."""
    from types import SimpleNamespace

    from symgen.errors import Interrupted
    from symgen.numerics.results import decidable

    two, one = SimpleNamespace(tau=np.array([0.0, 0.1])), SimpleNamespace(tau=np.array([0.0]))
    assert decidable(two, None)
    assert decidable(two, SimulationError(0.1, "beyond the range"))
    assert not decidable(one, SimulationError(0.0, "singular"))
    assert not decidable(None, SimulationError(0.0, "singular"))
    assert not decidable(two, Interrupted())
