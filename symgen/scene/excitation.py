"""``[driver]`` / ``[[drivers]]``, ``[[loads]]``, ``[effects]`` and ``[initial]``: what moves and loads the bars."""

from __future__ import annotations

from symgen.scene.mechanism import BarSpec
from symgen.scene.model import GROUND, Body, BodyDeformation, Driver, Effects, Initial, Joint, Load
from symgen.scene.reader import REQUIRED, Reader, describe, is_number, join
from symgen.scene.units import Scales
from symgen.scene.verdicts import expression_error, expression_not_finite, law_not_finite, seconds_error

DRIVER_KINDS = ("angle", "torque")
DRIVER_KEYS = ("kind", "body", "initial", "rate", "value", "law", "ramp", "rotor_inertia")
LAW_HINT = 'law is the prescribed angle theta - initial in rad as an expression of tau, e.g. law = "0.5*sin(tau)"; '
LAW_HINT_SI = (
    "law is the prescribed angle theta - initial in rad as an expression of t in seconds (or tau = omega t), "
    'e.g. law = "0.5*sin(30*t)"; '
)
LOAD_KINDS = ("distributed", "point")
LOAD_KEYS = ("body", "kind", "at", "axial", "transverse")
EFFECT_SWITCHES = ("axial", "transverse", "geometric_stiffening", "coriolis", "rotary_inertia")
# project additions to effects.axial (true / false keep the contract's meaning): the per-bar
# choice "auto" (the default), "dynamic" (= true), "quasi_static" and "inextensible"
AXIAL_MODELS = ("auto", "dynamic", "quasi_static", "inextensible")
EFFECT_KEYS = EFFECT_SWITCHES + ("strain", "gravity", "damping")
STRAINS = ("von_karman", "linear", "exact", "auto")
STRAIN_HINT = (
    'use "auto" (the default: von Karman, the exact bar where a run\'s model-form estimate exceeds '
    'simulation.accuracy), "von_karman", "exact" (von Karman strain and the curvature of the bar\'s axis to '
    'sixth order in the amplitudes: docs/exact-bars.md) or "linear" (the seed\'s)'
)
INITIAL_KEYS = ("guess", "deformation")
DEFORMATION_KEYS = ("f", "g", "fdot", "gdot")


def bar_name(r: Reader, value: object, key: str, bodies: dict[str, Body], hint: str = "") -> str:
    """A reference to a bar (not ground) that exists."""
    known = ", ".join(bodies)
    if not isinstance(value, str):
        r.fail(key, f"must be a body name, got {describe(value)}", f"known bodies: {known}")
    if value == GROUND:
        r.fail(key, '"ground" is not a bar here', hint or f"name a bar: {known}")
    if value not in bodies:
        r.fail(key, f"unknown body {value!r}", f"known bodies: {known}")
    return value


def expression_text(r: Reader, value: str, key: str, scales: Scales, unit: float = 1.0, hint: str = "") -> str:
    """The model's expression of tau for the text ``value`` at ``key``: as written in a
    dimensionless scene; in an SI scene the text is of t in seconds with an SI value, converted
    exactly (t = tau/omega, the value divided by ``unit``, the SI value of one model unit:
    :func:`symgen.scene.expressions.seconds_to_tau_text`, its verdict
    remembered: :mod:`symgen.scene.verdicts`)."""
    error = seconds_error(value, scales.omega, unit) if scales.si else expression_error(value)
    if error is not None:
        shown = value if len(value) <= 80 else value[:60] + f"... ({len(value)} characters)"
        r.fail(key, f"invalid expression {shown!r}: {error}", hint + _expression_hint(scales.si))
    if not scales.si:
        return value
    from symgen.scene.expressions import splice_seconds

    return splice_seconds(value, scales.omega, unit)


def _expression_hint(si: bool) -> str:
    """What an expression may hold (:mod:`symgen.scene.expressions`, imported here: a scene
    without expressions never needs it)."""
    from symgen.scene.expressions import EXPRESSION_HINT, SECONDS_HINT

    return SECONDS_HINT if si else EXPRESSION_HINT


