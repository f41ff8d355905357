"""Bars of one structure as one block (``Program.blocks``): each call's generalized forces are the
block's outputs with the call's inputs (the assignments, renamed); as CasADi calls of one Function
the residual is the inline one's bit for bit, and its Jacobian by the chain rule over the block's
own Jacobian Function (``functions.chain_jacobian``) is CasADi's AD Jacobian of the inline residual."""

from __future__ import annotations

import shutil
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
from held_build import build_held_to_second_chunk  # noqa: E402

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


# --- the runner (numerics.simulate): the Jacobian by the chain rule, the same in both backends ---


def _exact_chain(tmp_path, bars: int = 3) -> Path:
    path = tmp_path / f"chain{bars}_exact.toml"
    path.write_text(scene_text("chain", bars, 2, 3) + '\n[effects]\nstrain = "exact"\n')
    return path


def test_runner_dae_and_chain_rule_jacobian_equal_the_inline_ones(tmp_path):
    """The runner of a model whose blocks are calls: its ``dae`` the inline runner's, its ``jac_dae``
    (chain rule) CasADi's AD Jacobian of the inline ``dae`` to 1e-12 of its largest entry, and the
    virtual machine's ``dae`` (an MX oracle) the library's ``dae`` bit for bit."""
    from symgen.backends.casadi.pipeline import CompiledModel
    from symgen.ir.info import ModelInfo
    from symgen.numerics import simulate as sim
    from symgen.numerics.mechanism import Mechanism

    scene = load_scene(_exact_chain(tmp_path), [])
    model = derive(scene)
    funcs = F.build_functions(model)
    assert set(F.CALL_NAMES) <= set(funcs)
    inline = {k: funcs[k] for k in F.FUNCTION_NAMES}
    info = ModelInfo.of(model)
    mc = Mechanism(CompiledModel(funcs, info, 0.0, 0.0, False), scene)
    mi = Mechanism(CompiledModel(inline, info, 0.0, 0.0, False), scene)
    *_, part = mi.initial_state(0.0)
    part = mi.run_partition(part)
    fc, fi = sim._symbolic(mc, part), sim._symbolic(mi, part)
    assert "jac_dae" in fc and "jac_dae" not in fi
    dae = fi["dae"]
    ji = sim._dae_jacobian(dae, dae.sx_in(), dae.call(dae.sx_in()))
    jc = fc["jac_dae"]
    rng = np.random.default_rng(3)
    p = np.concatenate([mi.p_values, [0.0]])
    for _ in range(3):
        ins = [rng.uniform(-0.5, 0.5), *(rng.uniform(-0.3, 0.3, dae.size1_in(k)) for k in (1, 2)), p, np.zeros(0)]
        oi, oc = dae(*ins), fc["compiled:dae"](*ins)
        assert all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(oi, oc))
        ovm = fc["dae"](*ins)
        assert all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(ovm, oc))
        nominal = [np.asarray(x) for x in oi]
        for name in ("jac_alg_x", "jac_alg_z", "jac_ode_x", "jac_ode_z"):
            a = np.asarray(ji(*ins, *nominal)[ji.index_out(name)].full())
            b = np.asarray(jc(*ins, *nominal)[jc.index_out(name)].full())
            assert np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(a).max()), name
        # the blocks IDAS never asks for (t, p, u): structurally empty in both
        for name in ("jac_alg_t", "jac_alg_p", "jac_ode_t", "jac_ode_p"):
            assert ji.sparsity_out(ji.index_out(name)).nnz() == 0 == jc.sparsity_out(jc.index_out(name)).nnz()
        gi, gc = fi["g"](*ins[:4]), fc["g"](*ins[:4])
        assert np.array_equal(np.asarray(gi[0]), np.asarray(gc[0]))
        assert np.abs(np.asarray(gi[1]) - np.asarray(gc[1])).max() <= 1e-12 * np.abs(np.asarray(gi[1])).max()


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
def test_a_first_run_with_calls_switches_to_its_library_bit_for_bit(tmp_path, monkeypatch):
    """An exact chain (blocks as calls): a first run switching from the virtual machine to the
    library mid-run gives the second (compiled, cached) run's numbers to the last bit, and the
    virtual machine's alone; within the tolerance of the inline runner's."""
    from symgen.api import mechanism
    from symgen.numerics import compiled
    from symgen.numerics import simulate as sim

    for name in (compiled.CC_ENV, compiled.CFLAGS_ENV, compiled.BACKEND_ENV):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(sim, "_noticed", set())
    compiled._probe.cache_clear()
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    path = _exact_chain(tmp_path)
    mech = mechanism(path)
    assert "res_E" in mech.f
    with build_held_to_second_chunk(monkeypatch):
        first = sim.simulate(mech, t_end=T_END)
    assert first.stats["backend"] == "compiled" and first.stats["library"] == "built"
    assert 0.0 < first.stats["vm_until"] < T_END
    second = sim.simulate(mech, t_end=T_END)
    assert second.stats["library"] == "cached"
    vm = sim.simulate(mech, t_end=T_END, backend="vm")
    for a, b in ((first, second), (first, vm)):
        assert a.steps == b.steps and len(a.tau) == len(b.tau) > 10
        for what in ("tau", "outputs", "q", "v", "lam"):
            assert np.array_equal(getattr(a, what), getattr(b, what)), what
    # the inline runner (blocks inline: another model cache), the same run to the tolerance
    monkeypatch.setattr(F, "CALL_STRAINS", ())
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache-inline"))
    inline = sim.simulate(mechanism(path), t_end=T_END, backend="vm")
    assert "res_E" not in mechanism(path).f
    scale = np.abs(inline.q).max()
    assert np.abs(inline.q[-1] - vm.q[-1]).max() <= 1e-4 * scale


