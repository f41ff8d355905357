"""Section ``spinup``: issue 12's torque-driven elastic slider-crank under gravity spinning up
from rest (``scenes/slider_crank_spinup.toml``) against Exudyn (``exudyn_spinup.py``).

Measures, over 20 tau (the crank reaches ~6 per tau, 11 turns): (a) symgen's tolerance and
function counts, Exudyn's steps and elements; (b) the energy balance E - T theta of both;
(c) two rod stiffnesses (mu = 10, 100); (d) differences vs time and vs crank angle.
Errors: max |d theta| (rad) and max |d rod_mid| / peak up to tau = 10, 16, 20.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
SCENE = HERE / "scenes" / "slider_crank_spinup.toml"
TS = (10.0, 16.0, 20.0)


def _symgen(mu: float, na, nt: int, rtol: float) -> dict:
    from symgen.api import simulate_scene

    ov = [
        f"bodies.rod.mu={mu}",
        f"simulation.rtol={rtol}",
        f"simulation.atol={rtol * 1e-2}",
        f"bodies.rod.transverse_modes={nt}",
    ]
    ov += ["effects.axial=inextensible"] if na == "inx" else [f"bodies.rod.axial_modes={na}"]
    t0 = time.perf_counter()
    r = simulate_scene(SCENE, ov)
    th, E = r.column("theta"), r.column("energy")
    return {
        "t": r.tau,
        "theta": th,
        "rod_mid": r.column("rod_mid"),
        "balance": E - 0.1 * th,
        "wall": time.perf_counter() - t0,
    }


def _exudyn(mu: float, elements: int, steps: int, rho: float = 0.9) -> dict:
    from exudyn_spinup import spinup

    t, o, cpu = spinup(elements, steps, 20.0, mu, rho, energy_every=max(1, steps // 50))
    E = o["energy"]
    ok = ~np.isnan(E)
    o["balance"] = np.where(ok, E - 0.1 * o["theta"], np.nan)
    o["t"], o["wall"] = t, cpu
    return o


def _diff(a: dict, b: dict) -> list[str]:
    tau = np.arange(0.0, 20.0 + 1e-9, 0.01)
    th = [np.interp(tau, d["t"], d["theta"]) for d in (a, b)]
    rm = [np.interp(tau, d["t"], d["rod_mid"]) for d in (a, b)]
    cells = []
    for T in TS:
        m = tau <= T + 1e-9
        cells.append(
            f"{np.abs(th[0] - th[1])[m].max():.1e} / {np.abs(rm[0] - rm[1])[m].max() / np.abs(rm[1][m]).max():.1e}"
        )
    # vs crank angle (theta is monotone here): phase-insensitive
    g = np.linspace(0.0, min(th[0][-1], th[1][-1]), 20000)
    ra, rb = (np.interp(g, t_, r_) for t_, r_ in zip(th, rm))
    cells.append(f"{np.abs(ra - rb).max() / np.abs(rb).max():.1e}")
    return cells


def _drift(d: dict) -> str:
    b = d["balance"]
    ok = ~np.isnan(b)
    return f"{np.abs(b[ok] - b[ok][0]).max():.1e}"


def run(repeats: int = 1, quick: bool = False) -> str:
    out = [
        "## Torque-driven spin-up (issue 12): tolerance, energy, functions, the reference",
        "",
        "`scenes/slider_crank_spinup.toml` (rigid crank 0.5, rod 1 with lambda 1e4, slider mass 0.5, torque 0.1,",
        "gravity 0.1, from rest; dimensionless) over 20 tau (~11 turns); Exudyn: `exudyn_spinup.py` (ANCF cable,",
        "generalized-alpha rho_inf 0.9, fixed step). Cells: max |d theta| rad / max |d rod_mid| / peak up to",
        'tau = 10, 16, 20; "vs angle": rod_mid compared at equal crank angle; E - W: max drift of kinetic +',
        "elastic + potential minus the torque's work (total work ~7).",
        "",
    ]
    grid = {
        10.0: [
            ("sg", 9, 8, 1e-9),
            ("sg", 3, 4, 1e-6),
            ("sg", 3, 4, 1e-8),
            ("sg", 3, 4, 1e-10),
            ("sg", 3, 6, 1e-8),
            ("sg", 5, 4, 1e-8),
            ("sg", 7, 4, 1e-8),
            ("sg", 9, 4, 1e-8),
            ("sg", "inx", 4, 1e-8),
            ("ex", 4, 200),
            ("ex", 8, 200),
            ("ex", 16, 200),
            ("ex", 8, 100),
            ("ex", 8, 400),
            ("ex", 8, 800),
            ("ex", 8, 1600),
            ("ex", 16, 800),
            ("ex", 8, 3200),
        ],
        100.0: [
            ("sg", 9, 8, 1e-9),
            ("sg", 3, 4, 1e-8),
            ("sg", 5, 4, 1e-8),
            ("ex", 4, 400),
            ("ex", 8, 400),
            ("ex", 16, 400),
            ("ex", 8, 200),
            ("ex", 8, 800),
            ("ex", 8, 1600),
            ("ex", 8, 3200),
        ],
    }
    if quick:
        grid = {10.0: [("sg", 5, 4, 1e-8), ("sg", 3, 4, 1e-8), ("ex", 8, 200), ("ex", 8, 400)]}
    for mu, runs in grid.items():
        res = {}
        for r in runs:
            res[r] = _symgen(mu, r[1], r[2], r[3]) if r[0] == "sg" else _exudyn(mu, r[1], r[2])
        ref_sg = res[runs[0]]
        ex_runs = [r for r in runs if r[0] == "ex"]
        ref_ex = res[ex_runs[-1]]
        out += [
            f"### mu = {mu:g} (peak rod_mid {np.abs(ref_sg['rod_mid']).max():.3g})",
            "",
            f"| run | vs symgen {runs[0][1]}+{runs[0][2]} rtol {runs[0][3]:g}: tau 10 | 16 | 20 | vs angle "
            f"| vs Exudyn {ex_runs[-1][1]} el x {ex_runs[-1][2]}/tau: 10 | 16 | 20 | vs angle | E - W | s |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in runs:
            d = res[r]
            name = f"symgen {r[1]}+{r[2]} rtol {r[3]:g}" if r[0] == "sg" else f"Exudyn {r[1]} el, {r[2]} steps/tau"
            a = _diff(d, ref_sg) if d is not ref_sg else ["-"] * 4
            b = _diff(d, ref_ex) if d is not ref_ex else ["-"] * 4
            out.append(f"| {name} | " + " | ".join(a + b) + f" | {_drift(d)} | {d['wall']:.1f} |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(run(quick="--quick" in sys.argv))
