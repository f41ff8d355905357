"""Exudyn ANCF references of the exact bar (``effects.strain = "exact"``, docs/exact-bars.md).

The paper's slider-crank 6.1 (``tests/data/slider_crank_paper_si.toml``: lambda = 18246,
mu = 0.495, rigid crank at constant speed, massless slider) as a chain of ``ObjectANCFCable2D``
elements (the geometrically exact planar Euler-Bernoulli cable: eps = |r'| - 1,
kappa = r' x r'' / |r'|^2), built with the helpers of ``benchmarks/exudyn_models.py``.

    python benchmarks/exudyn_exact.py convergence     # mesh and step study (prints the table)
    python benchmarks/exudyn_exact.py write           # tests/data/slider_crank_paper_exudyn.csv

The reference written is the finest run of the study; its rows are the scene's output grid
(2 turns, 721 rows, one per degree of crank): t (s), rod_mid (m), unfiltered; compare
low-passed below CUTOFF cycles per turn (``symgen.apps.study.window_error``), which leaves out
the axial ringing whose phase neither model resolves alike.
"""

from __future__ import annotations

import math
import sys
import tomllib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from exudyn_models import _ancf_bar, _chord_deflection, _flywheel, _sensor, _solve

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "tests" / "data" / "slider_crank_paper_si.toml"
OUT = ROOT / "tests" / "data" / "slider_crank_paper_exudyn.csv"
TURNS = 2.0
ROWS_PER_TURN = 360  # one degree of crank: the axial ringing (~212 per turn) aliases to ~148, above CUTOFF
CUTOFF = 50.0  # cycles per turn: outputs are compared low-passed below it (the axial ringing left out)
FINE = (32, 23040)  # elements, steps per turn of the reference written


def slider_crank(elements: int, steps_per_turn: int, turns: float = TURNS) -> tuple[np.ndarray, np.ndarray]:
    """(t, rod_mid) on the output grid (ROWS_PER_TURN per turn) of the ANCF slider-crank."""
    import exudyn as exu
    from exudyn.itemInterface import CoordinateConstraint, MarkerBodyPosition, MarkerNodeCoordinate
    from exudyn.itemInterface import MarkerNodePosition, RevoluteJoint2D

    assert elements % 2 == 0 and steps_per_turn % ROWS_PER_TURN == 0
    with open(SCENE, "rb") as f:
        raw = tomllib.load(f)
    bars = {b["name"]: b for b in raw["bodies"]}
    omega = raw["scene"]["omega"]
    a, rod = bars["crank"]["length"], bars["rod"]
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mass = rod["density"] * rod["area"] * rod["length"]
    _, body, m_ground = _flywheel(mbs, omega, 1e8 * mass * a**2)
    m_tip = mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=[a, 0, 0]))
    nodes, _ = _ancf_bar(mbs, rod, (a, 0.0), 0.0, (0.0, a * omega), -a * omega / rod["length"], elements)
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_tip, mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))]))
    mbs.AddObject(
        CoordinateConstraint(
            markerNumbers=[m_ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[-1], coordinate=1))]
        )
    )
    sensors = [_sensor(mbs, nodes[k]) for k in (0, elements // 2, elements)]
    _solve(SC, mbs, omega, steps_per_turn, turns)
    A, M, B = (mbs.GetSensorStoredData(s) for s in sensors)
    t = A[:, 0]
    y = _chord_deflection(A[:, 1:3], M[:, 1:3], B[:, 1:3])
    grid = np.linspace(0.0, turns * 2 * math.pi / omega, int(round(turns * ROWS_PER_TURN)) + 1)
    idx = np.searchsorted(t, grid - 1e-9 * grid[-1])
    idx = np.minimum(idx, len(t) - 1)
    assert np.abs(t[idx] - grid).max() < 1e-6 * grid[-1], "the sensors missed the output grid"
    return grid, y[idx]


def convergence() -> None:
    runs = {}
    from symgen.apps.study import window_error

    for ne, st in ((16, 5760), (32, 5760), (32, 11520), (32, 23040), (64, 23040)):
        t, y = slider_crank(ne, st)
        runs[(ne, st)] = y
        print(f"{ne:3d} elements {st:6d} steps/turn: peak {np.abs(y).max():.6e}", flush=True)
    ref = runs[FINE]
    peak = np.abs(ref).max()
    dt = 2 * math.pi / ROWS_PER_TURN
    for k, y in runs.items():
        low = window_error(y, ref, dt, CUTOFF / (2 * math.pi), len(y))
        print(f"{k}: max |y - y{FINE}| / peak = {np.abs(y - ref).max() / peak:.2e}, low-passed {low:.2e}")


def write() -> None:
    t, y = slider_crank(*FINE)
    np.savetxt(OUT, np.column_stack([t, y]), delimiter=",", header="t,rod_mid", comments="", fmt="%.12e")
    print(f"wrote {OUT} ({len(t)} rows)")


if __name__ == "__main__":
    {"convergence": convergence, "write": write}[sys.argv[1]]()
