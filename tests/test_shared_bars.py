"""Bars of one structure derived once (``bars.SharedBarEquations``): the model is the one each bar's
own derivation gives, expression for expression (the same SymPy trees, hence the same emitted code),
display forms and their tables included; bars whose substituted values differ are derived themselves."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from symgen.model import bars as B
from symgen.model.bars import BarEquations
from symgen.model.derive import derive
from symgen.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_derivation import scene_text  # noqa: E402

INSTANTIATE = B._instantiate


def _derive(scene, share: bool, monkeypatch):
    monkeypatch.setattr(B, "SHARE_BARS", share)
    made = {"shared": 0, "own": 0}

    def counted(*args):
        out = INSTANTIATE(*args)
        made["shared" if out is not None else "own"] += 1
        return out

    monkeypatch.setattr(B, "_instantiate", counted)
    return derive(scene), made


def _assert_same(m0, m1) -> None:
    p0, p1 = m0.program, m1.program
    assert p0.inputs == p1.inputs
    assert p0.assignments == p1.assignments
    assert p0.groups == p1.groups
    assert list(p0.outputs) == list(p1.outputs)
    for k in p0.outputs:
        assert list(p0.outputs[k]) == list(p1.outputs[k]), k
    assert m0.params == m1.params
    assert list(m0.latex.items()) == list(m1.latex.items())  # the names recorded, in order
    fields = BarEquations.EXPRESSIONS + ("sym", "xa_d", "ya_d")
    for name in m0.bars:
        e0, e1 = m0.bars[name].equations, m1.bars[name].equations
        for f in fields + ("points", "loads"):
            assert getattr(e0, f) == getattr(e1, f), (name, f)
        for f in fields:
            assert getattr(e0.display, f) == getattr(e1.display, f), (name, f, "display")
        assert list(e0.values.items()) == list(e1.values.items()), name
        assert list(e0.inner_products.items()) == list(e1.inner_products.items()), name


@pytest.mark.parametrize(
    "sets",
    [
        [],
        ["effects.gravity=[0.3, -1.0]", "effects.damping=0.01", "effects.rotary_inertia=true"],
        ["effects.axial=inextensible"],
        ["effects.strain=exact"],
    ],
    ids=["von_karman", "gravity_damping_rotary", "inextensible", "exact"],
)
def test_chain_shares_and_equals_its_own_derivation(tmp_path, monkeypatch, sets):
    path = tmp_path / "chain3.toml"
    path.write_text(scene_text("chain", 3, 2, 3))
    scene = load_scene(path, sets)
    own, made0 = _derive(scene, False, monkeypatch)
    shared, made1 = _derive(scene, True, monkeypatch)
    assert made0 == {"shared": 0, "own": 0}
    assert made1 == {"shared": 2, "own": 0}  # b2, b3 from b1
    _assert_same(own, shared)


def test_reactions_on_a_bar_are_derived_by_that_bar(monkeypatch):
    """The four-bar's coupler and rocker carry the cut joint's reaction (a point force of their
    own): not the same values, so each is derived itself; the model is the same."""
    scene = load_scene(ROOT / "examples" / "four_bar.toml")
    own, _ = _derive(scene, False, monkeypatch)
    shared, made = _derive(scene, True, monkeypatch)
    assert made["own"] >= 1
    _assert_same(own, shared)
