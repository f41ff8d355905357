"""Results files: OUT.csv + OUT.json (the contract), written atomically, CSV first.

A complete run writes ``OUT.csv``, then its sidecar ``OUT.json`` (status "complete"), then the
plot if asked, and removes any ``OUT.partial.*`` of an earlier run. A run that stops early
(a solver failure: status "partial"; SIGINT/SIGTERM: status "interrupted") writes
``OUT.partial.csv`` / ``OUT.partial.json`` (the cause in ``failure``) and ``PLOT.partial.png``
instead, and removes any older ``OUT.csv`` / ``OUT.json`` / ``PLOT`` first, so that nothing
left behind looks like a complete result. The sidecar is written after its CSV and removed
before it is rewritten: a failed write never leaves a JSON beside a CSV it does not describe.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from symgen.outputs import atomic_write, remove

__all__ = ["ResultFiles", "atomic_write", "csv_text", "partial_paths", "write_results"]


def csv_text(tau: np.ndarray, values: np.ndarray, names: list[str], time_name: str = "tau") -> str:
    lines = [",".join([time_name, *names])]
    for t, row in zip(tau, values):
        lines.append(",".join(repr(float(x)) for x in (t, *row)))
    return "\n".join(lines) + "\n"


def partial_paths(out: Path) -> tuple[Path, Path]:
    out = Path(out)
    return out.with_name(out.stem + ".partial.csv"), out.with_name(out.stem + ".partial.json")


def partial_plot(plot: Path) -> Path:
    plot = Path(plot)
    return plot.with_name(plot.stem + ".partial" + plot.suffix)


class ResultFiles:
    """The files of one run: ``OUT.csv``, ``OUT.json``, ``PLOT`` and their ``.partial`` twins."""

    def __init__(self, out: str | os.PathLike, plot: str | os.PathLike | None = None) -> None:
        self.out = Path(out)
        self.plot = None if plot is None else Path(plot)
        self.partial_written = False
        self.complete_written = False

    def complete_paths(self) -> list[Path]:
        return [self.out, self.out.with_suffix(".json")] + ([self.plot] if self.plot else [])

    def partial_paths(self) -> list[Path]:
        return [*partial_paths(self.out)] + ([partial_plot(self.plot)] if self.plot else [])

    def csv_json(self, complete: bool) -> tuple[Path, Path]:
        return (self.out, self.out.with_suffix(".json")) if complete else partial_paths(self.out)

    def plot_path(self, complete: bool) -> Path | None:
        if self.plot is None:
            return None
        return self.plot if complete else partial_plot(self.plot)

    def write(self, tau, values, names, meta: dict, complete: bool = True, time_name: str = "tau") -> Path:
        """CSV, then its JSON sidecar; return the CSV path. The first column is ``time_name``
        (``tau``, or ``t`` in seconds for SI results). Stale files of the other kind go first;
        if a write fails, neither file of this run is left."""
        csv_path, json_path = self.csv_json(complete)
        remove(self.partial_paths() if complete else self.complete_paths())
        remove([json_path])
        text = csv_text(np.asarray(tau), np.asarray(values).reshape(len(tau), -1), names, time_name)
        try:
            atomic_write(csv_path, text)
            atomic_write(json_path, json.dumps(meta, indent=1, default=_jsonable) + "\n")
        except BaseException:
            remove([csv_path, json_path])
            raise
        self.partial_written = not complete
        self.complete_written = complete
        return csv_path

    def discard(self) -> None:
        """A run failed: remove every complete result of this name, and the partial ones
        unless this run wrote them. (A failure after this run's complete CSV and JSON were
        written -- the plot -- leaves them: they are complete and correct.)"""
        if self.complete_written:
            remove([self.plot] if self.plot else [])
            return
        remove(self.complete_paths() + ([] if self.partial_written else self.partial_paths()))


def write_results(out: str | os.PathLike, tau, values, names, meta: dict, complete: bool = True,
                  time_name: str = "tau") -> Path:
    """Write the CSV and its JSON sidecar (``ResultFiles.write``); return the CSV path written."""
    return ResultFiles(out).write(tau, values, names, meta, complete, time_name)


def _jsonable(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x)}")
