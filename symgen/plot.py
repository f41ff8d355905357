"""Plots of outputs against tau (matplotlib, no display needed)."""
from __future__ import annotations

import math
import os

import numpy as np

LABELS = {
    "chord_deflection": "deflection from chord / l",
    "chord_elongation": "chord elongation (|c| - l) / l",
    "deflection": r"$\eta$ (bar frame)",
    "axial": r"$\zeta$",
    "slope": r"$\eta'$ (rad)",
    "elastic_displacement": r"elastic displacement / $l_0$",
    "position": r"position / $l_0$",
    "angle": r"$\theta$ (rad)",
    "reaction": r"force / $m l_0^2\omega^2$",
    "driver_torque": r"torque / $m l_0^3\omega^2$",
    "energy": r"energy / $m l_0^3\omega^2$",
    "closure_residual": "closure residual",
}
#: The same quantities in SI results (the unit is given with the name).
SI_LABELS = {
    "chord_deflection": "deflection from chord",
    "chord_elongation": "chord elongation |c| - l",
    "deflection": r"$\eta$ (bar frame)",
    "axial": r"$\zeta$",
    "slope": r"$\eta'$",
    "elastic_displacement": "elastic displacement",
    "position": "position",
    "angle": r"$\theta$",
    "reaction": "force",
    "driver_torque": "torque",
    "energy": "energy",
    "closure_residual": "closure residual",
}


def plot_outputs(path: str | os.PathLike, tau: np.ndarray, values: np.ndarray, names: list[str],
                 kinds: list[str], title: str, partial: bool = False, turn: float | None = None,
                 units=None) -> None:
    """One panel per output, shared time axis (in crank turns when ``turn`` is given, in the
    time unit of ``turn`` and ``tau``); ``units`` (``symgen.run.units.ResultUnits``) labels the
    columns with their units."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(names)
    fig, axes = plt.subplots(n, 1, figsize=(8, 1.9 * n + 0.8), sharex=True, squeeze=False)
    x = tau / turn if turn else tau
    for k, ax in enumerate(axes[:, 0]):
        y = values[:, k]
        ax.plot(x, y, lw=0.9, color="C0")
        si = units is not None and units.system == "SI"
        unit = f" [{units.outputs[k].unit}]" if si else ""
        ax.set_ylabel(f"{names[k]}{unit}\n{(SI_LABELS if si else LABELS).get(kinds[k], '')}", fontsize=8)
        ax.grid(True, lw=0.3, alpha=0.6)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        if kinds[k] == "closure_residual":
            ax.set_yscale("symlog", linthresh=1e-16)
    si_time = units is not None and units.system == "SI"
    axes[-1, 0].set_xlabel("crank turns" if turn else ("t [s]" if si_time else r"$\tau = \omega t$"))
    if turn:
        for ax in axes[:, 0]:
            for c in range(1, int(math.floor(x[-1])) + 1):
                ax.axvline(c, color="0.7", lw=0.5)
    fig.suptitle(title + ("  [PARTIAL RUN]" if partial else ""), fontsize=10)
    fig.tight_layout()
    from .outputs import atomic_path
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=120, format="png")
    finally:
        plt.close(fig)
