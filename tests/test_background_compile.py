"""A run whose compiled library is not in the cache starts in CasADi's virtual machine while the
library compiles in a background thread, and switches to it between chunks once it is built
(issue 20, item 4: the first run). The switch changes nothing: the virtual machine and the
library compute the same operations in the same order, so the first run gives the numbers of the
second (compiled, from the cache) to the last bit. A background compile that is cancelled (an
interrupt, a failed run) kills the compilers' process groups and leaves nothing that loads."""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from symgen import cache
from symgen.api import mechanism
from symgen.numerics import compiled, simulate as simulate_mod
from symgen.numerics.simulate import simulate

from held_build import build_held_to_second_chunk

ROOT = Path(__file__).resolve().parent.parent
FOUR_BAR = ROOT / "examples" / "four_bar.toml"
#: the four-bar's outputs are a degree apart: 286 outputs, two chunks (simulate.CHUNK = 128)
T_END = 5.0

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")


@pytest.fixture(autouse=True)
def _fresh(monkeypatch, tmp_path):
    """An empty cache of compiled libraries, the default compiler and flags, auto backend."""
    for name in (compiled.CC_ENV, compiled.CFLAGS_ENV, compiled.BACKEND_ENV):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(simulate_mod, "_noticed", set())
    compiled._probe.cache_clear()
    mechanism(FOUR_BAR)  # the derived model from the session's cache, before the cache moves
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))


def _entries() -> list[str]:
    where = cache.compiled_dir()
    return sorted(n for n in os.listdir(where) if not n.startswith(cache.TEMP_PREFIX)) if where.exists() else []


def _same(a, b) -> None:
    assert a.steps == b.steps and len(a.tau) == len(b.tau) > 10
    for what in ("tau", "outputs", "q", "v", "lam"):
        assert np.array_equal(getattr(a, what), getattr(b, what)), what


def test_a_first_run_switches_to_the_library_mid_run_and_equals_the_compiled_second_run(monkeypatch):
    """The build is held back until the run's second chunk (so the switch happens mid-run, not by
    the luck of timing): the first run is part virtual machine, part compiled; the second loads
    the library from the cache; a run on the virtual machine alone agrees too."""
    mech = mechanism(FOUR_BAR)
    with build_held_to_second_chunk(monkeypatch):
        first = simulate(mech, t_end=T_END)  # two chunks: 128 outputs, then the rest
    assert first.stats["backend"] == "compiled" and first.stats["library"] == "built"
    assert 0.0 < first.stats["vm_until"] < T_END  # started in the virtual machine, switched mid-run
    assert len(_entries()) == 1  # installed for the next run
    second = simulate(mech, t_end=T_END)
    assert second.stats["library"] == "cached" and "vm_until" not in second.stats
    _same(first, second)
    _same(first, simulate(mech, t_end=T_END, backend="vm"))


def test_a_run_that_ends_before_its_library_waits_for_it_and_the_next_run_loads_it(monkeypatch):
    """A run shorter than its compile: all of it in the virtual machine, the library waited for at
    its end (the next run's), which the next run loads from the cache with the same numbers."""
    mech = mechanism(FOUR_BAR)
    with monkeypatch.context() as m:
        m.setattr(simulate_mod.DaeRunner, "switch_when_built", lambda self, tau: None)  # not mid-run
        first = simulate(mech, t_end=0.3)
    assert first.stats["backend"] == "vm" and first.stats["backend_choice"] == "auto"
    assert len(_entries()) == 1
    second = simulate(mech, t_end=0.3)
    assert second.stats["backend"] == "compiled" and second.stats["library"] == "cached"
    _same(first, second)


