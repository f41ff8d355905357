"""Lumped masses at joints (a slider's mass) against hand estimates.

The slider B of the seed's slider-crank moves on the x axis with the rigid kinematics
x_B(theta) = alpha cos theta + sqrt(1 - alpha^2 sin^2 theta) (alpha = 0.5, rod length 1, the
crank at unit speed). A slider of mass m_B needs the horizontal force m_B x_B'' from the rod.
The rod is a two-force member for this extra load (no transverse load changes; the moment of
the rod about A fixes the vertical part), so the extra end force is purely axial:

    Delta N = -m_B x_B'' / cos(theta_rod),      theta_rod = -asin(alpha sin theta)

(tension positive: near the dead centres x_B'' < 0 and the slider pulls the rod). Hand
estimates of its effect:

* quasi-statically the rod's elongation grows by Delta N / lambda (uniform axial force; the
  linear strain and the complete axial basis, which contains xi, represent it exactly);
* the driver torque grows by the slider's rate of kinetic energy, m_B x_B' x_B'' (power
  balance of the rigid mechanism, crank speed 1);
* the rod's axial vibration with the slider's mass at its free end: beta tan beta = m_rod / m_B,
  omega = beta sqrt(lambda) (a fixed-free bar with a tip mass); at theta = 0 the rod lies on the
  slider's line, so the slider moves with the rod's end.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.numerics.modes import modes
from symgen.numerics.quasistatic import quasi_static

SC = "examples/slider_crank.toml"
ALPHA, LAMBDA = 0.5, 18246.0
LINEAR_COMPLETE = [
    "effects.strain=linear",
    "bodies.rod.axial_shapes=complete",
    "bodies.rod.axial_modes=3",
    "bodies.rod.transverse_modes=1",
    "simulation.output_step=0.19634954084936207",
]


def _slider(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x_B', x_B'' (central differences of the closed form) and the rod angle."""
    x = lambda t: ALPHA * np.cos(t) + np.sqrt(1 - ALPHA**2 * np.sin(t) ** 2)
    h = 1e-4
    vel = (x(tau + h) - x(tau - h)) / (2 * h)
    acc = (x(tau + h) - 2 * x(tau) + x(tau - h)) / h**2
    return vel, acc, -np.arcsin(ALPHA * np.sin(tau))


@pytest.fixture(scope="module")
def pair():
    mass = 0.5
    light = quasi_static(mechanism(SC, [*LINEAR_COMPLETE, "joints.B.mass=0.0"]))
    heavy = quasi_static(mechanism(SC, [*LINEAR_COMPLETE, f"joints.B.mass={mass}"]))
    return mass, light, heavy


def test_slider_mass_stretches_the_rod_by_its_inertia_force(pair):
    mass, light, heavy = pair
    _, acc, th_rod = _slider(light.tau)
    expected = -mass * acc / np.cos(th_rod) / LAMBDA
    measured = heavy.column("eps_ax") - light.column("eps_ax")
    assert np.abs(measured - expected).max() < 1e-3 * np.abs(expected).max()
    # direction: stretched near the dead centres, compressed near the quarter turns
    assert measured[0] > 0 and measured[np.argmin(np.abs(light.tau - math.pi / 2))] < 0


def test_slider_mass_adds_its_kinetic_energy_rate_to_the_driver_torque(pair):
    mass, light, heavy = pair
    vel, acc, _ = _slider(light.tau)
    expected = mass * vel * acc
    measured = heavy.column("torque") - light.column("torque")
    assert np.abs(measured - expected).max() < 2e-3 * np.abs(expected).max()


def test_slider_mass_lowers_the_rods_axial_frequency():
    beta = 0.8603335890193797  # beta tan beta = 1 (slider mass = rod mass)
    assert beta * math.tan(beta) == pytest.approx(1.0, rel=1e-12)
    axial = ["bodies.rod.axial_shapes=complete", "bodies.rod.axial_modes=6"]
    free = modes(mechanism(SC, [*axial, "joints.B.mass=0.0"]), 0.0, shapes=False).frequencies("axial", "rod")[0]
    heavy = modes(mechanism(SC, [*axial, "joints.B.mass=1.0"]), 0.0, shapes=False).frequencies("axial", "rod")[0]
    assert free == pytest.approx(math.pi / 2 * math.sqrt(LAMBDA), rel=5e-4)  # Ritz: from above
    assert heavy == pytest.approx(beta * math.sqrt(LAMBDA), rel=1e-4)
