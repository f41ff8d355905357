"""The error estimate's axial part charges the quasi-static stretch's own inertia
(symgen.numerics.axial_drift.own_inertia): a steel arm spun at a constant rate by an angle driver,
started on its quasi-static deformation, against the closed form of its steady stretch.

In the frame turning with the arm at w the stretch u(x) solves u'' + k^2 (x + u) = 0, u(0) = 0,
EA u'(L) = M w^2 (L + u(L)) (tip mass M), k^2 = rho w^2 / E: x + u = C sin(k x),
C = 1 / (k cos kL - (M w^2 / EA) sin kL). The quasi-static treatment loads the bar with the
centrifugal force of its undisplaced mass only: u(L) = (kL)^2 (M/m + 1/3) L, low by 0.4 / lambda
of itself without a tip mass (lambda = E / (rho L^2 w^2)), where its other parts charge nothing
(the rotation is prescribed, the start quasi-static)."""

from __future__ import annotations

import json

import mpmath
import pytest

from symgen.cli import main
from symgen.numerics import axial_drift
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate

#: steel, L 0.5 m, 10 x 10 mm, at 300 rad/s: lambda = E / (rho L^2 w^2) = 1189
ARM = """
[scene]
name = "spin_arm"
units = "SI"
omega = 300.0
reference_length = 0.5

[[bodies]]
name = "arm"
length = 0.5
E = YOUNG
density = 7850.0
area = 1e-4
inertia = 8.333e-10
frame = "cantilever"

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
MASS
[driver]
kind = "angle"
body = "arm"
initial = 0.0
rate = 1.0

[initial]
deformation = "quasi-static"

[outputs]
tip_u = { kind = "axial", body = "arm", at = 1.0 }
theta = { kind = "angle", body = "arm" }

[simulation]
t_end = 6.283185307179586
output_step = 0.05
"""
RHO, L, W, BAR_MASS = 7850.0, 0.5, 300.0, 7850.0 * 1e-4 * 0.5
TIP = '\n[[masses]]\nbody = "arm"\nat = 1.0\nmass = {m!r}\n'


def _scene(tmp_path, lam: float, tip_ratio: float = 0.0):
    young = lam * RHO * L**2 * W**2
    mass = TIP.format(m=tip_ratio * BAR_MASS) if tip_ratio else ""
    path = tmp_path / f"spin_{lam:g}_{tip_ratio:g}.toml"
    path.write_text(ARM.replace("YOUNG", repr(young)).replace("MASS", mass))
    return path


def _closed_form(lam: float, tip_ratio: float = 0.0) -> float:
    """u(L) in m (40 digits: at lambda 1e6 the inertia's share is 4e-7)."""
    mpmath.mp.dps = 40
    kl = 1 / mpmath.sqrt(mpmath.mpf(lam))
    c = 1 / (kl * mpmath.cos(kl) - tip_ratio * kl**2 * mpmath.sin(kl))
    return float((c * mpmath.sin(kl) - 1) * L)


@pytest.mark.parametrize("lam", [1189.0, 1e6])
def test_the_axial_part_charges_a_spinning_arms_own_stretch_inertia(tmp_path, lam):
    """As a user runs it (``symgen simulate``, axial "auto" choosing quasi-static, the default
    estimate): the tip's stretch is off the closed form by 0.4 / lambda of itself, and the axial
    part charges that within [0.5, 2] (measured 0.997), from the stretch's own inertia."""
    path = _scene(tmp_path, lam)
    out = tmp_path / "run.csv"
    assert main(["simulate", str(path), "-o", str(out)]) == 0
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["axial_treatment"]["arm"]["treatment"] == "quasi_static"
    tip = [float(line.split(",")[1]) for line in out.read_text().splitlines()[1:]]
    exact = _closed_form(lam)
    true = max(abs(t - exact) for t in tip) / max(abs(t) for t in tip)
    assert true == pytest.approx(0.4 / lam, rel=0.01)
    part = side["error_estimate_detail"]["parts"]["axial"]["tip_u"]
    assert 0.5 <= part / true <= 2.0, f"part {part:.3g}, true {true:.3g}"
    assert side["error_estimate"]["tip_u"] >= part
    method = side["error_estimate_detail"]["methods"]["axial"]
    # from its quasi-static start (no axial force jump) the whole run with the axial dynamics kept is
    # read too: the same stretch's inertia, measured; either may be the larger on tip_u
    assert "the stretch's own inertia" in method
    assert "on tip_u (the larger there" in method


def test_the_stretch_inertia_with_a_tip_mass(tmp_path):
    """A tip mass of half the arm's: the closed form's u'(L) = M w^2 (L + u(L)) / EA, the part
    within [0.5, 2] of the missing share (measured 0.999; the quasi-static stretch is the linear
    load's (kL)^2 (M/m + 1/3) L)."""
    lam, ratio = 1e4, 0.5
    mech = load_mechanism(str(_scene(tmp_path, lam, ratio)))
    res = simulate(mech)
    part, how = axial_drift.own_inertia(mech, res)
    tip = res.column("tip_u") * L
    exact = _closed_form(lam, ratio)
    assert float(tip[-1]) == pytest.approx(L * (ratio + 1 / 3) / lam, rel=1e-6)
    true = float(abs(tip[-1] - exact) / abs(tip[-1]))
    assert 0.5 <= part["tip_u"] / true <= 2.0, f"part {part['tip_u']:.3g}, true {true:.3g}"
    assert part["theta"] == 0.0
