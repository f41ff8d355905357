"""One solver policy for the Python runners (``symgen.numerics``) and the emitted C solver.

The consistent start, the assembly, the closure polish, the singular-position test, the
range of the bar models and the divergence (beyond-buckling) check of the quasi-static start
are done twice: in Python (``symgen/numerics/mechanism.py``, ``symgen/numerics/simulate.py``) and in the emitted C
(the C runtime, ``symgen/backends/c/runtime/symgen_solver.c``). Their tolerances and limits live here only: the Python code
reads :data:`POLICY`, and the C context (``symgen/backends/c/context.py``) writes the same values into the
emitted model descriptor, which the runtime reads, so the two cannot drift apart. Each value states where it comes from.

Integrator internals with no Python twin (Radau IIA step control, ``symgen/backends/c/radau.py``) and the
Python-only quasi-static solver of (18)-(20) (``symgen/numerics/quasistatic.py``) keep their own constants.

The integrators' tolerances when a scene states neither ``simulation.rtol`` nor ``atol`` come from
its ``simulation.accuracy`` by :data:`TOLERANCES` (:func:`tolerances`), one rule per solver (IDAS's
BDF and the emitted C Radau IIA leave different global errors at the same rtol).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = [
    "SolverPolicy",
    "POLICY",
    "RangeRule",
    "RANGE",
    "ToleranceRule",
    "TOLERANCES",
    "SOLVERS",
    "tolerances",
    "range_message",
    "UnitRule",
    "UNITS",
    "RERUN_BUDGET",
    "rerun_budget",
    "ZERO_PEAK",
]


@dataclass(frozen=True)
class SolverPolicy:
    #: Newton on the position closure phi(q) = 0 stops at this |phi|_inf: coordinates are O(1)
    #: (lengths / l0, angles in rad), so this is a few hundred ulps, the round-off floor of phi.
    assembly_tol: float = 1e-13
    #: ... and when it stalls (no damped step decreases |phi|), a residual below this is still
    #: an assembly (round-off near a singular position); above it the scene cannot be assembled.
    assembly_accept: float = 1e-10
    #: Newton iterations of the assembly (quadratic convergence needs < 10 from a fair guess;
    #: the rest are for damped steps from a poor initial.guess).
    assembly_maxit: int = 60
    #: Smallest damping factor of a Newton step (halved from 1) before the assembly gives up.
    assembly_min_step: float = 1e-4
    #: Newton acceptance of a damped step: |phi(trial)| < (1 - ARMIJO * step) |phi(q)| (the
    #: classical sufficient-decrease constant 1/2).
    armijo: float = 0.5
    #: A position is singular (a toggle, a change point) when the closure Jacobian in the
    #: dependent rigid coordinates has smallest / largest singular value below this: its
    #: condition number then exceeds 1e7, so a closure solve loses about 7 of 16 digits and
    #: velocities and multipliers are no longer trustworthy to the integrator's tolerances.
    singular_ratio: float = 1e-7
    #: A step that fails (the integrator's step size collapses, the closure loses its solution)
    #: is reported as a singular position when this ratio was already below 5e-2 at the last
    #: good output: a condition number above 20, rising towards the rank loss the failing step
    #: met; else the integrator's own cause is reported.
    near_singular_ratio: float = 5e-2
    #: A rigid coordinate joins the dependent set while the closure Jacobian's columns chosen so
    #: far keep smallest / largest singular value above this (greedy partition choice).
    partition_ratio: float = 1e-6
    #: Newton on the quasi-static deformation at the start: |F|_inf at which it stops ...
    quasi_static_tol: float = 1e-12
    #: ... the residual still accepted after quasi_static_maxit iterations (else: near buckling) ...
    quasi_static_accept: float = 1e-8
    #: ... a last iterate with a residual below this is near a solution: when it lies beyond the
    #: range of the bar models, that is named as the cause (a state the model cannot hold), not
    #: the non-convergence (the residual is 1e-6 there: Newton stagnates beyond the range; at a
    #: buckling load it diverges, residuals of 1 and more) ...
    quasi_static_near: float = 1e-4
    #: ... and its iteration limit.
    quasi_static_maxit: int = 50
    #: Newton on the algebraic variables at fixed differential ones (the polish of every output
    #: row): stops at this |residual|_inf ...
    polish_tol: float = 1e-13
    #: ... or after this many iterations (it converges quadratically from the integrator's value).
    polish_maxit: int = 8
    #: Driver angle step (rad) of the central differences that give the quasi-static deformation
    #: rates and accelerations at the start: truncation O(h^2) ~ 1e-6 of them against the
    #: round-off of the second differences, O(tol / h^2) of a state solved to ``quasi_static_tol``,
    #: which a stiff bar's loads multiply by lambda (at 1e-4 rad a lambda-1e9 start is 1e-4 of
    #: peak off its inextensible limit, at 3e-3 below 3e-9; docs/exact-bars.md, "The consistent
    #: start, landed").
    driver_step: float = 3e-3
    #: The start's passes of the axial amplitudes' rates and accelerations along the bending's held
    #: motion (``start.quasi_static_start``): each changes the held axial acceleration ~200x less.
    start_axial_passes: int = 4
    #: Range of the bar models: the run stops when a bar's largest slope |eta'(xi)| (its transverse
    #: amplitudes times the shape functions' first derivatives, at the points of
    #: ``symgen.numerics.checks.range_tables``) exceeds this. The exact bar's curvature keeps
    #: kappa^2 = eta''^2 (1 + s + s^2), s = eta'^2, of eta''^2 / (1 - s): it leaves out s^3 = 0.12
    #: of the local bending energy at 0.7, and its measured output error, about
    #: ``RANGE.error_per_slope6`` s^3 of peak, reaches half the peak there: an expansion no longer
    #: of the bar (docs/exact-bars.md, "The range of the expansion"). 0.7 is also a rotation of
    #: 44 deg (eta' = sin of it), beyond the moderate rotations of the von Karman strain.
    slope_limit: float = 0.7
    #: ... and when its largest stretch ||r'| - 1| (r' = (1 + zeta', eta') its tangent from the axial
    #: and transverse amplitudes, at the same points: ``checks.range_tables``) exceeds this: the
    #: bar's elastic law is the small-strain one, one lambda (EA) and one mu (EI) at every strain.
    #: Beyond a few percent it no longer says which bar it is: the strain measures it may be
    #: written in (engineering, Green-Lagrange, logarithmic) differ by eps / 2 in the axial force,
    #: 2.5 % at 0.05, and the cross-section's contraction (Poisson's nu = 0.3-0.5) changes the
    #: bending stiffness by about 4 nu eps, 6-10 % there; and 5 % is beyond the elastic range of
    #: the materials a bar is made of (metals yield at 0.2-0.5 %, stiff polymers at 1-4 %). Not
    #: the axial amplitudes themselves: on a bent bar they carry its shortening (1/2 int eta'^2
    #: and on, 0.1 of the length at a slope of 0.55), which is not a strain (docs/exact-bars.md,
    #: "The range of the expansion").
    stretch_limit: float = 0.05
    #: Divergence check of the quasi-static start (beyond a buckling load): an eigenvalue s of
    #: the linearised motion of the deformation amplitudes about the start is a divergence when
    #: |Im s| <= this * scale and Re s > this * scale, scale = max(1, max |s|). Eigenvalues from
    #: QR (LAPACK's in Python, the C solver's own) are exact for the matrix perturbed by about
    #: eps = 2.2e-16 of its (balanced) norm: 1e-9 = 4.5e6 eps leaves that round-off of simple
    #: eigenvalues well below it (a stable undamped state's pairs +-i omega stay complex pairs).
    #: A load beyond the buckling load by a relative d has the rate omega_1 sqrt(d): refused once
    #: d > (this * omega_max / omega_1)^2 (1e-10 at a highest-to-lowest frequency ratio of 1e4).
    divergence_rtol: float = 1e-9
    #: The joint forces of an unstressed start as a continuum gives them (the first output of a
    #: run: ``symgen.numerics.start.continuum_start_outputs``, the C runtime's
    #: symgen_continuum_start_): the model's multipliers with the elastic bars' mass parameters
    #: scaled by this factor and by twice it, extrapolated linearly to 0 (2 y(f) - y(2 f)). The
    #: multipliers are rational in the factor, linear near 0, so the extrapolation's error is
    #: O(f^2) = 1e-12; the KKT matrix's condition grows as 1/f (round-off ~1e-10 of them).
    free_inertia_factor: float = 1e-6
    #: Newton on the algebraic equations at the start of a run with quasi-static transverse
    #: amplitudes (``bodies.<name>.quasi_static_transverse``; from the full model's consistent
    #: start, where they are dynamic): converged when its step is below this fraction of
    #: max(1, max |z|) (a few hundred ulps of the O(1) coordinates in z) ...
    quasi_start_tol: float = 1e-13
    #: ... or, once the step is below this fraction, when it no longer halves: Newton converges
    #: quadratically, so a step that stops shrinking is the round-off of an ill-conditioned
    #: Jacobian (a slot guide's overhang functions, nearly dependent polynomials, make the
    #: accelerations' round-off ~1e-10 of max |z|: measured on a stiff crank-shaper's lever) ...
    quasi_start_floor: float = 1e-8
    #: ... else refused after this many iterations (Newton converges quadratically from the
    #: dynamic start; a quasi-static function near buckling does not converge). The Python path
    #: (``symgen.numerics.simulate``) and the C runtime (symgen_quasi_start_) read both.
    quasi_start_maxit: int = 30

    def as_dict(self) -> dict:
        return asdict(self)


POLICY = SolverPolicy()


@dataclass(frozen=True)
class RangeRule:
    """Where a run of the exact bar (``effects.strain = "exact"``) leaves the accuracy its scene
    asks for (``simulation.accuracy``), by the bars' slopes: the warning of
    ``symgen.numerics.checks.range_record`` (the sidecar's ``range``, a line on stderr), made
    from the run's coordinates (IDAS) or the maxima the C library kept over the same rows, the
    same for both solvers. The stop at the edge
    of the model is ``SolverPolicy.slope_limit``, in both runners.

    The sixth-order bar leaves out the curvature's eta'^6 eta''^2 and the strain's eta'^6 / 16:
    a relative s^3 (s = eta'^2) of the local energy. Measured as a fraction of an output's peak,
    with s the largest slope over the run (docs/exact-bars.md, "The range of the expansion"):
    the static cantilever against the elastica 0.25 s^3 (tip 10-30 % of the length), the soft
    double pendulum's whip (the terms' own effect: the run with them against the run without,
    5 + 6 functions) 4.2 s^3 at slope 0.33, the dynamic case, where the tension works on the
    left-out shortening through the run."""

    #: an output's error, as a fraction of its peak, per s^3 = eta'^6 (the whip's 4.2, rounded)
    error_per_slope6: float = 4.0

    def warning_limit(self, accuracy: float) -> float:
        """The largest slope whose estimated error, ``error_per_slope6 * slope^6``, is within
        ``accuracy`` (0.37 at the default 0.01), never above the stop ``POLICY.slope_limit``."""
        return min((accuracy / self.error_per_slope6) ** (1.0 / 6.0), POLICY.slope_limit)


RANGE = RangeRule()


def range_message(body: str, what: str, limit: float, size: str) -> str:
    """The words of the stop at the edge of a bar model, shared by the Python runners
    (``symgen.numerics.checks.beyond_range``) and the emitted C (``symgen.backends.c.context``):
    ``what`` "slope" (``POLICY.slope_limit``) or "stretch" (``POLICY.stretch_limit``); ``size``:
    the value in words (Python's run gives the number, the C's says "this" and its runtime
    appends the number)."""
    if what == "slope":
        amount = "its largest slope |eta'| reaches"
        rest = (
            "the exact bar's expansion leaves out s^3 of the local bending energy, s = eta'^2, and the "
            "von Karman strain holds for moderate rotations"
        )
    elif what == "stretch":
        amount = "its largest stretch ||r'| - 1| reaches"
        rest = (
            "the bar's elastic law, one lambda and one mu at every strain, holds for small strains; on a stiff "
            "bar, too few axial functions to follow the bent bar's shortening (axial_modes) show as a stretch"
        )
    else:
        raise ValueError(f"no range check of {what!r} (slope or stretch)")
    return (
        f"bar '{body}' is deformed beyond the range of the model: {amount} {size} (limit {limit:g}; {rest}): "
        "a load beyond a buckling load, or forces the bar cannot carry"
    )


@dataclass(frozen=True)
class UnitRule:
    """How large one translation unit of a compiled library may be (``symgen.numerics.compiled``:
    CasADi's C of the runner's Functions; the emitted C solver's own C is not cut). The C
    compiler's memory grows with the operations of a unit, its time faster than they: gcc at
    -O0 takes about 4.5 kB and 50-75 us per CasADi operation (the exact four-bar's richer model,
    ``jac_dae`` at 322 k operations: 1.45 GB, 23 s), at -O1 about 9 kB (its ``dae``, 66 k: 615
    MB, 28 s). A Function of more operations than its bound is computed by parts of its output
    rows, each a unit of its own (compiled in parallel), and a small unit that calls them
    (``compiled.parts``): each entry is the same operations on the same operands, so the same
    number to the last bit; the values several rows share are computed in each part that needs
    them. Measured (``benchmarks/bench_first_run.py``, docs/exact-bars.md "The first run's
    cost"): that ``jac_dae`` in 13 parts, at most 196 MB and 22 s in all; that ``dae`` in 3
    parts, at most 234 MB and 18 s in all, 3-6 % slower per call."""

    #: the operations of one unit of a Function evaluated rarely (compiled at -O0: IDAS's
    #: Jacobian, the algebraic polish, the outputs): gcc's peak about 200 MB ...
    cold_ops: int = 50_000
    #: ... and of the residual ``dae`` (-O1, evaluated at every Newton iteration): gcc's peak
    #: about 250 MB
    hot_ops: int = 40_000


UNITS = UnitRule()


#: the integrators a rule is given for: IDAS (BDF, through CasADi) and the emitted C Radau IIA
SOLVERS = ("idas", "c")


@dataclass(frozen=True)
class ToleranceRule:
    """rtol and atol from ``simulation.accuracy`` (a fraction of each output's peak) when the scene
    states neither: ``rtol = accuracy * rtol_per_accuracy[solver]`` within ``[rtol_min, rtol_max]``,
    ``atol = rtol * atol_per_rtol[solver]``. The factors keep the time-integration error (the run
    against a converged run of the same model, max over the run / peak) at or below accuracy / 30
    on every validation scene and example measured, a third of the tenth of the accuracy left to
    it beside truncation and model form (benchmarks/RESULTS.md, "Tolerances from the accuracy").

    The coordinates are in units of a bar's length: rigid ones O(1), the elastic amplitudes of
    steel and aluminium bars at speed 1e-5 to 1e-3. atol must keep those under relative error
    control: at atol = rtol / 100 (the former fixed defaults' ratio) the steel slider-crank
    from rest (amplitudes 1e-4) was 260 x rtol off with the C solver and 370 x with IDAS."""

    #: rtol / accuracy of each solver (keys: :data:`SOLVERS`). BDF's global error on a run that
    #: rings undamped is up to 25 x its rtol (the steel slider-crank from rest) and 230 x (a bar
    #: vibrating freely through 30 periods) with this atol; Radau IIA's (order 5) up to 10 x.
    #: The seed's one-mode slider-crank (linear strain, its axial mode ringing undamped through
    #: 400 periods) is the exception: 2000 x rtol with IDAS, 40 x with the C solver; the error
    #: estimate's time part measures it and the command line warns (its example states rtol) ...
    rtol_per_accuracy: tuple[tuple[str, float], ...] = (("idas", 2e-4), ("c", 3e-3))
    #: ... atol / rtol of each solver ...
    atol_per_rtol: tuple[tuple[str, float], ...] = (("idas", 1e-6), ("c", 1e-4))
    #: ... rtol never looser than this (the loader warns above 1e-3 for a stated rtol) ...
    rtol_max: float = 1e-3
    #: ... nor tighter than this (round-off: coordinates O(1) in double precision)
    rtol_min: float = 1e-10

    def rtol_factor(self, solver: str) -> float:
        return _of(self.rtol_per_accuracy, solver)

    def atol_factor(self, solver: str) -> float:
        return _of(self.atol_per_rtol, solver)


def _of(table: tuple[tuple[str, float], ...], solver: str) -> float:
    for name, value in table:
        if name == solver:
            return value
    raise ValueError(f"no tolerance rule for the solver {solver!r} (one of {', '.join(SOLVERS)})")


TOLERANCES = ToleranceRule()


def tolerances(accuracy: float, solver: str = "idas", rule: ToleranceRule | None = None) -> tuple[float, float]:
    """(rtol, atol) of ``solver`` ("idas" or "c") for a scene that asks ``accuracy`` of every
    output and states no tolerances (:class:`ToleranceRule`)."""
    rule = TOLERANCES if rule is None else rule
    rtol = _round(min(rule.rtol_max, max(rule.rtol_min, accuracy * rule.rtol_factor(solver))))
    return rtol, _round(rtol * rule.atol_factor(solver))


def _round(x: float) -> float:
    """``x`` to 12 significant digits: 3e-09, not the product's 3.0000000000000004e-09, in the
    sidecar, ``symgen check`` and the emitted C."""
    return float(f"{x:.12g}")


#: The error estimate's reruns (its time part's run at 10x tighter tolerances, its truncation part's
#: run of the richer model; the chosen counts' decision is that truncation part) may take at most
#: this many times the integrator steps of the run they check (at least one step per output: a run
#: of few steps still gets a rerun of this many per output), by the rerun's own solver (IDAS's BDF
#: steps, the C solver's Radau IIA steps: ``symgen.numerics.simulate``, ``symgen.numerics.csolver``).
#: Past it the rerun is stopped and its part is "not estimated (budget: ...)". Steps, not CPU:
#: deterministic (the same decision on a loaded machine), counted the same way by both solvers.
#: Measured: the richer model's rerun at the run's tolerances takes up to 6.3x the run's steps (the
#: steel slider-crank's two added undamped bending functions, benchmarks/RESULTS.md "The error
#: estimate's cost"), and 10x tighter tolerances 1.3x-2x more (crank_pendulum_nylon's 5 + 6 exact
#: strip: 4761 -> 6208 steps): up to about 12x; 25 leaves 2x beside that. What it cuts: the
#: kept-out crank_pendulum_nylon's richer rerun at 55x (216 405 steps; benchmarks/validation/README.md).
RERUN_BUDGET = 25.0


def rerun_budget(run_steps: int, outputs: int, factor: float | None = None) -> int:
    """The step budget of a rerun checking a run of ``run_steps`` steps over ``outputs`` output
    steps: ``RERUN_BUDGET`` (or ``factor``) times the larger of the two."""
    return int(math.ceil((RERUN_BUDGET if factor is None else factor) * max(int(run_steps), int(outputs), 1)))


#: An output whose largest |value| over a run is at or below this, in the model's unit of its kind
#: (a deflection, slope or stretch per its bar's length, a position per l0, an angle in rad, a
#: force per m_ref l0^2 omega^2, a moment or an energy per m_ref l0^3 omega^2: symgen.numerics.units),
#: is zero to round-off: no error estimate is a fraction of its peak and no run-time decision (the
#: counts, the strain, the axial treatment) or warning is taken on it
#: (:meth:`symgen.numerics.run_result.SimResult.peaks`). Measured: a uniform arm spun at constant
#: speed has its tip's deflection 1e-20 (exactly 0 in the physics: the centrifugal load is axial);
#: read as a fraction of that peak, its estimate was 2.6 "of peak", which raised the arm's counts
#: twice to their cap and warned for tighter tolerances (tests/test_zero_peak.py). 1e-12 is far
#: below what any output a user asks for carries (a deflection of 1e-12 of a bar's length is below
#: an atom's size on a bar under 100 m; the stiffest bars tested, lambda 1e10, deflect 1e-10 and
#: stretch 3e-11 of their length under unit loads) and above the round-off of O(1) coordinates
#: (eps = 2.2e-16) carried through the run and the closure's Newton (``assembly_tol`` 1e-13).
ZERO_PEAK = 1e-12
