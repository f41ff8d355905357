"""The benchmark scenes of ``benchmarks/scenes/`` as Exudyn models (ANCF cable elements).

Exudyn (https://github.com/jgerstmayr/EXUDYN, PyPI ``exudyn``, the ``bench`` extra): each elastic
bar is ``ObjectANCFCable2D`` elements (geometrically exact planar Bernoulli-Euler cable: mass per
length rho A, EA, EI from the scene), solved by ``SolveDynamic`` (generalized-alpha, Exudyn's
default spectral radius 0.9, fixed step). The data (lengths, sections, material, speed) are read
from the same TOML files symgen runs, so both tools solve the same problem:

* the driven crank is a rigid flywheel (inertia 1e8 x the mechanism's: its speed stays omega to
  ~1e-9) pinned at the ground pivot; the slider-crank's rigid crank is that flywheel itself; the
  four-bar's elastic crank is clamped to it at its root (position by a revolute joint, slope by a
  ``GenericJoint`` on the rigid markers of flywheel and cable);
* pins are ``RevoluteJoint2D`` between node positions, the slider a coordinate constraint; the
  six-bar's rigid rocker and rocker2 are ``ObjectRigidBody2D`` uniform bars (m l^2 / 12) pinned
  at their end points, and its fifth bar is pinned to the ternary coupler's middle node (an
  element count divisible by 4: quarter points and midspan are nodes);
* the inverted slider-crank's slot (``inverted_slider_crank``): an ``ObjectJointSliding2D``
  (classical formulation) between the slider block (a point mass pinned to the crank's tip node)
  and the guide's chain of cable elements, which is pinned to the ground at its pivot;
* start: the rigid mechanism's assembly and velocities at t = 0, undeformed (symgen's default
  start, ``[initial]`` without deformation);
* Kelvin-Voigt material damping, the scene's ``effects.damping`` (a ratio in units of 1/omega):
  ``bendingDamping = EI c``, ``axialDamping = EA c`` with c = damping / omega seconds;
* outputs (SI, m), the symgen output kinds of the scenes: ``chord_deflection`` at midspan
  (deflection of the midspan node from the chord between the bar's end nodes, + to the left of
  start -> end) and, for the cantilever crank, ``deflection`` at the tip (in the frame clamped
  to the shaft); the six-bar's coupler also at its quarter points (``chord_deflection`` at 0.25,
  0.75; its ``deflection`` at 0.5 in symgen's pinned-pinned chord frame is the chord deflection).

Run one model in a fresh process (the whole-process timing of ``bench_exudyn``)::

    python benchmarks/exudyn_models.py four_bar_steel 8 2000 2
    python benchmarks/exudyn_models.py six_bar_steel 32 23040 2 10     # six-bar, 10x bending stiffness
"""

from __future__ import annotations

import math
import sys
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np

ADAPTIVE = True  # Exudyn's default: halve the step when Newton fails
# Newton's relative tolerance: Exudyn's default 1e-8 lies below the round-off of the residual of
# steel bars in SI (EA ~ 1e7 N): Newton stalls at ~1e-8, the adaptive step halves down to the
# minimum step and the run fails or crawls (16 elements: 60 s for a quarter turn instead of
# 0.1 s); 1e-6 converges, and moves the outputs by ~1e-7 of their peak (1e-5 vs 1e-6 measured).
NEWTON: dict = {"relativeTolerance": 1e-6}
SCENES = Path(__file__).resolve().parent / "scenes"


