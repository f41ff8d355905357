"""Issue 12 Deliver 2 acceptance: a slot guide with a long elastic overhang against Exudyn.

``benchmarks/scenes/inverted_slider_crank_overhang.toml``: an aluminium inverted slider-crank whose
guide overhangs the slider by 0.32 to 0.98 of its span over the turn. The reference is a
converged Exudyn model (ANCF cable guide and crank, ``ObjectJointSliding2D`` slot; see
``benchmarks/exudyn_models.inverted_slider_crank`` and ``benchmarks/bench_overhang.py``), stored in
``tests/data/inverted_slider_crank_overhang_exudyn.csv`` (its header says how it was made), so
only the last test needs Exudyn.

Acceptance: symgen's default model (elastic overhang) gives the guide's far-end deflection and
the crank-tip deflection within 1 % of their peaks (2 % before DERIVE_VERSION 11; measured over two
turns 0.45 % and 0.20 % before DERIVE_VERSION 12, 0.026 % and 0.018 % since: the guide's tension
stiffens its bending, it keeps its length as it bends, and its damping acts on its whole curvature
rate) (max |y - y_ref| / max |y_ref|
on the one-degree grid); the seed's rigid overhang does not.
"""

from __future__ import annotations

import math
import pathlib
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCENE = ROOT / "benchmarks" / "scenes" / "inverted_slider_crank_overhang.toml"
CSV = ROOT / "tests" / "data" / "inverted_slider_crank_overhang_exudyn.csv"
ACCEPT = ("guide_end", "crank_tip")
OUTPUTS = ACCEPT + ("guide_slope",)
TARGET = 0.01
#: the reference's own convergence: half its steps move it by up to 0.034 % of peak (its CSV header)
REFERENCE_NOISE = 3.4e-4


def _reference(degrees: int) -> dict:
    lines = [ln for ln in CSV.read_text().splitlines() if ln and not ln.startswith("#")]
    names = lines[0].split(",")
    data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1 : degrees + 2]])
    return {k: data[:, names.index(k)] for k in ("t",) + OUTPUTS}


def _symgen(overrides: list[str], degrees: int) -> dict:
    """symgen's outputs (SI) on the one-degree grid over ``degrees`` of crank."""
    from symgen.api import mechanism, results_table
    from symgen.numerics.simulate import simulate

    mech = mechanism(SCENE, overrides + [f"simulation.cycles={degrees / 360}"])
    res = simulate(mech)
    assert res.complete, res.failure
    cols = results_table(res, mech.scene)
    t = np.asarray(cols["t"])
    dt = math.pi / 180 / 22.0
    k = np.rint(t / dt).astype(int)
    on = np.abs(t - k * dt) <= 1e-6 * dt
    idx = {int(kk): i for i, kk in zip(np.nonzero(on)[0], k[on])}
    assert all(j in idx for j in range(degrees + 1)), "output grid points missing"
    sel = [idx[j] for j in range(degrees + 1)]
    return {name: np.asarray(cols[name])[sel] for name in ("t",) + OUTPUTS}


def _errors(y: dict, ref: dict) -> dict:
    return {k: float(np.abs(y[k] - ref[k]).max() / np.abs(ref[k]).max()) for k in OUTPUTS}


def test_stored_reference_is_the_scene():
    """The CSV covers two turns on the one-degree grid of the scene's 22 rad/s, with
    deflections in the small-deflection range (guide ~0.6 %, crank ~0.5 % of their lengths)."""
    ref = _reference(720)
    assert len(ref["t"]) == 721
    assert np.allclose(ref["t"], np.arange(721) * math.pi / 180 / 22.0, rtol=0, atol=1e-9)
    assert 0.003 < np.abs(ref["guide_end"]).max() / 0.95 < 0.02
    assert 0.003 < np.abs(ref["crank_tip"]).max() / 0.12 < 0.02


def test_default_quarter_turn_within_one_percent():
    """The first quarter turn (the default suite's short check), peaks of that quarter."""
    ref = _reference(90)
    err = _errors(_symgen([], 90), ref)
    assert all(err[k] <= TARGET for k in ACCEPT), err


