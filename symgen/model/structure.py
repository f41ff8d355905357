"""What shapes a derived model: the scene's *structure* (topology, effects, mode counts, shape
families, outputs) as the typed record :class:`symgen.ir.spec.ModelSpec` (:func:`model_spec`),
and the cache key made from it. Values (lambda, mu, lengths, rates, loads) are not part of it:
changing them reuses the cached model.

Kept free of SymPy so that a cached run never imports it.
"""

from __future__ import annotations

from dataclasses import dataclass

from symgen import __version__
from symgen.ir.spec import (
    DYNAMIC,
    INEXTENSIBLE,
    QUASI_STATIC,
    BodySpec,
    DriverSpec,
    EffectsSpec,
    EndSpec,
    JointSpec,
    LoadSpec,
    MassSpec,
    ModelSpec,
    OutputSpec,
    spec_key,
)
from symgen.scene.bases import DRIVER_HARMONICS as DRIVER_HARMONICS  # home: symgen.scene.bases (re-exported)
from symgen.scene.bases import POINT_TOL as POINT_TOL
from symgen.scene.bases import AXIAL_FIRST as AXIAL_FIRST
from symgen.scene.bases import AXIAL_SEPARATION as AXIAL_SEPARATION
from symgen.scene.bases import BENDING_FIRST as BENDING_FIRST
from symgen.scene.bases import axial_ringing, axial_separation
from symgen.scene.bases import interior_points as interior_points
from symgen.scene.model import GROUND, Scene

DERIVE_VERSION = "14"  # 14: an axially rigid slot guide has the kinetic energy of its shortening at the rate of its amplitudes (Z); 13: an axially rigid slot guide bends with its curvature to fourth order, (mu/2) int eta'^2 eta''^2 (E4); 12: an axially rigid slot guide's tension (rigid-body axial inertia and load, axial point forces, bars hanging from it) stiffens its bending (T1, T2, H<xi>), its Kelvin-Voigt damping acts on the beta_dot part of its curvature rate too (Kb, Kbb); 11: a slot guide with an elastic overhang: span functions zero beyond the contact (zero slope there) and the contact-slope function chi_0 (symgen.model.slot); 10: the exact bar's sums over E6 and C5 at Gauss nodes where that is cheaper (the same polynomials); 9: the exact bar's strain energy with -(lambda/2) int (P eps)^2 eta'^2 (|r'| - 1 = eps (1 - eta'^2/2), table Q4); 8: the exact bar's strain to fourth order (eta'^4/8, table C5) and the damping of its curvature rate (H4); 7: the exact bar to sixth order (curvature eta'^4 eta''^2, strain eta'^4/8); 6: Kelvin-Voigt damping on the von Karman strain rate; 5: coordinate records carry their joint; 4: projected von Karman strain energy, per-bar axial treatment, rotary inertia


def effective_modes(scene: Scene, body) -> tuple[int, int]:
    """(axial, transverse) function counts of a bar; a slot guide's transverse count includes
    its overhang's own functions (``overhang_modes``, appended after the span's)."""
    if body.rigid:
        return 0, 0
    na = body.axial_modes if scene.effects.axial else 0
    nt = body.transverse_modes if scene.effects.transverse else 0
    return na, nt + (overhang_modes(scene, body) if nt else 0)


def overhang_modes(scene: Scene, body) -> int:
    """Number of a slot guide's functions after its span functions: with an elastic overhang the
    contact-slope function chi_0 and the overhang's ``overhang_modes`` own bending functions (0:
    rigid overhang, the seed's form, no bending, or not a guide; ``symgen.model.slot``)."""
    if body.rigid or not (scene.effects.transverse and body.transverse_modes):
        return 0
    return sum(
        j.overhang_modes + 1
        for j in scene.joints
        if j.kind == "slot" and j.ends[1].body == body.name and j.overhang_modes
    )


