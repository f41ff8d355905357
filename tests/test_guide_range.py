"""The range check and the model-form estimate of a slot guide. The range check (its largest slope
|eta'|, ``symgen.numerics.checks``): a guide's
functions psi(xi, beta) move with the contact, so its slopes are read as powers of beta and
1 - beta times fixed numbers at points of its span and its overhang
(:class:`symgen.ir.shape_samples.GuideSamples`), by the Python runners and the emitted C solver
alike. Until then a guide's range was not checked at all (read with fixed samples of xi it had
stopped a run at a slope its guide never had).

The model-form estimate (``symgen.numerics.model_form._Guide``) charges a guide the curvature's
terms beyond its fourth order at each contact.

Oracles: the functions' own derivatives (SymPy, at two contacts); the closed form of a simply
supported beam with an overhang under an end load (Euler-Bernoulli, small deflection) and its
first-order change by the left-out energy; the model's own slope outputs (its symbolic output
function, not the range tables)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import sympy as sp

from symgen.api import mechanism, simulate_scene
from symgen.ir.shape_samples import GuideSamples, InvalidShapeSamples
from symgen.model.shape_samples import _nodes
from symgen.model.slot import XI, _derivative, guide_samples
from symgen.numerics import checks
from tests.oracles import write_scene

BETA = sp.Symbol("beta_A", real=True)


def _samples(nt: int, nover: int) -> GuideSamples:
    x, w = _nodes(())
    return guide_samples("guide", nt, nover, x, w)


@pytest.mark.parametrize("nspan, nover", [(3, 0), (2, 4), (4, 2)])
def test_guide_samples_are_the_functions_and_their_derivatives(nspan, nover):
    """d^n psi_k(xi, beta) / dxi^n, n = 0, 1, 2, of every function at the span's and the overhang's
    nodes, at two contacts, against the derivatives of the function itself (the rigid overhang's
    too: straight, sloped); the range check's slopes (``checks.guide_slopes``) are those at its
    rows."""
    nt = nspan + nover
    samples = _samples(nt, nover)
    rng = np.random.default_rng(3)
    g = rng.normal(size=(nt, 1))
    x = np.asarray(samples.x)
    for beta in (0.41, 0.66):
        for n in (0, 1, 2):
            span, over = samples.scalings(np.array([beta]), n)
            got = np.concatenate([np.asarray(samples.span[n]) @ (span * g), np.asarray(samples.over[n]) @ (over * g)])[
                :, 0
            ]
            want = np.zeros(2 * len(x))
            for k in range(nt):
                pieces = _derivative(k + 1, BETA, nspan, nover, n, 0)
                for piece, xi in ((0, beta * x), (1, beta + (1 - beta) * x)):
                    f = sp.lambdify(XI, pieces[piece].xreplace({BETA: beta}), "numpy")
                    rows = slice(piece * len(x), (piece + 1) * len(x))
                    want[rows] += g[k, 0] * np.broadcast_to(np.asarray(f(xi), dtype=float), xi.shape)
            assert np.abs(got - want).max() <= 1e-11 * max(np.abs(want).max(), 1.0), (beta, n)
        span_rows, over_rows = samples.range_rows()
        slopes = checks.guide_slopes(samples, g, np.array([beta]))[:, 0]
        span, over = samples.scalings(np.array([beta]), 1)
        whole = np.concatenate([np.asarray(samples.span[1]) @ (span * g), np.asarray(samples.over[1]) @ (over * g)])
        assert np.array_equal(slopes, whole[[*span_rows, *(len(x) + i for i in over_rows)], 0])


def test_guide_samples_record_round_trip_and_refusal():
    samples = _samples(4, 2)
    assert GuideSamples.from_json(json.loads(json.dumps(samples.to_json()))) == samples
    bad = samples.to_json()
    bad["over_powers"] = bad["over_powers"][:-1]
    with pytest.raises(InvalidShapeSamples, match="same functions"):
        GuideSamples.from_json(bad)
    bad = dict(samples.to_json(), span_powers=[0.5] * 4)
    with pytest.raises(InvalidShapeSamples, match="list of integers"):
        GuideSamples.from_json(bad)
    bad = dict(samples.to_json(), span=samples.to_json()["span"][:2])
    with pytest.raises(InvalidShapeSamples, match="three tables"):
        GuideSamples.from_json(bad)


#: a guide pinned at the origin along x, held at xi = 0.6 by a slot on a crank at rest, an end load P
#: across it: a simply supported beam (span a = 0.6) with an overhang c = 0.4 loaded at its end
STATIC_GUIDE = """
[scene]
name = "static_guide"
units = "dimensionless"
omega = 1.0
reference_length = 1.0

