"""effects.axial = "auto" with a Kelvin-Voigt damped start ringing (``Scene.axial_switch``,
:mod:`symgen.numerics.axial_choice`): the axial dynamics kept only while the start's ringing
lasts, then the quasi-static model from the state reached. The oracle: the same scene with the
axial dynamics kept for the whole run (``effects.axial = "dynamic"``), across lambda 1e4 ... 1e10
(underdamped at 1e4, overdamped above)."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from symgen.cli import main
from symgen.numerics import axial_choice, simulate as simulate_module
from symgen.numerics.axial_drift import decay_time
from symgen.numerics.strain_choice import resolved
from symgen.scene.loader import load_scene
from tests.test_axial_start_ringing import ARM

#: Kelvin-Voigt damping of the spun arm (tau): its first axial mode (pi/2) sqrt(lambda) is
#: underdamped at lambda 1e4 (c w = 1.6), overdamped from 1e6 on (its slow root decays in ~ c)
DAMPING = 1e-2
ACCURACY = 0.01
OUTPUTS = ("tip_x", "Ox")


def _text(lam: float, axial: str, outputs: tuple[str, ...] = OUTPUTS, damping: float = DAMPING) -> str:
    text = ARM.replace("LAMBDA", f"{lam:g}").replace("TIP", "1").replace("AXIAL", axial).replace("INITIAL", "")
    text = text.replace('strain = "von_karman"', f'strain = "von_karman"\ndamping = {damping}')
    lines = text.splitlines()
    return "\n".join(ln for ln in lines if not ln.endswith("}") or ln.split(" = ")[0] in outputs) + "\n"


def _run(
    tmp_path, lam: float, axial: str, outputs: tuple[str, ...] = OUTPUTS, damping: float = DAMPING
) -> tuple[np.ndarray, dict]:
    path = tmp_path / f"arm_{axial}.toml"
    path.write_text(_text(lam, axial, outputs, damping))
    out = tmp_path / f"arm_{axial}.csv"
    assert main(["simulate", str(path), "-o", str(out), "--estimate", "off"]) == 0
    return np.loadtxt(out, delimiter=",", skiprows=1), json.loads(out.with_suffix(".json").read_text())


def test_the_decay_time_is_the_damped_modes_closed_form():
    """Underdamped (c w < 2): Re s = -c w^2 / 2; overdamped: the slower root of
    s^2 + c w^2 s + w^2, whose decay time is about c where c w >> 2; continuous at c w = 2."""
    assert decay_time(1e-3, 100.0) == pytest.approx(2.0 / (1e-3 * 100.0**2), rel=1e-12)
    w = 1e5
    s_slow = (DAMPING * w * w - math.sqrt((DAMPING * w * w) ** 2 - 4 * w * w)) / 2
    assert decay_time(DAMPING, w) == pytest.approx(1 / s_slow, rel=1e-9)
    assert decay_time(DAMPING, w) == pytest.approx(DAMPING, rel=1e-5)  # 1 + 1/(c w)^2
    assert decay_time(2.0 / 50.0 * (1 - 1e-12), 50.0) == pytest.approx(
        decay_time(2.0 / 50.0 * (1 + 1e-12), 50.0), rel=1e-5
    )


@pytest.mark.parametrize(
    ("lam", "outputs"), [(1e4, ("stretch", *OUTPUTS)), (1e6, OUTPUTS), (1e8, OUTPUTS), (1e10, OUTPUTS)]
)
def test_a_damped_start_ringing_keeps_the_axial_dynamics_until_it_has_ended(tmp_path, monkeypatch, lam, outputs):
    """The spun arm started undeformed (its pin force and stretch ring by their whole peaks: the
    quasi-static run is 100 % off at the start), damped: auto keeps the arm's axial dynamics to
    the output where the ringing has ended (the sidecar says where and why), then quasi-static;
    every output is within twice its charge and a fifth of the accuracy of the run that keeps the
    axial dynamics throughout (the charge: at most a tenth), in no more IDAS steps (but the
    restart's). The decision is remembered with its switch."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    auto, side = _run(tmp_path, lam, "auto", outputs)
    dyn, side_dyn = _run(tmp_path, lam, "dynamic", outputs)
    why = side["axial_treatment"]["arm"]
    assert why["treatment"] == "dynamic" and "quasi-static after it" in why["reason"], why
    switch = side["axial_switch"]
    assert switch["bars"] == ["arm"] and switch["tau"] == pytest.approx(switch["decided"])
    assert 0 < switch["tau"] < 0.3  # the run is 0.6: at most half of it dynamic
    decided = resolved(load_scene(tmp_path / "arm_auto.toml")).axial_switch
    assert decided is not None and decided.tau == pytest.approx(switch["tau"])
    charge = dict(decided.charge)
    assert auto.shape == dyn.shape
    assert max(charge.values()) <= ACCURACY / 10
    for j, name in enumerate(outputs, start=1):
        diff = float(np.abs(auto[:, j] - dyn[:, j]).max() / np.abs(dyn[:, j]).max())
        assert diff <= ACCURACY / 5, (name, diff)
        assert diff <= 2 * charge[name] + 1e-9, (name, diff, charge[name])
    assert side["solver"]["steps"] <= side_dyn["solver"]["steps"] + 30  # at most a restart's ramp of the order
    assert sum(switch["steps"]) == side["solver"]["steps"]
    # remembered: a second run switches at the same output without deciding again
    monkeypatch.setattr(axial_choice, "decide", lambda *a: pytest.fail("decided again"))
    again, side2 = _run(tmp_path, lam, "auto", outputs)
    assert side2["axial_switch"]["tau"] == switch["tau"]
    assert np.array_equal(again, auto)


def test_a_stop_after_the_switch_keeps_both_parts_as_a_partial_result(tmp_path, monkeypatch):
    """A failure in the quasi-static part raises with the partial result of both parts (nothing
    that looks complete): the first part's outputs, then the second's up to the stop."""
    from symgen.errors import SimulationError
    from symgen.numerics.mechanism import load_mechanism

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    _run(tmp_path, 1e6, "auto")  # decides
    mech = load_mechanism(resolved(load_scene(tmp_path / "arm_auto.toml")))
    assert mech.scene.axial_switch is not None
    whole = simulate_module.simulate(mech)
    one = simulate_module._run

    def failing(m, settings, initial, progress):
        if m is mech:
            return one(m, settings, initial, progress)
        partial = one(m, replace(settings, t_end=0.4), initial, progress)
        partial.complete = False
        err = SimulationError(0.4, "stopped here")
        err.partial = partial
        raise err

    monkeypatch.setattr(simulate_module, "_run", failing)
    with pytest.raises(SimulationError) as got:
        simulate_module.simulate(mech)
    part = got.value.partial
    assert not part.complete and part.tau[-1] == pytest.approx(0.4)
    k = len(part.tau)
    assert np.allclose(part.outputs, whole.outputs[:k], rtol=0, atol=1e-6)  # the second part run to 0.4 alone
    assert part.lam.shape[1] == mech.m and part.q.shape[1] == mech.n


def test_no_switch_without_damping(tmp_path, monkeypatch):
    """Undamped, the start's ringing lasts the run: the axial dynamics are kept for the whole run
    (no switch, nothing in the sidecar about one), the run of effects.axial = "dynamic"."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    auto, side = _run(tmp_path, 1e6, "auto", damping=0.0)
    dyn, _ = _run(tmp_path, 1e6, "dynamic", damping=0.0)
    why = side["axial_treatment"]["arm"]
    assert why["treatment"] == "dynamic" and "quasi-static after it" not in why["reason"], why
    assert "axial_switch" not in side
    assert np.allclose(auto, dyn, rtol=0, atol=1e-9 * np.abs(dyn).max())
