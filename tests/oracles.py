"""Numerical helpers shared by the physics tests (independent of symgen's internals)."""
from __future__ import annotations

import numpy as np


def zero_crossing_frequency(t: np.ndarray, y: np.ndarray) -> float:
    """Angular frequency of a (near-)harmonic signal from its upward zero crossings.

    Crossing times are located by cubic interpolation through 4 samples around each sign
    change; the frequency is 2 pi / (mean period between the first and last crossing).
    """
    y = y - 0.0
    idx = np.where((y[:-1] < 0) & (y[1:] >= 0))[0]
    times = []
    for i in idx:
        lo, hi = max(i - 1, 0), min(i + 3, len(t))
        tt, yy = t[lo:hi], y[lo:hi]
        c = np.polyfit(tt - t[i], yy, min(3, len(tt) - 1))
        roots = np.roots(c)
        roots = roots[np.isreal(roots)].real
        h = t[i + 1] - t[i]
        roots = roots[(roots >= -1e-12) & (roots <= h + 1e-12)]
        times.append(t[i] + (roots[0] if len(roots) else -y[i] * h / (y[i + 1] - y[i])))
    if len(times) < 3:
        raise ValueError("too few zero crossings to measure a frequency")
    periods = (times[-1] - times[0]) / (len(times) - 1)
    return 2 * np.pi / periods


def write_scene(path, text: str):
    path.write_text(text)
    return path
