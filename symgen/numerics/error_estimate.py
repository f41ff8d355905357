"""An a-posteriori error estimate of every output of a finished run (issue 19, item 2).

The estimate of an output is a fraction of its peak, the sum of the parts that were estimated
(a part that was not is ``None`` with its reason, never 0):

* **truncation** -- how much the output would change with more functions per bar. An
  *embedded richer model* -- the same scene with ``EXTRA_AXIAL`` more axial and
  ``EXTRA_TRANSVERSE`` more transverse functions on every elastic bar that has them (a slot's
  guide with an elastic overhang ``EXTRA_GUIDE`` more span functions and as many more overhang
  functions; with a rigid overhang it keeps its counts), derived once and cached like any model (its added axial functions
  quasi-static from a quasi-static start, else dynamic: :func:`richer_scene`) -- is evaluated
  against the run, in one of two ways (``TRUNCATION_METHODS``):

  - ``"rerun"`` (the default): a second run of the richer model on the run's own output grid;
    the estimate is its difference to the run's model, both at ``TIGHTER`` times tighter
    tolerances than the run's (the model's tighter run is the time part's, made once:
    :func:`_tight`). Against the run itself at its own tolerances the difference carries both
    runs' time errors: the run's, which the time part charges again (kept-out d_alu_mass_long:
    correlation 0.99 with the time part's difference), and the richer run's, which is not
    truncation (the slider-crank 6.1 at rtol 1e-4: eps_ax 4.6x of the truncation alone, 0.90x
    at matched tighter tolerances; ``tests/test_error_estimate.py``). Where there is no tighter
    run (it failed, or the run integrated nothing) the richer model at the run's tolerances
    against the run, said in the method text. The richer model runs in IDAS, or after a
    ``--solver c`` run in its C solver when that library was built before (never compiled for
    the estimate: :func:`_same_solver_run`).
  - ``"linearized"``: no second integration. At the run's outputs its state (q, v, a, lam) is
    carried into the richer model's amplitudes (by index where the families are hierarchical,
    else by a least-squares map of the shape functions: the tip-load shape and the static
    corrections change with the count), where it leaves a residual only in the rows of the added
    functions: their generalized load (the distributed inertia of the frame's motion and of the
    retained amplitudes, gravity, the joint forces, i.e. the multipliers, projected onto the
    added functions). The richer model's own Jacobians linearised along the run (mass, damping,
    stiffness with the axial force's geometric stiffness, constraint rows, so the loop's
    compliance moves the angles and joint positions) are marched over the outputs by BDF2, which
    follows the retained functions' dynamics and leaves the added ones, far above what the
    output grid resolves, at their quasi-static response (residual flexibility); the outputs
    are read by the richer model's own output function.

  Both measure the change as the run's outputs are written: max over the output samples of
  |change| / peak |output|, the error a user reads off the result (and the validation suite's
  "true error", benchmarks/bench_validation.py). Not the low-passed measure of ``symgen study``
  (below ``DEFAULT_CUTOFF`` cycles per turn, ``symgen.numerics.signals``): the error of a
  truncated basis is mostly the ringing of the retained bending modes whose frequencies the
  truncation moves, and the second and higher modes ring above that cutoff (the aluminium
  double pendulum's upper tip: 1.7e-4 of peak against the converged model, of which 1.3e-5
  below the cutoff; the driver torques likewise). The samples of a ringing far above the grid
  are still the run's values there (aliased or not), so the difference of two runs' samples is
  their error there. Measured on both suites (RESULTS.md, "Error estimate" and "The error
  estimate against the true error"): the rerun lies within 0.8x-1.1x of the unfiltered
  difference to the converged model where the low-passed measure put it 0.9x to 340x of its own.

  Why the rerun is the default: ``benchmarks/bench_estimate.py`` (RESULTS.md, "Error estimate")
  compares both with the error measured against converged richer models on seven mechanisms.
  The rerun lies within 0.82x-1.11x of it on every output checked (15, measured as the outputs
  are written; 0.75x-1.13x low-passed). The linearised route is as
  good where the motion forces the response (the slider-crank, the steel four-bar, the
  deflections of the four-bar with a tool) but 10x to 100x low where the run rings freely
  (a released double pendulum, a torque-driven arm, a driver reaction with a ringing coupler):
  there a changed frequency slips the phase over the run, which is not linear in the change.
  The projection of the loads by hand onto the omitted functions was not written: it would be
  a second implementation of every load and joint beside the derivation's, and the linearised
  route, which gets the same projection from the derivation itself, shows that a quasi-static
  answer is not enough. The rerun costs a derivation (once) and a run of a model with two more
  functions per bar (``symgen simulate --estimate linearized|off`` for less).
* **time integration** -- with the "rerun" method, the run's difference to itself at
  ``TIGHTER`` times tighter tolerances (x 1/(1 - TIGHTER^-0.7)), by the run's own solver: a
  measurement, where a run that rings freely through many periods accumulates a phase error
  beyond any fixed multiple of rtol (the released double pendulum: 110x rtol). Measured against
  converged runs on the validation suite at the tolerances a scene gets from its accuracy
  (``symgen.policy.tolerances``): 1.1x to 1.3x the true time error, where the a-priori bound
  below was 30x to 1000x it (it would have been most of the estimate). Without a rerun (the
  "linearized" method, or a rerun that failed): that a-priori bound from the integrator's
  tolerances, ``TIME_FACTOR * rtol`` plus ``atol`` over the output's peak
  (``ALGEBRAIC_TIME_FACTOR`` for the outputs read from the multipliers, algebraic variables
  that IDAS's error control leaves out: driver torques measured up to 30x rtol). A run of
  ``simulate`` with no differential states (every rigid coordinate driven, every elastic
  amplitude quasi-static) integrated nothing: each output is the algebraic solution at its time
  by Newton, its part 0 with that said (:data:`ALGEBRAIC_TIME_TEXT`), no rerun, no bound.
* **model form** -- the gap between the bar model and a geometrically exact beam: the terms of
  the exact curvature the run's bar leaves out (von Karman: all beyond eta''^2; the exact bar:
  those beyond its fourth-order expansion), ``symgen.numerics.model_form``, numpy only on the
  shape samples the derivation cached. Connected through :data:`MODEL_FORM_ESTIMATORS`
  (:func:`register_model_form`) or the ``model_form`` argument. The seed's linear strain and
  ``geometric_stiffening = false`` are "not estimated" with the reason.
* **axial** -- what the quasi-static axial treatment of a bar (``effects.axial =
  "quasi_static"``, or ``"auto"`` where the bar's axial frequency is far above the motion) leaves
  out of the run that the other parts cannot see (the truncation rerun keeps the treatment): the
  stretch's inertia, whose phase drift of the free motion grows over the run
  (``symgen.numerics.axial_drift``; a freely spinning soft arm: 0.081 % per radian-time unit of
  rate, 5.4 % of tip_x after 11 turns; 0 where every rigid motion is driven), or the start's axial
  ringing where the run does not start on its quasi-static deformation (a window from the start
  with the axial dynamics kept: the press started at speed, its torque 7.4 %) or starts on it
  under a varying load (the start's equilibrium left out the loads of the deformation rates: an
  oscillating arm at lambda 1e3, tip_u 2.94 % off, charged 2.99 %; the start now holds them and
  the accelerations' loads, the axial amplitudes' along the bending's motion, 0.47 % off, read
  over the whole run with the axial dynamics kept, 0.47 %), or the stretch's
  own inertia (its centrifugal load on a spinning bar, its acceleration under a varying load: a
  steel arm at lambda 1189 driven at a constant rate, its tip stretch 3.4e-4 of itself short of
  the closed form, charged 3.35e-4), the largest of the three per output. 0 where no bar is
  quasi-static.

**The reruns' budget.** Each rerun (the time part's run at tighter tolerances, the truncation
part's run of the richer model) may take at most ``symgen.policy.RERUN_BUDGET`` times the steps of
the run it checks (:func:`symgen.policy.rerun_budget`, its solver's steps, IDAS's or the C
solver's). Past it the rerun is stopped and its part is not estimated, its reason beginning
``BUDGET_PREFIX`` ("budget: ... stopped after N steps, beyond its budget of B"): the truncation part
when either of its runs was stopped, the time part when its run was (not the a-priori bound: on a
run whose steps grow that much it would be a small number that looks like an estimate), and then
no output gets a total (``outputs`` all None; the CLI warns and says what to do). The kept-out
crank_pendulum_nylon (benchmarks/validation/README.md) is what it is for: its richer rerun took
216 405 IDAS steps, 55x its run's.

The record (:class:`ErrorEstimate`) is typed, with ``to_json``/``from_json`` that check every
field; a run's sidecar holds ``error_estimate: {output: fraction of peak}`` and the record as
``error_estimate_detail`` (``symgen.numerics.results.write_run``). Closure residuals are not
estimated (they are zero to round-off in every model).
"""

