"""An output that is zero to round-off over a run (symgen.policy.ZERO_PEAK, SimResult.peaks) has no
peak to be a fraction of: it gets no error estimate, decides no counts, strain or axial treatment,
and raises no warning; the CLI says it is zero. Oracle: a uniform elastic arm pinned at one end and
spun at constant speed from its quasi-static deformation. Its centrifugal load is axial, so its
deflection is exactly zero (symgen's: 1e-20, round-off), and its stretch has a closed form (the
stretch's own load included, u'' + k^2 u = -k^2 x, u(0) = 0, u'(1) = 0, k^2 = 1/lambda):
u(x) = sin(k x) / (k cos k) - x."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from symgen.cli import main
from symgen.numerics.error_estimate import ErrorEstimate
from symgen.numerics.run_result import SimResult
from symgen.policy import ZERO_PEAK
from tests.scenes import pinned_arm

LAMBDA = 2000.0

SPIN_ARM = pinned_arm(
    "spin_arm",
    f"lambda = {LAMBDA}\nmu = 1.0",
    """
[driver]
kind = "angle"
body = "arm"
initial = 0.0
rate = 1.0

[initial]
deformation = "quasi-static"

[outputs]
u_tip = { kind = "axial", body = "arm", at = 1.0 }
u_mid = { kind = "axial", body = "arm", at = 0.5 }
tip = { kind = "deflection", body = "arm", at = 1.0 }

[simulation]
t_end = 6.283185307179586
output_step = 0.01
""",
)


def _stretch(x: float) -> float:
    k = math.sqrt(1.0 / LAMBDA)
    return math.sin(k * x) / (k * math.cos(k)) - x


def _result(columns: dict[str, list[float]]) -> SimResult:
    rows = len(next(iter(columns.values())))
    empty = np.zeros((rows, 0))
    return SimResult(
        tau=np.arange(rows, dtype=float),
        outputs=np.column_stack(list(columns.values())),
        output_names=list(columns),
        q=empty,
        v=empty,
        lam=empty,
        closure_max=0.0,
        steps=0,
        simulate_s=0.0,
        partition=None,
    )


def test_peaks_are_zero_at_or_below_the_round_off_floor():
    r = _result(
        {
            "noise": [1e-20, -3e-17, 0.0],
            "floor": [0.0, ZERO_PEAK, 0.0],
            "small": [0.0, 3e-11, 0.0],
            "big": [0.5, -2.0, 1.0],
        }
    )
    assert r.peaks() == {"noise": 0.0, "floor": 0.0, "small": 3e-11, "big": 2.0}
    assert r.zero_outputs() == {"noise": 3e-17, "floor": ZERO_PEAK}


def test_the_record_keeps_the_zero_outputs_and_reads_older_records():
    rec = ErrorEstimate.from_json(
        {
            "outputs": {"a": 1e-3, "b": None},
            "parts": {p: {"a": 1e-3, "b": None} for p in ("truncation", "model_form", "axial", "time_integration")},
            "methods": dict.fromkeys(("truncation", "model_form", "axial", "time_integration"), "m"),
            "reasons": {},
            "richer": {},
            "zero": {"b": 1e-20},
        }
    )
    assert rec.zero == {"b": 1e-20} and "zero to round-off" in rec.text("b")
    assert ErrorEstimate.from_json(rec.to_json()) == rec
    older = rec.to_json()
    del older["zero"]
    assert ErrorEstimate.from_json(older).zero == {}


@pytest.fixture(scope="module")
def spun(tmp_path_factory):
    """The spinning arm run as a user runs it (counts chosen, default estimate): its rows, sidecar,
    stdout and stderr."""
    tmp = tmp_path_factory.mktemp("spin")
    scene = tmp / "spin_arm.toml"
    scene.write_text(SPIN_ARM)
    mp = pytest.MonkeyPatch()
    mp.setenv("SYMGEN_CACHE_DIR", str(tmp / "cache"))
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            assert main(["simulate", str(scene), "-o", str(tmp / "run.csv")]) == 0
    finally:
        mp.undo()
    rows = np.genfromtxt(tmp / "run.csv", delimiter=",", names=True)
    return rows, json.loads((tmp / "run.json").read_text()), out.getvalue(), err.getvalue()


def test_a_deflection_zero_to_round_off_takes_no_decision_and_no_warning(spun):
    """Before: the tip's 1e-20 read an estimate of 2.6 "of peak", raised the arm's counts twice
    to their cap (7 + 6) on it and warned for tighter tolerances."""
    rows, side, out, err = spun
    assert np.abs(rows["tip"]).max() <= ZERO_PEAK
    assert side["error_estimate"]["tip"] is None
    assert set(side["error_estimate_detail"]["zero"]) == {"tip"}
    assert "zero to round-off over the run" in err and "tip (peak" in err
    assert "warning" not in err, err
    for bar in side["bases"].values():
        assert "on tip" not in (bar["raised"] or "") and "on tip" not in bar["reason"]
        assert (bar["axial"], bar["transverse"]) != (7, 6)  # not raised to the cap


def test_the_stretch_against_its_closed_form_and_its_estimate(spun):
    """The outputs that are not zero keep their estimates, honest against the closed form."""
    rows, side, _, _ = spun
    for name, x in (("u_tip", 1.0), ("u_mid", 0.5)):
        exact = _stretch(x)
        true = float(np.abs(rows[name] - exact).max() / abs(exact))
        estimate = side["error_estimate"][name]
        assert true <= 0.01 and estimate is not None and estimate <= 0.01, (name, true, estimate)
        if name == "u_mid":  # u_tip's 1e-7 is at the run's time-integration floor
            assert 0.5 <= estimate / true <= 2.0, (true, estimate)
