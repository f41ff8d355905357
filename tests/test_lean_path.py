"""The lean IDAS path (issue 20, item 2): what a run no longer does, and that it gives the same
numbers.

* a run on a cached compiled library makes none of the runner's symbolic Functions (the
  library is found by their signatures, computed from the model's sizes), and its results are
  those of the run that built the library, to the last bit;
* a mechanism makes its runner's SX Functions once (the virtual machine's later runs reuse them);
* the polish evaluates only the columns still polished: each column ends where ``polish`` alone
  takes it;
* the singular-position check of the outputs skips the SVD where a determinant bound settles it:
  the same verdicts as the SVD of every output (the oracle).
No timing here (benchmarks/bench_lean.py measures it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from symgen import cache
from symgen.api import mechanism
from symgen.numerics import simulate as S
from symgen.policy import POLICY

ROOT = Path(__file__).resolve().parent.parent
SCENES = ["slider_crank", "four_bar", "motor_arm"]


def _no_symbolic(*args, **kwargs):
    raise AssertionError("the runner made its symbolic Functions")


@pytest.mark.parametrize("name", SCENES)
def test_a_cached_library_runs_without_symbolic_functions(name, tmp_path, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    mech = mechanism(ROOT / "examples" / f"{name}.toml")
    first = S.simulate(mech, t_end=0.3, backend="compiled")
    assert first.stats["library"] == "built"
    again_mech = mechanism(ROOT / "examples" / f"{name}.toml")  # a new process would have none made
    monkeypatch.setattr(S, "_symbolic", _no_symbolic)
    again = S.simulate(again_mech, t_end=0.3, backend="compiled")
    assert again.stats["library"] == "cached" and again.stats["backend"] == "compiled"
    assert not again_mech.runner_functions
    assert np.array_equal(first.outputs, again.outputs) and np.array_equal(first.q, again.q)
    assert len(list(cache.compiled_dir().iterdir())) == 1


def test_signatures_from_sizes_are_those_of_the_functions():
    for name in SCENES:
        mech = mechanism(ROOT / "examples" / f"{name}.toml")
        part = mech.initial_state(0.0)[4]
        run = S.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")
        made = [S.compiled._signature(f) for f in run._compiled_functions()]
        assert S._signatures(mech, part) == made, name


def test_a_mechanism_makes_its_runner_functions_once(monkeypatch):
    mech = mechanism(ROOT / "examples" / "slider_crank.toml")
    first = S.simulate(mech, t_end=0.3, backend="vm")
    assert len(mech.runner_functions) == 1
    monkeypatch.setattr(S, "_symbolic", _no_symbolic)
    again = S.simulate(mech, t_end=0.3, backend="vm")
    assert np.array_equal(first.outputs, again.outputs)


def test_the_polish_of_a_chunk_is_the_polish_of_each_column():
    """Columns perturbed by different amounts need different numbers of Newton steps: the
    batched polish (which narrows to the columns still polished) lands where ``polish`` of each
    column alone does, to the last bit."""
    mech = mechanism(ROOT / "examples" / "slider_crank.toml")
    res = S.simulate(mech, t_end=0.5, backend="vm")
    run = S.DaeRunner(mech, res.partition, 1e-6, 1e-8, backend="vm")
    idx = np.arange(1, 20)
    packed = [
        run.pack(res.q[i], res.v[i], mech.accelerations(res.tau[i], res.q[i], res.v[i])[0], res.lam[i]) for i in idx
    ]
    X = np.stack([x for x, _ in packed], axis=1)
    scale = 1 + np.logspace(-12, -3, len(idx))  # from almost polished to several steps away
    Z0 = np.stack([z for _, z in packed], axis=1) * scale
    p = np.concatenate([mech.p, [0.0]])
    ts = res.tau[idx]
    Zb = run.polish_many(ts, X, Z0, p)
    for k in range(len(idx)):
        zk = Z0[:, k].copy()
        for _ in range(POLICY.polish_maxit):  # polish_many's iteration, one column
            znew, r = run.gstep(ts[k], X[:, k], zk, p)
            if float(r) < POLICY.polish_tol:
                break
            zk = np.array(znew).ravel()
        assert np.array_equal(Zb[:, k], zk), k
        assert np.abs(np.array(run.g(ts[k], X[:, k], Zb[:, k], p)[0])).max() < 1e-10


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_singular_outputs_are_those_of_the_svd(n):
    rng = np.random.default_rng(n)
    J = rng.normal(size=(3000, n, n))
    for i in range(0, len(J), 5):  # near the limit on both sides, and far below it
        u, s, vt = np.linalg.svd(J[i])
        s[-1] = s[0] * 10 ** rng.uniform(-10, -4)
        J[i] = (u * s) @ vt
    J[3] = 0.0
    J[11] *= 1e150
    J[13] *= 1e-160
    J[17, :, 0] = 0.0
    sv = np.linalg.svd(J, compute_uv=False)
    want = np.nonzero(sv[:, -1] / np.maximum(sv[:, 0], 1e-300) < POLICY.singular_ratio)[0]
    got = S._singular_outputs(J)
    assert np.array_equal(got, want)
    assert len(want) >= (2 if n == 1 else 100)  # the oracle's set is not empty: the test can fail


def test_singular_outputs_of_a_non_square_jacobian_use_the_svd():
    rng = np.random.default_rng(7)
    J = rng.normal(size=(200, 3, 2))
    J[5, :, 1] = J[5, :, 0] * 2.0  # rank one
    assert S._singular_outputs(J).tolist() == [5]
