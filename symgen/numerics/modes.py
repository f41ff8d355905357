"""Natural frequencies and mode shapes of the deformation about the quasi-static state.

At an input position tau the mechanism sits on its quasi-static state (18)-(20) (deformation
rates and accelerations zero, closure exact): for a kinematically guided mechanism that is an
equilibrium of the equations frozen at tau. Small motions about it obey the linearisation of
the same index-1 system the dynamic runner integrates: with x = [q_I, v_I] (independent
coordinates: the amplitudes) and z = [q_D, v_D, a, lam] (dependent rigid coordinates, their
rates, accelerations, multipliers) solved from

    0 = G(x, z) = [phi, phid, res, phidd]

the motion is x' = [v_I, a_I(z(x))], and its Jacobian

    dx'/dx = [[0, I], [S_a dz/dx]],   dz/dx = -G_z^-1 G_x

is the state matrix on the tangent space of the closure (every perturbation keeps (11) at all
three levels; the dependent coordinates follow). Its eigenvalues s = sigma +- i omega_d give
the frequencies (in units of omega: per unit tau), natural frequency |s| and damping ratio
-sigma/|s|. Everything the residual contains is in it: centrifugal and geometric stiffening
through the axial force of the quasi-static state, spin softening -theta'^2 eta, Coriolis
coupling, lumped masses, Kelvin-Voigt damping (modal ratio c omega_n / 2).

A mechanism whose driver does work is not a conservative system even when frozen: the
velocity-level closure of a moving loop makes the dependent rates depend on the deformation, so
a linkage such as the four-bar shows small damping ratios of either sign (|zeta| ~ 1e-3..1e-2)
without any damping. They describe the energy exchange with the driver at that position; a
single bar spinning at constant speed (no loop) has none. A bar with a moving support (a slot's
variable span) shows larger ones: its support does work on the vibration.

A mechanism with free rigid coordinates (no driver, a torque driver, bars left undriven) has
no quasi-static state; its modes are taken about its static equilibrium at tau
(``symgen.numerics.equilibrium``), with the same index-1 linearisation and the time frozen
(prescribed angles held, loads and torques at their values at tau). The free rigid
coordinates are then independent coordinates too: their gravity (geometric) stiffness gives the
pendulum modes, labelled "<body> rigid" when most of a mode's potential energy is in the rigid
coordinates, beside the bending modes. An unstable equilibrium has real eigenvalues +-s (an
imaginary frequency), reported as a divergence; a direction nothing holds (a bar free to turn
without gravity) gives zero eigenvalues, reported as neutral.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypedDict

import casadi as ca
import numpy as np

from symgen.errors import SimulationError
from symgen.ir.info import ModelInfo
from symgen.ir.records import CoordKind
from symgen.numerics.equilibrium import Equilibrium, EquilibriumSystem, free_coordinates, frozen_alg
from symgen.numerics.index1 import index1
from symgen.numerics.mechanism import Mechanism
from symgen.numerics.quasistatic import QuasiStaticSystem

if TYPE_CHECKING:
    from symgen.model.shapes import Basis
    from symgen.scene.model import Scene

SHAPE_POINTS = 21
#: Real parts above this (per unit tau) count as growth; below it they are round-off.
GROWTH_TOL = 1e-9
#: A vibration mode growing with a damping ratio above -ZETA_NEUTRAL is neutral, not unstable:
#: its amplitude doubles over more than ln 2 / (2 pi 1e-5) = 11 000 periods, far slower than any
#: structural damping (zeta 1e-3 to 1e-2) removes it. An undamped moving loop shows such rates
#: (zeta -2.5e-7 measured) from the energy the driver exchanges at a frozen position.
ZETA_NEUTRAL = 1e-5
#: About an equilibrium, |s| below this fraction of the largest |s| is a zero eigenvalue: a
#: neutral direction (a bar free to turn with nothing holding it), whose double root at 0 the
#: eigensolver splits by about sqrt(machine epsilon x |A|).
NEUTRAL_REL = 1e-5


@dataclass
class Mode:
    index: int
    eigenvalue: complex
    natural_frequency: float  # |s|, units of omega
    frequency: float  # damped: Im s
    damping_ratio: float
    dominant: str  # "<body> transverse" | "<body> axial": largest deformation share
    energy_fractions: dict[str, float]  # group -> share of the modal kinetic energy (diagonal blocks)
    amplitudes: dict[str, float]  # coordinate -> real part of the normalised shape
    complexity: float  # |imaginary part| / |real part| of the normalised shape
    shape: dict[str, dict[str, list[float]]] = field(default_factory=dict)  # body -> {"xi", "zeta", "eta"}

    def as_dict(self, hz_per_unit: float | None = None) -> dict[str, object]:
        d: dict[str, object] = {
            "index": self.index,
            "natural_frequency": self.natural_frequency,
            "frequency": self.frequency,
            "damping_ratio": self.damping_ratio,
            "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
            "dominant": self.dominant,
            "energy_fractions": self.energy_fractions,
            "amplitudes": self.amplitudes,
            "complexity": self.complexity,
            "shape": self.shape,
        }
        if hz_per_unit is not None:
            d["natural_frequency_hz"] = self.natural_frequency * hz_per_unit
        return d


class Stability(TypedDict):
    """The verdict of :meth:`ModesResult.stability`."""

    stable: bool
    kind: str  # "stable" | "divergence" | "growth"
    reason: str


@dataclass
class ModesResult:
    tau: float
    modes: list[Mode]
    real_eigenvalues: list[float]  # overdamped (negative) or divergent (positive) eigenvalues
    state: dict[str, float]  # coordinate -> value at the quasi-static state
    independent: list[str]
    dependent: list[str]
    quasi_static: dict[str, float | str | int | None]  # the (20) solve's report at tau
    #: about a static equilibrium (a mechanism with free rigid coordinates): how it was found
    #: and the free coordinates' values (``Equilibrium.as_dict``); None about a quasi-static state
    equilibrium: dict[str, object] | None = None

    @property
    def stable(self) -> bool:
        return all(s <= GROWTH_TOL for s in self.real_eigenvalues) and not self._growing()

    def _growing(self) -> list[Mode]:
        """The vibration modes that grow faster than neutral (``ZETA_NEUTRAL``)."""
        return [m for m in self.modes if m.eigenvalue.real > GROWTH_TOL and m.damping_ratio < -ZETA_NEUTRAL]

    def stability(self, damping: float = 0.0) -> Stability:
        """The verdict and its reason: ``{"stable", "kind", "reason"}`` with ``kind`` one of
        ``stable``, ``divergence`` (a real positive eigenvalue: beyond buckling) or ``growth``
        (a vibration mode whose amplitude grows in the frozen system). About a static
        equilibrium, a divergence is the mechanism falling away from an unstable equilibrium."""
        pos = [s for s in self.real_eigenvalues if s > GROWTH_TOL]
        if pos and self.equilibrium is not None:
            return {
                "stable": False,
                "kind": "divergence",
                "reason": f"the static equilibrium is unstable: {len(pos)} real positive eigenvalue(s) (largest "
                f"{max(pos):.3g} per unit tau: an imaginary frequency {max(pos):.3g}i); a small push grows "
                "without oscillating and the mechanism falls away from this position (as an inverted pendulum "
                "does). A stable equilibrium: initial.guess angles near it",
            }
        if pos:
            return {
                "stable": False,
                "kind": "divergence",
                "reason": f"{len(pos)} real positive eigenvalue(s) (largest {max(pos):.3g}): the "
                "quasi-static state is unstable, beyond buckling; a deformation grows without "
                "oscillating",
            }
        growing = self._growing()
        if growing:
            worst = max(growing, key=lambda m: m.eigenvalue.real)
            what = (
                f"{len(growing)} vibration mode(s) grow in the frozen system (fastest: mode {worst.index}, "
                f"growth rate {worst.eigenvalue.real:.3g} per unit tau, zeta {worst.damping_ratio:.2g})"
            )
            if damping == 0:
                why = (
                    "the model has no damping: this is the energy the driver exchanges with the vibration "
                    "at this position of the moving loop (the frozen linearisation is not conservative); "
                    "it changes sign along the cycle. Not a buckling; set effects.damping to see whether "
                    "damping outweighs it"
                )
            else:
                why = "the driver feeds the vibration faster than effects.damping removes it at this position"
            return {"stable": False, "kind": "growth", "reason": f"{what}: {why}"}
        neutral = [m for m in self.modes if m.eigenvalue.real > GROWTH_TOL]
        if neutral:
            worst = max(neutral, key=lambda m: m.eigenvalue.real)
            return {
                "stable": True,
                "kind": "stable",
                "reason": f"no mode grows faster than neutral: {len(neutral)} vibration mode(s) have a tiny "
                f"positive real part (largest {worst.eigenvalue.real:.3g} per unit tau at mode "
                f"{worst.index}, zeta {worst.damping_ratio:.2g} > -{ZETA_NEUTRAL:g}: doubling over more "
                f"than {math.log(2) / (2 * math.pi * ZETA_NEUTRAL):.0f} periods)",
            }
        return {"stable": True, "kind": "stable", "reason": "every eigenvalue has a non-positive real part"}

    def frequencies(self, kind: str | None = None, body: str | None = None) -> np.ndarray:
        """Natural frequencies, ascending; ``kind`` ("transverse"/"axial") and ``body`` filter by
        the dominant group."""
        out = []
        for m in self.modes:
            b, k = m.dominant.rsplit(" ", 1)
            if (kind is None or k == kind) and (body is None or b == body):
                out.append(m.natural_frequency)
        return np.array(out)


def _rigid_march(qs: QuasiStaticSystem, tau: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rigid state at tau, followed from tau = 0 in small steps of the angle drivers (stays on the
    assembly branch of initial.guess)."""
    mech = qs.mech
    q, _, _, _, _ = mech.initial_state(0.0)
    steps = 1
    if tau != 0:
        start, end = mech.driver_motions(0.0), mech.driver_motions(tau)
        for drv in mech.scene.angle_drivers:  # every angle driver turns less than 0.05 per step
            turned = abs(end[drv.body][0] - start[drv.body][0])
            steps = max(steps, int(math.ceil(turned / 0.05)))
            if drv.law is not None or drv.ramp is not None:  # a law may swing back: follow it in tau too
                steps = max(steps, int(math.ceil(abs(tau) / 0.05)))
    for k in range(1, steps + 1):
        q, v, a = qs.rigid_state(tau * k / steps, q)
    return q, v, a


