"""``--set KEY=VALUE`` overrides applied to the raw TOML dict before validation.

KEY is a dotted path. In the arrays of tables ``bodies`` and ``joints`` an entry is addressed by
its ``name`` (``bodies.rod.transverse_modes``); any array entry can also be addressed by its
position (``loads.0.axial`` or ``loads[0].axial``). ``outputs.<name>.<key>`` addresses an existing
output; every other path is a chain of table keys, created when missing
(``effects.coriolis=false``). VALUE is read as a TOML value, else taken as a plain string
(``effects.strain=linear``).

Examples
--------
>>> raw = {"bodies": [{"name": "rod", "transverse_modes": 1}]}
>>> apply_overrides(raw, ["bodies.rod.transverse_modes=3", "effects.strain=linear"], "s.toml")
{'bodies': [{'name': 'rod', 'transverse_modes': 3}], 'effects': {'strain': 'linear'}}
"""

from __future__ import annotations

import copy
import re
import tomllib
from collections.abc import Sequence
from typing import Any

from symgen.errors import SceneError
from symgen.scene.limits import MAX_DEPTH, short_key, structure_problem

NAMED_ARRAYS = {"bodies": "body", "joints": "joint"}
SEGMENT = re.compile(r"([A-Za-z0-9_\-]+)((?:\[\d+\])*)")
EXAMPLE = "e.g. --set bodies.rod.transverse_modes=3 or --set simulation.rtol=1e-6"


