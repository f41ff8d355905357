"""The joint forces at an unstressed start (``symgen.numerics.start.continuum_start_outputs``)
and their part of the error estimate (``error_estimate.start_part``).

At t0 an unstressed elastic bar transmits nothing: its points accelerate on their own until
waves have left the joints. So the driver torque at the start of a crank that drives an elastic
rod from rest is the closed form of the rigid parts alone, the crank's inertia about its pivot
and the pin mass at its tip, J theta''(0) = (alpha^3 / 3 + m_A alpha^2) theta''(0) (units
m_ref l0^3 omega^2); the slider's mass, at the rod's far end, is not felt. A truncated basis
leaves about 1/N of the rod's mass on the joints: its start torque approaches the closed form
only as the counts grow.
"""

from __future__ import annotations

import numpy as np
import pytest

from symgen.numerics.error_estimate import start_part
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from symgen.numerics.start import continuum_start_outputs, free_inertia_parameters
from symgen.scene import load_scene

ALPHA, M_A, THETA_DD = 0.5, 0.2, 1.0
#: the closed form: the crank (mass per length 1, length alpha) about its pivot and the pin mass
ORACLE = (ALPHA**3 / 3 + M_A * ALPHA**2) * THETA_DD

SCENE = f"""
[scene]
name = "law_start"
units = "dimensionless"
omega = 1.0
reference_length = 1.0

[[bodies]]
name = "crank"
length = {ALPHA}
rigid = true

[[bodies]]
name = "rod"
length = 1.0
lambda = 1e4
mu = 1.0
frame = "pinned-pinned"
axial_modes = 3
transverse_modes = 4

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]

[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "rod"]
at = [1.0, 0.0]
mass = {M_A}

[[joints]]
name = "B"
kind = "slider"
bodies = ["rod", "ground"]
at = [1.0, [0.0, 0.0]]
direction = [1.0, 0.0]
mass = 0.5

[driver]
kind = "angle"
body = "crank"
initial = 0.5
law = "{THETA_DD}*tau^2/2"

[effects]
axial = "dynamic"

[outputs]
torque = {{ kind = "driver_torque" }}
RA = {{ kind = "reaction", joint = "A", component = "x" }}
eta = {{ kind = "chord_deflection", body = "rod", at = 0.5 }}

[simulation]
t_end = 0.5
output_step = 0.01
"""


@pytest.fixture(scope="module")
def scene_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("start") / "law_start.toml"
    path.write_text(SCENE)
    return path


def _start(path, overrides=()):
    mech = load_mechanism(load_scene(path, list(overrides)))
    q, v, a, lam, _ = mech.initial_state(0.0)
    own = dict(zip(mech.info.outputs, np.array(mech.call("out", 0.0, q, v, a, lam)).ravel()))
    return mech, q, v, own


def test_start_torque_is_the_closed_form_of_the_rigid_parts(scene_path):
    mech, q, v, own = _start(scene_path)
    cont = continuum_start_outputs(mech, 0.0, q, v)
    assert cont is not None and set(cont) == {"torque", "RA"}  # the deflection is not a joint force
    assert cont["torque"] == pytest.approx(ORACLE, rel=1e-9)
    # the rod transmits nothing at t0: the pin A carries the pin mass, on the crank's side only
    # (RA is the force of the crank on the rod)
    assert abs(cont["RA"]) < 1e-9
    # the model's own start torque carries the rod's mass its 3 + 4 functions leave on the joints
    assert own["torque"] - ORACLE > 0.1 * ORACLE


def test_the_models_start_torque_approaches_it_as_the_counts_grow(scene_path):
    errs = []
    for na, nt in ((1, 1), (3, 4), (6, 8)):
        mech, q, v, own = _start(scene_path, [f"bodies.rod.axial_modes={na}", f"bodies.rod.transverse_modes={nt}"])
        cont = continuum_start_outputs(mech, 0.0, q, v)
        assert cont is not None and cont["torque"] == pytest.approx(ORACLE, rel=1e-9)  # whatever the counts
        errs.append(own["torque"] - ORACLE)
    # measured 0.052, 0.015, 0.0074 (0.57, 0.17, 0.08 of the closed form): about 1/N of the rod's mass
    assert errs[0] > errs[1] > errs[2] > 0
    assert errs[2] > 0.05 * ORACLE


def test_kept_where_the_start_is_deformed_or_a_bar_is_rigid_in_a_direction(scene_path):
    mech, q, v, _ = _start(scene_path)
    deformed = q.copy()
    deformed[mech.info.elastic[0]] = 1e-4
    assert continuum_start_outputs(mech, 0.0, deformed, v) is None
    # quasi-static axial functions (no axial waves): the bar's axial inertia acts at once
    mech_qs = load_mechanism(load_scene(scene_path, ['effects.axial="quasi_static"']))
    assert free_inertia_parameters(mech_qs) == ()


def test_the_estimate_covers_the_start(scene_path):
    """The truncation part's start term is the model's start torque against the closed form."""
    mech, _, _, own = _start(scene_path)
    res = simulate(mech)
    peak = float(np.abs(res.column("torque")).max())
    part = start_part(mech, res)
    assert part["torque"] == pytest.approx(abs(own["torque"] - ORACLE) / peak, rel=1e-6)
    assert "eta" not in part