T_END = 5.0  # 286 outputs: two chunks (simulate.CHUNK = 128), the switch between them


def test_the_model_cache_keeps_the_call_functions(tmp_path):
    """A cache entry of a model with calls holds ``CALL_NAMES`` (read back, lazily too, the same
    Functions); one without holds none."""
    from symgen.backends.casadi import store
    from symgen.ir.info import ModelInfo

    model = derive(load_scene(_exact_chain(tmp_path), []))
    funcs = F.build_functions(model)
    info = ModelInfo.of(model)
    where = tmp_path / "models" / info.key
    assert store.save(funcs, info, where)
    loaded, _ = store.load(where)
    lazy, _ = store.load_lazy(where, info.key)
    assert set(loaded) == set(lazy) == set(F.FUNCTION_NAMES + F.CALL_NAMES)
    assert "bars" in lazy and lazy["bars"].serialize() == funcs["bars"].serialize()
    plain = tmp_path / "plain" / info.key
    assert store.save({k: funcs[k] for k in F.FUNCTION_NAMES}, info, plain)
    lazy, _ = store.load_lazy(plain, info.key)
    assert "res_E" not in lazy and list(lazy) == list(F.FUNCTION_NAMES)


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
def test_the_library_compiles_each_block_once(tmp_path, monkeypatch):
    """The library of an exact chain (blocks as calls), its ``jac_dae`` cut into parts: each
    block's Function and its Jacobian are a unit of their own (``compiled.share_callees``), every
    other unit calls them without carrying their C, a block only the cold Functions call is
    compiled cold; the library holds no ``g`` (``simulate._library_g``: made of ``dae`` and
    ``jac_dae``), and gives the virtual machine's numbers to the last bit."""
    from symgen.api import mechanism
    from symgen.numerics import compiled
    from symgen.numerics import simulate as sim
    from symgen.policy import UnitRule

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    mech = mechanism(_exact_chain(tmp_path))
    *_, part = mech.initial_state(0.0)
    part = mech.run_partition(part)
    run = sim.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")
    funcs = run._compiled_functions()
    shared = compiled.callees(funcs)
    assert shared and {n.removeprefix("jac_") for n in shared} == {n for n in shared if not n.startswith("jac_")}
    cold = compiled.cold_units(funcs, sim.COLD)
    assert {n for n in shared if n.startswith("jac_")} <= set(cold)  # called by jac_dae and g only
    assert not {n for n in shared if not n.startswith("jac_")} & set(cold)  # dae calls them
    bound = int(next(f for f in funcs if f.name() == "jac_dae").n_instructions()) // 2
    monkeypatch.setattr(compiled, "UNITS", UnitRule(cold_ops=bound, hot_ops=10**9))
    (tmp_path / "c").mkdir()
    units = compiled.write_units(funcs, tmp_path / "c", sim.COLD)
    stems = {u.stem for u in units}
    assert set(shared) <= stems and "jac_dae_part1" in stems
    for u in units:
        text = u.read_text()
        for name in shared:
            # a callee's C (CasADi's comment of its body) is in its own unit alone
            own = f"/* {name}:(" in text
            assert own == (u.stem == name), (u.stem, name)
    ext, built = compiled.library(funcs, mech.info.key, "test shared callees", store=False, cold=sim.COLD)
    assert built and "g" not in ext  # made of dae and jac_dae (simulate._library_g)
    rng = np.random.default_rng(5)
    plain = run._functions()
    p = np.concatenate([mech.p_values, [0.0]])
    for _ in range(2):
        t, x, z = rng.uniform(-0.5, 0.5), *(rng.uniform(-0.3, 0.3, plain["dae"].size1_in(k)) for k in (1, 2))
        for name, args in (("dae", (t, x, z, p, np.zeros(0))), ("g", (t, x, z, p)), ("rec", (t, x, z, p))):
            want = plain[f"compiled:{name}"](*args)
            got = (sim._library_g(ext) if name == "g" else ext[name])(*args)
            for a, b in zip(want, got):
                assert np.array_equal(np.asarray(ca.densify(a)), np.asarray(ca.densify(b))), name


