"""Any symgen scene as an Exudyn model (ANCF cables, rigid bodies): the validation references.

The scene is read through symgen's own loader (``symgen.scene.load_scene``: the typed, validated
``Scene`` record, all quantities in the model's dimensionless units), so both tools solve the
same problem; Exudyn is then run IN THOSE UNITS (length l0, time tau = omega t, mass per length
m_ref): a bar i is alpha_i long with mass per length nu_i, axial stiffness EA = lambda_i nu_i
alpha_i^2 and bending stiffness EI = mu_i nu_i alpha_i^4 (the groups' definitions), gravity,
lumped masses, torques and the Kelvin-Voigt time constant are the scene's numbers as they are.

* elastic bar: a chain of ``ObjectANCFCable2D`` elements (geometrically exact planar
  Euler-Bernoulli cable), Kelvin-Voigt damping ``bendingDamping = EI c``, ``axialDamping = EA c``
  (c = ``effects.damping``, in tau); every point a joint, a mass or an output names is a node
  (the element count is raised to a multiple of the denominators of those xi, else the point is
  a body marker inside an element);
* rigid bar: ``ObjectRigidBody2D`` (m = nu alpha, centroidal inertia m alpha^2 / 12);
* pin: ``RevoluteJoint2D`` between the two points; slider: a block of negligible mass pinned to
  the bar point, held on the ground line without turning by an ``ObjectJointPrismatic2D`` (its
  markers must be rigid; a cable's cross-section would turn the line with it); the joint's
  mass is attached to the bar like any other;
* angle driver: the driven bar's rotation coordinate prescribed by a ``CoordinateConstraint``
  whose offset is the scene's law, evaluated by symgen's own driver rows
  (``Mechanism.driver_motion``: constant speed, ``law``, ``ramp``); its multiplier is the
  driver torque. A driven ELASTIC bar (a cantilever frame) is clamped (position and slope) to a
  driven hub (inertia: the driver's rotor inertia) at its root;
* torque driver: a ``LoadTorqueVector`` on the driven bar (or its hub), the scene's value
  (a number or an expression of tau, parsed by symgen's expression parser);
* joint masses and ``[[masses]]``: a mass point pinned to the carrier's point, or (with an
  inertia or an offset) a rigid body clamped to the carrier's cross-section there;
* gravity: ``LoadMassProportional`` on every body;
* start: symgen's consistent start at t = 0 (``Mechanism.initial_state``: the bars' angles and
  angular rates), the bars placed from the ground pins along the pins, undeformed, moving
  rigidly (the scene's default start; a scene with ``[initial] deformation`` is refused);
* ``SolveDynamic`` (generalized-alpha, Exudyn's default spectral radius 0.9), a fixed step,
  Newton's relative tolerance 1e-6 (see ``exudyn_models.NEWTON``); its initial accelerations as
  Exudyn's defaults compute them (``computeInitialAccelerations``, ``storeInitialAlgebraicCoordinates``).
  The driver torque's first sample (t = 0) is then 0 at every mesh, 2 to 32 elements per bar
  (Exudyn 1.13.6: the initial accelerations leave out what constraint user functions prescribe),
  not the cable model's start; it is the continuum's value where no rigid inertia or load acts
  on a driven body at t = 0 (an unstressed bar transmits nothing then), as on every validation
  scene (tests/test_validation.py; benchmarks/RESULTS.md, "The start's joint forces").

Outputs are computed from the node positions the way symgen defines them
(``symgen/model/quantities.py``): ``chord_deflection``, ``deflection`` (pinned-pinned: the
chord frame; cantilever: the root tangent's frame), ``axial``, ``slope``, ``chord_elongation``,
``elastic_displacement``, ``position``, ``angle`` (chord angle, root tangent, or the rigid
body's rotation) and ``driver_torque``, in the model's units (:func:`to_result_units` gives the
units of symgen's result columns). ``energy``, ``reaction`` and ``closure_residual`` are not
converted (``UNSUPPORTED``).

    python benchmarks/exudyn_scene.py SCENE.toml ELEMENTS STEPS_PER_TAU [--set KEY=VALUE ...]
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
if str(BENCH) not in sys.path:
    sys.path.insert(0, str(BENCH))

from exudyn_models import NEWTON  # noqa: E402

#: output kinds this converter computes (the others are left out of its results)
SUPPORTED = (
    "chord_deflection",
    "deflection",
    "axial",
    "slope",
    "chord_elongation",
    "elastic_displacement",
    "position",
    "angle",
    "driver_torque",
)
UNSUPPORTED = ("energy", "reaction", "closure_residual")


class Unsupported(ValueError):
    """The scene uses something this converter does not model (said what, and where)."""


@dataclass
class ExudynResult:
    """One Exudyn run: time tau, outputs (model units) by name, and what it cost."""

    tau: np.ndarray
    outputs: dict[str, np.ndarray]
    cpu: float
    elements: dict[str, int]
    step: float
    skipped: tuple[str, ...] = ()
    info: dict = field(default_factory=dict)


def _denominator(xi: float, limit: int = 64) -> int | None:
    """The denominator q <= limit with xi = p / q (to 1e-12), else None."""
    f = Fraction(xi).limit_denominator(limit)
    return f.denominator if abs(float(f) - xi) < 1e-12 else None


def _interior_points(scene, name: str) -> list[float]:
    """The xi of bar ``name`` at which joints, masses and outputs act."""
    xs = [e.xi for j in scene.joints for e in j.ends if e.body == name and e.xi is not None]
    xs += [m.xi for m in scene.masses if m.body == name]
    xs += [o.xi for o in scene.outputs if o.body == name and o.xi is not None]
    return xs


def element_counts(scene, elements: int) -> dict[str, int]:
    """Elements per elastic bar: ``elements`` raised to a multiple of the denominators of the
    points the bar's joints, masses and outputs name (0.5 -> even, 0.25 -> multiple of 4)."""
    counts = {}
    for b in scene.bodies:
        if b.rigid:
            continue
        q = 1
        for xi in _interior_points(scene, b.name):
            d = _denominator(xi)
            if d is not None:
                q = math.lcm(q, d)
        counts[b.name] = max(q, -(-elements // q) * q)
    return counts


def _e(th: float) -> np.ndarray:
    return np.array([math.cos(th), math.sin(th)])


def _perp(v: np.ndarray) -> np.ndarray:
    return np.array([-v[1], v[0]])


def rigid_start(scene, q: np.ndarray, v: np.ndarray, coords) -> dict[str, tuple]:
    """bar -> (origin, origin velocity, theta, theta') of the start: the angles and rates from
    symgen's state, the origins (xi = 0) placed from the ground pins along the pins."""
    from symgen.ir.records import CoordKind

    ang = {}
    for i, c in enumerate(coords):
        if c.kind is CoordKind.THETA:
            ang[c.body] = (float(q[i]), float(v[i]))
    bars = {b.name: b for b in scene.bodies}
    placed: dict[str, tuple] = {}

    def place(name: str, xi: float, P: np.ndarray, V: np.ndarray) -> None:
        th, w = ang[name]
        s = xi * bars[name].alpha
        placed[name] = (P - s * _e(th), V - w * s * _perp(_e(th)), th, w)

    for j in scene.joints:
        if j.kind != "pin":
            continue
        for a, b in (j.ends, j.ends[::-1]):
            if a.body == "ground" and b.body != "ground" and b.body not in placed:
                place(b.body, b.xi, np.array(a.point, float), np.zeros(2))
    changed = True
    while changed:
        changed = False
        for j in scene.joints:
            if j.kind != "pin":
                continue
            for a, b in (j.ends, j.ends[::-1]):
                if a.body in placed and b.body != "ground" and b.body not in placed:
                    O, VO, th, w = placed[a.body]
                    s = a.xi * bars[a.body].alpha
                    place(b.body, b.xi, O + s * _e(th), VO + w * s * _perp(_e(th)))
                    changed = True
    missing = [b for b in bars if b not in placed]
    if missing:
        raise Unsupported(f"bars {missing} are not reached from a ground pin through pins")
    return placed


class _Model:
    """The Exudyn system of one scene (built by :func:`build`)."""

    def __init__(self, scene, mech, counts: dict[str, int]) -> None:
        import exudyn as exu
        from exudyn.itemInterface import ObjectGround

        self.exu = exu
        self.scene, self.mech, self.counts = scene, mech, counts
        self.SC = exu.SystemContainer()
        self.mbs = self.SC.AddSystem()
        self.ground = self.mbs.AddObject(ObjectGround())
        self.bars = {b.name: b for b in scene.bodies}
        self.nodes: dict[str, list[int]] = {}
        self.elems: dict[str, list[int]] = {}
        self.rigid: dict[str, tuple[int, int]] = {}  # bar -> (node, body)
        self.hubs: dict[str, tuple[int, int]] = {}  # driven elastic bar -> (node, body)
        self.driver_constraints: dict[str, int] = {}
        self.gravity = np.array(scene.effects.gravity, float)
        self.total_mass = sum(b.nu * b.alpha for b in scene.bodies)

    # ------------------------------------------------------------ bodies
    def elastic_bar(self, b, start) -> None:
        from exudyn.itemInterface import NodePoint2DSlope1, ObjectANCFCable2D

        O, VO, th, w = start
        n = self.counts[b.name]
        ex = _e(th)
        kv = self.scene.effects.damping
        EA = b.lam * b.nu * b.alpha**2 if b.lam is not None else 0.0
        EI = b.mu * b.nu * b.alpha**4 if b.mu is not None else 0.0
        if b.axial_modes == 0 or self.scene.effects.axial in (False, "inextensible"):
            raise Unsupported(f"bar {b.name!r}: an axially rigid bar (give it axial modes and lambda)")
        nodes = []
        for i in range(n + 1):
            s = b.alpha * i / n
            P = O + s * ex
            V = VO + w * s * _perp(ex)
            nodes.append(
                self.mbs.AddNode(
                    NodePoint2DSlope1(
                        referenceCoordinates=[P[0], P[1], ex[0], ex[1]],
                        initialVelocities=[V[0], V[1], -w * ex[1], w * ex[0]],
                    )
                )
            )
        elems = [
            self.mbs.AddObject(
                ObjectANCFCable2D(
                    nodeNumbers=[nodes[i], nodes[i + 1]],
                    length=b.alpha / n,
                    massPerLength=b.nu,
                    bendingStiffness=EI,
                    axialStiffness=EA,
                    bendingDamping=kv * EI,
                    axialDamping=kv * EA,
                )
            )
            for i in range(n)
        ]
        self.nodes[b.name], self.elems[b.name] = nodes, elems
        for e in elems:
            self._weight(e)

    def rigid_body(self, mass: float, inertia: float, G: np.ndarray, VG: np.ndarray, th: float, w: float):
        from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D

        node = self.mbs.AddNode(
            NodeRigidBody2D(referenceCoordinates=[G[0], G[1], th], initialVelocities=[VG[0], VG[1], w])
        )
        body = self.mbs.AddObject(ObjectRigidBody2D(mass=mass, inertia=inertia, nodeNumber=node))
        return node, body

    def rigid_bar(self, b, start) -> None:
        O, VO, th, w = start
        m = b.nu * b.alpha
        inertia = m * b.alpha**2 / 12 + self._rotor(b.name)
        s = 0.5 * b.alpha
        node, body = self.rigid_body(m, inertia, O + s * _e(th), VO + w * s * _perp(_e(th)), th, w)
        self.rigid[b.name] = (node, body)
        self._weight(body)

    def _rotor(self, name: str) -> float:
        return sum(d.rotor_inertia for d in self.scene.drivers if d.body == name)

    def _weight(self, body: int) -> None:
        from exudyn.itemInterface import LoadMassProportional, MarkerBodyMass

        if np.any(self.gravity != 0.0):
            m = self.mbs.AddMarker(MarkerBodyMass(bodyNumber=body))
            self.mbs.AddLoad(LoadMassProportional(markerNumber=m, loadVector=[*self.gravity, 0.0]))

    # ------------------------------------------------------------ points
    def _locate(self, name: str, xi: float) -> tuple[str, int, float]:
        """("node", node index, 0) or ("element", element index, local x) of the point xi."""
        n = self.counts[name]
        k = xi * n
        if abs(k - round(k)) < 1e-9:
            return "node", int(round(k)), 0.0
        e = min(int(k), n - 1)
        return "element", e, (k - e) * self.bars[name].alpha / n

    def position_marker(self, name: str, xi: float | None, point=None) -> int:
        from exudyn.itemInterface import MarkerBodyPosition, MarkerNodePosition

        if name == "ground":
            return self.mbs.AddMarker(
                MarkerBodyPosition(bodyNumber=self.ground, localPosition=[point[0], point[1], 0.0])
            )
        if name in self.rigid:
            L = self.bars[name].alpha
            return self.mbs.AddMarker(
                MarkerBodyPosition(bodyNumber=self.rigid[name][1], localPosition=[(xi - 0.5) * L, 0.0, 0.0])
            )
        where, i, x = self._locate(name, xi)
        if where == "node":
            return self.mbs.AddMarker(MarkerNodePosition(nodeNumber=self.nodes[name][i]))
        return self.mbs.AddMarker(MarkerBodyPosition(bodyNumber=self.elems[name][i], localPosition=[x, 0.0, 0.0]))

    def rigid_marker(self, name: str, xi: float, local=(0.0, 0.0)) -> int:
        """A marker of the cross-section at xi (turning with it), at ``local`` in its axes."""
        from exudyn.itemInterface import MarkerBodyRigid

        if name in self.rigid:
            L = self.bars[name].alpha
            return self.mbs.AddMarker(
                MarkerBodyRigid(
                    bodyNumber=self.rigid[name][1], localPosition=[(xi - 0.5) * L + local[0], local[1], 0.0]
                )
            )
        assert local == (0.0, 0.0), "an offset from a cable's cross-section: a rigid body carries it"
        where, i, x = self._locate(name, xi)
        n = self.counts[name]
        if where == "node":
            e, x = (i, 0.0) if i < n else (n - 1, self.bars[name].alpha / n)
        else:
            e = i
        return self.mbs.AddMarker(MarkerBodyRigid(bodyNumber=self.elems[name][e], localPosition=[x, 0.0, 0.0]))

    def point_state(self, name: str, xi: float, start) -> tuple[np.ndarray, np.ndarray, float, float]:
        O, VO, th, w = start[name]
        s = xi * self.bars[name].alpha
        return O + s * _e(th), VO + w * s * _perp(_e(th)), th, w

    # ------------------------------------------------------------ joints and masses
    def pin(self, m0: int, m1: int) -> None:
        from exudyn.itemInterface import RevoluteJoint2D

        self.mbs.AddObject(RevoluteJoint2D(markerNumbers=[m0, m1]))

    def end_marker(self, end) -> int:
        if end.body in self.hubs and abs(end.xi) < 1e-12:
            from exudyn.itemInterface import MarkerBodyPosition

            return self.mbs.AddMarker(MarkerBodyPosition(bodyNumber=self.hubs[end.body][1], localPosition=[0, 0, 0]))
        return self.position_marker(end.body, end.xi, end.point)

    def joint(self, j, start) -> None:
        from exudyn.itemInterface import ObjectJointPrismatic2D

        if j.kind == "pin":
            self.pin(self.end_marker(j.ends[0]), self.end_marker(j.ends[1]))
        elif j.kind == "slider":
            # a block (negligible mass; the joint's mass is attached to the bar like any other)
            # pinned to the bar point, sliding along the ground line without turning
            bar, gnd = (j.ends[0], j.ends[1]) if j.ends[1].body == "ground" else (j.ends[1], j.ends[0])
            d = np.array(j.direction, float)
            d /= np.linalg.norm(d)
            P, V, _, _ = self.point_state(bar.body, bar.xi, start)
            m = 1e-9 * self.total_mass
            _, block = self.rigid_body(m, m * 1e-2, P, V, 0.0, 0.0)
            self.mbs.AddObject(
                ObjectJointPrismatic2D(
                    markerNumbers=[self.ground_rigid_marker(gnd.point), self.rigid_marker_of(block)],
                    axisMarker0=[d[0], d[1], 0.0],
                    normalMarker1=[-d[1], d[0], 0.0],
                    constrainRotation=True,
                )
            )
            self.pin(self.position_marker(bar.body, bar.xi), self.position_marker_of(block))
        else:
            raise Unsupported(f"joint {j.name!r}: a {j.kind} (pins and sliders are converted)")

    def attached_mass(self, body: str, xi: float, mass: float, inertia: float, offset, start) -> None:
        """A mass (with its inertia and offset) carried by bar ``body``'s cross-section at xi."""
        from exudyn.itemInterface import GenericJoint, MarkerBodyRigid, NodePoint2D, ObjectMassPoint2D

        P, V, th, w = self.point_state(body, xi, start)
        if inertia == 0.0 and offset is None:
            if mass == 0.0:
                return
            node = self.mbs.AddNode(NodePoint2D(referenceCoordinates=list(P), initialVelocities=list(V)))
            obj = self.mbs.AddObject(ObjectMassPoint2D(mass=mass, nodeNumber=node))
            self._weight(obj)
            from exudyn.itemInterface import MarkerNodePosition

            self.pin(self.position_marker(body, xi), self.mbs.AddMarker(MarkerNodePosition(nodeNumber=node)))
            return
        off = np.zeros(2) if offset is None else np.array(offset, float)
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        G = P + R @ off
        VG = V + w * _perp(R @ off)
        # a massless body is singular: an attachment without mass gets a negligible one
        m = mass if mass > 0 else 1e-9 * self.total_mass
        J = inertia if inertia > 0 else 1e-9 * self.total_mass * max(b.alpha for b in self.bars.values()) ** 2
        _, obj = self.rigid_body(m, J, G, VG, th, w)
        if mass > 0:
            self._weight(obj)
        m_carrier = self.rigid_marker(body, xi)
        m_att = self.mbs.AddMarker(MarkerBodyRigid(bodyNumber=obj, localPosition=[-off[0], -off[1], 0.0]))
        self.mbs.AddObject(GenericJoint(markerNumbers=[m_carrier, m_att], constrainedAxes=[1, 1, 0, 0, 0, 1]))

    # ------------------------------------------------------------ drivers
    def hub(self, b, start, drv) -> None:
        """A driven elastic bar: a hub at its root (pinned to ground by the bar's ground joint),
        the root clamped to it."""
        from exudyn.itemInterface import GenericJoint

        O, VO, th, w = start[b.name]
        m = 1e-6 * self.total_mass
        J = drv.rotor_inertia + 1e-6 * self.total_mass * b.alpha**2
        self.hubs[b.name] = self.rigid_body(m, J, O, VO, th, w)
        m_hub = self.rigid_marker_of(self.hubs[b.name][1])
        self.mbs.AddObject(
            GenericJoint(markerNumbers=[m_hub, self.rigid_marker(b.name, 0.0)], constrainedAxes=[1, 1, 0, 0, 0, 1])
        )

    def ground_rigid_marker(self, point) -> int:
        from exudyn.itemInterface import MarkerBodyRigid

        return self.mbs.AddMarker(MarkerBodyRigid(bodyNumber=self.ground, localPosition=[point[0], point[1], 0.0]))

    def position_marker_of(self, body: int) -> int:
        from exudyn.itemInterface import MarkerBodyPosition

        return self.mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=[0.0, 0.0, 0.0]))

    def rigid_marker_of(self, body: int) -> int:
        from exudyn.itemInterface import MarkerBodyRigid

        return self.mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[0.0, 0.0, 0.0]))

    def driven(self, name: str) -> tuple[int, int]:
        return self.hubs.get(name) or self.rigid[name]

    def angle_driver(self, drv, theta0: float) -> None:
        from exudyn.itemInterface import CoordinateConstraint, MarkerNodeCoordinate, NodePointGround

        node, _ = self.driven(drv.body)
        g = self.mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
        mg = self.mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=g, coordinate=0))
        mr = self.mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=2))
        law = _driver_law(drv)
        ref = self.mech.driver_motion(0.0, drv.body)[0]
        if abs(law(0.0) - ref) > 1e-12 * max(1.0, abs(ref)):
            raise AssertionError(f"driver of {drv.body!r}: the law gives {law(0.0)} at t = 0, symgen {ref}")

        def offset(mbs, t, itemNumber, lOffset):  # the rotation's displacement from the start
            return law(t) - theta0

        self.driver_constraints[drv.body] = self.mbs.AddObject(
            CoordinateConstraint(markerNumbers=[mg, mr], offsetUserFunction=offset)
        )

    def torque_driver(self, drv) -> None:
        from exudyn.itemInterface import LoadTorqueVector

        _, body = self.driven(drv.body)
        marker = self.rigid_marker_of(body)
        if isinstance(drv.torque, str):
            from symgen.scene.expressions import parse_tau_expression, tau_symbol
            import sympy as sp

            f = sp.lambdify(tau_symbol(), parse_tau_expression(drv.torque), "math")

            def load(mbs, t, vec):
                return [0.0, 0.0, float(f(t))]

            self.mbs.AddLoad(LoadTorqueVector(markerNumber=marker, loadVectorUserFunction=load))
        else:
            self.mbs.AddLoad(LoadTorqueVector(markerNumber=marker, loadVector=[0.0, 0.0, float(drv.torque)]))


