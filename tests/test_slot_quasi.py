"""symgen's choice of quasi-static span functions on a slot's guide (issue 19;
docs/quasi-static-modes.md "Slot guides", design item 2).

The coupled check (``symgen.scene.bases._CoupledEstimate``) covers a guide with an elastic
overhang: the guide frozen at the start's contact, its span functions, the contact-slope function
and the overhang's own functions as Ritz columns of the mechanism's finite-element model, the
slot as the pin's point kept on the guide's line. Oracles:

* the start's contact of the crank-shaper in closed form: the crank's pin at (0.08, 0.15) m, the
  lever pinned at the origin, beta0 = |OA| / l = 0.17 / 0.5 = 0.34;
* the frozen guide's first span mode by itself: pinned at the pivot, clamped at the contact, (3.9266
  / beta0)^2 sqrt(mu) (the span functions have zero value and slope at the contact);
* the run with every function dynamic (the same counts): the quasi-static run stays within the
  accuracy of it;
* the aluminium overhang reference (tests/test_overhang_reference.py): both span functions
  quasi-static were 3.4-18.8 % off its Exudyn reference; the rule must not choose that.
"""

from __future__ import annotations

import math
import pathlib
import tomllib

import numpy as np
import pytest

from symgen.scene import bases as B
from symgen.scene import load_scene

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHAPER = ROOT / "tests" / "data" / "shaper_stiff.toml"
OVERHANG = ROOT / "benchmarks" / "scenes" / "inverted_slider_crank_overhang.toml"


def _model(scene):
    place = B._placement(scene, dict(scene.initial.guess))
    model = B._Coupled(scene, place, set(B._guide_slots(scene)))
    return place, model


