"""A compile interrupted by a signal leaves no compiler process behind (issue 22): the command
runs in a process group of its own, killed as a whole."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from symgen.processes import run_group

ROOT = Path(__file__).resolve().parent.parent


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie is dead for our purpose
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc").exists(), reason="reads /proc")
def test_sigint_during_a_command_kills_its_grandchildren(tmp_path):
    """A driver that starts a long-running grandchild (as cc starts cc1), interrupted with SIGINT
    in the parent: the grandchild is gone (subprocess.run left it running for its 300 s). The
    deadline is generous (10 s): on a loaded 2-core machine the kill and the reaping can take
    more than the second they take when idle; a grandchild left running outlives any deadline."""
    pidfile = tmp_path / "grandchild.pid"
    driver = tmp_path / "driver.sh"
    driver.write_text(f"#!/bin/sh\nsleep 300 &\necho $! > {pidfile}\nwait\n")
    driver.chmod(0o755)
    parent = textwrap.dedent(f"""
        import signal, sys
        sys.path.insert(0, {str(ROOT)!r})
        from symgen.processes import run_group
        try:
            run_group([{str(driver)!r}], timeout=600)
        except KeyboardInterrupt:
            sys.exit(130)
    """)
    proc = subprocess.Popen([sys.executable, "-c", parent])
    for _ in range(200):
        if pidfile.exists() and pidfile.read_text().strip():
            break
        time.sleep(0.05)
    grandchild = int(pidfile.read_text())
    assert _alive(grandchild)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=30) == 130
    deadline = time.monotonic() + 10.0
    while _alive(grandchild) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = _alive(grandchild)
    if alive:
        os.kill(grandchild, signal.SIGKILL)
    assert not alive


def test_timeout_kills_the_group_and_output_is_captured(tmp_path):
    ok = run_group(["sh", "-c", "echo out; echo err >&2; exit 3"])
    assert (ok.returncode, ok.stdout, ok.stderr) == (3, "out\n", "err\n")
    t0 = time.monotonic()
    with pytest.raises(subprocess.TimeoutExpired):
        run_group(["sh", "-c", "sleep 30 & wait"], timeout=0.5)
    assert time.monotonic() - t0 < 10


def test_a_long_compile_is_announced_with_its_estimate_and_the_way_around_it(capsys):
    """A 62-bar chain compiled silently for minutes: a compile estimated to be long says so first
    (one line, also in logs), and on a terminal the seconds run while it compiles."""
    from symgen.processes import COMPILE_BYTES_PER_S, LONG_COMPILE_S, announce_compile

    small = announce_compile("the model library", 64_000, "--backend vm runs without compiling")
    assert capsys.readouterr().err == "" and "64 kB of C" in small
    big = int(3 * LONG_COMPILE_S * COMPILE_BYTES_PER_S)
    announce_compile("the model library", big, "--backend vm runs without compiling")
    err = capsys.readouterr().err
    assert f"about {3 * LONG_COMPILE_S:.0f} s" in err and "--backend vm" in err and "once per model" in err


def test_the_seconds_run_on_a_terminal_while_a_command_runs(monkeypatch):
    import io

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    run_group(["sh", "-c", "sleep 1.6"], progress="compiling the test")
    assert "symgen: compiling the test: 1 s" in term.getvalue()


@pytest.mark.skipif(not Path("/proc").exists(), reason="reads /proc")
def test_sigint_during_parallel_commands_kills_every_group_and_starts_no_more(tmp_path):
    """Three compiler-like drivers, two at a time (as the model library's units are compiled),
    interrupted with SIGINT once both are running: both grandchildren are gone, the third
    driver never started."""
    drivers = []
    for k in range(3):
        driver = tmp_path / f"driver{k}.sh"
        driver.write_text(f"#!/bin/sh\nsleep 300 &\necho $! > {tmp_path / f'grandchild{k}.pid'}\nwait\n")
        driver.chmod(0o755)
        drivers.append([str(driver)])
    parent = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(ROOT)!r})
        from symgen.processes import run_groups
        try:
            run_groups({drivers!r}, max_jobs=2, timeout=600)
        except KeyboardInterrupt:
            sys.exit(130)
    """)
    proc = subprocess.Popen([sys.executable, "-c", parent])
    pidfiles = [tmp_path / f"grandchild{k}.pid" for k in range(3)]
    for _ in range(400):
        if all(p.exists() and p.read_text().strip() for p in pidfiles[:2]):
            break
        time.sleep(0.05)
    grandchildren = [int(p.read_text()) for p in pidfiles[:2]]
    assert all(map(_alive, grandchildren))
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=30) == 130
    deadline = time.monotonic() + 2.0
    while any(map(_alive, grandchildren)) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = [pid for pid in grandchildren if _alive(pid)]
    for pid in alive:
        os.kill(pid, signal.SIGKILL)
    assert not alive
    assert not pidfiles[2].exists()


def test_parallel_commands_keep_their_order_and_a_failure_stops_the_rest(tmp_path):
    from symgen.processes import run_groups

    done = run_groups([["sh", "-c", f"sleep 0.{3 - k}; echo {k}"] for k in range(3)], max_jobs=2)
    assert [(p.returncode, p.stdout) for p in done] == [(0, "0\n"), (0, "1\n"), (0, "2\n")]
    marker = tmp_path / "never"
    cmds = [["sh", "-c", "echo bad >&2; exit 4"], ["sh", "-c", "sleep 30"], ["sh", "-c", f"touch {marker}"]]
    t0 = time.monotonic()
    out = run_groups(cmds, max_jobs=2)
    assert time.monotonic() - t0 < 10
    assert (out[-1].returncode, out[-1].stderr) == (4, "bad\n") and not marker.exists()
    with pytest.raises(subprocess.TimeoutExpired):
        run_groups([["sh", "-c", "sleep 30 & wait"]] * 2, max_jobs=2, timeout=0.5)


def test_the_units_done_show_on_a_terminal_while_parallel_commands_run(monkeypatch):
    import io

    from symgen.processes import run_groups

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    run_groups([["true"], ["sh", "-c", "sleep 1.6"]], max_jobs=1, progress="compiling the test")
    assert "symgen: compiling the test: 1/2 done: 1 s" in term.getvalue()
