"""Any single corrupted value gives a SceneError (or a valid scene), never a crash."""

from __future__ import annotations

import copy
import pathlib
import tomllib

import pytest

from symgen.errors import SceneError
from symgen.scene import parse_scene

DATA = pathlib.Path(__file__).parent / "data"
DELETE = object()
ODD_VALUES = [-1, 0, 1.5, float("nan"), "x", True, [], {}, [1, 2, 3], ["ground", "ground"], [[0.0, 0.0], 0.0], DELETE]


def _paths(node, prefix=()):
    """Every (dotted) position in a parsed TOML tree."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield prefix + (key,)
        yield from _paths(value, prefix + (key,))


def _replace(raw, path, value):
    node = raw
    for step in path[:-1]:
        node = node[step]
    if value is DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value


@pytest.mark.parametrize("name", ["slider_crank.toml", "si_slider_crank.toml"])
def test_single_corruptions_never_crash(name):
    file = str(DATA / name)
    with open(file, "rb") as f:
        original = tomllib.load(f)
    for path in list(_paths(original)):
        for value in ODD_VALUES:
            raw = copy.deepcopy(original)
            _replace(raw, path, value)
            try:
                parse_scene(raw, file)
            except SceneError as err:
                assert err.hint, (path, value, str(err))
