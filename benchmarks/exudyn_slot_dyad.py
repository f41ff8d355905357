"""Exudyn (ANCF Cable2D) reference of ``benchmarks/scenes/slot_dyad.toml`` ("slot_dyad"), stored in
``tests/data/slot_dyad_exudyn.csv`` (``tests/test_slot_dyad_reference.py``).

Mechanism: a rigid crank O (driven at omega, along +x at t = 0) whose tip carries the slider block
(point mass, pinned to the driven flywheel at local (a, 0)); the block slides in a frictionless slot
along an elastic aluminium guide (a chain of ObjectANCFCable2D elements) pinned to the ground at P;
the guide's far end E (arc length L) is pinned to a rigid link1, link1's other end B to a rigid
link2, and link2 to the ground at Q. Rigid links: ObjectRigidBody2D, mass m = mu l, inertia
m l^2 / 12 about the centre. The slot: ObjectJointSliding2D (classical formulation), as in
``exudyn_models.inverted_slider_crank``.

Start: the rigid mechanism's assembly and velocities at t = 0, undeformed. The assembly branch of
the dyad: B the intersection of |B - E| = l1, |B - Q| = l2 on the side of E -> Q that the scene's
``[initial] guess`` (link1 angle) gives (B ~ (0.2433, 0.3855): to the LEFT of E -> Q).
Kelvin-Voigt damping kv = damping / omega seconds on the axial strain rate and the curvature rate.

Outputs at every degree of crank (t_k = k (pi/180) / omega, k = 0..360*turns):
  guide_end: the guide's far end's deflection from the line P -> slider contact point, + to the left
  guide_mid: the same for the guide's material point at arc length at * L (the scene's 0.4: a node)
  (both _chord_deflection(P0, X, C) of exudyn_models.py)
plus the link1 pin force at E (global, and its component along link1).

Usage (OPENBLAS_NUM_THREADS=1):
    python benchmarks/exudyn_slot_dyad.py        # the study (~160 s CPU): writes tests/data/slot_dyad_exudyn.csv,
                                                 # the step's Richardson extrapolation at 40 elements
    python benchmarks/exudyn_slot_dyad.py run ELEMENTS STEPS_PER_TURN [TURNS]   # one run, print peaks

Measured (Exudyn 1.13.6): 20 el / 5760 vs 40 / 11520 steps per turn 0.042 % / 0.120 % of peak
(guide_end / guide_mid); 40 / 11520 vs 40 / 23040 0.019 % / 0.058 %; 40 / 23040 vs 80 / 23040
0.0005 % / 0.0024 %; at 40 elements 23040 -> 46080 -> 92160 steps per turn 0.0097 / 0.0049 % (guide_end)
and 0.029 / 0.0145 % (guide_mid): first order (ratio 2.00; generalized-alpha, rho_inf 0.9), so the
reference is the step's Richardson extrapolation 2 x (92160) - (46080); the finest run alone is
0.005 % / 0.015 % from it, 80 elements at 23040 0.019 % / 0.056 %.
"""

from __future__ import annotations

import math
import os
import sys
import tomllib

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import exudyn_models as X  # noqa: E402  (helpers _ancf_bar, _flywheel, _solve, ...)

SCENE = os.environ.get("DYAD_SCENE", os.path.join(HERE, "scenes", "slot_dyad.toml"))
CSV = os.path.join(os.path.dirname(HERE), "tests", "data", "slot_dyad_exudyn.csv")


