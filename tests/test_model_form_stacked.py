"""The model-form estimate's coupled modes along the run, computed for all samples at once
(symgen.numerics.model_form._modes_along: one mapped call of the KKT system and of the modal
Function, stacked factorizations; issue 20), are those of symgen.numerics.model_form._modes_at at
each sample one at a time, to the rounding: two hinged elastic bars with a closure, at their rest
state and at states whose bending amplitudes and rates are moved at random (their axial forces
buckle some of the modes: the samples keep different numbers of modes)."""

from __future__ import annotations

import numpy as np

from symgen.api import mechanism
from symgen.ir.records import CoordKind
from symgen.numerics import model_form
from symgen.scene import load_scene

from tests.test_model_form_drift import HINGED


def test_the_stacked_coupled_modes_are_those_of_each_sample(tmp_path):
    path = tmp_path / "h.toml"
    path.write_text(HINGED)
    mech = mechanism(load_scene(path))
    q0, v0 = mech.initial_guess()
    rng = np.random.default_rng(1)
    S = 7
    g = [i for i, c in enumerate(mech.coords) if c.kind is CoordKind.G]
    Q, V = np.repeat(q0[None], S, axis=0), np.repeat(v0[None], S, axis=0)
    Q[1:, g] += 1e-3 * rng.standard_normal((S - 1, len(g)))
    V[1:, g] += 1e-2 * rng.standard_normal((S - 1, len(g)))
    t = np.linspace(0.0, 0.5, S)
    modal = model_form._modal_function(mech)
    assert model_form._modal_function(mech) is modal  # made once per mechanism
    stacked = model_form._modes_along(mech, t, Q, V, modal)
    one = model_form._modes_one_by_one(mech, t, Q, V, modal, model_form.MODES_KEPT)
    assert stacked is not None and one is not None
    count = stacked[0].shape[1]
    assert count >= 1
    assert len(model_form._modes_at(mech, 0.0, q0, v0, modal)[0]) > count  # the rest state keeps more
    for i in range(S):
        w, phi, Mphi, dlam = model_form._modes_at(mech, float(t[i]), Q[i], V[i], modal)
        assert np.array_equal(w[:count], one[0][i])
        for a, b, name in zip(stacked, (w, phi, Mphi, dlam), ("w", "phi", "M phi", "dlam")):
            ref = b[:count] if name == "w" else b[:, :count]
            assert a[i].shape == ref.shape, name
            assert np.allclose(a[i], ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max()), (name, i)
