"""Load a TOML scene file into the validated, dimensionless :class:`Scene`.

The file format is the contract of ``docs/scene-format.md``. Every problem is raised as
:class:`symgen.errors.SceneError` naming the file, the dotted key (``bodies.rod.lambda``), what
is wrong and what to do.

Examples
--------
>>> scene = load_scene("examples/slider_crank.toml", ["bodies.rod.transverse_modes=3"])  # doctest: +SKIP
>>> scene.body("rod").transverse_modes                                                   # doctest: +SKIP
3
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace

from symgen.errors import SceneError
from symgen.policy import tolerances
from symgen.scene.excitation import (
    check_driver_motion,
    check_expressions,
    driver_paths,
    read_drivers,
    read_effects,
    read_initial,
    read_loads,
)
from symgen.scene.limits import (
    ATOL_MAX,
    ATOL_MIN,
    MAX_DEPTH,
    MAX_FILE_BYTES,
    RTOL_MAX,
    RTOL_MIN,
    RTOL_WARN,
    SceneWarning,
    structure_problem,
    lift_hint,
    limit_value,
    over_limit,
    short_key,
)
from symgen.scene.masses import read_masses
from symgen.scene.mechanism import (
    check_connected,
    check_name,
    make_body,
    read_bars,
    read_joints,
    reference_bar,
    si_inputs,
)
from symgen.scene.bases import DEFAULT_ACCURACY, choose_bases, with_start
from symgen.scene.model import Body, CountsRaised, Driver, Effects, Initial, Scene, Simulation
from symgen.scene.outputs import read_outputs
from symgen.scene.overrides import apply_overrides
from symgen.scene.ranges import merge_inputs, check_body_groups, check_scaled_values, reference_inputs
from symgen.scene.reader import Reader
from symgen.scene.strain import choose_strain
from symgen.scene.units import Scales

__all__ = ["load_scene", "apply_overrides", "parse_scene", "scene_hash"]

TOP_KEYS = (
    "scene",
    "bodies",
    "joints",
    "driver",
    "drivers",
    "initial",
    "effects",
    "loads",
    "masses",
    "outputs",
    "simulation",
)
SCENE_KEYS = ("name", "reference_length", "omega", "units")
UNITS = ("dimensionless", "SI")
SIMULATION_KEYS = ("t_end", "cycles", "output_step", "rtol", "atol", "duration", "output_interval", "accuracy")
#: [simulation] keys in seconds, for SI scenes only (t_end and output_step stay in tau in both systems)
SECONDS_KEYS = ("duration", "output_interval")
DEFAULT_OUTPUT_STEP = 2.0 * math.pi / 360.0
#: the tolerance a scene leaves out when it states the other one (a scene that states neither
#: takes both from simulation.accuracy: symgen.policy.tolerances)
FIXED_RTOL = 1e-8
FIXED_ATOL = 1e-10


@dataclass(frozen=True)
class Header:
    """``[scene]``: name, units, omega and the optional reference length (file units)."""

    name: str
    units: str
    omega: float
    reference_length: float | None


def read_toml(file: str) -> dict:
    """Parse the file with ``tomllib``: unreadable, oversized, non-UTF-8, malformed or too
    deeply nested files become SceneError naming the file."""
    try:
        with open(file, "rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise SceneError(file, "", f"cannot read the scene file: {exc.strerror or exc}", "check the path") from None
    if len(data) > MAX_FILE_BYTES:
        raise SceneError(
            file,
            "",
            f"the file is larger than {MAX_FILE_BYTES // 2**20} MiB; a scene file is a short text",
            "check that this is the scene file",
        )
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise SceneError(
            file,
            "",
            f"not UTF-8 text (byte {exc.start}, line {line}: {data[exc.start : exc.start + 1]!r})",
            "a scene file is TOML text in UTF-8; save it as UTF-8, or check that this is the scene file",
        ) from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(file, "", f"TOML syntax error: {exc}", "fix the TOML syntax") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise SceneError(file, "", f"cannot read a value: {str(exc).split(';')[0]}", "fix the value") from None
    except RecursionError:
        deep = nesting_line(text)
        raise SceneError(
            file,
            "",
            f"arrays or inline tables nested too deeply{f' at line {deep}' if deep else ''} "
            f"(at most {MAX_DEPTH} levels)",
            "a scene needs a few levels; check the brackets",
        ) from None
    check_structure(raw, file)
    return raw


def nesting_line(text: str) -> int | None:
    """The line where brackets/braces first nest deeper than MAX_DEPTH (strings and comments
    skipped, roughly: enough to point at the place), or None."""
    depth, line, quote, comment, escaped = 0, 1, "", False, False
    for ch in text:
        if ch == "\n":
            line, comment = line + 1, False
        elif comment:
            continue
        elif quote:
            if escaped:
                escaped = False
            elif ch == "\\" and quote == '"':
                escaped = True
            elif ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            comment = True
        elif ch in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                return line
        elif ch in "]}":
            depth = max(0, depth - 1)
    return None


def check_structure(raw: dict, file: str, key: str = "", levels: int = MAX_DEPTH) -> None:
    """Tables and arrays nested at most ``levels`` deep (a scene needs 5), integers in 64 bits."""
    problem = structure_problem(raw, key, levels)
    if problem is not None:
        where, what = problem
        raise SceneError(
            file,
            short_key(where),
            what,
            "a scene needs a few levels of tables and arrays and modest numbers; check the keys, brackets and values",
        )


def scene_hash(raw: dict) -> str:
    """sha256 hex digest of the canonical JSON of the raw scene (after overrides)."""
    text = json.dumps(raw, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def read_header(r: Reader, raw: dict) -> Header:
    """``[scene]``: name (required), units, omega (required for SI), reference_length."""
    if "scene" not in raw:
        r.fail("scene", "missing required table [scene]", 'add [scene] with at least name = "..."')
    table = r.table(raw["scene"], "scene")
    r.check_keys(table, "scene", SCENE_KEYS, "[scene]")
    name = check_name(r, r.require(table, "scene", "name", "name the scene with a C identifier"), "scene.name", "scene")
    units = r.choice(table, "scene", "units", UNITS, "dimensionless")
    if units == "SI":
        omega = r.number(
            table, "scene", "omega", gt=0.0, hint="SI input needs the reference frequency omega in rad/s; tau = omega t"
        )
    else:
        omega = r.number(table, "scene", "omega", 1.0, gt=0.0)
        if omega != 1.0:
            r.fail(
                "scene.omega",
                f"a dimensionless scene is already scaled by omega; it must be 1.0, got {omega!r}",
                'remove omega, or set scene.units = "SI" to give it in rad/s',
            )
    reference = r.number(table, "scene", "reference_length", None, gt=0.0, hint="the reference length l0 must be > 0")
    return Header(name, units, omega, reference)


def _seconds_keys(r: Reader, table: dict, scales: Scales) -> None:
    """duration and output_interval are in seconds: SI scenes only, each exclusive with its
    tau twin (t_end/cycles, output_step)."""
    for key, twin in (("duration", "t_end"), ("output_interval", "output_step")):
        if key not in table:
            continue
        if not scales.si:
            r.fail(
                f"simulation.{key}",
                f"{key} is in seconds, but this scene is dimensionless (it has no omega to convert with)",
                f'give {twin} in tau instead, or set scene.units = "SI" with omega',
            )
        if twin in table and key == "output_interval":
            r.fail(
                "simulation.output_interval",
                "give either output_step (in tau) or output_interval (in seconds), not both",
                "remove one of them",
            )


def read_simulation(r: Reader, raw: dict, drivers: tuple[Driver, ...], paths: list[str], scales: Scales) -> Simulation:
    """``[simulation]``: t_end or cycles or (SI) duration (exactly one), output_step or (SI)
    output_interval, rtol, atol. Times are returned in tau; an SI scene's messages give seconds."""
    if "simulation" not in raw:
        r.fail("simulation", "missing required table [simulation]", "add [simulation] with t_end = ... or cycles = ...")
    table = r.table(raw["simulation"], "simulation")
    r.check_keys(table, "simulation", SIMULATION_KEYS, "[simulation]")
    _seconds_keys(r, table, scales)
    lengths = [k for k in ("t_end", "cycles", "duration") if k in table]
    if len(lengths) != 1:
        which = "neither" if not lengths else "both" if len(lengths) == 2 and not scales.si else " and ".join(lengths)
        r.fail(
            "simulation",
            (
                f"give exactly one of t_end, cycles and duration ({which} given)"
                if scales.si
                else f"give exactly one of t_end and cycles ({which} given)"
            ),
            "t_end is the end time in tau = omega t (in both unit systems); cycles is the number of crank turns"
            + ("; duration is the run's length in seconds" if scales.si else ""),
        )
    if "t_end" in table:
        t_end = scales.time(r.number(table, "simulation", "t_end", gt=0.0))
        check_t_end(r, t_end, "simulation.t_end", "", scales)
    elif "duration" in table:
        duration = r.number(table, "simulation", "duration", gt=0.0, hint="the run's length in seconds, > 0")
        t_end = duration * scales.omega
        check_t_end(r, t_end, "simulation.duration", f" ({duration:g} s x omega {scales.omega:g} rad/s)", scales)
    else:
        cycles = r.number(table, "simulation", "cycles", gt=0.0)
        # the turns of the first turning angle driver (constant rate, no law)
        angle = [(d, p) for d, p in zip(drivers, paths) if d.kind == "angle"]
        turning = [(d, p) for d, p in angle if d.law is None and d.rate != 0.0]
        if not turning and any(d.law is not None for d, _ in angle):
            r.fail(
                "simulation.cycles",
                "an angle driver with a law has no constant rate to count turns by",
                "give duration (in seconds) instead of cycles"
                if scales.si
                else "give t_end (in tau) instead of cycles",
            )
        rate = abs(turning[0][0].rate) if turning else 0.0
        t_end = cycles * 2.0 * math.pi / (rate if rate != 0.0 else 1.0)
        check_t_end(
            r,
            t_end,
            "simulation.cycles",
            f" ({cycles:g} turns at {turning[0][1]}.rate {rate:g})" if turning else f" ({cycles:g} x 2 pi)",
            scales,
        )
    step_key = "output_interval" if "output_interval" in table else "output_step"
    if "output_interval" in table:
        interval = r.number(table, "simulation", "output_interval", gt=0.0, hint="the output interval in seconds, > 0")
        step = interval * scales.omega
    elif "output_step" in table:
        step = scales.time(r.number(table, "simulation", "output_step", gt=0.0))
    else:
        step = DEFAULT_OUTPUT_STEP
    if step > t_end:
        if scales.si:
            said = f"the output step ({scales.seconds(step):g} s) is longer than the run ({scales.seconds(t_end):g} s)"
        else:
            said = f"the output step ({step:g}) is longer than the run (t_end = {t_end:g}, in tau)"
        r.fail(f"simulation.{step_key}", said, f"use an {step_key} <= the run's length")
    ratio = t_end / step
    rows: float = math.floor(ratio + 1e-9) + 1 if math.isfinite(ratio) else math.inf  # a subnormal step: inf rows
    if over_limit("rows", rows):
        key = (
            f"simulation.{step_key}"
            if step_key in table
            else ("simulation." + next(k for k in ("t_end", "duration", "cycles") if k in table))
        )
        r.fail(
            key,
            f"the run would write {rows:.4g} output rows (t_end / output_step + 1 = "
            f"{t_end:g} / {step:g} + 1, in tau), more than the limit {limit_value('rows'):g}",
            lift_hint("rows", "use a larger output step or a shorter run"),
        )
    rtol = r.number(table, "simulation", "rtol", FIXED_RTOL, gt=0.0)
    if not RTOL_MIN <= rtol < RTOL_MAX:
        r.fail(
            "simulation.rtol",
            f"the relative tolerance must be in [{RTOL_MIN:g}, {RTOL_MAX:g}), got {rtol:g}",
            "1e-6 to 1e-8 are usual; below 1e-14 is beyond double precision, 1 or more controls nothing",
        )
    if rtol > RTOL_WARN:
        warnings.warn(
            SceneWarning(
                f"{r.file}: simulation.rtol = {rtol:g} is loose: results can be tens of per cent off "
                f"(use rtol <= {RTOL_WARN:g}; 1e-6 to 1e-8 are usual)"
            ),
            stacklevel=2,
        )
    atol = r.number(table, "simulation", "atol", FIXED_ATOL, gt=0.0)
    if not atol < ATOL_MAX:
        r.fail(
            "simulation.atol",
            f"the absolute tolerance must be < {ATOL_MAX:g}, got {atol:g}: the "
            "coordinates are O(1) in model units, so it would control nothing",
            "use about rtol / 100, e.g. 1e-10",
        )
    if atol < ATOL_MIN:
        r.fail(
            "simulation.atol",
            f"the absolute tolerance must be >= {ATOL_MIN:g}, got {atol:g}: the "
            "coordinates are in units of a bar's length, and below that no double-precision solver can "
            "meet it",
            "use about rtol / 100, e.g. 1e-10",
        )
    accuracy = r.number(
        table,
        "simulation",
        "accuracy",
        DEFAULT_ACCURACY,
        gt=0.0,
        hint="the accuracy is a fraction of each output's peak, 0 < accuracy < 1 (e.g. 0.01 for 1 %)",
    )
    if accuracy >= 1.0:
        r.fail(
            "simulation.accuracy",
            f"the accuracy is a fraction of each output's peak and must be < 1, got {accuracy:g}",
            "use e.g. 0.01 for 1 % of peak (0.001 for 0.1 %)",
        )
    if "rtol" in table or "atol" in table:
        return Simulation(t_end=t_end, output_step=step, rtol=rtol, atol=atol, accuracy=accuracy)
    # neither stated: from the accuracy (symgen.policy.tolerances; rtol, atol are IDAS's, the
    # emitted C solver's follow from Simulation.tolerances("c"))
    rtol, atol = tolerances(accuracy, "idas")
    return Simulation(
        t_end=t_end, output_step=step, rtol=rtol, atol=atol, accuracy=accuracy, tolerances_from="accuracy"
    )