def geometry(raw: dict) -> dict:
    """Rigid assembly and velocities at t = 0 (crank along +x)."""
    bars = {b["name"]: b for b in raw["bodies"]}
    joints = {j["name"]: j for j in raw["joints"]}
    omega = raw["scene"]["omega"]
    a, L = bars["crank"]["length"], bars["guide"]["length"]
    l1, l2 = bars["link1"]["length"], bars["link2"]["length"]
    P = np.array(joints["P"]["at"][0], float)
    Q = np.array(joints["Q"]["at"][0], float)
    assert abs(P[1]) < 1e-15 and P[0] < -a, "the guide's pivot on the negative x axis"
    A = np.array([a, 0.0])  # crank tip = slider contact point
    vA = omega * np.array([0.0, a])
    s0 = a - P[0]  # slider's arc length on the guide at t = 0
    wg = omega * a / s0  # the guide turns about P; the slider does not slide at t = 0
    E = P + np.array([L, 0.0])
    vE = wg * L * np.array([0.0, 1.0])
    # branch: the side of E -> Q on which the scene's guess of link1's angle puts B
    g = raw["initial"]["guess"]["link1"]
    Bg = E + l1 * np.array([math.cos(g), math.sin(g)])
    u, v = Q - E, Bg - E
    side = 1.0 if u[0] * v[1] - u[1] * v[0] > 0 else -1.0
    B = X._circle_intersection(E, l1, Q, l2, side)
    # velocity closure: vE + w1 k x (B - E) = w2 k x (B - Q)
    w1, w2 = X._cross_solve(B - E, B - Q, -vE)
    return dict(
        omega=omega,
        a=a,
        L=L,
        P=P,
        Q=Q,
        A=A,
        vA=vA,
        s0=s0,
        wg=wg,
        E=E,
        vE=vE,
        B=B,
        th1=X._angle(B - E),
        th2=X._angle(B - Q),
        w1=w1,
        w2=w2,
        side=side,
    )


