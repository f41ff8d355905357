"""The shape functions of one elastic bar sampled at quadrature nodes: what the model-form
estimate of a run (:mod:`symgen.numerics.model_form`) needs of the bar's bases, without the
model layer's SymPy.

The samples are taken when a model is derived (:func:`symgen.model.shape_samples.remember_samples`)
and kept in the signed cache of checks (:func:`symgen.cache.remember`), keyed by
:func:`samples_question` (the bar's structure record, the node count, the version); a run reads
them back with :func:`symgen.cache.recall` and :meth:`ShapeSamples.from_json`, which checks
every field (:class:`InvalidShapeSamples`, never a ``KeyError``).

Every integral the estimate takes over the bar (mass, bending and geometric stiffness, the
exact curvature's energy) is ``sum_i w_i f(xi_i)`` over these nodes: Gauss-Legendre on
``SEGMENTS`` equal pieces of [0, 1], each further split at the bar's static-correction points
(where a correction function's third derivative jumps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from symgen import __version__
from symgen.ir.info import record_fields

__all__ = [
    "GAUSS_POINTS",
    "SEGMENTS",
    "GuideSamples",
    "InvalidShapeSamples",
    "ShapeSamples",
    "guide_question",
    "samples_question",
]

#: Gauss-Legendre points per segment and equal segments of [0, 1] (before the split at the
#: correction points): 16 x 8 nodes integrate the sine and clamped-free families' products of
#: degree <= 6 (E4's eta'^2 eta''^2) to 1e-12 relative (tests/test_model_form_lean.py)
GAUSS_POINTS = 8
SEGMENTS = 16
#: the version of the samples' question (a change of the nodes or of the record)
SAMPLES_VERSION = "1"


class InvalidShapeSamples(ValueError):
    """A cached shape-samples record that is not one (sampled again)."""


@dataclass(frozen=True)
class ShapeSamples:
    """One bar's functions at the quadrature nodes ``xi`` (weights ``w``): ``axial1[i][k]`` =
    phi_k'(xi_i); ``trans0``, ``trans1``, ``trans2`` the transverse functions psi_a and their
    first and second derivatives (lengths in units of the bar's length)."""

    bar: str
    xi: tuple[float, ...]
    w: tuple[float, ...]
    axial1: tuple[tuple[float, ...], ...]
    trans0: tuple[tuple[float, ...], ...]
    trans1: tuple[tuple[float, ...], ...]
    trans2: tuple[tuple[float, ...], ...]

    @property
    def na(self) -> int:
        return len(self.axial1[0]) if self.axial1 else 0

    @property
    def nt(self) -> int:
        return len(self.trans0[0]) if self.trans0 else 0

    def range_rows(self) -> tuple[int, ...]:
        """The nodes of the range check: the first and last node of every piece of the quadrature
        (``GAUSS_POINTS`` nodes each, in order), 0.0012 of a piece from its ends: a grid no
        coarser than 1/16 of the bar, both ends of the bar included to that distance, on which a
        slope's largest value is missed by less than 0.5 % of it."""
        return tuple(i for i in range(len(self.xi)) if i % GAUSS_POINTS in (0, GAUSS_POINTS - 1))

    def slope_table(self) -> tuple[tuple[float, ...], ...]:
        """psi_a'(xi_j) at the range check's points (:meth:`range_rows` of ``trans1``): the bar's
        slopes eta' there (``symgen.numerics.checks.beyond_range`` and the emitted C solver's
        range check)."""
        return tuple(self.trans1[i] for i in self.range_rows())

    def stretch_table(self) -> tuple[tuple[float, ...], ...]:
        """phi_k'(xi_j) at the same points (:meth:`range_rows` of ``axial1``): with the slopes, the
        bar's tangent r' = (1 + zeta', eta') there and its stretch |r'| - 1."""
        return tuple(self.axial1[i] for i in self.range_rows())

    def to_json(self) -> dict[str, Any]:
        return {
            "bar": self.bar,
            "xi": list(self.xi),
            "w": list(self.w),
            "axial1": [list(r) for r in self.axial1],
            "trans0": [list(r) for r in self.trans0],
            "trans1": [list(r) for r in self.trans1],
            "trans2": [list(r) for r in self.trans2],
        }

    @classmethod
    def from_json(cls, data: object) -> ShapeSamples:
        keys = ("bar", "xi", "w", "axial1", "trans0", "trans1", "trans2")
        data = record_fields(data, "the shape-samples record", keys, InvalidShapeSamples)
        bar = data["bar"]
        if not isinstance(bar, str) or not bar:
            raise InvalidShapeSamples("'bar' is not a bar's name")
        xi, w = _row(data["xi"], "xi"), _row(data["w"], "w")
        if not xi or len(w) != len(xi):
            raise InvalidShapeSamples("'xi' and 'w' are not nodes and their weights")
        if any(not 0.0 <= x <= 1.0 for x in xi) or any(x <= 0 for x in w) or abs(sum(w) - 1.0) > 1e-9:
            raise InvalidShapeSamples("'xi' and 'w' are not a quadrature of [0, 1]")
        tables = {k: _table(data[k], k, len(xi)) for k in ("axial1", "trans0", "trans1", "trans2")}
        widths = {len(t[0]) if t else 0 for k, t in tables.items() if k != "axial1"}
        if len(widths) != 1:
            raise InvalidShapeSamples("'trans0', 'trans1', 'trans2' do not hold the same functions")
        return cls(bar, xi, w, tables["axial1"], tables["trans0"], tables["trans1"], tables["trans2"])


def samples_question(body: dict[str, Any]) -> dict[str, Any]:
    """The cache question of a bar's samples: its structure record (``ModelInfo.structure``'s
    ``bodies`` entry: the families, counts, frame, correction points), the nodes, the version."""
    return {
        "check": "model_form.shape_samples",
        "version": __version__,
        "samples": SAMPLES_VERSION,
        "nodes": [SEGMENTS, GAUSS_POINTS],
        "body": body,
    }


def _row(x: object, what: str) -> tuple[float, ...]:
    if not isinstance(x, list) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in x
    ):
        raise InvalidShapeSamples(f"{what!r} is not a list of numbers")
    return tuple(float(v) for v in x)


