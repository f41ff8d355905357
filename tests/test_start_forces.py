"""The joint forces at an unstressed start (``symgen.numerics.start.continuum_start_outputs``):
the first sample a run records, on every path (IDAS, the C solver in process, the FMU), and
what the error estimate's truncation part makes of it.

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

import shutil

from symgen.numerics.error_estimate import richer_mechanism, truncation_deltas
from symgen.numerics.mechanism import load_mechanism
from symgen.numerics.simulate import simulate
from symgen.numerics.start import continuum_start_outputs, free_inertia_parameters, start_plan
from symgen.scene import load_scene

needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")

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


def test_the_start_plan_carries_the_limits_index_sets(scene_path):
    """The emitted C takes the same limit from the start plan: the rod's mass parameter and the
    joint-force outputs (not the deflection); none where a bar is axially rigid."""
    mech, _, _, _ = _start(scene_path)
    plan = start_plan(mech)
    assert plan.free_inertia == free_inertia_parameters(mech) == (mech.info.params.index("nu_rod"),)
    names = list(mech.info.outputs)
    assert plan.start_forces == (names.index("torque"), names.index("RA"))
    mech_qs = load_mechanism(load_scene(scene_path, ['effects.axial="quasi_static"']))
    assert start_plan(mech_qs).free_inertia == start_plan(mech_qs).start_forces == ()


def _first_samples_are_the_closed_form(tau, out, names, own):
    """The first sample: torque the closed form, RA zero; the deflection (not a joint force)
    the model's own; the second sample the model's motion (no longer the rigid parts')."""
    assert tau[0] == 0.0
    k = {n: names.index(n) for n in ("torque", "RA", "eta")}
    assert out[0, k["torque"]] == pytest.approx(ORACLE, rel=1e-9)
    assert abs(out[0, k["RA"]]) < 1e-9
    assert out[0, k["eta"]] == own["eta"]
    assert abs(own["torque"] - ORACLE) > 0.1 * ORACLE  # what the model's own would have recorded


def test_the_idas_runs_first_sample_is_the_closed_form(scene_path):
    mech, _, _, own = _start(scene_path)
    res = simulate(mech, t_end=0.05)
    assert res.start_forces == ("torque", "RA")
    _first_samples_are_the_closed_form(res.tau, res.outputs, list(res.output_names), own)


@needs_cc
def test_the_c_runs_first_sample_is_the_closed_form_and_the_idas_runs(scene_path):
    """--solver c: the C runtime's start takes the same limit (symgen_continuum_start_); the
    whole run agrees with IDAS's to the integrators' tolerances."""
    from symgen.numerics.csolver import simulate_c

    mech, _, _, own = _start(scene_path)
    res = simulate_c(mech, t_end=0.05)
    assert res.start_forces == ("torque", "RA")
    _first_samples_are_the_closed_form(res.tau, res.outputs, list(res.output_names), own)
    idas = simulate(mech, t_end=0.05)
    np.testing.assert_allclose(res.outputs[0], idas.outputs[0], rtol=0, atol=1e-12)
    peak = np.abs(idas.outputs).max(axis=0)
    assert np.all(np.abs(res.outputs - idas.outputs) <= 1e-3 * peak)


@needs_cc
def test_the_fmus_first_sample_is_the_closed_form(scene_path, tmp_path):
    """The FMU (the same C) records the continuum's start as its first output (FMPy's master)."""
    fmpy = pytest.importorskip("fmpy", reason="fmpy is not installed")
    from symgen.backends.c import c_context
    from symgen.backends.fmu import write_fmu
    from symgen.model.derive import derive

    mech, _, _, own = _start(scene_path)
    path = tmp_path / "law_start.fmu"
    write_fmu(mech.scene, path, c_context(mech.scene, derive(mech.scene), start_plan(mech), mech.info))
    res = fmpy.simulate_fmu(str(path), stop_time=0.05, output_interval=0.01)
    names = list(res.dtype.names[1:])
    out = np.column_stack([res[n] for n in names])
    _first_samples_are_the_closed_form(res["time"], out, names, own)


def test_the_estimate_charges_nothing_at_the_start(scene_path):
    """The richer model of the truncation part records the same continuum start (the limit does
    not depend on the counts), where the two models' own start torques differ: neither the rerun
    nor the linearised comparison charges the first sample."""
    mech, q, v, own = _start(scene_path)
    res = simulate(mech, t_end=0.1)
    richer, _ = richer_mechanism(mech)
    rich = simulate(richer, t_end=0.1)
    k = list(res.output_names).index("torque")
    assert rich.outputs[0, k] == pytest.approx(res.outputs[0, k], abs=1e-12)
    rq, rv, ra, rl, _ = richer.initial_state(0.0)
    rich_own = np.array(richer.call("out", 0.0, rq, rv, ra, rl)).ravel()[list(richer.info.outputs).index("torque")]
    assert abs(rich_own - own["torque"]) > 1e-3  # the models' own starts: 1/N of the rod's mass apart
    _, deltas, _ = truncation_deltas(mech, res, richer)
    assert deltas[0, k] == 0.0
    assert np.abs(deltas[1:, k]).max() > 0.0


def test_the_sidecar_says_what_the_first_sample_is(scene_path, tmp_path):
    """The run's sidecar names the outputs whose first sample is the continuum's; a scene whose
    bar is axially rigid at the start (quasi-static axial functions) records the model's own."""
    import json

    from symgen.api import simulate_scene

    for overrides, forces in (((), ["torque", "RA"]), (('effects.axial="quasi_static"',), [])):
        out = tmp_path / f"run{len(forces)}.csv"
        res = simulate_scene(str(scene_path), list(overrides) + ["simulation.t_end=0.05"], out=out, estimate="off")
        start = json.loads(out.with_suffix(".json").read_text())["start"]
        assert list(res.start_forces) == start["outputs"] == forces
        assert start["joint_forces"] == ("continuum" if forces else "model")
        assert ("continuum's" in start["note"]) == bool(forces)
