"""The checks of a scene's expressions that need SymPy, remembered in the signed cache.

A scene's expressions of tau (a driver's ``law``, a torque, a load) are parsed into SymPy by
:mod:`symgen.scene.expressions` and checked to be finite over the run (poles, values outside a
function's domain, a law's two derivatives). On a run of a cached model nothing else needs
SymPy, whose import alone costs most of such a run, so each verdict is remembered
(:func:`symgen.cache.recall` / :func:`symgen.cache.remember`: one file sealed with this user's
keyed hash, holding the question and its answer; only a passed check is remembered) and the same
question on a later run is answered without SymPy (``tests/test_lean_start.py``). The question holds everything the
answer depends on (the expression's text, the end of the run, the symgen version), never a
parsed object: the cached answer is data, nothing in it is evaluated.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from symgen import __version__, cache

T = TypeVar("T")


def _remembered(question: dict[str, Any], answer: Callable[[], T | None]) -> T | None:
    """None when ``question`` was answered None (all is well) before, else ``answer()``; a None
    answer is remembered. Only the good verdict is kept: a scene that fails its check stops the
    run anyway, and random bad input (a fuzzer, a typo being fixed) leaves nothing behind."""
    question = dict(question, symgen=__version__)
    found, value = cache.recall(question)
    if found and value is None:
        return None
    result = answer()
    if result is None:
        cache.remember(question, None)
    return result


def expression_error(text: str) -> str | None:
    """Why ``text`` is not an expression of tau (the parser's message), else None."""

    def answer() -> str | None:
        from symgen.scene.expressions import parse_tau_expression

        try:
            parse_tau_expression(text)
        except ValueError as exc:
            return str(exc)
        return None

    return _remembered({"check": "expression", "text": text}, answer)


def seconds_error(text: str, omega: float, scale: float) -> str | None:
    """Why an SI scene's ``text`` (an expression of t in seconds) cannot be converted to the
    model's expression of tau (:func:`symgen.scene.expressions.seconds_to_tau_text`), else None."""

    def answer() -> str | None:
        from symgen.scene.expressions import seconds_to_tau_text

        try:
            seconds_to_tau_text(text, omega, scale)
        except ValueError as exc:
            return str(exc)
        return None

    return _remembered({"check": "seconds", "text": text, "omega": omega, "scale": scale}, answer)


def expression_not_finite(text: str, t_end: float) -> float | None:
    """The first tau in [0, t_end] where the (valid) expression ``text`` is not a finite real
    number, else None (:func:`symgen.scene.expressions.first_non_finite`)."""

    def answer() -> float | None:
        from symgen.scene.expressions import first_non_finite, parse_tau_expression

        return first_non_finite(parse_tau_expression(text), t_end)

    return _remembered({"check": "finite", "text": text, "t_end": t_end}, answer)


def law_not_finite(driver: Any, t_end: float) -> tuple[float, str] | None:
    """The first (tau, what) in [0, t_end] where an angle driver's ``law``, or one of its two
    derivatives, is not a finite real number, else None (:func:`symgen.scene.motion.check_finite`).
    ``driver`` is a :class:`symgen.scene.model.Driver` with a law."""

    def answer() -> tuple[float, str] | None:
        from symgen.scene.motion import check_finite

        return check_finite(driver, t_end)

    question = {"check": "law", "law": driver.law, "initial": driver.initial, "t_end": t_end}
    return _remembered(question, answer)
