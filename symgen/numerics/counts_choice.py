"""The run-time half of the counts symgen chooses (:mod:`symgen.scene.bases` has the a-priori
half): after a complete run, the error estimate's truncation part (the richer model's rerun,
:func:`symgen.numerics.error_estimate.truncation_part`, ``EXTRA_AXIAL`` / ``EXTRA_TRANSVERSE``
more functions per bar) decides whether the run is made again with the richer model's counts as
the floor of the chosen counts: when it exceeds ``simulation.accuracy`` on any output (closure
residuals aside) and some bar's counts were chosen (its file states neither count). Stated
counts are never raised. The raised scene's run gets its own estimate (its own richer rerun),
which may raise once more: at most ``MAX_ROUNDS`` raises, the cap said. As ``effects.strain =
"auto"`` (:mod:`symgen.numerics.strain_choice`) and ``effects.axial = "auto"``
(:mod:`symgen.numerics.axial_choice`) the decision is remembered in the signed cache, keyed by
the scene's hash (after overrides), the model those decisions gave, the raises before it and the
version, so a rerun of the same scene loads the decided counts directly
(:func:`resolved`); the floors travel on ``Scene.counts_raised`` into the bases chooser, whose
coupled and quasi-static choices still apply (:func:`symgen.scene.loader.with_raised`), and the
sidecar's ``bases`` (``raised``), ``symgen effects`` and ``symgen check`` say why.

A truncation part whose rerun was stopped at its budget (``symgen.policy.RERUN_BUDGET``,
:mod:`symgen.numerics.error_estimate`) decides nothing: the counts as chosen are kept (nothing
remembered: a later run tries again), and the run's own estimate reads that part as not estimated
instead of paying the rerun again.

Only the "rerun" truncation decides (``symgen simulate --estimate rerun``, the default): the
linearised one is 10x to 100x low where the run rings freely (the module docstring of
:mod:`symgen.numerics.error_estimate`), and ``--estimate off`` asks for no estimate; both use a
remembered decision and make none.

Why after the run: the a-priori chooser reads the run's content from its drivers and a free
swing, not from the run; a soft free double pendulum whipping its lower link at 4.5 rad/tau got
3 + 4 functions per bar, 2.06 % of peak off its converged reference at the end with mu x 2
(5 + 6: 0.52 %), where the truncation part of its run said so.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from symgen import __version__, cache
from symgen.scene.model import CHECK_KINDS, CountsRaised

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene.model import Scene

__all__ = [
    "MAX_ROUNDS",
    "decide",
    "decisions",
    "raised",
    "recalled",
    "resolved",
    "run_with_counts_choice",
    "switchable",
]

R = TypeVar("R")

#: the decision's version in the remembered decisions (a changed estimate decides again; 3: the
#: truncation part's richer rerun against the run's model, both at the time part's tighter tolerances;
#: 4: an output zero to round-off over the run decides nothing, SimResult.peaks)
ESTIMATOR_VERSION = "4"
#: at most this many raises of a scene's chosen counts (each a run and its richer rerun more)
MAX_ROUNDS = 2
#: the only truncation method that decides (the module docstring)
DECIDING_METHOD = "rerun"


def chosen_bars(scene: Scene) -> list[str]:
    """The elastic bars whose counts symgen chose: the file states neither count."""
    return sorted(c.bar for c in scene.bases if c.given == (None, None))


def rounds(scene: Scene) -> int:
    """How many raises made the scene's counts."""
    return scene.counts_raised.rounds if scene.counts_raised is not None else 0


def switchable(scene: Scene) -> bool:
    """A scene whose chosen counts a run may still raise: some bar's counts are chosen and fewer
    than ``MAX_ROUNDS`` raises made them."""
    return bool(chosen_bars(scene)) and rounds(scene) < MAX_ROUNDS


def decisions(scene: Scene) -> dict[str, Any]:
    """What a remembered run-time decision about ``scene`` is keyed by beside its own check: the
    scene's hash (after overrides) and the decisions made before it (the bar formulation, the
    bars whose axial dynamics a run kept, the counts' floors). The chosen counts' and the
    quasi-static fallback's questions (:mod:`symgen.numerics.quasi_fallback`)."""
    raised = scene.counts_raised
    out: dict[str, Any] = {
        "scene": scene.hash,
        "strain": str(scene.effects.strain),
        "axial_kept": sorted(b for b, _ in scene.axial_kept),
        "floors": [] if raised is None else [list(f) for f in raised.floors],
    }
    if scene.axial_switch is not None:  # kept only until the start's ringing has ended
        out["axial_switch"] = scene.axial_switch.tau
    return out


def _question(scene: Scene) -> dict[str, Any]:
    return {"check": "counts.auto", "version": __version__, "estimator": ESTIMATOR_VERSION, **decisions(scene)}


def raised(scene: Scene, floors: dict[str, tuple[int, int]], reason: str) -> Scene:
    """``scene`` with its chosen counts at least ``floors`` (bar -> (axial, transverse)), chosen
    again (:func:`symgen.scene.loader.with_raised`), one raise more."""
    from symgen.scene.loader import with_raised

    return with_raised(
        scene,
        CountsRaised(tuple((b, a, t) for b, (a, t) in sorted(floors.items())), reason, rounds(scene) + 1),
    )


def _recall(scene: Scene) -> dict[str, Any] | None:
    if not scene.hash or not switchable(scene):
        return None
    known, answer = cache.recall(_question(scene))
    return answer if known and isinstance(answer, dict) else None


