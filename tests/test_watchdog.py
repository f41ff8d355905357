"""The progress watchdog of the IDAS runs (issue 22): a run whose steps shrink to nothing stops
in seconds naming where and why, and a chunk that IDAS could not finish in one call but can
output by output goes on (it ended the run, at a wrong tau, after 2 million steps)."""
from __future__ import annotations

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.errors import SimulationError
from symgen.numerics import simulate as sim_mod
from symgen.numerics.simulate import simulate
from tests.conftest import ROOT

SLIDER = ROOT / "examples" / "slider_crank.toml"


def test_a_near_toggle_crank_goes_through_without_grinding():
    """Crank 0.999999, rod 1.0: the rod stands nearly upright at tau = pi/2. The run used to
    grind through 2 million IDAS steps there and stop with "failed in a chunk but not step by
    step" at tau = 0; it now completes, with the closure held and a bounded number of steps."""
    mech = mechanism(SLIDER, ["bodies.crank.length=0.999999", "bodies.rod.length=1.0", "simulation.cycles=0.5"])
    res = simulate(mech, backend="vm")
    assert res.complete and res.tau[-1] == pytest.approx(np.pi, abs=1e-9)
    assert res.closure_max < 1e-10
    assert res.steps < 10 * sim_mod.MAX_STEPS_PER_DEGREE


def test_a_stalled_run_stops_naming_tau_and_the_likely_cause(monkeypatch):
    """With a budget no run can meet, the failure names the output step, the budget and what to
    check, and keeps the outputs before it (as any failed run)."""
    monkeypatch.setattr(sim_mod, "MAX_STEPS_PER_DEGREE", 3)
    mech = mechanism(SLIDER, ["simulation.cycles=0.25"])
    with pytest.raises(SimulationError) as info:
        simulate(mech, backend="vm")
    err = info.value
    assert "no progress: IDAS took more than 3 steps within the output step from tau = " in str(err), err
    assert err.tau is not None and err.partial is not None and len(err.partial.tau) >= 1
    assert "near-singular" not in str(err)      # the slider-crank is far from its toggles here


def test_simulate_shows_its_progress_on_a_terminal(monkeypatch):
    """A long `symgen simulate` printed nothing until it ended: on a terminal a bar of the
    outputs done goes to stderr (never to stdout, never into a pipe or a log)."""
    import io

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    monkeypatch.setattr("sys.stderr", term)
    mech = mechanism(SLIDER, ["simulation.cycles=0.5"])
    simulate(mech, backend="vm", progress=True)
    assert "simulate" in term.getvalue() and "output" in term.getvalue()
    quiet = Terminal()
    monkeypatch.setattr("sys.stderr", quiet)
    simulate(mech, backend="vm")                # the API's default: no bar
    assert quiet.getvalue() == ""