def _scene(name: str) -> dict:
    with open(SCENES / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


def _bars(raw: dict) -> dict:
    return {b["name"]: b for b in raw["bodies"]}


def _ancf_bar(mbs, bar: dict, start, angle: float, vel0, omega_bar: float, elements: int, kv: float = 0.0):
    """Nodes and elements of one bar from ``start`` along ``angle``, moving rigidly: start point
    velocity ``vel0``, angular velocity ``omega_bar``; ``kv``: Kelvin-Voigt time constant (s) of
    the material (bending moment EI (kappa + kv kappa'), axial force EA (eps + kv eps')).
    Returns the node and element numbers."""
    from exudyn.itemInterface import NodePoint2DSlope1, ObjectANCFCable2D

    length = bar["length"]
    ex, ey = math.cos(angle), math.sin(angle)
    nodes = []
    for i in range(elements + 1):
        s = length * i / elements
        x, y = start[0] + s * ex, start[1] + s * ey
        # v = v0 + w x (p - p0); slope rate = w x slope
        v = [vel0[0] - omega_bar * s * ey, vel0[1] + omega_bar * s * ex, -omega_bar * ey, omega_bar * ex]
        nodes.append(mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[x, y, ex, ey], initialVelocities=v)))
    rho_a = bar["density"] * bar["area"]
    objects = []
    for i in range(elements):
        objects.append(
            mbs.AddObject(
                ObjectANCFCable2D(
                    nodeNumbers=[nodes[i], nodes[i + 1]],
                    length=length / elements,
                    massPerLength=rho_a,
                    bendingStiffness=bar["E"] * bar["inertia"],
                    axialStiffness=bar["E"] * bar["area"],
                    bendingDamping=kv * bar["E"] * bar["inertia"],
                    axialDamping=kv * bar["E"] * bar["area"],
                )
            )
        )
    return nodes, objects


def _pin_nodes(mbs, a: int, b: int) -> None:
    from exudyn.itemInterface import MarkerNodePosition, RevoluteJoint2D

    mbs.AddObject(
        RevoluteJoint2D(
            markerNumbers=[
                mbs.AddMarker(MarkerNodePosition(nodeNumber=a)),
                mbs.AddMarker(MarkerNodePosition(nodeNumber=b)),
            ]
        )
    )


def _chord_deflection(P0: np.ndarray, Pm: np.ndarray, P1: np.ndarray) -> np.ndarray:
    """Deflection of Pm from the chord P0 -> P1, + to the left (rows: x, y)."""
    c = P1 - P0
    return (c[:, 0] * (Pm[:, 1] - P0[:, 1]) - c[:, 1] * (Pm[:, 0] - P0[:, 0])) / np.hypot(c[:, 0], c[:, 1])


def _solve(SC, mbs, omega: float, steps_per_turn: int, turns: float) -> float:
    import exudyn as exu

    mbs.Assemble()
    ss = exu.SimulationSettings()
    end = turns * 2 * math.pi / omega
    n = int(round(steps_per_turn * turns))
    ss.timeIntegration.numberOfSteps = n
    ss.timeIntegration.endTime = end
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.adaptiveStep = ADAPTIVE
    for k, v in NEWTON.items():
        setattr(ss.timeIntegration.newton, k, v)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ss.solutionSettings.writeSolutionToFile = False
        # sensors at every step (a write period drifts off the output grid); the caller keeps the
        # samples on its grid (steps per turn: multiples of the outputs per turn)
        ss.solutionSettings.sensorsWritePeriod = 0.5 * end / n
        ss.displayStatistics = False
        ss.displayComputationTime = False
    t0 = time.process_time()
    exu.SolveDynamic(mbs, ss)
    return time.process_time() - t0


def _flywheel(mbs, omega: float, inertia: float):
    """A rigid flywheel at the origin turning at omega, pinned to the ground: (node, body, ground marker)."""
    from exudyn.itemInterface import (
        CoordinateConstraint,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectRigidBody2D,
    )

    ground = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0], initialVelocities=[0, 0, omega]))
    body = mbs.AddObject(ObjectRigidBody2D(mass=1.0, inertia=inertia, nodeNumber=node))
    for c in (0, 1):
        mbs.AddObject(
            CoordinateConstraint(
                markerNumbers=[m_ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=c))]
            )
        )
    return node, body, m_ground


def _sensor(mbs, node: int) -> int:
    import exudyn as exu
    from exudyn.itemInterface import SensorNode

    return mbs.AddSensor(
        SensorNode(nodeNumber=node, storeInternal=True, outputVariableType=exu.OutputVariableType.Position)
    )


