"""What a derived model is, without its expressions: the typed record that crosses the model
cache (``model.json``) and that every runner reads instead of the SymPy model.

:class:`ModelInfo` holds the same :class:`~symgen.ir.records.Coordinate` and
:class:`~symgen.ir.records.ConstraintRow` records as the derived model (one form before and
after the cache), the parameter and output names, the driver row, the number of loop rows, the
bars' mode counts, the structure with its key, and the derivation's timings. ``to_json`` gives
the plain data of ``model.json``; ``from_json`` reads it back and checks every field, raising
:class:`InvalidModelInfo` (never a ``KeyError``) on anything malformed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, TypeGuard

from symgen.ir import names
from symgen.ir.records import ConstraintRow, Coordinate, CoordKind, DerivedModel, RowKind, find_coordinate


class InvalidModelInfo(ValueError):
    """A ``model.json`` that is not a model description (the model cache reports it as an
    invalid entry and derives the model again)."""


@dataclass(frozen=True)
class BarModes:
    """The deformation functions of one bar: how many, and of which family."""

    axial: int
    transverse: int
    axial_shapes: str  # "" when the bar has no axial amplitudes
    transverse_shapes: str  # "" when the bar has no transverse amplitudes

    def to_json(self) -> dict[str, int | str]:
        return {
            "axial": self.axial,
            "transverse": self.transverse,
            "axial_shapes": self.axial_shapes,
            "transverse_shapes": self.transverse_shapes,
        }


@dataclass(frozen=True)
class ModelInfo:
    """A derived model's description (see the module docstring)."""

    key: str  # the structure key (symgen.model.structure.structure_key)
    structure: dict[str, Any]  # the structure it hashes (symgen.model.structure.structure_of)
    coords: tuple[Coordinate, ...]  # one per entry of q
    lam_rows: tuple[ConstraintRow, ...]  # one per multiplier (row of phi): loop rows, driver, inextensibility
    params: tuple[str, ...]  # parameter names, in the order of the p input
    outputs: tuple[str, ...]  # output names, in the order of the out function
    driver_row: int | None  # row of the first angle driver in lam, if any (driver_rows: all)
    n_loop_rows: int  # rows of the closure function (the loop rows of phi)
    modes: dict[str, BarModes]  # bar -> its deformation functions
    timings: dict[str, float] = field(default_factory=dict)  # derive_s, and build_s once built

    # ------------------------------------------------------------------ sizes and look-ups
    @property
    def n(self) -> int:
        return len(self.coords)

    @property
    def m(self) -> int:
        return len(self.lam_rows)

    @property
    def driver_rows(self) -> dict[str, int]:
        """driven bar -> the row of its angle driver in lam, in the scene's order of drivers."""
        return {r.loop[-1]: i for i, r in enumerate(self.lam_rows) if r.kind is RowKind.DRIVER}

    def indices(self, *kinds: CoordKind) -> tuple[int, ...]:
        """Indices of the coordinates of the given kinds, in order."""
        return tuple(i for i, c in enumerate(self.coords) if c.kind in kinds)

    def rows(self, *kinds: RowKind) -> tuple[int, ...]:
        """Indices of the multiplier rows of the given kinds, in order."""
        return tuple(i for i, r in enumerate(self.lam_rows) if r.kind in kinds)

    def coordinate(self, kind: CoordKind, body: str) -> int:
        """Index of the coordinate ``kind`` of ``body`` (KeyError if there is none)."""
        return find_coordinate(self.coords, kind, body)

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.coords)

    @cached_property
    def elastic(self) -> tuple[int, ...]:
        """The deformation amplitudes (f, g)."""
        return self.indices(CoordKind.F, CoordKind.G)

    @cached_property
    def rigid(self) -> tuple[int, ...]:
        """The rigid coordinates (theta, s, beta)."""
        return self.indices(CoordKind.THETA, CoordKind.S, CoordKind.BETA)

    @cached_property
    def amplitudes(self) -> dict[str, tuple[tuple[int, ...], tuple[int, ...]]]:
        """bar -> (its axial amplitudes, its transverse amplitudes), bars in coordinate order."""
        groups: dict[str, tuple[list[int], list[int]]] = {}
        for i, c in enumerate(self.coords):
            if c.elastic:
                groups.setdefault(c.body, ([], []))[c.kind is CoordKind.G].append(i)
        return {body: (tuple(f), tuple(g)) for body, (f, g) in groups.items()}

    @cached_property
    def slot_joints(self) -> dict[str, dict[str, Any]]:
        """guide -> its slot joint's structure record (one slot per guide)."""
        return {
            j["ends"][1][0]: j
            for j in self.structure.get("joints", [])
            if j.get("kind") == "slot" and len(j["ends"]) == 2
        }

    @cached_property
    def slot_guides(self) -> frozenset[str]:
        """The guides of slot joints: their functions psi(xi, beta) move with the contact, so the
        range check reads their slopes scaled by the contact (``symgen.numerics.checks.guide_tables``),
        not fixed samples of xi (``range_tables``)."""
        return frozenset(self.slot_joints)

    @property
    def linear_strain(self) -> bool:
        """The seed's linear strain (``effects.strain = "linear"``): its axis does not shorten as it
        bends (zeta is not coupled to eta), so the tangent (1 + zeta', eta') of its amplitudes is
        longer than the bar by about eta'^2 / 2 without a strain: the range check reads its own
        strain zeta' (``symgen.numerics.checks.bar_ranges``, the C runtime's symgen_bar_range_)."""
        return (self.structure.get("effects") or {}).get("strain") == "linear"

    @cached_property
    def inextensible_rows(self) -> tuple[int, ...]:
        """The inextensibility rows (effects.axial = "inextensible"), kept apart from the loop rows."""
        return self.rows(RowKind.INEXTENSIBLE)

    @cached_property
    def inextensible_axial(self) -> tuple[int, ...]:
        """The axial amplitudes of the bars with inextensibility rows: the dependent coordinates
        of those rows."""
        bars = {self.lam_rows[i].joint for i in self.inextensible_rows}
        return tuple(i for i, c in enumerate(self.coords) if c.kind is CoordKind.F and c.body in bars)

    def with_timings(self, **timings: float) -> ModelInfo:
        """The same record with ``timings`` added (e.g. ``build_s`` once the Functions are built)."""
        return replace(self, timings={**self.timings, **timings})

    # ------------------------------------------------------------------ from the model, to / from JSON
    @classmethod
    def of(cls, model: DerivedModel) -> ModelInfo:
        """The description of a ``DerivedModel`` (its records, names and the bars' functions)."""
        return cls(
            key=model.key,
            structure=model.structure,
            coords=tuple(model.coords),
            lam_rows=tuple(model.lam_rows),
            params=tuple(model.param_names),
            outputs=tuple(model.output_names),
            driver_row=model.driver_row,
            n_loop_rows=len(model.program.outputs["closure"]),
            modes={
                name: BarModes(
                    len(b.sym.f),
                    len(b.sym.g),
                    b.basis_a.family if len(b.sym.f) else "",
                    b.basis_t.family if len(b.sym.g) else "",
                )
                for name, b in model.bars.items()
            },
            timings=dict(model.timings),
        )

    def to_json(self) -> dict[str, Any]:
        """The plain data of ``model.json``."""
        return {
            "key": self.key,
            "structure": self.structure,
            "coords": [
                {"name": c.name, "kind": c.kind.value, "body": c.body, "index": c.index, "joint": c.joint}
                for c in self.coords
            ],
            "lam_rows": [{"joint": r.joint, "kind": r.kind.value, "loop": list(r.loop)} for r in self.lam_rows],
            "params": list(self.params),
            "outputs": list(self.outputs),
            "driver_row": self.driver_row,
            "n_loop_rows": self.n_loop_rows,
            "modes": {name: md.to_json() for name, md in self.modes.items()},
            "timings": dict(self.timings),
        }

    @classmethod
    def from_json(cls, data: object) -> ModelInfo:
        """The record of ``model.json``'s data; :class:`InvalidModelInfo` if any field is missing,
        of the wrong type, or inconsistent (a coordinate whose name is not its fields' name, a
        row index out of range, repeated names)."""
        d = record_fields(
            data,
            "the model description",
            (
                "key",
                "structure",
                "coords",
                "lam_rows",
                "params",
                "outputs",
                "driver_row",
                "n_loop_rows",
                "modes",
                "timings",
            ),
        )
        key = _text(d["key"], "key")
        if not isinstance(d["structure"], dict):
            raise InvalidModelInfo("'structure' is not an object")
        coords = tuple(_coordinate(c, k) for k, c in enumerate(_list(d["coords"], "coords")))
        lam_rows = tuple(_row(r, k) for k, r in enumerate(_list(d["lam_rows"], "lam_rows")))
        params, outputs = (_names(d[name], name) for name in ("params", "outputs"))
        n_loop = d["n_loop_rows"]
        if not _is_int(n_loop) or not 0 <= n_loop <= len(lam_rows):
            raise InvalidModelInfo("'n_loop_rows' is not a row count")
        drv = d["driver_row"]
        first = next((i for i, r in enumerate(lam_rows) if r.kind is RowKind.DRIVER), None)
        if drv is not None and (
            not _is_int(drv) or not 0 <= drv < len(lam_rows) or lam_rows[drv].kind is not RowKind.DRIVER
        ):
            raise InvalidModelInfo("'driver_row' is not the index of the driver's row")
        if drv != first:
            raise InvalidModelInfo("'driver_row' is not the index of the first driver's row")
        if not isinstance(d["modes"], dict):
            raise InvalidModelInfo("'modes' is not an object")
        modes = {_text(name, "modes"): _bar_modes(md, name) for name, md in d["modes"].items()}
        timings = d["timings"]
        if not isinstance(timings, dict) or not all(isinstance(k, str) and _is_number(x) for k, x in timings.items()):
            raise InvalidModelInfo("'timings' is not an object of numbers")
        if "derive_s" not in timings:
            raise InvalidModelInfo("'timings.derive_s' is not a number")
        return cls(
            key=key,
            structure=d["structure"],
            coords=coords,
            lam_rows=lam_rows,
            params=params,
            outputs=outputs,
            driver_row=drv,
            n_loop_rows=n_loop,
            modes=modes,
            timings=dict(timings),
        )


