"""Limits on what a scene may ask for: sizes that cost memory or time, and sane numbers.

A scene file is data from other people: a typo (``transverse_modes = 1000000000``,
``output_step = 1e-9``, ``length = 1e300``) must end in a clear :class:`SceneError` naming the
file and the key, not in gigabytes of memory, an hour of derivation or an overflow deep in a
later stage. Every limit here says what it bounds, its value, and how to lift it.

Liftable limits (a larger value in the environment variable lifts them; the value is read when
a scene is loaded):

* shape functions per family (axial, transverse) of a bar: 24 (``SYMGEN_MAX_MODES``);
* output rows of a run, t_end / output_step + 1: 2 000 000 (``SYMGEN_MAX_ROWS``);
* run length t_end, in tau: 1e6 (``SYMGEN_MAX_T_END``);
* entries of [[bodies]], [[joints]], [[loads]] or [outputs]: 256 (``SYMGEN_MAX_ENTRIES``).

Fixed bounds (no physical scene comes near them):

* every number in the file has magnitude <= 1e30 (:data:`MAX_MAGNITUDE`);
* every dimensionless group (alpha, nu, lambda, mu, rho of each bar; l0, omega, m_ref) lies in
  [1e-30, 1e30] and every scaled value (ground points, joint masses, gravity, loads, torque)
  has magnitude <= 1e30 (:data:`GROUP_RANGE`), so no later product overflows;
* 1e-14 <= rtol < 1 (a warning above 1e-3: such runs can be tens of per cent off) and
  0 < atol < 1 (coordinates are O(1) in model units);
* the file is UTF-8 text (a byte-order mark is accepted) of at most 16 MiB, nested at most
  16 levels deep, its integers within TOML's 64 bits.

Examples
--------
>>> limit_value("modes", env={})
24
>>> limit_value("modes", env={"SYMGEN_MAX_MODES": "40"})
40
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass

from symgen.errors import SceneError

#: Largest magnitude of any number written in a scene file.
MAX_MAGNITUDE = 1e30
#: Range of the magnitude of every non-zero dimensionless group and scaled value.
GROUP_RANGE = (1e-30, 1e30)
#: Relative tolerance: smallest accepted, largest accepted (exclusive), largest without a warning.
RTOL_MIN, RTOL_MAX, RTOL_WARN = 1e-14, 1.0, 1e-3
#: Absolute tolerance: largest accepted (exclusive).
ATOL_MAX = 1.0
#: Absolute tolerance: smallest accepted. The coordinates are in model units (lengths / l0): 1e-20
#: of a bar's length is far below any physical deflection, and below it IDAS cannot meet the
#: tolerance in double precision (measured: 1e-30 gives IDA_TOO_MUCH_WORK at tau = 0, 1e-300
#: IDA_ILL_INPUT, on the slider-crank).
ATOL_MIN = 1e-20
#: Largest scene file, in bytes.
MAX_FILE_BYTES = 16 * 1024 * 1024
#: Deepest nesting of tables and arrays (the contract needs 5: initial.deformation.bar.g[k]).
MAX_DEPTH = 16
#: TOML integers are 64-bit signed.
INT64 = (-(2**63), 2**63 - 1)


@dataclass(frozen=True)
class Limit:
    """One liftable limit: its default, the environment variable that lifts it, what it bounds."""

    name: str
    default: int | float
    env: str
    what: str
    integer: bool = True


LIMITS: dict[str, Limit] = {
    lim.name: lim
    for lim in (
        Limit("modes", 24, "SYMGEN_MAX_MODES", "shape functions per family (axial or transverse) of one bar"),
        Limit("rows", 2_000_000, "SYMGEN_MAX_ROWS", "output rows of a run (t_end / output_step + 1)"),
        Limit("t_end", 1e6, "SYMGEN_MAX_T_END", "run length t_end in tau", integer=False),
        Limit("entries", 256, "SYMGEN_MAX_ENTRIES", "entries of [[bodies]], [[joints]], [[loads]] or [outputs]"),
    )
}


class SceneWarning(UserWarning):
    """A scene that is valid but probably not what its author wants (``symgen`` prints it)."""


def limit_value(name: str, env: Mapping[str, str] | None = None) -> int | float:
    """The current value of limit ``name``: its environment variable if set, else the default.

    Raises
    ------
    SceneError
        (file "environment") when the variable is set to something that is not a positive
        number (an integer for counts).
    """
    lim = LIMITS[name]
    text = (os.environ if env is None else env).get(lim.env, "").strip()
    if not text:
        return lim.default
    try:
        value = int(text) if lim.integer else float(text)
    except ValueError:
        value = None
    if value is None or not math.isfinite(value) or value <= 0:
        kind = "a positive integer" if lim.integer else "a positive finite number"
        raise SceneError(
            "environment",
            lim.env,
            f"must be {kind} (the limit on {lim.what}), got {text!r}",
            f"unset it for the default {lim.default:g}, or give {kind}",
        )
    return value


def lift_hint(name: str, advice: str) -> str:
    """``advice``, then how to lift limit ``name``."""
    lim = LIMITS[name]
    return (
        f"{advice}; or, if you really mean it, raise the limit with the environment variable "
        f"{lim.env}=N (now {limit_value(name):g})"
    )


def over_limit(name: str, count: float) -> bool:
    """True when ``count`` exceeds limit ``name``."""
    return count > limit_value(name)


def structure_problem(node: object, path: str = "", limit: int = MAX_DEPTH) -> tuple[str, str] | None:
    """(dotted key, what is wrong) of the first value nested deeper than ``limit`` levels or
    holding an integer outside TOML's 64-bit range, or ``None``.

    Iterative, so that any depth ``tomllib`` produces (dotted keys are not recursive there)
    is checked without recursion.
    """
    stack: list[tuple[object, str, int]] = [(node, path, 0)]
    while stack:
        value, where, depth = stack.pop()
        if depth > limit:
            return where, f"nested more than {limit} levels deep"
        if isinstance(value, dict):
            stack.extend((v, f"{where}.{k}" if where else str(k), depth + 1) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, _entry_key(where, i, v), depth + 1) for i, v in enumerate(value))
        elif isinstance(value, int) and not INT64[0] <= value <= INT64[1]:
            return where, f"an integer of {value.bit_length()} bits, beyond TOML's 64-bit integers"
    return None


def _entry_key(where: str, i: int, entry: object) -> str:
    """``bodies.rod`` for a named entry of [[bodies]] or [[joints]] (as messages address them),
    else ``where[i]``."""
    name = entry.get("name") if isinstance(entry, dict) else None
    if where in ("bodies", "joints") and isinstance(name, str) and name.isidentifier():
        return f"{where}.{name}"
    return f"{where}[{i}]"


def short_key(key: str, width: int = 80) -> str:
    """A dotted key cut to ``width`` characters for messages."""
    return key if len(key) <= width else key[: width - 3] + "..."
