"""``[[bodies]]`` and ``[[joints]]``: bars, joints and the connection of every bar to ground."""

from __future__ import annotations

import math
from dataclasses import dataclass

from symgen.scene.limits import lift_hint, limit_value, over_limit
from symgen.scene.model import GROUND, Body, Joint, JointEnd
from symgen.scene.names import NAME_RULE, name_problem
from symgen.scene.reader import REQUIRED, Reader, describe, join
from symgen.scene.units import Scales, axial_group, bending_group

FRAMES = ("pinned-pinned", "pinned-sliding", "cantilever")
AXIAL_SHAPES = ("complete", "stress-free")
TRANSVERSE_SHAPES = ("modes", "eigen", "polynomial")
JOINT_KINDS = ("pin", "slider", "slot")

BODY_COMMON = ("name", "length", "rigid", "mass_per_length")
BODY_ELASTIC = (
    "frame",
    "axial_modes",
    "transverse_modes",
    "axial_shapes",
    "transverse_shapes",
    "static_correction",
    "quasi_static_transverse",
)
BODY_DIMLESS = ("lambda", "mu")
BODY_SI = ("E", "area", "inertia", "density")
BODY_KEYS_DIMLESS = BODY_COMMON + BODY_DIMLESS + BODY_ELASTIC
BODY_KEYS_SI = BODY_COMMON + BODY_SI + BODY_ELASTIC
RIGID_FORBIDDEN = BODY_DIMLESS + ("E", "inertia") + BODY_ELASTIC
JOINT_KEYS = ("name", "kind", "bodies", "at", "direction", "mass", "inertia", "overhang", "overhang_modes")
OVERHANG_FORMS = ("elastic", "rigid")  # slot guides: the overhang bends, or moves with the span's end slope
OVERHANG_MODES_DEFAULT = 4
#: the overhang's functions (2 (xi - beta))^(m+1) grow nearly dependent: the condition number of
#: their mass matrix rises about 40x per function (2.9e10 with 5 at beta = 0.75, 3.4e12 with 6,
#: where IDAS fails in the first step of benchmarks/scenes/inverted_slider_crank_overhang.toml)
OVERHANG_MODES_MAX = 5

RESERVED_BODY_NAMES = {
    GROUND: "it is reserved for the fixed frame",
    "_scene": "it is reserved for the scene entry of the groups",
}
RESERVED_JOINT_NAMES = {GROUND: "it is reserved for the fixed frame"}


@dataclass(frozen=True)
class BarSpec:
    """One bar as written in the file (file units), before scaling by l0 and m_ref."""

    name: str
    length: float
    mass_per_length: float
    rigid: bool
    lam: float | None
    mu: float | None
    frame: str
    axial_modes: int | None  # None: absent, chosen from simulation.accuracy (symgen.scene.bases)
    transverse_modes: int | None
    axial_shapes: str
    transverse_shapes: str
    static_correction: bool | None = None
    quasi_static_transverse: int = 0  # the highest standard transverse functions without own inertia


# -- names --------------------------------------------------------------------------------------
def check_name(r: Reader, value: object, key: str, what: str, reserved: dict[str, str] | None = None) -> str:
    """A valid C-identifier name for ``what`` (body, joint, output, scene)."""
    if not isinstance(value, str):
        r.fail(
            key, f"{what} name must be a string, got {describe(value)}", f"write the name in double quotes; {NAME_RULE}"
        )
    problem = name_problem(value)
    if problem is None and reserved and value in reserved:
        problem = reserved[value]
    if problem is not None:
        words = (" and ".join(map(repr, reserved)) + (" are" if len(reserved) > 1 else " is")) if reserved else ""
        rule = NAME_RULE + (f"; {words} reserved" if reserved else "")
        r.fail(key, f"{what} name {value!r} is not allowed: {problem} ({rule})", "rename it and every reference to it")
    return value


