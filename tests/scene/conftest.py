"""Shared paths and helpers for the scene-loader tests."""

from __future__ import annotations

import pathlib

import pytest

HERE = pathlib.Path(__file__).parent
DATA = HERE / "data"
BAD = HERE / "bad"


@pytest.fixture
def dimless_path() -> pathlib.Path:
    """The valid dimensionless slider-crank (every contract key used once)."""
    return DATA / "slider_crank.toml"


@pytest.fixture
def si_path() -> pathlib.Path:
    """The valid SI slider-crank."""
    return DATA / "si_slider_crank.toml"


@pytest.fixture
def write_scene(tmp_path: pathlib.Path):
    """Write TOML text to a temporary scene file and return its path."""

    def write(text: str, name: str = "scene.toml") -> pathlib.Path:
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write
