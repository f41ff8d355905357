"""A first run's background library build held back until the run's second chunk, so that the
switch from the virtual machine to the library happens mid-run, not by the luck of timing
(tests/test_background_compile.py, tests/test_bar_blocks.py)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from symgen.numerics import compiled


@contextmanager
def build_held_to_second_chunk(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Within the block, the pending library reports itself not done at the run's first check
    and done (its build joined) from the second on; the real check is restored after."""
    checks = {"n": 0}
    done = compiled.PendingLibrary.done

    def held(self):
        checks["n"] += 1
        if checks["n"] < 2:
            return False
        if self._thread is not None:
            self._thread.join()
        return done(self)

    monkeypatch.setattr(compiled.PendingLibrary, "done", held)
    try:
        yield
    finally:
        monkeypatch.setattr(compiled.PendingLibrary, "done", done)
