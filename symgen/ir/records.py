"""The typed records of a derived model: the one contract between the derivation
(``symgen.model``) and every consumer (CasADi, C, LaTeX, the runners).

A coordinate, a multiplier row or a program intermediate is identified by its fields (kind,
body, joint, index), never by parsing its symbol's name; names and LaTeX names are made in
``symgen.ir.names`` from these same fields.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any

from symgen.ir.names import Name

if TYPE_CHECKING:  # a cached run reads these records without SymPy (tests/test_lean_start.py)
    import sympy as sp


@dataclass(frozen=True)
class BlockCall:
    """One bar of a :class:`Block`: the program symbols ``assigns`` are the block's outputs with
    the block's input symbols replaced by ``inputs`` (the same order)."""

    bar: str
    inputs: tuple[sp.Symbol, ...]
    assigns: tuple[sp.Symbol, ...]


@dataclass(frozen=True)
class Block:
    """The generalized forces E of the bars of one structure (``bars.SharedBarEquations``): the
    expressions ``outputs`` of the first bar's symbols ``inputs``, which every bar of ``calls``
    assigns with its own symbols. The assignments hold each bar's E as well (what the LaTeX and C
    backends write); a backend may make the block one function called per bar instead."""

    bar: str  # the bar whose equations the others share (its symbols are ``inputs``)
    inputs: tuple[sp.Symbol, ...]
    outputs: tuple[sp.Expr, ...]  # E: X, Y, theta, the f_k, the g_k
    calls: tuple[BlockCall, ...]


@dataclass
class Program:
    """Ordered assignments (intermediate symbol = expression of earlier symbols) and named output
    vectors over the inputs t, q, v, a, lam, p. Each intermediate belongs to a ``group``
    ("origin acceleration", "generalized force", "subtree force"), which the LaTeX backend
    reads to place it. ``blocks``: the generalized forces of bars that share their structure's
    equations, as a template and its calls (:class:`Block`); beside the assignments, not instead."""

    inputs: dict[str, tuple[sp.Symbol, ...]]  # name -> its symbols
    assignments: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)  # [(symbol, expr)]
    outputs: dict[str, list[sp.Expr]] = field(default_factory=dict)  # name -> its exprs
    groups: dict[sp.Symbol, str] = field(default_factory=dict)  # symbol -> its group
    blocks: list[Block] = field(default_factory=list)  # bar structures of 2+ bars (E as calls)

    def assign(self, name: Name, expr: sp.Expr, group: str) -> sp.Symbol:
        import sympy as sp

        sym = name.symbol()
        self.assignments.append((sym, sp.sympify(expr)))
        self.groups[sym] = group
        return sym

    def add(self, sym: sp.Symbol, expr: sp.Expr, group: str) -> None:
        """An assignment to a symbol made elsewhere (a bar's [x_A'']_i of (10))."""
        self.assignments.append((sym, expr))
        self.groups[sym] = group

    def group(self, group: str) -> list[tuple[sp.Symbol, sp.Expr]]:
        """[(symbol, expr)] of the assignments of ``group``, in order."""
        return [(sym, e) for sym, e in self.assignments if self.groups.get(sym) == group]


ORIGIN_ACCELERATION, GENERALIZED_FORCE, SUBTREE_FORCE = "origin acceleration", "generalized force", "subtree force"


class CoordKind(StrEnum):
    """What a coordinate is: a bar angle, a slider travel, an axial or transverse amplitude, a
    slot's support distance. The values are the texts of ``model.json``."""

    THETA = "theta"
    S = "s"
    F = "f"
    G = "g"
    BETA = "beta"

    @property
    def elastic(self) -> bool:
        """An amplitude of a bar's deformation (f, g); the others are rigid coordinates."""
        return self in (CoordKind.F, CoordKind.G)


class RowKind(StrEnum):
    """What a multiplier row (a row of phi) closes: a cut pin's or slot's x / y, a slider, the
    angle driver, a bar's inextensibility."""

    PIN_X = "pin-x"
    PIN_Y = "pin-y"
    SLOT_X = "slot-x"
    SLOT_Y = "slot-y"
    SLIDER = "slider"
    DRIVER = "driver"
    INEXTENSIBLE = "inextensible"


@dataclass(frozen=True)
class Coordinate:
    """One entry of q: a bar angle (THETA), an axial (F) or transverse (G) amplitude of
    ``body``, a slider travel (S) or a slot's support distance (BETA) of ``joint``."""

    name: str
    kind: CoordKind  # a text ("theta", ...) is taken as its CoordKind; any other raises ValueError
    body: str  # the bar it moves (the bar beyond a slider, the guide of a slot)
    index: int = 0  # amplitude index (0-based) for f, g
    joint: str = ""  # the slider or slot joint of S and BETA

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", CoordKind(self.kind))

    @property
    def elastic(self) -> bool:
        return self.kind.elastic


def find_coordinate(coords: Iterable[Coordinate], kind: CoordKind, body: str) -> int:
    """Index in ``coords`` (Coordinate records) of the coordinate ``kind`` of ``body``."""
    for i, c in enumerate(coords):
        if c.kind == kind and c.body == body:
            return i
    raise KeyError(f"no coordinate {kind!s} of {body!r}")


@dataclass(frozen=True)
class ConstraintRow:
    joint: str  # cut joint, "driver", or the bar of an INEXTENSIBLE row
    kind: RowKind  # a text ("pin-x", ...) is taken as its RowKind; any other raises ValueError
    loop: tuple[str, ...]  # bars around the loop (the bar itself for INEXTENSIBLE)

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", RowKind(self.kind))
        object.__setattr__(self, "loop", tuple(self.loop))


@dataclass
class DerivedModel:
    key: str
    scene_name: str
    structure: dict[str, Any]  # the ModelSpec's canonical JSON (symgen.ir.spec)
    topology: Any  # symgen.model.topology.Topology (a higher layer: not importable here)
    bars: dict[str, Any]  # body -> symgen.model.derive.BarModel (likewise)
    coords: list[Coordinate]  # Coordinate per q entry
    q: tuple[sp.Symbol, ...]
    v: tuple[sp.Symbol, ...]
    a: tuple[sp.Symbol, ...]
    lam: tuple[sp.Symbol, ...]
    lam_rows: list[ConstraintRow]  # ConstraintRow per lam entry
    params: tuple[sp.Symbol, ...]  # parameter symbols
    program: Program
    output_names: list[str]
    driver_row: int | None  # index of the first angle driver in lam, if any (ConstraintRow DRIVER: all)
    timings: dict[str, float]
    latex: dict[str, str] = field(default_factory=dict)  # symbol name -> LaTeX name (symgen.ir.names)

    @property
    def param_names(self) -> list[str]:
        return [str(p) for p in self.params]
