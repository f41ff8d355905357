"""Progress bars of the long commands (sweep, study, reproduce, effects --measure).

tqdm on stderr, shown only when stderr is a terminal (``enabled=None``): logs, pipes and CI
stay clean. The bars never write to stdout, which keeps the commands' own lines parsable.
"""

from __future__ import annotations

import sys


def progress_bar(total: int, desc: str, unit: str = "run", enabled: bool | None = None):
    """A tqdm bar (a no-op one when disabled); use ``.update(n)`` and ``.close()``."""
    from tqdm import tqdm

    disable = (not sys.stderr.isatty()) if enabled is None else not enabled
    # no monitor thread: a sweep forks its worker processes, which wants a single-threaded parent
    tqdm.monitor_interval = 0
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=disable, leave=False, dynamic_ncols=True)