def test_callees_not_read_stay_in_their_callers(tmp_path, monkeypatch):
    """Where CasADi's C is not laid out as ``compiled`` reads it (another CasADi: here a pattern
    that matches nothing), no callee gets a unit of its own and every caller keeps its copy, as
    before the callees were shared: the library builds and gives the virtual machine's numbers."""
    import re

    from symgen.api import mechanism
    from symgen.numerics import compiled
    from symgen.numerics import simulate as sim

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(compiled, "_BODY", re.compile(r"(?!x)x(?P<name>)(?P<fn>)(?P<body>)"))
    mech = mechanism(_exact_chain(tmp_path))
    *_, part = mech.initial_state(0.0)
    part = mech.run_partition(part)
    run = sim.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")
    funcs = run._compiled_functions()
    shared = compiled.callees(funcs)
    assert shared
    (tmp_path / "c").mkdir()
    units = compiled.write_units(funcs, tmp_path / "c", sim.COLD)
    assert not {u.stem for u in units} & set(shared) and not any((tmp_path / "c" / f"{n}.c").exists() for n in shared)
    ext, built = compiled.library(funcs, mech.info.key, "test callees kept", store=False, cold=sim.COLD)
    assert built
    plain = run._functions()
    rng = np.random.default_rng(6)
    t, x, z = rng.uniform(-0.5, 0.5), *(rng.uniform(-0.3, 0.3, plain["dae"].size1_in(k)) for k in (1, 2))
    p = np.concatenate([mech.p_values, [0.0]])
    for a, b in zip(plain["compiled:dae"](t, x, z, p, np.zeros(0)), ext["dae"](t, x, z, p, np.zeros(0))):
        assert np.array_equal(np.asarray(ca.densify(a)), np.asarray(ca.densify(b)))