from __future__ import annotations

import dataclasses
import math
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen import __version__
from symgen.errors import BudgetExceeded, SymgenError
from symgen.ir.info import record_fields
from symgen.ir.records import CoordKind
from symgen.numerics.run_result import MeasuredOnce
from symgen.scene.model import CHECK_KINDS

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import SimResult

__all__ = [
    "EXTRA_AXIAL",
    "EXTRA_TRANSVERSE",
    "MODEL_FORM_ESTIMATORS",
    "PARTS",
    "ErrorEstimate",
    "InvalidEstimate",
    "combined",
    "estimate_errors",
    "keep_truncation",
    "register_model_form",
    "time_integration_part",
    "truncation_part",
]

#: the richer model of the truncation part: this many more functions per elastic bar
EXTRA_TRANSVERSE = 2
EXTRA_AXIAL = 2
#: a slot guide's richer model (elastic overhang): this many more span functions and this many more
#: of the overhang's own (the guide's derivation grows steeply with its functions: 2 + 1 + 4 of the
#: overhang reference take minutes; its true error against Exudyn and the estimate:
#: tests/test_overhang_reference.py)
EXTRA_GUIDE = 1
#: sampled outputs of the truncation part (all of them when the run has fewer)
MAX_SAMPLES = 2000
#: how the truncation part is computed: "rerun" (a second run of the richer model: honest also
#: where the run rings freely and a changed frequency slips the phase over the run) or
#: "linearized" (the richer model linearised along the run: no second integration; measured
#: honest where the response is forced, 4x to 20x low where it rings freely: benchmarks/RESULTS.md)
TRUNCATION_METHODS = ("rerun", "linearized")
#: the time-integration bound: this many times rtol (plus atol over the output's peak; measured up
#: to 17 x rtol on steel bars against runs at 100x tighter tolerances) ...
TIME_FACTOR = 30.0
#: ... and this many for the outputs read from the multipliers (reactions, the driver torque,
#: axial forces), algebraic variables outside IDAS's error control: measured up to 30 x rtol
#: against runs at 100x tighter tolerances (benchmarks/RESULTS.md, "Error estimate")
ALGEBRAIC_TIME_FACTOR = 100.0
ALGEBRAIC_KINDS = ("reaction", "driver_torque", "axial")
#: the parts, in the order they are reported
PARTS = ("truncation", "model_form", "axial", "time_integration")
#: the part added after records were first written (symgen 2026-11-26): a record without it reads
#: as "not estimated" with this reason
LATER_PART = "axial"
LATER_REASON = "the record was written before symgen estimated the quasi-static axial treatment"

#: name -> a model-form estimator: ``f(mech, result) -> (output -> fraction of peak, method text)``.
#: The curvature estimate (symgen.numerics.model_form) is registered below.
ModelFormEstimator = Callable[["Mechanism", "SimResult"], tuple[dict[str, float], str]]
MODEL_FORM_ESTIMATORS: dict[str, ModelFormEstimator] = {}


def register_model_form(name: str, estimator: ModelFormEstimator) -> None:
    """Connect a model-form estimator (the seam of the model-form part)."""
    MODEL_FORM_ESTIMATORS[name] = estimator


def _curvature(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """The curvature's left-out terms (von Karman's beyond eta''^2, the exact bar's beyond its
    expansion): :func:`symgen.numerics.model_form.estimate`, imported when a run is estimated."""
    from symgen.numerics.model_form import estimate

    return estimate(mech, result)


register_model_form("curvature", _curvature)


class InvalidEstimate(ValueError):
    """An ``error_estimate_detail`` record that is not one (a field missing or of a wrong type)."""


# ---------------------------------------------------------------------- the record
@dataclass(frozen=True)
class ErrorEstimate:
    """The error estimate of a run's outputs, each a fraction of the output's peak.

    ``outputs``: output -> the sum of its estimated parts (None when no part was estimated).
    ``parts``: part -> output -> value, or None for "not estimated" (``reasons[part]`` says why).
    ``methods``: part -> how it was estimated. ``richer``: bar -> [axial, transverse] counts of
    the richer model of the truncation part. ``zero``: output -> its largest |value|, for the
    outputs that are zero to round-off over the run (:meth:`SimResult.peaks`): not estimated, no
    decision taken on them."""

    outputs: dict[str, float | None]
    parts: dict[str, dict[str, float | None]]
    methods: dict[str, str]
    reasons: dict[str, str] = field(default_factory=dict)
    richer: dict[str, list[int]] = field(default_factory=dict)
    zero: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "outputs": dict(self.outputs),
            "parts": {p: dict(v) for p, v in self.parts.items()},
            "methods": dict(self.methods),
            "reasons": dict(self.reasons),
            "richer": {b: list(c) for b, c in self.richer.items()},
            "zero": dict(self.zero),
        }

    @classmethod
    def from_json(cls, data: object) -> ErrorEstimate:
        """The record of ``to_json``'s data; :class:`InvalidEstimate` on anything malformed."""
        keys = ("outputs", "parts", "methods", "reasons", "richer", "zero")
        if isinstance(data, dict) and "zero" not in data:
            data = {**data, "zero": {}}  # a record written before the zero outputs were told apart
        data = record_fields(data, "the error estimate", keys, InvalidEstimate)
        outputs = _values(data["outputs"], "outputs")
        parts_raw = data["parts"]
        methods_raw, reasons_raw = data["methods"], data["reasons"]
        if (
            isinstance(parts_raw, dict)
            and isinstance(methods_raw, dict)
            and isinstance(reasons_raw, dict)
            and set(parts_raw) == set(PARTS) - {LATER_PART}
            and LATER_PART not in methods_raw
        ):
            # a record written before the axial part: that part was not estimated
            parts_raw = {**parts_raw, LATER_PART: dict.fromkeys(outputs)}
            data = {
                **data,
                "methods": {**methods_raw, LATER_PART: "not estimated"},
                "reasons": {**reasons_raw, LATER_PART: LATER_REASON},
            }
        if not isinstance(parts_raw, dict) or set(parts_raw) != set(PARTS):
            raise InvalidEstimate(f"'parts' is not an object of the parts {', '.join(PARTS)}")
        parts = {p: _values(parts_raw[p], f"parts.{p}") for p in PARTS}
        for p, vals in parts.items():
            if set(vals) != set(outputs):
                raise InvalidEstimate(f"'parts.{p}' does not name the same outputs as 'outputs'")
        methods, reasons = (_texts(data[k], k) for k in ("methods", "reasons"))
        if set(methods) != set(PARTS):
            raise InvalidEstimate(f"'methods' does not describe the parts {', '.join(PARTS)}")
        richer = data["richer"]
        if not isinstance(richer, dict) or not all(
            isinstance(b, str)
            and isinstance(c, list)
            and len(c) == 2
            and all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in c)
            for b, c in richer.items()
        ):
            raise InvalidEstimate("'richer' is not an object of [axial, transverse] counts")
        zero = _values(data["zero"], "zero")
        if not set(zero) <= set(outputs) or any(v is None for v in zero.values()):
            raise InvalidEstimate("'zero' is not an object of the outputs' peaks")
        return cls(
            outputs,
            parts,
            methods,
            reasons,
            {b: list(c) for b, c in richer.items()},
            {n: float(v) for n, v in zero.items() if v is not None},
        )

    @classmethod
    def not_estimated(cls, names: list[str], reason: str) -> ErrorEstimate:
        """The record of a run whose error was not estimated (every part, with the reason)."""
        return cls(
            dict.fromkeys(names),
            {p: dict.fromkeys(names) for p in PARTS},
            dict.fromkeys(PARTS, "not estimated"),
            dict.fromkeys(PARTS, reason),
        )

    def text(self, name: str) -> str:
        """One output's estimate as text: the total and its parts ("not estimated" for a part
        that was not)."""
        if name in self.zero:
            return f"not estimated: zero to round-off (peak {self.zero[name]:.1e})"
        total = self.outputs.get(name)
        cells = []
        for p in PARTS:
            v = self.parts[p].get(name)
            cells.append(f"{p.replace('_', ' ')} {'not estimated' if v is None else f'{v:.1e}'}")
        head = "not estimated" if total is None else f"{total:.1e}"
        return f"{head} ({', '.join(cells)})"


