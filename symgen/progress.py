"""Progress bars of the long commands (sweep, study, reproduce, effects --measure).

tqdm on stderr, shown only when stderr is a terminal (``enabled=None``): logs, pipes and CI
stay clean. The bars never write to stdout, which keeps the commands' own lines parsable. A
disabled bar does not import tqdm (~0.08 s of CPU, a fifth of a cached ``--solver c`` process:
benchmarks/bench_exudyn.py).
"""

from __future__ import annotations

import sys
from types import TracebackType


class _NoBar:
    """The disabled bar: ``update`` and ``close`` do nothing (tqdm's ``disable=True``, unimported)."""

    def update(self, n: float = 1) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> _NoBar:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        pass


def progress_bar(total: int, desc: str, unit: str = "run", enabled: bool | None = None):
    """A tqdm bar (a no-op one when disabled); use ``.update(n)`` and ``.close()``."""
    disable = (not sys.stderr.isatty()) if enabled is None else not enabled
    if disable:
        return _NoBar()
    from tqdm import tqdm

    # no monitor thread: a sweep forks its worker processes, which wants a single-threaded parent
    tqdm.monitor_interval = 0
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=False, leave=False, dynamic_ncols=True)