def _table(x: object, what: str, rows: int) -> tuple[tuple[float, ...], ...]:
    """A rows x k table (k >= 0; an empty list when the bar has no functions of that kind)."""
    if not isinstance(x, list):
        raise InvalidShapeSamples(f"{what!r} is not a table")
    if not x:
        return ()
    if len(x) != rows:
        raise InvalidShapeSamples(f"{what!r} does not have one row per node")
    table = tuple(_row(r, what) for r in x)
    if len({len(r) for r in table}) != 1 or not table[0]:
        raise InvalidShapeSamples(f"{what!r} is not a table of equal rows")
    return table


@dataclass(frozen=True)
class GuideSamples:
    """A slot guide's functions at quadrature nodes (its functions psi(xi, beta) move with the
    contact, so no fixed samples of xi describe them: :mod:`symgen.model.slot`). Each function is a
    power of beta times a fixed function of u = xi / beta on the span [0, beta], and a power of beta
    and of 1 - beta times a fixed function of v = (xi - beta) / (1 - beta) on the overhang:

        d^n psi_k / dxi^n = beta^(p - n) f_k^(n)(u)                 (span, p = ``span_powers[k]``)
                          = beta^p (1 - beta)^(o - n) h_k^(n)(v)     (overhang, (p, o) = ``over_powers[k]``)

    ``x``, ``w``: Gauss-Legendre nodes and weights of [0, 1] (``SEGMENTS`` pieces of
    ``GAUSS_POINTS``), the same for u and v (an integral over the span is beta sum w f(x), over the
    overhang (1 - beta) sum w h(x)); ``span[n]`` / ``over[n]`` (n = 0, 1, 2) the fixed functions'
    n-th derivatives there (nodes x functions; zero where a function vanishes on that piece, its
    powers then 0). ``nover``: the overhang's functions (0: the seed's rigid overhang, straight, so
    its slope is one value). Read by the range check (:meth:`slope_rows`: the Python runners and
    the C runtime's ``symgen_bar_range_``) and the model-form estimate
    (``symgen.numerics.model_form``)."""

    guide: str
    nover: int
    x: tuple[float, ...]
    w: tuple[float, ...]
    span: tuple[tuple[tuple[float, ...], ...], ...]
    over: tuple[tuple[tuple[float, ...], ...], ...]
    span_powers: tuple[int | None, ...]
    over_powers: tuple[tuple[int, int] | None, ...]

    @property
    def nt(self) -> int:
        return len(self.span_powers)

    def range_rows(self) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """(span, overhang) nodes of the range check: the first and last node of every piece
        (:meth:`ShapeSamples.range_rows`); one node of the rigid overhang (straight)."""
        rows = tuple(i for i in range(len(self.x)) if i % GAUSS_POINTS in (0, GAUSS_POINTS - 1))
        return rows, rows if self.nover else rows[-1:]

    def slope_rows(self) -> tuple[tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...]]:
        """The fixed slopes f_k'(u), h_k'(v) at the range check's (span, overhang) nodes."""
        span, over = self.range_rows()
        return tuple(self.span[1][i] for i in span), tuple(self.over[1][i] for i in over)

    def powers(self, n: int) -> tuple[tuple[tuple[int, int], ...], tuple[tuple[int, int], ...]]:
        """(span, overhang) powers (a, b) of beta and 1 - beta of each function's n-th derivative:
        (p - n, 0) on the span, (p, o - n) on the overhang ((0, 0) where it vanishes: zero samples)."""
        span = tuple((0, 0) if p is None else (p - n, 0) for p in self.span_powers)
        over = tuple((0, 0) if po is None else (po[0], po[1] - n) for po in self.over_powers)
        return span, over

    def scalings(self, beta: Any, n: int) -> tuple[Any, Any]:
        """(span, overhang) factors beta^a (1 - beta)^b of each function's n-th derivative
        (``powers``), functions x len(beta) for an array of contacts."""
        import numpy as np

        b = np.atleast_1d(np.asarray(beta, dtype=float))
        one = 1.0 - b

        def factors(powers: tuple[tuple[int, int], ...]) -> Any:
            return np.array([b**a * one**c for a, c in powers]).reshape(len(powers), len(b))

        span, over = self.powers(n)
        return factors(span), factors(over)

    def to_json(self) -> dict[str, Any]:
        return {
            "guide": self.guide,
            "nover": self.nover,
            "x": list(self.x),
            "w": list(self.w),
            "span": [[list(r) for r in t] for t in self.span],
            "over": [[list(r) for r in t] for t in self.over],
            "span_powers": list(self.span_powers),
            "over_powers": [None if p is None else list(p) for p in self.over_powers],
        }

    @classmethod
    def from_json(cls, data: object) -> GuideSamples:
        keys = ("guide", "nover", "x", "w", "span", "over", "span_powers", "over_powers")
        data = record_fields(data, "the guide-samples record", keys, InvalidShapeSamples)
        guide, nover = data["guide"], data["nover"]
        if not isinstance(guide, str) or not guide:
            raise InvalidShapeSamples("'guide' is not a bar name")
        if not isinstance(nover, int) or isinstance(nover, bool) or nover < 0:
            raise InvalidShapeSamples("'nover' is not a count")
        x, w = _row(data["x"], "x"), _row(data["w"], "w")
        if not x or len(w) != len(x) or any(not 0.0 <= v <= 1.0 for v in x) or abs(sum(w) - 1.0) > 1e-9:
            raise InvalidShapeSamples("'x' and 'w' are not a quadrature of [0, 1]")
        sp = data["span_powers"]
        if not isinstance(sp, list) or not sp or not all(_power_or_none(v) for v in sp):
            raise InvalidShapeSamples("'span_powers' is not a list of integers")
        op = data["over_powers"]
        if not isinstance(op, list) or not all(
            v is None or (isinstance(v, list) and len(v) == 2 and all(_power_or_none(u) and u is not None for u in v))
            for v in op
        ):
            raise InvalidShapeSamples("'over_powers' is not a list of integer pairs")
        if len(op) != len(sp):
            raise InvalidShapeSamples("'span_powers' and 'over_powers' do not hold the same functions")
        over_powers = tuple(None if v is None else (int(v[0]), int(v[1])) for v in op)
        tables = {}
        for key in ("span", "over"):
            t = data[key]
            if not isinstance(t, list) or len(t) != 3:
                raise InvalidShapeSamples(f"{key!r} is not three tables")
            tables[key] = tuple(_table(table, key, len(x)) for table in t)
            if any(not table or len(table[0]) != len(sp) for table in tables[key]):
                raise InvalidShapeSamples(f"{key!r} does not hold one column per function")
        span_powers = tuple(None if v is None else int(v) for v in sp)
        return cls(guide, nover, x, w, tables["span"], tables["over"], span_powers, over_powers)


def _power_or_none(v: object) -> bool:
    return v is None or (isinstance(v, int) and not isinstance(v, bool))


def guide_question(body: dict[str, Any], joint: dict[str, Any]) -> dict[str, Any]:
    """The cache question of a slot guide's samples: its structure record and its slot joint's
    (``ModelInfo.structure``: the counts and the overhang), the points, the version."""
    return {
        "check": "slot.guide_samples",
        "version": __version__,
        "samples": SAMPLES_VERSION,
        "nodes": [SEGMENTS, GAUSS_POINTS],
        "body": body,
        "joint": joint,
    }