def recalled(scene: Scene) -> Scene | None:
    """The scene with the raise remembered for it, or None (nothing remembered, or the
    remembered decision raised nothing)."""
    answer = _recall(scene)
    if answer is None:
        return None
    floors, reason = answer.get("floors"), answer.get("reason")
    if not isinstance(floors, dict) or not floors or not isinstance(reason, str):
        return None
    chosen = set(chosen_bars(scene))
    if not set(floors) <= chosen or not all(
        isinstance(c, list) and len(c) == 2 and all(isinstance(x, int) and not isinstance(x, bool) for x in c)
        for c in floors.values()
    ):
        return None
    return raised(scene, {b: (c[0], c[1]) for b, c in floors.items()}, reason)


def kept_as_is(scene: Scene) -> bool:
    """A remembered decision kept the scene's counts (its run need not decide again)."""
    answer = _recall(scene)
    return answer is not None and answer.get("floors") == {}


def resolved(scene: Scene) -> Scene:
    """The scene with the raises remembered for it (each round's in turn), else as it is."""
    for _ in range(MAX_ROUNDS):
        decided = recalled(scene)
        if decided is None:
            break
        scene = decided
    return scene


def _counts(scene: Scene) -> dict[str, tuple[int, int]]:
    return {c.bar: (c.axial, c.transverse) for c in scene.bases}


def decide(mech: Mechanism, result: Any) -> Scene | None:
    """After a complete run of ``mech`` whose scene is :func:`switchable`: the scene with its
    chosen counts raised to the richer model's when the run's truncation part (its rerun) exceeds
    the accuracy, else None (also when the part cannot be estimated, or when the raise would not
    change the counts: ``MAX_CHOSEN``). Remembered either way; the part is kept for the run's own
    error estimate where the run is kept."""
    from symgen.errors import SymgenError
    from symgen.numerics import error_estimate as ee

    scene = mech.scene
    accuracy = float(scene.simulation.accuracy)
    try:
        part = ee.truncation_part(mech, result, method=DECIDING_METHOD)
    except ee.TruncationNotEstimated as why:
        if str(why).startswith(ee.BUDGET_PREFIX):  # its rerun stopped at its budget: not paid again
            ee.keep_truncation(mech, result, DECIDING_METHOD, why)
        return None  # not estimated (the sidecar's error estimate says why): the counts as chosen
    except (SymgenError, ValueError, ArithmeticError, RuntimeError):
        return None  # not estimated (the sidecar's error estimate says why): the counts as chosen
    values, richer, _ = part
    kinds = {o.name: o.kind for o in scene.outputs}
    deciding = {n: v for n, v in values.items() if kinds.get(n) not in CHECK_KINDS}
    worst = max(deciding, key=lambda n: deciding[n]) if deciding else ""
    top = float(deciding.get(worst, 0.0))
    floors = {b: (c[0], c[1]) for b, c in richer.items() if b in chosen_bars(scene)} if top > accuracy else {}
    decided, reason = None, ""
    if floors:
        said = ", ".join(f"{b} {a} + {t}" for b, (a, t) in floors.items())
        reason = (
            f"the run's truncation estimate (a rerun with {ee.EXTRA_AXIAL} more axial and {ee.EXTRA_TRANSVERSE} more transverse functions per bar) is {top:.2e} of peak on {worst}, "
            f"above simulation.accuracy {accuracy:g}: its richer counts ({said} axial + transverse) taken "
            f"(raise {rounds(scene) + 1} of at most {MAX_ROUNDS})"
        )
        decided = raised(scene, floors, reason)
        if _counts(decided) == _counts(scene):  # every chosen family at its cap already
            decided, floors, reason = None, {}, ""
    if scene.hash:
        cache.remember(
            _question(scene),
            {"floors": {b: list(c) for b, c in floors.items()}, "reason": reason, "estimate": top},
        )
    if decided is None:
        ee.keep_truncation(mech, result, DECIDING_METHOD, part)
    return decided


def cap_text(scene: Scene) -> str:
    """What the CLI says where the counts' raises reached ``MAX_ROUNDS`` ("" where not)."""
    if rounds(scene) < MAX_ROUNDS:
        return ""
    return (
        f"symgen raised the chosen counts {MAX_ROUNDS} times (its cap): "
        + ", ".join(f"{c.bar} {c.axial} + {c.transverse}" for c in scene.bases if c.raised)
        + " axial + transverse functions"
    )


def run_with_counts_choice(
    mech: Mechanism,
    result: R | None,
    failure: BaseException | None,
    load: Callable[[Scene], Mechanism],
    run: Callable[[Mechanism], tuple[R | None, BaseException | None]],
    say: Callable[[str], None] | None = None,
    estimate: str = "off",
) -> tuple[Mechanism, R | None, BaseException | None]:
    """After ``run(mech)`` gave (``result``, ``failure``): while the scene's chosen counts may
    still be raised and the complete run's truncation part (``estimate`` "rerun" only) says so,
    the run made again with them raised (``load``-ed), at most ``MAX_ROUNDS`` raises in all; else
    the run as it is."""
    while (
        estimate == DECIDING_METHOD
        and failure is None
        and result is not None
        and switchable(mech.scene)
        and not kept_as_is(mech.scene)
    ):
        decided = decide(mech, result)
        if decided is None:
            break
        if say is not None:
            say(f"{decided.counts_raised.reason if decided.counts_raised else ''}: running it")
        mech = load(decided)
        result, failure = run(mech)
    return mech, result, failure
