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
from collections.abc import Sequence
from dataclasses import dataclass

from symgen.errors import SceneError
from symgen.scene.excitation import (check_driver_motion, read_driver, read_effects, read_initial,
                                     read_loads)
from symgen.scene.mechanism import (check_connected, check_name, make_body, read_bars, read_joints,
                                    reference_bar)
from symgen.scene.model import Body, Driver, Effects, Scene, Simulation
from symgen.scene.outputs import read_outputs
from symgen.scene.overrides import apply_overrides
from symgen.scene.reader import Reader
from symgen.scene.units import Scales

__all__ = ["load_scene", "apply_overrides", "parse_scene", "scene_hash"]

TOP_KEYS = ("scene", "bodies", "joints", "driver", "initial", "effects", "loads", "outputs",
            "simulation")
SCENE_KEYS = ("name", "reference_length", "omega", "units")
UNITS = ("dimensionless", "SI")
SIMULATION_KEYS = ("t_end", "cycles", "output_step", "rtol", "atol")
DEFAULT_OUTPUT_STEP = 2.0 * math.pi / 360.0


@dataclass(frozen=True)
class Header:
    """``[scene]``: name, units, omega and the optional reference length (file units)."""

    name: str
    units: str
    omega: float
    reference_length: float | None


def read_toml(file: str) -> dict:
    """Parse the file with ``tomllib``; unreadable files and syntax errors become SceneError."""
    try:
        with open(file, "rb") as handle:
            return tomllib.load(handle)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(file, "", f"TOML syntax error: {exc}", "fix the TOML syntax") from None
    except OSError as exc:
        raise SceneError(file, "", f"cannot read the scene file: {exc.strerror or exc}",
                         "check the path") from None


def scene_hash(raw: dict) -> str:
    """sha256 hex digest of the canonical JSON of the raw scene (after overrides)."""
    text = json.dumps(raw, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def read_header(r: Reader, raw: dict) -> Header:
    """``[scene]``: name (required), units, omega (required for SI), reference_length."""
    if "scene" not in raw:
        r.fail("scene", "missing required table [scene]", "add [scene] with at least name = \"...\"")
    table = r.table(raw["scene"], "scene")
    r.check_keys(table, "scene", SCENE_KEYS, "[scene]")
    name = check_name(r, r.require(table, "scene", "name", "name the scene with a C identifier"),
                      "scene.name", "scene")
    units = r.choice(table, "scene", "units", UNITS, "dimensionless")
    if units == "SI":
        omega = r.number(table, "scene", "omega", gt=0.0,
                         hint="SI input needs the reference frequency omega in rad/s; tau = omega t")
    else:
        omega = r.number(table, "scene", "omega", 1.0, gt=0.0)
        if omega != 1.0:
            r.fail("scene.omega", f"a dimensionless scene is already scaled by omega; it must be 1.0, "
                   f"got {omega!r}", "remove omega, or set scene.units = \"SI\" to give it in rad/s")
    reference = r.number(table, "scene", "reference_length", None, gt=0.0,
                         hint="the reference length l0 must be > 0")
    return Header(name, units, omega, reference)


def read_simulation(r: Reader, raw: dict, driver: Driver | None, scales: Scales) -> Simulation:
    """``[simulation]``: t_end or cycles (exactly one), output_step, rtol, atol."""
    if "simulation" not in raw:
        r.fail("simulation", "missing required table [simulation]",
               "add [simulation] with t_end = ... or cycles = ...")
    table = r.table(raw["simulation"], "simulation")
    r.check_keys(table, "simulation", SIMULATION_KEYS, "[simulation]")
    if ("t_end" in table) == ("cycles" in table):
        which = "both" if "t_end" in table else "neither"
        r.fail("simulation", f"give exactly one of t_end and cycles ({which} given)",
               "t_end is the end time in tau = omega t (in both unit systems); cycles is the number of crank turns")
    if "t_end" in table:
        t_end = scales.time(r.number(table, "simulation", "t_end", gt=0.0))
    else:
        cycles = r.number(table, "simulation", "cycles", gt=0.0)
        if driver is not None and driver.law is not None:
            r.fail("simulation.cycles", "an angle driver with a law has no constant rate to count turns by",
                   "give t_end (in tau) instead of cycles")
        rate = abs(driver.rate) if driver is not None and driver.kind == "angle" else 0.0
        t_end = cycles * 2.0 * math.pi / (rate if rate != 0.0 else 1.0)
    if "output_step" in table:
        step = scales.time(r.number(table, "simulation", "output_step", gt=0.0))
    else:
        step = DEFAULT_OUTPUT_STEP
    if step > t_end:
        r.fail("simulation.output_step", f"the output step ({step:g}) is longer than the run "
               f"(t_end = {t_end:g}, in tau)", "use an output_step <= t_end")
    rtol = r.number(table, "simulation", "rtol", 1e-8, gt=0.0)
    atol = r.number(table, "simulation", "atol", 1e-10, gt=0.0)
    return Simulation(t_end=t_end, output_step=step, rtol=rtol, atol=atol)


def build_groups(bodies: tuple[Body, ...], scales: Scales, units: str, effects: Effects) -> dict:
    """JSON-serialisable dimensionless groups by body, plus the scene's scales."""
    groups: dict = {b.name: {"alpha": b.alpha, "nu": b.nu, "lambda": b.lam, "mu": b.mu,
                             "rho": b.rho} for b in bodies}
    groups["_scene"] = {"l0": scales.l0, "omega": scales.omega, "m_ref": scales.m_ref,
                        "units": units, "gravity": list(effects.gravity)}
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
    header = read_header(r, raw)
    si = header.units == "SI"
    bars = read_bars(r, raw, si, header.omega)
    ref = reference_bar(bars)
    scales = Scales(si=si, l0=header.reference_length or ref.length, omega=header.omega,
                    m_ref=ref.mass_per_length)
    bodies = tuple(make_body(bar, scales) for bar in bars)
    by_name = {b.name: b for b in bodies}
    joints = read_joints(r, raw, by_name, scales)
    check_connected(r, bodies, joints)
    driver = read_driver(r, raw, by_name, joints, scales)
    initial = read_initial(r, raw, by_name, scales, tuple(j.name for j in joints if j.kind == "slot"))
    effects = read_effects(r, raw, scales)
    loads = read_loads(r, raw, by_name, {b.name: b for b in bars}, scales)
    outputs = read_outputs(r, raw, by_name, {j.name: j for j in joints}, driver)
    simulation = read_simulation(r, raw, driver, scales)
    check_driver_motion(r, driver, simulation.t_end)
    return Scene(name=header.name, path=file, hash=digest or scene_hash(raw), units=header.units,
                 l0=scales.l0, omega=scales.omega, m_ref=scales.m_ref, bodies=bodies,
                 joints=joints, driver=driver, initial=initial, effects=effects, loads=loads,
                 outputs=outputs, simulation=simulation,
                 groups=build_groups(bodies, scales, header.units, effects))


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
