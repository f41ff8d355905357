"""``effects.strain = "auto"`` (the default): which bar formulation a scene gets, and why.

The choice is made in two steps (docs/exact-bars.md, "Choosing the bar: strain = auto"):

* here, when the scene is loaded: "auto" becomes von Karman, the formulation every command
  derives, prints and emits (``symgen derive``, ``latex``, ``check``, ``effects``, the C code):
  the same model, with the same cache key, as ``strain = "von_karman"`` written in the file;
* after a run (``symgen simulate``, :func:`symgen.api.simulate_scene`;
  :mod:`symgen.numerics.strain_choice`): when the run's model-form estimate
  (:mod:`symgen.numerics.model_form`, the curvature terms von Karman leaves out) exceeds
  ``simulation.accuracy`` on any output, the scene is run again with the exact bar, and the
  run's sidecar says so with the estimate. The decision is remembered (signed cache), so a rerun
  of the same scene goes to the exact bar directly.

A scene that cannot take the exact bar (a slot joint, ``geometric_stiffening = false``) keeps
von Karman and says why. The record :class:`StrainChoice` travels on ``Scene.strain_choice``.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["AUTO", "StrainChoice", "choose_strain", "exact_refused"]

AUTO = "auto"


@dataclass(frozen=True)
class StrainChoice:
    """The bar formulation of a scene and why: ``requested`` as written ("auto" or a value),
    ``strain`` the one used, ``reason`` one sentence; ``switchable``: a run may still switch
    to the exact bar (an "auto" scene whose run has not estimated its model form yet);
    ``estimate``: the largest model-form estimate of von Karman that decided (fraction of peak,
    on ``output``), None before a run."""

    requested: str
    strain: str
    reason: str
    switchable: bool = False
    estimate: float | None = None
    output: str = ""
    accuracy: float | None = None

    def as_dict(self) -> dict:
        """The sidecar's ``strain`` entry (JSON)."""
        return {
            "requested": self.requested,
            "strain": self.strain,
            "reason": self.reason,
            "von_karman_model_form": self.estimate,
            "output": self.output,
            "accuracy": self.accuracy,
        }


def exact_refused(geometric_stiffening: bool, slots: list[str]) -> str:
    """Why the exact bar is not available to a scene ("" when it is)."""
    if not geometric_stiffening:
        return "geometric_stiffening = false (the exact curvature and the von Karman strain are one expansion)"
    if slots:
        return (
            f"a slot joint ({', '.join(slots)}): it has no slot-guide form (a guide's curvature is kept to "
            "fourth order whatever the strain)"
        )
    return ""


def choose_strain(requested: str, geometric_stiffening: bool, slots: list[str]) -> StrainChoice:
    """The formulation a loaded scene derives (see the module docstring)."""
    if requested != AUTO:
        return StrainChoice(requested, requested, f'effects.strain = "{requested}"')
    refused = exact_refused(geometric_stiffening, slots)
    if refused:
        return StrainChoice(AUTO, "von_karman", f"auto: von Karman; the exact bar is not available with {refused}")
    return StrainChoice(
        AUTO,
        "von_karman",
        "auto: von Karman until a run's model-form estimate (the curvature and strain terms it leaves out) exceeds "
        "simulation.accuracy on an output; then the run is made with the exact bar",
        switchable=True,
    )
