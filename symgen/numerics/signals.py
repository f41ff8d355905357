"""Sampled signals: the zero-phase low-pass that every comparison of two runs' outputs uses
(``symgen study``, ``symgen effects --measure``, the error estimate of a run), with its cutoff.

The stiff axial modes ring at hundreds of periods per turn and mechanisms with several elastic
bars ring in their high bending modes: comparisons keep the response below ``DEFAULT_CUTOFF``
cycles per crank turn (docs: the formulation's "axial outputs compared between models must be
low-pass filtered").
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DEFAULT_CUTOFF", "edge", "lowpass"]

DEFAULT_CUTOFF = 50.0  # cycles per crank turn (or per 2 pi of tau without an angle driver)


def lowpass(y: np.ndarray, dt: float, cutoff: float) -> np.ndarray:
    """Zero-phase low-pass of a sampled signal: keep frequencies below ``cutoff`` (cycles per
    unit of time), with a raised-cosine roll-off from 0.8 cutoff. The signal is mirrored first
    (continuous when made periodic); within about 1/cutoff of either end the result carries
    the filter's edge transient, which ``window_error`` leaves out."""
    y = np.asarray(y, dtype=float)
    n = len(y)
    if n < 4:
        return y.copy()
    ext = np.concatenate([y, y[::-1]])
    spec = np.fft.rfft(ext)
    f = np.fft.rfftfreq(2 * n, dt)
    gain = np.clip((cutoff - f) / (0.2 * cutoff), 0.0, 1.0)
    gain = 0.5 - 0.5 * np.cos(np.pi * gain)
    return np.fft.irfft(spec * gain, 2 * n)[:n]


def edge(dt: float, cutoff: float) -> int:
    """Samples at each end of a filtered signal left out of comparisons (one cutoff period)."""
    return int(math.ceil(1.0 / (cutoff * dt)))
