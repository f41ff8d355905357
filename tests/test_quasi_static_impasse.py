"""The quasi-static form's mass and its impasse (issue 19: legal input never gives an internal
error; docs/quasi-static-modes.md, "When the quasi-static form has no solution").

Scene: tests/data/four_bar_torque_spinup.toml (steel crank-rocker spun up by a torque, 3 + 4
functions per bar, the exact bar). With the top 3 transverse functions of both bars quasi-static
the coupler's dynamic axial rows read the quasi-static amplitudes through the axial-bending
coupling of the strain, and those amplitudes follow the crank's acceleration through their
inertia loads: the mass the accelerations see, ``M_dd - R_dh R_hh^-1 M_hd``, loses its
definiteness near tau = 19.34 (its smallest eigenvalue on the closure's motions, against the
full model's, 1.00 at the start, 0.084 at tau = 19.33, -0.037 at 19.34: measured). There the
quasi-static DAE has no solution for the accelerations and IDAS's corrector fails at any step.

Oracles:
* the index-1 DAE's Jacobian in z (``DaeRunner.g``): its determinant changes sign exactly where
  an eigenvalue of the quasi-static form's mass crosses 0 (the other blocks, the closure's and the
  stiffness of the quasi-static rows, stay regular), so the measure and the determinant, computed
  apart, must change sign between the same outputs;
* the all-dynamic run of the same scene: with 2 functions quasi-static per bar (no impasse) the
  run completes and differs from it by the quasi-static treatment's error, below
  simulation.accuracy (measured 4.6e-4 of peak).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.errors import SimulationError
from symgen.numerics import simulate as sim_mod

SCENE = Path(__file__).parent / "data" / "four_bar_torque_spinup.toml"
EXACT = ["effects.strain=exact"]


def _quasi(k: int) -> list[str]:
    return [f"bodies.coupler.quasi_static_transverse={k}", f"bodies.rocker.quasi_static_transverse={k}"]


@pytest.mark.slow
def test_impasse_stops_with_the_keys_named_and_the_mass_measured():
    """The run stops at the impasse with a SimulationError naming both keys and the measured mass
    (not an internal error, not a complete result), and the measure changes sign where the
    DAE's Jacobian's determinant does."""
    mech = mechanism(SCENE, EXACT + _quasi(3))
    with pytest.raises(SimulationError) as info:
        sim_mod.simulate(mech)
    err = info.value
    assert 19.2 < err.tau < 19.5
    text = str(err)
    for key in ("bodies.coupler.quasi_static_transverse", "bodies.rocker.quasi_static_transverse"):
        assert key in text
    assert "smallest eigenvalue" in text and "lower" in err.hint
    part = err.partial
    assert part is not None and not part.complete and part.tau[-1] < 19.5
    # the measure against the determinant of the algebraic Jacobian, output by output
    q0, v0, a0, lam0, partition = mech.initial_state(0.0)
    partition = mech.run_partition(partition)
    run = sim_mod.DaeRunner(mech, partition, 1e-8, 1e-10, backend="vm")
    ratios, signs = [], []
    for i in range(len(part.tau) - 6, len(part.tau)):
        x, z = run.pack(part.q[i], part.v[i], np.zeros(mech.n), part.lam[i])
        p = np.concatenate([mech.p, [part.tau[i]]])
        z = run.polish(0.0, x, z, p, tol=1e-12)
        ratios.append(sim_mod.quasi_mass_ratio(run, x, z, p))
        signs.append(np.linalg.slogdet(np.array(run.g(0.0, x, z, p)[1]))[0])
    assert ratios[0] > 0.3 and ratios[-1] < 0.0  # it falls through 0 within the last outputs
    flips_ratio = [k for k in range(1, len(ratios)) if np.sign(ratios[k]) != np.sign(ratios[k - 1])]
    flips_det = [k for k in range(1, len(signs)) if signs[k] != signs[k - 1]]
    assert flips_ratio == flips_det and len(flips_ratio) == 1
    # the C solver's path (symgen.numerics.csolver) measures the same at its last row
    c_err = sim_mod.quasi_failure_at(mech, part.tau[-1], part.q[-1], part.v[-1], part.lam[-1], "stopped")
    assert f"smallest eigenvalue was {ratios[-1]:.3g} " in str(c_err) and "lower" in c_err.hint
    # at the start the quasi-static amplitudes hardly feed back: the full model's mass
    x, z = run.pack(q0, v0, a0, lam0)
    p = np.concatenate([mech.p, [0.0]])
    assert sim_mod.quasi_mass_ratio(run, x, run.quasi_start(0.0, x, z), p) == pytest.approx(1.0, abs=0.01)


@pytest.mark.slow
def test_fewer_quasi_static_functions_complete_near_the_dynamic_run():
    """2 quasi-static functions per bar: the run completes and is within simulation.accuracy of
    the all-dynamic run (the same model and tolerances)."""
    full = sim_mod.simulate(mechanism(SCENE, EXACT))
    qs = sim_mod.simulate(mechanism(SCENE, EXACT + _quasi(2)))
    assert qs.complete and full.complete and qs.tau[-1] == pytest.approx(full.tau[-1])
    accuracy = mechanism(SCENE, EXACT).scene.simulation.accuracy
    for j, name in enumerate(full.output_names):
        a, b = np.asarray(qs.outputs)[:, j], np.asarray(full.outputs)[:, j]
        assert np.abs(a - b).max() < accuracy * np.abs(b).max(), name


def _chosen(mech):
    """``mech``'s scene with its stated quasi-static functions recorded as symgen's choice (the
    bases chooser's record: ``quasi`` as the bar's count, not ``quasi_stated``): no cheap scene
    is known where the chooser itself picks functions that meet the impasse, so the test forces
    the record the chooser would leave (symgen.scene.bases.quasi_choice)."""
    from dataclasses import replace

    from symgen.numerics.quasi_fallback import chosen_quasi_bars

    k = {b.name: b.quasi_static_transverse for b in mech.scene.bodies}
    bases = tuple(
        replace(c, quasi=k[c.bar], quasi_stated=False, quasi_reason="forced by the test") if k.get(c.bar) else c
        for c in mech.scene.bases
    )
    scene = replace(mech.scene, bases=bases)
    assert chosen_quasi_bars(scene) == ["coupler", "rocker"]
    return mechanism(scene)


@pytest.mark.slow
def test_chosen_quasi_static_functions_at_the_impasse_rerun_dynamic():
    """Quasi-static functions symgen chose (forced record, ``_chosen``) that meet the impasse:
    the run is made again with them dynamic (one warning line naming the bars, the tau and the
    quasi-static form), completes, and equals the all-dynamic run of the same model bit for bit;
    the stated key's own failure (the first test) keeps its exit-2 error."""
    from symgen.numerics.csolver import run as run_solver
    from symgen.numerics.mechanism import load_mechanism
    from symgen.numerics.results import attempt
    from symgen.numerics.strain_choice import run_with_strain_choice
    from symgen.scene.limits import SceneWarning

    def go(mech):
        return run_with_strain_choice(mech, load_mechanism, lambda m: attempt(lambda: run_solver(m, "idas")))

    forced = _chosen(mechanism(SCENE, EXACT + _quasi(3)))
    with pytest.warns(SceneWarning) as said:
        mech, result, failure = go(forced)
    lines = [str(w.message) for w in said if "quasi-static form met its impasse" in str(w.message)]
    assert len(lines) == 1, lines
    tau = float(lines[0].split("at tau = ")[1].split()[0])
    assert 19.0 < tau < 19.6 and "coupler, rocker" in lines[0] and "dynamic" in lines[0]
    assert failure is None and result is not None and result.complete
    assert not mech.quasi and all(b.quasi_static_transverse == 0 for b in mech.scene.bodies)
    assert all("impasse" in c.quasi_reason for c in mech.scene.bases if c.bar in ("coupler", "rocker"))
    _, full, full_failure = go(mechanism(SCENE, EXACT))
    assert full_failure is None and full is not None
    np.testing.assert_array_equal(np.asarray(result.outputs), np.asarray(full.outputs))
