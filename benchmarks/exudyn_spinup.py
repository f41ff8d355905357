"""Exudyn (ANCF cable) reference of ``benchmarks/scenes/slider_crank_spinup.toml`` (issue 12).

Independent of symgen: the scene's numbers are read from the TOML and used as SI values
(dimensionless scene, l0 = m_ref = omega = 1: rho A = mass_per_length = 1, EA = lambda,
EI = mu of the rod):

* crank: ``ObjectRigidBody2D`` (mass m_c = a, centroidal inertia m_c a^2 / 12, node at a/2),
  pinned to ground at O (two coordinate constraints on a body marker at -a/2), the driver torque
  as ``LoadTorqueVector`` on a rigid marker, gravity ``LoadMassProportional`` on its mass;
* rod: ``ObjectANCFCable2D`` elements (geometrically exact planar Bernoulli-Euler cable), pinned to
  the crank tip (``RevoluteJoint2D``), gravity on each element;
* slider: ``MassPoint2D`` of the joint's mass at the rod's end, pinned to it, y = 0;
* start at rest, undeformed, crank along +x; ``SolveDynamic`` (generalized-alpha, spectral radius
  ``rho_inf``: Exudyn's default 0.9 damps the high frequencies a little; 1.0 failed here
  ("SolveDynamic terminated" at 200 steps per tau); 0.8 and 0.95 run).

Outputs (t, dict): theta (crank angle), theta_dot, rod_mid (chord deflection at midspan, + to the
left of A -> B, / l), xB, and the energy E = kinetic + elastic + potential of the ANCF model
(``energy``: crank and slider in closed form, the cable's kinetic and potential energy by
Gauss quadrature of its Hermite interpolation of the node coordinates and velocities (the element's
own shape functions), its strain energy likewise of
1/2 EA eps^2 + 1/2 EI kappa^2 with Exudyn's cable strain eps = |r'| - 1, kappa = (r' x r'') / |r'|^2).

    python benchmarks/exudyn_spinup.py ELEMENTS STEPS_PER_TAU T_END [MU] [RHO_INF]
"""

from __future__ import annotations

import math
import sys
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np

SCENE = Path(__file__).resolve().parent / "scenes" / "slider_crank_spinup.toml"


def scene_data(mu: float | None = None, lam: float | None = None) -> dict:
    with open(SCENE, "rb") as f:
        raw = tomllib.load(f)
    bars = {b["name"]: b for b in raw["bodies"]}
    slider = next(j for j in raw["joints"] if j["name"] == "B")
    d = {
        "a": bars["crank"]["length"],
        "mc": bars["crank"]["length"] * bars["crank"].get("mass_per_length", 1.0),
        "l": bars["rod"]["length"],
        "rhoA": bars["rod"].get("mass_per_length", 1.0),
        "EA": bars["rod"]["lambda"],
        "EI": bars["rod"]["mu"],
        "M": slider["mass"],
        "T": float(raw["driver"]["value"]),
        "g": -raw["effects"]["gravity"][1],
    }
    if mu is not None:
        d["EI"] = mu
    if lam is not None:
        d["EA"] = lam
    # lambda, mu are per the rod's own mass and length: EA = lambda m l^2, EI = mu m l^4 (omega = 1)
    d["EA"] *= d["rhoA"] * d["l"] ** 2
    d["EI"] *= d["rhoA"] * d["l"] ** 4
    return d


def _hermite(x: float, h: float):
    """Cubic Hermite shape functions (values, first, second derivatives in s) on [0, h]."""
    u = x / h
    N = np.array([1 - 3 * u**2 + 2 * u**3, h * (u - 2 * u**2 + u**3), 3 * u**2 - 2 * u**3, h * (-(u**2) + u**3)])
    dN = np.array([-6 * u + 6 * u**2, h * (1 - 4 * u + 3 * u**2), 6 * u - 6 * u**2, h * (-2 * u + 3 * u**2)]) / h
    ddN = np.array([-6 + 12 * u, h * (-4 + 6 * u), 6 - 12 * u, h * (-2 + 6 * u)]) / h**2
    return N, dN, ddN