def check_sizes(r: Reader, raw: dict) -> None:
    """At most SYMGEN_MAX_ENTRIES bodies, joints, loads, masses and outputs (before any work on them)."""
    for section in ("bodies", "joints", "loads", "masses", "outputs"):
        value = raw.get(section)
        if isinstance(value, (list, dict)) and over_limit("entries", len(value)):
            r.fail(
                section,
                f"{len(value)} entries, more than the limit {limit_value('entries'):g}",
                lift_hint("entries", "split the model, or check that the file was generated correctly"),
            )


def check_t_end(r: Reader, t_end: float, key: str, how: str, scales: Scales | None = None) -> None:
    """t_end (in tau) finite and within the run-length limit (which is in tau)."""
    if not math.isfinite(t_end) or over_limit("t_end", t_end):
        if scales is not None and scales.si and math.isfinite(t_end):
            how += f", {scales.seconds(t_end):g} s"
        r.fail(
            key,
            f"the run would last t_end = {t_end:g} in tau{how}, more than the limit {limit_value('t_end'):g}",
            lift_hint("t_end", "shorten the run"),
        )


def build_groups(bodies: tuple[Body, ...], scales: Scales, units: str, effects: Effects) -> dict:
    """JSON-serialisable dimensionless groups by body, plus the scene's scales."""
    groups: dict = {b.name: {"alpha": b.alpha, "nu": b.nu, "lambda": b.lam, "mu": b.mu, "rho": b.rho} for b in bodies}
    groups["_scene"] = {
        "l0": scales.l0,
        "omega": scales.omega,
        "m_ref": scales.m_ref,
        "units": units,
        "gravity": list(effects.gravity),
    }
    return groups