def modes(mech: Mechanism, tau: float = 0.0, shapes: bool = True) -> ModesResult:
    """Linearised modes about the quasi-static state at input position ``tau`` (a kinematically
    guided mechanism), or about the static equilibrium at ``tau`` (a mechanism with free rigid
    coordinates: ``symgen.numerics.equilibrium``)."""
    q0, _, _, _, part0 = mech.initial_state(0.0)
    n, m = mech.n, mech.m
    eq: Equilibrium | None = None
    if free_coordinates(mech, part0):
        eq = EquilibriumSystem(mech).solve(tau, q0)
        q, v, a, lam = eq.q, np.zeros(n), np.zeros(n), eq.lam
        about: dict[str, float | str | int | None] = {"method": "static equilibrium", "residual": eq.residual}
    else:
        qs = QuasiStaticSystem(mech, part0, "deformed")
        qr, vr, ar = _rigid_march(qs, tau)
        y, rep = qs.solve(tau, qr, vr, ar)
        q, v, a, lam = qs.state(tau, qr, vr, ar, y)
        about = rep.as_dict()
    part = mech.choose_partition(tau, q)
    I, D = list(part.ind), list(part.dep)
    nI, nD = len(I), len(D)
    if nI == 0:
        raise SimulationError(
            tau,
            "the mechanism has no deformation amplitudes: it has no modes",
            "give an elastic bar axial_modes or transverse_modes",
        )
    # index-1 system G(x, z) = 0 and its Jacobians (about an equilibrium: with the time frozen)
    sys_ = index1(n, m, part)
    x, z, aa = sys_.x, sys_.z, sys_.a
    args: list[ca.SX | np.ndarray | float] = [tau, sys_.q, sys_.v, aa, sys_.lam, mech.p]
    f = mech.f
    G = sys_.alg(f, tau, mech.p) if eq is None else frozen_alg(sys_, mech, tau)
    jac = ca.Function("modes_jac", [x, z], [G, ca.jacobian(G, x), ca.jacobian(G, z), ca.jacobian(f["res"](*args), aa)])
    x0 = np.concatenate([q[I], v[I]])
    z0 = np.concatenate([q[D], v[D], a, lam])
    G0, Gx, Gz, M = (np.array(w) for w in jac(x0, z0))
    if np.abs(G0).max() > 1e-8:
        what = "quasi-static state" if eq is None else "static equilibrium"
        raise SimulationError(
            tau,
            f"the {what} does not satisfy the equations (residual {np.abs(G0).max():.3g})",
            "report this: it is an internal inconsistency",
        )
    dzdx = -np.linalg.solve(Gz, Gx)
    rows_aI = [2 * nD + i for i in I]
    Ax = np.zeros((2 * nI, 2 * nI))
    Ax[:nI, nI:] = np.eye(nI)
    Ax[nI:, :] = dzdx[rows_aI, :]
    s, W = np.linalg.eig(Ax)

    coords = mech.coords
    groups: dict[str, list[int]] = {}
    for i, c in enumerate(coords):
        kind = {CoordKind.F: "axial", CoordKind.G: "transverse"}.get(c.kind, "rigid")
        groups.setdefault(f"{c.body} {kind}", []).append(i)
    bases = _bases(mech) if shapes else {}
    K = None if eq is None else _stiffness(mech, tau, q, lam)
    scale = max(1.0, float(np.abs(s).max()))
    real_eigs, found = [], []
    for k in range(len(s)):
        sk = s[k]
        if eq is not None and abs(sk) <= NEUTRAL_REL * scale:
            real_eigs.append(0.0)  # a neutral direction: every nearby value is an equilibrium too
            continue
        if abs(sk.imag) <= 1e-9 * scale:
            real_eigs.append(float(sk.real))
            continue
        if sk.imag < 0:
            continue
        w = W[:nI, k]
        dq = np.zeros(n, dtype=complex)
        dq[I] = w
        dq[D] = dzdx[:nD, :nI] @ w  # dependent coordinates follow the closure
        amp = [i for i in I]
        j = amp[int(np.argmax(np.abs(dq[amp])))]
        dq = dq / dq[j]
        re, im = dq.real, dq.imag
        energy = {g: float(np.real(np.conj(dq[idx]) @ M[np.ix_(idx, idx)] @ dq[idx])) for g, idx in groups.items()}
        tot = sum(abs(e) for e in energy.values()) or 1.0
        fractions = {g: abs(e) / tot for g, e in energy.items() if abs(e) / tot > 1e-12}
        deform = {g: e for g, e in fractions.items() if not g.endswith(" rigid")}
        if K is not None and _rigid_share(K, dq, groups) > 0.5:
            deform = {}  # about an equilibrium: a rigid-body (pendulum) mode
        dominant = (
            max(deform, key=deform.__getitem__)
            if deform
            else (max(fractions, key=fractions.__getitem__) if fractions else "?")
        )
        mode = Mode(
            index=0,
            eigenvalue=complex(sk),
            natural_frequency=float(abs(sk)),
            frequency=float(sk.imag),
            damping_ratio=float(-sk.real / abs(sk)),
            dominant=dominant,
            energy_fractions=fractions,
            amplitudes={coords[i].name: float(re[i]) for i in range(n)},
            complexity=float(np.linalg.norm(im) / max(float(np.linalg.norm(re)), 1e-300)),
        )
        if shapes:
            mode.shape = _shape(mech.info, re, bases)
        found.append(mode)
    found.sort(key=lambda md: md.natural_frequency)
    for k, md in enumerate(found):
        md.index = k + 1
    return ModesResult(
        tau=float(tau),
        modes=found,
        real_eigenvalues=sorted(real_eigs),
        state={c.name: float(q[i]) for i, c in enumerate(coords)},
        independent=[coords[i].name for i in I],
        dependent=[coords[i].name for i in D],
        quasi_static=about,
        equilibrium=None if eq is None else eq.as_dict(mech),
    )


