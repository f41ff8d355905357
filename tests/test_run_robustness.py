"""Runs that used to stall, stop at a wrong tau or refuse a legal scene (issues 21, 22). The
progress watchdog of the IDAS runs: a run whose steps shrink to nothing stops
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
    assert "near-singular" not in str(err)  # the slider-crank is far from its toggles here


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
    simulate(mech, backend="vm")  # the API's default: no bar
    assert quiet.getvalue() == ""


def test_a_four_bar_without_a_guess_assembles_and_says_which_branch(tmp_path, capsys):
    """A plain four-bar without [initial] guess failed at tau = 0 ("not independent: singular
    position"): the branches are found from seeded guesses, the upper one taken (the example's
    guess), and the note gives the initial.guess of the other."""
    text = (ROOT / "examples" / "four_bar.toml").read_text()
    path = tmp_path / "no_guess.toml"
    path.write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith("guess =")) + "\n")
    over = ["simulation.cycles=0.1"]
    res = simulate(mechanism(path, over), backend="vm")
    note = capsys.readouterr().err
    assert "assembled on branch 1 of 2 found" in note and "set initial.guess = {" in note, note
    ref = simulate(mechanism(ROOT / "examples" / "four_bar.toml", over), backend="vm")
    np.testing.assert_allclose(res.outputs, ref.outputs, rtol=1e-6, atol=1e-9 * np.abs(ref.outputs).max())


def test_the_branch_note_is_told_once_per_run(tmp_path, capsys, monkeypatch):
    """A run without initial.guess at a singular start told its branch note once per start it
    computed: three times for one `symgen simulate` (the run, then the error estimate's reruns of
    the run and of its richer model). Told once; the reruns still start on the same branch."""
    from symgen.api import simulate_scene
    from symgen.numerics import start
    from symgen.scene import load_scene

    monkeypatch.setattr(start, "_NOTES_TOLD", set())
    text = SLIDER.read_text().replace("direction = [1.0, 0.0]", "direction = [0.0, 1.0]")
    assert "direction = [0.0, 1.0]" in text
    path = tmp_path / "vertical.toml"
    path.write_text(text)
    scene = load_scene(path, ["simulation.cycles=0.25"])
    simulate_scene(scene, out=tmp_path / "vertical.csv")
    err = capsys.readouterr().err
    assert err.count("assembled on branch 1 of 2 found") == 1, err
    assert "error_estimate" in (tmp_path / "vertical.json").read_text()
