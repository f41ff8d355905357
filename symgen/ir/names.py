"""The one home of the derived model's symbol names.

Every symbol of a model is named here, from typed fields: what it is (a bar angle, an
amplitude, a multiplier, a parameter...), the bar or joint it belongs to, its index and its
time-derivative order. Each constructor returns a :class:`Name`: the text the symbol carries
(SymPy, CasADi, the C identifiers' stem) and, beside it, its LaTeX name. The derivation makes
its symbols through these constructors inside :func:`recording`, which collects the LaTeX names
into the model's table; the LaTeX backend prints from that table. No module builds these texts
from strings of its own, and none parses them back to recover what a symbol is: consumers read
the typed records (``symgen.ir.records``) instead. ``tests/test_names.py`` holds both rules.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names are texts; only the derivation makes symbols (a cached run has no SymPy)
    import sympy as sp

#: derivative order -> text prefix and LaTeX accent
_PREFIX = ("", "d", "dd")
_DOTS = ("", r"\dot ", r"\ddot ")


def upright(name: str) -> str:
    """An identifier as upright math text (underscores escaped)."""
    return r"\mathrm{" + name.replace("_", r"\_") + "}"


@dataclass(frozen=True)
class Name:
    """A model symbol's name and its LaTeX name."""

    text: str
    latex: str

    def symbol(self, **assumptions: bool) -> sp.Symbol:
        """The SymPy symbol (``real=True`` unless other assumptions are given); recorded in the
        active :func:`recording` table."""
        import sympy as sp

        sym = sp.Symbol(self.text, **(assumptions or {"real": True}))
        table = _TABLE.get()
        if table is not None:
            table[self.text] = self.latex
        return sym


_TABLE: contextvars.ContextVar[dict[str, str] | None] = contextvars.ContextVar("symgen_names", default=None)

#: symbols every model shares
TAU = Name("tau", r"\tau")
XI = Name("xi", r"\xi")


@contextlib.contextmanager
def recording() -> Iterator[dict[str, str]]:
    """Collect {text: LaTeX} of every :meth:`Name.symbol` made inside the block."""
    table = {TAU.text: TAU.latex, XI.text: XI.latex}
    token = _TABLE.set(table)
    try:
        yield table
    finally:
        _TABLE.reset(token)


# --------------------------------------------------------------------------- coordinates
def bar_angle(bar: str, order: int = 0) -> Name:
    """theta of a bar (``order`` 1, 2: its rates)."""
    return Name(f"{_PREFIX[order]}theta_{bar}", rf"{_DOTS[order]}\theta_{{{upright(bar)}}}")


def amplitude(family: str, bar: str, k: int, order: int = 0) -> Name:
    """Amplitude ``k`` (0-based) of a bar's axial (``family`` "f") or transverse ("g") functions."""
    if family not in ("f", "g"):
        raise ValueError(f"amplitude family {family!r}: 'f' (axial) or 'g' (transverse)")
    return Name(f"{_PREFIX[order]}{family}_{bar}_{k + 1}", rf"{_DOTS[order]}{family}_{{{upright(bar)},{k + 1}}}")


def slider_travel(joint: str, order: int = 0) -> Name:
    """s of a slider on a ground line: the travel of its point along the line."""
    return Name(f"{_PREFIX[order]}s_{joint}", rf"{_DOTS[order]}s_{{{upright(joint)}}}")


def slot_support(joint: str, order: int = 0) -> Name:
    """beta of a slot: the guide's support distance (the variable span)."""
    return Name(f"{_PREFIX[order]}beta_{joint}", rf"{_DOTS[order]}\beta_{{{upright(joint)}}}")


def coordinate(kind: str, body: str, joint: str = "", index: int = 0, order: int = 0) -> Name:
    """The name of a coordinate record (``symgen.ir.records.Coordinate``) and of its rates."""
    if kind == "theta":
        return bar_angle(body, order)
    if kind in ("f", "g"):
        return amplitude(kind, body, index, order)
    if kind == "s":
        return slider_travel(joint, order)
    if kind == "beta":
        return slot_support(joint, order)
    raise ValueError(f"unknown coordinate kind {kind!r}")


# --------------------------------------------------------------------------- bar quantities
def origin_acceleration(axis: str, bar: str) -> Name:
    """[x_A'']_i, [y_A'']_i of (10): the bar origin's acceleration in its own axes / alpha."""
    return Name(f"{axis}Add_{bar}", rf"[\ddot {axis}_A]_{{{upright(bar)}}}")


def origin_velocity(axis: str, bar: str) -> Name:
    """[x_A']_i, [y_A']_i: the bar origin's velocity in its own axes / alpha (kinetic energy)."""
    return Name(f"{axis}Ad_{bar}", rf"[\dot {axis}_A]_{{{upright(bar)}}}")


_BAR_PARAMETERS = {"alpha": r"\alpha", "nu": r"\nu", "lambda": r"\lambda", "mu": r"\mu", "rho": r"\rho"}


def bar_parameter(kind: str, bar: str) -> Name:
    """alpha (length), nu (mass), lambda (axial), mu (bending), rho (rotary inertia) of a bar."""
    return Name(f"{kind}_{bar}", rf"{_BAR_PARAMETERS[kind]}_{{{upright(bar)}}}")


_FORCE_PARTS = {"X": "X", "Y": "Y", "th": r"\theta", "beta": r"\beta"}


