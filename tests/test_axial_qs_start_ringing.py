"""The error estimate's axial part from a quasi-static start under a varying axial load
(symgen.numerics.axial_drift.ringing, issue 19): an arm whose angle driver oscillates, bar axially
quasi-static, started on its quasi-static deformation, against the same scene with the axial
dynamics kept (5 axial functions, tolerances 1e-10 / 1e-13: the oracle).

The quasi-static start solved the deformation with its rates zero, then set the rates of the
quasi-static motion; the loads of those rates (the Coriolis load 2 theta' w' of the bending rate on
the turning bar) were in the run's axial force N(0) but not in the dynamic bar's start, which rang
about the stretch: 2.94 % of tip_u's peak, 1.46 % of the torque's at lambda 1e3 (0.031 % and
0.017 % at 1e5). The start now solves the deformation again with its rates and accelerations
held, the axial amplitudes' along the bending's held motion (tests/test_qs_start_consistent.py):
0.47 % and 0.46 % at 1e3, 5.4e-5 and 5.1e-5 of peak at 1e5 (with the axial rates from the states
solved at zero rates 0.68 % and 0.57 %, 0.052 % and 0.029 %: the bent start's offset to the
inextensible limit; with the rates alone held 0.65 % and 0.50 %, 0.022 % and 0.016 %), no
longer ringing but the quasi-static treatment's error over the run (at the driver's harmonics);
the start's axial force jump is gone, so the window is not run and the whole run with the axial
dynamics kept reads it."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from symgen.cli import main
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from tests.scenes import pinned_arm

#: a soft cantilever arm with a tip mass whose angle oscillates, sin(tau + 0.6): theta' and
#: theta'' are both nonzero at the start, the centrifugal axial load varies at 2 per unit tau
ARM = pinned_arm(
    "osc_arm",
    "lambda = LAMBDA\nmu = 4.0\naxial_modes = AXIAL_MODES\ntransverse_modes = 4",
    """
[driver]
kind = "angle"
body = "arm"
initial = 0.0
law = "sin(tau + 0.6)"

[initial]
deformation = "quasi-static"

[effects]
axial = "AXIAL"
strain = "von_karman"

[outputs]
tip_u = { kind = "axial", body = "arm", at = 1.0 }
tip = { kind = "deflection", body = "arm", at = 1.0 }
torque = { kind = "driver_torque" }

[simulation]
t_end = 12.566370614359172
output_step = 0.01
""",
    tip_mass="0.5",
)
OUTPUTS = ("tip_u", "tip", "torque")


def _scene(tmp_path, lam: float, axial: str, modes: int):
    path = tmp_path / f"osc_{lam:g}_{axial}_{modes}.toml"
    text = ARM.replace("LAMBDA", repr(lam)).replace("AXIAL_MODES", str(modes)).replace("AXIAL", axial)
    path.write_text(text)
    return path


@pytest.mark.parametrize("lam", [1e3, 1e5])
def test_the_axial_part_charges_a_quasi_static_starts_ringing(tmp_path, lam):
    """As a user runs it (``symgen simulate``, the default estimate): the quasi-static run against
    the axial-dynamic oracle, and the axial part within [0.5, 3] of that true error on every
    output (measured 0.997 / 0.996 / 0.998 at 1e3, 0.86 / 0.82 / 0.91 at 1e5; with the axial rates
    from the states at zero rates 1.00 / 1.00 / 1.00 and 0.99 / 0.96 / 0.96; with the rates alone held
    1.00 / 1.00 / 1.00 and 1.00 / 0.97 / 1.00; with the start at zero
    rates 1.02 / 1.00 / 1.00 and 0.96 / 0.84 / 0.79), the whole run read with the axial dynamics
    kept."""
    oracle = simulate(load_mechanism(str(_scene(tmp_path, lam, "dynamic", 5))), rtol=1e-10, atol=1e-13)
    path = _scene(tmp_path, lam, "quasi_static", 3)
    out = tmp_path / "run.csv"
    assert main(["simulate", str(path), "-o", str(out)]) == 0
    side = json.loads(out.with_suffix(".json").read_text())
    rows = list(csv.reader(out.read_text().splitlines()))
    data = np.array(rows[1:], dtype=float)
    detail = side["error_estimate_detail"]
    assert detail["methods"]["axial"].startswith("the start's ringing on")
    assert "the quasi-static start's axial force" in detail["methods"]["axial"]
    # a consistent start: no axial force jump, the whole run read instead of a window
    assert "the start's ringing not run" in detail["methods"]["axial"]
    assert "the whole run with the axial dynamics of arm kept" in detail["methods"]["axial"]
    for name in OUTPUTS:
        run = data[:, rows[0].index(name)]
        exact = np.asarray(oracle.column(name))
        n = min(len(run), len(exact))
        # the first sample of the torque is the continuum's joint force in both: from the second
        true = float(np.max(np.abs(run[1:n] - exact[1:n])) / np.max(np.abs(exact)))
        part = detail["parts"]["axial"][name]
        assert 0.5 <= part / true <= 3.0, f"{name}: part {part:.3g}, true {true:.3g}"
        assert side["error_estimate"][name] >= part
    if lam == 1e3:
        tip_u = data[:, rows[0].index("tip_u")]
        exact = np.asarray(oracle.column("tip_u"))
        n = min(len(tip_u), len(exact))
        # the error is real: 0.47 % on tip_u (2.9 % from the start at zero rates), where the
        # stretch's own inertia charges 9e-4 and the drift 0 (every rigid motion driven)
        assert np.max(np.abs(tip_u[1:n] - exact[1:n])) / np.max(np.abs(exact)) > 0.004