def slider_crank(elements: int, steps_per_turn: int, turns: float, name: str = "slider_crank_steel"):
    """(t s, {"rod_mid": m}, CPU s of SolveDynamic) of the slider-crank scene ``name``."""
    import exudyn as exu
    from exudyn.itemInterface import CoordinateConstraint, MarkerBodyPosition, MarkerNodeCoordinate, MarkerNodePosition
    from exudyn.itemInterface import RevoluteJoint2D

    assert elements % 2 == 0, "the midspan must be a node"
    raw = _scene(name)
    bars = _bars(raw)
    omega = raw["scene"]["omega"]
    a, rod = bars["crank"]["length"], bars["rod"]
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mass = rod["density"] * rod["area"] * rod["length"]
    _, body, m_ground = _flywheel(mbs, omega, 1e8 * mass * a**2)
    m_tip = mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=[a, 0, 0]))
    # crank along +x at t = 0: A = (a, 0) moves at (0, a w); B on the x axis: the rod turns at -a w / l
    kv = raw.get("effects", {}).get("damping", 0.0) / omega  # symgen's ratio is in units of 1/omega
    nodes, _ = _ancf_bar(mbs, rod, (a, 0.0), 0.0, (0.0, a * omega), -a * omega / rod["length"], elements, kv)
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_tip, mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))]))
    mbs.AddObject(
        CoordinateConstraint(
            markerNumbers=[m_ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[-1], coordinate=1))]
        )
    )
    sensors = [_sensor(mbs, nodes[k]) for k in (0, elements // 2, elements)]
    cpu = _solve(SC, mbs, omega, steps_per_turn, turns)
    A, M, B = (mbs.GetSensorStoredData(s) for s in sensors)
    return A[:, 0], {"rod_mid": _chord_deflection(A[:, 1:3], M[:, 1:3], B[:, 1:3])}, cpu


def four_bar_geometry(raw: dict):
    """Assembly and rigid velocities at t = 0 (crank along +x): A, B, bar angles, angular velocities."""
    bars = _bars(raw)
    omega = raw["scene"]["omega"]
    a, c, r = (bars[k]["length"] for k in ("crank", "coupler", "rocker"))
    o4 = next(j for j in raw["joints"] if j["name"] == "O4")["at"][0]
    A = np.array([a, 0.0])
    O4 = np.array(o4, dtype=float)
    d = np.linalg.norm(O4 - A)
    # B: the upper intersection of |B - A| = c and |B - O4| = r (the open assembly)
    x = (d * d + c * c - r * r) / (2 * d)
    h = math.sqrt(c * c - x * x)
    u = (O4 - A) / d
    B = A + x * u + h * np.array([-u[1], u[0]])
    th3 = math.atan2(*(B - A)[::-1])
    th4 = math.atan2(*(B - O4)[::-1])
    # velocity closure: vA + w3 k x (B - A) = w4 k x (B - O4), vA = w k x A
    vA = omega * np.array([-A[1], A[0]])
    ca, cb = B - A, B - O4
    M = np.array([[-ca[1], cb[1]], [ca[0], -cb[0]]])
    w3, w4 = np.linalg.solve(M, -vA)
    return A, B, O4, th3, th4, vA, w3, w4


def four_bar(elements: int, steps_per_turn: int, turns: float, name: str = "four_bar_steel"):
    """(t s, {"crank_tip", "coupler_mid", "rocker_mid": m}, CPU s of SolveDynamic) of the four-bar
    scene ``name``; ``elements`` per bar (the crank gets max(2, elements // 2): it is a third of the
    coupler's length and far stiffer)."""
    import exudyn as exu
    from exudyn.itemInterface import CoordinateConstraint, GenericJoint, MarkerBodyRigid, MarkerNodeCoordinate

    assert elements % 2 == 0, "the midspan must be a node"
    raw = _scene(name)
    bars = _bars(raw)
    omega = raw["scene"]["omega"]
    A, B, O4, th3, th4, vA, w3, w4 = four_bar_geometry(raw)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mass = sum(b["density"] * b["area"] * b["length"] for b in bars.values())
    _, fly, m_ground = _flywheel(mbs, omega, 1e8 * mass * bars["coupler"]["length"] ** 2)
    n_crank = max(2, elements // 2)
    kv = raw.get("effects", {}).get("damping", 0.0) / omega  # symgen's ratio is in units of 1/omega
    crank, crank_elements = _ancf_bar(mbs, bars["crank"], (0.0, 0.0), 0.0, (0.0, 0.0), omega, n_crank, kv)
    coupler, _ = _ancf_bar(mbs, bars["coupler"], A, th3, vA, w3, elements, kv)
    rocker, _ = _ancf_bar(mbs, bars["rocker"], O4, th4, (0.0, 0.0), w4, elements, kv)
    # crank root clamped to the flywheel: position and slope direction
    m_fly = mbs.AddMarker(MarkerBodyRigid(bodyNumber=fly, localPosition=[0, 0, 0]))
    m_root = mbs.AddMarker(MarkerBodyRigid(bodyNumber=crank_elements[0], localPosition=[0, 0, 0]))
    mbs.AddObject(GenericJoint(markerNumbers=[m_fly, m_root], constrainedAxes=[1, 1, 0, 0, 0, 1]))
    _pin_nodes(mbs, crank[-1], coupler[0])
    _pin_nodes(mbs, coupler[-1], rocker[-1])
    for c in (0, 1):
        mbs.AddObject(
            CoordinateConstraint(
                markerNumbers=[m_ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=rocker[0], coordinate=c))]
            )
        )
    sensors = {
        k: [_sensor(mbs, n[i]) for i in (0, len(n) // 2, len(n) - 1)]
        for k, n in (("crank", crank), ("coupler", coupler), ("rocker", rocker))
    }
    cpu = _solve(SC, mbs, omega, steps_per_turn, turns)
    data = {k: [mbs.GetSensorStoredData(s) for s in v] for k, v in sensors.items()}
    t = data["crank"][0][:, 0]
    P0, _, P1 = (d[:, 1:3] for d in data["crank"])
    th = omega * t  # the shaft's angle: the crank's clamped frame
    tip = -np.sin(th) * (P1[:, 0] - P0[:, 0]) + np.cos(th) * (P1[:, 1] - P0[:, 1])
    out = {"crank_tip": tip}
    for k in ("coupler", "rocker"):
        out[f"{k}_mid"] = _chord_deflection(*(d[:, 1:3] for d in data[k]))
    return t, out, cpu


def slot_joint(mbs, marker: int, elements: list, length: float, s0: float) -> None:
    """A frictionless slot: ``marker`` (a point) slides along the chain of cable ``elements`` of a bar
    of ``length``, starting at arc length ``s0`` (``ObjectJointSliding2D``, classical formulation; a
    data node holds the current element and the sliding coordinate)."""
    from exudyn.itemInterface import MarkerBodyCable2DCoordinates, NodeGenericData, ObjectJointSliding2D

    n = len(elements)
    le = length / n
    cable_markers = [mbs.AddMarker(MarkerBodyCable2DCoordinates(bodyNumber=e)) for e in elements]
    first = min(int(s0 // le), n - 1)
    data = mbs.AddNode(NodeGenericData(initialCoordinates=[first, s0], numberOfDataCoordinates=2))
    mbs.AddObject(
        ObjectJointSliding2D(
            markerNumbers=[marker, cable_markers[first]],
            slidingMarkerNumbers=cable_markers,
            slidingMarkerOffsets=[i * le for i in range(n)],
            nodeNumber=data,
            useClassicalFormulation=True,
        )
    )


def inverted_slider_crank(
    elements: int,
    steps_per_turn: int,
    turns: float,
    name: str = "inverted_slider_crank_overhang",
    crank_elements: int | None = None,
):
    """(t s, {"guide_end", "crank_tip", "guide_slope"}, CPU s of SolveDynamic) of the inverted
    slider-crank scene ``name``: the guide (``elements`` cable elements) pinned to the ground at
    its pivot P, the crank (``crank_elements``, default max(2, elements // 4)) clamped to the driven
    flywheel, the slider block a point mass pinned to the crank's tip node, and the slot an
    ``ObjectJointSliding2D`` (classical formulation) between the block and the guide's chain of
    elements (``MarkerBodyCable2DCoordinates`` per element, a data node holding the current element
    and the sliding coordinate). Outputs as symgen's: ``guide_end`` the far end's deflection from
    the line pivot -> slider (+ to the left), ``crank_tip`` the crank tip's deflection in the
    frame clamped to the shaft, ``guide_slope`` the angle of the guide's slope at the pivot from
    that line (rad)."""
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        GenericJoint,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        MarkerNodePosition,
        NodePoint2D,
        ObjectMassPoint2D,
        SensorNode,
    )

    raw = _scene(name)
    bars = _bars(raw)
    omega = raw["scene"]["omega"]
    crank, guide = bars["crank"], bars["guide"]
    joints = {j["name"]: j for j in raw["joints"]}
    a, L = crank["length"], guide["length"]
    P = np.array(joints["P"]["at"][0], dtype=float)
    slider_mass = joints["A"].get("mass", 0.0)
    # crank along +x at t = 0: the slider at A = (a, 0) moving at (0, a w); the guide along +x
    # (P on the negative x axis), turning at w a / (a - P_x), the slider not sliding yet
    assert abs(P[1]) < 1e-15 and P[0] < -a, "the guide's pivot on the negative x axis"
    s0 = a - P[0]
    w_guide = omega * a / s0
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mass = sum(b["density"] * b["area"] * b["length"] for b in bars.values()) + slider_mass
    _, fly, m_ground = _flywheel(mbs, omega, 1e8 * mass * L**2)
    kv = raw.get("effects", {}).get("damping", 0.0) / omega  # symgen's ratio is in units of 1/omega
    nc = crank_elements or max(2, elements // 4)
    cnodes, celems = _ancf_bar(mbs, crank, (0.0, 0.0), 0.0, (0.0, 0.0), omega, nc, kv)
    gnodes, gelems = _ancf_bar(mbs, guide, tuple(P), 0.0, (0.0, 0.0), w_guide, elements, kv)
    m_fly = mbs.AddMarker(MarkerBodyRigid(bodyNumber=fly, localPosition=[0, 0, 0]))
    m_root = mbs.AddMarker(MarkerBodyRigid(bodyNumber=celems[0], localPosition=[0, 0, 0]))
    mbs.AddObject(GenericJoint(markerNumbers=[m_fly, m_root], constrainedAxes=[1, 1, 0, 0, 0, 1]))
    for c in (0, 1):
        mbs.AddObject(
            CoordinateConstraint(
                markerNumbers=[m_ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=gnodes[0], coordinate=c))]
            )
        )
    # the slider block: a point mass pinned to the crank's tip node
    block = mbs.AddNode(NodePoint2D(referenceCoordinates=[a, 0.0], initialVelocities=[0.0, a * omega]))
    mbs.AddObject(ObjectMassPoint2D(mass=slider_mass, nodeNumber=block))
    m_block = mbs.AddMarker(MarkerNodePosition(nodeNumber=block))
    _pin_nodes(mbs, cnodes[-1], block)
    slot_joint(mbs, m_block, gelems, L, s0)
    sensors = {
        "root": _sensor(mbs, cnodes[0]),
        "tip": _sensor(mbs, cnodes[-1]),
        "block": _sensor(mbs, block),
        "pivot": _sensor(mbs, gnodes[0]),
        "end": _sensor(mbs, gnodes[-1]),
        "pivot_q": mbs.AddSensor(
            SensorNode(
                nodeNumber=gnodes[0], storeInternal=True, outputVariableType=exu.OutputVariableType.CoordinatesTotal
            )
        ),
    }
    cpu = _solve(SC, mbs, omega, steps_per_turn, turns)
    d = {k: mbs.GetSensorStoredData(v) for k, v in sensors.items()}
    t = d["root"][:, 0]
    th = omega * t
    R, T = d["root"][:, 1:3], d["tip"][:, 1:3]
    tip = -np.sin(th) * (T[:, 0] - R[:, 0]) + np.cos(th) * (T[:, 1] - R[:, 1])
    P0, C, E = d["pivot"][:, 1:3], d["block"][:, 1:3], d["end"][:, 1:3]
    chord = np.arctan2(C[:, 1] - P0[:, 1], C[:, 0] - P0[:, 0])
    slope = np.arctan2(d["pivot_q"][:, 4], d["pivot_q"][:, 3]) - chord
    slope = (slope + np.pi) % (2 * np.pi) - np.pi
    return t, {"guide_end": _chord_deflection(P0, E, C), "crank_tip": tip, "guide_slope": slope}, cpu


def _circle_intersection(P: np.ndarray, rp: float, Q: np.ndarray, rq: float, side: float) -> np.ndarray:
    """The point X with |X - P| = rp, |X - Q| = rq, to the left of P -> Q (side = 1) or right (-1)."""
    d = float(np.linalg.norm(Q - P))
    x = (d * d + rp * rp - rq * rq) / (2 * d)
    h = math.sqrt(rp * rp - x * x)
    u = (Q - P) / d
    return P + x * u + side * h * np.array([-u[1], u[0]])


def _angle(v: np.ndarray) -> float:
    return math.atan2(v[1], v[0])


def _cross_solve(r1: np.ndarray, r2: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """(w1, w2) with w1 k x r1 - w2 k x r2 = v."""
    M = np.array([[-r1[1], r2[1]], [r1[0], -r2[0]]])
    return tuple(np.linalg.solve(M, v))


def six_bar_geometry(raw: dict, crank_angle: float = 0.0) -> dict:
    """Rigid assembly and velocities of the six-bar scene (``six_bar_steel``) at a crank angle:
    points A, B, C (coupler midspan), D, pivots O4, O6, bar angles and angular velocities (crank
    at omega). The branch: B to the left of A -> O4 (the open four-bar), D on the side of the line
    C -> O6 that the scene's ``[initial] guess`` gives."""
    bars = _bars(raw)
    omega = raw["scene"]["omega"]
    a, c, r, l5, r6 = (bars[k]["length"] for k in ("crank", "coupler", "rocker", "link", "rocker2"))
    joints = {j["name"]: j for j in raw["joints"]}
    xc = joints["C"]["at"][0]
    O4 = np.array(joints["O4"]["at"][0], dtype=float)
    O6 = np.array(joints["O6"]["at"][0], dtype=float)
    A = a * np.array([math.cos(crank_angle), math.sin(crank_angle)])
    B = _circle_intersection(A, c, O4, r, 1.0)
    C = A + xc * (B - A)
    g = raw["initial"]["guess"]
    Dg = C + l5 * np.array([math.cos(g["link"]), math.sin(g["link"])])
    u, v = O6 - C, Dg - C
    side = 1.0 if u[0] * v[1] - u[1] * v[0] > 0 else -1.0
    D = _circle_intersection(C, l5, O6, r6, side)
    vA = omega * np.array([-A[1], A[0]])
    w3, w4 = _cross_solve(B - A, B - O4, -vA)
    vC = vA + w3 * np.array([-(C - A)[1], (C - A)[0]])
    w5, w6 = _cross_solve(D - C, D - O6, -vC)
    return {
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "O4": O4,
        "O6": O6,
        "vA": vA,
        "vC": vC,
        "theta": {"coupler": _angle(B - A), "rocker": _angle(B - O4), "link": _angle(D - C), "rocker2": _angle(D - O6)},
        "w": {"coupler": w3, "rocker": w4, "link": w5, "rocker2": w6},
    }


def _rigid_bar(mbs, bar: dict, pivot: np.ndarray, angle: float, w: float, velocity=(0.0, 0.0)):
    """A rigid uniform bar from ``pivot`` (moving at ``velocity``) along ``angle`` turning at w: (body, marker at
    the pivot end, marker at the far end)."""
    from exudyn.itemInterface import MarkerBodyPosition, NodeRigidBody2D, ObjectRigidBody2D

    length = bar["length"]
    m = bar["mass_per_length"] * length
    e = np.array([math.cos(angle), math.sin(angle)])
    G = pivot + 0.5 * length * e
    vG = np.asarray(velocity, dtype=float) + w * 0.5 * length * np.array([-e[1], e[0]])
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[G[0], G[1], angle], initialVelocities=[vG[0], vG[1], w]))
    body = mbs.AddObject(ObjectRigidBody2D(mass=m, inertia=m * length**2 / 12, nodeNumber=node))
    return (
        body,
        mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=[-0.5 * length, 0, 0])),
        mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=[0.5 * length, 0, 0])),
    )