# ---------------------------------------------------------------------- checks of from_json
def _is_int(x: object) -> TypeGuard[int]:
    return isinstance(x, int) and not isinstance(x, bool)


def _is_number(x: object) -> TypeGuard[float]:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _text(x: object, what: str) -> str:
    if not isinstance(x, str):
        raise InvalidModelInfo(f"{what!r} is not a text")
    return x


def _list(x: object, what: str) -> list[Any]:
    if not isinstance(x, list):
        raise InvalidModelInfo(f"{what!r} is not a list")
    return x


def record_fields(
    x: object, what: str, keys: tuple[str, ...], error: type[ValueError] = InvalidModelInfo
) -> dict[str, Any]:
    """``x`` as the JSON object of a record with exactly the fields ``keys``; ``error`` (the
    record's own exception) naming ``what`` when it is not an object, lacks a field or has one
    more. Every record's ``from_json`` starts here."""
    if not isinstance(x, dict):
        raise error(f"{what} is not an object")
    missing = [k for k in keys if k not in x]
    if missing:
        raise error(f"{what} has no {missing[0]!r}")
    extra = sorted(set(x) - set(keys))
    if extra:
        raise error(f"{what} has an unknown field {extra[0]!r}")
    return x


def _names(x: object, what: str) -> tuple[str, ...]:
    items = _list(x, what)
    if not all(isinstance(s, str) for s in items) or len(set(items)) != len(items):
        raise InvalidModelInfo(f"{what!r} are not distinct names")
    return tuple(items)


