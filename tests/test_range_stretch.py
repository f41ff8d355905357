"""The range of the bar models in the axial direction (issue 19; docs/exact-bars.md, "The range
of the expansion"): the run stops where a bar's largest stretch ||r'| - 1| (its tangent r' =
(1 + zeta', eta') from its axial and transverse amplitudes, at the slope check's points) passes
``POLICY.stretch_limit``, in both solvers, not where its axial amplitudes (which carry the bent
bar's shortening) sum to a tenth of its length, as before.

Oracles: the Euler-Bernoulli cantilever under its weight (tip w/8, tip slope w/6) and its elastica
(``test_range_slope.elastica_weight``) for a bent bar that must run; the rod spinning about one
end, linear elastic (root strain 1/cos k - 1, k = Omega/sqrt(lambda)), for the stop; the emitted
C solver for the same verdict, and its range record (kept during the run) against the one made
from its rows' q."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from symgen.api import mechanism, simulate_scene
from symgen.errors import SimulationError
from symgen.numerics import checks
from symgen.policy import POLICY, RANGE
from c_support import needs_cc
from test_range_slope import CANTILEVER, PENDULUM, elastica_weight
from tests.scenes import pinned_arm

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def cantilever(tmp_path_factory):
    path = tmp_path_factory.mktemp("stretch") / "cantilever.toml"
    path.write_text(CANTILEVER)

    def run(w: float):
        over = [f"effects.gravity=[0.0, {-w!r}]"]
        return mechanism(path, over), simulate_scene(path, over)

    return run


def test_stretch_of_the_tangent():
    """|r'| - 1 of (1 + zeta', eta') without cancellation: against the square root where that is
    exact enough, and against its series where the difference of the root and 1 loses the digits."""
    a, s = np.array([0.3, -0.2, 0.0, 0.01]), np.array([0.4, 0.7, 0.5, 0.0])
    assert np.allclose(checks.stretch(a, s), np.sqrt((1 + a) ** 2 + s**2) - 1, rtol=1e-14, atol=0)
    a, s = 1e-12, 3e-7  # |r'| - 1 = a + s^2 / 2 + O(a s^2, s^4)
    assert float(checks.stretch(a, s)) == pytest.approx(a + s * s / 2, rel=1e-12)


def test_a_bent_cantilever_is_not_a_stretched_one(cantilever):
    """A cantilever bent by its weight (exact bar, 3 + 4 functions, lambda = 1e6). At w = 0.2 the
    Euler-Bernoulli tip w/8 and tip slope w/6 (small slopes: 4e-4 off the elastica). At w = 4, a
    tip at 43 % of the length (slope 0.56), which the axial amplitudes' sum refused at the start
    (0.139 > 0.1, the shortening of the bent bar): it runs, its stretch (the axial functions'
    truncation of the shortening; N / lambda is 1e-6) well inside the limit, and its tip agrees
    with the elastica within the exact bar's error rule (measured 5.8e-3)."""
    mech, res = cantilever(0.2)
    tip = -float(res.column("tip")[0])
    assert tip == pytest.approx(0.2 / 8, rel=1e-3)
    assert float(checks.slopes(mech.info, res.q[0])["arm"][0]) == pytest.approx(0.2 / 6, rel=1e-3)

    mech, res = cantilever(4.0)
    q = res.q[0]
    fi, _ = mech.info.amplitudes["arm"]
    assert np.abs(q[list(fi)]).sum() > 0.1  # the former check's sum: refused at tau = 0
    assert checks.beyond_range(mech, q) is None
    stretch = float(checks.stretches(mech.info, q)["arm"][0])
    assert 1e-3 < stretch < POLICY.stretch_limit / 4
    y_ref, slope_ref = elastica_weight(4.0)
    slope = float(checks.slopes(mech.info, q)["arm"][0])
    assert slope == pytest.approx(slope_ref, rel=1e-2) and slope > 0.55
    error = abs(-float(res.column("tip")[0]) - y_ref) / y_ref
    assert error < min(RANGE.error_per_slope6 * slope**6, 1e-2)


SPUN = pinned_arm(
    "spun_bar",
    "lambda = 100.0\nmu = 100.0\naxial_modes = 6\ntransverse_modes = 3",
    """
[driver]
kind = "angle"
body = "arm"
initial = 0.0
law = "0.25*tau^2"

[initial]
deformation = "quasi-static"

[effects]
strain = "von_karman"
axial = "dynamic"

[outputs]
tip = { kind = "axial", body = "arm", at = 1.0 }

[simulation]
t_end = 8.0
output_step = 0.01
""",
)

LAMBDA, SPIN_UP = 100.0, 0.5  # the bar's lambda and d Omega / d tau of SPUN


def rod_root_strain(omega: float) -> float:
    """The root strain of a linear elastic rod of unit length, mass and stiffness lambda spinning
    at omega about one end: (x + u)'' + k^2 (x + u) = 0, u(0) = 0, u'(1) = 0, k = omega/sqrt(lambda):
    x + u = sin(k x) / (k cos k), u'(0) = 1/cos k - 1."""
    return 1.0 / math.cos(omega / math.sqrt(LAMBDA)) - 1.0