def _slow_compiler(tmp_path: Path) -> tuple[Path, Path]:
    """A C compiler that answers --version at once and otherwise starts a grandchild that sleeps
    (as cc starts cc1), writing its pid; returns (the script, the pid file)."""
    pids = tmp_path / "pids"
    cc = tmp_path / "slowcc"
    real = shutil.which("cc") or shutil.which("gcc")
    cc.write_text(
        f'#!/bin/sh\nif [ "$1" = "--version" ]; then exec {real} --version; fi\nsleep 300 &\necho $! >> {pids}\nwait\n'
    )
    cc.chmod(0o755)
    return cc, pids


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc").exists(), reason="reads /proc")
def test_a_cancelled_background_compile_kills_its_compilers_and_leaves_nothing_that_loads(tmp_path, monkeypatch):
    cc, pids = _slow_compiler(tmp_path)
    monkeypatch.setenv(compiled.CC_ENV, str(cc))
    mech = mechanism(FOUR_BAR)
    *_, part = mech.initial_state(0.0)
    run = simulate_mod.DaeRunner(mech, mech.run_partition(part), 1e-6, 1e-8, backend="auto", background=True)
    pending = run._pending
    assert isinstance(pending, compiled.PendingLibrary) and run.backend == "vm"
    for _ in range(400):
        if pids.exists() and pids.read_text().split():
            break
        time.sleep(0.05)
    sleepers = [int(p) for p in pids.read_text().split()]
    assert sleepers and all(map(_alive, sleepers))
    temps = [n for n in os.listdir(cache.compiled_dir()) if n.startswith(cache.TEMP_PREFIX)]
    assert temps  # the build's temporary folder, while it runs
    run.cancel()
    assert pending.done()
    deadline = time.monotonic() + 10
    while any(map(_alive, sleepers)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(map(_alive, sleepers))  # the compilers' groups were killed, grandchildren too
    assert os.listdir(cache.compiled_dir()) == []  # no entry, no temporary folder: nothing loads
    with pytest.raises(compiled.Unavailable, match="cancelled"):
        pending.result()


def test_an_interrupted_first_run_cancels_its_background_compile(tmp_path, monkeypatch):
    """SIGINT during a first run (here: raised at the first chunk): the run stops with its
    partial result, and the compile it started is cancelled, nothing left in the cache."""
    from symgen.errors import Interrupted

    cc, pids = _slow_compiler(tmp_path)
    monkeypatch.setenv(compiled.CC_ENV, str(cc))
    mech = mechanism(FOUR_BAR)
    calls = {"n": 0}
    check = simulate_mod.interrupt.check

    def signal_at_second_chunk(tau=None):
        calls["n"] += 1
        if calls["n"] == 2:
            raise Interrupted(2, tau)
        check(tau)

    monkeypatch.setattr(simulate_mod.interrupt, "check", signal_at_second_chunk)
    with pytest.raises(Interrupted) as err:
        simulate(mech, t_end=T_END)
    assert not err.value.partial.complete and len(err.value.partial.tau) > 1
    sleepers = [int(p) for p in pids.read_text().split()] if pids.exists() else []
    deadline = time.monotonic() + 10
    while any(map(_alive, sleepers)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(map(_alive, sleepers))
    assert os.listdir(cache.compiled_dir()) == []


def test_without_the_cache_a_run_does_not_wait_for_a_library_it_would_throw_away(monkeypatch, tmp_path):
    """``use_cache=False`` (``--no-cache``): the library would be this run's only, so a run that
    ends before it is built cancels it (no entry, no temporary folder), same numbers."""
    import tempfile

    mech = mechanism(FOUR_BAR)
    private = tmp_path / "tmp"
    private.mkdir()
    with monkeypatch.context() as m:
        m.setattr(tempfile, "tempdir", str(private))  # where a library outside the cache is built
        m.setattr(simulate_mod.DaeRunner, "switch_when_built", lambda self, tau: None)  # not mid-run
        m.setattr(compiled.PendingLibrary, "result", lambda self: pytest.fail("waited for a throw-away library"))
        res = simulate(mech, t_end=0.3, use_cache=False)
    assert res.stats["backend"] == "vm" and _entries() == []
    assert os.listdir(private) == []  # its build folder (outside the cache) removed
    _same(res, simulate(mech, t_end=0.3, backend="vm"))
