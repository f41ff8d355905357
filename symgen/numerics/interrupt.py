"""Stopping a run on SIGINT (Ctrl-C) or SIGTERM within a second, keeping what it computed.

One mechanism for every long loop (``simulate``, ``quasistatic``, ``study``, ``reproduce``,
``effects --measure``, sweeps)::

    from symgen.errors import Interrupted
    from symgen.numerics import interrupt

    with interrupt.handling():          # the CLI's main() does this once for every command
        for item in work:
            interrupt.check()           # raises Interrupted if a signal arrived
            try:
                run(item)               # may raise Interrupted itself (see below)
            except SomeFailure as err:
                interrupt.check()       # a failure while a signal is pending IS the interrupt
                record_failure(item, err)

* ``handling()`` installs handlers for SIGINT and SIGTERM (main thread only; elsewhere, or
  nested, it does nothing) and restores the previous ones on exit. A handler records the
  signal (``requested()``) and raises ``Interrupted`` at once, so pure-Python work (SymPy
  derivation, loops) stops within a bytecode.
* CasADi polls Python's signals inside its solvers (IDAS residual callbacks): the
  ``Interrupted`` raised there is swallowed and comes back as a ``RuntimeError`` such as
  "IDA_RES_FAIL" (without CasADi's polling a solver call finishes its chunk first, and the
  handler raises right after it). Hence the rule: **any failure while ``requested()`` is the
  interrupt** -- call ``check()`` (or ``raise interrupted(err)``) in every ``except`` that would
  otherwise retry, record a failed item, or blame the solver.
* Nor does the handler's ``Interrupted`` always come out as itself from C code that calls back
  into Python (numpy converting a CasADi ``DM`` calls ``DM.__array__``, whose SWIG ``full()``
  calls ``toarray``, ``size1``, ...): when the C caller ignores the exception and returns a
  result, CPython reports ``SystemError: <function DM.__array__ ...> returned a result with an
  exception set`` (the ``Interrupted`` its cause); CasADi's ``__array__`` can turn a failed
  ``full()`` into a ``TypeError``; CasADi's own interrupt check raises a bare
  ``KeyboardInterrupt``; and a C caller that clears the error drops it altogether (the next
  ``check()`` raises it). So a loop that keeps a partial result catches ``BaseException`` --
  not a list of kinds -- and asks ``interrupted(err, tau)`` what it was (re-raising what is
  neither the interrupt nor its own failure). The quasi-static loop caught a list of kinds and
  lost its tau and positions to the SystemError in 2.5 to 10 % of real SIGINTs.
* ``Interrupted`` derives from ``KeyboardInterrupt``: ``except Exception`` and
  ``except SymgenError`` let it through. Its ``exit_code`` is 128 + the signal (130 for SIGINT,
  143 for SIGTERM) and ``partial`` carries a run's partial result when the run keeps one.
"""

from __future__ import annotations

import contextlib
import re
import signal
import sys
import threading
from types import FrameType
from typing import TextIO, overload
from collections.abc import Iterator

from symgen.errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)

_pending: list[int] = []  # signals received inside handling(), oldest first
_depth = 0


def requested() -> int | None:
    """The signal received since ``handling()`` was entered (None: none)."""
    return _pending[0] if _pending else None


def check(tau: float | None = None) -> None:
    """Raise ``Interrupted`` if a signal arrived (``tau``: where the run stands, for the message)."""
    if _pending:
        raise Interrupted(_pending[0], tau)


@overload
def interrupted(err: BaseException, tau: float | None = None) -> BaseException: ...


@overload
def interrupted(err: None = None, tau: float | None = None) -> Interrupted | None: ...


def interrupted(err: BaseException | None = None, tau: float | None = None) -> BaseException | None:
    """What a failure ``err`` really is: ``Interrupted`` when a signal is pending (or when
    ``err`` is CasADi's report of a KeyboardInterrupt outside ``handling()``), else ``err``."""
    if isinstance(err, Interrupted):
        return err if err.tau is not None or tau is None else Interrupted(err.signum, tau)
    if _pending:
        return Interrupted(_pending[0], tau)
    if err is not None and "KeyboardInterrupt" in str(err):
        return Interrupted(signal.SIGINT, tau)
    return err


class _SolverNoiseFilter:
    """``sys.stderr`` inside ``handling()``: once a signal is pending, CasADi's own report of
    the interrupt inside a solver callback ("res failed: KeyboardInterrupt", "psetup failed:
    ...", IDAS's "At t = ..., the residual function failed unrecoverably." or "..., the linear
    solver setup failed unrecoverably.", written in pieces) is dropped -- symgen says
    "interrupted by SIGINT at tau = ..." instead. Everything else passes unchanged."""

    # a pattern's text (compiled by ``re`` at its first use: once a signal is pending)
    _NOISE = (
        r"^(\w+ failed: |KeyboardInterrupt|Interrupted|interrupted by SIG\w+( at tau = \S+)?"
        r"|(At t = [^,]*, the|The) [\w ]+ failed unrecoverably\. ?)$"
    )

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self._dropped = False

    def write(self, text: str) -> int:
        if _pending and (re.match(self._NOISE, text) or (self._dropped and text == "\n")):
            self._dropped = text != "\n"
            return len(text)
        self._dropped = False
        return self._stream.write(text)

    def __getattr__(self, name: str) -> object:
        return getattr(self._stream, name)


_deferring: list[bool] = []  # inside deferred(): a signal is recorded, raised when it ends


def _handler(signum: int, frame: FrameType | None) -> None:
    _pending.append(signum)
    if not _deferring:
        raise Interrupted(signum)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A short block (reading the command line) that a signal does not cut: the signal is
    recorded and raised by the next ``check()`` after the block, where the caller is ready to
    clean up (the command's outputs are known by then)."""
    _deferring.append(True)
    try:
        yield
    finally:
        _deferring.pop()


@contextlib.contextmanager
def handling(signals: tuple[signal.Signals, ...] = SIGNALS) -> Iterator[None]:
    """Install the SIGINT/SIGTERM handlers for the duration of the block (see the module)."""
    global _depth
    if threading.current_thread() is not threading.main_thread() or _depth:
        yield
        return
    previous = {s: signal.getsignal(s) for s in signals}
    _pending.clear()
    _depth += 1
    stderr = sys.stderr
    try:
        sys.stderr = _SolverNoiseFilter(stderr)
        for s in signals:
            signal.signal(s, _handler)
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        if isinstance(sys.stderr, _SolverNoiseFilter):
            sys.stderr = stderr
        _depth -= 1
        _pending.clear()
