"""Where the bars are, for drawing: points of every bar as a CasADi Function of the coordinates q.

The positions come from the package's own bar kinematics (``kinematics.BarKinematics``, and
``slot.SlotBarKinematics`` for the guide of a slot, whose span psi(xi, beta) moves with the
contact), placed along the spanning tree by the derivation's own tree kinematics (10)
(``kinematics.TreeKinematics``, its position level, with the scene's ground points and slider
directions as numbers): the origin of a bar hanging from its parent at joint K is
r_K - rho(xi_K), a bar on a slider starts at its ground point plus s times the slider's
direction. The shape functions are the ones the
model was derived with (same families, counts and tip-joint rule), so a point drawn here is the
point the equations move.

A *magnified* picture of the deformation (``Geometry.magnified``) draws the elastic
displacement field relative to the rigid mechanism at the same input: the rigid reference
q_r solves the closure (11) with every amplitude zero, the independent rigid coordinates
(the driven angle; the free ones of a torque-driven mechanism) kept as run; the drawn point is
r(q_r) + F (r(q) - r(q_r)). With F = 1 it is the computed position, with F = 0 the rigid
mechanism, and since r(q) and r(q_r) both close every loop the bars stay joined at every
joint for any F (the displacement field of a joint point is the same seen from either bar).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np
import sympy as sp

from symgen.ir import names
from symgen.ir.info import ModelInfo
from symgen.ir.parameters import parameter_records
from symgen.model.bars import BarSymbols, rot
from symgen.backends.casadi.functions import SympyToCasadi
from symgen.model.kinematics import BarKinematics, TreeKinematics
from symgen.model.rotary import section_rotation
from symgen.scene.model import GROUND, Scene
from symgen.model.static_shapes import bar_bases
from symgen.model.slot import XI, SlotBarKinematics, SlotBasis
from symgen.model.structure import basis_sizes, overhang_modes, structure_of
from symgen.model.topology import build_topology

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism

SAMPLES = 41  # points per bar (shape functions up to ~8 half-waves drawn smoothly)


@dataclass(frozen=True)
class Marker:
    """A joint drawn on the picture: index of its point in the points array."""

    joint: str
    kind: str  # "pin" | "slider" | "slot"
    index: int
    ground: tuple[float, ...] | None  # ground point (dimensionless) of a joint to ground, else None
    direction: tuple[float, ...] | None = None  # slider line direction


class Geometry:
    """Sample points of every bar (``bars[name]`` = column range), joint markers, and per
    ``[[masses]]`` entry the indices (point on the bar, the mass's centre)."""

    def __init__(self, scene: Scene, info: ModelInfo, samples: int = SAMPLES) -> None:
        self.scene = scene
        coords = info.coords
        self.n = len(coords)
        q = ca.SX.sym("q", self.n)
        env = {names.coordinate(c.kind, c.body, c.joint, c.index).symbol(): q[i] for i, c in enumerate(coords)}
        topo = build_topology(scene)
        slot_of = {j.ends[1].body: j.name for j in scene.joints if j.kind == "slot"}
        kins: dict[str, BarKinematics | SlotBarKinematics] = {}
        records = {rec["name"]: rec for rec in structure_of(scene)["bodies"]}
        for b in scene.bodies:
            na, nt = basis_sizes(scene, b)
            sym = BarSymbols.make(b.name, na, nt, elastic=not b.rigid)
            env[sym.alpha] = ca.SX(b.alpha)
            if b.name in slot_of:
                beta = names.slot_support(slot_of[b.name]).symbol()
                kins[b.name] = SlotBarKinematics(sym, SlotBasis(nt, beta, overhang_modes(scene, b)), (beta, None, None))
            else:
                kins[b.name] = BarKinematics(sym, *bar_bases(records[b.name]))
        missing = [str(s) for k in kins.values() for s in (k.sym.th, *k.sym.f, *k.sym.g) if s not in env]
        if missing:
            raise ValueError(f"the model has no coordinate {missing[0]} (scene and model differ)")
        values = {rec.name: rec.value for rec in parameter_records(scene)}  # ground points, slider lines
        slider_s = {
            e.joint: (names.slider_travel(e.joint).symbol(), None, None) for e in topo.edges.values() if e.slider
        }
        tree = TreeKinematics(topo, kins, lambda name: sp.Float(values[name.text]), slider_s)

        def along(name: str, xis: np.ndarray) -> list[sp.Matrix]:
            """rho at each xi (a guide's piecewise span built once in xi, then evaluated)."""
            kin = kins[name]
            if isinstance(kin, SlotBarKinematics):
                general = kin.rho(XI)
                return [general.xreplace({XI: sp.Float(float(x))}) for x in xis]
            return [kin.rho(float(x)) for x in xis]

        pts: list[sp.Matrix] = []
        self.bars: dict[str, range] = {}
        xis = np.linspace(0.0, 1.0, samples)
        for b in scene.bodies:
            rA = tree.position(b.name)
            start = len(pts)
            pts += [rA + r for r in along(b.name, xis)]
            self.bars[b.name] = range(start, len(pts))
        self.markers: list[Marker] = []
        for j in scene.joints:
            end = next(x for x in j.ends if x.body != GROUND and x.xi is not None)
            assert end.xi is not None  # chosen so (next() does not narrow)
            pts.append(tree.point_position(end.body, end.xi))
            g = next((x.point for x in j.ends if x.body == GROUND), None)
            self.markers.append(
                Marker(
                    j.name,
                    j.kind,
                    len(pts) - 1,
                    None if g is None else tuple(g),
                    None if j.direction is None else tuple(j.direction),
                )
            )
        # [[masses]]: the point on the bar, and the centre (the arm turning with the cross-section)
        self.point_masses: list[tuple[int, int]] = []
        for i, pm in enumerate(scene.masses):
            pts.append(tree.point_position(pm.body, pm.xi))
            centre = pts[-1]
            if pm.offset is not None:
                kin = kins[pm.body]
                d = sp.Matrix([values[names.mass_parameter(k, i).text] for k in ("along", "across")])
                centre = centre + rot(section_rotation(kin.sym, kin, pm.xi)) * d
            pts.append(centre)
            self.point_masses.append((len(pts) - 2, len(pts) - 1))
        conv = SympyToCasadi(env)
        xy = ca.horzcat(*[ca.vertcat(conv(p[0]), conv(p[1])) for p in pts])
        self.f = ca.Function("points", [q], [xy])
        self.npts = len(pts)

    def points(self, Q: np.ndarray) -> np.ndarray:
        """Positions (N, 2, npts) of every sample point for each row of Q (N, n)."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        out = np.array(self.f.map(len(Q))(Q.T))  # (2, npts * N)
        return out.reshape(2, len(Q), self.npts).transpose(1, 0, 2)


def rigid_reference(mech: Mechanism, tau: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """For each state, the rigid mechanism at the same input: every amplitude zero, the
    dependent rigid coordinates solved from the closure by Newton from the computed ones."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    amp = list(mech.info.elastic)
    out = Q.copy()
    if not amp:
        return out
    out[:, amp] = 0.0
    if mech.m == 0:
        return out
    part = mech.choose_partition(float(tau[0]), out[0])
    for k in range(len(Q)):
        out[k] = mech.assemble(float(tau[k]), out[k], part)
    return out


def magnified(P: np.ndarray, P_rigid: np.ndarray, factor: float) -> np.ndarray:
    """r(q_r) + F (r(q) - r(q_r)): the elastic displacement field drawn F times larger."""
    drawn: np.ndarray = P_rigid + factor * (P - P_rigid)
    return drawn


def auto_factor(P: np.ndarray, P_rigid: np.ndarray, target: float) -> tuple[float, float]:
    """(factor, peak displacement): a round factor (1, 2 or 5 times a power of ten) bringing
    the largest elastic displacement of any drawn point to about ``target``; 1 when nothing
    deforms."""
    peak = float(np.max(np.hypot(*(P - P_rigid).transpose(1, 0, 2)))) if P.size else 0.0
    if not peak > 1e-300 or not np.isfinite(peak):
        return 1.0, peak
    raw = target / peak
    if raw <= 1.0:
        return 1.0, peak
    e = np.floor(np.log10(raw))
    mant = raw / 10**e
    nice = 5.0 if mant >= 5 else 2.0 if mant >= 2 else 1.0
    return float(nice * 10**e), peak