def named_entries(
    r: Reader, raw: dict, section: str, what: str, reserved: dict[str, str] | None = None
) -> list[tuple[str, str, dict]]:
    """(name, dotted path, table) of each entry of an array of named tables, names unique."""
    entries = r.table_array(raw.get(section, []), section)
    seen: dict[str, int] = {}
    out = []
    for i, table in enumerate(entries):
        if "name" not in table:
            r.fail(join(join(section, i), "name"), f"{what} #{i + 1} has no 'name'", f"give every {what} a unique name")
        name = check_name(r, table["name"], join(join(section, i), "name"), what, reserved)
        path = join(section, name)
        if name in seen:
            r.fail(
                join(path, "name"),
                f"duplicate {what} name {name!r} (entries #{seen[name] + 1} and #{i + 1} of [[{section}]])",
                f"give every {what} a unique name",
            )
        seen[name] = i
        out.append((name, path, table))
    return out


# -- bodies -------------------------------------------------------------------------------------
def _check_unit_keys(r: Reader, table: dict, path: str, si: bool) -> None:
    """Reject dimensionless keys in an SI file and SI keys in a dimensionless file."""
    for key in table:
        if si and key in BODY_DIMLESS:
            r.fail(
                join(path, key),
                f"'{key}' is a dimensionless group but scene.units = \"SI\"",
                'give E, area, inertia and density instead, or set scene.units = "dimensionless"',
            )
        if not si and key in BODY_SI:
            r.fail(
                join(path, key),
                f"'{key}' is an SI quantity but this scene is dimensionless",
                'give the groups lambda and mu instead, or set scene.units = "SI"',
            )


def _check_rigid_keys(r: Reader, table: dict, path: str) -> None:
    """A rigid bar carries no elastic data."""
    for key in table:
        if key in RIGID_FORBIDDEN:
            r.fail(join(path, key), f"a rigid bar has no '{key}'", "remove it, or set rigid = false for an elastic bar")


def _si_mass(r: Reader, table: dict, path: str) -> float:
    """kg/m of an SI bar: mass_per_length, or density * area."""
    hint = "give mass_per_length (kg/m), or density (kg/m^3) and area (m^2)"
    if "mass_per_length" in table and "density" in table:
        r.fail(join(path, "density"), "give either mass_per_length or density and area, not both", "remove one of them")
    if "mass_per_length" in table:
        return r.number(table, path, "mass_per_length", gt=0.0, hint=hint)
    if "density" not in table:
        r.fail(join(path, "mass_per_length"), "missing the bar's mass: no mass_per_length or density", hint)
    density = r.number(table, path, "density", gt=0.0, hint=hint)
    return density * r.number(table, path, "area", gt=0.0, hint=hint)


def _elastic_groups_dimless(
    r: Reader, table: dict, path: str, axial: int | None, transverse: int | None
) -> tuple[float | None, float | None]:
    """lambda (required when axial_modes > 0) and mu (required when transverse_modes > 0); with
    a count absent, its group is optional (without it that count is 0), but one of them is needed."""
    if axial is None and transverse is None and "lambda" not in table and "mu" not in table:
        r.fail(
            path,
            "an elastic bar without mode counts needs lambda or mu (or both)",
            "give lambda = EA/(m l^2 omega^2) and mu = EI/(m l^4 omega^2), or set rigid = true",
        )
    lam = r.number(
        table,
        path,
        "lambda",
        REQUIRED if axial else None,
        gt=0.0,
        hint="lambda = EA/(m l^2 omega^2) of this bar, > 0; required when axial_modes > 0",
    )
    mu = r.number(
        table,
        path,
        "mu",
        REQUIRED if transverse else None,
        gt=0.0,
        hint="mu = EI/(m l^4 omega^2) of this bar, > 0; required when transverse_modes > 0",
    )
    return lam, mu


