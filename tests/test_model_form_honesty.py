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
#: noise), and the cause where outside [0.5, 2]
TRUNCATION_FILTERED = (
    "the truncation part is the richer model's change below 50 cycles per turn; this output's error is "
    "the ringing above it"
)
MEASURED: dict[str, dict[str, tuple[float, str]]] = {
    "slewing_arm": {"tip": (0.71, ""), "mid": (0.69, ""), "torque": (1.78, "")},
    "double_pendulum_alu": {
        "upper_tip": (0.05, "truncation under-estimated: " + TRUNCATION_FILTERED),
        "lower_tip": (0.92, ""),
    },
    "five_bar_elastic": {
        "link_a_mid": (0.61, ""),
        "link_b_mid": (0.86, ""),
        "torque_a": (0.26, "a driver torque whose error is neither model form nor the +2 functions' truncation"),
        "torque_b": (
            0.07,
            "a driver torque 0.21 % off with von Karman and with the exact bar alike (0.11 % converged): "
            "neither part sees it",
        ),
    },
    "slider_crank_paper": {"eta_mid": (1.51, "")},
    "six_bar_soft": {
        "coupler_mid": (1.31, ""),
        "rocker_mid": (0.70, ""),
        "rocker_q3": (0.72, ""),
        "link_mid": (0.45, "the link's phase drift over two turns, under-estimated by the model-form drift part"),
        "torque": (0.12, "the driver torque's 1.09 % is truncation (0.56 % converged) the +2 functions' rerun misses"),
    },
    "slider_crank_torque_soft": {
        "rod_mid": (0.58, ""),
        "xB": (0.41, "the slider's drift under the exact bar's remaining error (1.8 % on the rod, exact6's cause)"),
    },
    "crank_rocker_steel": {
        "crank_tip": (0.45, "the crank's truncation under-estimated by the +2 functions' rerun (0.084 % vs 0.022 %)"),
        "coupler_mid": (0.64, ""),
        "rocker_mid": (0.76, ""),
        "torque": (0.49, "the driver torque's truncation under-estimated, as the crank's"),
    },
    "slider_crank_steel_rest": {"rod_mid": (0.84, "")},
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
