"""Stopping a run on SIGINT (Ctrl-C) or SIGTERM within a second, keeping what it computed.

One mechanism for every long loop (``simulate``, ``quasistatic``, ``study``, ``reproduce``,
``effects --measure``, sweeps)::

    from symgen.errors import Interrupted
    from symgen.run import interrupt

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
* ``Interrupted`` derives from ``KeyboardInterrupt``: ``except Exception`` and
  ``except SymgenError`` let it through. Its ``exit_code`` is 128 + the signal (130 for SIGINT,
  143 for SIGTERM) and ``partial`` carries a run's partial result when the run keeps one.
"""
from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

from ..errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)

_pending: list[int] = []       # signals received inside handling(), oldest first
_depth = 0


def requested() -> int | None:
    """The signal received since ``handling()`` was entered (None: none)."""
    return _pending[0] if _pending else None


def check(tau: float | None = None) -> None:
    """Raise ``Interrupted`` if a signal arrived (``tau``: where the run stands, for the message)."""
    if _pending:
        raise Interrupted(_pending[0], tau)


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


def _handler(signum, frame):
    _pending.append(signum)
    raise Interrupted(signum)


@contextlib.contextmanager
def handling(signals=SIGNALS) -> Iterator[None]:
    """Install the SIGINT/SIGTERM handlers for the duration of the block (see the module)."""
    global _depth
    if threading.current_thread() is not threading.main_thread() or _depth:
        yield
        return
    previous = {s: signal.getsignal(s) for s in signals}
    _pending.clear()
    _depth += 1
    try:
        for s in signals:
            signal.signal(s, _handler)
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        _depth -= 1
        _pending.clear()
