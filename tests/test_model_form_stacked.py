"""The model-form estimate's coupled modes along the run, computed for all samples at once
(symgen.numerics.model_form._modes_along: one mapped call of the KKT system and of the modal
Function, stacked factorizations; issue 20), are those of symgen.numerics.model_form._modes_at at
each sample one at a time, to the rounding: two hinged elastic bars with a closure, at states
whose bending amplitudes and rates are moved at random (their axial forces buckle some of the
modes: the samples keep different numbers of modes), and with their rest state among them (its
closure Jacobian has another rank: the samples are taken one at a time)."""

from __future__ import annotations

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.ir.records import CoordKind
from symgen.numerics import model_form
from symgen.scene import load_scene
from tests.test_model_form_drift import HINGED


@pytest.fixture(scope="module")
def hinged(tmp_path_factory):
    path = tmp_path_factory.mktemp("stacked") / "h.toml"
    path.write_text(HINGED)
    mech = mechanism(load_scene(path))
    q0, v0 = mech.initial_guess()
    rng = np.random.default_rng(1)
    S = 7
    g = [i for i, c in enumerate(mech.coords) if c.kind is CoordKind.G]
    Q, V = np.repeat(q0[None], S, axis=0), np.repeat(v0[None], S, axis=0)
    Q[1:, g] += 1e-3 * rng.standard_normal((S - 1, len(g)))
    V[1:, g] += 1e-2 * rng.standard_normal((S - 1, len(g)))
    return mech, np.linspace(0.0, 0.5, S), Q, V


def _same_as_each_sample(mech, t, Q, V, got):
    modal = model_form._modal_function(mech)
    assert got is not None
    count = got[0].shape[1]
    assert count >= 1
    for i in range(len(t)):
        ref = model_form._modes_at(mech, float(t[i]), Q[i], V[i], modal)
        for a, b, name in zip(got, ref, ("w", "phi", "M phi", "dlam")):
            b = b[:count] if name == "w" else b[:, :count]
            assert a[i].shape == b.shape, name
            assert np.allclose(a[i], b, rtol=1e-12, atol=1e-12 * np.abs(b).max()), (name, i)
    return count


def test_the_stacked_coupled_modes_are_those_of_each_sample(hinged, monkeypatch):
    mech, t, Q, V = hinged
    modal = model_form._modal_function(mech)
    assert model_form._modal_function(mech) is modal  # made once per mechanism
    kept = [len(model_form._modes_at(mech, float(t[i]), Q[i], V[i], modal)[0]) for i in range(1, len(t))]
    assert len(set(kept)) > 1  # the samples keep different numbers of modes

    def refused(*args, **kwargs):
        raise AssertionError("the samples were taken one at a time")

    monkeypatch.setattr(model_form, "_modes_one_by_one", refused)
    got = model_form._modes_along(mech, t[1:], Q[1:], V[1:], modal)
    assert _same_as_each_sample(mech, t[1:], Q[1:], V[1:], got) == min(kept)


def test_samples_whose_closure_rank_differs_are_taken_one_at_a_time(hinged):
    mech, t, Q, V = hinged
    got = model_form._modes_along(mech, t, Q, V, model_form._modal_function(mech))
    _same_as_each_sample(mech, t, Q, V, got)