def parse_value(text: str) -> Any:
    """A ``--set`` value: a TOML value if it parses as one, else the text as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def _split_key(key: str, file: str, item: str) -> list[str | int]:
    """Split a dotted key into table keys (str) and array positions (int)."""
    steps: list[str | int] = []
    for part in key.split("."):
        match = SEGMENT.fullmatch(part)
        if not match:
            raise SceneError(
                file, key or item, f"malformed --set key {key!r} in {item!r}", f"use a dotted path of keys, {EXAMPLE}"
            )
        steps.append(int(match[1]) if match[1].isdigit() else match[1])
        steps.extend(int(i) for i in re.findall(r"\d+", match[2]))
    return steps


def parse_override(item: str, file: str) -> tuple[str, list[str | int], Any]:
    """Split ``KEY=VALUE`` into (key, path steps, parsed value)."""
    key, sep, text = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SceneError(file, key or item, f"malformed --set override {item!r}: expected KEY=VALUE", EXAMPLE)
    steps = _split_key(key, file, item)
    if len(steps) > MAX_DEPTH:
        raise SceneError(
            file,
            short_key(key),
            f"--set {short_key(key)}: nested more than {MAX_DEPTH} levels deep",
            f"use a dotted path of keys, {EXAMPLE}",
        )
    try:
        value = parse_value(text)
    except (ValueError, RecursionError) as exc:  # e.g. 5000 digits or 1000 nested brackets
        what = "nested too deeply" if isinstance(exc, RecursionError) else str(exc).split(";")[0]
        raise SceneError(
            file,
            short_key(key),
            f"--set {short_key(key)}: cannot read the value: {what}",
            'give a TOML value: a number, true/false, a "string", [array] or { table }',
        ) from None
    problem = structure_problem(value, key, MAX_DEPTH - len(steps))
    if problem is not None:
        raise SceneError(
            file,
            short_key(problem[0]),
            f"--set {short_key(key)}: {problem[1]}",
            'give a TOML value: a number, true/false, a "string", [array] or { table }',
        )
    return key, steps, value


def _array_entry(node: list, step: str | int, path: list[str | int], key: str, file: str) -> Any:
    """The entry of an array addressed by position or (for tables) by ``name``."""
    if isinstance(step, int):
        if step >= len(node):
            raise SceneError(
                file, key, f"--set {key}: there is no entry {step} (the array has {len(node)})", "count entries from 0"
            )
        return step
    for i, entry in enumerate(node):
        if isinstance(entry, dict) and entry.get("name") == step:
            return i
    what = NAMED_ARRAYS.get(str(path[0]), "entry") if path else "entry"
    known = [str(e.get("name")) for e in node if isinstance(e, dict) and "name" in e]
    raise SceneError(
        file,
        key,
        f"--set {key}: no {what} named {step!r}",
        f"known: {', '.join(known)}" if known else "check the scene file",
    )


def _descend(node: Any, step: str | int, done: list[str | int], last: bool, key: str, file: str) -> Any:
    """The index into ``node`` for ``step``, creating a missing table where allowed."""
    here = ".".join(str(s) for s in done) or "the scene"
    if isinstance(node, list):
        if last and len(done) == 1 and done[0] in NAMED_ARRAYS:
            what = NAMED_ARRAYS[str(done[0])]
            raise SceneError(
                file,
                key,
                f"--set {key}: set one key of a {what}, not the whole entry",
                f"address it by name, e.g. --set {done[0]}.{step}.<key>=VALUE",
            )
        return _array_entry(node, step, done, key, file)
    if not isinstance(node, dict):
        raise SceneError(file, key, f"--set {key}: {here} is not a table", "check the path")
    if isinstance(step, int):
        raise SceneError(
            file, key, f"--set {key}: {here} is not an array", "address table keys by name, array entries by position"
        )
    if step not in node and not last:
        if done == ["outputs"]:
            raise SceneError(
                file,
                key,
                f"--set {key}: no output named {step!r}",
                f'to add one, --set outputs.{step}={{kind = "...", ...}}',
            )
        if not done and step in NAMED_ARRAYS:
            raise SceneError(file, key, f"--set {key}: the scene has no [[{step}]]", "add them to the scene file")
        node[step] = {}
    return step


def set_path(raw: dict, steps: list[str | int], value: Any, key: str, file: str) -> None:
    """Assign ``value`` at ``steps`` inside ``raw`` (in place)."""
    node: Any = raw
    for i, step in enumerate(steps):
        last = i == len(steps) - 1
        index = _descend(node, step, steps[:i], last, key, file)
        if last:
            node[index] = value
        else:
            node = node[index]


def apply_overrides(raw: dict, overrides: Sequence[str], file: str) -> dict:
    """Apply ``--set KEY=VALUE`` overrides to a copy of the raw scene dict.

    Parameters
    ----------
    raw : the scene as parsed by ``tomllib`` (not modified)
    overrides : ``KEY=VALUE`` strings, applied in order
    file : the scene file, for messages

    Returns
    -------
    A new dict with the overrides applied.

    Raises
    ------
    SceneError
        For a malformed override or a path naming an unknown body, joint or output
        (key = the override path, message mentioning ``--set``).
    """
    result = copy.deepcopy(raw)
    made_rigid: list[str] = []
    given: set[tuple[str, str]] = set()
    for item in overrides:
        key, steps, value = parse_override(item, file)
        set_path(result, steps, value, key, file)
        if len(steps) == 3 and steps[0] == "bodies" and isinstance(steps[1], str):
            given.add((steps[1], str(steps[2])))
            if steps[2] == "rigid" and value is True:
                made_rigid.append(steps[1])
    for name in made_rigid:
        _drop_elastic_data(result, name, given)
    return result


def _drop_elastic_data(raw: dict, body: str, given: set[tuple[str, str]]) -> None:
    """``--set bodies.NAME.rigid=true`` on an elastic bar: its elastic data in the file (E,
    lambda, mode counts...) no longer applies and is dropped; what the same command line sets
    for that bar is kept (and refused by the loader, naming it, if a rigid bar cannot take it)."""
    from symgen.scene.mechanism import RIGID_FORBIDDEN

    for table in raw.get("bodies", []) if isinstance(raw.get("bodies"), list) else []:
        if isinstance(table, dict) and table.get("name") == body:
            for key in [k for k in table if k in RIGID_FORBIDDEN and (body, k) not in given]:
                del table[key]
