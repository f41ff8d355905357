"""The consistent start of a run: assembly at t0, the partition, the singular-position check,
and, when the scene asks for it (``initial.deformation = "quasi-static"``), the quasi-static
deformation (18)-(19) with its range and divergence checks (``symgen.numerics.checks``).

``start_plan`` gives the same start as data (``symgen.ir.plan.StartPlan``) for the emitted C
solver, which runs it again from the same guess with the same partitions.

The joint forces of an unstressed start as the continuum gives them
(``continuum_start_outputs``): a run's first output of the driver torques and reactions, on
every path (the IDAS run, ``symgen.numerics.simulate``; the C runtime's start from the plan's
``free_inertia`` and ``start_forces`` and ``POLICY.free_inertia_factor``)."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, TypeAlias

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.errors import SimulationError
from symgen.ir.plan import AmplitudeGroup, StartPlan
from symgen.ir.records import CoordKind
from symgen.numerics import checks
from symgen.numerics.index1 import Partition
from symgen.policy import POLICY

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism

    #: a solved start (:func:`_start`): q, v, a, lam, the partition, the guess (q, v), the
    #: assembly's partition
    SolvedStart: TypeAlias = tuple[
        np.ndarray, np.ndarray, np.ndarray, np.ndarray, Partition, tuple[np.ndarray, np.ndarray], Partition
    ]

#: a consistent start: (q, v, a, lam, partition)
State: TypeAlias = "tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Partition]"


#: Seeds of the assembly branch search (initial.guess not given): angles of the free bars drawn
#: from this generator, this many; the first that assembles to a regular position is taken.
BRANCH_SEED, BRANCH_TRIES = 20261125, 64
#: the branch notes told on stderr in this process (each once: the estimate's reruns of the
#: run and of its richer model start from the same guess)
_NOTES_TOLD: set[str] = set()


def _assembled(mech: Mechanism, t0: float, q: np.ndarray) -> tuple[Partition, np.ndarray, Partition]:
    """(partition of the assembly, the assembled q, partition at it) from the guess q; a
    SimulationError when it cannot be assembled or is at a singular position."""
    assembly = mech.choose_partition(t0, q)
    q = mech.assemble(t0, q, assembly)
    part = mech.choose_partition(t0, q)  # re-choose at the assembled position
    ratio, row = checks.singular_ratio(mech, t0, q, part)
    if ratio < POLICY.singular_ratio:
        raise SimulationError(
            t0,
            f"the rigid mechanism starts at a singular position: the closure Jacobian "
            f"of the {mech.loop_name(row)} loses rank (ratio {ratio:.2e})",
            "start the driver at another angle or change initial.guess",
        )
    return assembly, q, part


def _find_branch(
    mech: Mechanism, t0: float, q0: np.ndarray, failure: SimulationError
) -> tuple[np.ndarray, tuple[Partition, np.ndarray, Partition]]:
    """The assembly from the first of ``BRANCH_TRIES`` seeded guesses of the free bar angles
    that assembles to a regular position: (that guess, its assembly). The branches found are
    told on stderr, with the initial.guess that selects each; none found: ``failure``, which
    names the real cause (the mechanism cannot be assembled), with the hint of a guess."""
    driven = {d.body for d in mech.scene.drivers}
    free = [i for i, c in enumerate(mech.coords) if c.kind is CoordKind.THETA and c.body not in driven]
    rng = np.random.default_rng(BRANCH_SEED)
    found: list[tuple[np.ndarray, tuple[Partition, np.ndarray, Partition]]] = []
    for _ in range(BRANCH_TRIES):
        q = q0.copy()
        q[free] = rng.uniform(-np.pi, np.pi, len(free))
        try:
            result = _assembled(mech, t0, q)
        except SimulationError:
            continue
        wrapped = np.angle(np.exp(1j * result[1][free]))
        if not any(np.allclose(wrapped, np.angle(np.exp(1j * r[1][free])), atol=1e-6) for _, r in found):
            found.append((q, result))
    # the branch drawn highest first (bars above their joints, as mechanisms are usually drawn)
    found.sort(key=lambda branch: -float(np.sin(branch[1][1][free]).sum()))
    if not found:
        raise SimulationError(
            t0,
            f"{failure.cause}; no assembly was found from {BRANCH_TRIES} other guesses "
            "of the bar angles either: the mechanism cannot be assembled at the start",
            "check the lengths, ground points and the driver's initial angle; or give initial.guess angles (rad)",
        ) from None

    def angles(q: np.ndarray) -> str:
        return ", ".join(f"{mech.coords[i].body} = {float(np.angle(np.exp(1j * q[i]))):.4g}" for i in free)

    others = "; ".join(f"{{ {angles(r[1])} }}" for _, r in found[1:])
    note = (
        f"symgen: note: initial.guess is not given and the bars at angle 0 do not assemble "
        f"({failure.cause}); assembled on branch 1 of {len(found)} found: {{ {angles(found[0][1][1])} }}"
        + (f"; for another, set initial.guess = {others}" if others else "")
    )
    if note not in _NOTES_TOLD:  # once per process: the estimate's reruns start the same way
        _NOTES_TOLD.add(note)
        print(note, file=sys.stderr)
    return found[0]


def consistent_start(mech: Mechanism, t0: float = 0.0) -> State:
    """Consistent (q, v, a, lam) at t0 and the coordinate partition."""
    return _start(mech, t0)[:5]


def continued_start(mech: Mechanism, t0: float, q: np.ndarray, v: np.ndarray) -> State:
    """A consistent state of ``mech`` at t0 from the (q, v) another model of the same coordinates
    reached there (a run continued with another axial treatment: ``Scene.axial_switch``): q
    assembled (the dependent coordinates, and the amplitudes ``mech``'s rows fix: a quasi-static
    bar's axial amplitudes), the velocities from v, the accelerations and multipliers of ``mech``."""
    _, q, part = _assembled(mech, t0, np.asarray(q, dtype=float).copy())
    v = mech.velocities(t0, q, np.asarray(v, dtype=float).copy(), part)
    a, lam = mech.accelerations(t0, q, v)
    return q, v, a, lam, part


def start_plan(mech: Mechanism) -> StartPlan:
    """The start of the scene's run at tau = 0 as data for the emitted C solver: the partitions
    this start chooses (at the guess, for the assembly, and at the assembled position, for the
    run), the guess itself, and the index sets of the quasi-static start and of the checks.
    Runs the whole start once, so a scene the Python start refuses is refused here too.
    The run's partition is the IDAS run's (``Mechanism.run_partition``): the quasi-static
    transverse amplitudes (``Mechanism.quasi``: stated by ``bodies.<name>.quasi_static_transverse``
    or chosen by ``symgen.scene.bases.quasi_choice``) are neither independent nor dependent, and
    the C start solves them from their rows after the full model's start, as IDAS's does
    (docs/quasi-static-modes.md). The index sets of the continuum's start joint forces
    (``free_inertia_parameters``, ``start_force_outputs``) let the C start take the same limit
    with the run's parameters."""
    _, _, _, _, part, (q0, v0), assembly = _start(mech, 0.0)
    run = mech.run_partition(part)
    info = mech.info
    dep = set(part.dep)
    inext_rows, inext_axial = info.inextensible_rows, info.inextensible_axial
    forces = start_force_outputs(mech)
    follow, moving = following_axial(mech, part) if mech.scene.initial.quasi_static else ((), ())
    # the dependent coordinates are rigid but with inextensible rows, where the start's are the model's
    assert not (forces and set(info.elastic) & dep), "a continuum start with a dependent amplitude"
    return StartPlan(
        independent=tuple(run.ind),
        dependent=tuple(run.dep),
        assembly_dependent=tuple(assembly.dep),
        q_guess=tuple(float(x) for x in q0),
        v_guess=tuple(float(x) for x in v0),
        elastic=tuple(i for i in info.elastic if i not in dep),
        accel=tuple(sorted(set(info.rigid) | dep)),
        inextensible_rows=inext_rows,
        inextensible_axial=inext_axial,
        singular_rows=tuple(i for i in range(info.m) if i not in inext_rows),
        singular_cols=tuple(i for i in part.dep if i not in inext_axial),
        amplitudes=tuple(AmplitudeGroup(body, f, g) for body, (f, g) in info.amplitudes.items()),
        # the same index sets as continuum_start_outputs (the C runtime checks the start is
        # unstressed on `elastic`: here every amplitude, the dependent ones being rigid)
        free_inertia=free_inertia_parameters(mech) if forces else (),
        start_forces=forces,
        quasi=tuple(run.quasi),
        follow=follow,
        moving=moving,
    )


def _start(mech: Mechanism, t0: float) -> SolvedStart:
    """(q, v, a, lam, partition, (q, v) guessed, partition of the assembly) at t0: made once per
    mechanism and t0 (``Mechanism.starts``; a start that fails is not kept), copies returned. The
    start is a function of the model, its parameters and t0 alone (not of a run's tolerances), so
    the error estimate's reruns of the run's own model (the time part's tighter run) and the C
    path's start plan after an IDAS run take the run's start instead of solving it again."""
    key = float(t0)
    if key not in mech.starts:
        mech.starts[key] = _solve_start(mech, key)
    q, v, a, lam, part, (q0, v0), assembly = mech.starts[key]
    return q.copy(), v.copy(), a.copy(), lam.copy(), part, (q0.copy(), v0.copy()), assembly


def _solve_start(mech: Mechanism, t0: float) -> SolvedStart:
    """:func:`_start`, solved."""
    sc = mech.scene
    q, v = mech.initial_guess(t0)
    try:
        assembly, q_asm, part = _assembled(mech, t0, q)
    except SimulationError as failure:
        if sc.initial.guess or mech.m == 0:
            raise
        # no initial.guess: the all-zero angles are a singular or unassemblable start; find the
        # assembly branches from other seeds, take the first, and say how to choose another
        q, (assembly, q_asm, part) = _find_branch(mech, t0, q, failure)
    guess = (q.copy(), v.copy())
    q = q_asm
    if sc.initial.quasi_static:
        q, v = quasi_static_start(mech, t0, q, v, part)
    v = mech.velocities(t0, q, v, part)
    a, lam = mech.accelerations(t0, q, v)
    return q, v, a, lam, part, guess, assembly


class StaticSystem:
    """Newton system of the quasi-static state (18)-(19) for one partition: the independent
    amplitudes' rates and accelerations given (v0, a0: zero in (18)-(19), held at the start's in
    :func:`quasi_static_start`), rigid kinematics consistent with closure at all three levels.
    Unknowns u = [u_E, q_D, v_D, a_R, lam] (E: the independent amplitudes, R: the rigid and
    dependent accelerations); u_E holds each amplitude's position, or, for those in ``moving``
    (the bending a start holds on its quasi-static motion while the axial amplitudes follow it:
    :func:`quasi_static_start`), its acceleration, their position and rate given (q0, v0): the
    system keeps its size and its rows."""

    def __init__(self, mech: Mechanism, part: Partition, moving: tuple[int, ...] = ()) -> None:
        import casadi as ca  # here: a cached run of the C solver never imports CasADi

        D = list(part.dep)
        self.E = [i for i in mech.info.elastic if i not in D]
        R = sorted(set(mech.rigid) | set(D))  # unknown accelerations
        nE, nD, self.nR = len(self.E), len(D), len(R)
        u = ca.SX.sym("u", nE + 2 * nD + self.nR + mech.m)
        t = ca.SX.sym("t")
        q0 = ca.SX.sym("q0", mech.n)
        v0 = ca.SX.sym("v0", mech.n)
        a0 = ca.SX.sym("a0", mech.n)
        q, v, a = ca.SX(q0), ca.SX(v0), ca.SX(a0)
        for k, i in enumerate(self.E):
            if i in moving:
                a[i] = u[k]  # q[i], v[i]: on the held motion
            else:
                q[i] = u[k]  # v[i], a[i]: the rate and acceleration given (zero, or held: quasi_static_state)
        for k, i in enumerate(D):
            q[i] = u[nE + k]
            v[i] = u[nE + nD + k]
        for k, i in enumerate(R):
            a[i] = u[nE + 2 * nD + k]
        lam = u[nE + 2 * nD + self.nR :]
        args: list[ca.SX | np.ndarray] = [t, q, v, a, lam, mech.p]
        F = ca.vertcat(mech.f["phi"](*args), mech.f["phid"](*args), mech.f["res"](*args), mech.f["phidd"](*args))
        self.fun = ca.Function("static", [t, q0, v0, a0, u], [F, ca.jacobian(F, u), q, v])


def static_system(mech: Mechanism, part: Partition, moving: tuple[int, ...] = ()) -> StaticSystem:
    """The mechanism's quasi-static system for ``part`` (and ``moving``), built once per partition."""
    cache = mech.static_systems
    key = (part, moving)
    if key not in cache:
        cache[key] = StaticSystem(mech, part, moving)
    return cache[key]


def following_axial(mech: Mechanism, part: Partition) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(axial, moving): the independent axial amplitudes (not quasi-static) whose rates and
    accelerations the quasi-static start takes along the bending's held motion, and that bending
    (the independent transverse amplitudes, not quasi-static); ((), ()) where there is none of
    either (:func:`quasi_static_start`; the C runtime's ``follow`` from ``StartPlan.follow``)."""
    dep, quasi = set(part.dep), set(mech.quasi)
    free = [i for i in mech.info.elastic if i not in dep and i not in quasi]
    axial = tuple(i for i in free if mech.coords[i].kind is CoordKind.F)
    moving = tuple(i for i in free if mech.coords[i].kind is CoordKind.G)
    return (axial, moving) if axial and moving else ((), ())


def quasi_static(
    mech: Mechanism,
    t: float,
    q: np.ndarray,
    v: np.ndarray,
    part: Partition,
    tol: float = POLICY.quasi_static_tol,
    maxit: int = POLICY.quasi_static_maxit,
    rates: np.ndarray | None = None,
    accels: np.ndarray | None = None,
    moving: tuple[int, ...] = (),
) -> tuple[np.ndarray, np.ndarray, int]:
    """Quasi-static deformation at t for the rigid state in (q, v): returns (q, v, iterations)."""
    qn, vn, _, it = quasi_static_state(mech, t, q, v, part, tol, maxit, rates, accels, moving)
    return qn, vn, it


def quasi_static_state(
    mech: Mechanism,
    t: float,
    q: np.ndarray,
    v: np.ndarray,
    part: Partition,
    tol: float = POLICY.quasi_static_tol,
    maxit: int = POLICY.quasi_static_maxit,
    rates: np.ndarray | None = None,
    accels: np.ndarray | None = None,
    moving: tuple[int, ...] = (),
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """:func:`quasi_static` with the multipliers of that state: (q, v, lam, iterations). The
    deformation accelerations are zero in it; the deformation rates too, or, given ``rates``
    (length n, read at the independent amplitudes), held at those: the loads of the deformation
    rates (the Coriolis load 2 theta' w' of a bending rate on a turning bar's axial force) are then
    in the state and in lam; given ``accels`` too (length n, read at the independent amplitudes),
    the accelerations are held at those: the loads of the deformation's accelerations (its own
    inertia, and the foreshortening's acceleration a dependent axial amplitude has under an
    inextensible or quasi-static axial treatment) are in them (the consistent quasi-static start,
    :func:`quasi_static_start`). The amplitudes in ``moving`` keep the position and rate of (q, v)
    and their accelerations are solved for instead (:class:`StaticSystem`)."""
    system = static_system(mech, part, moving)
    fun = system.fun
    E, D = system.E, list(part.dep)
    held = [i for i in E if i not in moving]
    v = np.array(v, dtype=float)
    v[held] = 0.0 if rates is None else np.asarray(rates, dtype=float)[held]
    a = np.zeros(mech.n)
    if accels is not None:
        a[held] = np.asarray(accels, dtype=float)[held]
    uE = np.array([0.0 if i in moving else q[i] for i in E])
    u = np.concatenate([uE, q[D], v[D], np.zeros(system.nR), np.zeros(mech.m)])
    for it in range(1, maxit + 1):  # noqa: B007 - the count of iterations is returned
        F, J, _, _ = fun(t, q, v, a, u)
        F = np.array(F).ravel()
        if np.abs(F).max() < tol:
            break
        u = u - np.linalg.solve(np.array(J), F)
    else:
        F0, _, q_last, _ = fun(t, q, v, a, u)
        F = np.array(F0).ravel()
        if np.abs(F).max() > POLICY.quasi_static_accept:
            # the real cause first: Newton stagnates near a state beyond the range of the bar
            # models (the emitted C runtime decides alike)
            near = np.abs(F).max() <= POLICY.quasi_static_near
            beyond = checks.beyond_range(mech, np.array(q_last).ravel()) if near else None
            if beyond is not None:
                raise SimulationError(
                    t,
                    f"in the quasi-static state, {beyond[1]}",
                    "check the loads, lumped masses and stiffness (lambda, mu) of that bar",
                )
            raise SimulationError(
                t,
                f"the quasi-static state did not converge (residual {np.abs(F).max():.3g})",
                "the mechanism may be near buckling or a singular position",
            )
    _, _, qn, vn = fun(t, q, v, a, u)
    lam = np.asarray(u[len(E) + 2 * len(D) + system.nR :], dtype=float)
    return np.array(qn).ravel(), np.array(vn).ravel(), lam, it


def quasi_static_start(
    mech: Mechanism, t0: float, q: np.ndarray, v: np.ndarray, part: Partition
) -> tuple[np.ndarray, np.ndarray]:
    """Initial deformation = quasi-static state; under angle drivers the deformation
    rates and accelerations are the quasi-static ones too (central first and second differences
    of the quasi-static states at t0 - h, t0, t0 + h), and the deformation is solved again with
    both held, so that their loads are in it as in the run's first instant: the rates' (the
    Coriolis load 2 theta' w' of a bending rate on a turning bar's axial force) and the
    accelerations' (the deformation's own inertia, first order in it; the foreshortening's
    acceleration, which an inextensible or quasi-static axial amplitude has from its rows and a
    dynamic one only so). The run then starts with the quasi-static motion's accelerations: it
    rings little, and a dynamic axial bar's start tends to its inextensible limit's like 1/lambda
    (docs/exact-bars.md, "A consistent quasi-static start").
    An unstable quasi-static state (beyond a buckling load) is refused: the run would sit on
    an equilibrium the bar leaves at the first disturbance."""
    qs, vs, _ = quasi_static(mech, t0, q, v, part)
    beyond = checks.beyond_range(mech, qs)
    if beyond is not None:
        raise SimulationError(
            t0,
            f"in the quasi-static state, {beyond[1]}",
            "check the loads, lumped masses and stiffness (lambda, mu) of that bar",
        )
    rate, coord = checks.divergent_deformation(mech, t0, qs, vs, part)
    if rate > 0:
        raise SimulationError(
            t0,
            f"the quasi-static state is unstable: the deformation grows at rate "
            f"{rate:.3g} (per unit tau) along {coord}, a load beyond a buckling load",
            "lower the load or stiffen the bar; or start undeformed (remove initial.deformation "
            '= "quasi-static") to follow the bar into its buckled state',
        )
    if not any(any(m[1:]) for m in mech.driver_motions(t0).values()):
        return qs, vs  # angle drivers at rest (constant angles), or none: the quasi-static rates are zero
    E = static_system(mech, part).E
    h = mech.driver_step(t0)
    ends = [_shifted(mech, t0, dt, qs, vs, part)[E] for dt in (-h, h)]
    vs = vs.copy()
    vs[E] = (ends[1] - ends[0]) / (2 * h)
    acc = np.zeros(mech.n)
    acc[E] = (ends[1] - 2.0 * qs[E] + ends[0]) / (h * h)
    # the deformation again with those rates and accelerations held (their loads in it, as in the
    # run's first instant); a quasi-static amplitude has neither in the run (docs/quasi-static-modes.md)
    vs[list(mech.quasi)] = 0.0
    acc[list(mech.quasi)] = 0.0
    q1, v1, _ = quasi_static(mech, t0, qs, vs, part, rates=vs, accels=acc)
    # the axial amplitudes' rates and accelerations along the bending's held motion through the
    # state just solved (q1): axial-only quasi-static solves at t0 - h, t0, t0 + h with the bending
    # on g1 + dt g' + dt^2/2 g'' (its accelerations free), their central differences held, the state
    # solved again; POLICY.start_axial_passes times (docs/exact-bars.md, "The consistent start, landed")
    axial, moving = following_axial(mech, part)
    for _ in range(POLICY.start_axial_passes if axial else 0):
        fs = [_shifted(mech, t0, dt, q1, v1, part, moving, vs, acc)[list(axial)] for dt in (-h, 0.0, h)]
        vs[list(axial)] = (fs[2] - fs[0]) / (2 * h)
        acc[list(axial)] = (fs[2] - 2.0 * fs[1] + fs[0]) / (h * h)
        q1, v1, _ = quasi_static(mech, t0, q1, vs, part, rates=vs, accels=acc)
    return q1, v1


def _shifted(
    mech: Mechanism,
    t0: float,
    dt: float,
    q: np.ndarray,
    v: np.ndarray,
    part: Partition,
    moving: tuple[int, ...] = (),
    rates: np.ndarray | None = None,
    accels: np.ndarray | None = None,
) -> np.ndarray:
    """The quasi-static state at t0 + dt from (q, v) at t0 (:func:`quasi_static_start`'s
    differences): the driven angles moved, the ``moving`` amplitudes on their held motion
    q + dt rates + dt^2/2 accels (their rate rates + dt accels, their accelerations the unknowns),
    the closure assembled and its velocities made consistent; its q (the C runtime's
    ``symgen_shifted_`` alike)."""
    qq, vv = q.copy(), v.copy()
    for body, motion in mech.driver_motions(t0 + dt).items():
        qq[mech.info.coordinate(CoordKind.THETA, body)] = motion[0]
    if moving:
        assert rates is not None and accels is not None
        m = list(moving)
        qq[m] = q[m] + dt * rates[m] + 0.5 * dt * dt * accels[m]
        vv[m] = rates[m] + dt * accels[m]
    qq = mech.assemble(t0 + dt, qq, part)
    vv = mech.velocities(t0 + dt, qq, vv, part)
    return quasi_static(mech, t0 + dt, qq, vv, part, moving=moving)[0]


# ---------------------------------------------------------------------- the start's joint forces
#: the output kinds read from the joint forces (the multipliers): the first output of a run
#: records them as the continuum's (``continuum_start_outputs``). (The kind "axial" is the
#: bar's axial displacement zeta, read from the coordinates: the same in both.)
START_FORCE_KINDS = ("reaction", "driver_torque")
#: what a run's first output of those kinds is, for the sidecar and the method texts
START_NOTE = (
    "joint forces at the unstressed start (driver torques, reactions): the continuum's, where every elastic "
    "bar has dynamic axial and transverse functions (the bars' distributed inertia is not felt at an "
    "unstressed start; a truncated basis would leave about 1/N of a bar's mass on its joints there); "
    "the model's own at every later output"
)


def free_inertia_parameters(mech: Mechanism) -> tuple[int, ...]:
    """The parameter indices of the masses (``nu_<bar>``) of the elastic bars whose distributed
    inertia an unstressed start does not reach the joints with, or () when the start's
    joint forces are the model's own (``continuum_start_outputs``): every elastic bar needs
    dynamic axial functions and transverse functions (a bar without one family, or with
    quasi-static or inextensible axial functions, is rigid in that direction: its inertia does
    act on the joints at once), none of them quasi-static, and no slot guide (its support moves
    with the bar)."""
    from symgen.ir import names
    from symgen.ir.spec import DYNAMIC
    from symgen.model.structure import axial_treatment, slot_guide

    sc = mech.scene
    if mech.quasi or sc.initial.quasi_static or mech.info.inextensible_axial:
        return ()
    found = []
    for b in sc.bodies:
        if b.rigid:
            continue
        modes = mech.info.modes.get(b.name)
        if modes is not None and not modes.axial and not modes.transverse:
            continue  # 0 + 0 functions: a rigid bar (its inertia acts on the joints at once, kept)
        if modes is None or not modes.axial or not modes.transverse or not sc.effects.transverse:
            return ()
        if slot_guide(sc, b.name) or axial_treatment(sc, b).treatment != DYNAMIC:
            return ()
        name = names.bar_parameter("nu", b.name).text
        if name not in mech.info.params:
            return ()
        found.append(mech.info.params.index(name))
    return tuple(found)


def start_force_outputs(mech: Mechanism) -> tuple[int, ...]:
    """The indices of the outputs (``mech.info.outputs``) whose value at an unstressed start is
    the continuum's (``continuum_start_outputs``): those of ``START_FORCE_KINDS``, or () where
    the start's joint forces are the model's own (``free_inertia_parameters``)."""
    if not free_inertia_parameters(mech):
        return ()
    kind = {o.name: o.kind for o in mech.scene.outputs}
    return tuple(i for i, n in enumerate(mech.info.outputs) if kind.get(n) in START_FORCE_KINDS)


def unstressed(mech: Mechanism, q: np.ndarray, v: np.ndarray) -> bool:
    """Whether (q, v) is an unstressed start: every deformation amplitude and its rate exactly 0
    (the C runtime decides alike on its start)."""
    elastic = list(mech.info.elastic)
    return not (np.any(np.asarray(q)[elastic] != 0.0) or np.any(np.asarray(v)[elastic] != 0.0))


def continuum_start_outputs(mech: Mechanism, t0: float, q: np.ndarray, v: np.ndarray) -> dict[str, float] | None:
    """The outputs read from the joint forces (``start_force_outputs``) at an unstressed start
    as a continuum gives them (output -> value), or None where the model's own are kept (no
    such output, ``free_inertia_parameters``, or a deformed start). A run records them as its
    first output (``symgen.numerics.simulate``; the emitted C solver computes the same limit in
    its start, ``symgen_continuum_start_``, with the same ``StartPlan`` index sets and factor).

    At t0 an unstressed bar carries no stress, so each of its points accelerates on its own:
    the joints feel none of its distributed inertia or loads until waves have left them
    (axially a force rho A c times the velocity mismatch, growing from 0 with t; in bending
    like t^(1/2)). A truncated basis cannot move all of the bar's mass alone: the part of the
    frame's motion its functions cannot represent (about 1/N of the mass for N functions)
    stays attached to the joints, so the model's joint forces at t0 carry that part's inertia,
    which falls only as 1/N with the counts and is gone after the period of the highest
    function (benchmarks/RESULTS.md, "The start's joint forces"). The continuum's are the
    model's in the limit of no distributed mass on those bars (their nu -> 0; the rigid bars,
    lumped masses and rotors keep theirs), which every complete basis reaches as N grows:
    evaluated with nu scaled by ``POLICY.free_inertia_factor`` f and by 2 f and extrapolated
    to 0, 2 y(f) - y(2 f). A KKT matrix singular with the masses scaled raises
    ``numpy.linalg.LinAlgError`` (not seen: the rigid parts' inertia and the constraints
    determine it)."""
    cols = start_force_outputs(mech)
    if not cols or not unstressed(mech, q, v):
        return None
    free = list(free_inertia_parameters(mech))
    z0n, z0m = np.zeros(mech.n), np.zeros(mech.m)
    outs = []
    for factor in (POLICY.free_inertia_factor, 2.0 * POLICY.free_inertia_factor):
        p = np.array(mech.p, dtype=float)
        p[free] *= factor
        K, r = mech.kkt(t0, q, v, z0n, z0m, p)
        sol = np.linalg.solve(np.array(K), -np.array(r).ravel())
        outs.append(np.array(mech.f["out"](t0, q, v, sol[: mech.n], sol[mech.n :], p)).ravel())
    limit = 2.0 * outs[0] - outs[1]
    names = list(mech.info.outputs)
    return {names[i]: float(limit[i]) for i in cols}