def _coordinate(x: object, k: int) -> Coordinate:
    what = f"coords[{k}]"
    d = record_fields(x, what, ("name", "kind", "body", "index", "joint"))
    name, kind, body, index, joint = (d[f] for f in ("name", "kind", "body", "index", "joint"))
    for f, text in (("name", name), ("body", body), ("joint", joint)):
        _text(text, f"{what}.{f}")
    if not _is_int(index) or index < 0:
        raise InvalidModelInfo(f"{what}.index is not an amplitude index")
    try:
        c = Coordinate(name, CoordKind(kind), body, index, joint)
    except ValueError:
        raise InvalidModelInfo(
            f"{what}.kind {kind!r:.40} is not one of {', '.join(k.value for k in CoordKind)}"
        ) from None
    if names.coordinate(c.kind, c.body, c.joint, c.index).text != c.name:
        raise InvalidModelInfo(f"{what} is named {c.name!r:.60}, not after its kind, bar, joint and index")
    return c


def _row(x: object, k: int) -> ConstraintRow:
    what = f"lam_rows[{k}]"
    d = record_fields(x, what, ("joint", "kind", "loop"))
    joint, kind, loop = (d[f] for f in ("joint", "kind", "loop"))
    _text(joint, f"{what}.joint")
    if not all(isinstance(b, str) for b in _list(loop, f"{what}.loop")):
        raise InvalidModelInfo(f"{what}.loop is not a list of bars")
    try:
        return ConstraintRow(joint, RowKind(kind), tuple(loop))
    except ValueError:
        raise InvalidModelInfo(
            f"{what}.kind {kind!r:.40} is not one of {', '.join(k.value for k in RowKind)}"
        ) from None


def _bar_modes(x: object, bar: str) -> BarModes:
    what = f"modes.{bar}"
    d = record_fields(x, what, ("axial", "transverse", "axial_shapes", "transverse_shapes"))
    for f in ("axial", "transverse"):
        if not _is_int(d[f]) or d[f] < 0:
            raise InvalidModelInfo(f"{what}.{f} is not a count")
    for f in ("axial_shapes", "transverse_shapes"):
        _text(d[f], f"{what}.{f}")
    return BarModes(d["axial"], d["transverse"], d["axial_shapes"], d["transverse_shapes"])