def _values(x: object, what: str) -> dict[str, float | None]:
    if not isinstance(x, dict) or not all(
        isinstance(k, str)
        and (v is None or (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0))
        for k, v in x.items()
    ):
        raise InvalidEstimate(f"{what!r} is not an object of fractions (or null)")
    return {k: (None if v is None else float(v)) for k, v in x.items()}


def _texts(x: object, what: str) -> dict[str, str]:
    if not isinstance(x, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in x.items()):
        raise InvalidEstimate(f"{what!r} is not an object of texts")
    return dict(x)


# ---------------------------------------------------------------------- the estimate
def estimate_errors(
    mech: Mechanism,
    result: SimResult,
    rtol: float,
    atol: float,
    model_form: ModelFormEstimator | None = None,
    richer: Mechanism | None = None,
    truncation: str = "rerun",
) -> ErrorEstimate:
    """The error estimate of ``result``, a run of ``mech`` with the tolerances ``rtol``,
    ``atol`` (see the module docstring). ``model_form``: the model-form estimator (default: the
    one registered, if any: :data:`MODEL_FORM_ESTIMATORS`). ``richer``: the richer model of the
    truncation part, when the caller has it already (else it is made: :func:`richer_mechanism`).
    Both reruns use the run's own solver (:func:`_same_solver_run`); the richer model's C solver
    only where it was built before (else IDAS)."""
    names = list(result.output_names)
    peaks = result.peaks()
    parts: dict[str, dict[str, float | None]] = {}
    methods: dict[str, str] = {}
    reasons: dict[str, str] = {}
    counts: dict[str, list[int]] = {}
    measured = _measured(mech, result, names)

    def not_estimated(part: str, reason: str) -> None:
        parts[part] = dict.fromkeys(names)
        methods[part] = "not estimated"
        reasons[part] = reason

    try:
        trunc, counts, how = truncation_part(mech, result, richer, truncation, rtol, atol)
        parts["truncation"] = {n: trunc.get(n) for n in names}
        methods["truncation"] = how + (START_TEXT if result.start_forces else "")
    except (TruncationNotEstimated, SymgenError) as why:
        not_estimated("truncation", str(why))
    except (ValueError, ArithmeticError, RuntimeError) as why:  # RuntimeError: CasADi's
        # the run is complete and stays so: its estimate says what stopped the richer model
        not_estimated("truncation", f"the richer model could not be evaluated ({type(why).__name__}: {why})")
    from symgen.numerics import axial_drift as _axial_drift
    from symgen.numerics.model_form import ModelFormNotEstimated

    estimator = model_form or (next(iter(MODEL_FORM_ESTIMATORS.values())) if MODEL_FORM_ESTIMATORS else None)
    if estimator is None:
        not_estimated(
            "model_form", "no model-form estimator is connected (the curvature estimate: symgen.numerics.model_form)"
        )
    else:
        try:
            values, how = estimator(mech, result)
        except ModelFormNotEstimated as why:
            not_estimated("model_form", str(why))
        except (ValueError, ArithmeticError, RuntimeError) as why:  # LinAlgError is a ValueError
            # the run is complete and stays so: its estimate says what stopped the estimator
            not_estimated("model_form", f"the model-form estimate could not be evaluated ({type(why).__name__}: {why})")
        else:
            parts["model_form"] = {n: (float(values[n]) if n in values and n in measured else None) for n in names}
            methods["model_form"] = how
    try:
        values, how = _axial_drift.estimate(mech, result)
    except _axial_drift.AxialNotEstimated as why:
        not_estimated("axial", str(why))
    except (ValueError, ArithmeticError, RuntimeError) as why:  # RuntimeError: CasADi's
        not_estimated("axial", f"the quasi-static axial part could not be evaluated ({type(why).__name__}: {why})")
    else:
        parts["axial"] = {n: (float(values[n]) if n in values and n in measured else None) for n in names}
        methods["axial"] = how
    bound = time_integration_part(result, rtol, atol, peaks, {o.name: o.kind for o in mech.scene.outputs})
    parts["time_integration"] = {n: v if n in measured else None for n, v in bound.items()}
    methods["time_integration"] = (
        f"a-priori bound from the tolerances: {TIME_FACTOR:g} x rtol + atol / peak, {ALGEBRAIC_TIME_FACTOR:g} x rtol "
        f"for reactions, driver torques and axial forces (rtol {rtol:g}, atol {atol:g})"
    )
    if _algebraic(result):
        # nothing was integrated: each output solves the algebraic equations at its time, which a
        # rerun at tighter tolerances solves again to the same numbers (IDAS's rtol, atol unused)
        parts["time_integration"] = {n: (0.0 if v is not None else None) for n, v in parts["time_integration"].items()}
        methods["time_integration"] = ALGEBRAIC_TIME_TEXT.format(tol=_algebraic_tol())
    elif truncation == "rerun":
        try:
            tight = _tighter_run(mech, result, rtol, atol)
        except BudgetExceeded as why:
            # stopped at its budget: not estimated (the a-priori bound is no measure of a run whose
            # steps grow this much: it would be a small number that looks like an estimate)
            not_estimated("time_integration", _budget_text(why, "the run at tighter tolerances", result))
        except (SymgenError, ValueError, ArithmeticError, RuntimeError) as why:
            reasons["time_integration"] = f"the run at tighter tolerances failed ({why}): the bound alone"
        else:
            # the measured difference replaces the a-priori bound (kept for the outputs it leaves
            # out): at tolerances from the accuracy the bound is 30x to 1000x the run's true time
            # error, the rerun 1.1x to 1.3x it (benchmarks/RESULTS.md, "Tolerances from the accuracy")
            parts["time_integration"] = {
                n: (tight[n] if v is not None and n in tight else v) for n, v in parts["time_integration"].items()
            }
            methods["time_integration"] = (
                f"the run's difference to itself at {TIGHTER:g}x tighter tolerances "
                f"({'the C solver' if _ran_in_c(result) else 'IDAS'}) "
                f"x {1 / (1 - TIGHTER**-0.7):.3g} (rtol {rtol:g}, atol {atol:g}; the global error grows with the "
                f"periods a run rings through, beyond any fixed multiple of rtol); where it is not measured, "
                + methods["time_integration"]
            )
    _TIGHT.clear()  # both parts have read it: not kept past the estimate
    # a part stopped at its rerun's budget leaves no total: the others' sum would look like one
    stopped = any(r.startswith(BUDGET_PREFIX) for r in reasons.values())
    outputs = {n: None if stopped else combined([parts[p][n] for p in PARTS]) for n in names}
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    zero = {n: p for n, p in result.zero_outputs().items() if kinds.get(n) not in CHECK_KINDS}
    return ErrorEstimate(outputs, parts, methods, reasons, counts, zero)


