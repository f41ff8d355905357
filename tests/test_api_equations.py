"""symgen.api.equations: the derived model as SymPy matrices (issue 21), checked against a hand
derivation (the rigid pendulum of docs/tutorial_equations.py, which this test runs) and against
the model that runs (the CasADi functions) on a closed loop."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import sympy as sp

from symgen.api import equations, mechanism

ROOT = Path(__file__).resolve().parent.parent


def test_the_tutorial_runs_and_gives_the_pendulum_by_hand():
    run = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "tutorial_equations.py")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert run.returncode == 0, run.stderr
    # (m l^2 / 3) theta'' = T - m g (l / 2) cos(theta), with m = l = 1, g = 2, T = 0.3
    assert "mass matrix: 1/3" in run.stdout and "forcing: 3/10 - cos(theta_bar)" in run.stdout, run.stdout
    assert "theta'' = 9/10 - 3*cos(theta_bar)" in run.stdout


def test_the_matrices_give_back_the_model_that_runs():
    """M a + G lam - f is the residual the integrator solves, and d constraints / d q its
    closure Jacobian, at random states of the slider-crank."""
    path = ROOT / "examples" / "slider_crank.toml"
    eqs = equations(path)
    mech = mechanism(path)
    assert [str(s) for s in eqs.parameters] == list(mech.info.params)
    rng = np.random.default_rng(5)
    n, m = len(eqs.coordinates), len(eqs.multipliers)
    syms = [eqs.time, *eqs.coordinates, *eqs.speeds, *eqs.accelerations, *eqs.multipliers]
    M = sp.lambdify(syms, eqs.mass_matrix.xreplace(eqs.values), "numpy")
    G = sp.lambdify(syms, eqs.multiplier_matrix.xreplace(eqs.values), "numpy")
    f = sp.lambdify(syms, eqs.forcing.xreplace(eqs.values), "numpy")
    J = sp.lambdify(syms, eqs.constraint_jacobian.xreplace(eqs.values), "numpy")
    for _ in range(3):
        t = float(rng.uniform(0, 6))
        q, v, a = (rng.normal(scale=0.3, size=n) for _ in range(3))
        lam = rng.normal(size=m)
        args = [t, *q, *v, *a, *lam]
        mine = np.asarray(M(*args)) @ a + np.asarray(G(*args)) @ lam - np.asarray(f(*args)).ravel()
        np.testing.assert_allclose(mine, mech.call("res", t, q, v, a, lam), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.asarray(J(*args)), mech.jac_q(t, q), rtol=1e-9, atol=1e-12)
