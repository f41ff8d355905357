"""Runs with no differential states (issue 20): every rigid coordinate driven and every elastic
amplitude quasi-static (``bodies.<name>.quasi_static_transverse`` = all of them, the axial ones
quasi-static), or a rigid mechanism driven through all its degrees of freedom. IDAS has nothing to
integrate: each output is the algebraic solution at its time, by Newton continued from the
previous outputs (``symgen.numerics.simulate.AlgebraicSweep``: a CasADi Function made once per
mechanism, one call per block of outputs).

Oracles:
* the per-output Newton the sweep replaced, written here in numpy: from the previous two outputs'
  solutions extrapolated, Newton with LAPACK's LU to |g| < 1e-12 (at most 30 steps), the outputs
  from the model's own output function at each state. The same numbers to 1e-9 relative
  (measured: 7e-15) on the steel slider-crank from rest (benchmarks/validation) and the paper's
  slider-crank with its axial function quasi-static;
* the turning arm's Euler-Bernoulli closed form (tests/test_quasi_static_modes.py's scene with
  every function quasi-static): tip deflection -g cos(theta) / (8 mu);
* a mechanism with a rigid degree of freedom that no driver takes (a free pendulum, every
  elastic function quasi-static) keeps its differential states: IDAS integrates it.
"""

from __future__ import annotations

import json
import os
import signal
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.cli import main
from symgen.errors import Interrupted, SimulationError
from symgen.numerics import error_estimate, interrupt
from symgen.numerics import simulate as S
from symgen.numerics.error_estimate import estimate_errors

ROOT = Path(__file__).resolve().parent.parent
STEEL = str(ROOT / "benchmarks" / "validation" / "slider_crank_steel_rest.toml")
STEEL_QS = ["bodies.rod.quasi_static_transverse=3"]
PAPER = str(ROOT / "examples" / "slider_crank.toml")
PAPER_QS = ["bodies.rod.quasi_static_transverse=1", "effects.axial=quasi_static"]


def _mech(scene, overrides=()):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the bases' warnings (modes of the dynamic band static)
        return mechanism(scene, list(overrides))


def _per_output(mech, result):
    """The oracle: the former loop, one output at a time in numpy (module docstring). Returns the
    outputs, q, v, lam of outputs 1.. of ``result``'s grid (the first is the start)."""
    part = result.partition
    run = S.DaeRunner(mech, part, 1e-8, 1e-10, backend="vm")
    q, v, a, lam, _ = mech.initial_state(0.0)
    x, z = run.pack(q, v, a, lam)
    if part.quasi:
        z = run.quasi_start(0.0, x, z)
    z_prev = z
    rows: dict[str, list[np.ndarray]] = {"outputs": [], "q": [], "v": [], "lam": []}
    for t in result.tau[1:]:
        p = np.concatenate([mech.p, [t]])
        zi = 2 * z - z_prev
        for _ in range(30):
            g, J = (np.array(w) for w in run.g(0.0, x, zi, p))
            if np.abs(g).max() < 1e-12:
                break
            zi = zi - np.linalg.solve(J, g.ravel())
        z_prev, z = z, zi
        qq, vv, aa, ll = run.unpack(x, z)
        rows["outputs"].append(mech.call("out", t, qq, vv, aa, ll))
        rows["q"].append(qq)
        rows["v"].append(vv)
        rows["lam"].append(ll)
    return {k: np.array(w) for k, w in rows.items()}


