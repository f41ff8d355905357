"""Issue 19, item 2's acceptance on the validation suite: each scene run as a user runs it
(default settings, no mode counts, ``effects.strain = "auto"``), its sidecar's ``error_estimate``
(truncation + model form + time integration) against the true error, max over the run
|symgen - ref| / peak |ref| against the converged Exudyn ANCF reference
(``benchmarks/bench_validation.py honesty``; benchmarks/RESULTS.md, "Error estimate on the
validation suite"). Outputs whose true error is below the reference's own convergence
(``bench_validation.TOL`` = 2e-4 of peak) are below noise and not asserted.

Where the estimate lies within [0.5, 2] x the true error the case asserts it; where it does not
today, a strict xfail says the measured ratio and its cause, so it flips when fixed. The slewing
arm (one bar, a few seconds) is in the default suite; the others are slow.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_validation as V  # noqa: E402

#: ratios estimate / true error measured by ``bench_validation.py honesty`` (the outputs above
#: noise), and the cause where outside [0.5, 2]; measured 2026-11-26 with the model-form part's
#: drift at the mechanism's coupled modes (symgen.numerics.model_form.coupled_modes; before, each
#: bar's own first mode: the five-bar 0.93 / 1.24 / 1.40 / 0.91, the six-bar 0.79 / 0.63 / 0.67 /
#: 0.52 / 1.13, the crank-rocker 0.94 / 0.88 / 0.82 / 0.98; tests/test_model_form_drift.py)
#: The truncation part against the run's model at the time part's tighter tolerances (wt-truncref,
#: 2026-11-27): every ratio below the same to two digits, but slider_crank_torque_soft's, measured
#: 1.02 / 1.06 there (stored: its branch's 1.05 / 1.07); the suite's runs have small time errors.
MEASURED: dict[str, dict[str, tuple[float, str]]] = {
    "slewing_arm": {
        # DERIVE_VERSION 8 (the exact strain's eta'^4 / 8): tip and mid fell to 3.4e-5 and 1.4e-4 of peak,
        # below the reference's noise (they were 7.7e-4, ratios 0.82 and 0.88)
        # the exact bar with the strain's eta'^4 / 8 (true 3.7e-4) and the estimate measured as written
        # (estimator 10: 0.92; 11: the same)
        # estimator 15 (the static change with the arm's slow axial force, model_form.SLOW_AXIAL): 1.02
        # (model-form part 8.0e-5 -> 1.2e-4)
        "torque": (1.02, ""),
    },
    # the axial part's drift charges the deflections their whole rate along the run (0 before, the rate
    # along the free rigid coordinates: 0.75 / 0.92): 3.9e-5 / 4.0e-5 of peak (estimator 10: the same)
    "double_pendulum_alu": {"upper_tip": (0.92, ""), "lower_tip": (0.95, "")},  # 14: 0.92 (0.93 before)
    "five_bar_elastic": {
        # 2026-11-27, the drift read without the driver's harmonics below each mode's band
        # (symgen.numerics.model_form.forced_harmonics): 0.64 / 0.86 / 1.08 / 0.68 -> 0.64 / 0.87 / 1.11 / 0.68
        # 2026-11-27, estimator 6 (a mode's own vibration moves it by its backbone, half its tangent's
        # stiffening; the modes' drifts summed at each instant): 0.64 / 0.87 / 1.11 / 0.68 -> 0.58 / 0.81 /
        # 1.00 / 0.62; estimator 7 (a vibration drifts from when it came in): 0.55 / 0.80 / 0.96 / 0.57;
        # estimator 10 (each coupled mode's own coordinate changes by its oscillator's first-order
        # response, each output by its participation): 1.18 / 1.63 / 1.32 / 1.05; estimator 11 (the static
        # change and the drifts added at the same instant): 0.92 / 1.54 / 1.26 / 1.02 (with the stretch's
        # share of the curvature too, off in 11: 1.23 / 2.50 / 1.61 / 1.52); estimator 14 (the modes'
        # modal velocity without the rigid coordinates' motion, the stretch's share of the curvature on):
        # 1.04 / 1.80 / 1.07 / 0.71
        "link_a_mid": (1.04, ""),
        "link_b_mid": (1.80, ""),
        "torque_a": (1.07, ""),
        # the run's first sample of the joint forces is the continuum's (symgen.numerics.start):
        # torque_b's error fell from 0.19 % (its model's own sample at tau = 0) to 0.040 %
        "torque_b": (0.71, ""),
    },
    # the start's axial ringing charged (the axial part: 5.2e-4 of peak, a window from the undeformed start
    # with the axial dynamics kept): 1.48 -> 1.69
    # 1.68 -> 1.63 without the driver's harmonics below the rod's band (2026-11-27)
    # 1.63 -> 1.47 with estimator 6 (the backbone, the modes' drifts at each instant); 1.39 with 7; 1.60
    # with 10; 1.54 with 11; 1.56 with 14
    "slider_crank_paper": {"eta_mid": (1.56, "")},
    "six_bar_soft": {
        # without the driver's harmonics below each mode's band (2026-11-27): 1.12 / 1.22 / 1.23 / 1.03 /
        # 1.64 -> 0.75 / 1.19 / 1.21 / 1.03 / 1.66
        # estimator 6 (the backbone, the modes' drifts at each instant): 0.75 / 1.19 / 1.21 / 1.03 / 1.66 ->
        # 0.55 / 1.01 / 1.03 / 0.75 / 1.34; estimator 7: 0.55 / 0.97 / 0.99 / 0.58 / 1.23; estimator 10:
        # 0.70 / 0.79 / 0.81 / 0.59 / 1.40; estimator 11: 0.66 / 0.66 / 0.68 / 0.58 / 1.27 (the whole
        # estimate's parts added at the same instant too, not kept: coupler_mid 0.47); estimator 14:
        # 0.62 / 0.82 / 0.83 / 0.61 / 1.34
        "coupler_mid": (0.62, ""),
        "rocker_mid": (0.82, ""),
        "rocker_q3": (0.83, ""),
        "link_mid": (0.61, ""),
        # the run's first sample of the joint forces is the continuum's (symgen.numerics.start):
        # the driver torque's error fell from 1.09 % (its model's own sample at tau = 0) to 0.196 %
        "torque": (1.34, ""),
    },
    # DERIVE_VERSION 9 (the strain's -eps eta'^2 / 2): the true error fell 1.06 % -> 0.383 % (rod_mid),
    # 6.4e-4 -> 2.1e-4 (xB); the truncation part alone is 0.97x / 1.00x of it. The model-form part
    # charged the exact bar that term until it stopped (5.2e-3 -> 5.4e-4 on rod_mid, 1.4e-4 -> 1.4e-5 on
    # xB; ratios 2.32 and 1.67 before): the converged exact bar is 2.9e-4 off (docs/exact-bars.md)
    # estimator 6: 1.06 / 1.25 -> 1.05 / 1.21; estimator 7: 1.05 / 1.15; estimator 10: 1.02 / 1.02;
    # 11 without the crank's timing: the same; with it (measured on its branch, as 10a): 1.05 / 1.07;
    # 14: 1.02 / 1.06
    "slider_crank_torque_soft": {"rod_mid": (1.02, ""), "xB": (1.06, "")},
    "crank_rocker_steel": {
        # estimator 6: 1.13 / 1.06 / 0.90 / 1.08 -> 1.00 / 0.94 / 0.83 / 0.96; 7: 1.00 / 0.86 / 0.81 / 0.96;
        # 10: 0.93 / 0.92 / 0.75 / 0.89; 11: 0.85 / 0.92 / 0.74 / 0.81; 14: 0.76 / 0.80 / 0.78 / 0.71;
        # 15 (the static change with the links' slow axial force): 0.76 / 0.77 / 0.78 / 0.71: coupler_mid's
        # static change 6.3e-5 -> 3.4e-5 against the 2.0e-5 of von Karman vs exact below 10 per unit tau
        # (the tool's axial ringing from the start amplified before); that difference is the start's
        # ringing, 3.2e-4 in the links' bending band and 2.7e-4 above 50 per unit tau, which the drift
        # reads at 1.6e-4 (docs/exact-bars.md, "A fast axial force")
        "crank_tip": (0.76, ""),
        "coupler_mid": (0.77, ""),
        "rocker_mid": (0.78, ""),  # 0.91 before the driver's harmonics were taken out (2026-11-27)
        "torque": (0.71, ""),
    },
    # 1.49 before the coupled modes too (its model-form part is 1.6e-9: the change is the merged
    # axial treatment's, measured 2026-11-26); 1.11 with all 3 of the rod's functions quasi-static
    # (true 7.7e-4, estimate 8.6e-4: the richer model keeps its 2 added functions dynamic; estimator 10
    # and 11 the same)
    "slider_crank_steel_rest": {"rod_mid": (1.11, "")},
    # a slot guide at large deflection (benchmarks/scenes/slot_dyad.toml, bench_validation.SLOT_SCENES;
    # its reference tests/data/slot_dyad_exudyn.csv): the model-form part did not estimate slot guides
    # (0.38 / 0.60, the truncation and time parts alone) until estimator version 17, the guide's curvature
    # beyond its fourth order at each contact (model_form._Guide): model form 2.5e-4 / 2.2e-4 of peak
    # against true 2.3e-4 / 3.4e-4. Kept out (a steel guide driving a dyad at 35 rad/s, 6 % deflection,
    # benchmarks/validation/README.md "session 17"): 0.15 / 0.24 -> 1.05 / 1.14; a second kept-out dyad run
    # after it (two turns, 4.4 %): 0.49 / 0.40, its converged model 3.1e-4 / 5.3e-4 off against a model-form
    # part of 1.1e-4 / 1.2e-4; half of guide_mid's is the ANCF guide's axial stretch (EA x10 moves the
    # reference by 2.5e-4), which the axially rigid guide leaves out: 0.55 / 0.69 against that reference
    "slot_dyad": {"guide_end": (1.45, ""), "guide_mid": (1.18, "")},
}
CHEAP = ("slewing_arm",)

_RESULTS: dict[str, dict] = {}


def _honesty(scene: str) -> dict:
    if scene not in _RESULTS:
        _RESULTS[scene] = V.honesty(scene)
    return _RESULTS[scene]


def _cases() -> list:
    cases = []
    for scene, outputs in MEASURED.items():
        for out, (ratio, cause) in outputs.items():
            marks = [] if scene in CHEAP else [pytest.mark.slow]
            if cause:
                marks.append(pytest.mark.xfail(strict=True, reason=f"measured {ratio:.2f}: {cause}"))
            cases.append(pytest.param(scene, out, marks=marks, id=f"{scene}-{out}"))
    return cases


@pytest.mark.parametrize("scene, output", _cases())
def test_estimate_within_a_factor_two_of_the_true_error(scene: str, output: str) -> None:
    res = _honesty(scene)["outputs"][output]
    assert not res["below_noise"], f"{scene}.{output}: true error {res['true']:.2e} is below the reference's noise"
    assert res["estimate"] is not None
    ratio = res["estimate"] / res["true"]
    assert 0.5 <= ratio <= 2.0, f"{scene}.{output}: estimate {res['estimate']:.2e}, true {res['true']:.2e}"


def test_every_output_above_noise_is_listed() -> None:
    """The table above covers every output of the cheap scenes that is above noise (a new
    output, or one that rises above noise, has to be measured and listed)."""
    for scene in CHEAP:
        above = {k for k, o in _honesty(scene)["outputs"].items() if not o["below_noise"]}
        assert above == set(MEASURED[scene]), scene