def value_or_expression(
    r: Reader, table: dict, path: str, key: str, default: object, scales: Scales, what: str, unit: float = 1.0
) -> float | str:
    """A number (as written: the caller scales it), or an expression of tau (dimensionless
    scenes) or of t in seconds (SI scenes; returned converted to tau, its value divided by
    ``unit``: :func:`expression_text`)."""
    of = "t (in seconds)" if scales.si else "tau"
    if key not in table:
        if default is REQUIRED:
            r.missing(path, key, f"give a number or an expression of {of} ({what})")
        return default  # type: ignore[return-value]
    value = table[key]
    if isinstance(value, str):
        return expression_text(r, value, join(path, key), scales, unit)
    if not is_number(value):
        r.fail(
            join(path, key),
            f"must be a number or an expression of {of}, got {describe(value)}",
            _expression_hint(scales.si),
        )
    return r.as_number(value, join(path, key))


# -- driver -------------------------------------------------------------------------------------
def _check_pinned_to_ground(r: Reader, path: str, body: str, joints: tuple[Joint, ...]) -> None:
    """A driver turns its bar about a ground pin."""
    for joint in joints:
        names = {end.body for end in joint.ends}
        if joint.kind == "pin" and names == {GROUND, body}:
            return
    r.fail(
        join(path, "body"),
        f'bar {body!r} has no pin joint with "ground"; a driver prescribes the '
        "angle of (or applies a moment to) a bar turning about a ground pin",
        "drive a bar that is pinned to ground, e.g. the crank",
    )


def driver_paths(raw: dict) -> list[str]:
    """The key path of each driver table of a raw scene: ``driver`` or ``drivers[i]``."""
    if "drivers" in raw and isinstance(raw["drivers"], list):
        return [join("drivers", i) for i in range(len(raw["drivers"]))]
    return ["driver"] if "driver" in raw else []


def read_drivers(
    r: Reader, raw: dict, bodies: dict[str, Body], joints: tuple[Joint, ...], scales: Scales
) -> tuple[Driver, ...]:
    """``[driver]`` (one) or ``[[drivers]]`` (several, the same keys each): each drives a distinct
    bar pinned to ground."""
    if "driver" in raw and "drivers" in raw:
        r.fail(
            "drivers",
            "give either [driver] or [[drivers]], not both",
            "move the [driver] table into the [[drivers]] array (one [[drivers]] table per driver)",
        )
    if "driver" in raw:
        return (read_driver(r, raw["driver"], "driver", bodies, joints, scales),)
    tables = r.table_array(raw.get("drivers", []), "drivers")
    out: list[Driver] = []
    for i, table in enumerate(tables):
        path = join("drivers", i)
        d = read_driver(r, table, path, bodies, joints, scales)
        for k, prev in enumerate(out):
            if prev.body == d.body:
                r.fail(
                    join(path, "body"),
                    f"bar {d.body!r} is already driven by drivers[{k}]; a bar takes one driver",
                    "drive each bar once: remove one of the two, or drive another bar pinned to ground",
                )
        out.append(d)
    return tuple(out)


def read_driver(
    r: Reader, value: object, path: str, bodies: dict[str, Body], joints: tuple[Joint, ...], scales: Scales
) -> Driver:
    """One driver table at ``path``: kinematic (angle) or dynamic (torque) guidance."""
    table = r.table(value, path)
    r.check_keys(table, path, DRIVER_KEYS, "[driver]" if path == "driver" else "a [[drivers]] table")
    kind = r.choice(table, path, "kind", DRIVER_KINDS)
    body = bar_name(
        r,
        r.require(table, path, "body", "name the driven bar"),
        join(path, "body"),
        bodies,
        "the driver acts on a bar pinned to ground, not on ground itself",
    )
    _check_pinned_to_ground(r, path, body, joints)
    rotor = scales.rotary_inertia(
        r.number(
            table,
            path,
            "rotor_inertia",
            0.0,
            ge=0.0,
            hint="the rotor inertia (motor rotor + gears reflected to the driven bar's shaft; kg m^2 in SI, "
            "else relative to m_ref l0^3) must be >= 0",
        )
    )
    if kind == "angle":
        if "value" in table:
            r.fail(
                join(path, "value"),
                "an angle driver has no value (torque)",
                'remove it, or use kind = "torque" to apply a moment',
            )
        initial = r.number(table, path, "initial", 0.0)
        if "law" in table:
            return Driver("angle", body, initial, 0.0, law=_law(r, table, path, scales), rotor_inertia=rotor)
        rate = r.number(
            table,
            path,
            "rate",
            hint="the angular rate d theta/d tau, or rad/s in SI; "
            'or give law = "<expression of tau>" for a prescribed angle',
        )
        ramp = r.number(
            table,
            path,
            "ramp",
            None,
            gt=0.0,
            hint="ramp is the spin-up time T (in tau) over which the rate rises smoothly "
            "from 0 to 'rate'; it must be > 0",
        )
        return Driver("angle", body, initial, scales.rate(rate), ramp=ramp, rotor_inertia=rotor)
    for key in ("law", "ramp"):
        if key in table:
            r.fail(
                join(path, key),
                f"a torque driver has no {key} (it prescribes a moment, not the angle)",
                'remove it, or use kind = "angle" to prescribe the angle',
            )
    torque = value_or_expression(r, table, path, "value", REQUIRED, scales, "torque", scales.torque_unit())
    initial = r.number(table, path, "initial", None)
    rate = r.number(table, path, "rate", 0.0)
    if isinstance(torque, float):
        torque = scales.torque(torque)
    return Driver("torque", body, initial, scales.rate(rate), torque, rotor_inertia=rotor)


