"""The compiled backend (symgen.numerics.compiled): the model's run-time Functions as a cached shared
library, run by IDAS through CasADi.

* Its results equal those of CasADi's virtual machine to 1e-12 of each quantity's peak (in
  fact to the last bit: the same operations in the same order, the same IDAS steps).
* The library cache is keyed by the compiler (path and ``--version``) and the flags: a change
  of either builds a new library; a library whose bytes changed is rebuilt, never loaded.
* Without a C compiler (``SYMGEN_CC`` pointing nowhere, PATH without one, a compile that
  fails) the run falls back to the virtual machine, says so in one line, same numbers.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import casadi
import numpy as np
import pytest

from symgen import cache
from symgen.api import mechanism
from symgen.numerics import compiled, simulate as simulate_mod
from symgen.numerics.simulate import simulate

ROOT = Path(__file__).resolve().parent.parent
SLIDER = ROOT / "examples" / "slider_crank.toml"
FOUR_BAR = ROOT / "examples" / "four_bar.toml"
SHORT = {"slider_crank": (SLIDER, 1.0), "four_bar": (FOUR_BAR, 0.4)}

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")


@pytest.fixture(autouse=True)
def _compiler_env(monkeypatch):
    """Each test starts from the default compiler and flags, and a fresh one-line notice."""
    for name in (compiled.CC_ENV, compiled.CFLAGS_ENV, compiled.BACKEND_ENV):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(simulate_mod, "_noticed", set())
    compiled._probe.cache_clear()


def _close(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference as a fraction of the peak of ``a``."""
    return float(np.abs(a - b).max() / max(np.abs(a).max(), 1e-300))


@pytest.fixture(scope="module")
def pairs():
    """(virtual machine, compiled) short runs of both examples (libraries in the session's cache)."""
    out = {}
    for name, (path, t_end) in SHORT.items():
        mech = mechanism(path)
        out[name] = (simulate(mech, t_end=t_end, backend="vm"), simulate(mech, t_end=t_end, backend="compiled"))
    return out


@pytest.mark.parametrize("name", sorted(SHORT))
def test_compiled_results_equal_the_virtual_machine(pairs, name):
    vm, comp = pairs[name]
    assert vm.stats["backend"] == "vm" and comp.stats["backend"] == "compiled"
    assert len(vm.tau) == len(comp.tau) > 10 and comp.complete
    assert comp.steps == vm.steps  # the same IDAS steps
    for what in ("outputs", "q", "v", "lam"):
        assert _close(getattr(vm, what), getattr(comp, what)) <= 1e-12, what


def _entries() -> list[str]:
    return sorted(os.listdir(cache.compiled_dir()))


