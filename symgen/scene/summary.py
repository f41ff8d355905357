"""A short text summary of a validated scene (``symgen check``).

Examples
--------
>>> from symgen.scene import load_scene
>>> print(summary(load_scene("examples/slider_crank.toml")))   # doctest: +SKIP
slider_crank (examples/slider_crank.toml): valid, dimensionless, l0 = 1, omega = 1
  bars     crank: rigid, alpha 0.5, nu 1
  ...

An SI scene's driver, gravity and run are given in SI (rad/s, N m, m/s^2, seconds; the run's
t_end in tau too): ``run      duration 0.0546 s (t_end 12.6 tau), output interval ...``.
"""

from __future__ import annotations

import math

from symgen.scene.quasi import quasi_static_reasons
from symgen.scene.model import Scene, Simulation


def describe_tolerances(sim: Simulation) -> str:
    """The integrators' tolerances of a run and why (``symgen check``, ``symgen effects``): the
    scene's, or IDAS's and the emitted C solver's from the accuracy (``symgen.policy.tolerances``)."""
    if sim.tolerances_from != "accuracy":
        return f"rtol {sim.rtol:g}, atol {sim.atol:g} ({sim.tolerances_reason()})"
    (rtol, atol), (c_rtol, c_atol) = sim.tolerances("idas"), sim.tolerances("c")
    return (
        f"rtol {rtol:g}, atol {atol:g} (IDAS); rtol {c_rtol:g}, atol {c_atol:g} (--solver c); {sim.tolerances_reason()}"
    )


def _bar(body, corrections: dict | None = None) -> str:
    head = f"{body.name}: "
    if body.rigid:
        return head + f"rigid, alpha {body.alpha:.6g}, nu {body.nu:.6g}"
    groups = ", ".join(
        f"{k} {v:.6g}"
        for k, v in (("alpha", body.alpha), ("nu", body.nu), ("lambda", body.lam), ("mu", body.mu))
        if v is not None
    )
    families = " + ".join(
        f"{n} {what}" + (f" ({shapes})" if n else "")
        for n, what, shapes in (
            (body.axial_modes, "axial", body.axial_shapes),
            (body.transverse_modes, "transverse", body.transverse_shapes),
        )
    )
    extra = ""
    pts = (corrections or {}).get(body.name)
    if pts:
        where = ", ".join(f"{x:.6g}" for x in next(iter(pts.values())))
        kinds = " and ".join(k for k in pts if k != "moment")
        if pts.get("moment"):  # a rigid body with a rotary inertia or an arm: a unit couple's too
            kinds += "; moment at xi = " + ", ".join(f"{x:.6g}" for x in pts["moment"])
        extra = (
            f" + static corrections at xi = {where} ({kinds}; bodies.{body.name}.static_correction = false drops them)"
        )
    return head + f"{body.frame}, {families} shape functions{extra}; {groups}"


def describe_basis(choice) -> str:
    """One line of a bar's :class:`~symgen.scene.bases.BasisChoice`: its counts, whether chosen
    or stated, the dynamic/static split, the a-priori estimate and why."""
    how = " and ".join(
        f"{n} {what} {'chosen' if g is None else 'as stated'}"
        for n, what, g in zip((choice.axial, choice.transverse), ("axial", "transverse"), choice.given)
    )
    split = (
        f"dynamic modes: {choice.dynamic[0]} axial, {choice.dynamic[1]} bending; "
        f"a-priori estimate {choice.estimate:.2g} of peak (accuracy {choice.accuracy:g})"
    )
    warn = f"; WARNING: {choice.warning}" if choice.warning else ""
    if choice.raised:  # a run's truncation estimate raised the chosen counts (said in the reason too)
        how += " (raised by a run's truncation estimate)"
    return f"{how}; {split}; {choice.reason}{warn}"


def _joint(joint) -> str:
    ends = " - ".join(end.body for end in joint.ends)
    mass = f", mass {joint.mass:.6g}" if joint.mass else ""
    if joint.inertia:
        mass += f", rotary inertia {joint.inertia:.6g}"
    return f"{joint.name}: {joint.kind} {ends}{mass}"