def _law(r: Reader, table: dict, path: str, scales: Scales) -> str:
    """``law``: theta - initial in rad as an expression of tau (SI scenes: of t in seconds,
    converted to tau); exclusive with rate and ramp."""
    for key in ("rate", "ramp"):
        if key in table:
            r.fail(
                join(path, key),
                f"an angle driver with a law has no {key} (the law gives the whole motion)",
                f"remove {key}, or remove law for the constant-speed drive"
                + (" with its spin-up ramp" if key == "ramp" else ""),
            )
    value = table["law"]
    key = join(path, "law")
    hint = LAW_HINT_SI if scales.si else LAW_HINT
    if not isinstance(value, str):
        r.fail(
            key,
            f"must be a string expression of {'t (in seconds)' if scales.si else 'tau'}, got {describe(value)}",
            hint + _expression_hint(scales.si),
        )
    return expression_text(r, value, key, scales, 1.0, hint)


def _as_written(raw: dict | None, key: str, text: str) -> str:
    """The text at ``key`` ("driver.value", "drivers[1].law", "loads[1].axial") as the file gives
    it (an SI scene's expression of t, before its conversion to tau), else ``text``."""
    table: object = raw
    for part in key.replace("[", ".").replace("]", "").split("."):
        if isinstance(table, dict):
            table = table.get(part)
        elif isinstance(table, list) and part.isdigit() and int(part) < len(table):
            table = table[int(part)]
        else:
            return text
    return table if isinstance(table, str) else text


def _run_text(scales: Scales, t_end: float) -> str:
    """The end of the run (t_end in tau) as messages show it: seconds in SI, else tau."""
    return f"{scales.seconds(t_end):.6g}" + (" s" if scales.si else "")


def check_driver_motion(r: Reader, drivers: tuple[Driver, ...], paths: list[str], t_end: float, scales: Scales) -> None:
    """Each prescribed angle and its two derivatives are finite over [0, t_end] (t_end in tau;
    an SI scene's messages give the time in seconds)."""
    for driver, path in zip(drivers, paths):
        if driver.kind != "angle" or driver.law is None:
            continue  # the constant-speed drive and its ramp (T > 0) are finite by construction
        bad = law_not_finite(driver, t_end)
        if bad is None:
            continue
        what = bad[1].replace("d tau", "dt") if scales.si else bad[1]
        r.fail(
            join(path, "law"),
            f"the prescribed angle's {what} is not a finite real number at {scales.time_text(bad[0])} "
            f"(the run goes from 0 to {_run_text(scales, t_end)})",
            "give a law that is smooth (twice differentiable) and finite on the whole run",
        )