def test_top_span_function_quasi_static_quarter_turn_within_one_percent():
    """The guide's second span function quasi-static (``quasi_static_transverse = 1``: with the
    elastic overhang the span functions vanish beyond the contact, so the key is accepted on a
    guide; refused before DERIVE_VERSION 11): within 1 % of the reference as the default is (two
    turns, measured: guide_end 0.47 %, crank_tip 0.21 %, guide_slope 0.55 % against the default's
    0.45, 0.20, 0.57 %). Both span functions quasi-static are not: the span's first mode (38 per
    unit tau) is not far above the guide's first (11) and guide_slope reads it (18.8 %)."""
    ref = _reference(90)
    err = _errors(_symgen(["bodies.guide.quasi_static_transverse=1"], 90), ref)
    assert all(err[k] <= TARGET for k in ACCEPT), err


def test_quasi_static_span_functions_are_refused_on_a_rigid_overhang():
    """The seed's rigid overhang moves with every span function's end slope: the key is refused,
    naming it."""
    from symgen.api import mechanism
    from symgen.errors import SceneError

    with pytest.raises(SceneError, match="quasi_static_transverse"):
        mechanism(SCENE, ['joints.A.overhang="rigid"', "bodies.guide.quasi_static_transverse=1"])


@pytest.mark.slow
def test_default_two_turns_within_one_percent_rigid_overhang_not():
    ref = _reference(720)
    err = _errors(_symgen([], 720), ref)
    assert all(err[k] <= TARGET for k in ACCEPT), err
    rigid = _errors(_symgen(['joints.A.overhang="rigid"'], 720), ref)
    assert rigid["guide_end"] > 0.2, rigid


@pytest.mark.slow
def test_exudyn_reproduces_the_stored_reference():
    """A coarser Exudyn run (16 guide elements, 2880 steps/turn: 0.12 % from the reference in the
    bench's convergence table) lands on the stored curves."""
    pytest.importorskip("exudyn")
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from exudyn_models import inverted_slider_crank

    t, out, _ = inverted_slider_crank(16, 2880, 2.0)
    ref = _reference(720)
    dt = math.pi / 180 / 22.0
    k = np.rint(np.asarray(t) / dt).astype(int)
    on = (np.abs(t - k * dt) <= 1e-6 * dt) & (k <= 720)
    idx = np.full(721, -1)
    idx[k[on]] = np.nonzero(on)[0]
    assert (idx >= 0).all()
    err = _errors({name: np.asarray(out[name])[idx] for name in OUTPUTS}, ref)
    assert max(err.values()) < 3e-3, err


@pytest.mark.slow
def test_the_truncation_part_is_estimated_on_the_guide():
    """The error estimate's truncation part reruns a richer guide (one more span function and one
    more overhang function: 3 + chi_0 + 5, the crank 5 + 5) instead of saying "not estimated".
    Measured over two turns: the richer model changes guide_end by 3.5e-6, crank_tip 6.4e-6 and
    guide_slope 2.5e-3 of peak (the guide's basis is converged in guide_end and crank_tip), while
    the true errors against the Exudyn reference are 0.45 %, 0.20 % and 0.57 %: the difference is
    not the truncation (nor the time integration, 4e-6), and the model-form part does not estimate
    slot guides: the total estimate is 0.002x, 0.02x and 0.45x the true error there (open)."""
    from symgen.api import mechanism
    from symgen.numerics import error_estimate
    from symgen.numerics.simulate import simulate

    mech = mechanism(SCENE, ["simulation.cycles=0.25"])
    res = simulate(mech)
    assert res.complete, res.failure
    sim = mech.scene.simulation
    est = error_estimate.estimate_errors(mech, res, sim.rtol, sim.atol)
    assert est.methods["truncation"] != "not estimated", est.reasons
    assert est.richer["guide"] == [0, mech.scene.body("guide").transverse_modes + 1]
    assert all(isinstance(est.parts["truncation"][k], float) for k in OUTPUTS)