def combined(values: Iterable[float | None]) -> float | None:
    """One output's estimate from its parts (fractions of its peak; None: not estimated): their
    sum, None when none was estimated. The one rule both the run's estimate and the choices made
    before it (:func:`symgen.numerics.strain_choice.decide`: what the accuracy leaves) use."""
    known = [float(v) for v in values if v is not None]
    return float(sum(known)) if known else None


#: the time-integration part's check run: this many times tighter tolerances
TIGHTER = 10.0
#: how the reason of a part whose rerun was stopped at its budget (``symgen.policy.RERUN_BUDGET``)
#: begins: the part is not estimated, and no output gets a total (the CLI warns and says what to do)
BUDGET_PREFIX = "budget: "


def _budget(result: SimResult) -> int:
    """The step budget of a rerun checking ``result`` (:func:`symgen.policy.rerun_budget`)."""
    from symgen.policy import rerun_budget

    return rerun_budget(int(result.steps), max(len(result.tau) - 1, 1))


def _budget_text(err: BudgetExceeded, what: str, result: SimResult) -> str:
    """The reason of a part whose rerun ``what`` was stopped at its budget (begins ``BUDGET_PREFIX``)."""
    from symgen.policy import RERUN_BUDGET

    at = "" if err.tau is None else f" at tau = {err.tau:.4g}"
    return (
        f"{BUDGET_PREFIX}{what} was stopped{at} after {err.steps} steps, beyond its budget of {err.budget} "
        f"({RERUN_BUDGET:g}x the run's {result.steps} steps, symgen.policy.RERUN_BUDGET): state the counts "
        "(bodies.NAME.axial_modes and transverse_modes) or run with --estimate linearized or off"
    )


#: the time-integration part of a run with no differential states (``symgen.numerics.simulate``:
#: every rigid coordinate driven, every elastic amplitude quasi-static; not the C solver's, whose
#: Radau IIA steps and dense output do integrate and interpolate): 0, said how
ALGEBRAIC_TIME_TEXT = (
    "none: the run has no differential states (every rigid coordinate driven, every elastic amplitude "
    "quasi-static), so nothing was integrated: each output is the solution of the algebraic equations at its "
    "time, by Newton to |residual| < {tol:g}, exact to that tolerance (no rerun at tighter tolerances: it "
    "would solve the same equations again)"
)


def _algebraic(result: SimResult) -> bool:
    """Whether ``result`` is a run of ``simulate`` with no differential states (its outputs the
    algebraic solutions, by Newton: ``stats["differential_states"]`` 0)."""
    return result.stats.get("differential_states") == 0 and not _ran_in_c(result)


def _algebraic_tol() -> float:
    from symgen.numerics.simulate import ALGEBRAIC_TOL  # a run of simulate imported it already

    return ALGEBRAIC_TOL


def _steps_text(run: SimResult) -> str:
    """What a rerun took: its integrator's steps, or its Newton iterations where it integrated nothing."""
    if _algebraic(run):
        return f"no differential states: Newton at each output, {run.stats.get('newton_iterations')} iterations"
    return f"{run.steps} {'Radau IIA (C)' if _ran_in_c(run) else 'IDAS'} steps"


def _tighter_run(mech: Mechanism, result: SimResult, rtol: float, atol: float) -> dict[str, float]:
    """output -> the difference of the run to the same run at ``TIGHTER`` times tighter
    tolerances (as a fraction of the peak), scaled to the run's own
    error: x 1 / (1 - TIGHTER^-0.7), the global error of a BDF run with local error control
    taken as at least rtol^0.7 (orders 2 to 5: rtol^(p/(p+1)); Radau IIA's, order 5, is
    rtol^(5/6), so the factor covers it too). The tighter run is the truncation part's
    (:func:`_tight`: made once)."""
    tau = np.asarray(result.tau, dtype=float)
    if len(tau) < 2:
        return {}
    tight = _tight(mech, result, rtol, atol)
    names = list(result.output_names)
    scale = 1.0 / (1.0 - TIGHTER**-0.7)
    return {n: scale * v for n, v in _fractions_of_peak(mech, result, _difference(result, tight, names), names).items()}


#: the last run made at ``TIGHTER`` times tighter tolerances, (mechanism, run, rtol, atol) -> that
#: run or the error that stopped it: read by the truncation part (the richer model against it) and
#: the time part (the run against it) of the same run's estimate, made once
_TIGHT: list[tuple[object, object, float, float, SimResult | BaseException]] = []


#: the richer models' IDAS runs of the truncation part, the latest ``RICH_RUNS_KEPT``, by what
#: makes a run (:func:`_run_identity`): the chosen counts' raise (:mod:`symgen.numerics.counts_choice`)
#: runs the richer model as the raised scene's, whose time part's tighter rerun is then that very run
#: (the same model, parameters, quasi-static functions, start, output grid, tolerances and backend:
#: the kept-out crank_pendulum_nylon's 5 + 6 strip, 216 405 IDAS steps, 181 s CPU, made twice before)
_RICH_RUNS: list[tuple[tuple[Any, ...], SimResult]] = []
RICH_RUNS_KEPT = 2


def _run_identity(mech: Mechanism, result: SimResult, rtol: float, atol: float) -> tuple[Any, ...] | None:
    """What an IDAS run of ``mech`` over ``result``'s output grid at ``rtol``, ``atol`` on the
    backend ``result`` was asked for depends on (:func:`_idas_run`): the model (its key and
    parameter values), the amplitudes it treats quasi-statically, the scene beside its bases'
    reasons and the raises' record (the start, the drivers, the outputs, the simulation), the
    grid, the tolerances and the backend. None after a C run (its reruns are the C solver's)."""
    if _ran_in_c(result):
        return None
    tau = np.asarray(result.tau, dtype=float)
    if len(tau) < 2:
        return None
    backend = result.stats.get("backend_choice", result.stats.get("backend"))
    scene = dataclasses.replace(mech.scene, bases=(), counts_raised=None)
    return (
        mech.info.key,
        tuple(float(v) for v in mech.p_values),
        tuple(mech.quasi),
        scene,
        float(tau[0]),
        float(tau[-1]),
        float(tau[1] - tau[0]),
        float(rtol),
        float(atol),
        backend if backend in ("compiled", "vm") else None,
    )


def _keep_rich_run(identity: tuple[Any, ...] | None, run: SimResult) -> None:
    if identity is None or _ran_in_c(run):
        return
    _RICH_RUNS[:] = [(i, r) for i, r in _RICH_RUNS if i != identity][-(RICH_RUNS_KEPT - 1) :] + [(identity, run)]