def run(elements: int, steps_per_turn: int, turns: float = 1.0, at: float | None = None, scene: str = SCENE):
    """(t, {"guide_end", "guide_mid"}, extra dict, CPU s) sampled every degree of crank."""
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        MarkerNodePosition,
        NodePoint2D,
        ObjectGround,
        ObjectMassPoint2D,
        RevoluteJoint2D,
        SensorNode,
        SensorObject,
    )

    with open(scene, "rb") as f:
        raw = tomllib.load(f)
    bars = {b["name"]: b for b in raw["bodies"]}
    joints = {j["name"]: j for j in raw["joints"]}
    if at is None:
        at = raw["outputs"]["guide_mid"]["at"]
    geo = geometry(raw)
    omega, a, L, P, Q, s0 = (geo[k] for k in ("omega", "a", "L", "P", "Q", "s0"))
    imid = at * elements
    assert abs(imid - round(imid)) < 1e-9, f"arc length {at} L must fall on a node ({elements} elements)"
    imid = int(round(imid))
    assert steps_per_turn % 360 == 0, "steps per turn: a multiple of the 360 outputs per turn"
    kv = raw.get("effects", {}).get("damping", 0.0) / omega  # time constant in units of 1/omega

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    guide = bars["guide"]
    m_tot = (
        guide["density"] * guide["area"] * L
        + joints["A"].get("mass", 0.0)
        + sum(bars[k]["mass_per_length"] * bars[k]["length"] for k in ("crank", "link1", "link2"))
    )
    # the driven crank: a rigid flywheel at O, inertia 1e8 x the mechanism's (speed = omega to ~1e-9);
    # the crank's own mass does not matter (its motion is prescribed)
    _, fly, m_ground = X._flywheel(mbs, omega, 1e8 * m_tot * L**2)

    # the guide: pinned to the ground at P, along +x, turning rigidly at wg about P
    gnodes, gelems = X._ancf_bar(mbs, guide, tuple(P), 0.0, (0.0, 0.0), geo["wg"], elements, kv)
    for c in (0, 1):
        mbs.AddObject(
            CoordinateConstraint(
                markerNumbers=[m_ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=gnodes[0], coordinate=c))]
            )
        )

    # the slider block: a point mass pinned to the crank tip (flywheel local (a, 0))
    block = mbs.AddNode(NodePoint2D(referenceCoordinates=list(geo["A"]), initialVelocities=list(geo["vA"])))
    mbs.AddObject(ObjectMassPoint2D(mass=joints["A"].get("mass", 0.0), nodeNumber=block))
    m_block = mbs.AddMarker(MarkerNodePosition(nodeNumber=block))
    m_tip = mbs.AddMarker(MarkerBodyPosition(bodyNumber=fly, localPosition=[a, 0, 0]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_tip, m_block]))

    X.slot_joint(mbs, m_block, gelems, L, s0)  # the slot

    # the dyad: rigid uniform bars, initial velocities of the rigid mechanism
    # the dyad: rigid uniform bars (exudyn_models._rigid_bar), initial velocities of the rigid mechanism
    body1, m1a, m1b = X._rigid_bar(mbs, bars["link1"], geo["E"], geo["th1"], geo["w1"], geo["vE"])  # E -> B
    _, m2a, m2b = X._rigid_bar(mbs, bars["link2"], Q, geo["th2"], geo["w2"])  # Q -> B
    n1 = mbs.GetObject(body1)["nodeNumber"]
    ground = mbs.AddObject(ObjectGround())
    m_Q = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[Q[0], Q[1], 0]))
    j_E = mbs.AddObject(RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerNodePosition(nodeNumber=gnodes[-1])), m1a]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m1b, m2b]))  # B
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_Q, m2a]))  # Q

    sens = {
        k: X._sensor(mbs, n)
        for k, n in (("pivot", gnodes[0]), ("end", gnodes[-1]), ("mid", gnodes[imid]), ("block", block))
    }
    sens["l1"] = mbs.AddSensor(
        SensorNode(nodeNumber=n1, storeInternal=True, outputVariableType=exu.OutputVariableType.Coordinates)
    )
    sens["fE"] = mbs.AddSensor(
        SensorObject(objectNumber=j_E, storeInternal=True, outputVariableType=exu.OutputVariableType.Force)
    )
    cpu = X._solve(SC, mbs, omega, steps_per_turn, turns)
    d = {k: mbs.GetSensorStoredData(v) for k, v in sens.items()}

    # keep the samples on the 1-degree grid
    t = d["pivot"][:, 0]
    dt = math.pi / 180 / omega
    k = np.rint(t / dt).astype(int)
    on = np.abs(t - k * dt) < 1e-6 * dt
    sel = {}
    for i in np.nonzero(on)[0]:
        sel.setdefault(int(k[i]), i)
    nout = int(round(360 * turns)) + 1
    assert sorted(sel) == list(range(nout)), f"missing output samples: {nout - len(sel)}"
    idx = np.array([sel[j] for j in range(nout)])
    d = {kk: v[idx] for kk, v in d.items()}
    t = d["pivot"][:, 0]
    P0, E, M, C = (d[kk][:, 1:3] for kk in ("pivot", "end", "mid", "block"))
    out = {"guide_end": X._chord_deflection(P0, E, C), "guide_mid": X._chord_deflection(P0, M, C)}
    phi1 = d["l1"][:, 3] + geo["th1"]  # node coordinates are displacements from the reference
    F = d["fE"][:, 1:3]
    extra = {
        "fE": F,
        "fE_axial": F[:, 0] * np.cos(phi1) + F[:, 1] * np.sin(phi1),
        "slide": np.hypot(C[:, 0] - P0[:, 0], C[:, 1] - P0[:, 1]),
    }
    return t, out, extra, cpu


def _write_csv(path, t, out, comment):
    with open(path, "w") as f:
        f.write(f"# {comment}\n")
        f.write("t,guide_end,guide_mid\n")
        for i in range(len(t)):
            f.write(f"{t[i]:.12e},{out['guide_end'][i]:.12e},{out['guide_mid'][i]:.12e}\n")


