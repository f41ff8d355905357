"""The model-form estimate near the Euler load (issue 19, item 2: an estimate that does not flatter).

The near-buckling column of tests/test_hard_cases.py (pinned, its far end on a slider along its
axis, a compressive end load r P_cr, a small uniform lateral load, mu 0.01, 3 + 3 functions,
quasi-static start), von Karman forced. Von Karman's model is the linear beam-column series here
(its own closed form, ``beam_column_midspan``; the run within 2.9e-6 of it at 0.99), so its
model-form error is the series against the inextensible large-deflection elastica
(``oracles.imperfect_elastica_midspan``): 4.2e-7, 2.7e-5, 1.9e-4, 8.5e-4 and 2.04e-2 of peak at
r = 0.5, 0.9, 0.95, 0.97, 0.99, the deflected shape's geometric stiffening amplified by
1 / (1 - r).

The estimate's static change carries that amplification through the bar's tangent stiffness
K = mu Kt - P C3 (symgen.numerics.model_form): uncapped (estimator 13) it reads 1.00x the
elastica's difference at 0.5 .. 0.97 and 1.07x at 0.99 with lambda = 1e8; capped at 20 (estimator
12) it read 0.54x at 0.97 and 0.19x at 0.99 (lambda 1e8; 1e4: 3.7e-3 against 2.04e-2, 0.18x).

The inextensible elastica has no stretch: with a finite lambda the estimate also charges the
stretch's -eps eta'^2 / 2 that the inextensible bar leaves out (eps = -P / lambda), a softening
of relative size (P / lambda) r / (1 - r) that the oracle cannot check; at 0.99 it moves the ratio to
1.02 (lambda 1e4) and 0.59 (1e3); at lower loads, where the curvature's part is small, it is the
estimate (lambda 1e4: 1.9x at 0.9, 0.08x at 0.95, the two parts of opposite sign: docs/exact-bars.md,
"Near the Euler load"), so lower loads are asserted at lambda = 1e8 only.

At or beyond the Euler load K is not positive definite and no static change is an estimate: the
outputs the bar moves are charged ``model_form.BEYOND_BUCKLING`` of their peak, the method text
says why.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from symgen.api import simulate_scene
from symgen.numerics import model_form
from tests.oracles import imperfect_elastica_midspan
from tests.test_hard_cases import GAMMA, MU, P_CR, beam_column_midspan, write_column

VK = ["effects.axial=inextensible", "effects.strain=von_karman"]


def _run(tmp_path, ratio: float, lam: float, **kw):
    """(the run's mid column, the sidecar's error_estimate_detail) of the column at ``ratio``."""
    scene = write_column(tmp_path, ratio, 3, **kw)
    out = tmp_path / f"col_{ratio:g}_{lam:g}.csv"
    res = simulate_scene(scene, [*VK, f"bodies.col.lambda={lam:g}"], out=out, estimate="linearized")
    detail = json.loads(out.with_suffix(".json").read_text())["error_estimate_detail"]
    return np.asarray(res.column("mid")), detail


@pytest.mark.parametrize(
    "ratio, lam",
    [(0.9, 1e8), (0.95, 1e8), (0.97, 1e8), (0.99, 1e8), (0.99, 1e6), (0.99, 1e4), (0.99, 1e3)],
)
def test_model_form_part_carries_the_amplification(tmp_path, ratio, lam):
    """The sidecar's model-form part of mid against von Karman's model-form error (its closed form
    against the elastica), within [0.5, 2]: measured 1.00 / 1.00 / 1.00 / 1.07 at 0.9 / 0.95 /
    0.97 / 0.99 (lambda 1e8), 1.07 / 1.02 / 0.59 at 0.99 with lambda 1e6 / 1e4 / 1e3 (the stretch's
    term: module docstring). With the cap of 20 the 0.99 cases read 0.19 / 0.19 / 0.18 / 0.10x."""
    mid, detail = _run(tmp_path, ratio, lam)
    series = beam_column_midspan(ratio * P_CR)
    assert abs(mid[0] - series) < 2e-3 * series  # the run is von Karman's closed form (truncation small)
    true = abs(series - imperfect_elastica_midspan(ratio * P_CR, MU, GAMMA)) / np.abs(mid).max()
    est = detail["parts"]["model_form"]["mid"]
    assert 0.5 <= est / true <= 2.0, (est, true, est / true)


@pytest.mark.parametrize("ratio", [0.97, 0.99])
def test_whole_estimate_against_the_elastica(tmp_path, ratio):
    """The run as the column test runs it (lambda 1e4): the sidecar's whole estimate of mid against
    its true error, the run against the elastica (measured 0.73 at 0.97, 1.02 at 0.99; with the cap
    of 20: 0.18 at 0.99)."""
    mid, detail = _run(tmp_path, ratio, 1e4)
    true = abs(mid[0] - imperfect_elastica_midspan(ratio * P_CR, MU, GAMMA)) / np.abs(mid).max()
    assert 0.5 <= detail["outputs"]["mid"] / true <= 2.0, (detail["outputs"]["mid"], true)


def test_beyond_the_euler_load_is_not_estimated(tmp_path):
    """At 1.1 P_cr, started undeformed (it grows away from the straight state at 0.31 per unit tau),
    K is not positive definite along the run: mid is charged the whole peak (not a capped static
    change, which read 20 times the unamplified one) and the method text names the bar."""
    _, detail = _run(tmp_path, 1.1, 1e4, quasi_static=False, t_end=3.0)
    assert detail["parts"]["model_form"]["mid"] == model_form.BEYOND_BUCKLING
    method = detail["methods"]["model_form"]
    assert "bar 'col' at or beyond its Euler load" in method and "61 of 61 samples" in method