#: ``effects.axial = "auto"`` eliminates a bar's axial dynamics when its first axial frequency is
#: at least AXIAL_SEPARATION times the run's fastest motion (the frequencies and the constants:
#: :func:`symgen.scene.bases.axial_separation`, re-exported here), when the start's axial ringing
#: is within the accuracy (:func:`symgen.scene.bases.axial_ringing`), and only when its stretch
#: cannot strain a closed loop: the quasi-static treatment adds the
#: stretch N/lambda to the outputs but not to the loop's kinematics, so in a loop whose other
#: bars bend, the share of this bar's axial compliance in the loop's (its end-to-end l/EA against
#: the softest other bar's bending compliance under a joint force) must be negligible. Measured:
#: the steel four-bar (shares 0.13-0.28 %) is 3-7 % off its full dynamics when quasi-static;
#: the aluminium four-bar with 100x stiffer bars (shares <= 7.7e-5) 0.04 %.
LOOP_SHARE_MAX = 1e-4


@dataclass(frozen=True)
class AxialTreatment:
    """How one elastic bar's axial deformation is modelled, and why.

    ``treatment``: "dynamic" (axial amplitudes with inertia and the strain energy of the strain
    the basis can carry), "quasi_static" (no axial vibration: the inextensible constraint form,
    the amplitudes following the bending, the axial force N its multiplier, plus the stretch
    N/lambda where outputs read the bar's shape),
    "inextensible" (lambda -> oo: no stretch) or "off" (no axial functions)."""

    bar: str
    treatment: str
    reason: str
    omega_axial: float | None = None
    omega_run: float | None = None


def axial_treatments(scene: Scene) -> dict[str, AxialTreatment]:
    """The treatment of every elastic bar (rigid bars are not listed)."""
    return {b.name: axial_treatment(scene, b) for b in scene.bodies if not b.rigid}


def axial_treatment(scene: Scene, body) -> AxialTreatment:
    eff = scene.effects
    na, _ = effective_modes(scene, body)
    if not na:
        why = "effects.axial = false" if eff.axial is False else "no axial functions (axial_modes = 0)"
        return AxialTreatment(body.name, "off", why)
    if eff.axial == INEXTENSIBLE:
        return AxialTreatment(body.name, INEXTENSIBLE, 'effects.axial = "inextensible"')
    if eff.axial == QUASI_STATIC:
        return AxialTreatment(body.name, QUASI_STATIC, 'effects.axial = "quasi_static"')
    if eff.axial is True or eff.axial == DYNAMIC:
        written = "true" if eff.axial is True else '"dynamic"'
        return AxialTreatment(body.name, DYNAMIC, f"effects.axial = {written}")
    if eff.strain == "linear":
        return AxialTreatment(
            body.name, DYNAMIC, "auto: the seed's linear strain keeps its axial dynamics (the paper's model)"
        )
    kept = dict(scene.axial_kept)
    if body.name in kept:
        return AxialTreatment(body.name, DYNAMIC, kept[body.name])
    if slot_guide(scene, body.name):
        return AxialTreatment(body.name, DYNAMIC, "auto: slot guide")
    w_axial, w_run, w_bend = axial_separation(scene, body)
    ratio = w_axial / w_run
    detail = (
        f"first axial frequency {w_axial:.4g} = {ratio:.3g} x the fastest motion to resolve {w_run:.4g} "
        f"(max of 2 x first bending {w_bend:.4g}, {DRIVER_HARMONICS:g} x driver rate), per unit tau"
    )
    share, softest = loop_stretch_share(scene, body)
    if ratio >= AXIAL_SEPARATION and share > LOOP_SHARE_MAX:
        return AxialTreatment(
            body.name,
            DYNAMIC,
            f"auto: {detail}, but in a closed loop its stretch is "
            f"{share:.2g} of the compliance against the bending of {softest} (> {LOOP_SHARE_MAX:g}): "
            "axial dynamics kept",
            w_axial,
            w_run,
        )
    ring = axial_ringing(scene, body, scene.initial.quasi_static)
    if ratio >= AXIAL_SEPARATION and ring.estimate > scene.simulation.accuracy:
        return AxialTreatment(
            body.name,
            DYNAMIC,
            f"auto: {detail} >= {AXIAL_SEPARATION:g}, but {ring.reason}, above simulation.accuracy "
            f"{scene.simulation.accuracy:g}: axial dynamics kept",
            w_axial,
            w_run,
        )
    if ratio >= AXIAL_SEPARATION:
        return AxialTreatment(
            body.name,
            QUASI_STATIC,
            f"auto: {detail} >= {AXIAL_SEPARATION:g}: axial dynamics eliminated",
            w_axial,
            w_run,
        )
    return AxialTreatment(
        body.name, DYNAMIC, f"auto: {detail} < {AXIAL_SEPARATION:g}: axial dynamics kept", w_axial, w_run
    )