def _driver_law(drv):
    """theta(tau) of an angle driver as a float function: symgen's own expression
    (``symgen.scene.motion.driver_angle``: constant speed, ``law``, ``ramp``), compiled once
    (symgen's ``Mechanism.driver_motion`` gives the same numbers at 200 us a call, ten times the
    cost of the whole cable model per step)."""
    import sympy as sp

    from symgen.scene.expressions import tau_symbol
    from symgen.scene.motion import driver_angle

    tau = tau_symbol()
    return sp.lambdify(tau, driver_angle(drv, tau, drv.initial or 0.0, drv.rate, drv.ramp), "math")


def build(scene, mech, elements: int) -> tuple[_Model, dict]:
    """The Exudyn model of ``scene`` (``mech``: its symgen Mechanism, for the start and the
    driver laws) with about ``elements`` cable elements per elastic bar; (model, start)."""
    if scene.initial.deformation or scene.initial.quasi_static:
        raise Unsupported("[initial] deformation: the converter starts undeformed (symgen's default)")
    if scene.loads:
        raise Unsupported("[[loads]] are not converted")
    if scene.effects.strain == "linear" or scene.effects.rotary_inertia or not scene.effects.geometric_stiffening:
        raise Unsupported("the ANCF cable is geometrically exact: effects.strain = linear etc. have no counterpart")
    q, v, _, _, _ = mech.initial_state(0.0)
    start = rigid_start(scene, q, v, mech.coords)
    M = _Model(scene, mech, element_counts(scene, elements))
    drivers = {d.body: d for d in scene.drivers}
    for b in scene.bodies:
        if b.rigid:
            M.rigid_bar(b, start[b.name])
        else:
            M.elastic_bar(b, start[b.name])
            if b.name in drivers:
                if b.frame != "cantilever":
                    raise Unsupported(f"driven elastic bar {b.name!r} needs a cantilever frame (clamped to the shaft)")
                if not any(
                    e.body == b.name and abs(e.xi) < 1e-12 and o.body == "ground"
                    for j in scene.joints
                    if j.kind == "pin"
                    for e, o in (j.ends, j.ends[::-1])
                ):
                    raise Unsupported(f"driven elastic bar {b.name!r}: its ground pin must be at its root (xi = 0)")
                M.hub(b, start, drivers[b.name])
    for j in scene.joints:
        M.joint(j, start)
        if j.mass or j.inertia:
            carrier = next(e for e in j.ends if e.body != "ground")
            M.attached_mass(carrier.body, carrier.xi, j.mass, j.inertia, None, start)
    for pm in scene.masses:
        M.attached_mass(pm.body, pm.xi, pm.mass, pm.inertia, pm.offset, start)
    for d in scene.drivers:
        if d.kind == "angle":
            M.angle_driver(d, start[d.body][2])
        else:
            M.torque_driver(d)
    return M, start


