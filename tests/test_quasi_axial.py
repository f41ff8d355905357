"""symgen's choice of quasi-static axial functions and the measure of what saves IDAS steps
(``symgen.scene.bases.quasi_choice``, issue 19 "Cost"; docs/quasi-static-modes.md).

The steel crank-rocker at 900 rpm (benchmarks/scenes/crank_rocker_steel_900.toml: undamped,
starting undeformed, rtol 1e-8) spends its IDAS steps on the ringing of its cantilever crank's
second and third axial functions (the run's fastest modes, 2407 and 4161 per unit tau): with
them quasi-static the two turns take 108419 steps instead of 167835 (3 + 4 on every bar: 167564),
the outputs against 6 + 8 unchanged (benchmarks/RESULTS.md, "The steel crank-rocker's IDAS
steps"). Oracles: the closure (a function that is not zero at a joint is never taken), the
Kelvin-Voigt decay time 2 / (c w^2) of a mode (a damped scene's high modes cost no steps), and
the same counts with every function dynamic (the run's change within the accuracy, fewer steps).
"""

from __future__ import annotations

import warnings

import numpy as np

from symgen.api import mechanism
from symgen.numerics.simulate import simulate
from symgen.numerics.start import start_plan
from symgen.scene import bases as B
from symgen.scene import load_scene

CRANK_ROCKER = "benchmarks/scenes/crank_rocker_steel_900.toml"


def _scene(path, overrides=()):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path, list(overrides))


def _estimate(scene):
    place = B._placement(scene, dict(scene.initial.guess))
    counts = {c.bar: (c.axial, c.transverse) for c in scene.bases}
    omega_run, _ = B.run_frequency(scene)
    return B._CoupledEstimate(B._Coupled(scene, place, set()), not scene.initial.quasi_static, omega_run), counts


def test_crank_rocker_takes_its_cranks_top_axial_functions():
    """The crank's top two axial functions (sines: zero at both ends, so at joint A) quasi-static,
    nothing else: they lower the fastest mode the run rings from the crank's third axial mode to
    the crank's bending near 1390 per unit tau (3x: the steps follow it); the coupler's and the
    rocker's functions would change the coupled modes beyond what the accuracy leaves."""
    scene = _scene(CRANK_ROCKER)
    by = {c.bar: c for c in scene.bases}
    assert (by["crank"].quasi, by["crank"].quasi_axial) == (0, 2)
    assert all(by[n].quasi == 0 and by[n].quasi_axial == 0 for n in ("coupler", "rocker"))
    assert "axial: the highest 2 of its 3 axial functions are quasi-static" in by["crank"].quasi_reason
    assert by["crank"].as_dict()["quasi_static"]["axial_functions"] == 2
    est, counts = _estimate(scene)
    dynamic = est.quasi_check(counts, {})
    chosen = est.quasi_check(counts, {}, {"crank": 2})
    assert dynamic is not None and chosen is not None
    assert dynamic.fastest > 4000 and chosen.fastest < 1500
    assert dynamic.fastest / chosen.fastest > 2.9 > B.QUASI_GAIN
    # the change, the modes in quadrature, fits what the accuracy leaves in quadrature
    left = np.sqrt(scene.simulation.accuracy**2 - max(c.estimate for c in scene.bases) ** 2)
    assert chosen.estimate <= left
    assert f"{left:.2g}" in by["crank"].quasi_reason


def test_axial_function_at_a_joint_is_never_taken():
    """The steel slider-crank from rest (validation scene)'s rod: its axial function xi moves the slider (its pin at xi = 1),
    although at the start position the rod lies along the slider's line (the constraints there do
    not read it); its sines are zero at both pins. Its axial modes (shares below 1e-13) ring below
    rtol: taking them saves no steps, so the choice keeps them dynamic (its transverse functions
    are all quasi-static: tests/test_quasi_choice.py)."""
    scene = _scene("benchmarks/validation/slider_crank_steel_rest.toml")
    est, counts = _estimate(scene)
    na = counts["rod"][0]
    assert na == 3
    assert est.quasi_check(counts, {}, {"rod": na}) is None
    assert est.quasi_check(counts, {}, {"rod": na - 1}) is not None
    (c,) = scene.bases
    assert c.quasi == 3 and c.quasi_axial == 0 and "does not lower the fastest mode the run rings" in c.quasi_reason


def test_damping_decays_the_ringing_that_would_cost_steps():
    """Kelvin-Voigt damping c decays a mode of frequency w in 2 / (c w^2): at c = 1e-3 the crank's
    axial modes (w > 2000 per unit tau: 5e-4 per unit tau) ring for a fraction of a degree, the
    fastest mode the run rings over the run is a low one and nothing saves steps; at c = 0 they
    ring for the whole run."""
    undamped, damped = _scene(CRANK_ROCKER), _scene(CRANK_ROCKER, ["effects.damping=1e-3"])
    fast = {}
    for label, scene in (("undamped", undamped), ("damped", damped)):
        est, counts = _estimate(scene)
        check = est.quasi_check(counts, {})
        assert check is not None
        fast[label] = check.fastest
    assert fast["undamped"] > 4000 and fast["damped"] < 200
    assert all(c.quasi_axial == 0 and c.quasi == 0 for c in damped.bases)
    assert "no steps saved" in {c.bar: c for c in damped.bases}["crank"].quasi_reason


def test_quarter_turn_takes_fewer_steps_within_the_accuracy():
    """A quarter turn of the crank-rocker with symgen's choice (the crank's top two axial
    functions quasi-static) against the same counts stated (every function dynamic) and against
    3 + 4 on every bar: fewer than 0.7 x the steps of either (measured 13478 against 25416 and
    25708), the outputs within the accuracy's left-over of the dynamic run's; the emitted C solver's start plan integrates them as dynamic."""
    over = ["simulation.cycles=0.25"]
    scene = _scene(CRANK_ROCKER, over)
    counts = {c.bar: (c.axial, c.transverse) for c in scene.bases}
    assert {c.bar: c.quasi_axial for c in scene.bases} == {"crank": 2, "coupler": 0, "rocker": 0}
    stated = over + [
        f"bodies.{b}.{k}={n}"
        for b, (na, nt) in counts.items()
        for k, n in (("axial_modes", na), ("transverse_modes", nt))
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        chosen, dynamic = mechanism(CRANK_ROCKER, over), mechanism(CRANK_ROCKER, stated)
    assert [chosen.coords[i].name for i in chosen.quasi] == ["f_crank_2", "f_crank_3"]
    assert dynamic.quasi == ()
    a, b = simulate(chosen), simulate(dynamic)
    assert a.steps < 0.7 * b.steps
    # issue 19's cost rule: fewer steps than 3 + 4 on every bar (measured 25708)
    uniform = over + [f"bodies.{b}.{k}={n}" for b in counts for k, n in (("axial_modes", 3), ("transverse_modes", 4))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert a.steps < 0.7 * simulate(mechanism(CRANK_ROCKER, uniform)).steps
    for name in ("coupler_mid", "rocker_mid", "torque"):
        y, r = a.column(name), b.column(name)
        assert np.max(np.abs(y - r)) / np.max(np.abs(r)) < 5e-3, name
    # the emitted C solver takes the same partition (StartPlan.quasi): the chosen axial amplitudes
    # leave its independent coordinates, the dependent ones stay
    plan_a, plan_b = start_plan(chosen), start_plan(dynamic)
    assert plan_a.quasi == chosen.quasi and plan_b.quasi == ()
    assert plan_a.dependent == plan_b.dependent
    assert plan_a.independent == tuple(i for i in plan_b.independent if i not in chosen.quasi)
