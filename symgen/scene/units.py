"""Scaling of scene quantities to the dimensionless units of :mod:`symgen.scene.model`.

SI input (``units = "SI"``) is divided by the reference scales; dimensionless input is
already in model units except for lengths/positions, which are divided by ``l0`` in both cases.

Examples
--------
>>> s = Scales(si=True, l0=0.5, omega=10.0, m_ref=2.0)
>>> s.gravity(9.81)   # g / (l0 omega^2)
0.1962
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


def axial_group(modulus: Any, area: Any, mass: Any, length: Any, omega: Any) -> Any:
    """lambda = E A / (m l^2 omega^2) of an SI bar (numbers, or SymPy symbols for the emitted
    C's conversion of physical parameters: one formula, symgen.ir.physical)."""
    return modulus * area / (mass * length**2 * omega**2)


def bending_group(modulus: Any, inertia: Any, mass: Any, length: Any, omega: Any) -> Any:
    """mu = E I / (m l^4 omega^2) of an SI bar (numbers or SymPy symbols, as axial_group)."""
    return modulus * inertia / (mass * length**4 * omega**2)


@dataclass(frozen=True)
class Scales:
    """Reference scales of one scene. The methods are formulas: they take numbers, or SymPy
    symbols (``symgen.ir.physical`` builds the emitted C's conversion from them).

    Parameters
    ----------
    si : True when the file is in SI units
    l0 : reference length (m for SI, else the dimensionless value used)
    omega : rad/s for SI, 1.0 otherwise
    m_ref : mass per length of the reference bar (kg/m for SI, else that bar's relative value)
    """

    si: bool
    l0: float
    omega: float
    m_ref: float

    def length(self, x: float) -> float:
        """A length or position: x / l0 (both unit systems)."""
        return x / self.l0

    def time(self, t: float) -> float:
        """A simulation time. The contract gives [simulation] times in tau = omega t in
        both unit systems (``t_end = ...  # in tau``), so nothing to convert."""
        return t

    def rate(self, r: float) -> float:
        """A driver rate or deformation rate: per tau in both unit systems (the contract's
        ``theta = initial + rate * tau``; in SI the crank turns at rate * omega rad/s)."""
        return r

    def joint_mass(self, m: float) -> float:
        """A lumped mass: SI kg -> m / (m_ref l0)."""
        return m / (self.m_ref * self.l0) if self.si else m

    def rotary_inertia(self, j: float) -> float:
        """A rotary inertia (driver rotor, lumped at a joint): SI kg m^2 -> J / (m_ref l0^3)."""
        return j / (self.m_ref * self.l0**3) if self.si else j

    def gravity(self, g: float) -> float:
        """A gravity component: SI m/s^2 -> g / (l0 omega^2)."""
        return g / (self.l0 * self.omega**2) if self.si else g

    def torque_unit(self) -> float:
        """The SI value of one model unit of moment: m_ref l0^3 omega^2 (N m); 1 when dimensionless."""
        return self.m_ref * self.l0**3 * self.omega**2 if self.si else 1.0

    def distributed_unit(self, m_i: float, l_i: float) -> float:
        """The SI value of one model unit of distributed load on bar i: m_i l_i omega^2 (N/m)."""
        return m_i * l_i * self.omega**2 if self.si else 1.0

    def point_unit(self, m_i: float, l_i: float) -> float:
        """The SI value of one model unit of point load on bar i: m_i l_i^2 omega^2 (N)."""
        return m_i * l_i**2 * self.omega**2 if self.si else 1.0

    def torque(self, torque: float) -> float:
        """A moment: SI N m -> M / (m_ref l0^3 omega^2)."""
        return torque / self.torque_unit() if self.si else torque

    def distributed(self, q: float, m_i: float, l_i: float) -> float:
        """A distributed load on bar i: SI N/m -> q / (m_i l_i omega^2)."""
        return q / self.distributed_unit(m_i, l_i) if self.si else q

    def point(self, force: float, m_i: float, l_i: float) -> float:
        """A point load on bar i: SI N -> F / (m_i l_i^2 omega^2)."""
        return force / self.point_unit(m_i, l_i) if self.si else force

    def seconds(self, tau: float) -> float:
        """A model time tau as shown to the user: t = tau / omega seconds in SI, else tau."""
        return tau / self.omega if self.si else tau

    def time_text(self, tau: float) -> str:
        """``"t = 0.1 s"`` (SI) or ``"tau = 23"`` (dimensionless) for messages."""
        return f"t = {tau / self.omega:.6g} s" if self.si else f"tau = {tau:.6g}"


#: The scale of each output kind's SI factor (symgen.numerics.units: the results' columns)
OUTPUT_SCALE = {
    "deflection": "bar",
    "axial": "bar",
    "chord_deflection": "bar",
    "chord_elongation": "bar",
    "elastic_displacement": "l0",
    "position": "l0",
    "slope": "one",
    "angle": "one",
    "reaction": "force",
    "driver_torque": "moment",
    "energy": "energy",
    "closure_residual": "check",
}


def output_factor(kind: str, l0: Any, omega: Any, m_ref: Any, bar_length: Any = None) -> Any:
    """The SI value of one model unit of an output of ``kind`` (numbers or SymPy symbols):
    ``bar_length`` (m) for a bar's deflection or stretch, l0 for positions, m_ref l0^2 omega^2
    for a force, m_ref l0^3 omega^2 for a moment or an energy, 1 for angles and the closure check."""
    scale = OUTPUT_SCALE[kind]
    if scale == "bar":
        if bar_length is None:
            raise ValueError(f"a {kind} output needs its bar's length")
        return bar_length
    return {
        "l0": l0,
        "one": 1.0,
        "force": m_ref * l0**2 * omega**2,
        "moment": m_ref * l0**3 * omega**2,
        "energy": m_ref * l0**3 * omega**2,
        "check": 1.0,
    }[scale]