def parse_scene(raw: dict, file: str, digest: str = "") -> Scene:
    """Validate a raw scene dict (overrides already applied) into a :class:`Scene`.

    Parameters
    ----------
    raw : the parsed TOML
    file : the scene file, for messages and ``Scene.path``
    digest : ``Scene.hash``; computed from ``raw`` when empty
    """
    r = Reader(file)
    r.table(raw, "")
    r.check_keys(raw, "", TOP_KEYS, "the scene file")
    check_sizes(r, raw)
    header = read_header(r, raw)
    si = header.units == "SI"
    bars = read_bars(r, raw, si, header.omega)
    ref = reference_bar(bars)
    scales = Scales(si=si, l0=header.reference_length or ref.length, omega=header.omega, m_ref=ref.mass_per_length)
    bodies = tuple(make_body(bar, scales) for bar in bars)
    check_body_groups(r, raw, bodies, si, ref.name, (scales.l0, scales.m_ref, scales.omega))
    by_name = {b.name: b for b in bodies}
    joints = read_joints(r, raw, by_name, scales)
    check_connected(r, bodies, joints)
    drivers = read_drivers(r, raw, by_name, joints, scales)
    paths = driver_paths(raw)
    effects = read_effects(r, raw, scales)
    strain_choice = choose_strain(
        effects.strain, effects.geometric_stiffening, [j.name for j in joints if j.kind == "slot"]
    )
    effects = replace(effects, strain=strain_choice.strain)
    loads = read_loads(r, raw, by_name, {b.name: b for b in bars}, scales)
    masses = read_masses(r, raw, by_name, joints, scales)
    outputs = read_outputs(r, raw, by_name, {j.name: j for j in joints}, drivers)
    check_scaled_values(r, merge_inputs(*reference_inputs(raw, si, ref.name)), joints, effects, loads, drivers, paths)
    simulation = read_simulation(r, raw, drivers, paths, scales)
    check_driver_motion(r, drivers, paths, simulation.t_end, scales)
    check_expressions(r, drivers, paths, loads, simulation.t_end, scales, raw)
    scene = Scene(
        name=header.name,
        path=file,
        hash=digest or scene_hash(raw),
        units=header.units,
        l0=scales.l0,
        omega=scales.omega,
        m_ref=scales.m_ref,
        bodies=bodies,
        joints=joints,
        drivers=drivers,
        initial=Initial(),  # read below, once every bar's counts are known
        effects=effects,
        loads=loads,
        outputs=outputs,
        simulation=simulation,
        groups=build_groups(bodies, scales, header.units, effects),
        masses=masses,
        si_inputs=si_inputs(raw, bars, header.omega, header.reference_length) if si else (),
        strain_choice=strain_choice,
    )
    table: dict = raw["initial"] if isinstance(raw.get("initial"), dict) else {}
    given_guess: dict = table["guess"] if isinstance(table.get("guess"), dict) else {}
    scene = with_bases(
        r,
        scene,
        {b.name: (b.axial_modes, b.transverse_modes) for b in bars if not b.rigid},
        quasi_static_start=table.get("deformation") == "quasi-static",
        deformed_start=isinstance(table.get("deformation"), dict) and bool(table["deformation"]),
        quasi_stated=frozenset(
            t["name"]
            for t in (raw["bodies"] if isinstance(raw.get("bodies"), list) else [])
            if isinstance(t, dict) and "quasi_static_transverse" in t and isinstance(t.get("name"), str)
        ),
        guess={  # read_initial checks the guess below; here only its well-formed angles
            k: float(v)
            for k, v in given_guess.items()
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        },
    )
    by_name = {b.name: b for b in scene.bodies}
    initial = read_initial(r, raw, by_name, scales, tuple(j.name for j in joints if j.kind == "slot"))
    bases = with_start(scene.bases, initial.quasi_static, effects.damping)
    return replace(scene, initial=initial, bases=bases)


