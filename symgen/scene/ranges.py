"""Range checks of the dimensionless groups and scaled values a scene produces.

Each number of a file is finite and at most 1e30 in magnitude (the :class:`Reader` checks
that), but quotients of them can still overflow or vanish: ``length = 1e-300`` makes every
other bar's alpha = l / l0 about 1e300, an SI bar of ``E = 1e-30`` a lambda of 1e-40. Every
group must therefore lie in :data:`GROUP_RANGE`; when one does not, the error names the input
that most likely caused it (the one farthest from 1 in orders of magnitude) and lists the
others that enter the group.

Examples
--------
>>> culprit([("bodies.rod.length", 1e-300), ("scene.reference_length", 1.0)])
'bodies.rod.length'
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from symgen.scene.limits import GROUP_RANGE
from symgen.scene.model import Body, Driver, Effects, Joint, Load
from symgen.scene.reader import Reader, is_number, join

Inputs = Sequence[tuple[str, float]]

HINT = "check the units and the exponents of these inputs"


def culprit(inputs: Inputs) -> str:
    """The key of the input farthest from 1 in orders of magnitude."""

    def distance(item: tuple[str, float]) -> float:
        value = abs(item[1])
        return abs(math.log10(value)) if 0.0 < value < math.inf else math.inf

    return max(inputs, key=distance)[0]


def _listing(inputs: Inputs) -> str:
    return ", ".join(f"{key} = {value:g}" for key, value in inputs)


def check_group(r: Reader, what: str, value: float | None, inputs: Inputs) -> None:
    """A positive group (alpha, nu, lambda, mu, rho, l0, omega, m_ref) within GROUP_RANGE."""
    lo, hi = GROUP_RANGE
    if value is None or (math.isfinite(value) and lo <= abs(value) <= hi):
        return
    r.fail(
        culprit(inputs),
        f"gives {what} = {value:g}, outside [{lo:g}, {hi:g}] where the model can compute (from {_listing(inputs)})",
        HINT,
    )


def check_scaled(r: Reader, key: str, what: str, value: float, inputs: Inputs) -> None:
    """A scaled value (may be 0) of magnitude at most GROUP_RANGE[1]."""
    hi = GROUP_RANGE[1]
    if math.isfinite(value) and abs(value) <= hi:
        return
    r.fail(key, f"{what} is {value:g} in model units, beyond {hi:g} (from {_listing(inputs)})", HINT)


def _present(table: dict, path: str, keys: Iterable[str]) -> list[tuple[str, float]]:
    """(dotted key, value) of the numeric keys of ``table`` that are present."""
    return [(join(path, k), float(table[k])) for k in keys if is_number(table.get(k))]


def reference_inputs(raw: dict, si: bool, ref: str) -> tuple[list, list, list]:
    """(l0, m_ref, omega) inputs: the keys of the file that set the scales, with their values."""
    scene = raw.get("scene", {}) if isinstance(raw.get("scene"), dict) else {}
    table = _body_table(raw, ref)
    path = f"bodies.{ref}"
    l0 = _present(scene, "scene", ("reference_length",)) or _present(table, path, ("length",))
    mass = _present(table, path, ("mass_per_length",)) or _present(table, path, ("density", "area"))
    return l0, mass, _present(scene, "scene", ("omega",)) if si else []


def _body_table(raw: dict, name: str) -> dict:
    bodies = raw.get("bodies", [])
    return next((t for t in bodies if isinstance(t, dict) and t.get("name") == name), {})


def check_body_groups(
    r: Reader, raw: dict, bodies: Sequence[Body], si: bool, ref: str, scales: tuple[float, float, float]
) -> None:
    """l0, m_ref, omega and alpha, nu, lambda, mu, rho of every bar within GROUP_RANGE.

    Parameters
    ----------
    raw : the scene (its ``bodies`` tables name the inputs)
    bodies : the scaled bodies
    si : SI input (lambda and mu come from E, area, inertia, mass, length and omega)
    ref : the reference bar (its length is l0 unless scene.reference_length is given; its
        mass per length is m_ref)
    scales : (l0, m_ref, omega)
    """
    l0_in, m_in, omega_in = reference_inputs(raw, si, ref)
    for what, value, inputs in zip(
        ("the reference length l0", "the reference mass per length m_ref", "omega"), scales, (l0_in, m_in, omega_in)
    ):
        if inputs:
            check_group(r, what, value, inputs)
    for body in bodies:
        path = f"bodies.{body.name}"
        table = _body_table(raw, body.name)
        length = _present(table, path, ("length",))
        mass = _present(table, path, ("mass_per_length",)) or _present(table, path, ("density", "area"))
        check_group(r, f"alpha = l / l0 of bar {body.name!r}", body.alpha, merge_inputs(length, l0_in))
        check_group(r, f"nu = m / m_ref of bar {body.name!r}", body.nu, merge_inputs(mass, m_in))
        if si:
            lam_in = merge_inputs(_present(table, path, ("E", "area")), mass, length, omega_in)
            mu_in = merge_inputs(_present(table, path, ("E", "inertia")), mass, length, omega_in)
        else:
            lam_in, mu_in = _present(table, path, ("lambda",)), _present(table, path, ("mu",))
        check_group(r, f"lambda = EA/(m l^2 omega^2) of bar {body.name!r}", body.lam, lam_in)
        check_group(r, f"mu = EI/(m l^4 omega^2) of bar {body.name!r}", body.mu, mu_in)
        check_group(r, f"rho = mu / lambda of bar {body.name!r}", body.rho, merge_inputs(lam_in, mu_in))


def merge_inputs(*lists: Inputs) -> list[tuple[str, float]]:
    """The inputs of several lists, each key once, in order."""
    return list(dict(item for items in lists for item in items).items())


def check_scaled_values(
    r: Reader,
    scales_inputs: Inputs,
    joints: Sequence[Joint],
    effects: Effects,
    loads: Sequence[Load],
    drivers: Sequence[Driver],
    driver_paths: Sequence[str],
) -> None:
    """Ground points, joint masses, gravity, numeric loads and torque: finite after scaling."""
    for joint in joints:
        path = f"joints.{joint.name}"
        check_scaled(r, join(path, "mass"), f"the lumped mass of joint {joint.name!r}", joint.mass, scales_inputs)
        check_scaled(
            r, join(path, "inertia"), f"the lumped rotary inertia of joint {joint.name!r}", joint.inertia, scales_inputs
        )
        for end in joint.ends:
            for x in end.point or ():
                check_scaled(r, join(path, "at"), f"a ground point of joint {joint.name!r}", x, scales_inputs)
    for g in effects.gravity:
        check_scaled(r, "effects.gravity", "gravity", g, scales_inputs)
    for i, load in enumerate(loads):
        for key in ("axial", "transverse"):
            value = getattr(load, key)
            if isinstance(value, float):
                check_scaled(r, join(join("loads", i), key), f"the {key} load on {load.body!r}", value, scales_inputs)
    for driver, path in zip(drivers, driver_paths):
        check_scaled(r, join(path, "rotor_inertia"), "the driver's rotor inertia", driver.rotor_inertia, scales_inputs)
        if isinstance(driver.torque, float):
            check_scaled(r, join(path, "value"), "the driver torque", driver.torque, scales_inputs)