def test_the_start_contact_and_the_frozen_span_mode():
    """The placement solves the slot's contact with the loop (beta0 = 0.34 in closed form); the
    lever's 4 span functions in the coupled model's finite elements (Ritz) give the span's first
    frequency, pinned at the pivot and clamped at the contact, (3.9266 / beta0)^2 sqrt(mu) per
    unit tau, within 1e-3."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(SHAPER)
    place, model = _model(scene)
    beta0 = math.hypot(0.08, 0.15) / 0.5
    assert abs(place["A"][1] - beta0) < 1e-9
    p = model.parts["lever"]
    span, _ = B._guide_functions(p.x, place["A"][1], 4, 4)
    i = slice(p.start, p.start + 3 * len(p.x))
    wi = [3 * k + j for k in range(len(p.x)) for j in (1, 2)]
    K = model.K[i, i][np.ix_(wi, wi)]
    M = model.M[i, i][np.ix_(wi, wi)]
    w = np.sqrt(np.linalg.eigvals(np.linalg.solve(span.T @ M @ span, span.T @ K @ span)).real)
    expected = (3.9266023 / beta0) ** 2 * math.sqrt(scene.body("lever").mu)
    assert abs(w.min() / expected - 1.0) < 1e-3, (w.min(), expected)


def test_the_aluminium_overhang_keeps_its_span_functions_dynamic():
    """The overhang reference with the guide's count symgen's: its span's first mode over the run
    (at least the whole length's pinned-clamped, 1.562 x 7.31 = 11.4 per unit tau) is near the
    run's content (4): the span's band keeps span functions dynamic (``guide_band``), and the
    coupled check refuses the rest (it shifts the guide's first coupled mode)."""
    scene = _without(OVERHANG, "bodies", "transverse_modes", name="guide")
    guide = next(c for c in scene.bases if c.bar == "guide")
    assert guide.given[1] is None and guide.transverse >= 2
    assert B.guide_band(guide) >= 1
    assert guide.quasi == 0, guide.quasi_reason


def _without(path, table, key, name=None):
    """The scene file with ``key`` removed from ``table`` (of the bar ``name`` in [[bodies]])."""
    from symgen.scene.loader import parse_scene, scene_hash

    raw = tomllib.loads(path.read_text())
    for t in raw[table] if isinstance(raw[table], list) else [raw[table]]:
        if name is None or t.get("name") == name:
            t.pop(key, None)
    return parse_scene(raw, str(path), scene_hash(raw))


def test_the_stiff_shaper_chooses_quasi_static_span_functions_from_its_quasi_static_start():
    """From the quasi-static start the stiff lever's span modes (above 370 per unit tau over the
    run: ``guide_band``) are far above the run's content (4) and ring from nothing: all 4 span
    functions quasi-static (their change of the coupled modes about 2e-6 of peak), the contact-slope
    and overhang functions dynamic. From the undeformed start (undamped) the start rings the
    coupled modes at 700 and 2945 per unit tau, whose phase the span functions move: none
    (measured over the quarter turn against the all-dynamic run, undeformed: 2 span functions
    quasi-static 1.2 %, all 4 2.6 % of the torque's peak)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(SHAPER)
        ringing = _without(SHAPER, "initial", "deformation")
    lever = next(c for c in scene.bases if c.bar == "lever")
    assert lever.transverse == 4 and lever.quasi == 4, lever.quasi_reason
    assert scene.body("lever").quasi_static_transverse == 4
    lever = next(c for c in ringing.bases if c.bar == "lever")
    assert lever.quasi == 0 and "phase" in lever.quasi_reason + lever.reason, lever.quasi_reason


@pytest.mark.slow
def test_the_stiff_shaper_quasi_static_run_is_within_the_accuracy_of_the_dynamic_run():
    """Measured (a quarter turn from the quasi-static start, 4 of 4 span functions quasi-static):
    lever_mid 1.2e-6, lever_q3 3.5e-6, torque 7.4e-6 of peak against the all-dynamic run, 40181
    against 56595 IDAS steps. The
    start is consistent (the deformation's rates and accelerations held, the axial amplitudes'
    along the bending's held motion): the all-dynamic run no longer rings from it, so the
    quasi-static functions save what their own frequencies cost, not a start-up ringing (with the
    axial rates from the states at zero rates, session 9: lever_mid 2.4e-8, lever_q3 1.8e-8,
    torque 3.8e-7 of peak, 40925 against 97331 steps; with the rates and accelerations zero:
    1.2e-6, 1.1e-6, 9.8e-6, 40159 against 93781; with the rates alone held, session 8: 40702
    against 56978, docs/exact-bars.md)."""
    import warnings

    from symgen.api import mechanism, results_table
    from symgen.numerics.simulate import simulate

    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for tag, sets in (("quasi", []), ("dynamic", ["bodies.lever.quasi_static_transverse=0"])):
            mech = mechanism(SHAPER, sets)
            res = simulate(mech)
            assert res.complete, res.failure
            out[tag] = (results_table(res, mech.scene), res.steps)
    acc = 0.01
    q, d = out["quasi"][0], out["dynamic"][0]
    for name in ("lever_mid", "lever_q3", "ram_x", "torque"):
        a, b = np.asarray(q[name]), np.asarray(d[name])
        assert np.abs(a - b).max() <= acc * np.abs(b).max(), name
    assert out["quasi"][1] < 0.8 * out["dynamic"][1], (out["quasi"][1], out["dynamic"][1])


def test_the_contact_range_over_the_turn_and_the_overhang_warning():
    """The shaper's contact over the turn in closed form: the crank's pin 0.08 m about O, 0.15 m
    above the lever's pivot: from (0.15 - 0.08) / 0.5 = 0.14 (crank down) to (0.15 + 0.08) / 0.5 =
    0.46 (up), both among the eight positions sampled; at 0.14 the overhang is 6.14 spans, beyond
    the six the overhang's functions were checked for (tests/test_slot_overhang.py): a warning
    names the slot joint. The aluminium overhang reference (0.32 to 0.98 spans) has none."""
    import warnings

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        scene = load_scene(SHAPER)
    lo, hi = B.contact_range(scene, dict(scene.initial.guess))["A"]
    assert abs(lo - 0.14) < 1e-9 and abs(hi - 0.46) < 1e-9
    assert any("joints.A" in str(w.message) and "6.14 spans" in str(w.message) for w in said)
    scene = load_scene(OVERHANG)
    lo, hi = B.contact_range(scene, dict(scene.initial.guess))["A"]
    assert (1 - hi) / hi > 0.3 and (1 - lo) / lo < 1.0
    assert not any("spans" in c.warning for c in scene.bases)