def _elastic_groups_si(
    r: Reader,
    table: dict,
    path: str,
    axial: int | None,
    transverse: int | None,
    length: float,
    mass: float,
    omega: float,
) -> tuple[float | None, float | None]:
    """lambda = EA/(m l^2 w^2) and mu = EI/(m l^4 w^2) from SI data (an absent count: its
    section property is optional, without it that count is 0; one of them is needed)."""
    need_e = axial is None or transverse is None or axial > 0 or transverse > 0
    if axial is None and transverse is None and "area" not in table and "inertia" not in table:
        r.fail(
            path,
            "an elastic bar without mode counts needs its area or inertia (or both)",
            "give E with area (axial) and inertia (bending) in SI units, or set rigid = true",
        )
    modulus = r.number(
        table, path, "E", REQUIRED if need_e else None, gt=0.0, hint="an elastic bar needs Young's modulus E in Pa"
    )
    area = r.number(
        table,
        path,
        "area",
        REQUIRED if axial else None,
        gt=0.0,
        hint="axial_modes > 0 needs the cross-section area in m^2",
    )
    inertia = r.number(
        table,
        path,
        "inertia",
        REQUIRED if transverse else None,
        gt=0.0,
        hint="transverse_modes > 0 needs the second moment of area in m^4",
    )
    lam = mu = None
    if modulus is not None and area is not None:
        lam = axial_group(modulus, area, mass, length, omega)
    if modulus is not None and inertia is not None:
        mu = bending_group(modulus, inertia, mass, length, omega)
    return lam, mu


def read_bar(r: Reader, name: str, path: str, table: dict, si: bool, omega: float) -> BarSpec:
    """Validate one ``[[bodies]]`` entry."""
    _check_unit_keys(r, table, path, si)
    r.check_keys(table, path, BODY_KEYS_SI if si else BODY_KEYS_DIMLESS, "a body")
    rigid = r.boolean(table, path, "rigid", False)
    if rigid:
        _check_rigid_keys(r, table, path)
    length = r.number(table, path, "length", gt=0.0, hint="give the bar's length, > 0")
    if si:
        mass = _si_mass(r, table, path)
    else:
        mass = r.number(
            table,
            path,
            "mass_per_length",
            1.0,
            gt=0.0,
            hint="mass_per_length is relative to the reference bar's, > 0, default 1.0",
        )
    if rigid:
        return BarSpec(name, length, mass, True, None, None, "", 0, 0, "", "")
    frame = r.choice(table, path, "frame", FRAMES)
    axial = r.integer(
        table,
        path,
        "axial_modes",
        None,
        ge=0,
        hint="the number of axial shape functions, 0 = axially rigid; leave it out to let simulation.accuracy choose",
    )
    transverse = r.integer(
        table,
        path,
        "transverse_modes",
        None,
        ge=0,
        hint="the number of transverse shape functions, 0 = no bending; leave it out to let simulation.accuracy choose",
    )
    for key, count in (("axial_modes", axial), ("transverse_modes", transverse)):
        if count is not None and over_limit("modes", count):
            r.fail(
                join(path, key),
                f"{count} shape functions is more than the limit of "
                f"{limit_value('modes'):g} per family (derivation time and memory grow steeply: "
                "24 axial + 24 transverse on one bar take about half a minute)",
                lift_hint("modes", "a few (3 to 8) converge for most bars; `symgen study` shows how many yours needs"),
            )
    axial_shapes = r.choice(table, path, "axial_shapes", AXIAL_SHAPES, "complete")
    transverse_shapes = r.choice(table, path, "transverse_shapes", TRANSVERSE_SHAPES, "modes")
    static_correction = r.boolean(table, path, "static_correction", None) if "static_correction" in table else None
    quasi = r.integer(
        table,
        path,
        "quasi_static_transverse",
        0,
        ge=0,
        hint="the number of the highest transverse functions treated quasi-statically, 0 (default) = none",
    )
    if transverse is not None and quasi > transverse:
        r.fail(
            join(path, "quasi_static_transverse"),
            f"{quasi} quasi-static functions is more than the bar's {transverse} transverse_modes",
            f"give at most {transverse} (the highest of its transverse_modes functions lose their own inertia)",
        )
    if si:
        lam, mu = _elastic_groups_si(r, table, path, axial, transverse, length, mass, omega)
    else:
        lam, mu = _elastic_groups_dimless(r, table, path, axial, transverse)
    frame = "pinned-pinned" if frame == "pinned-sliding" else frame
    return BarSpec(
        name,
        length,
        mass,
        False,
        lam,
        mu,
        frame,
        axial,
        transverse,
        axial_shapes,
        transverse_shapes,
        static_correction,
        quasi,
    )


