"""``--solver c`` beyond ``simulate``: the Python API, ``sweep``, ``study`` and ``effects --measure``
(issue 20 item 3). Each runs the emitted C Radau IIA in process and gives what the IDAS path
gives to the run's tolerance (the oracle here is the IDAS path at the same settings: both are
converged well below the asserted bound at these tolerances, see tests/test_c_dense.py); a sweep
over parameter values compiles one library for all its points."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from symgen.errors import SceneError

ROOT = Path(__file__).resolve().parent.parent
SLIDER = ROOT / "examples" / "slider_crank.toml"
SHORT = ["simulation.cycles=0.25"]

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _c_entries(cache: Path) -> list[Path]:
    return sorted(p for p in (cache / "compiled").glob("c*") if (p / "solver.so").exists())


def test_api_solver_c_gives_the_idas_results_and_writes_the_same_files(cache, tmp_path):
    from symgen.api import simulate_scene

    ref = simulate_scene(SLIDER, SHORT)
    got = simulate_scene(SLIDER, SHORT, solver="c")
    assert got.output_names == ref.output_names and got.outputs.shape == ref.outputs.shape
    np.testing.assert_allclose(got.tau, ref.tau, rtol=0, atol=1e-12)
    for k in (0, 1, 2):  # eta_mid, eps_ax, torque: the scene's rtol 1e-8, the axial ringing 3e-3 (test_compiled)
        assert np.abs(got.outputs[:, k] - ref.outputs[:, k]).max() < 3e-3 * np.abs(ref.outputs[:, k]).max()
    assert np.abs(got.q - ref.q).max() < 1e-4 * np.abs(ref.q).max()
    simulate_scene(SLIDER, SHORT, out=tmp_path / "c.csv", states=True, solver="c")
    meta = json.loads((tmp_path / "c.json").read_text())
    assert meta["status"] == "complete" and meta["solver"]["backend"] == "c" and meta["states"]["columns"]
    with pytest.raises(SceneError, match="solver"):
        simulate_scene(SLIDER, SHORT, solver="radau")
    with pytest.raises(ValueError, match="backend"):
        simulate_scene(SLIDER, SHORT, solver="c", backend="vm")
    with pytest.raises(ValueError, match="backend"):
        simulate_scene(SLIDER, SHORT, out=tmp_path / "d.csv", solver="c", backend="vm")


def test_sweep_over_values_compiles_one_library_and_matches_idas(cache):
    from symgen.api import sweep

    vary = {"bodies.rod.mu": "0.3,0.495,0.8"}  # the bending stiffness: each point's own parameters
    lines: list[str] = []
    c = sweep(SLIDER, vary, SHORT, workers=1, solver="c", progress=False, say=lines.append)
    assert len(_c_entries(cache)) == 1, _c_entries(cache)
    assert any("1 library compiled" in ln for ln in lines), lines
    i = sweep(SLIDER, vary, SHORT, workers=1, progress=False)
    assert list(c["status"]) == list(i["status"]) == ["ok"] * 3
    # the bending peak to 1e-4; the torque carries the axial ringing that neither resolves at the
    # scene's rtol 1e-8 (3e-3, test_compiled): measured 1.6e-4 apart at another lambda
    np.testing.assert_allclose(c["peak_eta_mid"], i["peak_eta_mid"], rtol=1e-4)
    np.testing.assert_allclose(c["peak_torque"], i["peak_torque"], rtol=3e-3)
    assert c["peak_eta_mid"][0] > 1.5 * c["peak_eta_mid"][2]  # the points differ: not the first's parameters


@pytest.mark.slow
def test_effects_measure_with_solver_c_measures_what_idas_measures(cache):
    from symgen.apps.effects import measure_effects, table

    c = measure_effects(str(SLIDER), [], cycles=0.25, solver="c")
    i = measure_effects(str(SLIDER), [], cycles=0.25)
    assert [r.change.key for r in c.rows] == [r.change.key for r in i.rows]
    assert "Radau IIA (C) steps" in table(c) and "IDAS steps" in table(i)
    for a, b in zip(c.rows, i.rows):
        assert a.status == b.status, (a.change.key, a.status, b.status)
        if a.error is not None and b.error is not None and max(a.error, b.error) > 1e-3:
            assert a.error == pytest.approx(b.error, rel=0.1), a.change.key  # the measured error of an effect


@pytest.mark.slow
def test_study_with_solver_c_runs_every_configuration_in_c(cache):
    from symgen.apps.study import run_study

    kw = dict(levels=[(1, 1), (2, 2)], tolerances=[1e-6], repeats=1, per_bar=False, effects=False, t_end=1.5)
    c = run_study(str(SLIDER), [], solver="c", **kw)
    i = run_study(str(SLIDER), [], **kw)
    assert c.solver == "c" and [r.status for r in c.rows] == [r.status for r in i.rows]
    assert all(r.status == "ok" for r in c.rows)
    # a model's error (1+1 modes: 2.7 %) is the same whichever solver; an integration error is
    # each solver's own (Radau IIA at rtol 1e-6: 7e-6, IDAS: 1.7e-4; both far below the models')
    for a, b in zip(c.rows, i.rows):
        if max(a.error, b.error) > 1e-3:
            assert a.error == pytest.approx(b.error, rel=0.01), a.config.label
        else:
            assert a.error < 1e-3 and b.error < 1e-3, a.config.label
    assert sum(max(a.error, b.error) > 1e-3 for a, b in zip(c.rows, i.rows)) == 2  # both 1+1 rows


def test_the_estimate_of_a_solver_c_run_measures_the_c_solvers_time_error(cache):
    """After a ``--solver c`` run the error estimate's time-integration part reruns the run at
    tighter tolerances in the C solver (the error of the solver that made the run); the
    truncation part's richer model runs in IDAS while its C library is not built (the estimate
    never builds it: no second C library on the run's way), in its C solver once it is. The
    truncation part is the IDAS run's to within the runs' tolerance either way (the same two
    models; the oracle is the IDAS path's estimate)."""
    from symgen.api import mechanism
    from symgen.numerics.csolver import simulate_c
    from symgen.numerics.error_estimate import estimate_errors, richer_mechanism
    from symgen.numerics.simulate import simulate

    mech = mechanism(SLIDER, SHORT)
    sim = mech.scene.simulation
    c_run = simulate_c(mech)
    idas_run = simulate(mech)
    c_est = estimate_errors(mech, c_run, sim.rtol, sim.atol)
    idas_est = estimate_errors(mech, idas_run, sim.rtol, sim.atol)
    assert "tighter tolerances (the C solver)" in c_est.methods["time_integration"]
    assert "tighter tolerances (IDAS)" in idas_est.methods["time_integration"]
    assert "IDAS steps" in c_est.methods["truncation"]
    assert len(_c_entries(cache)) == 1  # the run's library only: the richer one was not built
    simulate_c(richer_mechanism(mech)[0])  # the richer model's C solver, built outside the estimate
    assert len(_c_entries(cache)) == 2
    c_rich_est = estimate_errors(mech, c_run, sim.rtol, sim.atol)
    assert "Radau IIA (C) steps" in c_rich_est.methods["truncation"], c_rich_est.methods["truncation"]
    assert "IDAS steps" in estimate_errors(mech, idas_run, sim.rtol, sim.atol).methods["truncation"]
    assert len(_c_entries(cache)) == 2
    for est in (c_est, c_rich_est):
        for name, value in idas_est.parts["truncation"].items():
            got = est.parts["truncation"][name]
            if value is None:
                assert got is None
                continue
            assert got is not None and value > 0
            print(f"{name}: truncation after C {got:.3e}, after IDAS {value:.3e}")
            assert 0.8 < got / value < 1.25, name


def test_a_first_run_with_solver_c_derives_its_scene_once(cache, monkeypatch):
    """The emitted C solver's first build takes the model the run derived for its CasADi
    Functions (``CompiledModel.take_derived``) instead of deriving the scene again; a later
    build (the model from the cache) derives it (the C is emitted from SymPy)."""
    from symgen.api import simulate_scene
    from symgen.model import derive as derive_module
    from symgen.model.structure import structure_key, structure_of

    keys: list[str] = []
    real = derive_module.derive

    def counted(scene):
        keys.append(structure_key(structure_of(scene)))
        return real(scene)

    monkeypatch.setattr(derive_module, "derive", counted)
    sets = [*SHORT, "effects.strain=von_karman"]
    first = simulate_scene(SLIDER, sets, solver="c")
    assert keys and len(keys) == len(set(keys)), keys  # each model derived once
    # the C library is cached now: a run with another tolerance builds nothing and derives nothing
    keys.clear()
    again = simulate_scene(SLIDER, sets, solver="c")
    assert keys == []
    np.testing.assert_array_equal(np.asarray(first.outputs), np.asarray(again.outputs))
    # the library removed, the model cached: the C build derives the scene itself, once
    for entry in _c_entries(cache):
        shutil.rmtree(entry)
    simulate_scene(SLIDER, sets, solver="c")
    assert len(keys) == 1
