"""Slots: a bar point sliding along an elastic guide with a variable support distance beta.

Oracles: the simply supported beam ((k pi)^2 sqrt(mu) for a span equal to the guide), an
independent Rayleigh-Ritz computation of the frozen-beta guide by numerical quadrature, the
symgen pinned-pinned bar of the same span, and a hand estimate of the slider mass's effect.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from symgen.api import mechanism, simulate_scene
from symgen.ir.records import CoordKind
from tests.oracles import write_scene

FROZEN = """
[scene]
name = "frozen_slot"
[[bodies]]
name = "post"
length = 1.0
rigid = true
[[bodies]]
name = "guide"
length = {L}
mu = {mu}
frame = "pinned-pinned"
axial_modes = 0
transverse_modes = 3
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "post"]
at = [[{d}, -1.0], 0.0]
[[joints]]
name = "P"
kind = "pin"
bodies = ["ground", "guide"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "S"
kind = "slot"
bodies = ["post", "guide"]
at = [1.0, "variable"]
overhang = "{overhang}"
[driver]
kind = "angle"
body = "post"
initial = 1.5707963267948966
rate = 0.0
[initial]
guess = {{ guide = 0.0, S = {beta} }}
[outputs]
w = {{ kind = "deflection", body = "guide", at = 0.3 }}
[simulation]
t_end = 0.1
output_step = 0.05
"""


def frozen_frequencies(tmp_path, L, d, mu, overhang="rigid"):
    """Linear frequencies of the guide's amplitudes with the contact held at distance d
    (the seed's rigid overhang unless told: the tests below check that form)."""
    path = write_scene(tmp_path / "frozen.toml", FROZEN.format(L=L, d=d, mu=mu, beta=d / L, overhang=overhang))
    mech = mechanism(path)
    q, v, a, lam, part = mech.initial_state()
    beta = q[[c.kind for c in mech.coords].index(CoordKind.BETA)]
    amp = list(mech.info.indices(CoordKind.G))
    n, h = len(amp), 1e-7
    K, M = np.zeros((n, n)), np.zeros((n, n))
    r0 = mech.call("res", 0.0, q, v, a, lam)[amp]
    for j, i in enumerate(amp):
        dq = q.copy()
        dq[i] += h
        K[:, j] = (mech.call("res", 0.0, dq, v, a, lam)[amp] - r0) / h
        da = a.copy()
        da[i] += 1.0
        M[:, j] = mech.call("res", 0.0, q, v, da, lam)[amp] - r0
    return beta, np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))


def test_contact_at_the_end_is_the_simply_supported_beam(tmp_path):
    mu = 0.8
    beta, w = frozen_frequencies(tmp_path, L=2.0, d=2.0, mu=mu)
    assert beta == pytest.approx(1.0, abs=1e-12)
    expected = [(k * math.pi) ** 2 * math.sqrt(mu) for k in (1, 2, 3)]
    np.testing.assert_allclose(w, expected, rtol=1e-6)


def test_frozen_slot_equals_pinned_pinned_bar_of_that_span(tmp_path):
    """The same span as a plain pinned-pinned bar (pin + slider along its axis) in symgen."""
    mu = 0.8
    _, w_slot = frozen_frequencies(tmp_path, L=2.0, d=2.0, mu=mu)
    plain = f"""
[scene]
name = "plain"
[[bodies]]
name = "beam"
length = 2.0
mu = {mu}
frame = "pinned-pinned"
axial_modes = 0
transverse_modes = 3
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "beam"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "B"
kind = "slider"
bodies = ["beam", "ground"]
at = [1.0, [2.0, 0.0]]
direction = [1.0, 0.0]
[outputs]
w = {{ kind = "deflection", body = "beam", at = 0.3 }}
[simulation]
t_end = 0.1
output_step = 0.05
"""
    mech = mechanism(write_scene(tmp_path / "plain.toml", plain))
    q, v, a, lam, _ = mech.initial_state()
    amp = list(mech.info.indices(CoordKind.G))
    r0 = mech.call("res", 0.0, q, v, a, lam)[amp]
    K = np.column_stack(
        [(mech.call("res", 0.0, q + 1e-7 * np.eye(len(q))[i], v, a, lam)[amp] - r0) / 1e-7 for i in amp]
    )
    M = np.column_stack([mech.call("res", 0.0, q, v, a + np.eye(len(q))[i], lam)[amp] - r0 for i in amp])
    w_plain = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    np.testing.assert_allclose(w_slot, w_plain, rtol=1e-6)


@pytest.mark.parametrize("d", [0.9, 1.4])
def test_frozen_slot_with_overhang_matches_independent_rayleigh_ritz(tmp_path, d):
    """Contact inside the guide (overhang beyond it): the generated equations against a
    Rayleigh-Ritz model built here by numerical quadrature of the same admissible functions
    (sin(k pi xi / beta) on the span, tangent continuation on the overhang)."""
    L, mu = 2.0, 0.8
    beta, w = frozen_frequencies(tmp_path, L=L, d=d, mu=mu)
    assert beta == pytest.approx(d / L, abs=1e-12)

    def psi(k, x, der=0):
        a = k * math.pi / beta
        if x <= beta:
            return [math.sin(a * x), a * math.cos(a * x), -a * a * math.sin(a * x)][der]
        slope = a * math.cos(k * math.pi)
        return [slope * (x - beta), slope, 0.0][der]

    n = 3
    M = np.array(
        [
            [
                quad(lambda x: psi(i, x) * psi(j, x), 0, beta)[0] + quad(lambda x: psi(i, x) * psi(j, x), beta, 1)[0]
                for j in range(1, n + 1)
            ]
            for i in range(1, n + 1)
        ]
    )
    K = mu * np.array(
        [
            [quad(lambda x: psi(i, x, 2) * psi(j, x, 2), 0, beta, limit=200)[0] for j in range(1, n + 1)]
            for i in range(1, n + 1)
        ]
    )
    expected = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    np.testing.assert_allclose(w, expected, rtol=1e-6)


def test_inverted_slider_crank_closes_over_ten_turns():
    res = simulate_scene(
        "examples/inverted_slider_crank.toml", ["simulation.cycles=10", "simulation.output_step=0.0698131700797732"]
    )
    assert res.tau[-1] == pytest.approx(20 * math.pi)
    assert res.closure_max <= 1e-10
    # the guide swings +-30 degrees (asin(crank / pivot distance) = asin(1/2))
    assert np.abs(res.column("guide_angle")).max() == pytest.approx(math.pi / 6, abs=2e-3)


def test_slider_mass_stretches_the_crank_as_the_hand_estimate_says():
    """Hand estimate: the slider (mass m_s at the crank tip, radius 1, crank at constant rate 1)
    needs the centripetal force m_s * 1 * 1^2 along the crank; the slot, frictionless, cannot
    supply it, so the crank carries it as an extra tip tension: its tip elongation grows by
    m_s / lambda on average (uniform bar under a tip force: u(l) = F l / EA). Transverse
    response: the slider's inertia is radial, so the crank's bending changes little."""
    overrides = ["simulation.cycles=1"]
    light = simulate_scene("examples/inverted_slider_crank.toml", overrides + ["joints.A.mass=0.0"])
    heavy = simulate_scene("examples/inverted_slider_crank.toml", overrides + ["joints.A.mass=0.25"])
    lam = 1.0e5
    delta = np.mean(heavy.column("crank_tip_axial")) - np.mean(light.column("crank_tip_axial"))
    assert delta == pytest.approx(0.25 / lam, rel=0.1)
    assert delta > 0
