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
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

#: Measured C compile speed of the emitted model code at the default flags (-O1), bytes of C per
#: second: 64 kB in 0.41 s, 264 kB in 1.45 s on a loaded 2-core machine (2026-11-25). Used only to
#: say how long a compile will take, never to decide anything.
COMPILE_BYTES_PER_S = 180e3
#: A compile estimated to take longer than this is announced with its estimate and the way around it.
LONG_COMPILE_S = 20.0


def run_group(
    cmd: Sequence[str | os.PathLike[str]],
    *,
    timeout: float | None = None,
    cwd: str | os.PathLike[str] | None = None,
    env: dict[str, str] | None = None,
    progress: str | None = None,
) -> subprocess.CompletedProcess[str]:
    """``subprocess.run(cmd, capture_output=True, text=True)`` with stdin closed, in a new process
    group (a new session) that is killed as a whole when the wait ends by an exception
    (``subprocess.TimeoutExpired`` after ``timeout`` seconds, ``KeyboardInterrupt``...).
    ``progress``: what to show, with the seconds elapsed, on a terminal's stderr while it runs."""
    args = [os.fspath(c) for c in cmd]
    proc = subprocess.Popen(
        args,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=None if cwd is None else Path(cwd),
        env=env,
        start_new_session=True,
    )
    try:
        with _ticker(progress):
            out, err = proc.communicate(timeout=timeout)
    except BaseException:
        kill_group(proc)
        raise
    return subprocess.CompletedProcess(args, proc.returncode, out, err)


def compile_estimate(source_bytes: int) -> float:
    """Seconds a compile of ``source_bytes`` of emitted C will take, roughly (:data:`COMPILE_BYTES_PER_S`)."""
    return source_bytes / COMPILE_BYTES_PER_S


def announce_compile(what: str, source_bytes: int, instead: str) -> str:
    """The progress label of compiling ``what``; a compile estimated to be long is announced on
    stderr first (one line, also in logs), with ``instead``: how to run without it."""
    est = compile_estimate(source_bytes)
    if est > LONG_COMPILE_S:
        print(
            f"symgen: compiling {what} ({source_bytes / 1e6:.1f} MB of C): about {est:.0f} s, once per model "
            f"(cached); {instead}",
            file=sys.stderr,
            flush=True,
        )
    return f"compiling {what} ({source_bytes / 1e3:.0f} kB of C, about {max(est, 1):.0f} s)"


@contextlib.contextmanager
def _ticker(label: str | None, every: float = 1.0) -> Iterator[None]:
    """``label`` and the seconds elapsed, rewritten in place on a terminal's stderr each
    ``every`` seconds until the block ends (then erased); nothing when stderr is not a terminal."""
    if not label or not sys.stderr.isatty():
        yield
        return
    done = threading.Event()
    t0 = time.monotonic()

    def tick() -> None:
        while not done.wait(every):
            sys.stderr.write(f"\rsymgen: {label}: {time.monotonic() - t0:.0f} s ")
            sys.stderr.flush()

    thread = threading.Thread(target=tick, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()
        if time.monotonic() - t0 >= every:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()


def kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL to the process group led by ``proc`` (its grandchildren too); then reap ``proc``."""
    with contextlib.suppress(ProcessLookupError, PermissionError, OSError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(OSError, ValueError):
        proc.kill()
    with contextlib.suppress(BaseException):
        proc.communicate(timeout=5)