# ---------------------------------------------------------------- outputs
class _Sensors:
    """Node and body sensors of the points the outputs read (each added once)."""

    def __init__(self, M: _Model) -> None:
        self.M = M
        self.ids: dict[tuple, int] = {}

    def point(self, name: str, xi: float) -> tuple:
        """A key whose data are [t, x, y, (sx, sy)] rows of bar ``name``'s point xi."""
        exu, M = self.M.exu, self.M
        from exudyn.itemInterface import SensorBody, SensorNode

        if name in M.rigid:
            key = ("rigid", name)
            if key not in self.ids:
                self.ids[key] = M.mbs.AddSensor(
                    SensorNode(
                        nodeNumber=M.rigid[name][0],
                        storeInternal=True,
                        outputVariableType=exu.OutputVariableType.Coordinates,
                    )
                )
            return key
        where, i, x = M._locate(name, xi)
        key = (name, where, i, x)
        if key not in self.ids:
            if where == "node":
                s = SensorNode(
                    nodeNumber=M.nodes[name][i],
                    storeInternal=True,
                    outputVariableType=exu.OutputVariableType.Coordinates,
                )
            else:
                s = SensorBody(
                    bodyNumber=M.elems[name][i],
                    localPosition=[x, 0.0, 0.0],
                    storeInternal=True,
                    outputVariableType=exu.OutputVariableType.Position,
                )
            self.ids[key] = M.mbs.AddSensor(s)
        return key

    def constraint(self, body: str) -> tuple:
        exu, M = self.M.exu, self.M
        from exudyn.itemInterface import SensorObject

        key = ("driver", body)
        if key not in self.ids:
            self.ids[key] = M.mbs.AddSensor(
                SensorObject(
                    objectNumber=M.driver_constraints[body],
                    storeInternal=True,
                    outputVariableType=exu.OutputVariableType.Force,
                )
            )
        return key


