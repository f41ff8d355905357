"""Bars of one structure as one block (``Program.blocks``): each call's generalized forces are the
block's outputs with the call's inputs (the assignments, renamed); as CasADi calls of one Function
the residual is the inline one's bit for bit, and its Jacobian by the chain rule over the block's
own Jacobian Function (``functions.chain_jacobian``) is CasADi's AD Jacobian of the inline residual."""

from __future__ import annotations

import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from symgen.backends.casadi import functions as F
from symgen.backends.casadi.store import INPUT_NAMES
from symgen.model.derive import derive
from symgen.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_derivation import scene_text  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore::symgen.scene.limits.SceneWarning")

SETS = {
    "von_karman": [],
    "exact": ["effects.strain=exact"],
    "gravity_damping_rotary": ["effects.gravity=[0.3, -1.0]", "effects.damping=0.01", "effects.rotary_inertia=true"],
}


def _model(tmp_path, sets, bars: int = 3):
    path = tmp_path / "chain.toml"
    path.write_text(scene_text("chain", bars, 2, 3))
    return derive(load_scene(path, sets))


@pytest.mark.parametrize("case", list(SETS))
def test_calls_are_the_renamed_block(tmp_path, case):
    m = _model(tmp_path, SETS[case])
    prog = m.program
    assert [b.bar for b in prog.blocks] == ["b1"]
    (b,) = prog.blocks
    assert [c.bar for c in b.calls] == ["b1", "b2", "b3"]
    assigned = dict(prog.assignments)
    for c in b.calls:
        rule = dict(zip(b.inputs, c.inputs))
        assert len(set(c.inputs)) == len(c.inputs)
        for out, sym in zip(b.outputs, c.assigns):
            assert out.xreplace(rule) == assigned[sym], (c.bar, sym)


def test_lumped_inertia_keeps_its_bar_out(tmp_path):
    """A bar whose E carry a joint's lumped rotary inertia (b2, J2's) is no call of the block."""
    path = tmp_path / "chain.toml"
    text = scene_text("chain", 3, 2, 3).replace('bodies = ["b2", "b3"]', 'bodies = ["b2", "b3"]\ninertia = 0.01')
    path.write_text(text)
    prog = derive(load_scene(path, [])).program
    assert [[c.bar for c in b.calls] for b in prog.blocks] == [["b1", "b3"]]


def _random_inputs(prog, rng):
    return [rng.uniform(-0.5, 0.5, len(prog.inputs[n])) for n in INPUT_NAMES]


def _params(m, rng):
    # positive physical parameters (alpha, nu, lambda, ...) near 1, the rest small
    return np.array([rng.uniform(0.5, 1.5) for _ in m.program.inputs["p"]])


@pytest.mark.parametrize("case", ["exact", "gravity_damping_rotary"])
def test_calls_residual_and_chain_rule_jacobian(tmp_path, case):
    m = _model(tmp_path, SETS[case])
    prog = m.program
    inline = F.build_functions(m)
    calls = F.build_functions_with_calls(m)
    rng = np.random.default_rng(7)
    for _ in range(3):
        args = _random_inputs(prog, rng)
        args[5] = _params(m, rng)
        for name in ("res", "out", "energy"):
            a = np.asarray(inline[name](*args)).ravel()
            b = np.asarray(calls[name](*args)).ravel()
            assert np.array_equal(a, b), name  # the same expressions converted: bit for bit
    split, bf = F.split_functions(m)
    assert len(bf.functions) == 1 and len(bf.calls) == 3
    sx = {n: ca.SX.sym(n, len(prog.inputs[n])) for n in INPUT_NAMES}
    w = ca.vertcat(sx["q"], sx["v"], sx["a"], sx["lam"])
    args_sx = [sx[n] for n in INPUT_NAMES]
    res, jac = F.chain_jacobian(split, bf, "res", args_sx, w)
    ad = ca.jacobian(inline["res"](*args_sx), w)
    f = ca.Function("f", args_sx, [res, jac, inline["res"](*args_sx), ad])
    for _ in range(3):
        args = _random_inputs(prog, rng)
        args[5] = _params(m, rng)
        r1, j1, r0, j0 = (np.asarray(x) for x in f(*args))
        assert np.array_equal(r1, r0)
        scale = max(1.0, np.abs(j0).max())
        assert np.abs(j1 - j0).max() <= 1e-12 * scale, np.abs(j1 - j0).max()
        assert np.abs(j0).max() > 0