def study():
    raw = tomllib.load(open(SCENE, "rb"))
    geo = geometry(raw)
    print("assembly: B =", geo["B"], "th1 =", geo["th1"], "th2 =", geo["th2"], "(side", geo["side"], ")")
    print("velocities: wg =", geo["wg"], "vE =", geo["vE"], "w1 =", geo["w1"], "w2 =", geo["w2"])
    # the mesh: 40 vs 80 elements at 23040 steps; the step: 40 elements at 23040, 46080, 92160 steps per
    # turn, first order (generalized-alpha, rho_inf 0.9): the reference is their Richardson extrapolation
    cases = [(20, 5760), (40, 11520), (40, 23040), (80, 23040), (40, 46080), (40, 92160)]
    res = {}
    for ne, spt in cases:
        t, out, ex, cpu = run(ne, spt)
        res[(ne, spt)] = (t, out, ex, cpu)
        print(
            f"{ne:3d} el {spt:6d} steps/turn: cpu {cpu:7.2f} s  peak |guide_end| {np.abs(out['guide_end']).max() * 1e3:.5f} mm"
            f"  peak |guide_mid| {np.abs(out['guide_mid']).max() * 1e3:.5f} mm"
            f"  max|F_E| {np.hypot(*ex['fE'].T).max():.4f} N  max|F_E axial| {np.abs(ex['fE_axial']).max():.4f} N"
            f"  (axial min {ex['fE_axial'].min():.4f} max {ex['fE_axial'].max():.4f})",
            flush=True,
        )

    def change(a: tuple, b: tuple) -> dict:
        x, y = res[a][1], res[b][1]
        return {k: float(np.abs(x[k] - y[k]).max() / np.abs(y[k]).max()) for k in x}

    lines = []
    for a, b in zip(cases, cases[1:]):
        rel = change(a, b)
        lines.append(f"{a[0]}el/{a[1]} vs {b[0]}el/{b[1]}: " + ", ".join(f"{k} {100 * v:.4f}%" for k, v in rel.items()))
        print("max|diff|/max|value|", lines[-1])
    coarse, fine = res[(40, 46080)][1], res[(40, 92160)][1]
    ratio = {k: change((40, 23040), (40, 46080))[k] / change((40, 46080), (40, 92160))[k] for k in fine}
    print("step convergence ratio (first order: 2):", ratio)
    t = res[(40, 92160)][0]
    out = {k: 2 * fine[k] - coarse[k] for k in fine}
    comment = (
        f"Exudyn {__import__('exudyn').__version__} ANCF Cable2D, Richardson extrapolation 2 x (40 elements, 92160 "
        f"steps/turn) - (40 elements, 46080) (generalized-alpha rho_inf 0.9, first order: change ratios "
        + ", ".join(f"{k} {v:.3f}" for k, v in ratio.items())
        + f"), kv = {raw['effects']['damping']}/omega; peaks |guide_end| "
        f"{np.abs(out['guide_end']).max():.6e} m, |guide_mid| {np.abs(out['guide_mid']).max():.6e} m; "
        "convergence max|diff|/max|value|: " + "; ".join(lines)
    )
    _write_csv(CSV, t, out, comment)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "run":
        ne, spt = int(sys.argv[2]), int(sys.argv[3])
        turns = float(sys.argv[4]) if len(sys.argv) > 4 else 1.0
        t, out, ex, cpu = run(ne, spt, turns)
        i = np.argmax(np.abs(out["guide_end"]))
        print(
            f"cpu {cpu:.3f} n {len(t)} peaks guide_end {np.abs(out['guide_end']).max():.6e} at t {t[i]:.5f}"
            f" guide_mid {np.abs(out['guide_mid']).max():.6e} max|F_E| {np.hypot(*ex['fE'].T).max():.4f}"
            f" max|F_E axial| {np.abs(ex['fE_axial']).max():.4f}"
        )
        if os.environ.get("DYAD_OUT"):
            _write_csv(os.environ["DYAD_OUT"], t, out, f"run {ne} {spt}")
    else:
        study()
