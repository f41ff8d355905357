"""A run stopped at the quasi-static form's impasse with quasi-static functions symgen chose:
the run made again with those functions dynamic (issue 19: symgen's own choices must not break
a run; docs/quasi-static-modes.md, "When the quasi-static form has no solution").

The bases chooser (:func:`symgen.scene.bases.quasi_choice`) makes functions above a bar's band
quasi-static from a linear model at the start, where the feedback of the quasi-static amplitudes
through the strain's axial-bending coupling is ~0; along the run it may grow until the mass of the
quasi-static form, ``M_dd - R_dh R_hh^-1 M_hd``, loses its definiteness and the accelerations have
no solution (:func:`symgen.numerics.simulate.quasi_mass_ratio`). A failure of such a run (the
error :func:`symgen.numerics.simulate._quasi_failure` builds, IDAS or the C solver, which marks it
with ``quasi_bars``) then makes the run again, once, with the quasi-static functions symgen chose
dynamic (the bars' ``quasi_static_transverse`` 0 and their record's ``quasi``/``quasi_axial``
0, its ``quasi_reason`` saying why), with one warning line. Functions the file states
(``bodies.<name>.quasi_static_transverse``) stay: their failure is the user's to change (exit 2,
the hint names the key). Each family on its own: a bar whose axial functions symgen chose
quasi-static and whose transverse ones the file states keeps the stated ones (only the chosen
family is made dynamic).

The fallback is remembered in the signed cache, as the other run-time decisions are
(:mod:`symgen.numerics.strain_choice`, :mod:`symgen.numerics.counts_choice`): keyed by the
scene's hash (after overrides), the decisions before it (the bar formulation, the axial dynamics
kept, the counts' floors) and the quasi-static functions symgen chose, so the next run of the same
scene loads the all-dynamic model directly (:func:`resolved`, its record's ``quasi_reason`` saying
it was remembered) instead of meeting the impasse first. A changed choice (another symgen, another
chooser's answer) is another question: decided again.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any, TypeVar

from symgen import __version__, cache

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene.model import Scene

__all__ = [
    "chosen_quasi",
    "chosen_quasi_bars",
    "recalled",
    "resolved",
    "run_with_quasi_fallback",
    "without_chosen_quasi",
]

R = TypeVar("R")

#: the fallback's version in the remembered decisions
FALLBACK_VERSION = "1"


def chosen_quasi(scene: Scene) -> dict[str, tuple[bool, bool]]:
    """bar -> (its transverse, its axial quasi-static functions are symgen's choice), for the bars
    with any: transverse, the record's ``quasi`` where the file does not state
    ``quasi_static_transverse``; axial, ``quasi_axial`` (no key states those)."""
    bodies = {b.name: b for b in scene.bodies}
    out = {}
    for c in scene.bases:
        body = bodies.get(c.bar)
        transverse = (
            bool(c.quasi) and not c.quasi_stated and body is not None and body.quasi_static_transverse == c.quasi
        )
        if transverse or c.quasi_axial:
            out[c.bar] = (transverse, bool(c.quasi_axial))
    return out


def chosen_quasi_bars(scene: Scene) -> list[str]:
    """The bars with quasi-static functions symgen chose, of either family (:func:`chosen_quasi`)."""
    return list(chosen_quasi(scene))


def without_chosen_quasi(scene: Scene, why: str) -> Scene:
    """``scene`` with the quasi-static functions symgen chose dynamic, each family on its own
    (:func:`chosen_quasi`: stated ones stay); ``why`` goes into their record's ``quasi_reason``."""
    chosen = chosen_quasi(scene)
    bodies = tuple(
        replace(b, quasi_static_transverse=0) if chosen.get(b.name, (False, False))[0] else b for b in scene.bodies
    )
    bases = []
    for c in scene.bases:
        transverse, axial = chosen.get(c.bar, (False, False))
        if transverse or axial:
            families = " and ".join(f for f, on in (("transverse", transverse), ("axial", axial)) if on)
            c = replace(
                c,
                quasi=0 if transverse else c.quasi,
                quasi_axial=0 if axial else c.quasi_axial,
                quasi_reason=f"{why}: the {families} functions symgen chose quasi-static made dynamic "
                f"(was: {c.quasi_reason})",
            )
        bases.append(c)
    return replace(scene, bodies=tuple(bodies), bases=tuple(bases))


def _question(scene: Scene) -> dict[str, Any]:
    from symgen.numerics.counts_choice import decisions

    return {
        "check": "quasi.fallback",
        "version": __version__,
        "fallback": FALLBACK_VERSION,
        **decisions(scene),
        "chosen": {b: list(f) for b, f in sorted(chosen_quasi(scene).items())},
        "counts": [[c.bar, c.axial, c.transverse, c.quasi, c.quasi_axial] for c in scene.bases],
    }


def recalled(scene: Scene) -> Scene | None:
    """The scene with a fallback remembered for it made (its chosen quasi-static functions
    dynamic), or None (nothing chosen, or nothing remembered)."""
    if not scene.hash or not chosen_quasi(scene):
        return None
    known, answer = cache.recall(_question(scene))
    if not known or not isinstance(answer, dict) or not isinstance(answer.get("why"), str):
        return None
    return without_chosen_quasi(scene, f"{answer['why']} (remembered from an earlier run)")


def resolved(scene: Scene) -> Scene:
    """The scene with a fallback remembered for it, else as it is."""
    return recalled(scene) or scene


def run_with_quasi_fallback(
    mech: Mechanism,
    result: R | None,
    failure: BaseException | None,
    load: Callable[[Scene], Mechanism],
    run: Callable[[Mechanism], tuple[R | None, BaseException | None]],
) -> tuple[Mechanism, R | None, BaseException | None]:
    """After ``run(mech)`` gave (``result``, ``failure``): when the failure is the quasi-static
    form's (``quasi_bars`` set by ``_quasi_failure``) and some of those functions are symgen's
    choice, one warning line and the run made again with them dynamic (``load``-ed; remembered for
    the scene: :func:`resolved`); else as it is."""
    if failure is None or not getattr(failure, "quasi_bars", None):
        return mech, result, failure
    bars = chosen_quasi_bars(mech.scene)
    if not set(bars) & set(failure.quasi_bars):  # type: ignore[attr-defined]
        return mech, result, failure
    tau = getattr(failure, "tau", None)
    where = f"tau = {tau:.6g}" if tau is not None else "the start"
    ratio = getattr(failure, "quasi_ratio", float("nan"))
    why = f"the quasi-static form met its impasse at {where}"
    from symgen.scene.limits import SceneWarning

    warnings.warn(
        SceneWarning(
            f"{mech.scene.path}: {why} with the quasi-static functions symgen chose on {', '.join(bars)} "
            f"(its mass {ratio:.2g} of the model's at the last output: docs/quasi-static-modes.md, the "
            f"impasse); running again with them dynamic"
        ),
        stacklevel=2,
    )
    if mech.scene.hash:
        cache.remember(
            _question(mech.scene), {"why": why, "ratio": float(ratio) if ratio == ratio else None, "bars": bars}
        )
    mech = load(without_chosen_quasi(mech.scene, why))
    result, failure = run(mech)
    return mech, result, failure