def with_bases(
    r: Reader,
    scene: Scene,
    given: dict[str, tuple[int | None, int | None]],
    quasi_static_start: bool = False,
    guess: dict[str, float] | None = None,
    quasi_stated: frozenset[str] = frozenset(),
    deformed_start: bool = False,
) -> Scene:
    """The scene with every elastic bar's counts: as written, or chosen from
    ``simulation.accuracy`` where absent (:func:`symgen.scene.bases.choose_bases`), and the
    choice recorded on ``Scene.bases``; the quasi-static functions symgen chooses
    (:func:`symgen.scene.bases.quasi_choice`) on the bars' ``quasi_static_transverse``. Stated counts whose a-priori estimate exceeds the
    accuracy warn (SceneWarning: stderr; the sidecar's ``bases`` carries it too)."""
    choices = choose_bases(scene, given, quasi_static_start, guess, quasi_stated, deformed_start)
    bodies = tuple(
        replace(
            b,
            axial_modes=choices[b.name].axial,
            transverse_modes=choices[b.name].transverse,
            quasi_static_transverse=choices[b.name].quasi or b.quasi_static_transverse,
        )
        if b.name in choices
        else b
        for b in scene.bodies
    )
    for c in choices.values():
        if c.warning:
            warnings.warn(SceneWarning(f"{r.file}: {c.warning}"), stacklevel=3)
    return replace(scene, bodies=bodies, bases=tuple(choices.values()))