def check_expressions(
    r: Reader,
    drivers: tuple[Driver, ...],
    paths: list[str],
    loads: tuple[Load, ...],
    t_end: float,
    scales: Scales,
    raw: dict | None = None,
) -> None:
    """Every load and torque given as an expression is a finite real number over the run
    [0, t_end] (in tau): a pole or a value outside its domain is named here, with its time
    (in seconds for an SI scene, whose ``raw`` expressions of t are quoted as written), instead
    of failing later inside the integrator with a message about its tolerances."""
    found = [
        (join(path, "value"), driver.torque)
        for driver, path in zip(drivers, paths)
        if driver.kind == "torque" and isinstance(driver.torque, str)
    ]
    for i, load in enumerate(loads):
        found += [
            (f"loads[{i}].{key}", text)
            for key in ("axial", "transverse")
            if isinstance(text := getattr(load, key), str)
        ]
    for key, text in found:
        bad = expression_not_finite(text, t_end)
        if bad is not None:
            at, run, end = scales.time_text(bad), _run_text(scales, t_end), "that time" if scales.si else "that tau"
            r.fail(
                key,
                f"{_as_written(raw, key, text)!r} is not a finite real number at {at} (a pole, or outside the "
                f"function's domain; the run goes from 0 to {run})",
                f"give an expression that is finite on the whole run, or end the run before {end}",
            )


# -- loads --------------------------------------------------------------------------------------
def read_load(
    r: Reader, table: dict, path: str, bodies: dict[str, Body], bars: dict[str, BarSpec], scales: Scales
) -> Load:
    """One ``[[loads]]`` entry, scaled by the loaded bar's m_i l_i omega^2 (SI)."""
    r.check_keys(table, path, LOAD_KEYS, "a load")
    body = bar_name(
        r, r.require(table, path, "body", "name the loaded bar"), join(path, "body"), bodies, "loads act on bars"
    )
    kind = r.choice(table, path, "kind", LOAD_KINDS)
    xi = None
    if kind == "point":
        xi = r.number(
            table, path, "at", ge=0.0, le=1.0, hint="a point load needs its position at = xi in [0, 1] along the bar"
        )
    elif "at" in table:
        r.fail(join(path, "at"), "a distributed load has no 'at'", 'remove it, or use kind = "point"')
    bar = bars[body]
    unit = (scales.point_unit if kind == "point" else scales.distributed_unit)(bar.mass_per_length, bar.length)
    values = [value_or_expression(r, table, path, key, 0.0, scales, "load", unit) for key in ("axial", "transverse")]
    scale = scales.point if kind == "point" else scales.distributed
    axial, transverse = (scale(v, bar.mass_per_length, bar.length) if isinstance(v, float) else v for v in values)
    return Load(body=body, kind=kind, xi=xi, axial=axial, transverse=transverse)


def read_loads(
    r: Reader, raw: dict, bodies: dict[str, Body], bars: dict[str, BarSpec], scales: Scales
) -> tuple[Load, ...]:
    """Every ``[[loads]]`` entry (optional)."""
    tables = r.table_array(raw.get("loads", []), "loads")
    return tuple(read_load(r, t, join("loads", i), bodies, bars, scales) for i, t in enumerate(tables))


# -- effects ------------------------------------------------------------------------------------
def read_effects(r: Reader, raw: dict, scales: Scales) -> Effects:
    """``[effects]`` with the contract's defaults (those of :class:`Effects`)."""
    defaults = Effects()
    table = r.table(raw.get("effects", {}), "effects")
    r.check_keys(table, "effects", EFFECT_KEYS, "[effects]")
    switches = {k: r.boolean(table, "effects", k, getattr(defaults, k)) for k in EFFECT_SWITCHES if k != "axial"}
    axial_hint = (
        'write "auto" (the default: per bar, the axial dynamics eliminated when they are far '
        'faster than the run), true (= "dynamic"), "quasi_static", "inextensible" (the lambda -> '
        "infinity limit: no stretch) or false (no axial deformation)"
    )
    if isinstance(table.get("axial"), str):
        switches["axial"] = r.choice(table, "effects", "axial", AXIAL_MODELS, hint=axial_hint)
    else:
        switches["axial"] = r.boolean(table, "effects", "axial", defaults.axial, hint=axial_hint)
    strain = r.choice(table, "effects", "strain", STRAINS, "auto", hint=STRAIN_HINT)
    if strain == "exact":
        if not switches["geometric_stiffening"]:
            r.fail(
                "effects.strain",
                '"exact" needs geometric_stiffening = true (its curvature terms and the von Karman strain '
                "are one expansion of the bar's exact deformation)",
                'remove geometric_stiffening = false, or use strain = "linear"',
            )
        joints = raw.get("joints", [])
        slots = (
            [j.get("name", "?") for j in joints if isinstance(j, dict) and j.get("kind") == "slot"]
            if isinstance(joints, list)
            else []
        )
        if slots:
            r.fail(
                "effects.strain",
                f'"exact" is not available with a slot joint ({", ".join(map(str, slots))}): the exact bar '
                "has no slot-guide form (the guide's functions psi(xi, beta) move with the contact; its curvature is "
                "kept to fourth order whatever the strain)",
                'use strain = "von_karman" for this scene',
            )
    gx, gy = defaults.gravity
    if "gravity" in table:
        gx, gy = r.pair(table["gravity"], "effects.gravity", "gravity = [gx, gy] in ground axes, m/s^2 in SI")
    damping = r.number(
        table, "effects", "damping", defaults.damping, ge=0.0, hint="the Kelvin-Voigt ratio must be >= 0"
    )
    return Effects(**switches, strain=strain, gravity=(scales.gravity(gx), scales.gravity(gy)), damping=damping)


