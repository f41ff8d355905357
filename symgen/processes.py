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
import sys
import threading
import time
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

if TYPE_CHECKING:
    import subprocess
else:
    from symgen.lazy import LazyModule

    subprocess = LazyModule("subprocess")  # imported when a process is started (symgen.lazy)

#: Measured C compile speed of the emitted model code at the default flags (-O1), bytes of C per
#: second: 64 kB in 0.41 s, 264 kB in 1.45 s on a loaded 2-core machine (2026-11-25). Used only to
#: say how long a compile will take, never to decide anything.
COMPILE_BYTES_PER_S = 180e3
#: A compile estimated to take longer than this is announced with its estimate and the way around it.
LONG_COMPILE_S = 20.0


class Cancelled(Exception):
    """:func:`run_groups` stopped because its ``cancel`` event was set (its groups killed)."""


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


def jobs() -> int:
    """How many commands to run at once: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def run_groups(
    cmds: Sequence[Sequence[str | os.PathLike[str]]],
    *,
    max_jobs: int,
    timeout: float | None = None,
    progress: str | None = None,
    cancel: threading.Event | None = None,
) -> list[subprocess.CompletedProcess[str]]:
    """:func:`run_group` of several commands, at most ``max_jobs`` at once, started in the order
    given (put the longest first): each in a process group of its own, and every group still
    running killed and reaped when the wait ends by an exception (``KeyboardInterrupt``,
    ``subprocess.TimeoutExpired`` after ``timeout`` seconds in all, ...). A command that fails
    stops the rest (those running are killed, those waiting never start): the result then
    ends with the failed one. ``progress``: what to show on a terminal, with the commands done.
    ``cancel``: set from another thread (the waiting one runs in a background thread, where no
    signal arrives), every group is killed and reaped and :class:`Cancelled` raised."""
    todo = [[os.fspath(c) for c in cmd] for cmd in cmds]
    running: list[tuple[int, subprocess.Popen[bytes], IO[bytes], IO[bytes]]] = []  # (index, process, stdout, stderr)
    done: dict[int, subprocess.CompletedProcess[str]] = {}
    failed: int | None = None
    t0 = time.monotonic()
    label = None if progress is None else lambda: f"{progress}: {len(done)}/{len(todo)} done"
    try:
        with _ticker(label):
            nxt = 0
            while (nxt < len(todo) and failed is None) or running:
                if cancel is not None and cancel.is_set():
                    raise Cancelled("cancelled")
                while nxt < len(todo) and failed is None and len(running) < max(1, max_jobs):
                    out: IO[bytes] = tempfile.TemporaryFile()  # files, not pipes: none blocks on a full pipe
                    err: IO[bytes] = tempfile.TemporaryFile()
                    proc = subprocess.Popen(
                        todo[nxt], stdin=subprocess.DEVNULL, stdout=out, stderr=err, start_new_session=True
                    )
                    running.append((nxt, proc, out, err))
                    nxt += 1
                for entry in list(running):
                    k, proc, out, err = entry
                    if proc.poll() is None:
                        continue
                    running.remove(entry)
                    done[k] = subprocess.CompletedProcess(todo[k], proc.returncode, _text(out), _text(err))
                    if proc.returncode != 0 and failed is None:
                        failed = k
                if failed is not None:
                    _kill_all(running)
                elif timeout is not None and time.monotonic() - t0 > timeout:
                    raise subprocess.TimeoutExpired(todo[running[0][0]], timeout)
                time.sleep(0.02)
    except BaseException:
        _kill_all(running)
        raise
    order = sorted(k for k in done if k != failed) + ([] if failed is None else [failed])
    return [done[k] for k in order]


def _kill_all(running: list[tuple[int, subprocess.Popen[bytes], IO[bytes], IO[bytes]]]) -> None:
    """:func:`kill_group` of every running command, its output files closed; the list emptied."""
    for _, proc, out, err in running:
        kill_group(proc)
        out.close()
        err.close()
    running.clear()


def _text(fh: IO[bytes]) -> str:
    """What a command wrote to the temporary file ``fh`` (closed after)."""
    with fh:
        fh.seek(0)
        return fh.read().decode(errors="replace")


def compile_estimate(source_bytes: int, max_jobs: int = 1, largest: int = 0) -> float:
    """Seconds a compile of ``source_bytes`` of emitted C will take, roughly (:data:`COMPILE_BYTES_PER_S`):
    spread over ``max_jobs`` compilers at once, no less than the ``largest`` translation unit's."""
    return max(source_bytes / max(1, max_jobs), largest) / COMPILE_BYTES_PER_S


def announce_compile(what: str, source_bytes: int, instead: str, max_jobs: int = 1, largest: int = 0) -> str:
    """The progress label of compiling ``what``; a compile estimated to be long is announced on
    stderr first (one line, also in logs), with ``instead``: how to run without it. ``max_jobs``,
    ``largest``: the C is compiled as translation units (the largest of ``largest`` bytes), that
    many at once."""
    est = compile_estimate(source_bytes, max_jobs, largest)
    if est > LONG_COMPILE_S:
        print(
            f"symgen: compiling {what} ({source_bytes / 1e6:.1f} MB of C): about {est:.0f} s, once per model "
            f"(cached); {instead}",
            file=sys.stderr,
            flush=True,
        )
    return f"compiling {what} ({source_bytes / 1e3:.0f} kB of C, about {max(est, 1):.0f} s)"


@contextlib.contextmanager
def _ticker(label: str | Callable[[], str] | None, every: float = 1.0) -> Iterator[None]:
    """``label`` (or what it returns, when a function) and the seconds elapsed, rewritten in place
    on a terminal's stderr each ``every`` seconds until the block ends (then erased); nothing when
    stderr is not a terminal."""
    if not label or not sys.stderr.isatty():
        yield
        return
    done = threading.Event()
    t0 = time.monotonic()

    def tick() -> None:
        while not done.wait(every):
            text = label() if callable(label) else label
            sys.stderr.write(f"\rsymgen: {text}: {time.monotonic() - t0:.0f} s \033[K")
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