def _made_before(identity: tuple[Any, ...] | None) -> SimResult | None:
    """The richer model's run of an earlier truncation part that is this run (:data:`_RICH_RUNS`)."""
    if identity is None:
        return None
    for i, run in _RICH_RUNS:
        if i == identity:
            return run
    return None


def _tight(mech: Mechanism, result: SimResult, rtol: float, atol: float) -> SimResult:
    """``mech`` run again over ``result``'s output grid at ``TIGHTER`` times tighter tolerances
    than ``rtol``, ``atol`` by the run's own solver (:func:`_same_solver_run`), made once per run
    and tolerances (the last one kept; an earlier truncation part's richer run that is this run,
    :data:`_RICH_RUNS`, is taken); raises what stopped it."""
    for m, r, rt, at, tight in _TIGHT:
        if m is mech and r is result and rt == rtol and at == atol:
            if isinstance(tight, BaseException):
                raise tight
            return tight
    tau = np.asarray(result.tau, dtype=float)
    made: SimResult | BaseException | None = _made_before(_run_identity(mech, result, rtol / TIGHTER, atol / TIGHTER))
    if made is None:
        try:
            made = _same_solver_run(
                mech, result, float(tau[1] - tau[0]), rtol / TIGHTER, atol / TIGHTER, max_steps=_budget(result)
            )
        except (SymgenError, ValueError, ArithmeticError, RuntimeError) as why:
            made = why
    _TIGHT[:] = [(mech, result, rtol, atol, made)]
    if isinstance(made, BaseException):
        raise made
    return made


#: the truncation part's method text where the run's first sample of the joint forces is the
#: continuum's (``SimResult.start_forces``)
START_TEXT = (
    "; the first sample's driver torques and reactions are the continuum's at the unstressed start "
    "(symgen.numerics.start.continuum_start_outputs: exact whatever the counts, as the richer model's, "
    "so the comparison charges nothing there)"
)


def time_integration_part(
    result: SimResult,
    rtol: float,
    atol: float,
    peaks: Mapping[str, float] | None = None,
    kinds: Mapping[str, str] | None = None,
) -> dict[str, float | None]:
    """output -> ``TIME_FACTOR * rtol + atol / peak`` (``ALGEBRAIC_TIME_FACTOR`` for the outputs
    of ``kinds`` (output -> kind) read from the multipliers; None for an output that is zero over
    the run: it has no peak to be a fraction of)."""
    peaks = result.peaks() if peaks is None else peaks
    kinds = kinds or {}

    def factor(n: str) -> float:
        return ALGEBRAIC_TIME_FACTOR if kinds.get(n) in ALGEBRAIC_KINDS else TIME_FACTOR

    return {n: (factor(n) * rtol + atol / p if p > 0 else None) for n, p in peaks.items()}


