"""Issue 12, Deliver 4: the six-bar with an elastic ternary link pinned at mid-span
(``benchmarks/scenes/six_bar_steel.toml``) against an independent converged reference.

The references are Exudyn runs (ANCF cable elements, ``benchmarks/exudyn_models.six_bar``)
stored as CSV in ``tests/data/`` (header: elements, steps, Exudyn version, date and the
reference's own convergence figure), written by ``python benchmarks/bench_sixbar.py
--write-reference``; Exudyn is not needed to run these tests. The study (Exudyn's convergence,
symgen with more functions, CPU times) is the ``sixbar`` section of benchmarks/RESULTS.md.

Acceptance (issue 12): symgen's default model (the scene's function counts and shape families)
within 1 % of peak over two turns, at the scene's bending stiffness and at ten times it. The
error: max over the outputs of max |y - y_ref| / max |y_ref| on the one-degree output grid.

Measured with the static correction function at the mid-span pin (symgen's default since
issue 12's Deliver 1; 4 transverse functions per bar, rtol 1e-6, the scene's defaults): 0.17 %
at the scene's stiffness, 0.03 % at ten times it; with sines only
(``bodies.coupler.static_correction = false``) 0.68 % and 0.40 %. More sines converge on symgen's own limit, which sits 0.16 %
(0.05 % at 10x EI) from the reference (8 functions: 0.17 % / 0.08 %; 12: 0.16 % / 0.05 %): the
formulations' difference (von Karman assumed modes vs geometrically exact ANCF cable), well below
the 1 % target. The references' own convergence: 0.015 % and 0.039 % (header).
With 2 transverse functions per bar (the count of the other steel benchmark scenes) the default
model is 0.34 % and 0.33 % off; sines alone 4.1 % and 2.4 % (3 functions: 0.69 % / 0.41 %):
``test_two_functions_within_one_percent`` checks both.
"""

from __future__ import annotations

import math
import pathlib
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_sixbar import load_reference  # noqa: E402  (one reader of the stored references)

SCENE = ROOT / "benchmarks" / "scenes" / "six_bar_steel.toml"
DATA = ROOT / "tests" / "data"
ELASTIC = ("coupler", "link")
INERTIA = 2.25e-11
VARIANTS = {
    "scene": ([], DATA / "six_bar_reference.csv", 1.0),
    "stiff10": (
        [f"bodies.{b}.inertia={10 * INERTIA:g}" for b in ELASTIC],
        DATA / "six_bar_reference_stiff10.csv",
        10.0,
    ),
}


def _scene_outputs() -> tuple[list[str], float]:
    import tomllib

    with open(SCENE, "rb") as f:
        raw = tomllib.load(f)
    return list(raw["outputs"]), float(raw["scene"]["omega"])


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_stored_reference_is_sound(variant):
    """The stored reference loads, has the scene's output columns on the one-degree grid over
    two turns, and its own convergence (half the elements, half the steps) is below 0.2 %."""
    _, path, factor = VARIANTS[variant]
    meta, cols = load_reference(path)
    outputs, omega = _scene_outputs()
    assert list(cols) == ["t"] + outputs
    n = 721
    assert all(len(v) == n for v in cols.values())
    np.testing.assert_allclose(cols["t"] * omega, np.arange(n) * math.pi / 180, rtol=0, atol=1e-9)
    for k in outputs:
        assert np.all(np.isfinite(cols[k])) and np.abs(cols[k]).max() > 0
    for key in ("exudyn_version", "date", "elements_coupler", "elements_link", "steps_per_turn"):
        assert key in meta, key
    assert float(meta["stiffness_factor"]) == factor
    assert int(meta["elements_coupler"]) % 4 == 0  # quarter points and midspan are nodes
    figure = float(meta["convergence"])
    assert figure == max(float(meta["convergence_elements"]), float(meta["convergence_steps"]))
    assert figure < 2e-3, f"the reference's own convergence {figure:.2e} is not below 0.2 %"


def _symgen_error(variant: str, extra: tuple = ()) -> tuple[float, dict]:
    from symgen.api import mechanism, results_table
    from symgen.numerics.simulate import simulate

    over, path, _ = VARIANTS[variant]
    over = list(over) + list(extra)
    _, ref = load_reference(path)
    outputs, omega = _scene_outputs()
    mech = mechanism(SCENE, over)
    res = simulate(mech)
    assert res.complete, res.failure
    cols = results_table(res, mech.scene)  # SI: t in s, deflections in m
    deg = np.asarray(cols["t"]) * omega / (math.pi / 180)
    idx = np.rint(deg).astype(int)
    keep = np.abs(deg - idx) < 1e-6
    assert np.array_equal(idx[keep], np.arange(721))
    errs = {}
    for k in outputs:
        y = np.asarray(cols[k])[keep]
        assert len(y) == len(ref[k])
        errs[k] = np.abs(y - ref[k]).max() / np.abs(ref[k]).max()
    return max(errs.values()), errs


@pytest.mark.slow
@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_default_model_within_one_percent(variant):
    """symgen's default model within 1 % of peak over two turns of the stored reference
    (measured before the static corrections: 0.68 % and 0.40 % at 10x EI)."""
    worst, errs = _symgen_error(variant)
    assert worst <= 1e-2, {k: f"{100 * v:.2f} %" for k, v in errs.items()}


# Measured with sines only (`static_correction = false`): 2 transverse functions per
# bar miss the mid-span pin's kink (sin(2 pi xi) vanishes at the pin; the next shape that carries
# it is sin(3 pi xi)).
TWO_FUNCTIONS = {"scene": 4.1e-2, "stiff10": 2.4e-2}


@pytest.mark.slow
@pytest.mark.parametrize("variant", sorted(TWO_FUNCTIONS))
def test_two_functions_within_one_percent(variant):
    """The same acceptance with 2 transverse functions per elastic bar (the function count of the
    other steel benchmark scenes): the static correction at the mid-span pin carries the kink
    (measured 0.34 %, 0.33 % at 10x EI); without it the sines alone miss it by more than 1 %
    (measured 4.1 %, 2.4 %: ``TWO_FUNCTIONS``)."""
    two = [f"bodies.{b}.transverse_modes=2" for b in ELASTIC]
    worst, errs = _symgen_error(variant, two)
    assert worst <= 1e-2, {k: f"{100 * v:.2f} %" for k, v in errs.items()}
    sines, _ = _symgen_error(variant, two + ["bodies.coupler.static_correction=false"])
    assert sines > 1e-2 and sines == pytest.approx(TWO_FUNCTIONS[variant], rel=0.05)
