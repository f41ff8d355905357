"""A mode's band content that the driver forces is charged the change of its forced response, not a
phase drift (symgen.numerics.model_form.perturbed_along, estimator version 10), against directly
integrated oscillators (scipy, no formula of the estimate's): x'' + c W^2 x' + W^2 x = load, and the
same with W moved by the fraction SHIFT; the measured change is the largest difference of the two
runs, the estimate the largest of its envelope of the first-order change.

The cases: a steady load far from the resonance (0.8 W), near it (0.95 W), at it, each with the
start's transient (both runs start at rest: the free ringing the load's onset excites), and a free
ringing released at the start with a forced part of about its size. The drift rule of versions 5-7
charged all of the band's content the free vibration's phase drift, omega x shift x its age (at most
the decay time 2 / (c W^2)): 2.8x the measured change at 0.8 W, 1.8x at 0.95 W, 1.2x at the
resonance, 4.0x the ringing with a forced part at 0.85 W (the first and the last checked below
against the drift rule's own formula, so that they can fail it); the estimate 0.99x, 1.01x, 1.02x,
0.96x.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from symgen.numerics import model_form

W, SHIFT, SPAN = 5.0, 2.0e-3, 120.0
ZETA = 0.02  # c W / 2: decay time 1 / (ZETA W) = 10
C = 2.0 * ZETA / W  # Kelvin-Voigt c (c W^2 = 2 ZETA W)
TAU = np.linspace(0.0, SPAN, 12001)
BAND = (0.75 * W, 1.25 * W)


def _run(w: float, load_freq: float, load: float, x0: float) -> np.ndarray:
    def rhs(t: float, z: np.ndarray) -> list[float]:
        return [z[1], load * np.cos(load_freq * t) - w**2 * z[0] - C * W**2 * z[1]]

    sol = solve_ivp(rhs, (0.0, SPAN), [x0, 0.0], t_eval=TAU, rtol=1e-11, atol=1e-14, method="DOP853")
    return np.asarray(sol.y[0])


CASES = {  # load frequency / W, load, released amplitude
    "forced far (0.8 W)": (0.8, 1.0, 0.0),
    "forced near (0.95 W)": (0.95, 1.0, 0.0),
    "forced at resonance": (1.0, 1.0, 0.0),
    "free ringing and a forced part": (0.85, 1.0, 0.2),
}


@pytest.mark.parametrize("case", list(CASES))
def test_forced_content_is_charged_its_change_not_a_drift(case):
    r, load, x0 = CASES[case]
    y = _run(W, r * W, load, x0)
    measured = float(np.abs(_run(W * (1.0 + SHIFT), r * W, load, x0) - y).max())
    mode = (TAU, np.full(len(TAU), W), np.full(len(TAU), SHIFT))
    got = float(model_form.perturbed_along(TAU, y, mode, C, BAND).max())
    ratio = got / measured
    assert 0.5 <= ratio <= 2.0, (case, ratio)
    # the drift rule (versions 5-7): the band's envelope times W SHIFT times its age, at most the
    # decay time; off the resonance it charges the forced response as a free vibration's drift
    env = np.abs(model_form._band_signal(TAU, y, BAND))
    drift = float((env * np.minimum(W * SHIFT * np.minimum(TAU, 1.0 / (ZETA * W)), 2.0)).max())
    if r < 0.9:
        assert drift / measured > 2.0, (case, drift / measured)


def test_a_sweeping_mode_follows_its_own_phase():
    """The mode's frequency sweeps along a turn, as a crank-driven bar's does (c_alu_long's rod:
    4.1-7.2 per unit tau): W(t) = W (1 + 0.25 sin t), driven at harmonic 5 of the unit rate and
    released ringing. Measured against the oscillator with W(t) (1 + SHIFT): 0.87x; at the mean
    frequency 0.61x."""

    def wt(t: float) -> float:
        return W * (1.0 + 0.25 * np.sin(t))

    def run(f: float) -> np.ndarray:
        def rhs(t: float, z: np.ndarray) -> list[float]:
            w = f * wt(t)
            return [z[1], np.cos(5.0 * t) - w**2 * z[0] - C * w**2 * z[1]]

        return np.asarray(solve_ivp(rhs, (0.0, SPAN), [0.2, 0.0], t_eval=TAU, rtol=1e-11, atol=1e-14).y[0])

    y = run(1.0)
    measured = float(np.abs(run(1.0 + SHIFT) - y).max())
    w_t = wt(TAU)
    mode = (TAU, w_t, np.full(len(TAU), SHIFT))
    got = float(model_form.perturbed_along(TAU, y, mode, C, (0.7 * W, 1.3 * W)).max())
    assert 0.5 <= got / measured <= 2.0, got / measured
    # at the mode's mean frequency the free ringing's phase is lost on the sweep
    flat = (TAU, np.full(len(TAU), W), np.full(len(TAU), SHIFT))
    assert float(model_form.perturbed_along(TAU, y, flat, C, (0.7 * W, 1.3 * W)).max()) < got


#: the five-bar's link modes (docs/exact-bars.md, "The drift's modal coordinate"): 26.1 per unit
#: tau, Kelvin-Voigt sigma = c W^2 / 2 = 0.34, the shift swinging with the loop's load at the
#: driver's rate 1 (and 2) within each turn, from -3e-5 to 6.2e-4 about a mean of 5e-5
W5, SIGMA5 = 26.1, 0.34
C5 = 2.0 * SIGMA5 / W5**2
SPAN5 = 4.0 * np.pi
TAU5 = np.linspace(0.0, SPAN5, 20001)
SWINGS = {
    "held at its mean": lambda t: 5.4e-5 + 0.0 * t,
    "swinging at the driver's rate": lambda t: 5.4e-5 + 3e-4 * np.sin(t),
    "swinging at twice it": lambda t: 5.4e-5 + 3e-4 * np.sin(2.0 * t),
    "peaked with the load": lambda t: -3e-5 + 6.5e-4 * np.maximum(0.0, np.cos(t)) ** 12,
}
CONTENTS = {  # released amplitude, loads (harmonic of the driver's rate, amplitude)
    "free ringing": (1.0, ()),
    "harmonics 21, 23, 26, 27 forced": (0.0, ((21, 0.3), (23, 0.3), (26, 1.0), (27, 1.0))),
    "ringing and harmonic 24": (1.0, ((24, 30.0),)),
}


def _parametric(swing, x0: float, loads, on: bool) -> np.ndarray:
    def rhs(t: float, z: np.ndarray) -> list[float]:
        s = swing(t) if on else 0.0
        f = sum(a * np.cos(k * t) for k, a in loads)
        return [z[1], f - W5**2 * (1.0 + 2.0 * s) * z[0] - C5 * W5**2 * z[1]]

    sol = solve_ivp(rhs, (0.0, SPAN5), [x0, 0.0], t_eval=TAU5, rtol=1e-11, atol=1e-14, method="DOP853")
    return np.asarray(sol.y[0])


@pytest.mark.parametrize("content", list(CONTENTS))
@pytest.mark.parametrize("swing", list(SWINGS))
def test_a_shift_swinging_within_a_turn(swing, content):
    """The first-order response to a shift that swings with the loop's load within each turn, against
    the integrated parametric oscillator x'' + c W^2 x' + W^2 (1 + 2 s(t)) x = f(t): over each of the
    spans tau 0-3 (the start's ringing), 3-2 pi, 2 pi-4 pi the estimate's largest |change| is
    0.98-1.17x the measured one (the signed phase integral of the swing, bounded, and the mean's
    secular part both followed). What this shows: the oscillator's response to the five-bar's
    swinging shift is right, so the five-bar's over-read with STRETCH_CURVATURE (drift 2.0-2.4x the
    whole difference above 15 per unit tau in the second turn) was not the response; it was the
    modal coordinate (tests/test_model_form_stretch.py::test_five_bar_modal_coordinate_is_the_links_vibration).
    This test passes on estimator version 13 too."""
    x0, loads = CONTENTS[content]
    s = SWINGS[swing]
    y = _parametric(s, x0, loads, on=False)
    moved = _parametric(s, x0, loads, on=True) - y
    got = model_form.perturbed_along(TAU5, y, (TAU5, np.full(len(TAU5), W5), s(TAU5)), C5, (0.75 * W5, 1.25 * W5))
    for a, b in ((0.0, 3.0), (3.0, 2 * np.pi), (2 * np.pi, SPAN5 + 1e-9)):
        span = (TAU5 >= a) & (TAU5 < b)
        ratio = float(got[span].max() / np.abs(moved[span]).max())
        assert 0.8 <= ratio <= 1.25, (a, ratio)
