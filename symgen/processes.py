"""Child processes that never outlive the run that started them (the C compiler, CMake).

A compiler driver (``cc``) starts its own children (``cc1``, ``as``, ``ld``): killing the driver
alone on Ctrl-C leaves them running, ``cc1`` at full CPU for minutes on a large model. So every
such command runs in a process group of its own, and whatever ends the wait -- a signal's
``Interrupted`` (a ``KeyboardInterrupt``), a timeout, any error -- kills the whole group and
reaps it before the exception goes on.

Kept free of SymPy and CasADi (base layer).
"""
from __future__ import annotations

import contextlib
import os
import signal
import subprocess
from collections.abc import Sequence
from pathlib import Path


def run_group(cmd: Sequence[str | os.PathLike], *, timeout: float | None = None,
              cwd: str | os.PathLike | None = None, env: dict | None = None) -> subprocess.CompletedProcess:
    """``subprocess.run(cmd, capture_output=True, text=True)`` with stdin closed, in a new process
    group (a new session) that is killed as a whole when the wait ends by an exception
    (``subprocess.TimeoutExpired`` after ``timeout`` seconds, ``KeyboardInterrupt``...)."""
    args = [os.fspath(c) for c in cmd]
    proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=None if cwd is None else Path(cwd), env=env, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except BaseException:
        kill_group(proc)
        raise
    return subprocess.CompletedProcess(args, proc.returncode, out, err)


def kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL to the process group led by ``proc`` (its grandchildren too); then reap ``proc``."""
    with contextlib.suppress(ProcessLookupError, PermissionError, OSError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(OSError, ValueError):
        proc.kill()
    with contextlib.suppress(BaseException):
        proc.communicate(timeout=5)