def _cable_energy(q: np.ndarray, v: np.ndarray, h: float, d: dict) -> tuple[float, float, float]:
    """(kinetic, strain, potential) of the cable: q, v (nodes x 4: x, y, x', y') absolute."""
    xg, wg = np.polynomial.legendre.leggauss(8)
    K = U = V = 0.0
    for e in range(len(q) - 1):
        qe = np.concatenate([q[e], q[e + 1]])
        ve = np.concatenate([v[e], v[e + 1]])
        for xi, w in zip(xg, wg):
            s = 0.5 * h * (xi + 1)
            N, dN, ddN = _hermite(s, h)

            def interp(S, z):
                return np.array(
                    [
                        S[0] * z[0] + S[1] * z[2] + S[2] * z[4] + S[3] * z[6],
                        S[0] * z[1] + S[1] * z[3] + S[2] * z[5] + S[3] * z[7],
                    ]
                )

            r, r1, r2, rv = interp(N, qe), interp(dN, qe), interp(ddN, qe), interp(N, ve)
            n1 = np.hypot(*r1)
            eps = n1 - 1.0
            kap = (r1[0] * r2[1] - r1[1] * r2[0]) / n1**2
            ww = 0.5 * h * w
            K += ww * 0.5 * d["rhoA"] * (rv @ rv)
            U += ww * 0.5 * (d["EA"] * eps**2 + d["EI"] * kap**2)
            V += ww * d["rhoA"] * d["g"] * r[1]
    return K, U, V