def _request(M: _Model, sensors: _Sensors, o) -> list[tuple]:
    if o.kind == "driver_torque":
        body = o.body or next(d.body for d in M.scene.drivers if d.kind == "angle")
        return [sensors.constraint(body)]
    if o.kind == "angle" and o.body in M.rigid:
        return [sensors.point(o.body, 0.0)]
    return [sensors.point(o.body, 0.0), sensors.point(o.body, 1.0)] + (
        [sensors.point(o.body, o.xi)] if o.xi is not None else []
    )


def _unwrap_to(angle: np.ndarray, start: float) -> np.ndarray:
    a = np.unwrap(angle)
    return a + 2 * math.pi * round((start - a[0]) / (2 * math.pi))


def _evaluate(M: _Model, o, data: dict, keys: list[tuple], start) -> np.ndarray:
    """The output ``o`` (not driver_torque) from its sensors' data: rows [t, x, y, (sx, sy)] of
    total coordinates (a rigid body's [t, x, y, phi]) on the common time grid."""
    b = M.bars[o.body]
    th0 = start[o.body][2]
    if b.rigid:
        if o.kind == "angle":
            return data[keys[0]][:, 3]
        raise Unsupported(f"outputs.{o.name}: {o.kind} of a rigid bar")
    P0, P1 = data[keys[0]][:, 1:3], data[keys[1]][:, 1:3]
    c = P1 - P0
    chord_len = np.hypot(c[:, 0], c[:, 1])
    if b.frame == "cantilever":
        s = data[keys[0]][:, 3:5]  # the root's slope
        th = _unwrap_to(np.arctan2(s[:, 1], s[:, 0]), th0)
    else:
        th = _unwrap_to(np.arctan2(c[:, 1], c[:, 0]), th0)
    if o.kind == "angle":
        return th
    if o.kind == "chord_elongation":
        return chord_len / b.alpha - 1.0
    P = data[keys[2]][:, 1:3]
    d = P - P0
    if o.kind == "chord_deflection":
        return (c[:, 0] * d[:, 1] - c[:, 1] * d[:, 0]) / chord_len / b.alpha
    ex = np.stack([np.cos(th), np.sin(th)], axis=1)
    local_x = (ex[:, 0] * d[:, 0] + ex[:, 1] * d[:, 1]) / b.alpha
    local_y = (ex[:, 0] * d[:, 1] - ex[:, 1] * d[:, 0]) / b.alpha
    if o.kind == "deflection":
        return local_y
    if o.kind == "axial":
        return local_x - o.xi
    if o.kind == "position":
        return P[:, 0 if o.component == "x" else 1]
    if o.kind == "elastic_displacement":
        return (P - (P0 + b.alpha * o.xi * ex))[:, 0 if o.component == "x" else 1]
    if o.kind == "slope":
        if data[keys[2]].shape[1] < 5:
            raise Unsupported(f"outputs.{o.name}: a slope between nodes")
        s = data[keys[2]][:, 3:5]
        return _unwrap_to(np.arctan2(s[:, 1], s[:, 0]), th0) - th
    raise Unsupported(f"outputs.{o.name}: kind {o.kind!r}")