def loop_stretch_share(scene: Scene, body) -> tuple[float, str]:
    """(share, softest other bar): in a closed loop, the end-to-end axial compliance of ``body``
    (l/EA = 1/(lambda nu alpha) in l0 per m_ref l0^2 omega^2) against the bending compliance of
    the softest other elastic bar under a joint force (cantilever tip l^3/3EI, pinned mid-span
    l^3/48EI, EI = mu nu alpha^4). 0 without loops or without other bending bars."""
    if len(scene.joints) <= len(scene.bodies) or not body.lam:
        return 0.0, ""
    others = [b for b in scene.bodies if b is not body and not b.rigid and b.mu and b.transverse_modes]
    if not others:
        return 0.0, ""

    def bending(b) -> float:
        return (1 / 3 if b.frame == "cantilever" else 1 / 48) / (b.mu * b.nu * b.alpha)

    soft = max(others, key=bending)
    ca = 1.0 / (body.lam * body.nu * body.alpha)
    return ca / (ca + bending(soft)), soft.name


def slot_guide(scene: Scene, name: str) -> bool:
    return any(j.kind == "slot" and any(e.body == name and e.variable for e in j.ends) for j in scene.joints)


def _tip_joint(scene: Scene, name: str) -> bool:
    """A joint or a ``[[masses]]`` entry acts at the bar's far end (xi = 1)."""
    if any(m.body == name and abs(m.xi - 1.0) < 1e-12 for m in scene.masses):
        return True
    return any(e.body == name and e.xi is not None and abs(e.xi - 1.0) < 1e-12 for j in scene.joints for e in j.ends)


def moment_points(scene: Scene, name: str) -> tuple[float, ...]:
    """The interior points of bar ``name`` (those of :func:`interior_points`) where a point
    MOMENT acts too: a ``[[masses]]`` entry with a rotary inertia or an offset arm, a joint with
    a rotary inertia carried by the bar (both turn with the cross-section, so their inertia acts
    through the section's rotation)."""
    xs = [m.xi for m in scene.masses if m.body == name and (m.inertia > 0 or m.offset is not None)]
    for j in scene.joints:
        if j.inertia > 0:
            end = next((e for e in j.ends if e.body != GROUND), None)
            if end is not None and end.body == name and end.xi is not None and not end.variable:
                xs.append(end.xi)
    return tuple(x for x in interior_points(scene, name) if any(abs(x - float(y)) < POINT_TOL for y in xs))