def test_library_rebuilt_when_flags_or_compiler_change_or_bytes_change(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    mech = mechanism(SLIDER)
    run = lambda: simulate(mech, t_end=0.2, backend="compiled")
    first = run()
    assert first.stats["library"] == "built" and len(_entries()) == 1
    again = run()
    assert again.stats["library"] == "cached" and len(_entries()) == 1
    # other flags: a new library (the old one stays for the old flags)
    monkeypatch.setenv(compiled.CFLAGS_ENV, "-O0 -ffp-contract=off")
    other = run()
    assert other.stats["library"] == "built" and len(_entries()) == 2
    assert _close(first.outputs, other.outputs) <= 1e-12
    monkeypatch.delenv(compiled.CFLAGS_ENV)
    assert run().stats["library"] == "cached"
    # another compiler (a wrapper at another path), then a new version of it at the same path
    real = shutil.which("cc") or shutil.which("gcc")
    wrapper = tmp_path / "bin" / "mycc"
    wrapper.parent.mkdir()
    wrapper.write_text(f'#!/bin/sh\nexec {real} "$@"\n')
    wrapper.chmod(0o755)
    monkeypatch.setenv(compiled.CC_ENV, str(wrapper))
    assert run().stats["library"] == "built" and len(_entries()) == 3
    assert run().stats["library"] == "cached"
    wrapper.write_text(f'#!/bin/sh\nif [ "$1" = --version ]; then echo "mycc 99.0"; exit 0; fi\nexec {real} "$@"\n')
    compiled._probe.cache_clear()  # a new process would ask the compiler again
    assert run().stats["library"] == "built" and len(_entries()) == 4
    # a library whose bytes changed is reported in one line, rebuilt and never loaded
    monkeypatch.delenv(compiled.CC_ENV)
    compiled._probe.cache_clear()
    capsys.readouterr()
    entry = next(
        cache.compiled_dir() / e
        for e in _entries()
        if (cache.compiled_dir() / e / compiled.LIBRARY).stat().st_mtime_ns
        == min((cache.compiled_dir() / x / compiled.LIBRARY).stat().st_mtime_ns for x in _entries())
    )
    lib = entry / compiled.LIBRARY
    data = bytearray(lib.read_bytes())
    data[len(data) // 2] ^= 0xFF
    lib.write_bytes(bytes(data))
    res = run()
    err = capsys.readouterr().err
    assert res.stats["library"] == "built"
    assert err.count("\n") == 1 and "does not match the keyed hash" in err and "rebuilding it" in err
    assert _close(first.outputs, res.outputs) <= 1e-12
    assert cache.sha256_hex(lib.read_bytes()) != cache.sha256_hex(bytes(data))
    assert run().stats["library"] == "cached"
    # symgen cache info / clear know the libraries
    assert "compiled" in cache.info()
    cache.clear()
    assert not cache.compiled_dir().exists()


@pytest.mark.parametrize("hide", ["SYMGEN_CC", "PATH", "flags"])
def test_without_a_working_compiler_the_virtual_machine_runs_and_says_so_once(
    hide, tmp_path, monkeypatch, capsys, pairs
):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    if hide == "SYMGEN_CC":
        monkeypatch.setenv(compiled.CC_ENV, "/nonexistent/cc")
        why = "is not an executable"
    elif hide == "PATH":
        monkeypatch.setenv("PATH", str(tmp_path))  # no cc, gcc or clang
        why = "no C compiler"
    else:
        monkeypatch.setenv(compiled.CFLAGS_ENV, "--no-such-flag-for-any-compiler")
        why = "failed"
    mech = mechanism(SLIDER)
    capsys.readouterr()
    res = simulate(mech, t_end=SHORT["slider_crank"][1])
    simulate(mech, t_end=0.1)  # the notice is not repeated
    err = capsys.readouterr().err
    assert res.stats["backend"] == "vm"
    assert err.count("\n") == 1 and why in err and "virtual machine" in err, err
    comp = pairs["slider_crank"][1]
    assert np.array_equal(res.outputs, comp.outputs) and np.array_equal(res.q, comp.q)
    assert not cache.compiled_dir().exists() or not _entries()


def _cli(args, env_extra: dict, tmp_path: Path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), **env_extra)
    return subprocess.run(
        [sys.executable, "-m", "symgen.cli", *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300
    )


def test_cli_backends_write_the_same_csv_and_forced_compiled_without_compiler_exits_2(tmp_path):
    common = ["simulate", str(SLIDER), "--set", "simulation.cycles=0.05"]
    a = _cli([*common, "-o", str(tmp_path / "a.csv")], {}, tmp_path)
    assert a.returncode == 0, a.stderr
    assert "compiled library" in a.stdout and a.stderr == ""
    b = _cli([*common, "-o", str(tmp_path / "b.csv")], {compiled.CC_ENV: "/nonexistent"}, tmp_path)
    assert b.returncode == 0, b.stderr
    assert b.stderr.count("\n") == 1 and "virtual machine" in b.stderr
    c = _cli([*common, "-o", str(tmp_path / "c.csv"), "--backend", "vm"], {}, tmp_path)
    assert c.returncode == 0 and c.stderr == ""
    text = (tmp_path / "a.csv").read_text()
    assert text == (tmp_path / "b.csv").read_text() == (tmp_path / "c.csv").read_text()
    import json

    assert json.loads((tmp_path / "a.json").read_text())["solver"]["backend"] == "compiled"
    assert json.loads((tmp_path / "c.json").read_text())["solver"]["backend"] == "vm"
    d = _cli(
        [*common, "-o", str(tmp_path / "d.csv"), "--backend", "compiled"], {compiled.CC_ENV: "/nonexistent"}, tmp_path
    )
    assert d.returncode == 2 and "--backend" in d.stderr and "/nonexistent" in d.stderr
    assert not (tmp_path / "d.csv").exists() and not (tmp_path / "d.json").exists()
    e = _cli([*common, "-o", str(tmp_path / "e.csv")], {compiled.BACKEND_ENV: "fast"}, tmp_path)
    assert e.returncode == 2 and compiled.BACKEND_ENV in e.stderr


# --------------------------------------------------------------------------- --solver c
def test_solver_c_writes_the_idas_columns_within_the_tolerance(tmp_path):
    """``--solver c`` (the emitted Radau IIA, compiled and cached) writes the columns of the
    IDAS path at the same output times; at the scene's tolerances (rtol 1e-8) the two agree
    to 1e-5 of the peak on the bending deflection and to 3e-3 on the axial strain and the
    torque (the axial ringing, resolved by neither at rtol 1e-8: ``c_support.IDAS_TOL``)."""
    common = ["simulate", str(SLIDER), "--set", "simulation.cycles=0.25"]
    i = _cli([*common, "-o", str(tmp_path / "idas.csv")], {}, tmp_path)
    c = _cli([*common, "--solver", "c", "-o", str(tmp_path / "c.csv")], {}, tmp_path)
    assert i.returncode == 0 and c.returncode == 0, i.stderr + c.stderr
    assert "Radau IIA (C) steps" in c.stdout
    head_i, head_c = ((tmp_path / f).read_text().splitlines()[0] for f in ("idas.csv", "c.csv"))
    assert head_i == head_c == "tau,eta_mid,eps_ax,torque,closure"
    a = np.loadtxt(tmp_path / "idas.csv", delimiter=",", skiprows=1)
    b = np.loadtxt(tmp_path / "c.csv", delimiter=",", skiprows=1)
    assert a.shape == b.shape and a.shape[0] > 80
    assert np.abs(a[:, 0] - b[:, 0]).max() < 1e-13
    peak = np.abs(a).max(axis=0)
    assert np.abs(a[:, 1] - b[:, 1]).max() < 1e-5 * peak[1]
    assert np.abs(a[:, 2:4] - b[:, 2:4]).max(axis=0).tolist() < (3e-3 * peak[2:4]).tolist()
    assert np.abs(b[:, 4]).max() < 1e-12  # closure at machine precision
    import json

    meta = json.loads((tmp_path / "c.json").read_text())
    assert meta["status"] == "complete" and meta["solver"]["backend"] == "c"
    assert meta["solver"]["name"].startswith("radau-iia") and meta["solver"]["steps"] > 0
    assert json.loads((tmp_path / "idas.json").read_text())["solver"]["name"] == "idas"
    # another run length or tolerance reuses the cached executable (they are its arguments)
    f = _cli(
        [
            "simulate",
            str(SLIDER),
            "--set",
            "simulation.cycles=0.1",
            "--set",
            "simulation.rtol=1e-7",
            "--solver",
            "c",
            "-o",
            str(tmp_path / "f.csv"),
        ],
        {},
        tmp_path,
    )
    assert f.returncode == 0 and "C solver loaded" in f.stdout, f.stdout + f.stderr
    assert len((tmp_path / "f.csv").read_text().splitlines()) == 1 + 37
    # no compiler: exit 2, nothing written
    d = _cli([*common, "--solver", "c", "-o", str(tmp_path / "d.csv")], {compiled.CC_ENV: "/nonexistent"}, tmp_path)
    assert d.returncode == 2 and "--solver" in d.stderr and "/nonexistent" in d.stderr, d.stderr
    assert not any((tmp_path / f).exists() for f in ("d.csv", "d.json"))
    # --states: the in-process C run has the coordinates (it once wrote the outputs only, exit 2):
    # the columns of the IDAS path's --states, the rigid angles within the tolerance
    e = _cli([*common, "--solver", "c", "--states", "-o", str(tmp_path / "e.csv")], {}, tmp_path)
    s = _cli([*common, "--states", "-o", str(tmp_path / "s.csv")], {}, tmp_path)
    assert e.returncode == 0 and s.returncode == 0, e.stderr + s.stderr
    head_e, head_s = ((tmp_path / f).read_text().splitlines()[0] for f in ("e.csv", "s.csv"))
    assert head_e == head_s and ",q." in head_e
    qe = np.loadtxt(tmp_path / "e.csv", delimiter=",", skiprows=1)[:, 5:]
    qs = np.loadtxt(tmp_path / "s.csv", delimiter=",", skiprows=1)[:, 5:]
    assert qe.shape == qs.shape and np.abs(qe - qs).max() < 1e-4 * np.abs(qs).max()


def test_solver_c_executable_follows_the_derived_model_not_only_the_scene(tmp_path, monkeypatch):
    """The same scene file derives another model when symgen's rules change (here the closed-loop
    rule of ``effects.axial = "auto"``): the cached C executable of the old model is not run for
    it. The steel four-bar (three elastic bars in a loop, started undeformed: it rings axially)
    with the rule loosened gets quasi-static bars; with the rule as it is, all three dynamic, and
    ``--solver c`` then agrees with IDAS (rtol 1e-9) to 1e-3 of every deflection's peak. An
    executable keyed by the scene alone once ran the quasi-static model here: 4-7 % off."""
    from symgen.model import structure
    from symgen.numerics.csolver import simulate_c

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    scene = ROOT / "benchmarks" / "scenes" / "four_bar_steel.toml"
    run = ["simulation.cycles=1", "simulation.rtol=1e-5", "simulation.atol=1e-8"]
    with monkeypatch.context() as m:
        m.setattr(structure, "LOOP_SHARE_MAX", 1.0)
        loose = mechanism(scene, run)
        assert "quasi_static" in {t.treatment for t in structure.axial_treatments(loose.scene).values()}
        assert simulate_c(loose).stats["library"] == "built"
    mech = mechanism(scene, run)
    assert {t.treatment for t in structure.axial_treatments(mech.scene).values()} == {"dynamic"}
    res = simulate_c(mech)
    assert res.stats["library"] == "built"
    ref = simulate(mechanism(scene, ["simulation.cycles=1", "simulation.rtol=1e-9", "simulation.atol=1e-12"]))
    assert res.output_names == ref.output_names and res.outputs.shape == ref.outputs.shape
    for j, name in enumerate(ref.output_names):
        assert _close(ref.outputs[:, j], res.outputs[:, j]) < 1e-3, (name, res.steps)


def test_solver_c_executable_follows_the_solver_constants(tmp_path, monkeypatch):
    """The Radau and step-control constants live in symgen/backends/c/radau.py and are rendered into
    the C: a changed constant builds a new executable (the key once hashed only the templates, and
    a changed THET reused the old one), an unchanged one is the cached one (its key compares
    equal after the manifest's JSON round trip)."""
    from symgen.backends.c import radau
    from symgen.numerics.csolver import simulate_c

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    mech = mechanism(SLIDER, ["simulation.cycles=0.05"])
    first = simulate_c(mech)
    assert first.stats["library"] == "built"
    assert simulate_c(mech).stats["library"] == "cached"
    monkeypatch.setattr(radau, "THET", "0.1")
    other = simulate_c(mech)
    assert other.stats["library"] == "built"
    assert np.abs(other.outputs - first.outputs).max() < 1e-3 * np.abs(first.outputs).max()


def test_the_library_split_in_parallel_units_computes_what_one_unit_computes(tmp_path):
    """The library is compiled as one translation unit per Function (in parallel); each Function
    gives, to the last bit, what the same Functions compiled as one unit give (the generated C
    of a Function does not depend on its unit), on inputs drawn at random."""
    mech = mechanism(FOUR_BAR)
    q, v, a, lam, part = mech.initial_state(0.0)
    funcs = simulate_mod.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")._compiled_functions()
    units = compiled.write_units(funcs, tmp_path)
    assert sorted(u.name for u in units) == sorted(f"{f.name()}.c" for f in funcs) and len(units) == 5
    assert [u.stat().st_size for u in units] == sorted((u.stat().st_size for u in units), reverse=True)

    split, built = compiled.library(funcs, mech.info.key, "test split", store=False)
    assert built
    one = tmp_path / "one"
    one.mkdir()
    gen = casadi.CodeGenerator("model.c", {"with_header": False})
    for f in funcs:
        gen.add(f)
    gen.generate(str(one) + os.sep)
    comp = compiled.compiler()
    cmd = [comp.path, *comp.flags, "-fPIC", "-shared", str(one / "model.c"), "-o", str(one / "model.so"), "-lm"]
    subprocess.run(cmd, check=True)
    importer = casadi.Importer(str(one / "model.so"), "dll")
    rng = np.random.default_rng(20)
    for f in funcs:
        if f.name().startswith("jac_"):
            continue
        whole = casadi.external(f.name(), importer, {"enable_fd": False})
        for _ in range(3):
            args = [rng.uniform(-1.0, 1.0, f.size_in(i)) for i in range(f.n_in())]
            got, want = split[f.name()].call(args), whole.call(args)
            for g, w in zip(got, want):
                assert np.array_equal(np.asarray(g), np.asarray(w)), f.name()
        # the Jacobian (IDAS's jac_dae, from the split library's unit of its own) as well
        if f.name() == "dae":
            jg, jw = split["dae"].jacobian(), whole.jacobian()
            args = [rng.uniform(-1.0, 1.0, jg.size_in(i)) for i in range(jg.n_in())]
            for g, w in zip(jg.call(args), jw.call(args)):
                assert np.array_equal(np.asarray(g), np.asarray(w))


def test_a_function_compiled_in_parts_computes_what_it_computes_whole(tmp_path, monkeypatch, pairs):
    """A Function larger than ``policy.UNITS`` allows is compiled as parts by its output rows, each
    a unit of its own, and a unit that calls them (``compiled.parts``, ``compiled.caller_c``): here
    the four-bar's ``jac_dae``, ``g`` and ``dae`` with a bound a third of ``jac_dae``'s operations.
    Every entry is in exactly one part, each part within the bound; the library's ``dae``, its
    Jacobian blocks as IDAS asks for them (the ``jac_dae`` of parts), ``g`` and ``rec`` give the
    virtual machine's numbers to the last bit, and so does a whole run on it (the same IDAS steps)."""
    from symgen.policy import UnitRule

    mech = mechanism(FOUR_BAR)
    q, v, a, lam, part = mech.initial_state(0.0)
    run = simulate_mod.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")
    funcs = run._compiled_functions()
    byname = {f.name(): f for f in funcs}
    bound = int(byname["jac_dae"].n_instructions()) // 3
    assert byname["dae"].n_instructions() > bound and byname["g"].n_instructions() > bound
    for name in ("jac_dae", "g", "dae"):
        f = byname[name]
        cut = compiled.parts(f, bound)
        assert cut is not None and len(cut) >= 2
        assert all(p.n_instructions() <= bound for p, _ in cut)
        entries = sorted(e for _, where in cut for e in where)
        assert entries == sorted((k, j) for k in range(f.n_out()) for j in range(f.sparsity_out(k).nnz()))

    monkeypatch.setattr(compiled, "UNITS", UnitRule(cold_ops=bound, hot_ops=bound))
    units = compiled.write_units(funcs, tmp_path, simulate_mod.COLD)
    stems = {u.stem for u in units}
    assert {"jac_dae", "jac_dae_part0", "jac_dae_part1", "g_part1", "dae_part1"} <= stems
    assert {compiled.unit_of(u) for u in units} == set(simulate_mod.COMPILED)

    ext, built = compiled.library(funcs, mech.info.key, "test parts", store=False, cold=simulate_mod.COLD)
    assert built
    raw = run._functions()["dae"]
    blocks = ["jac:ode:x", "jac:alg:x", "jac:ode:z", "jac:alg:z"]
    want_jac = raw.factory("blocks", casadi.dyn_in(), blocks)
    got_jac = ext["dae"].factory("blocks", casadi.dyn_in(), blocks)
    rng = np.random.default_rng(21)
    for _ in range(3):
        for got, want in ((got_jac, want_jac), (ext["dae"], raw), (ext["g"], byname["g"]), (ext["rec"], byname["rec"])):
            args = [rng.uniform(-1.0, 1.0, want.size_in(i)) for i in range(want.n_in())]
            for g, w in zip(got.call(args), want.call(args)):
                assert np.array_equal(np.asarray(g), np.asarray(w)), want.name()

    vm = pairs["four_bar"][0]
    parts_run = simulate(mech, t_end=SHORT["four_bar"][1], backend="compiled", use_cache=False)
    assert parts_run.stats["backend"] == "compiled" and parts_run.steps == vm.steps
    for what in ("outputs", "q", "v", "lam"):
        assert np.array_equal(getattr(vm, what), getattr(parts_run, what)), what


def test_a_scene_without_multipliers_runs_on_every_path(tmp_path):
    """tests/data/pendulum_tool.toml (one coordinate, no constraint, no multiplier): the compiled
    IDAS library once failed its own signature check on it (the empty multiplier vector sliced
    from a one-element z came out 1 x 0, announced 0 x 1). On the virtual machine, the compiled
    library and the C solver it swings at the compound pendulum's closed-form frequency; the
    compiled run equals the virtual machine's to the last bit, the C run agrees within the
    scene's tolerance, and the --states columns hold no multiplier."""
    from tests.oracles import zero_crossing_frequency
    from tests.test_point_mass import _pendulum_closed_form

    omega, hanging = _pendulum_closed_form()
    amp = 0.02
    scene = ROOT / "tests" / "data" / "pendulum_tool.toml"
    common = ["simulate", str(scene), "--set", f"driver.initial={hanging + amp!r}", "--estimate", "off", "--states"]
    runs = {}
    for name, extra in (("vm", ["--backend", "vm"]), ("compiled", ["--backend", "compiled"]), ("c", ["--solver", "c"])):
        proc = _cli([*common, *extra, "-o", str(tmp_path / f"{name}.csv")], {}, tmp_path)
        assert proc.returncode == 0 and proc.stderr == "", (name, proc.stderr)
        head = (tmp_path / f"{name}.csv").read_text().splitlines()[0]
        assert head == "tau,theta,energy,q.theta_arm", (name, head)
        runs[name] = np.loadtxt(tmp_path / f"{name}.csv", delimiter=",", skiprows=1)
    assert runs["vm"].shape == runs["compiled"].shape == runs["c"].shape and runs["vm"].shape[0] == 2001
    assert _close(runs["vm"], runs["compiled"]) <= 1e-12
    assert np.abs(runs["c"][:, 1] - runs["vm"][:, 1]).max() < 1e-6 * amp
    for name, rows in runs.items():
        assert zero_crossing_frequency(rows[:, 0], rows[:, 1] - hanging) == pytest.approx(omega, rel=1e-4), name
