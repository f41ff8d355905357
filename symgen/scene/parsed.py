"""A TOML text parsed once: a scene file (or a ``--set`` value) that an earlier process parsed is
recalled from the cache, so that a run on a cached model does not import ``tomllib`` (its
regular expressions compiled at import, ``datetime``: ~40 M of the ~430 M instructions of a
cached ``simulate --solver c`` process; benchmarks/RESULTS.md).

The parse is remembered as a sealed JSON verdict (:func:`symgen.cache.remember`; its question is
the text's sha256, the symgen and Python versions, checked with the keyed hash on recall), and only when
JSON holds it exactly: tables, arrays, strings, booleans, integers and finite floats (a text with
a date or time, ``inf`` or ``nan`` is parsed every time). A text that does not parse is never
remembered: its error comes from ``tomllib``, as before. What is recalled is checked as a parse
is (``symgen.scene.limits.check_structure``, then the scene's own checks).
"""

from __future__ import annotations

import json
import math
import sys
from typing import Any

from symgen import __version__

__all__ = ["loads"]


def _plain(value: object) -> bool:
    """JSON data that loads back equal and of the same types (iterative: any depth)."""
    stack = [value]
    while stack:
        x = stack.pop()
        kind = type(x)
        if isinstance(x, dict) and kind is dict:
            if not all(type(k) is str for k in x):
                return False
            stack.extend(x.values())
        elif isinstance(x, list) and kind is list:
            stack.extend(x)
        elif isinstance(x, float) and kind is float:
            if not math.isfinite(x):
                return False
        elif kind not in (str, int, bool):
            return False
    return True


def loads(text: str) -> dict[str, Any]:
    """``tomllib.loads(text)``, recalled when this symgen parsed the same text before; raises
    what ``tomllib`` raises."""
    from symgen import cache

    question = {
        "check": "toml",
        "sha256": cache.sha256_hex(text.encode("utf-8", "surrogatepass")),
        "symgen": __version__,
        "python": list(sys.version_info[:2]),  # tomllib's version
    }
    found, answer = cache.recall(question)
    if found and type(answer) is str:
        try:
            recalled = json.loads(answer)  # verified with its verdict
        except (ValueError, RecursionError):
            recalled = None
        if type(recalled) is dict:
            return recalled
    import tomllib

    raw = tomllib.loads(text)
    if _plain(raw):
        try:
            # the JSON text, in the TOML's order (a verdict's answer is written with sorted keys;
            # the order of a table's keys is the scene's: outputs, bodies, ...)
            cache.remember(question, json.dumps(raw, allow_nan=False))
        except (RecursionError, ValueError):  # nested deeper than JSON writes: parsed again next time
            pass
    return raw
