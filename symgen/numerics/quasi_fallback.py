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
the hint names the key). Not remembered: the next run of the scene meets the impasse again.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene.model import Scene

__all__ = ["chosen_quasi_bars", "run_with_quasi_fallback", "without_chosen_quasi"]

R = TypeVar("R")


def chosen_quasi_bars(scene: Scene) -> list[str]:
    """The bars with quasi-static functions symgen chose (transverse: the record's ``quasi``
    where the file does not state ``quasi_static_transverse``; axial: ``quasi_axial``)."""
    bodies = {b.name: b for b in scene.bodies}
    out = []
    for c in scene.bases:
        body = bodies.get(c.bar)
        transverse = (
            bool(c.quasi) and not c.quasi_stated and body is not None and body.quasi_static_transverse == c.quasi
        )
        if transverse or c.quasi_axial:
            out.append(c.bar)
    return out


def without_chosen_quasi(scene: Scene, why: str) -> Scene:
    """``scene`` with the quasi-static functions symgen chose dynamic (:func:`chosen_quasi_bars`);
    ``why`` goes into their record's ``quasi_reason``."""
    bars = set(chosen_quasi_bars(scene))
    bodies = tuple(replace(b, quasi_static_transverse=0) if b.name in bars else b for b in scene.bodies)
    bases = tuple(
        replace(c, quasi=0, quasi_axial=0, quasi_reason=f"{why}: all dynamic (was: {c.quasi_reason})")
        if c.bar in bars
        else c
        for c in scene.bases
    )
    return replace(scene, bodies=bodies, bases=bases)


def run_with_quasi_fallback(
    mech: Mechanism,
    result: R | None,
    failure: BaseException | None,
    load: Callable[[Scene], Mechanism],
    run: Callable[[Mechanism], tuple[R | None, BaseException | None]],
) -> tuple[Mechanism, R | None, BaseException | None]:
    """After ``run(mech)`` gave (``result``, ``failure``): when the failure is the quasi-static
    form's (``quasi_bars`` set by ``_quasi_failure``) and some of those functions are symgen's
    choice, one warning line and the run made again with them dynamic (``load``-ed); else as it is."""
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
    mech = load(without_chosen_quasi(mech.scene, why))
    result, failure = run(mech)
    return mech, result, failure
