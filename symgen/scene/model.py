"""The validated scene: frozen dataclasses, all quantities dimensionless.

This is the contract between ``symgen.scene.loader`` (TOML -> Scene) and every later
stage. Units after loading (whatever the file's ``units``):

* lengths / positions: divided by the reference length l0 (``alpha = l_i / l0``);
* time: tau = omega t;
* mass per length: relative to m_ref (``nu = m_i / m_ref``); lumped masses (joints, ``[[masses]]``) relative to m_ref l0;
* lambda, mu: each bar's OWN groups EA/(m_i l_i^2 omega^2), EI/(m_i l_i^4 omega^2);
* distributed loads: groups q/(m_i l_i omega^2) of that bar, in the bar's axes;
* point loads: F/(m_i l_i^2 omega^2) of that bar, in the bar's axes;
* gravity: g/(l0 omega^2) in ground axes;
* rotary inertias (driver rotor, lumped at joints, of ``[[masses]]``): J/(m_ref l0^3);
* torque: M/(m_ref l0^3 omega^2); forces (reactions) in m_ref l0^2 omega^2.

A load or torque value is either a float or a string expression of ``tau`` (validated by the
loader with :func:`symgen.scene.expressions.parse_tau_expression`, which every later stage uses).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from symgen.policy import tolerances

if TYPE_CHECKING:
    from symgen.scene.bases import BasisChoice
    from symgen.scene.strain import StrainChoice

GROUND = "ground"


@dataclass(frozen=True)
class Body:
    """One bar. ``rigid`` bars have lam = mu = rho = None, frame = "", no modes."""

    name: str
    alpha: float  # l_i / l0
    rigid: bool
    nu: float  # m_i / m_ref
    lam: float | None  # lambda_i = EA/(m_i l_i^2 w^2)
    mu: float | None  # mu_i = EI/(m_i l_i^4 w^2)
    rho: float | None  # rotary-inertia group (r_g / l_i)^2 = mu/lam
    frame: str  # "pinned-pinned" ("pinned-sliding" normalised to it) | "cantilever" | "" (rigid)
    axial_modes: int  # as written in the file, or chosen from simulation.accuracy when absent (Scene.bases
    # says which); effects are applied by the derivation
    transverse_modes: int
    axial_shapes: str  # "complete" | "stress-free"
    transverse_shapes: str  # "modes" | "eigen" | "polynomial"
    static_correction: bool | None = None  # None: static correction functions at interior points (default)
    # the highest this many of its transverse_modes functions are quasi-static: stiffness and
    # loads, no inertia of their own (docs/quasi-static-modes.md; applied by the run, not the model)
    quasi_static_transverse: int = 0


@dataclass(frozen=True)
class JointEnd:
    """One side of a joint: a bar at position xi in [0, 1], or a ground point."""

    body: str  # body name or GROUND
    xi: float | None = None  # bars only (None for the guide of a slot)
    point: tuple[float, float] | None = None  # ground only (dimensionless, / l0)
    variable: bool = False  # slot guide: the support distance beta(tau) is unknown


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str  # "pin" | "slider" | "slot"
    ends: tuple[JointEnd, JointEnd]  # in the file's order of ``bodies``
    direction: tuple[float, float] | None = None  # slider: unit vector of the ground line
    mass: float = 0.0  # lumped mass at the joint / (m_ref l0)
    inertia: float = 0.0  # lumped rotary inertia at the joint / (m_ref l0^3)
    overhang: str = ""  # slot: "elastic" (the guide's overhang bends) | "rigid"
    overhang_modes: int = 0  # slot, elastic overhang: its own bending functions


@dataclass(frozen=True)
class PointMass:
    """A ``[[masses]]`` entry: a point mass (with its rotary inertia) at ``xi`` of bar ``body``,
    on the bar's axis or, with ``offset``, rigidly attached beside it (a tool on an arm): the
    offset (along, across) / l0 is in the axes of the cross-section at xi, so the attachment
    turns with it (theta + eta'(xi) on an elastic bar)."""

    body: str
    xi: float
    mass: float = 0.0  # / (m_ref l0)
    inertia: float = 0.0  # about its own centre / (m_ref l0^3)
    offset: tuple[float, float] | None = None  # (along, across) / l0, None: on the axis


@dataclass(frozen=True)
class Driver:
    kind: str  # "angle" | "torque"
    body: str
    initial: float | None  # angle at tau = 0 [rad]; torque driver: None = from the assembly
    rate: float  # angle: d theta/d tau; torque: initial angular rate (default 0)
    torque: float | str = 0.0  # torque driver only: constant or expression of tau
    law: str | None = None  # angle driver only: theta = initial + law(tau), expression of tau
    ramp: float | None = None  # angle driver only: spin-up time T (tau) to reach ``rate`` smoothly
    rotor_inertia: float = 0.0  # rotor + gear reflected to the driven bar's shaft / (m_ref l0^3)


@dataclass(frozen=True)
class BodyDeformation:
    f: tuple[float, ...] = ()
    g: tuple[float, ...] = ()
    fdot: tuple[float, ...] = ()
    gdot: tuple[float, ...] = ()


@dataclass(frozen=True)
class Initial:
    guess: tuple[tuple[str, float], ...] = ()  # (body, angle) or (slot joint, beta) pairs
    deformation: tuple[tuple[str, BodyDeformation], ...] = ()  # (body, amplitudes) pairs
    quasi_static: bool = False  # project key: initial.deformation = "quasi-static"


@dataclass(frozen=True)
class Effects:
    axial: bool | str = "auto"  # true | false | project additions "auto" (default, per bar),
    # "dynamic" (= true), "quasi_static", "inextensible" (lambda -> oo)
    transverse: bool = True
    geometric_stiffening: bool = True
    coriolis: bool = True
    rotary_inertia: bool = False
    strain: str = "von_karman"  # "von_karman" | "linear" | "exact"
    gravity: tuple[float, float] = (0.0, 0.0)
    damping: float = 0.0  # Kelvin-Voigt ratio (in units of 1/omega)


@dataclass(frozen=True)
class Load:
    body: str
    kind: str  # "distributed" | "point"
    xi: float | None  # point loads only
    axial: float | str = 0.0
    transverse: float | str = 0.0


@dataclass(frozen=True)
class Output:
    name: str
    kind: str  # see OUTPUT_KINDS
    body: str | None = None
    joint: str | None = None
    xi: float | None = None  # "at"
    component: str | None = None  # "x" | "y"


OUTPUT_KINDS = (
    "chord_deflection",
    "chord_elongation",
    "deflection",
    "axial",
    "slope",
    "elastic_displacement",
    "position",
    "angle",
    "reaction",
    "driver_torque",
    "energy",
    "closure_residual",
)
#: output kinds that check the solver (zero to round-off in every model, not an approximation of
#: anything): no error estimate is given for them and no run-time decision is taken on them
CHECK_KINDS = ("closure_residual",)


@dataclass(frozen=True)
class Simulation:
    t_end: float
    output_step: float
    rtol: float = 1e-8
    atol: float = 1e-10
    accuracy: float = 0.01  # fraction of each output's peak: chooses absent mode counts (symgen.scene.bases)
    # "scene": rtol and atol as the scene states them (one of them stated: the other's former
    # default); "accuracy": the scene states neither, both follow from the accuracy by the rule of
    # the solver that runs it (symgen.policy.tolerances; rtol, atol above are IDAS's)
    tolerances_from: str = "scene"

    def tolerances(self, solver: str = "idas") -> tuple[float, float]:
        """(rtol, atol) of a run by ``solver`` ("idas" or "c"): the scene's, or from the accuracy by
        that solver's rule."""
        if self.tolerances_from == "accuracy":
            return tolerances(self.accuracy, solver)
        return self.rtol, self.atol

    def tolerances_reason(self) -> str:
        """Why the run has its tolerances, as the sidecar, ``symgen check`` and ``effects`` say it."""
        if self.tolerances_from == "accuracy":
            return f"from simulation.accuracy {self.accuracy:g} (the scene states neither rtol nor atol)"
        return "stated in [simulation] (one left out keeps its fixed default, rtol 1e-8 or atol 1e-10)"


@dataclass(frozen=True)
class CountsRaised:
    """The chosen counts the runs' truncation estimates raised (``symgen.numerics.counts_choice``):
    ``floors``: (bar, axial, transverse), at least these counts for the bar's chosen families
    (``symgen.scene.bases.choose_bases``); ``reason``: why, as the latest raise said it;
    ``rounds``: how many raises made them (at most ``counts_choice.MAX_ROUNDS``)."""

    floors: tuple[tuple[str, int, int], ...]
    reason: str
    rounds: int = 1

    def floor(self, bar: str) -> tuple[int, int] | None:
        """The (axial, transverse) floor of ``bar``, or None."""
        return next(((a, t) for b, a, t in self.floors if b == bar), None)


@dataclass(frozen=True)
class AxialSwitch:
    """``effects.axial = "auto"`` for a damped start ringing (``symgen.numerics.axial_choice``):
    the bars of ``Scene.axial_kept`` keep their axial dynamics from the start to ``tau`` (on the
    run's output grid), while the start's ringing lasts, and are quasi-static after it, the run
    continued from the state reached (``symgen.numerics.simulate``). ``charge``: (output, fraction
    of its peak) the switch and the quasi-static treatment after it leave out, as the decision
    measured them (the error estimate's axial part of a run that switched); ``how``: how."""

    tau: float
    charge: tuple[tuple[str, float], ...]
    how: str


@dataclass(frozen=True)
class Scene:
    name: str
    path: str
    hash: str  # sha256 hex of the canonical scene after overrides
    units: str  # "dimensionless" | "SI"
    l0: float  # reference length (m for SI, else the dimensionless value used)
    omega: float  # rad/s (SI) or 1.0
    m_ref: float  # kg/m (SI) or 1.0
    bodies: tuple[Body, ...]
    joints: tuple[Joint, ...]
    drivers: tuple[Driver, ...]  # [driver] (one) or [[drivers]], in the file's order
    initial: Initial
    effects: Effects
    loads: tuple[Load, ...]
    outputs: tuple[Output, ...]
    simulation: Simulation
    groups: dict = field(default_factory=dict, compare=False, hash=False)
    masses: tuple[PointMass, ...] = ()  # [[masses]]: point masses and rigid attachments on bars
    # groups: {body: {"alpha":..,"nu":..,"lambda":..,"mu":..,"rho":..}, "_scene": {"gravity": [..], ...}}
    si_inputs: tuple[tuple[str, float], ...] = ()
    # SI scenes: the file's physical inputs of the groups, (scene key, value) in SI units:
    # scene.omega, scene.reference_length (if given) and each bar's length, E, area, inertia,
    # density or mass_per_length, as given (symgen.ir.physical: the emitted C's --set by them)
    bases: tuple[
        BasisChoice, ...
    ] = ()  # symgen.scene.bases.BasisChoice per elastic bar: its counts, chosen or stated, and why
    # effects.strain as written ("auto", the default, or a value), the formulation used and why
    # (symgen.scene.strain; None for a Scene built in code: its effects.strain is used as it is)
    strain_choice: StrainChoice | None = None
    # effects.axial = "auto": (bar, reason) of the bars whose axial dynamics a run's estimate kept
    # (symgen.numerics.axial_choice: the quasi-static stretch's phase drift above the accuracy)
    axial_kept: tuple[tuple[str, str], ...] = ()
    # ... and where their start's ringing is damped, until when (None: the whole run)
    axial_switch: AxialSwitch | None = None
    # the chosen counts a run's truncation estimate raised (symgen.numerics.counts_choice): floors
    # on the bases chooser's choice of the bars whose file states neither count (None: none raised)
    counts_raised: CountsRaised | None = None

    @property
    def driver(self) -> Driver | None:
        """The scene's only driver (None without one). A scene with several drivers has no
        single one: code that reads this must handle ``drivers``, so it is refused here instead
        of silently dropping drivers 2..n."""
        if len(self.drivers) > 1:
            raise ValueError(f"scene {self.name!r} has {len(self.drivers)} drivers; read Scene.drivers")
        return self.drivers[0] if self.drivers else None

    @property
    def angle_drivers(self) -> tuple[Driver, ...]:
        """The angle drivers, in the file's order."""
        return tuple(d for d in self.drivers if d.kind == "angle")

    @property
    def turning_driver(self) -> Driver | None:
        """The first angle driver that turns at a constant rate (no law, rate != 0): its turns
        are the scene's crank turns (simulation.cycles, plots, windows); None without one."""
        return next((d for d in self.angle_drivers if d.law is None and d.rate != 0.0), None)

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)
