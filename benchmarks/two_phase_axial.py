"""Experiment (issue 19, the cost of a run that keeps the axial dynamics for its start's ringing):
the axial dynamics kept only while a damped start ringing lasts, then the axial quasi-static
model from the state reached, at a switch time given by hand. Since session 13 symgen does this
itself where ``effects.axial = "auto"`` finds the ringing damped (``Scene.axial_switch``, the switch
time measured by ``symgen.numerics.axial_drift.ringing_end``); this script runs it at any time.

    python benchmarks/two_phase_axial.py SCENE T_SWITCH [--set KEY=VALUE ...] [--ref REF.csv.gz]

Runs the scene with ``effects.axial = "dynamic"`` from 0 to T_SWITCH (tau, rounded to the output
grid), then with ``effects.axial = "quasi_static"`` from that state
(``symgen.numerics.start.continued_start`` of the run's q and v at T_SWITCH: the quasi-static
axial amplitudes re-solved there), and the whole
run with the axial dynamics kept; prints IDAS steps, CPU s and, given a reference CSV (the
columns of symgen's result, e.g. ``benchmarks/validation/ref/*.csv.gz``), each output's max
|error| / peak for both, and their difference to each other.
"""

from __future__ import annotations

import argparse
import gzip
import time

import numpy as np

from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from symgen.numerics.start import continued_start
from symgen.numerics.units import result_units
from symgen.scene.loader import load_scene


def two_phase(path: str, t_switch: float, sets: list[str]) -> tuple[object, object, object]:
    """(the whole run with the axial dynamics kept, (tau, outputs) of the two-phase run, stats)."""
    dyn = load_mechanism(load_scene(path, [*sets, "effects.axial=dynamic"]))
    qs = load_mechanism(load_scene(path, [*sets, "effects.axial=quasi_static"]))
    h = dyn.scene.simulation.output_step
    t_s = round(t_switch / h) * h
    tic = time.process_time()
    whole = simulate(dyn)
    whole_s = time.process_time() - tic
    tic = time.process_time()
    first = simulate(dyn, t_end=t_s)
    names = [c.name for c in dyn.coords]
    assert [c.name for c in qs.coords] == names, "the two models' coordinates differ"
    second = simulate(qs, t0=t_s, initial=continued_start(qs, t_s, first.q[-1], first.v[-1]))
    split_s = time.process_time() - tic
    tau = np.concatenate([first.tau, second.tau[1:]])
    out = np.vstack([first.outputs, second.outputs[1:]])
    stats = {
        "t_switch": t_s,
        "whole": (whole.steps, whole_s),
        "split": (first.steps, second.steps, split_s),
    }
    return whole, (tau, out), stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("t_switch", type=float)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--ref", default=None)
    args = ap.parse_args()
    whole, (tau, out), stats = two_phase(args.scene, args.t_switch, args.sets)
    print(
        f"switch at tau {stats['t_switch']:.4g}; whole run with the axial dynamics: {stats['whole'][0]} IDAS steps, "
        f"{stats['whole'][1]:.1f} s CPU; two-phase: {stats['split'][0]} + {stats['split'][1]} steps, "
        f"{stats['split'][2]:.1f} s CPU"
    )
    units = result_units(load_scene(args.scene, args.sets))
    t1, y1 = units.convert(whole.tau, whole.outputs)
    t2, y2 = units.convert(tau, out)
    names = list(whole.output_names)
    print(
        "two-phase vs whole:",
        " ".join(f"{n} {np.abs(y2[:, j] - y1[:, j]).max() / np.abs(y1[:, j]).max():.2e}" for j, n in enumerate(names)),
    )
    if args.ref:
        with gzip.open(args.ref, "rt") as f:
            head = f.readline().strip().split(",")
            ref = np.loadtxt(f, delimiter=",", ndmin=2)
        for label, (t, y) in (("whole", (t1, y1)), ("two-phase", (t2, y2))):
            errs = []
            for j, n in enumerate(names):
                if n in head:
                    yr = ref[:, head.index(n)]
                    errs.append(f"{n} {np.abs(np.interp(ref[:, 0], t, y[:, j]) - yr).max() / np.abs(yr).max():.2e}")
            print(f"{label} vs reference:", " ".join(errs))


if __name__ == "__main__":
    main()