def with_raised(scene: Scene, raised: CountsRaised) -> Scene:
    """The loaded ``scene`` with its bases chosen again, the floors of ``raised`` on the chosen
    counts (``Scene.counts_raised``: a run's truncation estimate raised them,
    ``symgen.numerics.counts_choice``): the stated counts, the start and the stated quasi-static
    functions as the file gave them (``Scene.bases``), the chooser's coupled and quasi-static
    choices made again for the new counts. Its warnings were said when the file was loaded."""
    stated = {c.bar: c for c in scene.bases}
    bodies = tuple(
        replace(b, quasi_static_transverse=0) if b.name in stated and not stated[b.name].quasi_stated else b
        for b in scene.bodies
    )
    base = replace(scene, bodies=bodies, counts_raised=raised)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        chosen = with_bases(
            Reader(scene.path),
            base,
            {name: c.given for name, c in stated.items()},
            quasi_static_start=scene.initial.quasi_static,
            deformed_start=bool(scene.initial.deformation),
            quasi_stated=frozenset(name for name, c in stated.items() if c.quasi_stated),
            guess={k: float(v) for k, v in scene.initial.guess},
        )
    return replace(chosen, bases=with_start(chosen.bases, scene.initial.quasi_static, scene.effects.damping))


def load_scene(path: str | os.PathLike, overrides: Sequence[str] = ()) -> Scene:
    """Read, override and validate a scene file.

    Parameters
    ----------
    path : the TOML scene file
    overrides : ``KEY=VALUE`` strings (``--set``), applied before validation

    Returns
    -------
    Scene
        Frozen, dimensionless (see :mod:`symgen.scene.model`).

    Raises
    ------
    SceneError
        For any syntax, override, type, range or consistency problem.
    """
    file = os.fspath(path)
    raw = apply_overrides(read_toml(file), overrides, file)
    return parse_scene(raw, file, scene_hash(raw))


def scene_of(scene: Scene | str | os.PathLike[str], overrides: Sequence[str] = ()) -> Scene:
    """``scene`` itself when it is a loaded ``Scene`` (overrides then refused: they apply to a
    file), else the scene file loaded with its ``--set`` overrides (:func:`load_scene`)."""
    if not isinstance(scene, Scene):
        return load_scene(scene, overrides)
    if overrides:
        raise ValueError("overrides apply to a scene file; pass the path, or load_scene(path, overrides)")
    return scene