#: Exudyn's CoordinateConstraint force is the multiplier of q_rot - offset = 0 acting on the
#: driven body with the opposite sign of the moment the driver applies (checked against
#: symgen's driver_torque on the steel slider-crank: tests/test_validation.py)
_TORQUE_SIGN = -1.0


def run(
    scene,
    elements: int,
    step: float,
    t_end: float | None = None,
    mech=None,
    rho_inf: float = 0.9,
    newton_rtol: float | None = None,
) -> ExudynResult:
    """Run the Exudyn model of ``scene`` (a Scene record) with ``elements`` per elastic bar and
    a fixed step ``step`` (tau) to ``t_end`` (default the scene's); the outputs at the scene's
    output grid, in the model's units. ``newton_rtol``: Newton's relative tolerance instead of
    ``exudyn_models.NEWTON``'s 1e-6 (undamped steel in the model's units, lambda ~ 3e7: at 1e-6
    Newton stalls on round-off and the adaptive step crawls, 56 s instead of 0.02 s at 1e-4)."""
    import exudyn as exu

    if mech is None:
        from symgen.numerics.mechanism import load_mechanism

        mech = load_mechanism(scene)
    M, start = build(scene, mech, elements)
    sensors = _Sensors(M)
    wanted, skipped = [], []
    for o in scene.outputs:
        if o.kind in SUPPORTED:
            wanted.append((o, _request(M, sensors, o)))
        else:
            skipped.append(o.name)
    mbs = M.mbs
    mbs.Assemble()
    t_end = scene.simulation.t_end if t_end is None else t_end
    n = int(round(t_end / step))
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = n
    ss.timeIntegration.endTime = n * step
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.adaptiveStep = True
    ss.timeIntegration.generalizedAlpha.spectralRadius = rho_inf
    for k, val in NEWTON.items():
        setattr(ss.timeIntegration.newton, k, val)
    if newton_rtol is not None:  # a scene whose residual's round-off lies above NEWTON's tolerance
        ss.timeIntegration.newton.relativeTolerance = newton_rtol
    if mbs.systemData.NumberOfNodes() > 100:  # long chains: Exudyn's dense solver grows as n^3
        ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ss.solutionSettings.writeSolutionToFile = False
        ss.solutionSettings.sensorsWritePeriod = 0.5 * step
        ss.displayStatistics = False
        ss.displayComputationTime = False
    t0 = time.process_time()
    exu.SolveDynamic(mbs, ss)
    cpu = time.process_time() - t0
    raw = {k: mbs.GetSensorStoredData(i) for k, i in sensors.ids.items()}
    # the model's coordinates are displacements from the reference: totals
    for k, d in raw.items():
        if k[0] == "rigid":
            node = M.rigid[k[1]][0]
            ref = np.array(mbs.GetNodeParameter(node, "referenceCoordinates"))
            d[:, 1:4] += ref
        elif len(k) == 4 and k[1] == "node":
            ref = np.array(mbs.GetNodeParameter(M.nodes[k[0]][k[2]], "referenceCoordinates"))
            d[:, 1:5] += ref
    grid = np.arange(scene.simulation.t_end / scene.simulation.output_step + 1e-9 + 1, dtype=int)
    tau = grid * scene.simulation.output_step
    tau = tau[tau <= n * step * (1 + 1e-12)]
    data = {}
    for k, d in raw.items():
        d = regular_rows(d, step)
        tk = d[:, 0]
        data[k] = np.column_stack([tau] + [np.interp(tau, tk, d[:, c]) for c in range(1, d.shape[1])])
    out = {}
    for o, keys in wanted:
        if o.kind == "driver_torque":
            out[o.name] = _TORQUE_SIGN * data[keys[0]][:, 1]
        else:
            out[o.name] = _evaluate(M, o, data, keys, start)
    return ExudynResult(tau, out, cpu, dict(M.counts), step, tuple(skipped), {"steps": n})