def read_bars(r: Reader, raw: dict, si: bool, omega: float) -> list[BarSpec]:
    """Every ``[[bodies]]`` entry, in file order (at least one)."""
    if not raw.get("bodies"):
        r.fail("bodies", "the scene has no bodies", "add at least one [[bodies]] table")
    entries = named_entries(r, raw, "bodies", "body", RESERVED_BODY_NAMES)
    return [read_bar(r, name, path, table, si, omega) for name, path, table in entries]


#: The physical inputs of an SI bar's groups, in the order of :func:`si_inputs`.
BAR_INPUTS = ("length", "E", "area", "inertia", "density", "mass_per_length")


def si_inputs(raw: dict, bars: list[BarSpec], omega: float, reference_length: float | None) -> tuple:
    """(scene key, value) of an SI scene's physical inputs of its groups (the scene is valid:
    the values are numbers): scene.omega, scene.reference_length when given, and each bar's
    BAR_INPUTS that the file gives."""
    tables = {t.get("name"): t for t in raw.get("bodies", []) if isinstance(t, dict)}
    out = [("scene.omega", float(omega))]
    if reference_length is not None:
        out.append(("scene.reference_length", float(reference_length)))
    for bar in bars:
        table = tables.get(bar.name, {})
        out += [(f"bodies.{bar.name}.{k}", float(table[k])) for k in BAR_INPUTS if k in table]
    return tuple(out)


def reference_bar(bars: list[BarSpec]) -> BarSpec:
    """The bar that defines the default l0 and m_ref: the first flexible bar, else the first."""
    return next((b for b in bars if not b.rigid), bars[0])


def make_body(bar: BarSpec, scales: Scales) -> Body:
    """The model :class:`Body` of a bar: alpha = l / l0, nu = m / m_ref, rho = mu / lambda."""
    rho = bar.mu / bar.lam if bar.mu is not None and bar.lam is not None else None
    return Body(
        name=bar.name,
        alpha=bar.length / scales.l0,
        rigid=bar.rigid,
        nu=bar.mass_per_length / scales.m_ref,
        lam=bar.lam,
        mu=bar.mu,
        rho=rho,
        frame=bar.frame,
        axial_modes=bar.axial_modes or 0,  # an absent count: chosen once the scene is read (loader)
        transverse_modes=bar.transverse_modes or 0,
        axial_shapes=bar.axial_shapes,
        transverse_shapes=bar.transverse_shapes,
        static_correction=bar.static_correction,
        quasi_static_transverse=bar.quasi_static_transverse,
    )


# -- joints -------------------------------------------------------------------------------------
def _joint_bodies(r: Reader, table: dict, path: str, kind: str, bodies: dict[str, Body]) -> list[str]:
    """The two body names of a joint, checked against the bodies and the joint kind."""
    key = join(path, "bodies")
    known = ", ".join(list(bodies) + [GROUND])
    value = r.require(table, path, "bodies", 'give two names, e.g. bodies = ["ground", "crank"]')
    if not isinstance(value, list) or len(value) != 2 or not all(isinstance(v, str) for v in value):
        r.fail(
            key,
            f"must be a list of two body names, got {describe(value)}",
            f'e.g. bodies = ["ground", "crank"]; known bodies: {known}',
        )
    for name in value:
        if name != GROUND and name not in bodies:
            r.fail(key, f"unknown body {name!r}", f"known bodies: {known}")
    if kind == "pin" and value[0] == value[1]:
        r.fail(key, f"a pin cannot join {value[0]!r} to itself", "name two different bodies")
    if kind == "slot" and (GROUND in value or value[0] == value[1]):
        r.fail(
            key,
            f"a slot joins a point of one bar to a second (guide) bar, got {value}",
            'e.g. bodies = ["crank", "guide"]; a point sliding on ground is a "slider"',
        )
    if kind == "slider" and (value.count(GROUND) != 1):
        r.fail(
            key,
            f'a slider joins exactly one bar and "ground", got {value}',
            "a slider puts a bar point on a fixed ground line; join two bars with a pin",
        )
    return value


