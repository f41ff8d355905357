"""What ``bodies.<name>.quasi_static_transverse`` asks of each bar, and why, in words: the
sidecar's ``quasi_static_transverse`` entry and a line of ``symgen effects``
(docs/quasi-static-modes.md). The treatment itself is the run's (``symgen.numerics.mechanism``)."""

from __future__ import annotations

from symgen.scene.model import Scene


#: said of every bar's quasi-static functions (symgen's choice or the file's): the paths that treat them
C_PATH = "IDAS and the emitted C solver (--solver c, emit-c, emit-fmu) alike"


def quasi_static_reasons(scene: Scene) -> dict[str, tuple[int, str]]:
    """bar -> (number of its quasi-static transverse functions, one sentence) for every bar that
    has any, and for every bar whose quasi-static functions symgen chose
    (``symgen.scene.bases.quasi_choice``; its reason, also where it chose none)."""
    choices = {c.bar: c for c in scene.bases}
    out: dict[str, tuple[int, str]] = {}
    for body in scene.bodies:
        k = body.quasi_static_transverse
        c = choices.get(body.name)
        if not body.rigid and c is not None and c.quasi_reason and c.quasi == k:  # symgen's choice
            out[body.name] = (
                k,
                f"chosen: {c.quasi_reason}" + (f"; quasi-static in {C_PATH}" if k or c.quasi_axial else ""),
            )
            continue
        if body.rigid or not k:
            continue
        nt = body.transverse_modes
        text = (
            f"the highest {k} of its {nt} transverse functions are quasi-static "
            f"(bodies.{body.name}.quasi_static_transverse = {k}): their stiffness and every load on them, "
            "the inertia loads of the rigid motion and of the other functions included, but no inertia "
            f"of their own: algebraic amplitudes, no eigenvalues for the integrator to follow ({C_PATH})"
        )
        if c is not None and c.omega_bending:
            dyn = c.dynamic[1]
            text += f"; the bases' dynamic band holds {dyn} bending mode{'s' if dyn != 1 else ''}"
            first = nt - k  # index of the first quasi-static function (0-based)
            if first < len(c.omega_bending):
                ratio = c.omega_run / c.omega_bending[first]
                text += (
                    f", the first quasi-static one at w = {c.omega_bending[first]:.4g} against the run's "
                    f"{c.omega_run:.4g} (its static response misses r^2 = {ratio**2:.2g} of it)"
                )
            if first < dyn:
                text += "; WARNING: it treats modes of the dynamic band statically"
        out[body.name] = (k, text)
    return out
