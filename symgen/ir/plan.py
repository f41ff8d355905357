"""How a run of a scene starts, as data: the typed record the numerics make
(``symgen.numerics.start.start_plan``) and the C backend bakes into the emitted solver, so that
both start the same way and the backend never calls the numerics.

Indices are positions in q (coordinates) or in lam (multiplier rows) of the model's
:class:`~symgen.ir.info.ModelInfo`.
"""

from __future__ import annotations

from dataclasses import dataclass


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
    dependent: tuple[int, ...]  # ... and the dependent rigid ones (one per multiplier row)
    assembly_dependent: tuple[int, ...]  # the dependent coordinates of the assembly Newton at the guess
    q_guess: tuple[float, ...]  # the raw guess the assembly starts from (initial.guess, deformation, driver)
    v_guess: tuple[float, ...]
    elastic: tuple[int, ...]  # independent amplitudes: the unknowns of the quasi-static start
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

    def __post_init__(self) -> None:
        n = len(self.q_guess)
        for what, idx in (("free_inertia", self.free_inertia), ("start_forces", self.start_forces)):
            if len(set(idx)) != len(idx) or any(i < 0 for i in idx):
                raise ValueError(f"a start plan whose {what} {idx} are not distinct indices")
        if bool(self.free_inertia) != bool(self.start_forces):
            raise ValueError(
                f"a start plan with free_inertia {self.free_inertia} and start_forces {self.start_forces}: "
                "both or neither"
            )
        ind, dep = set(self.independent), set(self.dependent)
        if (
            len(self.v_guess) != n
            or ind & dep
            or ind | dep != set(range(n))
            or len(ind) != len(self.independent)
            or len(dep) != len(self.dependent)
        ):
            raise ValueError(
                f"a start plan whose partition {self.independent} | {self.dependent} does not split the {n} coordinates"
            )
        if len(self.assembly_dependent) != len(self.dependent):
            raise ValueError("the assembly and the run have different numbers of dependent coordinates")

    @property
    def n(self) -> int:
        return len(self.q_guess)