SIX_BAR_ELASTIC = ("coupler", "link")


def six_bar(elements: int, steps_per_turn: int, turns: float, name: str = "six_bar_steel", stiffness: float = 1.0):
    """(t s, {"coupler_q1", "coupler_mid", "coupler_q3", "link_mid": m}, CPU s of SolveDynamic) of
    the six-bar scene ``name`` (rigid crank, rocker and rocker2; elastic coupler, the ternary link,
    and link, pinned at the coupler's midspan). ``elements`` on the coupler (a multiple of 4: its
    quarter points and midspan are nodes), ``elements // 2`` on the link (at least 2); the fifth
    bar's first node is pinned to the coupler's middle node. ``stiffness`` multiplies both elastic
    bars' second moment (the ten-times-stiffer variant: 10)."""
    import exudyn as exu
    from exudyn.itemInterface import MarkerBodyPosition, MarkerNodePosition, ObjectGround, RevoluteJoint2D

    assert elements % 4 == 0, "the coupler's quarter points must be nodes"
    raw = _scene(name)
    bars = _bars(raw)
    for k in SIX_BAR_ELASTIC:
        bars[k] = {**bars[k], "inertia": bars[k]["inertia"] * stiffness}
    omega = raw["scene"]["omega"]
    geo = six_bar_geometry(raw)
    th, w = geo["theta"], geo["w"]
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mass = sum(
        b.get("mass_per_length", b.get("density", 0.0) * b.get("area", 0.0)) * b["length"] for b in bars.values()
    )
    _, fly, _ = _flywheel(mbs, omega, 1e8 * mass * bars["coupler"]["length"] ** 2)
    m_crank_tip = mbs.AddMarker(MarkerBodyPosition(bodyNumber=fly, localPosition=[bars["crank"]["length"], 0, 0]))
    kv = raw.get("effects", {}).get("damping", 0.0) / omega  # symgen's ratio is in units of 1/omega
    coupler, _ = _ancf_bar(mbs, bars["coupler"], geo["A"], th["coupler"], geo["vA"], w["coupler"], elements, kv)
    n_link = max(2, elements // 2)
    n_link += n_link % 2
    link, _ = _ancf_bar(mbs, bars["link"], geo["C"], th["link"], geo["vC"], w["link"], n_link, kv)
    _, m_r0, m_r1 = _rigid_bar(mbs, bars["rocker"], geo["O4"], th["rocker"], w["rocker"])
    _, m_s0, m_s1 = _rigid_bar(mbs, bars["rocker2"], geo["O6"], th["rocker2"], w["rocker2"])
    ground = mbs.AddObject(ObjectGround())

    def node_marker(n):
        return mbs.AddMarker(MarkerNodePosition(nodeNumber=n))

    def ground_marker(P):
        return mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[P[0], P[1], 0]))

    for m0, m1 in (
        (m_crank_tip, node_marker(coupler[0])),  # A
        (node_marker(coupler[-1]), m_r1),  # B
        (ground_marker(geo["O4"]), m_r0),  # O4
        (node_marker(coupler[elements // 2]), node_marker(link[0])),  # C: the coupler's middle node
        (node_marker(link[-1]), m_s1),  # D
        (ground_marker(geo["O6"]), m_s0),
    ):  # O6
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[m0, m1]))
    q = elements // 4
    sensors = {
        "coupler": [_sensor(mbs, coupler[i]) for i in (0, q, 2 * q, 3 * q, 4 * q)],
        "link": [_sensor(mbs, link[i]) for i in (0, n_link // 2, n_link)],
    }
    cpu = _solve(SC, mbs, omega, steps_per_turn, turns)
    cp = [mbs.GetSensorStoredData(s) for s in sensors["coupler"]]
    lk = [mbs.GetSensorStoredData(s)[:, 1:3] for s in sensors["link"]]
    t = cp[0][:, 0]
    P = [d[:, 1:3] for d in cp]
    out = {
        "coupler_q1": _chord_deflection(P[0], P[1], P[4]),
        "coupler_mid": _chord_deflection(P[0], P[2], P[4]),
        "coupler_q3": _chord_deflection(P[0], P[3], P[4]),
        "link_mid": _chord_deflection(*lk),
    }
    return t, out, cpu


MODELS = {
    "slider_crank_steel": slider_crank,
    "four_bar_steel": four_bar,
    "six_bar_steel": six_bar,
    "inverted_slider_crank_overhang": inverted_slider_crank,
}


def main(argv: list[str]) -> None:
    """``NAME ELEMENTS STEPS_PER_TURN TURNS``: build, solve, print the peak of each output."""
    name, elements, steps, turns = argv[0], int(argv[1]), int(argv[2]), float(argv[3])
    kw = {"stiffness": float(argv[4])} if len(argv) > 4 else {}  # six_bar: the bending-stiffness factor
    t, out, cpu = MODELS[name](elements, steps, turns, name, **kw)
    print(" ".join(f"{k}={np.abs(v).max():.6e}" for k, v in out.items()), f"cpu={cpu:.4f}")


if __name__ == "__main__":
    main(sys.argv[1:])