def summary(scene: Scene, corrections: dict | None = None) -> str:
    """Bars (frames, shape functions, groups), joints, driver, point masses, loads, outputs and the run;
    ``corrections``: {bar: its static correction points by direction} (``structure.static_points``,
    which the caller gives: the model layer is above the scene's)."""
    si = scene.units == "SI"
    moment = scene.m_ref * scene.l0**3 * scene.omega**2  # N m per model unit (SI scenes)
    lines = [f"{scene.name} ({scene.path}): valid, {scene.units}, l0 = {scene.l0:.6g}, omega = {scene.omega:.6g}"]
    lines += [f"  {'bars' if i == 0 else '':8} {_bar(b, corrections)}" for i, b in enumerate(scene.bodies)]
    lines += [f"  {'joints' if i == 0 else '':8} {_joint(j)}" for i, j in enumerate(scene.joints)]
    modes = sum(b.axial_modes + b.transverse_modes for b in scene.bodies)
    elastic = sum(not b.rigid for b in scene.bodies)
    lines.append(f"  {'modes':8} {modes} shape functions on {elastic} elastic bar(s)")
    lines += [f"  {'bases' if i == 0 else '':8} {c.bar}: {describe_basis(c)}" for i, c in enumerate(scene.bases)]
    quasi = quasi_static_reasons(scene)
    lines += [f"  {'quasi' if i == 0 else '':8} {bar}: {why}" for i, (bar, (_, why)) in enumerate(quasi.items())]
    if scene.strain_choice is not None:
        lines.append(f"  {'strain':8} {scene.strain_choice.strain} ({scene.strain_choice.reason})")
    if not scene.drivers:
        lines.append(f"  {'driver':8} none")
    for i, drv in enumerate(scene.drivers):
        head = ("driver" if len(scene.drivers) == 1 else "drivers") if i == 0 else ""
        if drv.kind == "angle":
            if drv.law is not None:
                motion = f"{drv.initial:.6g} + ({drv.law}) rad, tau = omega t"
            elif si:
                motion = f"{drv.initial:.6g} rad + {drv.rate * scene.omega:.6g} rad/s t"
            else:
                motion = f"{drv.initial:.6g} + {drv.rate:.6g} tau"
            lines.append(f"  {head:8} angle of {drv.body}: {motion}")
        elif si and isinstance(drv.torque, float):
            lines.append(f"  {head:8} torque on {drv.body}: {drv.torque * moment:.6g} N m")
        else:
            unit = " x m_ref l0^3 omega^2, tau = omega t" if si else ""
            lines.append(f"  {head:8} torque on {drv.body}: {drv.torque}{unit}")
        if drv.rotor_inertia:
            lines.append(f"  {'':8} rotor inertia {drv.rotor_inertia:.6g} (/ m_ref l0^3)")
    for i, pm in enumerate(scene.masses):
        mass = f"{'masses' if i == 0 else '':8} masses[{i}]: {pm.mass:.6g} on {pm.body} at xi = {pm.xi:.6g}"
        if pm.inertia:
            mass += f", rotary inertia {pm.inertia:.6g}"
        if pm.offset is not None:
            mass += f", offset [{pm.offset[0]:.6g}, {pm.offset[1]:.6g}] (a rigid attachment)"
        lines.append(f"  {mass}")
    if scene.loads:
        lines.append(f"  {'loads':8} {len(scene.loads)} on " + ", ".join(sorted({ld.body for ld in scene.loads})))
    gx, gy = scene.effects.gravity
    if si and (gx or gy):
        g = scene.l0 * scene.omega**2
        lines.append(f"  {'gravity':8} [{gx * g:.6g}, {gy * g:.6g}] m/s^2")
    elif gx or gy:
        lines.append(f"  {'gravity':8} [{gx:.6g}, {gy:.6g}] (g / (l0 omega^2))")
    lines.append(f"  {'outputs':8} " + ", ".join(f"{o.name} ({o.kind})" for o in scene.outputs))
    sim = scene.simulation
    rows = math.floor(sim.t_end / sim.output_step + 1e-9) + 1
    if si:
        run = (
            f"duration {sim.t_end / scene.omega:.6g} s (t_end {sim.t_end:.6g} tau), "
            f"output interval {sim.output_step / scene.omega:.6g} s"
        )
    else:
        run = f"t_end {sim.t_end:.6g} tau, output step {sim.output_step:.6g}"
    lines.append(f"  {'run':8} {run} ({rows} rows), accuracy {sim.accuracy:g} of peak")
    lines.append(f"  {'':8} {describe_tolerances(sim)}")
    return "\n".join(lines)