def generalized_force(part: str, bar: str, k: int | None = None) -> Name:
    """E of a bar: its generalized forces along X, Y, theta, beta, or amplitude ``k`` of "f"/"g"."""
    if part in ("f", "g"):
        if k is None:
            raise ValueError(f"the generalized force of amplitude family {part!r} needs the amplitude's index")
        return Name(f"E{part}_{bar}_{k + 1}", rf"E_{{{part},{upright(bar)},{k + 1}}}")
    return Name(f"E{part}_{bar}", rf"E_{{{_FORCE_PARTS[part]},{upright(bar)}}}")


def subtree_force(axis: str, bar: str) -> Name:
    """S of a tree joint: the resultant of the bars beyond it (route 2 of the seed)."""
    return Name(f"S{axis.upper()}_{bar}", rf"S_{{{axis.upper()},{upright(bar)}}}")


def axial_force(bar: str, k: int) -> Name:
    """N_k of an inextensible or quasi-static bar: the multiplier of (phi'_k, eps) = 0."""
    return Name(f"N_{bar}_{k + 1}", rf"N_{{{upright(bar)},{k + 1}}}")


# --------------------------------------------------------------------------- multipliers
def joint_force(joint: str, axis: str | None = None) -> Name:
    """Lambda of a cut joint: x, y of a pin or slot, the normal force of a slider (``axis`` None)."""
    if axis is None:
        return Name(f"L_{joint}", rf"\Lambda_{{{upright(joint)}}}")
    return Name(f"L{axis}_{joint}", rf"\Lambda_{{{axis},{upright(joint)}}}")


DRIVER_FORCE = Name("L_driver", r"\Lambda_{\mathrm{drv}}")


def driver_force(index: int) -> Name:
    """Lambda of angle driver ``index`` (0-based, among all drivers): the first is ``L_driver``
    (the name of a single-driver scene), driver i > 0 is ``L_driver_<i+1>``."""
    if index == 0:
        return DRIVER_FORCE
    return Name(f"L_driver_{index + 1}", rf"\Lambda_{{\mathrm{{drv}},{index + 1}}}")


# --------------------------------------------------------------------------- parameters
def joint_parameter(kind: str, joint: str) -> Name:
    """px, py (ground point), dx, dy (slider direction), m (lumped mass), I (rotary inertia)."""
    if kind in ("px", "py", "dx", "dy"):
        return Name(f"{kind}_{joint}", rf"{kind[0]}_{{{kind[1]},{upright(joint)}}}")
    if kind in ("m", "I"):
        return Name(f"{kind}_{joint}", rf"{kind}_{{{upright(joint)}}}")
    raise ValueError(f"unknown joint parameter {kind!r}")


_MASS = {"m": "m", "I": "I", "along": r"d_{\parallel", "across": r"d_{\perp"}


def mass_parameter(kind: str, index: int) -> Name:
    """Of ``[[masses]]`` entry ``index`` (0-based): m (its mass), I (its rotary inertia), along,
    across (its offset from the bar's axis in the cross-section's axes)."""
    if kind not in _MASS:
        raise ValueError(f"unknown point-mass parameter {kind!r}")
    n = index + 1
    head = _MASS[kind]
    latex = rf"{head}_{{\mathrm{{M}}{n}}}" if kind in ("m", "I") else rf"{head},\mathrm{{M}}{n}}}"
    return Name(f"mass{n}_{kind}", latex)


_GLOBAL = {
    "gx": r"g_{x}",
    "gy": r"g_{y}",
    "theta0": r"\theta_{\mathrm{drv}}^{0}",
    "rate": r"\Omega_{\mathrm{drv}}",
    "ramp": r"T_{\mathrm{drv}}",
    "torque": r"M_{0}",
    "damping": r"c_{\mathrm{KV}}",
    "J_rotor": r"J_{\mathrm{rot}}",
}


def global_parameter(kind: str) -> Name:
    """gx, gy (gravity), theta0, rate, ramp (angle driver), torque, damping, J_rotor."""
    return Name(kind, _GLOBAL[kind])


DRIVER_PARAMETERS = ("theta0", "rate", "ramp", "torque", "J_rotor")


def driver_parameter(kind: str, index: int) -> Name:
    """theta0, rate, ramp, torque or J_rotor of driver ``index`` (0-based, in the scene's order):
    the first driver's are the global names of a single-driver scene, driver i > 0 has
    ``<kind>_<i+1>``."""
    if kind not in DRIVER_PARAMETERS:
        raise ValueError(f"unknown driver parameter {kind!r}")
    if index == 0:
        return global_parameter(kind)
    n = index + 1
    latex = {
        "theta0": rf"\theta_{{\mathrm{{drv}},{n}}}^{{0}}",
        "rate": rf"\Omega_{{\mathrm{{drv}},{n}}}",
        "ramp": rf"T_{{\mathrm{{drv}},{n}}}",
        "torque": rf"M_{{0,{n}}}",
        "J_rotor": rf"J_{{\mathrm{{rot}},{n}}}",
    }[kind]
    return Name(f"{kind}_{n}", latex)


def load_parameter(index: int, component: str, point: bool) -> Name:
    """Value of load ``index`` (0-based), ``component`` "axial" or "transverse"; a point load
    prints as B_P, Gamma_P, a distributed one as beta-bar, gamma-bar."""
    n = index + 1
    if component == "axial":
        latex = rf"B_{{\mathrm{{P}}{n}}}" if point else rf"\bar\beta_{{{n}}}"
    elif component == "transverse":
        latex = rf"\Gamma_{{\mathrm{{P}}{n}}}" if point else rf"\bar\gamma_{{{n}}}"
    else:
        raise ValueError(f"unknown load component {component!r}")
    return Name(f"load{n}_{component}", latex)
