"""The model-form estimate's phase drifts of several modes add as signals, each at its own phase
(symgen.numerics.model_form._drift_along), against a directly integrated oracle: two damped
oscillators at different frequencies, each hardened by a known fraction of its frequency, both
ringing from the start (one released, one kicked), each decaying at its own rate; the output is
their sum. The change of the output
between the hardened and the original system (integrated by scipy, no phase formula) is what the
estimate must match: the sum of the modes' drift sizes (envelope x phase) reads their largest
values as if they were in phase at the same instant, which they are not.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from symgen.numerics import model_form

OMEGAS = (5.0, 8.3)
SHIFTS = (2.0e-3, 1.5e-3)
DAMPING = (0.004, 0.012)  # damping ratios
SPAN = 40.0


def _output(tau: np.ndarray, hardened: bool) -> np.ndarray:
    """x1 + x2: x1 released from 1, x2 kicked (rate 8) at tau = 0; their frequencies moved by
    ``SHIFTS`` where ``hardened``."""
    w = [o * (1.0 + s) if hardened else o for o, s in zip(OMEGAS, SHIFTS)]

    def rhs(t: float, z: np.ndarray) -> list[float]:
        x1, v1, x2, v2 = z
        return [v1, -(w[0] ** 2) * x1 - 2 * DAMPING[0] * w[0] * v1, v2, -(w[1] ** 2) * x2 - 2 * DAMPING[1] * w[1] * v2]

    got = solve_ivp(rhs, (0.0, SPAN), [1.0, 0.0, 0.0, 8.0], t_eval=tau, rtol=1e-11, atol=1e-13)
    return np.asarray(got.y[0] + got.y[2])


def test_drifts_of_two_modes_add_as_signals():
    tau = np.linspace(0.0, SPAN, 8001)
    y, hard = _output(tau, False), _output(tau, True)
    measured = float(np.abs(hard - y).max())
    bands = model_form._bands(list(OMEGAS))
    drifts = [
        model_form._drift_along(tau, y, w, (tau, np.full(len(tau), s)), SPAN, band)
        for w, s, band in zip(OMEGAS, SHIFTS, bands)
    ]
    signal = float(np.abs(sum(drifts)).max())
    # the sizes (envelope x phase) summed at each instant: the drifts of estimator version 6
    sizes = float(
        np.max(
            sum(model_form._band_envelope(tau, y, w, band) * w * s * tau for w, s, band in zip(OMEGAS, SHIFTS, bands))
        )
    )
    assert 0.8 <= signal / measured <= 1.25, (signal, measured)
    assert signal < sizes
    # each mode's drift alone is its own measured change: the signal, not only its size
    for k, (w, band) in enumerate(zip(OMEGAS, bands)):
        alone = np.real(model_form._band_signal(tau, hard - y, w, band))
        c = float(np.dot(alone, drifts[k]) / (np.linalg.norm(alone) * np.linalg.norm(drifts[k])))
        assert c > 0.9, (k, c)
