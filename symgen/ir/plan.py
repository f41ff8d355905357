"""How a run of a scene starts, as data: the typed record the numerics make
(``symgen.numerics.start.start_plan``) and the C backend bakes into the emitted solver, so that
both start the same way and the backend never calls the numerics.

Indices are positions in q (coordinates) or in lam (multiplier rows) of the model's
:class:`~symgen.ir.info.ModelInfo`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields


@dataclass(frozen=True)
class AmplitudeGroup:
    """The deformation amplitudes of one bar (the range checks sum them per bar)."""

    body: str
    axial: tuple[int, ...]
    transverse: tuple[int, ...]


@dataclass(frozen=True)
class StartPlan:
    """The partition of the coordinates, the assembly and quasi-static start, and the index sets
    of the run checks."""

    independent: tuple[int, ...]  # the partition at the assembled start: differential coordinates
    dependent: tuple[int, ...]  # ... the dependent rigid ones (one per multiplier row) ...
    assembly_dependent: tuple[int, ...]  # the dependent coordinates of the assembly Newton at the guess
    q_guess: tuple[float, ...]  # the raw guess the assembly starts from (initial.guess, deformation, driver)
    v_guess: tuple[float, ...]
    elastic: tuple[int, ...]  # amplitudes not dependent (quasi-static ones too): the quasi-static start's unknowns
    accel: tuple[int, ...]  # rigid and dependent coordinates: its unknown accelerations
    inextensible_rows: tuple[int, ...]  # inextensibility rows (left out of the singular-position check)
    inextensible_axial: tuple[int, ...]  # their axial amplitudes
    singular_rows: tuple[int, ...]  # rows of the closure Jacobian that decide a singular position
    singular_cols: tuple[int, ...]  # ... and its columns (the dependent rigid coordinates)
    amplitudes: tuple[AmplitudeGroup, ...]
    # the joint forces of an unstressed start as a continuum gives them (the first output of a
    # run: symgen.numerics.start.continuum_start_outputs): the parameters scaled towards 0 (the
    # elastic bars' masses) and the outputs replaced (driver torques, reactions); both empty
    # where the run records the model's own
    free_inertia: tuple[int, ...] = ()
    start_forces: tuple[int, ...] = ()
    # ... and the quasi-static amplitudes (``Mechanism.quasi``; algebraic, as in the Python
    # path's ``symgen.numerics.index1.Partition.quasi``): the run's partition is
    # independent | dependent | quasi; the start (assembly, quasi-static start, consistent
    # state) is the full model's, every amplitude dynamic
    quasi: tuple[int, ...] = ()
    # the quasi-static start's axial amplitudes whose rates and accelerations it takes along the
    # held motion of the bending amplitudes ``moving`` (``start.following_axial``): both empty
    # where there is none of either
    follow: tuple[int, ...] = ()
    moving: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        n = len(self.q_guess)
        for what, idx in (
            ("free_inertia", self.free_inertia),
            ("start_forces", self.start_forces),
            ("quasi", self.quasi),
            ("follow", self.follow),
            ("moving", self.moving),
        ):
            if len(set(idx)) != len(idx) or any(i < 0 for i in idx):
                raise ValueError(f"a start plan whose {what} {idx} are not distinct indices")
        if bool(self.free_inertia) != bool(self.start_forces):
            raise ValueError(
                f"a start plan with free_inertia {self.free_inertia} and start_forces {self.start_forces}: "
                "both or neither"
            )
        ind, dep, quasi = set(self.independent), set(self.dependent), set(self.quasi)
        if (
            len(self.v_guess) != n
            or ind & dep
            or quasi & (ind | dep)
            or ind | dep | quasi != set(range(n))
            or len(ind) != len(self.independent)
            or len(dep) != len(self.dependent)
        ):
            raise ValueError(
                f"a start plan whose partition {self.independent} | {self.dependent} | {self.quasi} "
                f"does not split the {n} coordinates"
            )
        if len(self.assembly_dependent) != len(self.dependent):
            raise ValueError("the assembly and the run have different numbers of dependent coordinates")

    @property
    def n(self) -> int:
        return len(self.q_guess)

    def to_json(self) -> dict[str, object]:
        """The plan as JSON data (:meth:`from_json` reads it back)."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self)}

    @classmethod
    def from_json(cls, data: object) -> StartPlan:
        """The plan of :meth:`to_json`'s data; ValueError if a field is missing, extra, of the
        wrong type, or the plan is inconsistent (``__post_init__``)."""
        from symgen.ir.info import record_fields

        d = record_fields(data, "the start plan", tuple(f.name for f in fields(cls)), ValueError)
        ints = {f.name: _ints(d[f.name], f.name) for f in fields(cls) if f.name not in _NOT_INDICES}
        floats = {k: _floats(d[k], k) for k in ("q_guess", "v_guess")}
        groups = []
        for k, g in enumerate(d["amplitudes"] if isinstance(d["amplitudes"], list) else [None]):
            g = record_fields(g, f"amplitudes[{k}]", ("body", "axial", "transverse"), ValueError)
            if not isinstance(g["body"], str):
                raise ValueError(f"amplitudes[{k}].body is not a name")
            groups.append(AmplitudeGroup(g["body"], _ints(g["axial"], "axial"), _ints(g["transverse"], "transverse")))
        return cls(**ints, **floats, amplitudes=tuple(groups))  # type: ignore[arg-type]


_NOT_INDICES = ("q_guess", "v_guess", "amplitudes")


def _plain(x: object) -> object:
    if isinstance(x, AmplitudeGroup):
        return {"body": x.body, "axial": list(x.axial), "transverse": list(x.transverse)}
    if isinstance(x, tuple):
        return [_plain(e) for e in x]
    return x


def _ints(x: object, what: str) -> tuple[int, ...]:
    if not isinstance(x, list) or not all(isinstance(e, int) and not isinstance(e, bool) and e >= 0 for e in x):
        raise ValueError(f"the start plan's {what} is not a list of indices")
    return tuple(x)


def _floats(x: object, what: str) -> tuple[float, ...]:
    if not isinstance(x, list) or not all(isinstance(e, float) and math.isfinite(e) for e in x):
        raise ValueError(f"the start plan's {what} is not a list of finite numbers")
    return tuple(x)
