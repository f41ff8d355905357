"""Units of the results: SI columns for SI scenes, the model's dimensionless units otherwise.

The model runs in the dimensionless units of the seed (lengths / l0 or / the bar's length,
time tau = omega t, forces / (m_ref l0^2 omega^2), moments / (m_ref l0^3 omega^2)). A scene written
in SI gets its results back in SI unless ``--units dimensionless`` is asked: every column is the
dimensionless value times one factor, stated per column in the JSON sidecar (``units``), so
that either form can be recovered from the other.

=====================  ===========================  =======================  ======
output kind            dimensionless value          SI factor                SI unit
=====================  ===========================  =======================  ======
time column            tau = omega t                1 / omega                s
deflection, axial,     per length of the bar l_i    l_i = alpha_i l0         m
chord_deflection
chord_elongation       (|c| - l_i) / l_i            l_i                      m
elastic_displacement,  per l0                       l0                       m
position
slope, angle           rad                          1                        rad
reaction               per m_ref l0^2 omega^2       m_ref l0^2 omega^2       N
driver_torque          per m_ref l0^3 omega^2       m_ref l0^3 omega^2       N m
energy                 per m_ref l0^3 omega^2       m_ref l0^3 omega^2       J
closure_residual       per l0 (a solver check)      1                        1
=====================  ===========================  =======================  ======

>>> from symgen.scene import load_scene                                    # doctest: +SKIP
>>> cols = result_units(load_scene("examples/four_bar.toml"), "SI")       # doctest: +SKIP
>>> cols.time.unit, cols.time.factor                                       # doctest: +SKIP
('s', 0.004347826086956522)
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.errors import SceneError
from symgen.scene.units import OUTPUT_SCALE, output_factor

if TYPE_CHECKING:
    from symgen.scene.model import Scene

UNIT_SYSTEMS = ("SI", "dimensionless")

#: the scale of every output kind's factor (its formula: symgen.scene.units.output_factor)
_KIND_SCALE = OUTPUT_SCALE
_SI_UNIT = {"bar": "m", "l0": "m", "one": "rad", "force": "N", "moment": "N m", "energy": "J", "check": "1"}
_DIMENSIONLESS_UNIT = {
    "bar": "l_i (bar length)",
    "l0": "l0",
    "one": "rad",
    "force": "m_ref l0^2 omega^2",
    "moment": "m_ref l0^3 omega^2",
    "energy": "m_ref l0^3 omega^2",
    "check": "l0 (solver check)",
}


@dataclass(frozen=True)
class ColumnUnit:
    """One results column: its name, unit and the factor from the model's dimensionless value."""

    name: str
    unit: str
    factor: float

    def as_dict(self) -> dict[str, str | float]:
        return {"unit": self.unit, "factor": self.factor}


@dataclass(frozen=True)
class ResultUnits:
    """Units of the time column and of every output column of one scene's results."""

    system: str  # "SI" | "dimensionless"
    time: ColumnUnit
    outputs: tuple[ColumnUnit, ...]

    def convert(self, tau: np.ndarray, values: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(time column, output columns) in these units from the model's dimensionless ones."""
        values = np.asarray(values, dtype=float).reshape(len(tau), -1)
        factors = np.array([c.factor for c in self.outputs], dtype=float)
        return np.asarray(tau, dtype=float) * self.time.factor, values * factors

    def convert_rows(self, rows: Iterable[list[float]]) -> Iterator[list[float]]:
        """:meth:`convert` of rows [tau, outputs..., more...] (floats, without numpy): the time and
        the outputs times their factors (the same products, to the bit), the columns after the
        outputs (a run's coordinates) as they are."""
        factors = [self.time.factor, *(c.factor for c in self.outputs)]
        k = len(factors)
        if all(f == 1.0 for f in factors):  # x * 1.0 is x
            return iter(rows)
        return ([x * f for x, f in zip(row, factors)] + row[k:] for row in rows)

    def as_dict(self) -> dict[str, object]:
        return {
            "system": self.system,
            "time": {"name": self.time.name, **self.time.as_dict()},
            "columns": {c.name: c.as_dict() for c in self.outputs},
        }


def choose_system(scene: Scene, requested: str | None) -> str:
    """The unit system of a run's results: SI for SI scenes unless ``dimensionless`` is asked."""
    if requested is None:
        return "SI" if scene.units == "SI" else "dimensionless"
    if requested not in UNIT_SYSTEMS:
        raise SceneError(
            "command line", "--units", f"unknown unit system {requested!r}", f"use one of {', '.join(UNIT_SYSTEMS)}"
        )
    if requested == "SI" and scene.units != "SI":
        raise SceneError(
            str(scene.path),
            "scene.units",
            'SI results need an SI scene (units = "SI" with omega and SI data)',
            "drop --units SI: a dimensionless scene has no scales to convert with",
        )
    return requested


def result_units(scene: Scene, system: str | None = None) -> ResultUnits:
    """Units and factors of the results of ``scene`` (``system`` from :func:`choose_system`)."""
    system = choose_system(scene, system)
    si = system == "SI"
    l0, omega, m_ref = scene.l0, scene.omega, scene.m_ref
    cols = []
    for o in scene.outputs:
        kind_scale = _KIND_SCALE[o.kind]
        if not si:
            cols.append(ColumnUnit(o.name, _DIMENSIONLESS_UNIT[kind_scale], 1.0))
            continue
        length = None
        if kind_scale == "bar":
            assert o.body is not None  # a bar's output names its bar (the scene loader checks it)
            length = scene.body(o.body).alpha * l0
        factor = output_factor(o.kind, l0, omega, m_ref, length)
        cols.append(ColumnUnit(o.name, _SI_UNIT[kind_scale], float(factor)))
    time = ColumnUnit("t", "s", 1.0 / omega) if si else ColumnUnit("tau", "1 (tau = omega t)", 1.0)
    return ResultUnits(system, time, tuple(cols))
