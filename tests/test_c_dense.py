"""The C solver's dense output and its in-process run (``simulate --solver c``, issue 20 item 3).

* Steps set by accuracy, not by the output grid: the steel slider-crank (rtol 1e-4, two turns)
  with outputs every degree and every 10 degrees takes the very same steps (1992 measured; the
  solver that landed on every output took 725 vs 164 at 1 %), and the rows at common times
  agree to round-off. The rows lie between steps (steps and rows interleave); they are compared
  with IDAS at rtol 1e-11 (the oracle, converged far below 1e-4) to the run's tolerance.
* A closed form between steps: a stiff bar (lambda = mu = 1e8, quasi-static start: a rigid
  physical pendulum to 1e-8) released from rest at 1 rad swings as
  phi(t) = 2 arcsin(k sn(K - w t | k^2)), k = sin(a / 2), w^2 = 3 g / (2 L) (Jacobi's elliptic
  functions); every row (20 per step on average) to 1e-6 rad at rtol 1e-8.
* In process: the states come with the outputs (q of the run equal IDAS's q to the tolerance), a
  run that fails keeps the rows before the failure (partial, the same rows as IDAS's), and a real
  SIGINT stops a long run within 2 s, its rows written as OUT.partial.csv, status "interrupted".
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import special

from symgen.api import mechanism
from symgen.errors import SimulationError

ROOT = Path(__file__).resolve().parent.parent
STEEL = ROOT / "benchmarks" / "scenes" / "slider_crank_steel.toml"
SLIDER = ROOT / "examples" / "slider_crank.toml"
DEG = math.pi / 180

needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
pytestmark = needs_cc


@pytest.fixture(autouse=True)
def _own_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "c-dense-cache"))


def _peak_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(a).max())


def test_steps_do_not_depend_on_the_output_grid_and_rows_between_steps_match_idas():
    from symgen.numerics.csolver import simulate_c
    from symgen.numerics.simulate import simulate

    mech = mechanism(STEEL, ["simulation.rtol=1e-4"])
    every1 = simulate_c(mech, output_step=DEG)
    every10 = simulate_c(mech, output_step=10 * DEG)
    assert every1.complete and every10.complete
    assert every1.steps == every10.steps, (every1.steps, every10.steps)
    assert every1.steps not in (len(every1.tau) - 1, len(every10.tau) - 1)  # rows fall between steps
    assert len(every1.tau) == 721 and len(every10.tau) == 73
    np.testing.assert_allclose(every1.tau[::10], every10.tau, rtol=1e-14, atol=1e-14)
    assert np.abs(every1.outputs[::10] - every10.outputs).max() < 1e-12 * np.abs(every1.outputs).max()
    ref = simulate(mech, output_step=DEG, rtol=1e-11, atol=1e-13)
    assert ref.outputs.shape == every1.outputs.shape
    # measured 2.3e-5 at rtol 1e-4 with RADAU5's looser atol, less since
    assert _peak_error(ref.outputs, every1.outputs) < 1e-3
    # the states: q of the C rows are IDAS's (rigid angles, amplitudes)
    assert every1.q.shape == ref.q.shape and every1.lam.shape == ref.lam.shape
    for k in range(ref.q.shape[1]):
        assert np.abs(ref.q[:, k] - every1.q[:, k]).max() < 1e-3 * max(np.abs(ref.q[:, k]).max(), 1e-12), k


def test_rows_between_steps_follow_the_pendulum_closed_form(tmp_path):
    from test_energy import write_pendulum

    from symgen.numerics.csolver import simulate_c

    amp, g = 1.0, 1.0
    scene = write_pendulum(
        tmp_path, lam=1e8, mu=1e8, amp=amp, t_end=10.0, output_step=0.01, rtol=1e-8, atol=1e-10, quasi_static=True
    )
    res = simulate_c(mechanism(scene))
    assert res.complete and len(res.tau) == 1001
    assert res.steps < len(res.tau) / 4  # most rows lie inside a step
    k = math.sin(amp / 2)
    w = math.sqrt(3 * g / 2)
    sn, _, _, _ = special.ellipj(special.ellipk(k * k) - w * res.tau, k * k)
    phi = 2 * np.arcsin(k * sn)
    err = np.abs(res.column("angle") + math.pi / 2 - phi).max()
    assert err < 1e-6, err


def test_a_failed_run_keeps_the_rows_before_it_like_idas():
    """A rod too soft for its load leaves the range of the model: the C run stops at the same
    output as IDAS, with the same rows before it (states too), and names the bar."""
    from symgen.api import simulate_scene
    from symgen.numerics.csolver import simulate_c

    with pytest.raises(SimulationError, match="beyond the range") as py:
        simulate_scene(SLIDER, ["bodies.rod.mu=0.01"])
    with pytest.raises(SimulationError, match="beyond the range") as c:
        simulate_c(mechanism(SLIDER, ["bodies.rod.mu=0.01"]))
    a, b = py.value.partial, c.value.partial
    assert not b.complete and "'rod'" in b.failure
    assert len(a.tau) == len(b.tau) and a.tau[-1] == pytest.approx(b.tau[-1], abs=1e-12)
    assert b.q.shape == a.q.shape


def test_sigint_stops_the_in_process_c_run_with_its_rows_marked_interrupted(tmp_path):
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env["SYMGEN_CACHE_DIR"] = str(tmp_path / "cache")
    warm = subprocess.run(
        [sys.executable, "-m", "symgen.cli", "simulate", str(SLIDER), "--solver", "c", "-o", str(tmp_path / "w.csv"),
         "--set", "simulation.cycles=0.05"],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert warm.returncode == 0, warm.stderr
    out = tmp_path / "long.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "symgen.cli", "simulate", str(SLIDER), "--solver", "c", "--states", "-v",
         "-o", str(out), "--set", "simulation.cycles=500"],
        cwd=ROOT, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    try:
        assert proc.stderr is not None
        for line in proc.stderr:
            if "integrating" in line:
                break
        time.sleep(1.5)
        assert proc.poll() is None, "the run ended before the signal"
        proc.send_signal(signal.SIGINT)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=60)
        dt = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err
    assert dt < 2.0, f"took {dt:.2f} s to stop"
    assert "interrupted by SIGINT at tau =" in err and "Traceback" not in err
    assert not out.exists() and not out.with_suffix(".json").exists()
    meta = json.loads((tmp_path / "long.partial.json").read_text())
    assert meta["status"] == "interrupted" and meta["solver"]["backend"] == "c"
    rows = (tmp_path / "long.partial.csv").read_text().splitlines()
    assert rows[0].startswith("tau,eta_mid,eps_ax,torque,closure,q.") and len(rows) > 100
    last = [float(w) for w in rows[-1].split(",")]
    assert last[0] > 0 and all(math.isfinite(w) for w in last)


def test_a_cached_c_run_imports_no_sympy_nor_jinja2(tmp_path):
    """The in-process C run of a cached model and library (CLI and API) imports neither SymPy nor
    jinja2 nor matplotlib (``test_lean_start``'s watch): the first run derives and compiles."""
    from test_lean_start import _lean

    over = "simulation.cycles=0.05"
    _lean(
        [
            ["cli", "simulate", str(SLIDER), "--set", over, "--solver", "c", "-o", str(tmp_path / "cli.csv")],
            ["cli", "simulate", str(SLIDER), "--set", over, "--solver", "c", "--states", "-o", str(tmp_path / "s.csv")],
        ],
        tmp_path,
    )
