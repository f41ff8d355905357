"""The run-time half of ``effects.strain = "auto"`` (:mod:`symgen.scene.strain` has the loaded
half): after a complete von Karman run of an "auto" scene, its model-form estimate
(:func:`symgen.numerics.model_form.model_form_estimate`) decides whether the run is made again
with the exact bar: when it exceeds, on any output (closure residuals aside), what
``simulation.accuracy`` leaves beside the other parts of the run's error estimate known before
it (the bases' a-priori truncation estimate, the time part's bound from the tolerances), the
parts summed as the estimate sums them (:func:`others_before`). The decision is remembered in the signed cache, keyed by the scene's hash (the scene
after overrides) and the version, so a rerun of the same scene loads the decided model directly.

Why after the run, not from the scene alone: the error is ~ (pi^2 / 2) (slope)^2, amplified by
axial compression towards the Euler load, and the slopes come from the run (a torque-driven
spin-up's speed, a slewing arm's tip deflection): the a-priori estimates of the bases chooser
(:mod:`symgen.scene.bases`) are relative (truncation as a fraction of the bar's own response)
and carry no amplitude. docs/exact-bars.md, "Choosing the bar", has the measured cases.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any, TypeVar

from symgen import __version__, cache
from symgen.scene.model import CHECK_KINDS
from symgen.scene.strain import AUTO, StrainChoice

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene.model import Scene

__all__ = [
    "decide",
    "judge",
    "others_before",
    "recalled",
    "resolved",
    "run_with_strain_choice",
    "switchable",
    "with_choice",
]

R = TypeVar("R")

#: the model-form estimator's version in the remembered decisions (a changed estimator decides again)
#: (3: the phase drift along the run, the exact bar's strain to eta'^4/8; 4: the drift without the
#: response forced at a constant driver's harmonics; 5: outputs that read only the angle drivers'
#: angles estimated 0; 6: a mode's own vibration moves it by half its tangent's stiffening, the backbone;
#: 7: a vibration drifts from when its content came in, not from the run's start; 8 and 9 on branches,
#: not merged; 10: each coupled mode's own coordinate changes by its oscillator's first-order response
#: to its shift, along its own phase, and each output by its participation in the mode; 11: 8's static
#: change and drifts added as sizes at the same instant; 9's stretch's share of the curvature ported
#: but off, model_form.STRETCH_CURVATURE; a torque-driven crank's timing, the drift of its angle the
#: static change's forcing builds up, model_form._free_lead; 12: von Karman kept only within what the
#: accuracy leaves beside the bases' a-priori truncation and the time bound, :func:`others_before`;
#: 13: the static change's amplification by axial compression uncapped while the bar's tangent
#: stiffness is positive definite, the outputs a bar at or beyond its Euler load moves charged
#: model_form.BEYOND_BUCKLING; 14: a coupled mode's modal velocity from the velocity less the rigid
#: coordinates' motion the closure gives it, model_form._coordinate_rows: phi^T M v also projected the
#: rigid mechanism's motion, 4-7x the five-bar's modes' own content in their bands; 15: the static
#: change with each bar's axial force less its content at and above the bar's first bending
#: frequency, model_form._Bar.slow_axial_force: a slider's axial ringing's peaks were amplified; 16: an
#: output zero to round-off over the run decides nothing, SimResult.peaks; a scene with a slot guide,
#: whose model form model_form._Guide estimates since the estimator's 17, is never decided: the exact bar
#: is refused there, symgen.scene.strain.exact_refused; 17: a coupled mode's drift read in a band
#: spanning its frequency's sweep along the run, model_form.swept_bands)
ESTIMATOR_VERSION = "17"


def _question(scene: Scene) -> dict[str, Any]:
    return {"check": "strain.auto", "version": __version__, "estimator": ESTIMATOR_VERSION, "scene": scene.hash}


def switchable(scene: Scene) -> bool:
    """An "auto" scene whose run may still switch to the exact bar."""
    return scene.strain_choice is not None and scene.strain_choice.switchable


def with_choice(scene: Scene, choice: StrainChoice) -> Scene:
    """The scene with the formulation ``choice`` (its effects.strain and its record)."""
    return replace(scene, effects=replace(scene.effects, strain=choice.strain), strain_choice=choice)


def recalled(scene: Scene) -> Scene | None:
    """The scene with the decision remembered for it, or None (not "auto", or not decided yet)."""
    if not switchable(scene) or not scene.hash:
        return None
    known, answer = cache.recall(_question(scene))
    if not known or not isinstance(answer, dict):
        return None
    try:
        choice = StrainChoice(
            AUTO,
            str(answer["strain"]),
            str(answer["reason"]),
            False,
            float(answer["estimate"]),
            str(answer["output"]),
            float(answer["accuracy"]),
        )
    except (KeyError, TypeError, ValueError):
        return None
    if choice.strain not in ("von_karman", "exact"):
        return None
    return with_choice(scene, choice)


def others_before(mech: Mechanism, result: Any) -> dict[str, float]:
    """output -> the parts of the run's error estimate beside the model form that are known
    before its own estimate is made, combined as that estimate combines parts
    (:func:`symgen.numerics.error_estimate.combined`): the bases' a-priori truncation estimate
    (the largest over the bars, :class:`symgen.scene.bases.BasisChoice`, as the quasi-static
    choice reads it) and the time-integration part's a-priori bound from the run's tolerances
    (:func:`symgen.numerics.error_estimate.time_integration_part`). The axial part is decided
    after the bar (:mod:`symgen.numerics.axial_choice`): not counted."""
    from symgen.numerics.error_estimate import combined, time_integration_part

    scene = mech.scene
    truncation = max((float(c.estimate) for c in scene.bases), default=0.0)
    solver = "c" if getattr(result, "stats", {}).get("backend") == "c" else "idas"
    rtol, atol = scene.simulation.tolerances(solver)  # the run's own
    kinds = {o.name: o.kind for o in scene.outputs}
    time = time_integration_part(result, rtol, atol, kinds=kinds)
    return {n: combined([truncation, t]) or 0.0 for n, t in time.items()}


#: the least share of the accuracy von Karman's model form is left, however much the other parts
#: take (the tenth the time part is kept to, symgen.policy.tolerances): where the bases' a-priori
#: truncation estimate alone takes (nearly) all of it, the exact bar would not bring the run
#: within it and a model form of a few thousandths of the accuracy (examples/four_bar_tool.toml:
#: 1.6e-4 beside 9.8e-3 at 0.01) is no reason for its cost
LEAST_SHARE = 0.1


def judge(model_form: dict[str, float], others: dict[str, float], accuracy: float) -> tuple[bool, str, float, float]:
    """(the exact bar?, the output that decides, its model-form estimate, what the accuracy
    leaves it) from von Karman's model-form estimate and the other parts known before the run's
    estimate (:func:`others_before`), output -> fraction of peak. What the accuracy leaves an
    output's model form is ``accuracy - others``, the parts summed as the run's estimate sums
    them (:func:`symgen.numerics.error_estimate.combined`), at least ``LEAST_SHARE * accuracy``;
    the exact bar where the model form exceeds it on any output. The output that decides is the
    one furthest over (or nearest to) what is left."""
    from symgen.numerics.error_estimate import combined

    if not model_form:
        return False, "", 0.0, accuracy
    room = {n: max(accuracy - (combined([others.get(n)]) or 0.0), LEAST_SHARE * accuracy) for n in model_form}
    worst = max(model_form, key=lambda n: model_form[n] - room[n])
    return model_form[worst] > room[worst], worst, float(model_form[worst]), room[worst]


def decide(mech: Mechanism, result: Any) -> StrainChoice | None:
    """The decision after a complete von Karman run ``result`` of the "auto" scene of ``mech``
    (remembered), or None when its model form cannot be estimated (the scene keeps von Karman,
    provisionally). Von Karman is kept where, on every output (closure residuals aside), its
    model-form estimate fits in what the accuracy leaves beside the other parts the run's
    estimate will carry (:func:`others_before`): ``accuracy - others``, the parts summed as the
    estimate sums them; else the exact bar."""
    from symgen.numerics.model_form import (  # only to decide
        ModelFormNotEstimated,
        keep_for_estimate,
        model_form_estimate,
    )

    scene = mech.scene
    try:
        est = model_form_estimate(mech, result)
        others = others_before(mech, result)
    except (ModelFormNotEstimated, ValueError, ArithmeticError, RuntimeError):
        # not estimated (the reason is the sidecar's error estimate): von Karman, provisionally
        return None
    kinds = {o.name: o.kind for o in scene.outputs}
    values = {n: v for n, v in est.outputs.items() if kinds.get(n) not in CHECK_KINDS}
    accuracy = float(scene.simulation.accuracy)
    exact, worst, top, room = judge(values, others, accuracy)
    beside = (
        f"what simulation.accuracy {accuracy:g} leaves beside the bases' a-priori truncation and the time bound "
        f"({accuracy - room:.1e}), {room:.2e}"
    )
    # bars at or beyond their Euler load somewhere in the run (model_form.BEYOND_BUCKLING charged):
    # the reason says so, a number alone (1.0 of peak) would not tell why
    buckled = sorted(b for b, (_, amp) in est.bars.items() if amp == float("inf"))
    why = (
        f" ({', '.join(buckled)} at or beyond {'its' if len(buckled) == 1 else 'their'} Euler load in the run: "
        "no static change is an estimate there, the outputs it moves charged their whole peak)"
        if buckled
        else ""
    )
    if exact:
        choice = StrainChoice(
            AUTO,
            "exact",
            f"auto: the exact bar, because the model-form estimate of von Karman (the curvature and strain terms it "
            f"leaves out) is {top:.2e} of peak on {worst}{why}, above {beside}",
            False,
            top,
            worst,
            accuracy,
        )
    else:
        choice = StrainChoice(
            AUTO,
            "von_karman",
            f"auto: von Karman, its model-form estimate (the curvature and strain terms it leaves out) is "
            f"{top:.2e} of peak{f' on {worst}' if worst else ''}, within {beside}",
            False,
            top,
            worst,
            accuracy,
        )
        # von Karman kept: this run is the run, and its error estimate reads this estimate
        keep_for_estimate(mech, with_choice(scene, choice), result, est)
    if scene.hash:
        cache.remember(
            _question(scene),
            {"strain": choice.strain, "reason": choice.reason, "estimate": top, "output": worst, "accuracy": accuracy},
        )
    return choice


def resolved(scene: Scene) -> Scene:
    """The scene with the decisions remembered for it (the bar formulation, then the axial
    dynamics a run kept: :mod:`symgen.numerics.axial_choice`, then the chosen counts a run
    raised: :mod:`symgen.numerics.counts_choice`, then the chosen quasi-static functions a run
    made dynamic at the quasi-static form's impasse: :mod:`symgen.numerics.quasi_fallback`), else
    as it is."""
    from symgen.numerics import axial_choice, counts_choice, quasi_fallback

    return quasi_fallback.resolved(counts_choice.resolved(axial_choice.resolved(recalled(scene) or scene)))


def run_with_strain_choice(
    mech: Mechanism,
    load: Callable[[Scene], Mechanism],
    run: Callable[[Mechanism], tuple[R | None, BaseException | None]],
    say: Callable[[str], None] | None = None,
    estimate: str = "off",
) -> tuple[Mechanism, R | None, BaseException | None]:
    """``run(mech)`` -> (mechanism, result, failure), with "auto" decided when the scene of
    ``mech`` may still switch (:func:`resolved` it first to use a remembered decision): after a
    complete von Karman run (or one stopped early with a partial result:
    :func:`symgen.numerics.results.decidable`, judged up to the stop) its model-form estimate decides, and the run is made again with the
    exact bar (``load``-ed) when it says so. Then ``effects.axial = "auto"``'s run-time half
    (:func:`symgen.numerics.axial_choice.run_with_axial_choice`) on the run it gave, then the
    chosen counts' (:func:`symgen.numerics.counts_choice.run_with_counts_choice`, where
    ``estimate``, the run's truncation method, is "rerun"). A run stopped at the quasi-static
    form's impasse with functions symgen chose quasi-static is made again with them dynamic
    (:func:`symgen.numerics.quasi_fallback.run_with_quasi_fallback`). Any other scene is run once, as it is."""
    from symgen.numerics.axial_choice import run_with_axial_choice
    from symgen.numerics.counts_choice import run_with_counts_choice

    from symgen.numerics.quasi_fallback import run_with_quasi_fallback

    mech, result, failure = _run_with_strain_choice(mech, load, run, say)
    # a run stopped at the quasi-static form's impasse with functions symgen chose quasi-static:
    # made again with them dynamic, before the next rules judge it (and after the last: the chosen
    # counts' rerun chooses its quasi-static functions again)
    mech, result, failure = run_with_quasi_fallback(mech, result, failure, load, run)
    mech, result, failure = run_with_axial_choice(mech, result, failure, load, run, say)
    mech, result, failure = run_with_counts_choice(mech, result, failure, load, run, say, estimate)
    return run_with_quasi_fallback(mech, result, failure, load, run)


def _run_with_strain_choice(
    mech: Mechanism,
    load: Callable[[Scene], Mechanism],
    run: Callable[[Mechanism], tuple[R | None, BaseException | None]],
    say: Callable[[str], None] | None = None,
) -> tuple[Mechanism, R | None, BaseException | None]:
    from symgen.numerics.results import judged

    if not switchable(mech.scene):
        result, failure = run(mech)
        return mech, result, failure
    # the von Karman model before the decision: evaluated once (the exact bar's model replaces
    # it, or the decision is remembered and the next run compiles it): no library for it
    mech.provisional = True
    try:
        result, failure = run(mech)
    finally:
        mech.provisional = False
    choice = judged(decide, mech, result, failure)
    if choice is None:
        return mech, result, failure
    decided = with_choice(mech.scene, choice)
    if choice.strain == "von_karman":
        mech.scene = decided  # the same model: the record says what was estimated
        return mech, result, failure
    if say is not None:
        say(choice.reason + ": running it")
    mech = load(decided)
    result, failure = run(mech)
    return mech, result, failure
