"""The quasi-static form's fallback (symgen.numerics.quasi_fallback) without the slow run that
meets the impasse (tests/test_quasi_static_impasse.py runs it): each family of quasi-static
functions on its own (a stated key stays while symgen's own axial choice is made dynamic), and
the fallback remembered for the scene, so that its next run loads the all-dynamic model at once.

Scene: benchmarks/scenes/crank_rocker_steel_900.toml, whose crank gets 2 axial functions
quasi-static from the bases chooser (symgen's choice: no key states them).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from symgen.api import scene_of
from symgen.numerics import quasi_fallback as qf
from symgen.numerics.strain_choice import resolved
from symgen.scene.limits import SceneWarning

SCENE = Path(__file__).parent.parent / "benchmarks" / "scenes" / "crank_rocker_steel_900.toml"
STATED = ["bodies.crank.quasi_static_transverse=1"]


class _Impasse(Exception):
    """A failure as ``simulate._quasi_failure`` marks it at the impasse."""

    def __init__(self, bars: tuple[str, ...]) -> None:
        super().__init__("impasse")
        self.quasi_bars, self.tau, self.quasi_ratio = bars, 2.5, 0.01


def _crank(scene):
    body = next(b for b in scene.bodies if b.name == "crank")
    record = next(c for c in scene.bases if c.bar == "crank")
    return body, record


def test_a_stated_family_stays_where_symgen_chose_the_other():
    """A stated ``quasi_static_transverse`` beside axial functions symgen made quasi-static (the
    loader's chooser leaves a bar with a stated key alone; the error estimate's richer model adds
    quasi-static axial functions to any bar: the record forced here as that one's)."""
    from dataclasses import replace

    scene = scene_of(SCENE, STATED)
    scene = replace(scene, bases=tuple(replace(c, quasi_axial=2) if c.bar == "crank" else c for c in scene.bases))
    body, record = _crank(scene)
    assert record.quasi_axial == 2 and body.quasi_static_transverse == 1  # the premise
    assert qf.chosen_quasi(scene) == {"crank": (False, True)}
    after = qf.without_chosen_quasi(scene, "why")
    body, record = _crank(after)
    assert body.quasi_static_transverse == 1  # stated: kept
    assert record.quasi_axial == 0 and "axial functions symgen chose" in record.quasi_reason
    assert "transverse functions" not in record.quasi_reason
    # a failure only of the stated functions is not symgen's to change: no rerun
    mech = SimpleNamespace(scene=scene)
    runs: list[object] = []
    out = qf.run_with_quasi_fallback(
        mech, None, _Impasse(("coupler",)), lambda s: SimpleNamespace(scene=s), lambda m: runs.append(m) or (1, None)
    )
    assert out[0] is mech and not runs


def test_the_fallback_is_remembered_for_the_scene(monkeypatch, tmp_path):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    scene = scene_of(SCENE, [])
    assert qf.chosen_quasi(scene) == {"crank": (False, True)}
    assert resolved(scene) is scene or _crank(resolved(scene))[1].quasi_axial == 2  # nothing remembered yet
    loaded: list[object] = []

    def load(s):
        loaded.append(s)
        return SimpleNamespace(scene=s)

    with pytest.warns(SceneWarning, match="quasi-static form met its impasse at tau = 2.5"):
        mech, result, failure = qf.run_with_quasi_fallback(
            SimpleNamespace(scene=scene), None, _Impasse(("crank",)), load, lambda m: ("done", None)
        )
    assert (result, failure) == ("done", None) and _crank(mech.scene)[1].quasi_axial == 0
    # the next run of the same scene: the all-dynamic model at once, said so
    again = resolved(scene_of(SCENE, []))
    record = _crank(again)[1]
    assert record.quasi_axial == 0 and "remembered from an earlier run" in record.quasi_reason
    assert qf.chosen_quasi(again) == {}
    # another scene (another hash) is not this decision
    other = scene_of(SCENE, ["simulation.accuracy=0.005"])
    assert _crank(resolved(other))[1].quasi_axial == _crank(other)[1].quasi_axial
    # a cache emptied: decided again (the impasse met first)
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "other"))
    assert _crank(resolved(scene_of(SCENE, [])))[1].quasi_axial == 2