def _relative(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


@pytest.mark.parametrize(
    "scene,overrides",
    [(STEEL, STEEL_QS), (PAPER, [*PAPER_QS, "simulation.cycles=0.5"])],
    ids=["steel_slider_crank", "paper_slider_crank"],
)
def test_the_sweep_gives_the_numbers_of_the_per_output_newton(scene, overrides):
    mech = _mech(scene, overrides)
    res = S.simulate(mech)
    assert res.partition.ind == () and res.partition.quasi  # nothing to integrate
    assert res.complete and res.steps == 0 and res.stats["differential_states"] == 0
    n = len(res.tau) - 1
    assert n >= 180
    # Newton converges in a few steps per output from the extrapolated guess
    assert n <= res.stats["newton_iterations"] <= 5 * n
    ref = _per_output(mech, res)
    for key in ("outputs", "q", "v", "lam"):
        assert _relative(getattr(res, key)[1:], ref[key]) < 1e-9, key
    assert res.closure_max < 1e-12
    # made once per mechanism: a second run reuses the sweep (and gives the same numbers)
    sweeps = dict(mech.algebraic_sweeps)
    again = S.simulate(mech)
    assert mech.algebraic_sweeps == sweeps and np.array_equal(again.outputs, res.outputs)


def test_blocks_and_chunks_do_not_change_the_numbers(monkeypatch):
    """A run split into other blocks (the mapaccum width) gives the same numbers to the last bit:
    each output is solved from the same two previous solutions whatever the split; other chunks
    (the recording's) too, up to the rounding of the output times (t_start + i h)."""
    mech = _mech(PAPER, [*PAPER_QS, "simulation.cycles=0.5"])
    res = S.simulate(mech)
    monkeypatch.setattr(S.AlgebraicSweep, "BLOCK", 7)
    mech.algebraic_sweeps.clear()
    blocks = S.simulate(mech)
    assert np.array_equal(blocks.outputs, res.outputs) and np.array_equal(blocks.q, res.q)
    assert blocks.stats["newton_iterations"] == res.stats["newton_iterations"]
    monkeypatch.setattr(S, "CHUNK", 5)
    chunks = S.simulate(mech)
    assert np.abs(chunks.tau - res.tau).max() < 1e-15 * res.tau[-1] * 10
    for key in ("outputs", "q", "v", "lam"):
        assert _relative(getattr(chunks, key), getattr(res, key)) < 1e-12, key


def _arm(path, *, driven, g=1e-3, mu=1e4, lam=1e6, t_end=3.2):
    # driven: turned at rate 1 from theta = 0; free: released from rest at theta = -0.5
    driver = '[driver]\nkind = "angle"\nbody = "arm"\nrate = 1.0' if driven else ""
    guess = "" if driven else "guess = { arm = -0.5 }"
    text = f"""
[scene]
name = "turning_arm"
units = "dimensionless"
[[bodies]]
name = "arm"
length = 1.0
mass_per_length = 1.0
lambda = {lam!r}
mu = {mu!r}
frame = "cantilever"
axial_modes = 1
transverse_modes = 4
quasi_static_transverse = 4
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
{driver}
[initial]
deformation = "quasi-static"
{guess}
[effects]
axial = "quasi_static"
gravity = [0.0, {-g!r}]
[outputs]
tip = {{ kind = "deflection", body = "arm", at = 1.0 }}
angle = {{ kind = "angle", body = "arm" }}
[simulation]
t_end = {t_end!r}
output_step = 0.05
rtol = 1e-8
atol = 1e-12
"""
    file = path / f"arm_{'driven' if driven else 'free'}.toml"
    file.write_text(text)
    return str(file)


def test_a_driven_arm_with_every_function_quasi_static_against_the_closed_form(tmp_path):
    """The turning arm of tests/test_quasi_static_modes.py, every function quasi-static (the axial
    one too): the static deflection of a uniformly loaded cantilever, -g cos(theta) / (8 mu),
    within its centrifugal stiffening and stretch, O(1/mu) and O(1/lambda) (the same bound as
    that module's; measured 7.7e-5 of peak)."""
    mech = _mech(_arm(tmp_path, driven=True))
    res = S.simulate(mech)
    assert res.partition.ind == () and res.steps == 0 and res.stats["newton_iterations"] > 0
    exact = -1e-3 * np.cos(res.column("angle")) / (8 * 1e4)
    assert np.abs(res.column("tip") - exact).max() / np.abs(exact).max() < 1.5e-4 + 2.0 / 1e6


def test_a_free_pendulum_with_every_function_quasi_static_is_integrated(tmp_path):
    """No driver: the arm's angle is a differential state even with every elastic amplitude
    quasi-static; IDAS integrates it (and the sidecar says so)."""
    file = _arm(tmp_path, driven=False, t_end=1.0)
    mech = _mech(file)
    res = S.simulate(mech)
    assert [mech.coords[i].name for i in res.partition.ind] == ["theta_arm"]
    assert res.steps > 0 and res.stats["differential_states"] == 2 and res.stats["newton_iterations"] is None
    # it swings as a rigid bar pinned at its end does from rest: theta'' = -(3 g / 2) cos(theta),
    # theta(t) = theta0 - (3 g / 4) cos(theta0) t^2 + O(g^2 t^4) (4e-8 here; the bending O(1/mu))
    swing = res.column("angle") - (-0.5 - 0.75e-3 * np.cos(0.5) * res.tau**2)
    assert np.abs(swing).max() < 2e-6
    out = tmp_path / "free.csv"
    assert main(["simulate", file, "-o", str(out), "--estimate", "off"]) == 0
    solver = json.loads(out.with_suffix(".json").read_text())["solver"]
    assert solver["steps"] > 0 and solver["differential_states"] == 2 and solver["newton_iterations"] is None


FOUR_BAR_TOGGLE = """
[scene]
name = "toggle"
[[bodies]]
name = "crank"
length = 1.5
rigid = true
[[bodies]]
name = "coupler"
length = 1.0
rigid = true
[[bodies]]
name = "rocker"
length = 1.0
rigid = true
[[joints]]
name = "O2"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "coupler"]
at = [1.0, 0.0]
[[joints]]
name = "B"
kind = "pin"
bodies = ["coupler", "rocker"]
at = [1.0, 1.0]
[[joints]]
name = "O4"
kind = "pin"
bodies = ["ground", "rocker"]
at = [[2.0, 0.0], 0.0]
[driver]
kind = "angle"
body = "crank"
initial = 0.5
rate = 1.0
[initial]
guess = { coupler = 0.24, rocker = 1.28 }
[outputs]
rocker = { kind = "angle", body = "rocker" }
torque = { kind = "driver_torque" }
[simulation]
t_end = 2.0
output_step = 0.005
"""


def test_a_rigid_mechanism_driven_into_a_toggle_keeps_the_outputs_before_it(tmp_path):
    """The non-Grashof four-bar of tests/test_cli.py, rigid and driven (no differential state),
    meets its toggle at tau = acos(0.375) - 0.5 = 0.686: the run stops there naming the loop, with
    every output before it, each the oracle's."""
    scene = tmp_path / "toggle.toml"
    scene.write_text(FOUR_BAR_TOGGLE)
    mech = _mech(scene)
    with pytest.raises(SimulationError) as info:
        S.simulate(mech)
    err = info.value
    assert "singular position" in str(err) and "loop closed by joint 'B'" in str(err)
    assert err.tau == pytest.approx(np.arccos(0.375) - 0.5, abs=0.02)
    part = err.partial
    assert not part.complete and part.partition.ind == ()
    assert 130 < len(part.tau) and part.tau[-1] <= err.tau  # beyond the first chunk and block
    ref = _per_output(mech, part)
    assert _relative(part.outputs[1:], ref["outputs"]) < 1e-9


def _signal_at(real, at, surfaces=None):
    """``real`` wrapped: its ``at``-th call sends SIGINT to this process first (the handler's
    ``Interrupted``, or ``surfaces`` made of it, as CasADi's calls can report it)."""
    calls = []

    def wrapped(*a, **k):
        calls.append(None)
        if len(calls) == at:
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)  # the handler raises during the sleep
            except Interrupted as stop:
                if surfaces is None:
                    raise
                raise surfaces from stop
            pytest.fail("the SIGINT handler did not raise")
        return real(*a, **k)

    return wrapped


