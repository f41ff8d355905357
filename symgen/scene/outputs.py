"""``[outputs]``: named signals, each kind with exactly the keys it needs."""

from __future__ import annotations

from symgen.scene.excitation import bar_name
from symgen.scene.mechanism import check_name
from symgen.scene.model import OUTPUT_KINDS, Body, Driver, Joint, Output
from symgen.scene.reader import Reader, describe, join

#: Keys (besides ``kind``) that each output kind requires; no others are accepted.
KIND_KEYS: dict[str, tuple[str, ...]] = {
    "chord_deflection": ("body", "at"),
    "chord_elongation": ("body",),
    "deflection": ("body", "at"),
    "axial": ("body", "at"),
    "slope": ("body", "at"),
    "elastic_displacement": ("body", "at", "component"),
    "position": ("body", "at", "component"),
    "angle": ("body",),
    "reaction": ("joint", "component"),
    "driver_torque": (),
    "energy": (),
    "closure_residual": (),
}
#: Keys that a kind accepts but does not require: driver_torque's driven bar (required when the
#: scene has several angle drivers).
OPTIONAL_KEYS: dict[str, tuple[str, ...]] = {"driver_torque": ("body",)}
#: Kinds that measure deformation: their bar must be elastic.
ELASTIC_KINDS = ("chord_deflection", "chord_elongation", "deflection", "axial", "slope", "elastic_displacement")
COMPONENTS = ("x", "y")
RESERVED_OUTPUT_NAMES = {"tau": "it is the time column of the results", "ground": "it is reserved for the fixed frame"}


def _output_keys(r: Reader, table: dict, path: str, kind: str) -> None:
    """Exactly the keys the kind needs: none missing, none extra."""
    needed = KIND_KEYS[kind]
    optional = OPTIONAL_KEYS.get(kind, ())
    allowed = ("kind",) + needed + optional
    needs = ", ".join(needed) if needed else "nothing else"
    if optional:
        needs += f" (optional: {', '.join(optional)})"
    for key in table:
        if key not in allowed:
            r.fail(
                join(path, key),
                f"an output of kind {kind!r} takes no '{key}' (allowed: {', '.join(allowed)})",
                f"remove it; {kind} needs {needs}",
            )
    for key in needed:
        if key not in table:
            r.fail(
                join(path, key), f"missing required key '{key}' for an output of kind {kind!r}", f"{kind} needs {needs}"
            )


def _output_body(r: Reader, table: dict, path: str, kind: str, bodies: dict[str, Body]) -> str:
    """The measured bar; deformation kinds need an elastic bar."""
    name = bar_name(r, table["body"], join(path, "body"), bodies)
    if kind in ELASTIC_KINDS and bodies[name].rigid:
        r.fail(
            join(path, "body"),
            f"{kind} measures deformation but {name!r} is a rigid bar",
            "name an elastic bar, or use position/angle for a rigid one",
        )
    return name


def read_output(
    r: Reader, name: str, value: object, bodies: dict[str, Body], joints: dict[str, Joint], drivers: tuple[Driver, ...]
) -> Output:
    """One named output."""
    path = join("outputs", name)
    check_name(r, name, path, "output", RESERVED_OUTPUT_NAMES)
    table = r.table(value, path, f'write {name} = {{ kind = "...", ... }}')
    kind = r.choice(table, path, "kind", OUTPUT_KINDS)
    _output_keys(r, table, path, kind)
    body = _output_body(r, table, path, kind, bodies) if "body" in table else None
    joint = None
    if "joint" in table:
        joint = table["joint"]
        if not isinstance(joint, str) or joint not in joints:
            r.fail(
                join(path, "joint"),
                f"unknown joint {joint!r}"
                if isinstance(joint, str)
                else f"must be a joint name, got {describe(joint)}",
                f"known joints: {', '.join(joints)}",
            )
    xi = r.number(table, path, "at", None, ge=0.0, le=1.0, hint="at is a position along the bar in [0, 1]")
    component = r.choice(table, path, "component", COMPONENTS, None)
    if kind == "driver_torque":
        _driver_torque_body(r, path, body, drivers)
    return Output(name=name, kind=kind, body=body, joint=joint, xi=xi, component=component)


def _driver_torque_body(r: Reader, path: str, body: str | None, drivers: tuple[Driver, ...]) -> None:
    """driver_torque is the moment of an angle driver: the only one, or the one on ``body``."""
    angle = [d.body for d in drivers if d.kind == "angle"]
    if not angle:
        if not drivers:
            why = "the scene has no driver"
        else:
            why = "the driver is a torque driver" if len(drivers) == 1 else "every driver is a torque driver"
        r.fail(
            join(path, "kind"),
            f"driver_torque is the moment needed by an angle driver, but {why}",
            "use it with [driver] kind = \"angle\"; a torque driver's moment is its 'value'",
        )
    if body is None and len(angle) > 1:
        r.fail(
            join(path, "body"),
            f"the scene has {len(angle)} angle drivers ({', '.join(angle)}); driver_torque must say which",
            f'add body = "<driven bar>", one of: {", ".join(angle)}',
        )
    if body is not None and body not in angle:
        r.fail(
            join(path, "body"),
            f"bar {body!r} has no angle driver",
            f"name a bar driven by an angle driver: {', '.join(angle)}",
        )


def read_outputs(
    r: Reader, raw: dict, bodies: dict[str, Body], joints: dict[str, Joint], drivers: tuple[Driver, ...]
) -> tuple[Output, ...]:
    """Every output, in the file's order (at least one)."""
    table = r.table(raw.get("outputs", {}), "outputs")
    if not table:
        r.fail("outputs", "the scene has no outputs", 'add at least one, e.g. [outputs] eps = { kind = "energy" }')
    return tuple(read_output(r, name, value, bodies, joints, drivers) for name, value in table.items())