# -- initial ------------------------------------------------------------------------------------
def _guess(
    r: Reader, value: object, bodies: dict[str, Body], slots: tuple[str, ...] = ()
) -> tuple[tuple[str, float], ...]:
    """``initial.guess = {body = angle, slot_joint = beta}``."""
    table = r.table(value, "initial.guess", "write guess = { bar = angle_in_rad, ... }")
    for name in table:
        if name not in slots:
            bar_name(r, name, join("initial.guess", name), bodies)
    return tuple((name, r.number(table, "initial.guess", name)) for name in table)


def _body_deformation(r: Reader, value: object, path: str, body: Body, scales: Scales) -> BodyDeformation:
    """Modal amplitudes of one bar; lists must match its mode counts, missing ones are zeros."""
    table = r.table(value, path, "write { f = [...], g = [...], fdot = [...], gdot = [...] }")
    r.check_keys(table, path, DEFORMATION_KEYS, "a deformation")
    if body.rigid:
        r.fail(path, f"{body.name!r} is a rigid bar: it has no deformation", "remove it, or make the bar elastic")
    counts = {
        "f": ("axial_modes", body.axial_modes),
        "fdot": ("axial_modes", body.axial_modes),
        "g": ("transverse_modes", body.transverse_modes),
        "gdot": ("transverse_modes", body.transverse_modes),
    }
    values = {}
    for key, (count_name, count) in counts.items():
        if key not in table:
            values[key] = (0.0,) * count
            continue
        amplitudes = r.numbers(table[key], join(path, key))
        if len(amplitudes) != count:
            r.fail(
                join(path, key),
                f"has {len(amplitudes)} entries but bar {body.name!r} has {count_name} = {count}",
                "give one amplitude per mode",
            )
        if key.endswith("dot"):
            amplitudes = tuple(scales.rate(a) for a in amplitudes)
        values[key] = amplitudes
    return BodyDeformation(**values)


def read_initial(r: Reader, raw: dict, bodies: dict[str, Body], scales: Scales, slots: tuple[str, ...] = ()) -> Initial:
    """The optional ``[initial]``: assembly guess and initial deformation."""
    table = r.table(raw.get("initial", {}), "initial")
    r.check_keys(table, "initial", INITIAL_KEYS, "[initial]")
    guess = _guess(r, table["guess"], bodies, slots) if "guess" in table else ()
    value = table.get("deformation", {})
    if isinstance(value, str):
        if value != "quasi-static":
            r.fail(
                "initial.deformation",
                f"unknown value {value!r}",
                'use "quasi-static" or a table { bar = { f = [...], g = [...] } }',
            )
        return Initial(guess=guess, quasi_static=True)
    table = r.table(value, "initial.deformation", 'use "quasi-static" or a table { bar = { f = [...], g = [...] } }')
    deformation = []
    for name, entry in table.items():
        key = join("initial.deformation", name)
        bar_name(r, name, key, bodies)
        deformation.append((name, _body_deformation(r, entry, key, bodies[name], scales)))
    return Initial(guess=guess, deformation=tuple(deformation))
