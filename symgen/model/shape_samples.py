"""Sample a bar's shape functions at quadrature nodes for the model-form estimate
(:class:`symgen.ir.shape_samples.ShapeSamples`), when the model is derived: a run on the cached
model then reads them from the signed cache without SymPy."""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from symgen import cache
from symgen.ir.shape_samples import (
    GAUSS_POINTS,
    SEGMENTS,
    GuideSamples,
    InvalidShapeSamples,
    ShapeSamples,
    guide_question,
    samples_question,
)
from symgen.model.static_shapes import bar_bases

__all__ = ["guide_samples", "remember_samples", "sample_bar", "shape_samples"]


def _nodes(breaks: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [0, 1]: ``SEGMENTS`` equal pieces, split further at
    ``breaks``."""
    cuts = sorted({*np.linspace(0.0, 1.0, SEGMENTS + 1).tolist(), *(b for b in breaks if 0.0 < b < 1.0)})
    x0, w0 = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    xs, ws = [], []
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b - a <= 1e-12:
            continue
        xs.append(a + (b - a) * (x0 + 1.0) / 2.0)
        ws.append((b - a) * w0 / 2.0)
    return np.concatenate(xs), np.concatenate(ws)


def sample_bar(body: dict[str, Any]) -> ShapeSamples:
    """The samples of one bar (its ``ModelInfo.structure["bodies"]`` record)."""
    ba, bt = bar_bases(body)
    return ShapeSamples(body["name"], *_sampled(ba, bt))


Table = tuple[tuple[float, ...], ...]


@lru_cache(maxsize=64)
def _sampled(ba: Any, bt: Any) -> tuple[tuple[float, ...], tuple[float, ...], Table, Table, Table, Table]:
    """(xi, w, axial1, trans0, trans1, trans2) of a bar of bases ``ba``, ``bt``: sampled once per
    process for equal bases (the bars of one structure: each function's 50-digit evaluation at
    every node is most of a first run's sampling, 12 x 0.35 s on a 12-bar exact chain)."""
    xi, w = _nodes((*ba.points, *bt.points, *bt.moment_points))

    def table(basis: Any, d: int) -> Table:
        if len(basis) == 0:
            return ()
        return tuple(tuple(float(v) for v in basis.values(float(x), d)) for x in xi)

    return (
        tuple(float(x) for x in xi),
        tuple(float(x) for x in w),
        table(ba, 1),
        table(bt, 0),
        table(bt, 1),
        table(bt, 2),
    )


def shape_samples(body: dict[str, Any]) -> ShapeSamples:
    """The samples of one bar, from the cache of checks or sampled now (and remembered)."""
    question = samples_question(body)
    known, answer = cache.recall(question)
    if known:
        try:
            return ShapeSamples.from_json(answer)
        except ValueError:
            pass
    samples = sample_bar(body)
    cache.remember(question, samples.to_json())
    return samples


def remember_samples(structure: dict[str, Any]) -> None:
    """Sample every elastic bar of a derived model's ``structure`` (its transverse or axial count
    > 0) into the cache, where the model-form estimate and the range check of its runs read them
    (an axially elastic bar that does not bend has a stretch check too)."""
    bodies = {body["name"]: body for body in structure.get("bodies", [])}
    for body in bodies.values():
        if body.get("nt") or body.get("na"):
            shape_samples(body)
    for joint in structure.get("joints", []):
        if joint.get("kind") == "slot" and len(joint["ends"]) == 2 and bodies.get(joint["ends"][1][0], {}).get("nt"):
            guide_samples(bodies[joint["ends"][1][0]], joint)


def guide_samples(body: dict[str, Any], joint: dict[str, Any]) -> GuideSamples:
    """A slot guide's samples (:func:`symgen.model.slot.guide_samples`) at the nodes of a bar
    without correction points, from the cache of checks or sampled now (and remembered): ``body``
    and ``joint`` are the guide's and its slot's structure records."""
    question = guide_question(body, joint)
    known, answer = cache.recall(question)
    if known:
        try:
            return GuideSamples.from_json(answer)
        except InvalidShapeSamples:
            pass
    from symgen.model.slot import guide_samples as sample_guide, overhang_count

    x, w = _nodes(())
    samples = sample_guide(body["name"], int(body["nt"]), overhang_count(joint), x, w)
    cache.remember(question, samples.to_json())
    return samples