def _stiffness(mech: Mechanism, tau: float, q: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """d res / d q at rest at (q, lam): the tangent stiffness, gravity's included."""
    qs = ca.SX.sym("q", mech.n)
    zn = np.zeros(mech.n)
    K = ca.Function("modes_K", [qs], [ca.jacobian(mech.f["res"](tau, qs, zn, zn, lam, mech.p), qs)])
    return np.array(K(q))


def _rigid_share(K: np.ndarray, dq: np.ndarray, groups: dict[str, list[int]]) -> float:
    """The share of a mode's potential energy (diagonal blocks of the stiffness) in the rigid
    coordinates: near 1 for a pendulum mode (gravity's stiffness), near 0 for a bending mode
    (strain energy)."""
    energy = {g: abs(float(np.real(np.conj(dq[idx]) @ K[np.ix_(idx, idx)] @ dq[idx]))) for g, idx in groups.items()}
    total = sum(energy.values()) or 1.0
    return sum(e for g, e in energy.items() if g.endswith(" rigid")) / total


def _bases(mech: Mechanism) -> dict[str, tuple[Basis | None, Basis | None]]:
    from symgen.model.static_shapes import bar_bases

    out: dict[str, tuple[Basis | None, Basis | None]] = {}
    structure = {b["name"]: b for b in mech.info.structure["bodies"]}
    for b in mech.scene.bodies:
        st = structure[b.name]
        if b.rigid or (st["na"] == 0 and st["nt"] == 0):
            continue
        ba, bt = bar_bases(st)  # with the static correction functions of its interior points
        out[b.name] = (ba if len(ba) else None, bt if len(bt) else None)
    return out


def _shape(
    info: ModelInfo, dq: np.ndarray, bases: dict[str, tuple[Basis | None, Basis | None]]
) -> dict[str, dict[str, list[float]]]:
    xi = np.linspace(0.0, 1.0, SHAPE_POINTS)
    out = {}
    for body, (ba, bt) in bases.items():
        fi, gi = info.amplitudes.get(body, ((), ()))
        f, g = [dq[i] for i in fi], [dq[i] for i in gi]
        zeta = [float(np.dot(ba.values(x), f)) if ba is not None else 0.0 for x in xi]
        eta = [float(np.dot(bt.values(x), g)) if bt is not None else 0.0 for x in xi]
        out[body] = {"xi": [float(x) for x in xi], "zeta": zeta, "eta": eta}
    return out


def modes_json(result: ModesResult, scene: Scene, info: ModelInfo) -> dict[str, object]:
    """The ``symgen modes -o OUT.json`` document."""
    hz = scene.omega / (2 * math.pi) if scene.units == "SI" else None
    return {
        "scene": str(scene.path),
        "scene_hash": scene.hash,
        "tau": result.tau,
        "units": (
            "frequencies in units of omega (per unit tau = omega t)"
            + (f"; *_hz: Hz with omega = {scene.omega:g} rad/s" if hz else "")
        ),
        "about": "quasi-static state at tau (closure exact on the deformed bars), linearised on the "
        "independent coordinates (tangent space of the closure)"
        if result.equilibrium is None
        else "static equilibrium at tau (the mechanism has free rigid coordinates: rates and accelerations "
        "zero, gravity, loads and torques at tau, prescribed angles held), linearised with the time frozen on "
        "the independent coordinates (tangent space of the closure)",
        "equilibrium": result.equilibrium,
        "groups": scene.groups,
        "effects": {
            "geometric_stiffening": scene.effects.geometric_stiffening,
            "coriolis": scene.effects.coriolis,
            "strain": scene.effects.strain,
            "damping": scene.effects.damping,
            "rotary_inertia": scene.effects.rotary_inertia,
        },
        "modes_per_body": {name: md.to_json() for name, md in info.modes.items()},
        "independent": result.independent,
        "dependent": result.dependent,
        "state": result.state,
        "quasi_static": result.quasi_static,
        "stable": result.stable,
        "stability": result.stability(scene.effects.damping),
        "real_eigenvalues": result.real_eigenvalues,
        "modes": [m.as_dict(hz) for m in result.modes],
    }


def modes_table(result: ModesResult, scene: Scene, limit: int = 12) -> str:
    """A short text table of the lowest modes, with the stability verdict and its reason."""
    hz = scene.omega / (2 * math.pi) if scene.units == "SI" else None
    undamped = scene.effects.damping == 0
    zeta_head = "zeta*" if undamped else "zeta"
    head = f"{'mode':>4}  {'omega_n (x omega)':>17}  {zeta_head:>9}  " + (f"{'Hz':>10}  " if hz else "") + "dominant"
    if result.equilibrium is None:
        lines = [f"modes at tau = {result.tau:g} (quasi-static state, {result.quasi_static['method']})"]
    else:
        lines = equilibrium_lines(result.equilibrium, scene)
    lines.append(head)
    for m in result.modes[:limit]:
        lines.append(
            f"{m.index:>4}  {m.natural_frequency:>17.6g}  {m.damping_ratio:>9.2g}  "
            + (f"{m.natural_frequency * hz:>10.5g}  " if hz else "")
            + m.dominant
        )
    if len(result.modes) > limit:
        lines.append(f"... {len(result.modes) - limit} more in the JSON")
    if undamped and result.modes and result.equilibrium is None:
        lines.append(
            "* no damping in the model (effects.damping = 0): zeta is the frozen-time energy exchange "
            "with the driver at this position, of either sign, not dissipation"
        )
    if undamped and result.modes and result.equilibrium is not None:
        lines.append("* no damping in the model (effects.damping = 0): zeta is round-off")
    if result.real_eigenvalues:
        zero = [s for s in result.real_eigenvalues if s == 0.0] if result.equilibrium is not None else []
        if zero:
            lines.append(
                f"{len(zero)} zero eigenvalue(s), two per neutral direction: nothing holds the free "
                "coordinates there (every nearby position is an equilibrium too)"
            )
        neg = [s for s in result.real_eigenvalues if s < 0.0 or (s <= GROWTH_TOL and s not in zero)]
        if neg:
            what = "overdamped" if result.equilibrium is None else "decaying without oscillating"
            lines.append(f"{len(neg)} real negative eigenvalue(s) ({what})")
    verdict = result.stability(scene.effects.damping)
    lines.append(("stable: " if verdict["stable"] else "UNSTABLE: ") + verdict["reason"])
    return "\n".join(lines)


def equilibrium_lines(equilibrium: dict[str, object], scene: Scene) -> list[str]:
    """The head of the table about a static equilibrium: which one (the free coordinates'
    values, angles in degrees), how it was found, how to choose another."""
    free = equilibrium["free"]
    assert isinstance(free, dict)
    degrees = equilibrium["free_deg"]  # the angles among them, in degrees
    assert isinstance(degrees, dict)
    values = ", ".join(
        f"{name} = {degrees[name]:.6g} deg" if name in degrees else f"{name} = {x:.6g}" for name, x in free.items()
    )
    keys = equilibrium.get("choose_with") or []
    assert isinstance(keys, list)
    other = f"; another equilibrium: --set {keys[0]}=ANGLE_RAD near it" if keys else ""
    return [
        f"modes about the static equilibrium at tau = {equilibrium['tau']:g} (the mechanism has free rigid "
        "coordinates: gravity, loads and torques frozen at tau, prescribed angles held)",
        f"equilibrium: {values} (found by {equilibrium['method']} from initial.guess in "
        f"{equilibrium['iterations']} step(s){other})",
    ]