def test_an_overstretched_bar_stops(tmp_path):
    """A soft bar (lambda = 100) spun up slowly (Omega = 0.5 tau, its axial frequency 16) stretches
    as the spinning rod does (its root's strain, the largest, within 1 % of the closed form on
    the way) until the strain passes the limit: the run stops at the first output beyond it,
    within 1 % of the closed form's time (tau 6.197), naming the bar and the stretch."""
    path = tmp_path / "spun.toml"
    path.write_text(SPUN)
    with pytest.raises(SimulationError, match="bar 'arm' is deformed beyond the range of the model") as err:
        simulate_scene(path)
    assert "stretch ||r'| - 1| reaches" in str(err.value) and f"limit {POLICY.stretch_limit:g}" in str(err.value)
    partial = err.value.partial
    e = checks.stretches(mechanism(path).info, partial.q.T)["arm"]
    assert e[:-1].max() <= POLICY.stretch_limit < e[-1]
    k_stop = math.acos(1.0 / (1.0 + POLICY.stretch_limit))
    assert partial.tau[-1] == pytest.approx(k_stop * math.sqrt(LAMBDA) / SPIN_UP, rel=1e-2)
    for i in (len(e) // 2, 3 * len(e) // 4):
        assert e[i] == pytest.approx(rod_root_strain(SPIN_UP * partial.tau[i]), rel=1e-2)


@needs_cc
def test_both_solvers_stop_the_overstretched_bar_alike(tmp_path):
    """The emitted C solver stops the spun bar at the same output as IDAS; the command line says
    so with exit code 2 and the partial result kept, its sidecar's range record (kept by the C
    library during the run) the one made from the partial rows' q."""
    path = tmp_path / "spun.toml"
    path.write_text(SPUN)
    with pytest.raises(SimulationError) as idas:
        simulate_scene(path)
    with pytest.raises(SimulationError, match="bar 'arm' is deformed beyond the range") as c:
        simulate_scene(path, solver="c")
    assert "stretch" in str(c.value)
    assert c.value.partial.tau[-1] == pytest.approx(idas.value.partial.tau[-1], abs=1e-9)
    out = tmp_path / "run.csv"
    cmd = [sys.executable, "-m", "symgen.cli", "simulate", str(path), "--solver", "c", "--estimate", "off"]
    proc = subprocess.run([*cmd, "-o", str(out)], capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 2 and "bar 'arm'" in proc.stderr and "stretch" in proc.stderr
    record = json.loads(out.with_name("run.partial.json").read_text())["range"]
    partial = c.value.partial
    ours = checks.range_record(mechanism(path).info, partial.tau, partial.q, 0.01)
    _same_record(record, ours)
    assert record["largest_stretch"]["arm"]["stretch"] > POLICY.stretch_limit


def _same_record(got: dict, made: dict) -> None:
    """Two range records alike: the same keys, bars, times and messages' times; values to 1e-12."""
    assert got.keys() == made.keys()
    for key in ("largest_slope", "largest_stretch"):
        assert got[key].keys() == made[key].keys(), key
        for bar, v in got[key].items():
            assert v["tau"] == made[key][bar]["tau"]
            value = next(k for k in v if k != "tau")
            assert v[value] == pytest.approx(made[key][bar][value], rel=1e-12, abs=1e-300)
    assert [(w["bar"], w["tau"]) for w in got["warnings"]] == [(w["bar"], w["tau"]) for w in made["warnings"]]
    for w, m in zip(got["warnings"], made["warnings"]):
        assert w["slope"] == pytest.approx(m["slope"], rel=1e-12)
    assert {k: v for k, v in got.items() if k not in ("largest_slope", "largest_stretch", "warnings")} == {
        k: v for k, v in made.items() if k not in ("largest_slope", "largest_stretch", "warnings")
    }


@needs_cc
def test_the_c_solvers_range_record_is_the_rows(tmp_path):
    """The soft pendulum of test_range_slope (exact bar, released horizontal: its slope passes the
    default accuracy's 0.368 at tau 0.52, the largest 0.66 at 3.6, its stretch 0.028 there, the
    run complete): the C library's record, kept during the run, is the one made from its rows'
    q (the same rows, to round-off), and IDAS warns for the same bar at the same time."""
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM)
    records = {}
    for solver in ("idas", "c"):
        out = tmp_path / f"{solver}.csv"
        res = simulate_scene(path, out=out, solver=solver)
        records[solver] = json.loads(out.with_suffix(".json").read_text())["range"]
    assert res.range_maxima is not None
    _same_record(records["c"], checks.range_record(mechanism(path).info, res.tau, res.q, 0.01))
    ri, rc = records["idas"], records["c"]
    assert [(w["bar"], w["tau"]) for w in ri["warnings"]] == [(w["bar"], w["tau"]) for w in rc["warnings"]]
    assert len(rc["warnings"]) == 1 and 0.4 < rc["warnings"][0]["tau"] < 0.7
    for key, value in (("largest_slope", "slope"), ("largest_stretch", "stretch")):
        assert ri[key]["arm"][value] == pytest.approx(rc[key]["arm"][value], rel=1e-3)
    assert 0.6 < rc["largest_slope"]["arm"]["slope"] < POLICY.slope_limit
    assert 0.01 < rc["largest_stretch"]["arm"]["stretch"] < POLICY.stretch_limit