def _solve(A: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    try:
        sol: np.ndarray = np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:
        sol = np.linalg.lstsq(A, rhs, rcond=None)[0]
    return sol


def _free_at_start(mech: Mechanism, result: SimResult, T: np.ndarray) -> list[int]:
    """Richer coordinates the quasi-static start solves for: all but the run's independent
    rigid coordinates (a free crank, a pendulum: their start is given)."""
    part = result.partition or mech.choose_partition(float(result.tau[0]), np.asarray(result.q[0]))
    held = {int(np.argmax(np.abs(T[:, i]))) for i in part.ind if i in mech.rigid}
    return [i for i in range(T.shape[0]) if i not in held]


def _measured(mech: Mechanism, result: SimResult, names: list[str]) -> set[str]:
    """The outputs an estimate is given for: all but the closure residuals (zero to round-off in
    every model: not an approximation of anything) and the outputs that are zero to round-off over
    this run (:meth:`SimResult.peaks`: no peak to be a fraction of)."""
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    zero = result.zero_outputs()
    return {n for n in names if kinds.get(n) not in CHECK_KINDS and n not in zero}


class TruncationNotEstimated(Exception):
    """The truncation part cannot be estimated for this run (the reason)."""


# ---------------------------------------------------------------------- truncation
def richer_scene(scene: Any, guides: bool = True) -> tuple[Any, dict[str, list[int]]]:
    """The scene with ``EXTRA_AXIAL`` / ``EXTRA_TRANSVERSE`` more functions on every elastic bar
    that has functions of that kind (a slot's guide with an elastic overhang ``EXTRA_GUIDE`` more
    span functions and as many more of its overhang's own: the richer basis spans the run's, the
    span functions being the span's own and the overhang's polynomials hierarchical; with a rigid
    overhang the guide keeps its counts), and bar -> [axial, transverse] counts as written (a
    guide's transverse count: its span functions). ``guides=False``: every guide keeps its counts
    (the linearized truncation part, whose state map follows the functions by their places).

    The added axial functions are quasi-static (the bar's ``BasisChoice.quasi_axial`` raised by
    their number: the run's own quasi-static axial functions stay so, a function the closure
    reads stays dynamic: ``symgen.numerics.mechanism``) where the run starts on its quasi-static
    deformation (``initial.deformation = "quasi-static"``: no function rings from the start) and
    the run's axial functions cover the bar's axial band (``BasisChoice.dynamic``); else, and
    always for the transverse functions, they are dynamic. Measured (benchmarks/RESULTS.md, "The
    error estimate's cost"): on ``examples/four_bar.toml`` (exact bars 4+4, quasi-static start)
    the added axial functions quasi-static change no output's truncation part by more than 3 %
    and take the richer model's IDAS steps from 78309 to 53886; the added transverse functions
    quasi-static (the coupler's and the rocker's) put it 5x to 40x lower (torque 1.9e-3 ->
    3.5e-4): the retained modes' ringing moves with the added functions' dynamics. From an
    undeformed start, damped or not, the added axial functions quasi-static were not honest: the
    validation five-bar's torque_b 8.0e-6 -> 2.2e-3 of peak (6.2x its true error), the
    torque-driven soft slider-crank's rod_mid 3.7e-3 -> 2.9e-3 (its true error 3.8e-3)."""
    from symgen.model.structure import slot_guide

    bodies, counts = [], {}
    eff = scene.effects
    choices = {c.bar: c for c in scene.bases}
    quasi_static_start = bool(scene.initial.quasi_static)
    bases = []
    joints = list(scene.joints)
    for b in scene.bodies:
        if not b.rigid and slot_guide(scene, b.name):
            slots = [i for i, j in enumerate(joints) if j.kind == "slot" and j.ends[1].body == b.name]
            if not (guides and eff.transverse and b.transverse_modes) or not all(
                joints[i].overhang_modes for i in slots
            ):
                bodies.append(b)  # a rigid overhang: each span function carries it (kept)
                continue
            for i in slots:
                joints[i] = dataclasses.replace(joints[i], overhang_modes=joints[i].overhang_modes + EXTRA_GUIDE)
            nt = b.transverse_modes + EXTRA_GUIDE
            bodies.append(dataclasses.replace(b, transverse_modes=nt))
            counts[b.name] = [b.axial_modes, nt]
            continue
        if b.rigid:
            bodies.append(b)
            continue
        na = b.axial_modes + (EXTRA_AXIAL if eff.axial is not False and b.axial_modes else 0)
        nt = b.transverse_modes + (EXTRA_TRANSVERSE if eff.transverse and b.transverse_modes else 0)
        bodies.append(dataclasses.replace(b, axial_modes=na, transverse_modes=nt))
        counts[b.name] = [na, nt]
        c = choices.pop(b.name, None)
        if c is not None and na > b.axial_modes and quasi_static_start and c.dynamic[0] <= b.axial_modes:
            # the added axial functions quasi-static (the docstring)
            c = dataclasses.replace(c, axial=na, quasi_axial=c.quasi_axial + (na - b.axial_modes))
        if c is not None:
            bases.append(c)
    bases += choices.values()
    return dataclasses.replace(scene, bodies=tuple(bodies), joints=tuple(joints), bases=tuple(bases)), counts


#: the richer models loaded in this process: (cache root, richer scene) -> the mechanism; the
#: latest ``RICHER_KEPT`` (a sweep or a benchmark estimates the same model's runs again)
_RICHER: OrderedDict[tuple[str, Any], Mechanism] = OrderedDict()
RICHER_KEPT = 4


def nothing_to_add(scene: Any) -> str:
    """Why the richer model of ``scene`` (:func:`richer_scene`) adds no function: its elastic bars
    are slot guides with a rigid overhang, whose span functions carry the overhang, or it has none."""
    from symgen.model.structure import slot_guide

    guides = [b.name for b in scene.bodies if not b.rigid and slot_guide(scene, b.name)]
    if not guides:
        return "the model has no elastic functions to add to"
    which = f"{guides[0]} is a slot's guide" if len(guides) == 1 else f"{', '.join(guides)} are slots' guides"
    return (
        f"the richer model adds functions to no bar: {which} with a rigid overhang, whose span functions "
        'carry the overhang (compare a run with its transverse_modes raised by hand, or overhang = "elastic")'
    )


def richer_mechanism(mech: Mechanism, guides: bool = True) -> tuple[Mechanism, dict[str, list[int]]]:
    """The embedded richer model of ``mech`` (derived once, then from the model cache; loaded
    once per process and cache); ``guides``: as :func:`richer_scene`."""
    from symgen import cache
    from symgen.numerics.mechanism import load_mechanism

    scene, counts = richer_scene(mech.scene, guides)
    key = (str(cache.cache_root()), scene)
    try:
        hash(key)
    except TypeError:  # a scene holding a mutable value: loaded each time
        return load_mechanism(scene), counts
    if key in _RICHER:
        _RICHER.move_to_end(key)
    else:
        _RICHER[key] = load_mechanism(scene)
        if len(_RICHER) > RICHER_KEPT:
            _RICHER.popitem(last=False)
    return _RICHER[key], counts


def _bodies(info: Any) -> dict[str, dict[str, Any]]:
    return {b["name"]: b for b in info.structure.get("bodies", [])}


def _hierarchical(spec: Mapping[str, Any]) -> bool:
    """The first n functions of the bar's families are the same whatever n: no static
    corrections (orthogonalised against the others) and no tip-load shape (likewise)."""
    tip = spec.get("tip_joint") and spec.get("frame") == "cantilever" and spec.get("transverse_shapes") == "modes"
    return not spec.get("static_points") and not tip


def _shape_map(base: Mapping[str, Any], rich: Mapping[str, Any]) -> tuple[list[list[float]], list[list[float]]]:
    """(axial, transverse) matrices P (rich x base) with rich_functions @ P = base_functions,
    by least squares over the bar (values and second derivatives), remembered in the cache
    (a cached run does not import the model's SymPy); ValueError when the richer basis does not
    contain the base one."""
    from symgen import cache

    question = {"check": "error_estimate.shape_map", "version": __version__, "base": dict(base), "rich": dict(rich)}
    known, answer = cache.recall(question)
    if known:
        return answer["axial"], answer["transverse"]
    from symgen.model.static_shapes import bar_bases

    xs = np.linspace(0.0, 1.0, 121)
    out: list[list[list[float]]] = []
    for k, (bb, br) in enumerate(zip(bar_bases(dict(base)), bar_bases(dict(rich)))):
        if len(bb) == 0:
            out.append([])
            continue
        derivs = (0, 2) if k == 1 else (0, 1)
        B = np.vstack([np.array([bb.values(x, d) for x in xs]) for d in derivs])
        Rm = np.vstack([np.array([br.values(x, d) for x in xs]) for d in derivs])
        P, *_ = np.linalg.lstsq(Rm, B, rcond=None)
        miss = np.abs(Rm @ P - B).max() / max(np.abs(B).max(), 1e-300)
        if miss > 1e-6:
            raise ValueError(f"the richer basis of bar {base['name']} does not contain its functions ({miss:.1e})")
        out.append(P.tolist())
    cache.remember(question, {"axial": out[0], "transverse": out[1]})
    return out[0], out[1]


def _state_map(base: Mechanism, rich: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    """(T, S): q_rich = T q_base (and v, a likewise), lam_rich = S lam_base."""
    bi, ri = base.info, rich.info
    T = np.zeros((ri.n, bi.n))
    where = {(c.kind, c.body, c.joint, c.index): i for i, c in enumerate(ri.coords)}
    bspec, rspec = _bodies(bi), _bodies(ri)
    maps: dict[str, tuple[Any, Any]] = {}
    for body in bi.amplitudes:
        same = bspec[body] == rspec[body]
        if not same and not (_hierarchical(bspec[body]) and _hierarchical(rspec[body])):
            maps[body] = _shape_map(bspec[body], rspec[body])
    for j, c in enumerate(bi.coords):
        if c.elastic and c.body in maps:
            pa, pt = maps[c.body]
            P = np.asarray(pa if c.kind is CoordKind.F else pt)
            rich_idx = ri.amplitudes[c.body][c.kind is CoordKind.G]
            base_idx = bi.amplitudes[c.body][c.kind is CoordKind.G]
            T[list(rich_idx), j] = P[:, base_idx.index(j)]
            continue
        key = (c.kind, c.body, c.joint, c.index)
        if key not in where:
            raise TruncationNotEstimated(f"the richer model has no coordinate {c.name}")
        T[where[key], j] = 1.0
    S = np.zeros((ri.m, bi.m))
    seen: dict[tuple[Any, ...], int] = {}
    rich_rows: dict[tuple[Any, ...], int] = {}
    for i, r in enumerate(ri.lam_rows):
        k = (r.kind, r.joint, r.loop)
        rich_rows[(*k, seen.get(k, 0))] = i
        seen[k] = seen.get(k, 0) + 1
    seen.clear()
    for j, r in enumerate(bi.lam_rows):
        k = (r.kind, r.joint, r.loop)
        n = seen.get(k, 0)
        seen[k] = n + 1
        if (*k, n) not in rich_rows:
            raise TruncationNotEstimated(f"the richer model has no row of joint {r.joint}")
        S[rich_rows[(*k, n)], j] = 1.0
    return T, S


#: the truncation part a decision measured on a run (:func:`keep_truncation`), read once by that
#: run's estimate (keyed by the truncation method)
_KEPT_TRUNCATION: MeasuredOnce[tuple[dict[str, float], dict[str, list[int]], str] | TruncationNotEstimated] = (
    MeasuredOnce()
)


def keep_truncation(
    mech: Mechanism,
    result: SimResult,
    method: str,
    part: tuple[dict[str, float], dict[str, list[int]], str] | TruncationNotEstimated,
) -> None:
    """Keep ``part``, :func:`truncation_part` of this run by ``method`` (the chosen counts'
    decision measured it: :mod:`symgen.numerics.counts_choice`), for the run's own estimate (read
    once; the previous one is dropped); or why it was not estimated (a rerun stopped at its
    budget: the estimate says so instead of paying the rerun again)."""
    _KEPT_TRUNCATION.keep(mech, result, part, method)


def truncation_part(
    mech: Mechanism,
    result: SimResult,
    richer: Mechanism | None = None,
    method: str = "rerun",
    rtol: float | None = None,
    atol: float | None = None,
) -> tuple[dict[str, float], dict[str, list[int]], str]:
    """(output -> fraction of peak, bar -> richer counts, method text) of the truncation part
    (the module docstring). ``rtol``, ``atol``: the run's own tolerances, those of the richer
    model's rerun (None: the scene's, IDAS's). Raises :class:`TruncationNotEstimated` with the
    reason when the run has no elastic functions to enrich or the richer model does not extend
    this one. The part :func:`keep_truncation` kept for this very run and method is read instead
    (once)."""
    if method not in TRUNCATION_METHODS:
        raise ValueError(f"unknown truncation method {method!r}; expected one of {', '.join(TRUNCATION_METHODS)}")
    if richer is None:
        known = _KEPT_TRUNCATION.take(mech, result, method)
        if isinstance(known, TruncationNotEstimated):
            raise known
        if known is not None:
            return known
    if method == "rerun":
        return _rerun(mech, result, richer, rtol, atol)
    idx, deltas, counts = truncation_deltas(mech, result, richer)
    values = _fractions_of_peak(mech, result, deltas, list(result.output_names))
    bars = ", ".join(f"{b} {c[0]}+{c[1]}" for b, c in counts.items())
    how = (
        f"embedded richer model ({bars} axial+transverse functions) linearised along the run, "
        f"on {len(idx)} of its outputs: the response of the added functions to their generalized loads "
        "(quasi-static above the output grid's resolution), through the loop"
    )
    return values, counts, how


def _ran_in_c(result: SimResult) -> bool:
    """Whether ``result`` is a run of the emitted C solver (``--solver c``)."""
    return result.stats.get("backend") == "c"


def _difference(result: SimResult, other: SimResult, names: list[str]) -> np.ndarray:
    """``other``'s outputs ``names`` minus ``result``'s (samples x outputs), over the samples
    both have."""
    k = min(len(other.tau), len(result.tau))
    return np.column_stack([other.column(n)[:k] - result.column(n)[:k] for n in names])


def _fractions_of_peak(mech: Mechanism, result: SimResult, deltas: np.ndarray, names: list[str]) -> dict[str, float]:
    """output -> its largest change in ``deltas`` (columns ``names``) as a fraction of its peak in
    ``result``: the estimate's measure (the module docstring), for the outputs it estimates."""
    measured = _measured(mech, result, list(result.output_names))
    peaks = result.peaks()
    return {
        n: float(np.abs(deltas[:, j]).max() / peaks[n]) for j, n in enumerate(names) if n in measured and peaks[n] > 0
    }


def _same_solver_run(
    mech: Mechanism,
    result: SimResult,
    step: float,
    rtol: float,
    atol: float,
    build: bool = True,
    idas_tolerances: tuple[float, float] | None = None,
    max_steps: int | None = None,
) -> SimResult:
    """``mech`` run over ``result``'s output grid with ``rtol``, ``atol`` by the run's own
    solver: the emitted C Radau IIA solver after a ``--solver c`` run (``result.stats``'s
    backend "c"), else IDAS on the backend the run was asked for. The C path starts at tau = 0;
    where it is refused, or (``build=False``) its library is not in the cache or its run fails,
    the rerun is IDAS's.

    The time part's tighter rerun is of the run's own model, whose C library is the run's
    (cached). The truncation part's richer model takes ``build=False``: its C solver is used
    when it was built before, never compiled on the run's way (a richer exact bar's took 170 s),
    so a first ``--solver c`` run measures its richer model with IDAS: at ``idas_tolerances``
    where given (the IDAS rule's from the accuracy: the C rule's looser ones would charge IDAS's
    own time error to the truncation part), else at ``rtol``, ``atol``. ``max_steps``: the rerun's
    budget of its solver's steps (:func:`_budget`; ``BudgetExceeded`` past it)."""
    from symgen.errors import SceneError, SimulationError

    tau = np.asarray(result.tau, dtype=float)
    if _ran_in_c(result) and float(tau[0]) == 0.0:
        from symgen.numerics.csolver import NotBuilt, simulate_c

        try:
            return simulate_c(
                mech, t_end=float(tau[-1]), output_step=step, rtol=rtol, atol=atol, build=build, max_steps=max_steps
            )
        except (SceneError, NotBuilt):  # no working C compiler, a scene the C path refuses, a library
            pass  # not built: IDAS below
        except SimulationError as err:
            # the run's own solver failed at tighter tolerances, or a rerun past its budget: said as such
            if build or isinstance(err, BudgetExceeded):
                raise
            # the richer model's C run failed: IDAS below
        if idas_tolerances is not None:
            rtol, atol = idas_tolerances
    return _idas_run(mech, result, step, rtol, atol, max_steps)


def _idas_run(
    mech: Mechanism, result: SimResult, step: float, rtol: float, atol: float, max_steps: int | None = None
) -> SimResult:
    """``mech`` run by IDAS over ``result``'s output grid, on the backend the run was asked for."""
    from symgen.numerics.simulate import simulate

    tau = np.asarray(result.tau, dtype=float)
    backend = result.stats.get("backend_choice", result.stats.get("backend"))  # what the run was asked
    return simulate(
        mech,
        t_end=float(tau[-1]),
        output_step=step,
        rtol=rtol,
        atol=atol,
        t0=float(tau[0]),
        backend=backend if backend in ("compiled", "vm") else None,
        max_steps=max_steps,
    )


def _rerun(
    mech: Mechanism, result: SimResult, richer: Mechanism | None, rtol: float | None = None, atol: float | None = None
) -> tuple[dict[str, float], dict[str, list[int]], str]:
    """The truncation part by a second run of the richer model on the run's own output grid,
    against the run's model on the same grid, both at ``TIGHTER`` times tighter tolerances than
    the run's (``rtol``, ``atol``; None: the scene's; after a ``--solver c`` run with the
    tolerances from the accuracy, the C solver's, ``Simulation.tolerances("c")``, not IDAS's
    tighter ones). The model's tighter run is the time part's (:func:`_tight`). Against the run
    itself at its own tolerances, the difference carries both runs' time errors: the run's is
    the time part's, and the richer run's is not truncation. Where the tighter run fails, or the
    run integrated nothing (:func:`_algebraic`: no time part's rerun), the richer model at the
    run's tolerances against the run."""
    from symgen.errors import SimulationError

    counts: dict[str, list[int]]
    if richer is None:
        richer, counts = richer_mechanism(mech)
    else:
        counts = {b: [md.axial, md.transverse] for b, md in richer.info.modes.items()}
    if richer.info.n == mech.info.n:
        raise TruncationNotEstimated(nothing_to_add(mech.scene))
    tau = np.asarray(result.tau, dtype=float)
    if len(tau) < 2:
        raise TruncationNotEstimated("the run has fewer than two outputs")
    sim = mech.scene.simulation
    rtol = sim.rtol if rtol is None else rtol
    atol = sim.atol if atol is None else atol
    # after a C run on the tolerances from the accuracy, a richer model without a built C solver
    # runs by IDAS on IDAS's rule (tests/test_tolerance_from_accuracy.py)
    fallback = sim.tolerances("idas") if sim.tolerances_from == "accuracy" else None
    base: SimResult = result
    against = "the run at its own tolerances (its run at tighter tolerances: none"
    if _algebraic(result):
        against += ", it integrated nothing)"
    else:
        try:
            base = _tight(mech, result, rtol, atol)
        except BudgetExceeded as why:
            # the richer model at the run's tolerances would cost as much: not estimated
            raise TruncationNotEstimated(
                _budget_text(why, "the run's model at tighter tolerances (the richer model's reference)", result)
            ) from None
        except (SymgenError, ValueError, ArithmeticError, RuntimeError) as why:
            against += f", it failed: {why})"
        else:
            rtol, atol = rtol / TIGHTER, atol / TIGHTER
            fallback = None if fallback is None else (fallback[0] / TIGHTER, fallback[1] / TIGHTER)
            against = (
                f"the run's model at {TIGHTER:g}x tighter tolerances than the run's (the time part's rerun, "
                f"{_steps_text(base)}): "
                "against the run itself, the difference would carry the run's own time error, which the "
                "time part charges"
            )
    try:
        rich = _same_solver_run(
            richer,
            result,
            float(tau[1] - tau[0]),
            rtol,
            atol,
            build=False,
            idas_tolerances=fallback,
            max_steps=_budget(result),
        )
    except BudgetExceeded as err:
        raise TruncationNotEstimated(_budget_text(err, "the richer model's run", result)) from None
    except SimulationError as err:
        raise TruncationNotEstimated(f"the richer model's run failed: {err}") from None
    if base is not result and rich.complete:  # at the tighter tolerances: a raised scene's time part
        _keep_rich_run(_run_identity(richer, result, rtol, atol), rich)
    names = list(result.output_names)
    values = _fractions_of_peak(mech, result, _difference(base, rich, names), names)
    bars = ", ".join(f"{b} {c[0]}+{c[1]}" for b, c in counts.items())
    how = (
        f"second run of the embedded richer model ({bars} axial+transverse functions) on the run's output grid "
        f"at rtol {rtol:g}, atol {atol:g} ({_steps_text(rich)}) against {against}: the largest "
        "difference of the two runs' outputs"
    )
    return values, counts, how


def truncation_deltas(
    mech: Mechanism, result: SimResult, richer: Mechanism | None = None
) -> tuple[np.ndarray, np.ndarray, dict[str, list[int]]]:
    """(the sampled output indices, the change of every output there (samples x outputs), bar ->
    richer counts): what the richer model changes along the run (:func:`truncation_part`)."""
    import casadi as ca

    from symgen.model.structure import slot_guide

    counts: dict[str, list[int]]
    if richer is None:  # a guide keeps its counts: the state map follows the functions by their places
        richer, counts = richer_mechanism(mech, guides=False)
    else:
        counts = {b: [md.axial, md.transverse] for b, md in richer.info.modes.items()}
        if any(
            not b.rigid
            and slot_guide(mech.scene, b.name)
            and len(richer.info.amplitudes[b.name][1]) != len(mech.info.amplitudes[b.name][1])
            for b in mech.scene.bodies
        ):
            raise TruncationNotEstimated(
                "the linearized truncation part does not map a richer slot guide's functions (its span, "
                'contact-slope and overhang functions change places with the counts): truncation_method = "rerun"'
            )
    if not any(mech.info.amplitudes.values()) or richer.info.n == mech.info.n:
        raise TruncationNotEstimated(nothing_to_add(mech.scene))
    T, S = _state_map(mech, richer)
    ri = richer.info
    tau = np.asarray(result.tau, dtype=float)
    N = len(tau)
    if N == 0:
        raise TruncationNotEstimated("the run has no output")
    idx = np.arange(0, N, max(1, math.ceil(N / MAX_SAMPLES)))
    t, q, v, a, lam, p = (
        ca.SX.sym(k, s)
        for k, s in (("t", 1), ("q", ri.n), ("v", ri.n), ("a", ri.n), ("lam", ri.m), ("p", len(richer.p)))
    )
    args = [t, q, v, a, lam, p]
    res, phi = richer.f["res"](*args), richer.f["phi"](*args)
    system = ca.Function(
        "truncation_system",
        args,
        [
            res,
            phi,
            ca.jacobian(res, a),
            ca.jacobian(res, v),
            ca.jacobian(res, q),
            ca.jacobian(res, lam),
            ca.jacobian(phi, q),
        ],
    )
    out_f = richer.f["out"]
    names = list(result.output_names)
    cols = [list(ri.outputs).index(n) for n in names]
    n, m = ri.n, ri.m
    quasi_static_start = bool(mech.scene.initial.quasi_static)
    # the correction d = [dq; dlam] of the richer model about the run, linearised along it:
    #   M da + C dv + K dq + L dlam = -r(t),  Phi_q dq = -phi(t)
    # marched on the sampled outputs by BDF2 (BDF1 on the first step and where the step
    # changes): A-stable and strongly damping where h w >> 1, so the omitted functions, far
    # above what the output grid resolves, respond quasi-statically (residual flexibility),
    # while the retained ones keep their dynamics (a changed frequency shows as the phase
    # drift it causes)
    dq_prev: list[np.ndarray] = []
    dv_prev: list[np.ndarray] = []
    deltas = np.zeros((len(idx), len(names)))
    for j, k in enumerate(idx):
        tk = float(tau[k])
        qb, vb, lb = np.asarray(result.q[k]), np.asarray(result.v[k]), np.asarray(result.lam[k])
        ab, _ = mech.accelerations(tk, qb, vb)
        qr, vr, ar, lr = T @ qb, T @ vb, T @ ab, S @ lb
        r, ph, M, C, K, L, G = (np.array(x) for x in system(tk, qr, vr, ar, lr, richer.p))
        r, ph = r.ravel(), ph.ravel()
        A = np.zeros((n + m, n + m))
        A[n:, :n] = G
        if j == 0:
            # the start: the richer model starts from the same state, its added functions at
            # their quasi-static values when the scene starts quasi-static (else undeformed)
            if quasi_static_start:
                held = [i for i in range(n) if i not in _free_at_start(mech, result, T)]
                A[:n, :n], A[:n, n:] = K, L
                A[held, :] = 0.0
                A[held, held] = 1.0
                rhs = -np.concatenate([r, ph])
                rhs[held] = 0.0
            else:
                A[:n, :n] = np.eye(n)
                A[:n, n:] = 0.0
                rhs = np.zeros(n + m)
                A[n:, n:] = np.eye(m)  # then dlam is 0 too (read only through the outputs)
                A[n:, :n] = 0.0
            sol = _solve(A, rhs)
            dq, dl = sol[:n], sol[n:]
            dv = np.zeros(n)
            da = np.zeros(n)
        else:
            h = tau[k] - tau[idx[j - 1]]
            bdf2 = j >= 2 and abs((tau[idx[j - 1]] - tau[idx[j - 2]]) - h) <= 1e-6 * h
            if bdf2:
                c0 = 3.0 / (2.0 * h)
                v_hist = (-4.0 * dq_prev[-1] + dq_prev[-2]) / (2.0 * h)
                a_hist = (-4.0 * dv_prev[-1] + dv_prev[-2]) / (2.0 * h)
            else:
                c0 = 1.0 / h
                v_hist = -dq_prev[-1] / h
                a_hist = -dv_prev[-1] / h
            A[:n, :n] = c0 * c0 * M + c0 * C + K
            A[:n, n:] = L
            rhs = np.concatenate([-r - M @ (c0 * v_hist + a_hist) - C @ v_hist, -ph])
            sol = _solve(A, rhs)
            dq, dl = sol[:n], sol[n:]
            dv = c0 * dq + v_hist
            da = c0 * dv + a_hist
        dq_prev, dv_prev = [*dq_prev[-1:], dq], [*dv_prev[-1:], dv]
        y1 = np.array(out_f(tk, qr + dq, vr + dv, ar + da, lr + dl, richer.p)).ravel()[cols]
        deltas[j] = y1 - np.asarray(result.outputs[k])
        if k == 0:
            # the run's first joint forces are the continuum's, the richer model's limit too
            # (the rigid parts' alone, whatever the counts): no change there
            deltas[j, [names.index(nm) for nm in result.start_forces]] = 0.0
    return idx, deltas, counts
