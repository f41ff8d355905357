"""The run-time half of ``effects.axial = "auto"`` for the bars its a-priori rule makes
quasi-static (``symgen.model.structure.axial_treatment``): after a complete run (or one stopped
early with a partial result, judged up to the stop), the error
estimate's axial part (:mod:`symgen.numerics.axial_drift`: the phase drift of the free motion with
the stretch's inertia the quasi-static treatment leaves out, the start's axial ringing, force
outputs included, and the stretch's own inertia: a bar spinning at a rate near its first axial
frequency stretches more than its quasi-static stretch) decides whether the run is made again with those bars' axial dynamics kept: when
either exceeds ``simulation.accuracy`` on any output (closure residuals aside). As ``effects.strain = "auto"`` (:mod:`symgen.numerics.strain_choice`)
the decision is remembered in the signed cache, keyed by the scene's hash (after overrides), the
bar formulation the run used and the version, so a rerun of the same scene loads the decided model
directly; the kept bars travel on ``Scene.axial_kept`` and the sidecar's ``axial_treatment`` says
why.

Why after the run: the drift integrates over the run (a free rotation's phase: the soft arm
spinning 11 turns is 5.4 % of peak off at a separation of 11.2 x its motion, where the a-priori
rule's forced-response bound sees a fraction of a per cent), and the ringing of an undeformed start
at speed shows most in the force outputs, which the a-priori rule leaves out
(``symgen.scene.bases.AXIAL_RINGING_UNREAD``): a steel press started undeformed at 600 rpm has its
driver torque 3.6 % of peak off in the first 0.02 s with the rod quasi-static, 0.003 % with its
axial dynamics kept, at the same cost (Kelvin-Voigt damping ends the ringing); an undamped stiff
slider-crank started so rings its torque by 2.4 x its peak for the whole run, and keeping the
axial dynamics costs what resolving that ringing costs (``initial.deformation = "quasi-static"``
starts without it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any, TypeVar

from symgen import __version__, cache
from symgen.ir.spec import QUASI_STATIC
from symgen.scene.model import CHECK_KINDS, AxialSwitch

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene.model import Scene

__all__ = ["decide", "kept_as_is", "recalled", "resolved", "run_with_axial_choice", "switchable"]

R = TypeVar("R")

#: the axial part's version in the remembered decisions (a changed estimate decides again;
#: "2": the start's ringing decides too; "3": the drift charges each output's whole rate along the run;
#: "4": the stretch's own inertia decides too; "5": the start's ringing is measured from a quasi-static
#: start too, where the loads of its deformation rates move the axial force; "6": an output zero to
#: round-off over the run decides nothing, SimResult.peaks; "7": a quasi-static start is consistent
#: (its rates' loads in): where it leaves no axial force jump the whole run is read instead; "8": that
#: whole run reads SimResult.peaks, an output zero to round-off charged nothing there too)
#: "9": a damped start ringing keeps the axial dynamics only until it has ended (Scene.axial_switch);
#: "10": only where all it leaves out is within a tenth of the accuracy; "11": the switch charged by
#: the run's own model continued from the kept run's state at it)
ESTIMATOR_VERSION = "11"
#: what each measure of the axial part is, in the reason
MEASURES = {
    "drift": "the phase drift of the free motion with the stretch's inertia the quasi-static treatment leaves out",
    "ringing": (
        "the start's axial ringing: a window from the start (not on its quasi-static deformation) run with the axial "
        "dynamics kept, against the quasi-static run"
    ),
    "own": (
        "the stretch's own inertia: the inertia of the stretch N/lambda (a spinning bar's centrifugal load on its "
        "stretch included) over the bar's axial stiffness"
    ),
}

#: what a ringing start's user can do instead, said with the decision
RINGING_ALTERNATIVE = (
    "the run resolves the ringing: its steps follow the axial frequency where nothing damps it; "
    'initial.deformation = "quasi-static" starts without it where the mechanism is meant to start on its '
    "quasi-static deformation"
)


def _question(scene: Scene) -> dict[str, Any]:
    return {
        "check": "axial.auto",
        "version": __version__,
        "estimator": ESTIMATOR_VERSION,
        "scene": scene.hash,
        "strain": str(scene.effects.strain),
    }


def _auto_quasi_static(scene: Scene) -> list[str]:
    """The bars the auto rule makes quasi-static in ``scene``."""
    from symgen.model.structure import axial_treatments

    if scene.effects.axial != "auto":
        return []
    return sorted(n for n, t in axial_treatments(scene).items() if t.treatment == QUASI_STATIC)


def switchable(scene: Scene) -> bool:
    """An ``effects.axial = "auto"`` scene whose run may still keep axial dynamics: some bar is
    quasi-static by the auto rule and no run has decided yet."""
    return not scene.axial_kept and bool(_auto_quasi_static(scene))


def _kept(scene: Scene, bars: list[str], reason: str, switch: AxialSwitch | None = None) -> Scene:
    return replace(scene, axial_kept=tuple((b, reason) for b in bars), axial_switch=switch)


def _switch_of(answer: dict[str, Any]) -> tuple[bool, AxialSwitch | None]:
    """(valid, the switch) of a remembered decision (no "switch": valid, None)."""
    got = answer.get("switch")
    if got is None:
        return True, None
    if not isinstance(got, dict):
        return False, None
    t, charge, how = got.get("tau"), got.get("charge"), got.get("how")
    if (
        not isinstance(t, float)
        or not math.isfinite(t)
        or not isinstance(how, str)
        or not isinstance(charge, dict)
        or not all(isinstance(k, str) and isinstance(v, float) and math.isfinite(v) for k, v in charge.items())
    ):
        return False, None
    return True, AxialSwitch(t, tuple(sorted(charge.items())), how)


def recalled(scene: Scene) -> Scene | None:
    """The scene with the bars a remembered decision kept dynamic, or None (nothing remembered,
    or the decision kept none)."""
    if not scene.hash or not switchable(scene):
        return None
    known, answer = cache.recall(_question(scene))
    if not known or not isinstance(answer, dict):
        return None
    bars, reason = answer.get("bars"), answer.get("reason")
    if not isinstance(bars, list) or not isinstance(reason, str) or not all(isinstance(b, str) for b in bars):
        return None
    quasi = set(_auto_quasi_static(scene))
    if not bars or not set(bars) <= quasi:
        return None
    valid, switch = _switch_of(answer)
    if not valid:
        return None
    return _kept(scene, bars, reason, switch)


def kept_as_is(scene: Scene) -> bool:
    """A remembered decision kept every bar of ``scene`` quasi-static (its run need not decide
    again)."""
    if not scene.hash or not switchable(scene):
        return False
    known, answer = cache.recall(_question(scene))
    return known and isinstance(answer, dict) and answer.get("bars") == []


def resolved(scene: Scene) -> Scene:
    """The scene with the decision remembered for it, else as it is."""
    return recalled(scene) or scene


def decide(mech: Mechanism, result: Any) -> Scene | None:
    """After a complete run of ``mech`` whose scene is :func:`switchable`: the scene with the
    auto rule's quasi-static bars kept dynamic when the run's axial part (the drift, the start's
    ringing or the stretch's own inertia) exceeds the accuracy, else None (also when the part cannot be estimated).
    Remembered either way; a run kept as it is keeps its measured part for its error estimate."""
    from symgen.numerics import axial_drift as _axial_drift  # the estimate: only to decide

    scene = mech.scene
    accuracy = float(scene.simulation.accuracy)
    try:
        found = _axial_drift.parts(mech, result, enough=accuracy)
    except (_axial_drift.AxialNotEstimated, ValueError, ArithmeticError, RuntimeError):
        return None  # not estimated (the sidecar's error estimate says why): kept quasi-static
    kinds = {o.name: o.kind for o in scene.outputs}
    top, worst, part = 0.0, "", "drift"
    for measure, values in (("drift", found.drift), ("ringing", found.ringing), ("own", found.own)):
        for n, v in values.items():
            if kinds.get(n) not in CHECK_KINDS and v > top:
                top, worst, part = float(v), n, measure
    bars = _auto_quasi_static(scene) if top > accuracy else []
    reason = (
        f"auto: the run's axial estimate ({MEASURES[part]}) is {top:.2e} of peak on {worst}, above "
        f"simulation.accuracy {accuracy:g}: axial dynamics kept"
    )
    switch = _damped_switch(mech, result, found, kinds) if bars and part == "ringing" else None
    if switch is not None:
        left = max((v for _, v in switch.charge), default=0.0)
        reason += (
            f" until tau {switch.tau:.6g}, quasi-static after it: {switch.how} (the switch and the quasi-static "
            f"treatment after it: {left:.2e} of peak at most, the error estimate's axial part)"
        )
    elif part == "ringing":
        reason += f" ({RINGING_ALTERNATIVE})"
    if scene.hash:
        answer: dict[str, Any] = {"bars": bars, "reason": reason, "estimate": top, "output": worst, "part": part}
        if switch is not None:
            answer["switch"] = {"tau": switch.tau, "charge": dict(switch.charge), "how": switch.how}
        cache.remember(_question(scene), answer)
    if not bars:
        _axial_drift.keep_parts(mech, result, found)
        return None
    return _kept(scene, bars, reason, switch)


def _damped_switch(mech: Mechanism, result: Any, found: Any, kinds: dict[str, str]) -> AxialSwitch | None:
    """Where the axial part that keeps the axial dynamics is the start's ringing alone (the drift
    and the stretch's own inertia within ``axial_drift.SWITCH_SHARE`` of the accuracy) and
    Kelvin-Voigt damping ends it early in the run (:func:`symgen.numerics.axial_drift.ringing_end`,
    every output within that share of the accuracy after it, the quasi-static model continued
    from there too): the switch to the quasi-static treatment there, charging each output the
    larger of that continued run's difference and the quasi-static run's drift and own inertia. None otherwise (the axial dynamics kept for
    the whole run), also where the two models' coordinates or rows do not match."""
    from symgen.numerics import axial_drift as _axial_drift
    from symgen.numerics.simulate import switched_rows

    accuracy = float(mech.scene.simulation.accuracy)
    others = [
        float(v) for values in (found.drift, found.own) for n, v in values.items() if kinds.get(n) not in CHECK_KINDS
    ]
    if max(others, default=0.0) > _axial_drift.SWITCH_SHARE * accuracy:
        return None
    try:
        end = _axial_drift.ringing_end(mech, result, _axial_drift.SWITCH_SHARE * accuracy)
    except (_axial_drift.AxialNotEstimated, ValueError, ArithmeticError, RuntimeError):
        return None  # the window failed: kept for the whole run
    if end is None:
        return None
    bars = sorted(_axial_drift.quasi_static_bars(mech))
    kept = _axial_drift.kept_mechanism(_axial_drift.axial_dynamic_scene(mech.scene, bars))
    if switched_rows(kept, mech, bars) is None:
        return None
    charge = {
        n: max(end.charge.get(n, 0.0), float(found.drift.get(n, 0.0)), float(found.own.get(n, 0.0)))
        for n in end.charge
        if kinds.get(n) not in CHECK_KINDS
    }
    return AxialSwitch(float(end.tau), tuple(sorted(charge.items())), end.how)


def run_with_axial_choice(
    mech: Mechanism,
    result: R | None,
    failure: BaseException | None,
    load: Callable[[Scene], Mechanism],
    run: Callable[[Mechanism], tuple[R | None, BaseException | None]],
    say: Callable[[str], None] | None = None,
) -> tuple[Mechanism, R | None, BaseException | None]:
    """After ``run(mech)`` gave (``result``, ``failure``): when the scene may still keep axial
    dynamics and the run's axial part says so (a complete run, or one stopped early with a partial
    result, judged up to the stop: :func:`symgen.numerics.results.decidable`), the run made again with them kept
    (``load``-ed); else the run as it is (without deciding where a remembered decision kept it)."""
    from symgen.numerics.results import judged

    if not switchable(mech.scene) or kept_as_is(mech.scene):
        return mech, result, failure
    decided = judged(decide, mech, result, failure)
    if decided is None:
        return mech, result, failure
    if say is not None:
        bars = ", ".join(b for b, _ in decided.axial_kept)
        say(f"{bars}: {decided.axial_kept[0][1]}: running it")
    mech = load(decided)
    result, failure = run(mech)
    return mech, result, failure