def spinup(
    elements: int,
    steps_per_tau: int,
    t_end: float,
    mu: float | None = None,
    rho_inf: float = 0.9,
    lam: float | None = None,
    energy_every: int = 0,
):
    """(t, {theta, theta_dot, rod_mid, xB[, energy]}, CPU s). ``energy_every`` > 0: the energy at
    every that-many output samples (else not computed)."""
    import exudyn as exu
    from exudyn.itemInterface import (
        ObjectANCFCable2D,
        NodePoint2DSlope1,
        NodeRigidBody2D,
        ObjectRigidBody2D,
        NodePointGround,
        MarkerNodeCoordinate,
        MarkerBodyPosition,
        MarkerBodyRigid,
        MarkerBodyMass,
        MarkerNodePosition,
        CoordinateConstraint,
        RevoluteJoint2D,
        LoadTorqueVector,
        LoadMassProportional,
        NodePoint2D,
        MassPoint2D,
        SensorNode,
    )

    d = scene_data(mu, lam)
    a, l, h = d["a"], d["l"], d["l"] / elements
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    mg = [mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=c)) for c in (0, 1)]
    # crank
    nc = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[a / 2, 0, 0]))
    crank = mbs.AddObject(ObjectRigidBody2D(mass=d["mc"], inertia=d["mc"] * a * a / 12, nodeNumber=nc))
    mO = mbs.AddMarker(MarkerBodyPosition(bodyNumber=crank, localPosition=[-a / 2, 0, 0]))
    from exudyn.itemInterface import ObjectGround

    og = mbs.AddObject(ObjectGround())
    mbs.AddObject(
        RevoluteJoint2D(markerNumbers=[mbs.AddMarker(MarkerBodyPosition(bodyNumber=og, localPosition=[0, 0, 0])), mO])
    )
    mbs.AddLoad(
        LoadTorqueVector(
            markerNumber=mbs.AddMarker(MarkerBodyRigid(bodyNumber=crank, localPosition=[0, 0, 0])),
            loadVector=[0, 0, d["T"]],
        )
    )
    mbs.AddLoad(
        LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=crank)), loadVector=[0, -d["g"], 0])
    )
    mA = mbs.AddMarker(MarkerBodyPosition(bodyNumber=crank, localPosition=[a / 2, 0, 0]))
    # rod
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[a + i * h, 0, 1, 0])) for i in range(elements + 1)]
    for i in range(elements):
        el = mbs.AddObject(
            ObjectANCFCable2D(
                nodeNumbers=[nodes[i], nodes[i + 1]],
                length=h,
                massPerLength=d["rhoA"],
                bendingStiffness=d["EI"],
                axialStiffness=d["EA"],
            )
        )
        mbs.AddLoad(
            LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=el)), loadVector=[0, -d["g"], 0])
        )
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[mA, mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))]))
    # slider mass
    nB = mbs.AddNode(NodePoint2D(referenceCoordinates=[a + l, 0]))
    sB = mbs.AddObject(MassPoint2D(mass=d["M"], nodeNumber=nB))
    mbs.AddObject(
        RevoluteJoint2D(
            markerNumbers=[
                mbs.AddMarker(MarkerNodePosition(nodeNumber=nB)),
                mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
            ]
        )
    )
    mbs.AddObject(
        CoordinateConstraint(markerNumbers=[mg[1], mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nB, coordinate=1))])
    )
    mbs.AddLoad(
        LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=sB)), loadVector=[0, -d["g"], 0])
    )
    OV = exu.OutputVariableType
    s_c = [
        mbs.AddSensor(SensorNode(nodeNumber=nc, storeInternal=True, outputVariableType=o))
        for o in (OV.Coordinates, OV.Coordinates_t)
    ]
    keep = nodes if energy_every else [nodes[0], nodes[elements // 2], nodes[-1]]
    s_n = [
        (
            mbs.AddSensor(SensorNode(nodeNumber=n, storeInternal=True, outputVariableType=OV.Coordinates)),
            mbs.AddSensor(SensorNode(nodeNumber=n, storeInternal=True, outputVariableType=OV.Coordinates_t)),
        )
        for n in keep
    ]
    mbs.Assemble()
    ss = exu.SimulationSettings()
    n = int(round(steps_per_tau * t_end))
    ss.timeIntegration.numberOfSteps = n
    ss.timeIntegration.endTime = t_end
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.newton.relativeTolerance = 1e-8
    ss.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ss.solutionSettings.writeSolutionToFile = False
        ss.solutionSettings.sensorsWritePeriod = 0.5 * t_end / n
        ss.displayStatistics = False
        ss.displayComputationTime = False
    t0 = time.process_time()
    exu.SolveDynamic(mbs, ss)
    cpu = time.process_time() - t0
    C, Cd = (mbs.GetSensorStoredData(s) for s in s_c)
    t = C[:, 0]
    # the nodes' coordinates are displacements from the reference: add it
    ref = {k: np.array([a + k * h, 0, 1, 0]) for k in range(elements + 1)}
    idx = list(range(elements + 1)) if energy_every else [0, elements // 2, elements]
    Q = [mbs.GetSensorStoredData(s)[:, 1:5] + ref[k] for (s, _), k in zip(s_n, idx)]
    Qd = [mbs.GetSensorStoredData(s)[:, 1:5] for (_, s), k in zip(s_n, idx)]
    PA, PM, PB = (Q[i][:, :2] for i in ((0, elements // 2, elements) if energy_every else (0, 1, 2)))
    c = PB - PA
    rod_mid = (c[:, 0] * (PM[:, 1] - PA[:, 1]) - c[:, 1] * (PM[:, 0] - PA[:, 0])) / np.hypot(c[:, 0], c[:, 1]) / l
    out = {"theta": C[:, 3], "theta_dot": Cd[:, 3], "rod_mid": rod_mid, "xB": PB[:, 0]}
    if energy_every:
        E = np.full(len(t), np.nan)
        I_O = d["mc"] * a * a / 3
        for i in range(0, len(t), energy_every):
            th, w = C[i, 3], Cd[i, 3]
            e_c = 0.5 * I_O * w * w + d["mc"] * d["g"] * 0.5 * a * math.sin(th)
            vB = Qd[-1][i, :2]
            e_s = 0.5 * d["M"] * (vB @ vB)  # slider on y = 0: no potential
            K, U, V = _cable_energy(np.array([q[i] for q in Q]), np.array([v[i] for v in Qd]), h, d)
            E[i] = e_c + e_s + K + U + V
        out["energy"] = E
    return t, out, cpu


if __name__ == "__main__":
    args = sys.argv[1:]
    el, st, te = int(args[0]), int(args[1]), float(args[2])
    mu = float(args[3]) if len(args) > 3 else None
    rho = float(args[4]) if len(args) > 4 else 0.9
    t, out, cpu = spinup(el, st, te, mu, rho, energy_every=50)
    print(
        f"cpu {cpu:.2f}s theta_end {out['theta'][-1]:.6f} w_end {out['theta_dot'][-1]:.6f} "
        f"rod_mid max {np.abs(out['rod_mid']).max():.6e}"
    )
    E = out["energy"]
    ok = ~np.isnan(E)
    W = scene_data(mu)["T"] * (out["theta"] - out["theta"][0])
    print("E - W drift", np.abs((E - W)[ok] - (E - W)[0]).max(), "E0", E[0])
