"""Plots of outputs against tau (matplotlib, no display needed)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from symgen.outputs import printable

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


def plot_outputs(
    path: str | os.PathLike,
    tau: np.ndarray,
    values: np.ndarray,
    names: list[str],
    kinds: list[str],
    title: str,
    partial: bool = False,
    turn: float | None = None,
    units=None,
) -> None:
    """One panel per output, shared time axis (in crank turns when ``turn`` is given, in the
    time unit of ``turn`` and ``tau``); ``units`` (``symgen.numerics.units.ResultUnits``) labels the
    columns with their units."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(names)
    # constrained layout keeps the figure title (suptitle) above the panels and the stacked
    # y labels apart, whatever the number of outputs
    fig, axes = plt.subplots(n, 1, figsize=(8, 1.7 * n + 1.1), sharex=True, squeeze=False, layout="constrained")
    x = tau / turn if turn else tau
    for k, ax in enumerate(axes[:, 0]):
        y = values[:, k]
        si = units is not None and units.system == "SI"
        unit = f" [{units.outputs[k].unit}]" if si else ""
        label = (SI_LABELS if si else LABELS).get(kinds[k], "")
        if kinds[k] == "closure_residual":
            # its size is what matters: |r| on a log axis, a few decades labelled
            from matplotlib.ticker import LogLocator

            ax.semilogy(x, np.maximum(np.abs(y), 1e-18), lw=0.9, color="C0")
            ax.yaxis.set_major_locator(LogLocator(numticks=5))
            label = "|" + label + "|"
        else:
            ax.plot(x, y, lw=0.9, color="C0")
            ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        ax.set_ylabel(f"{names[k]}{unit}\n{label}", fontsize=8)
        ax.grid(True, lw=0.3, alpha=0.6)
    si_time = units is not None and units.system == "SI"
    axes[-1, 0].set_xlabel("crank turns" if turn else ("t [s]" if si_time else r"$\tau = \omega t$"))
    if turn:
        for ax in axes[:, 0]:
            for c in range(1, int(math.floor(x[-1])) + 1):
                ax.axvline(c, color="0.7", lw=0.5)
    fig.suptitle(
        printable(title) + ("  [PARTIAL RUN]" if partial else ""), fontsize=10, parse_math=False
    )  # a file name is text, never mathtext
    fig.align_ylabels(axes[:, 0])
    from symgen.outputs import atomic_path

    try:
        with atomic_path(path) as tmp:  # format from the suffix: .png, .svg or .pdf
            fig.savefig(tmp, dpi=120, format=Path(path).suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)


def plot_run(plot) -> None:
    """Draw the plot a run's writer asked for (``symgen.numerics.results.OutputsPlot``): the
    ``--plot`` of ``symgen simulate`` / ``quasistatic`` and of ``symgen.api``'s runs."""
    plot_outputs(
        plot.path,
        plot.time,
        plot.values,
        plot.names,
        plot.kinds,
        plot.title,
        partial=plot.partial,
        turn=plot.turn,
        units=plot.units,
    )