#: the last step is a sliver when shorter than this fraction of the step
SLIVER = 1e-3


def regular_rows(d: np.ndarray, step: float) -> np.ndarray:
    """The rows of a sensor's stored data ``d`` (time first) written by the steps the solver
    took, without a repeated time and without the sliver step at the end: n steps of h reach
    endTime short by ~1e-9 (round-off over ~1e6 steps) and Exudyn then takes one more step of
    that size, whose constraint multipliers are meaningless (a steel slider-crank press over 20
    turns at 128 steps per degree: the driver torque of that step 26 x the regular one's and of
    the other sign, the reference's last sample 21 % of peak off). A last row later than the one
    before it by less than ``SLIVER`` x ``step`` is dropped: the grid's last time then reads the
    last regular row, ~1e-9 earlier. The times must not decrease (a time integration's)."""
    t = d[:, 0]
    if np.any(np.diff(t) < 0):
        raise ValueError("sensor times decrease: not a time integration's record")
    d = d[np.r_[True, np.diff(t) > 0]]
    if len(d) > 1 and d[-1, 0] - d[-2, 0] < SLIVER * step:
        d = d[:-1]
    return d


def to_result_units(scene, tau: np.ndarray, outputs: dict[str, np.ndarray]) -> tuple[np.ndarray, dict]:
    """(time, outputs) in the units of symgen's result columns (SI for an SI scene)."""
    from symgen.numerics.units import result_units

    units = result_units(scene)
    factor = {c.name: c.factor for c in units.outputs}
    return tau * units.time.factor, {k: v * factor[k] for k, v in outputs.items()}


def main(argv: list[str]) -> None:
    from symgen.scene import load_scene

    path, elements, steps_per_tau = argv[0], int(argv[1]), float(argv[2])
    overrides = [a.split("=", 1)[0] + "=" + a.split("=", 1)[1] for a in argv[3:]]
    scene = load_scene(path, overrides)
    r = run(scene, elements, 1.0 / steps_per_tau)
    print(
        " ".join(f"{k}={np.abs(v).max():.6e}" for k, v in r.outputs.items()),
        f"cpu={r.cpu:.2f}",
        f"elements={r.elements}",
        f"skipped={list(r.skipped)}",
    )


if __name__ == "__main__":
    main(sys.argv[1:])
