"""``[[masses]]``: point masses and rigid attachments anywhere on a bar (issue 21, Deliver 2).

Each entry puts a point mass (and its rotary inertia about its own centre) at ``at`` = xi of bar
``body``: on the bar's axis, or with ``offset = [along, across]`` rigidly attached beside it (a
tool on an arm), the offset in the axes of the cross-section at xi, so it turns with it. The
derivation treats it like a joint's lumped mass and inertia (``symgen.model.loads``).
"""

from __future__ import annotations

import math

from symgen.scene.excitation import bar_name
from symgen.scene.model import Body, Joint, PointMass
from symgen.scene.reader import Reader, join
from symgen.scene.units import Scales

MASS_KEYS = ("body", "at", "mass", "inertia", "offset")


def read_masses(
    r: Reader, raw: dict, bodies: dict[str, Body], joints: tuple[Joint, ...], scales: Scales
) -> tuple[PointMass, ...]:
    """Every ``[[masses]]`` entry (optional), scaled to model units."""
    tables = r.table_array(raw.get("masses", []), "masses")
    guides = {e.body for j in joints if j.kind == "slot" for e in j.ends if e.variable}
    return tuple(read_mass(r, t, join("masses", i), bodies, guides, scales) for i, t in enumerate(tables))


def read_mass(
    r: Reader, table: dict, path: str, bodies: dict[str, Body], guides: set[str], scales: Scales
) -> PointMass:
    """One ``[[masses]]`` entry."""
    r.check_keys(table, path, MASS_KEYS, "a point mass")
    body = bar_name(
        r,
        r.require(table, path, "body", "name the bar that carries the mass"),
        join(path, "body"),
        bodies,
        "a point mass sits on a bar; a mass at a joint is that joint's `mass`",
    )
    if body in guides:
        r.fail(
            join(path, "body"),
            f"bar {body!r} guides a slot; symgen does not model point masses on a slot's guide",
            "put the mass on another bar, or split the guide into two bars joined by a pin",
        )
    xi = r.number(table, path, "at", ge=0.0, le=1.0, hint="the position along the bar: at = xi in [0, 1]")
    mass = r.number(
        table, path, "mass", ge=0.0, hint="the point mass (kg in SI, else relative to m_ref l0) must be >= 0"
    )
    inertia = r.number(
        table,
        path,
        "inertia",
        0.0,
        ge=0.0,
        hint="the rotary inertia about the mass's own centre (kg m^2 in SI, else relative to m_ref l0^3) must be >= 0",
    )
    offset = None
    if "offset" in table:
        along, across = r.pair(
            table["offset"],
            join(path, "offset"),
            "write offset = [along, across]: the mass's centre from the bar's axis at xi, in the "
            "cross-section's axes (m in SI, else the file's length unit)",
        )
        if along or across:  # [0, 0] is the axis: no attachment arm
            offset = (scales.length(along), scales.length(across))
    out = PointMass(body, xi, scales.joint_mass(mass), scales.rotary_inertia(inertia), offset)
    for key, value in (("mass", out.mass), ("inertia", out.inertia), *(("offset", x) for x in offset or ())):
        if not math.isfinite(value):
            r.fail(
                join(path, key),
                f"is not a finite number in model units (relative to the reference bar: {value})",
                "check the value and its unit against the bars' (m_ref, l0)",
            )
    return out