[[bodies]]
name = "crank"
length = 0.3
rigid = true
mass_per_length = 1.0

[[bodies]]
name = "guide"
length = 1.0
lambda = 1e6
mu = 1.0
frame = "pinned-pinned"
axial_modes = 0
transverse_modes = {nt}

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.6, -0.3], 0.0]

[[joints]]
name = "P"
kind = "pin"
bodies = ["ground", "guide"]
at = [[0.0, 0.0], 0.0]

[[joints]]
name = "A"
kind = "slot"
bodies = ["crank", "guide"]
at = [1.0, "variable"]
{overhang}

[[loads]]
body = "guide"
kind = "point"
at = 1.0
transverse = -{load}
axial = 0.0

[driver]
kind = "angle"
body = "crank"
initial = 1.5707963267948966
rate = 0.0

[initial]
deformation = "quasi-static"
guess = {{ guide = 0.0, A = 0.6 }}

[outputs]
tip = {{ kind = "deflection", body = "guide", at = 1.0 }}
tip_slope = {{ kind = "slope", body = "guide", at = 1.0 }}
support_slope = {{ kind = "slope", body = "guide", at = 0.6 }}
pin_slope = {{ kind = "slope", body = "guide", at = 0.0 }}

[simulation]
t_end = 0.01
output_step = 0.01
accuracy = 0.05
"""

A, C, LOAD = 0.6, 0.4, 0.1


def _static(tmp_path, overhang: str, nt: int, solver: str = "idas", load: float = LOAD):
    path = write_scene(tmp_path / f"static_{solver}.toml", STATIC_GUIDE.format(nt=nt, overhang=overhang, load=load))
    mech = mechanism(path)
    if solver == "c":
        from symgen.numerics.csolver import simulate_c

        return mech, simulate_c(mech)
    return mech, simulate_scene(path)


def test_elastic_overhang_slopes_against_the_closed_form(tmp_path):
    """Elastic overhang (2 span functions, the contact-slope function, 2 of the overhang's own: the
    static shapes exactly). Euler-Bernoulli (EI = mu = 1): slope at the pin -P c a / 6, at the
    support P c a / 3, at the loaded end P c a / 3 + P c^2 / 2 = 0.016 (the largest), the end's
    deflection P c^2 (a + c) / 3. The range check's largest slope is the end's to 2e-4 (its points
    0.0012 of a sixteenth inside the end; the slope's nonlinear part ~ slope^2); the model's slope
    outputs are the closed form's to 5e-4."""
    mech, res = _static(tmp_path, "overhang_modes = 2", 2)
    closed = {
        "pin_slope": -LOAD * C * A / 6,
        "support_slope": LOAD * C * A / 3,
        "tip_slope": LOAD * C * A / 3 + LOAD * C**2 / 2,
        "tip": LOAD * C**2 * (A + C) / 3,
    }
    for name, value in closed.items():
        assert abs(float(res.column(name)[0])) == pytest.approx(abs(value), rel=5e-4), name
    record = checks.range_record(mech.info, res.tau, res.q, 0.01)
    assert record["largest_slope"]["guide"]["slope"] == pytest.approx(closed["tip_slope"], rel=2e-4)
    assert "not_checked" not in record


def test_rigid_overhang_slope_is_the_models_own(tmp_path):
    """The seed's rigid overhang (straight along the span's end slope, 6 sines on the span): the
    largest slope is the span's end slope, which the overhang keeps; the range check reads the
    model's own slope output there (its symbolic output function) to 1e-9. The sines' truncation
    of the span under the overhang's end moment leaves it 9 % short of the closed form's P c a / 3
    (the form's, not the check's)."""
    mech, res = _static(tmp_path, 'overhang = "rigid"', 6)
    record = checks.range_record(mech.info, res.tau, res.q, 0.01)
    own = abs(float(res.column("tip_slope")[0]))
    assert own == pytest.approx(abs(float(res.column("support_slope")[0])), rel=1e-9)
    assert record["largest_slope"]["guide"]["slope"] == pytest.approx(own, rel=1e-9)
    assert 0.85 < own / (LOAD * C * A / 3) < 0.95


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
def test_the_c_solver_reads_the_guide_alike(tmp_path):
    """The emitted C solver's range check of a guide (``symgen_bar_range_``: the same rows and
    powers) gives the Python record's largest slope to round-off."""
    mech, res = _static(tmp_path, "overhang_modes = 2", 2)
    _, res_c = _static(tmp_path, "overhang_modes = 2", 2, solver="c")
    assert res_c.range_maxima is not None
    record = checks.range_record(mech.info, res.tau, res.q, 0.01)
    record_c = checks.range_record(mech.info, (), (), 0.01, maxima=res_c.range_maxima[1])
    assert record_c["largest_slope"]["guide"]["slope"] == pytest.approx(
        record["largest_slope"]["guide"]["slope"], rel=1e-9
    )


@pytest.mark.parametrize("load", [0.25, 0.5])
def test_model_form_of_a_guide_against_the_first_order_change(tmp_path, load):
    """The guide's model keeps its curvature to fourth order, eta''^2 (1 + eta'^2); what it leaves
    out begins with (mu/2) int eta''^2 eta'^4. Its first-order effect on the loaded end's deflection
    (the load's work: the end's influence function is the linear deflection / P) is
    -(mu / P) int (eta''^2 2 eta'^3 eta' + eta'' eta'^4 eta'') = -3 int eta''^2 eta'^4 / P with the
    closed-form linear shape (cubic on the span, the overhang's cantilever beyond): 9.55e-7 and
    1.53e-5 of the end's deflection at end slopes 0.040 and 0.080. The estimate's model-form part
    on the end deflection is that to 1 % and 2 % (its h = s^2 / (1 - s) and the deflected state's
    own slopes add the next order), and grows as the load^4."""
    mech, res = _static(tmp_path, "overhang_modes = 2", 2, load=load)
    from symgen.numerics.model_form import model_form_estimate

    est = model_form_estimate(mech, res)
    x, w = np.polynomial.legendre.leggauss(40)
    xs, ws = (x + 1) / 2 * A, w * A / 2  # the span: eta' = P c (3 x^2 - a^2) / (6 a), eta'' = P c x / a
    integral = np.sum(ws * (load * C * xs / A) ** 2 * (load * C / (6 * A) * (3 * xs**2 - A**2)) ** 4)
    u, wu = (x + 1) / 2 * C, w * C / 2  # the overhang: eta' = P c a / 3 + P (c u - u^2 / 2), eta'' = P (c - u)
    integral += np.sum(wu * (load * (C - u)) ** 2 * (load * C * A / 3 + load * (C * u - u**2 / 2)) ** 4)
    tip = load * C**2 * (A + C) / 3
    closed = 3 * integral / (load * tip)
    assert est.outputs["tip"] == pytest.approx(closed, rel=0.01 if load < 0.3 else 0.02)
    assert est.guides == ("guide",) and "slot guide guide" in est.method
