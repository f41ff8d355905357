"""Typed access to raw TOML values, raising :class:`SceneError` with dotted keys.

Every accessor takes the table, the dotted path of that table (``bodies.rod``) and the key,
so that a message can always name the exact place of a problem.

Examples
--------
>>> r = Reader("scene.toml")
>>> r.number({"length": 2}, "bodies.rod", "length", gt=0.0)
2.0
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from datetime import date, datetime, time
from typing import Any, NoReturn, TypeGuard

from symgen.errors import SceneError
from symgen.scene.limits import MAX_MAGNITUDE

#: Sentinel meaning "this key is required" (no default).
REQUIRED: Any = object()

SPELLING_HINT = "check the spelling; docs/scene-format.md lists every key"


def join(path: str, key: str | int) -> str:
    """Dotted key of ``key`` inside the table at ``path`` (``[i]`` for array positions)."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else key


def toml_type(value: object) -> str:
    """TOML name of the type of a parsed value, for messages."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    if isinstance(value, dict):
        return "table"
    if isinstance(value, (datetime, date, time)):
        return "date/time"
    return type(value).__name__


def describe(value: object) -> str:
    """``string 'abc'``, ``boolean True``...: a value with its TOML type."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{toml_type(value)} {text}"


def _short(value: object) -> str:
    """repr of a value, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def is_number(value: object) -> TypeGuard[int | float]:
    """True for TOML integers and floats (TOML booleans are not numbers)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class Reader:
    """Validating accessor bound to one scene file.

    Parameters
    ----------
    file : path of the scene file, used in every error
    """

    def __init__(self, file: str) -> None:
        self.file = file

    # -- errors -----------------------------------------------------------------------------
    def fail(self, key: str, message: str, hint: str = "") -> NoReturn:
        """Raise a :class:`SceneError` for ``key``."""
        raise SceneError(self.file, key, message, hint)

    def missing(self, path: str, key: str, hint: str = "") -> NoReturn:
        """Raise the error for a missing required key."""
        self.fail(join(path, key), f"missing required key '{key}'", hint or f"add {key} = ...")

    # -- structure --------------------------------------------------------------------------
    def table(self, value: object, key: str, hint: str = "") -> dict:
        """Check that ``value`` is a TOML table."""
        if not isinstance(value, dict):
            self.fail(
                key, f"must be a table, got {describe(value)}", hint or f"write [{key}] or {{ key = value, ... }}"
            )
        return value

    def table_array(self, value: object, key: str, hint: str = "") -> list[dict]:
        """Check that ``value`` is an array of tables (``[[key]]``)."""
        if not isinstance(value, list):
            self.fail(
                key,
                f"must be an array of tables ([[{key}]]), got {describe(value)}",
                hint or f"write each entry as a [[{key}]] table",
            )
        for i, item in enumerate(value):
            self.table(item, join(key, i), hint)
        return value

    def check_keys(self, table: dict, path: str, allowed: Iterable[str], what: str = "") -> None:
        """Reject any key of ``table`` that is not in ``allowed``."""
        allowed = tuple(allowed)
        for key in table:
            if key not in allowed:
                where = f" in {what}" if what else ""
                self.fail(join(path, key), f"unknown key '{key}'{where} (allowed: {', '.join(allowed)})", SPELLING_HINT)

    def require(self, table: dict, path: str, key: str, hint: str = "") -> Any:
        """The value of a required key."""
        if key not in table:
            self.missing(path, key, hint or f"add {key} = ...")
        return table[key]

    # -- scalars ----------------------------------------------------------------------------
    def number(
        self,
        table: dict,
        path: str,
        key: str,
        default: Any = REQUIRED,
        *,
        gt: float | None = None,
        ge: float | None = None,
        le: float | None = None,
        hint: str = "",
    ) -> Any:
        """A finite number (int or float, not bool) as ``float``, optionally range-checked."""
        if key not in table:
            if default is REQUIRED:
                self.missing(path, key, hint)
            return default
        return self.as_number(table[key], join(path, key), gt=gt, ge=ge, le=le, hint=hint)

    def as_number(
        self,
        value: object,
        key: str,
        *,
        gt: float | None = None,
        ge: float | None = None,
        le: float | None = None,
        hint: str = "",
        label: str = "",
    ) -> float:
        """Check one value: a finite number within the given bounds."""
        prefix = f"{label} " if label else ""
        if not is_number(value):
            self.fail(
                key,
                f"{prefix}must be a number, got {describe(value)}",
                hint or "write a number without quotes, e.g. 1.0",
            )
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the float range
            x = math.copysign(math.inf, value)
        bounds = [f"{op} {b:g}" for op, b in ((">", gt), (">=", ge), ("<=", le)) if b is not None]
        hint = hint or f"use a finite number{' ' + ' and '.join(bounds) if bounds else ''}"
        if not math.isfinite(x):
            self.fail(key, f"{prefix}must be a finite number, got {_short(value)}", hint)
        if abs(x) > MAX_MAGNITUDE:
            self.fail(
                key,
                f"{prefix}is {x:g}: beyond {MAX_MAGNITUDE:g}, larger than any quantity of a scene",
                "check the units and the exponent",
            )
        if gt is not None and not x > gt:
            self.fail(key, f"{prefix}must be > {gt:g}, got {value!r}", hint)
        if ge is not None and not x >= ge:
            self.fail(key, f"{prefix}must be >= {ge:g}, got {value!r}", hint)
        if le is not None and not x <= le:
            self.fail(key, f"{prefix}must be <= {le:g}, got {value!r}", hint)
        return x

    def integer(
        self, table: dict, path: str, key: str, default: Any = REQUIRED, *, ge: int | None = None, hint: str = ""
    ) -> Any:
        """An integer (not bool, not float), optionally with a lower bound."""
        if key not in table:
            if default is REQUIRED:
                self.missing(path, key, hint)
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(
                join(path, key),
                f"must be an integer, got {describe(value)}",
                hint or "write a whole number without a decimal point",
            )
        if ge is not None and value < ge:
            self.fail(join(path, key), f"must be >= {ge}, got {value}", hint or f"use an integer >= {ge}")
        return value

    def boolean(self, table: dict, path: str, key: str, default: Any = REQUIRED, hint: str = "") -> Any:
        """A TOML boolean (``true``/``false``)."""
        if key not in table:
            if default is REQUIRED:
                self.missing(path, key, hint)
            return default
        value = table[key]
        if not isinstance(value, bool):
            self.fail(
                join(path, key),
                f"must be true or false, got {describe(value)}",
                hint or "write true or false without quotes",
            )
        return value

    def string(self, table: dict, path: str, key: str, default: Any = REQUIRED, hint: str = "") -> Any:
        """A TOML string."""
        if key not in table:
            if default is REQUIRED:
                self.missing(path, key, hint)
            return default
        value = table[key]
        if not isinstance(value, str):
            self.fail(join(path, key), f"must be a string, got {describe(value)}", hint or "write it in double quotes")
        return value

    def choice(
        self, table: dict, path: str, key: str, choices: Sequence[str], default: Any = REQUIRED, hint: str = ""
    ) -> Any:
        """A string that must be one of ``choices``."""
        allowed = ", ".join(f'"{c}"' for c in choices)
        value = self.string(table, path, key, default, hint or f"use one of {allowed}")
        if value is not default and value not in choices:
            self.fail(
                join(path, key),
                f"unknown value {value!r} (allowed: {allowed})",
                hint or "check the spelling; values are case-sensitive",
            )
        return value

    # -- arrays -----------------------------------------------------------------------------
    def numbers(
        self, value: object, key: str, length: int | None = None, hint: str = "", label: str = ""
    ) -> tuple[float, ...]:
        """An array of finite numbers, optionally of a given length."""
        prefix = f"{label} " if label else ""
        if not isinstance(value, list):
            self.fail(key, f"{prefix}must be an array of numbers, got {describe(value)}", hint or "write [number, ...]")
        if length is not None and len(value) != length:
            self.fail(
                key,
                f"{prefix}must have {length} entries, got {len(value)}",
                hint or f"write {length} numbers in brackets",
            )
        return tuple(self.as_number(v, key, hint=hint, label=f"{prefix}entry {i}".strip()) for i, v in enumerate(value))

    def pair(self, value: object, key: str, hint: str = "", label: str = "") -> tuple[float, float]:
        """A 2-vector ``[x, y]`` of finite numbers."""
        x, y = self.numbers(value, key, 2, hint or "write it as [x, y]", label)
        return (x, y)