@pytest.mark.parametrize(
    "surfaces",
    [None, SystemError("<function DM.__array__ at 0x7f0000000000> returned a result with an exception set")],
    ids=["Interrupted", "SystemError"],
)
def test_an_interrupt_keeps_the_outputs_solved_before_it(monkeypatch, surfaces):
    """800 outputs: chunks of 128, 256 and 416; SIGINT at the second chunk's sweep keeps the
    start and the first chunk, with the tau reached."""
    mech = _mech(STEEL, [*STEEL_QS, "simulation.output_interval=0.005"])
    monkeypatch.setattr(S.AlgebraicSweep, "solve", _signal_at(S.AlgebraicSweep.solve, 2, surfaces))
    with pytest.raises(KeyboardInterrupt) as info:
        with interrupt.handling():
            S.simulate(mech)
    stop = info.value
    assert isinstance(stop, Interrupted) and stop.exit_code == 130
    part = stop.partial
    assert not part.complete and len(part.tau) == 1 + S.CHUNK and part.outputs.shape[0] == 1 + S.CHUNK
    assert stop.tau == part.tau[-1] == pytest.approx(S.CHUNK * 0.005)
    assert part.stats["differential_states"] == 0 and part.stats["newton_iterations"] >= S.CHUNK


def test_the_command_line_interrupted_writes_the_partial_result_and_its_sidecar(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(S.AlgebraicSweep, "solve", _signal_at(S.AlgebraicSweep.solve, 2))
    out = tmp_path / "steel.csv"
    sets = ["--set", STEEL_QS[0], "--set", "simulation.output_interval=0.005"]
    code = main(["simulate", STEEL, "-o", str(out), "--estimate", "off", *sets])
    err = capsys.readouterr().err
    assert code == 130, err
    assert "interrupted by SIGINT at tau =" in err and "Traceback" not in err
    assert not out.exists()
    meta = json.loads((tmp_path / "steel.partial.json").read_text())
    assert meta["status"] == "interrupted" and meta["failure"].startswith("interrupted by SIGINT at tau =")
    assert meta["solver"]["differential_states"] == 0 and meta["solver"]["newton_iterations"] >= S.CHUNK
    rows = np.loadtxt(tmp_path / "steel.partial.csv", delimiter=",", skiprows=1)
    assert len(rows) == 1 + S.CHUNK and rows[-1, 0] == pytest.approx(S.CHUNK * 0.005)


def test_the_sidecar_and_the_command_line_say_what_solved_the_run(tmp_path, capsys):
    out = tmp_path / "qs.csv"
    code = main(["simulate", PAPER, "-o", str(out), "--estimate", "off", *sum((["--set", o] for o in PAPER_QS), [])])
    text = capsys.readouterr().out
    assert code == 0
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["status"] == "complete" and meta["partition"]["independent"] == []
    assert meta["partition"]["quasi_static"] == ["g_rod_1"]
    solver = meta["solver"]
    assert solver["name"] == "idas" and solver["steps"] == 0 and solver["differential_states"] == 0
    n = len(np.loadtxt(out, delimiter=",", skiprows=1)) - 1
    assert n <= solver["newton_iterations"] <= 5 * n
    assert f"no differential states: Newton at each output, {solver['newton_iterations']} iterations" in text
    assert meta["timings"]["simulate_s"] > 0 and meta["closure_residual_max"] < 1e-12


def test_the_estimate_says_nothing_was_integrated_and_does_not_rerun_it(monkeypatch):
    """The time-integration part of a run with no differential states is 0, the method text says
    why, and the run is not repeated at tighter tolerances (it would solve the same equations)."""
    mech = _mech(PAPER, [*PAPER_QS, "simulation.cycles=0.25"])
    res = S.simulate(mech)

    def no_rerun(*args, **kwargs):
        raise AssertionError("the run was rerun at tighter tolerances")

    monkeypatch.setattr(error_estimate, "_tighter_run", no_rerun)
    # richer=mech: the truncation part is not estimated (nothing added), the rest as always
    est = estimate_errors(mech, res, 1e-8, 1e-10, richer=mech)
    measured = [n for n in res.output_names if n != "closure"]
    assert all(est.parts["time_integration"][n] == 0.0 for n in measured)
    assert est.parts["time_integration"]["closure"] is None
    assert est.methods["time_integration"].startswith("none: the run has no differential states")
    assert "Newton to |residual| < 1e-12" in est.methods["time_integration"]
    assert "time_integration" not in est.reasons
    # a run that integrates keeps the measured rerun (its method text says so)
    dyn_mech = _mech(PAPER, ["simulation.cycles=0.05"])
    monkeypatch.undo()
    dyn = estimate_errors(dyn_mech, S.simulate(dyn_mech), 1e-8, 1e-10, richer=dyn_mech)
    assert dyn.methods["time_integration"].startswith("the run's difference to itself")


def test_a_cached_library_runs_an_algebraic_partition_without_symbolic_functions(tmp_path, monkeypatch):
    """The compiled library of a partition without independent coordinates is found by the
    signatures computed from the sizes (x and the DAE's ode 0 x 1), like any other; the compiled
    run gives the virtual machine's numbers to the last bit."""
    from symgen.numerics import compiled

    try:
        compiled.compiler()
    except compiled.Unavailable as exc:
        pytest.skip(exc.reason)
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    overrides = [*PAPER_QS, "simulation.cycles=0.25"]
    vm = S.simulate(_mech(PAPER, overrides), backend="vm")
    first = S.simulate(_mech(PAPER, overrides), backend="compiled")
    assert first.stats["library"] == "built" and first.stats["differential_states"] == 0
    assert np.array_equal(first.outputs, vm.outputs) and np.array_equal(first.q, vm.q)

    def no_symbolic(*args, **kwargs):
        raise AssertionError("the runner made its symbolic Functions")

    again_mech = _mech(PAPER, overrides)
    monkeypatch.setattr(S, "_symbolic", no_symbolic)
    again = S.simulate(again_mech, backend="compiled")
    assert again.stats["library"] == "cached" and not again_mech.runner_functions
    assert np.array_equal(again.outputs, vm.outputs)


def test_the_estimate_says_how_a_rerun_solved_its_outputs():
    """The truncation part's method text names what its rerun took: integrator steps, or Newton
    iterations where the richer model had no differential states either."""
    from symgen.numerics.run_result import SimResult

    def run(stats, steps):
        empty = np.zeros((1, 1))
        return SimResult(np.zeros(1), empty, ["y"], empty, empty, empty, 0.0, steps, 0.0, None, stats=stats)

    assert error_estimate._steps_text(run({"differential_states": 0, "newton_iterations": 12}, 0)) == (
        "no differential states: Newton at each output, 12 iterations"
    )
    assert error_estimate._steps_text(run({"differential_states": 4, "newton_iterations": None}, 77)) == "77 IDAS steps"
    assert error_estimate._steps_text(run({"backend": "c"}, 57)) == "57 Radau IIA (C) steps"