def _joint_end(r: Reader, name: str, at: object, key: str, i: int, scales: Scales) -> JointEnd:
    """One end: a ground point [x, y] (scaled by l0) or a bar position xi in [0, 1]."""
    if name == GROUND:
        point = r.pair(at, key, 'a ground entry of "at" is a point [x, y]', label=f"at[{i}] (ground)")
        return JointEnd(GROUND, point=(scales.length(point[0]), scales.length(point[1])))
    xi = r.as_number(
        at,
        key,
        ge=0.0,
        le=1.0,
        label=f"at[{i}] (bar {name!r})",
        hint='a bar entry of "at" is a position along the bar in [0, 1]',
    )
    return JointEnd(name, xi=xi)


def _joint_ends(r: Reader, table: dict, path: str, names: list[str], scales: Scales) -> tuple[JointEnd, JointEnd]:
    """Both ends of a joint from ``bodies`` and ``at``."""
    key = join(path, "at")
    at = r.require(table, path, "at", "one entry per body: [x, y] for ground, xi in [0, 1] for a bar")
    if not isinstance(at, list) or len(at) != 2:
        r.fail(
            key,
            f"must have one entry per body (2), got {describe(at)}",
            'e.g. at = [[0.0, 0.0], 0.0] for bodies = ["ground", "crank"]',
        )
    first, second = (_joint_end(r, n, a, key, i, scales) for i, (n, a) in enumerate(zip(names, at)))
    return first, second


def _slot_ends(
    r: Reader, table: dict, path: str, names: list[str], bodies: dict[str, Body]
) -> tuple[JointEnd, JointEnd]:
    """A slot: ``at = [xi, "variable"]``: the first bar's point xi slides along the second
    bar (the guide), whose support distance beta(tau) becomes an unknown."""
    key = join(path, "at")
    hint = 'a slot is written at = [xi, "variable"]: the point xi of the first bar slides along the second'
    at = r.require(table, path, "at", hint)
    if not isinstance(at, list) or len(at) != 2 or at[1] != "variable":
        r.fail(key, f'must be [xi, "variable"] for a slot, got {describe(at)}', hint)
    xi = r.as_number(at[0], key, ge=0.0, le=1.0, label=f"at[0] (bar {names[0]!r})", hint=hint)
    guide = bodies[names[1]]
    if guide.rigid:
        r.fail(
            key,
            f"the guide {guide.name!r} of a slot is rigid; symgen models slots on elastic bars",
            "make the guide elastic (it may have transverse_modes = 0), or use a pin elsewhere",
        )
    if guide.frame != "pinned-pinned":
        r.fail(
            f"bodies.{guide.name}.frame",
            f"the guide of slot {path.split('.')[-1]!r} must use the "
            f'"pinned-pinned" frame (pinned at xi = 0, supported at the slot), got {guide.frame!r}',
            'set frame = "pinned-pinned"',
        )
    if guide.axial_modes != 0:
        r.fail(
            f"bodies.{guide.name}.axial_modes",
            "a bar carrying a slot is axially rigid in symgen (a frictionless slot transmits no axial force to it)",
            "set axial_modes = 0",
        )
    return JointEnd(names[0], xi=xi), JointEnd(names[1], variable=True)


def _direction(r: Reader, table: dict, path: str, kind: str) -> tuple[float, float] | None:
    """Unit direction of a slider's ground line (required for sliders only)."""
    if kind != "slider":
        if "direction" in table:
            r.fail(
                join(path, "direction"), f"a {kind} joint has no direction", "remove it; only sliders have a direction"
            )
        return None
    key = join(path, "direction")
    dx, dy = r.pair(r.require(table, path, "direction", "give the ground line's direction [dx, dy]"), key)
    norm = math.hypot(dx, dy)
    if norm == 0.0:
        r.fail(key, "the direction vector is zero", "give a non-zero direction, e.g. [1.0, 0.0]")
    return (dx / norm, dy / norm)