@pytest.fixture(scope="module")
def user_run(tmp_path_factory) -> tuple[dict, dict]:
    """The scene without its function counts and tolerances (symgen chooses them from the default
    accuracy), run by ``symgen simulate`` with the default error estimate over two turns: (outputs on
    the one-degree grid, the sidecar)."""
    import json
    import re

    from symgen.cli import main

    tmp = tmp_path_factory.mktemp("user_run")
    text = re.sub(r"(?m)^(axial_modes|transverse_modes|rtol|atol)\s*=.*$", "", SCENE.read_text(encoding="utf-8"))
    scene = tmp / SCENE.name
    scene.write_text(text, encoding="utf-8")
    out = tmp / "run.csv"
    assert main(["simulate", str(scene), "-o", str(out)]) == 0
    lines = out.read_text().splitlines()
    names = lines[0].split(",")
    data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    cols = {k: data[:, names.index(k)] for k in ("t",) + OUTPUTS}
    assert np.allclose(cols["t"], np.arange(721) * math.pi / 180 / 22.0, rtol=0, atol=1e-9)
    return cols, json.loads(out.with_suffix(".json").read_text())


@pytest.mark.slow
def test_within_one_percent_as_a_user_runs_the_scene(user_run):
    """Issue 19's acceptance for the slot-with-overhang class, run as a user runs it (no counts,
    the tolerances from the accuracy, the default estimate): every output within 1 % of peak of
    the Exudyn reference over two turns (measured 0.45 %, 0.20 %, 0.53 % before DERIVE_VERSION 12)."""
    err = _errors(user_run[0], _reference(720))
    assert all(e <= TARGET for e in err.values()), err


@pytest.mark.slow
def test_the_guide_matches_the_ancf_cable_to_a_tenth_of_a_percent(user_run):
    """The physics of the slot guide against the ANCF cable: within 0.1 % of peak on every output
    (issue 19 Deliver 3's bar for converged models; measured 0.026 / 0.018 / 0.064 %, the first two
    below the reference's own step convergence, 0.034 %). Before DERIVE_VERSION 12 the axially rigid
    guide kept the centrifugal softening of its kinetic energy but not its tension's stiffening nor
    its length's shortening, and its Kelvin-Voigt damping missed the beta_dot part of its curvature
    rate: 0.45 / 0.20 / 0.53 % (the tension alone: 0.10 / 0.026 / 0.35 %; with the damping's
    beta_dot part 0.032 / 0.019 / 0.074 %), converged in functions and time."""
    err = _errors(user_run[0], _reference(720))
    assert all(e <= 0.001 for e in err.values()), err


@pytest.mark.slow
def test_the_error_estimate_is_honest_as_a_user_runs_the_scene(user_run):
    """The sidecar's ``error_estimate`` within [0.5, 2] x the true error (issue 19, item 2) on the
    slot-with-overhang class, for the outputs whose true error is above the reference's own
    convergence (``REFERENCE_NOISE``: half its steps move it by 0.034 % of peak; the validation
    suite's rule, tests/test_model_form_honesty.py). Measured 2026-11-29 (DERIVE_VERSION 12; no
    counts: crank 3 + 3, guide 4 span + chi_0 + 4 overhang functions chosen): true 2.6e-4 / 1.8e-4 /
    6.4e-4 of peak (guide_end / crank_tip / guide_slope), the estimate 1.4e-5 / 2.3e-5 / 3.5e-4:
    guide_slope 0.56 (its truncation part: one span function more moves it 3.2e-4; with 5 and 6 span
    functions it is 0.042 and 0.057 % off the reference), the others below the noise. Before
    DERIVE_VERSION 12 the guide's missing tension, shortening and damping made the true errors
    0.45 / 0.20 / 0.53 %, which no part estimated (ratios 0.001 / 0.01 / 0.06). Since estimator
    version 17 the model-form part estimates the guide's curvature beyond its fourth order
    (``model_form._Guide``): 1e-6 .. 2e-5 of peak here (0.6 % deflection)."""
    y, side = user_run
    err = _errors(y, _reference(720))
    est = side["error_estimate"]
    above = [k for k in OUTPUTS if err[k] > REFERENCE_NOISE]
    assert above == ["guide_slope"], err  # the others are at the reference's own convergence
    ratios = {k: est[k] / err[k] for k in above}
    assert all(0.5 <= r <= 2.0 for r in ratios.values()), (err, est, ratios)
