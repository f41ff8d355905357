"""The error estimate's reruns have a budget (``symgen.policy.RERUN_BUDGET`` times the steps of
the run they check, issue 19): past it a rerun is stopped, its part is "not estimated (budget:
...)" and no output gets a total (never a small number that looks like an estimate), the counts
as chosen are kept (the counts' decision is that truncation part), the run's results are written
and the CLI warns and says what to do. Tested with a tiny budget (the constant set by the test)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from symgen import policy
from symgen.cli import main
from symgen.errors import BudgetExceeded
from symgen.numerics import error_estimate as ee


def test_the_budget_is_a_multiple_of_the_run_at_least_one_step_per_output():
    assert policy.rerun_budget(1000, 200) == int(policy.RERUN_BUDGET * 1000)
    assert policy.rerun_budget(10, 200) == int(policy.RERUN_BUDGET * 200)  # one step per output at least
    assert policy.rerun_budget(1000, 200, factor=0.5) == 500


def test_a_run_past_its_step_budget_stops_with_what_it_made_in_idas_and_in_c(tmp_path):
    """IDAS checks the budget before each chunk of outputs (its chunks a run's without a budget:
    CHUNK, then doubling), the C solver every STEPS_PER_CALL steps: both stop with BudgetExceeded
    and the rows before it, the very rows of the same run without a budget, which is complete."""
    from test_energy import write_pendulum

    from symgen.api import mechanism
    from symgen.numerics.csolver import STEPS_PER_CALL, simulate_c
    from symgen.numerics.simulate import CHUNK, simulate

    scene = write_pendulum(tmp_path, lam=1e3, mu=5.0, t_end=20.0, output_step=0.01, rtol=1e-9, atol=1e-11)
    mech = mechanism(scene)
    for run in (lambda **k: simulate(mech, **k), lambda **k: simulate_c(mech, **k)):
        full = run()
        assert full.complete and full.steps > 4 * STEPS_PER_CALL  # the budget below stops it early
        with pytest.raises(BudgetExceeded, match="budget: stopped after") as stop:
            run(max_steps=full.steps // 4)
        part = stop.value.partial
        assert part is not None and not part.complete
        assert full.steps // 4 < stop.value.steps <= full.steps
        assert 2 <= len(part.tau) < len(full.tau)
        k = len(part.tau)
        if part.stats.get("backend") != "c":  # IDAS stopped at a chunk's end
            assert (k - 1) % CHUNK == 0
        # the rows before the stop are the run's: a budget changes no step
        assert np.array_equal(part.outputs[:k], full.outputs[:k])


def test_past_the_budget_the_parts_are_not_estimated_and_the_chosen_counts_kept(tmp_path, capsys, monkeypatch):
    """The whipping pendulum whose chosen counts the truncation rerun raises
    (tests/test_counts_choice.py): with a tiny budget the rerun is stopped, the counts stay as
    chosen, the run is written, its truncation and time parts are not estimated with the budget as
    the reason (not the time part's a-priori bound), no output has a total, the CLI warns, and the
    stopped rerun is not made a second time by the run's own estimate."""
    from test_counts_choice import _scene

    from symgen.numerics import simulate as sim_module

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(policy, "RERUN_BUDGET", 1e-3)
    path = _scene(tmp_path, "budget")
    budgets: list[int | None] = []
    real_simulate = sim_module.simulate

    def counted(m, *a, **k):
        budgets.append(k.get("max_steps"))
        return real_simulate(m, *a, **k)

    monkeypatch.setattr(sim_module, "simulate", counted)
    assert main(["simulate", str(path), "-o", str(tmp_path / "run.csv"), "-v"]) == 0
    out, err = capsys.readouterr()
    assert "running it" not in err and "raised" not in out  # the counts as chosen
    reruns = [b for b in budgets if b is not None]
    assert len(reruns) == 1, budgets  # the tighter rerun, stopped once: not made again
    side = json.loads((tmp_path / "run.json").read_text())
    assert not any(c["raised"] for c in side["bases"].values())
    assert all(c["chosen"] == [True, True] for c in side["bases"].values())
    assert np.loadtxt(tmp_path / "run.csv", delimiter=",", skiprows=1).shape[0] == 701  # the run, whole
    detail = side["error_estimate_detail"]
    for part in ("truncation", "time_integration"):
        assert detail["methods"][part] == "not estimated"
        assert detail["reasons"][part].startswith(ee.BUDGET_PREFIX), detail["reasons"][part]
        assert all(v is None for v in detail["parts"][part].values())
    assert all(v is None for v in side["error_estimate"].values())  # no total that looks like one
    assert "truncation part is not estimated" in err and "--estimate linearized or off" in err
    assert "bodies.NAME.axial_modes" in err
    assert "not estimated (a rerun's budget)" in out