def read_joint(r: Reader, name: str, path: str, table: dict, bodies: dict[str, Body], scales: Scales) -> Joint:
    """Validate one ``[[joints]]`` entry."""
    r.check_keys(table, path, JOINT_KEYS, "a joint")
    kind = r.choice(table, path, "kind", JOINT_KINDS)
    names = _joint_bodies(r, table, path, kind, bodies)
    if kind == "slot":
        ends = _slot_ends(r, table, path, names, bodies)
    else:
        ends = _joint_ends(r, table, path, names, scales)
    direction = _direction(r, table, path, kind)
    mass = r.number(table, path, "mass", 0.0, ge=0.0, hint="the lumped mass at the joint must be >= 0")
    inertia = r.number(
        table,
        path,
        "inertia",
        0.0,
        ge=0.0,
        hint="the lumped rotary inertia at the joint (kg m^2 in SI, else relative to m_ref l0^3) must be >= 0",
    )
    overhang, overhang_modes = _overhang(r, table, path, kind)
    return Joint(
        name=name,
        kind=kind,
        ends=ends,
        direction=direction,
        mass=scales.joint_mass(mass),
        inertia=scales.rotary_inertia(inertia),
        overhang=overhang,
        overhang_modes=overhang_modes,
    )


def _overhang(r: Reader, table: dict, path: str, kind: str) -> tuple[str, int]:
    """A slot's overhang model: ("elastic", n) bends with n functions of its own (default),
    ("rigid", 0) moves with the span's end slope (the seed's form). ("", 0) for other joints."""
    if kind != "slot":
        for key in ("overhang", "overhang_modes"):
            if key in table:
                r.fail(
                    join(path, key),
                    f"a {kind} joint has no {key}",
                    "remove it; only slot joints model the guide's overhang",
                )
        return "", 0
    form = r.choice(table, path, "overhang", OVERHANG_FORMS, "elastic")
    if form == "rigid":
        if "overhang_modes" in table:
            r.fail(
                join(path, "overhang_modes"),
                "a rigid overhang has no functions of its own",
                'remove overhang_modes, or set overhang = "elastic"',
            )
        return form, 0
    count = r.integer(
        table,
        path,
        "overhang_modes",
        OVERHANG_MODES_DEFAULT,
        ge=1,
        hint='the number of the overhang\'s own bending functions, >= 1 (or overhang = "rigid")',
    )
    if count > OVERHANG_MODES_MAX:
        r.fail(
            join(path, "overhang_modes"),
            f"{count} overhang functions is more than {OVERHANG_MODES_MAX}: "
            "the overhang's polynomial functions grow nearly dependent (their mass matrix's condition "
            "number rises about 40x per function) and the integrator fails",
            "use 3 to 5: they converge for overhangs up to the span (3, 4 and 5 agree to 0.01 % of "
            "peak in benchmarks/RESULTS.md, section overhang)",
        )
    return form, count


def read_joints(r: Reader, raw: dict, bodies: dict[str, Body], scales: Scales) -> tuple[Joint, ...]:
    """Every ``[[joints]]`` entry, in file order."""
    entries = named_entries(r, raw, "joints", "joint", RESERVED_JOINT_NAMES)
    for name, path, _ in entries:
        if name in bodies:
            r.fail(
                join(path, "name"),
                f"joint name {name!r} is also the name of a body",
                "bodies and joints share one namespace (initial.guess names bars and slot joints "
                "in one table): rename the joint",
            )
    return tuple(read_joint(r, name, path, table, bodies, scales) for name, path, table in entries)


def check_connected(r: Reader, bodies: tuple[Body, ...], joints: tuple[Joint, ...]) -> None:
    """Every bar must be connected to ground through joints."""
    neighbours: dict[str, set[str]] = {name: set() for name in (GROUND, *(b.name for b in bodies))}
    for joint in joints:
        a, b = (end.body for end in joint.ends)
        neighbours[a].add(b)
        neighbours[b].add(a)
    reached, todo = {GROUND}, [GROUND]
    while todo:
        for other in neighbours[todo.pop()] - reached:
            reached.add(other)
            todo.append(other)
    for body in bodies:
        if body.name not in reached:
            r.fail(
                f"bodies.{body.name}",
                f"body {body.name!r} is not connected to ground through any chain of joints",
                "add the joints that attach it to the mechanism",
            )