def static_points(scene: Scene, body) -> dict:
    """``{"transverse": (...), "axial": (...), "moment": (...)}``: where the bar gets static
    correction functions (``bodies.<name>.static_correction``, default on): at its interior
    points, transverse when it bends, axial when it keeps its axial dynamics (a quasi-static or
    inextensible bar's axial amplitudes are constrained by the bending, they carry no point force
    of their own); a transverse moment correction too where a point moment acts
    (:func:`moment_points`). Empty dict when none; no "moment" key when no moment acts."""
    if body.rigid or body.static_correction is False or slot_guide(scene, body.name):
        return {}
    pts = interior_points(scene, body.name)
    if not pts:
        return {}
    na, nt = effective_modes(scene, body)
    out = {}
    if nt:
        out["transverse"] = pts
        moments = moment_points(scene, body.name)
        if moments:
            out["moment"] = moments
    if na and axial_treatment(scene, body).treatment == DYNAMIC:
        out["axial"] = pts
    return out


def basis_sizes(scene: Scene, body) -> tuple[int, int]:
    """(axial, transverse) numbers of amplitudes of a bar: its functions and its static corrections."""
    na, nt = effective_modes(scene, body)
    pts = static_points(scene, body)
    return na + len(pts.get("axial", ())), nt + len(pts.get("transverse", ())) + len(pts.get("moment", ()))


def model_spec(scene: Scene) -> ModelSpec:
    """The typed input of the derivation: everything of ``scene`` that shapes the derived
    equations (and nothing that is only a value)."""
    eff = scene.effects
    bodies = []
    for b in scene.bodies:
        na, nt = effective_modes(scene, b)
        pts = static_points(scene, b)
        bodies.append(
            BodySpec(
                b.name,
                b.rigid,
                b.frame,
                na,
                nt,
                b.axial_shapes if na else "",
                b.transverse_shapes if nt else "",
                _tip_joint(scene, b.name) if nt else False,
                tuple(pts.get("axial", ())),
                tuple(pts.get("transverse", ())),
                tuple(pts.get("moment", ())),
            )
        )
    joints = tuple(
        JointSpec(
            j.name,
            j.kind,
            tuple(EndSpec(e.body, e.xi) for e in j.ends),
            j.mass > 0,
            j.inertia > 0,
            (j.overhang, j.overhang_modes) if j.kind == "slot" else None,
        )
        for j in scene.joints
    )
    drv = tuple(
        DriverSpec(
            d.kind,
            d.body,
            d.torque if isinstance(d.torque, str) else "const",
            d.law,
            d.ramp is not None,
            d.rotor_inertia > 0,
        )
        for d in scene.drivers
    )
    loads = tuple(
        LoadSpec(
            ld.body,
            ld.kind,
            ld.xi,
            ld.axial if isinstance(ld.axial, str) else "const",
            ld.transverse if isinstance(ld.transverse, str) else "const",
        )
        for ld in scene.loads
    )
    outputs = tuple(OutputSpec(o.name, o.kind, o.body, o.joint, o.xi, o.component) for o in scene.outputs)
    treat = axial_treatments(scene)
    axial = None
    if any(t.treatment in (QUASI_STATIC, INEXTENSIBLE) for t in treat.values()):
        axial = tuple((name, t.treatment) for name, t in sorted(treat.items()))
    effects = EffectsSpec(
        eff.coriolis,
        eff.geometric_stiffening,
        eff.rotary_inertia,
        eff.strain,
        any(x != 0 for x in eff.gravity),
        eff.damping > 0,
        axial,
    )
    masses = tuple(MassSpec(m.body, m.xi, m.mass > 0, m.inertia > 0, m.offset is not None) for m in scene.masses)
    return ModelSpec((__version__, DERIVE_VERSION), tuple(bodies), joints, drv, effects, loads, outputs, masses)


def structure_of(scene: Scene) -> dict:
    """The canonical JSON of :func:`model_spec` (what the cache key hashes, what a derived
    model and its cache entry carry as ``structure``)."""
    return model_spec(scene).to_json()


def structure_key(structure: ModelSpec | dict) -> str:
    """The model cache's key of a spec or of its canonical JSON (a cache entry's ``structure``)."""
    return spec_key(structure.to_json() if isinstance(structure, ModelSpec) else structure)
