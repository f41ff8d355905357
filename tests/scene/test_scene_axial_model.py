"""``effects.axial``: the contract's true / false plus the project's "auto" (the default),
"dynamic", "quasi_static" and "inextensible"."""

from __future__ import annotations

import pytest

from symgen.errors import SceneError
from symgen.scene import Effects, load_scene
from symgen.model.structure import structure_key, structure_of


def _with_axial(path, value: str, write_scene):
    text = path.read_text()
    assert text.count("\naxial = true\n") == 1
    return write_scene(text.replace("\naxial = true\n", f"\naxial = {value}\n"))


@pytest.mark.parametrize(
    "value, expected",
    [
        ("true", True),
        ("false", False),
        ('"inextensible"', "inextensible"),
        ('"auto"', "auto"),
        ('"dynamic"', "dynamic"),
        ('"quasi_static"', "quasi_static"),
    ],
)
def test_axial_values(dimless_path, write_scene, value, expected):
    scene = load_scene(_with_axial(dimless_path, value, write_scene))
    assert scene.effects.axial == expected
    assert scene.effects.coriolis is False  # the rest of [effects] read as before


def test_axial_default_and_override(dimless_path, write_scene):
    assert Effects().axial == "auto"
    text = dimless_path.read_text().replace("\naxial = true\n", "\n")
    assert load_scene(write_scene(text)).effects.axial == "auto"  # absent: the default
    assert load_scene(dimless_path).effects.axial is True
    assert load_scene(dimless_path, ["effects.axial=inextensible"]).effects.axial == "inextensible"
    assert load_scene(dimless_path, ["effects.axial=false"]).effects.axial is False


@pytest.mark.parametrize(
    "value, fragment",
    [
        ('"rigid"', "unknown value 'rigid'"),
        ('"Inextensible"', "unknown value 'Inextensible'"),
        ("1", "must be true or false, got integer 1"),
        ("[true]", "must be true or false"),
    ],
)
def test_bad_axial_values(dimless_path, write_scene, value, fragment):
    with pytest.raises(SceneError) as info:
        load_scene(_with_axial(dimless_path, value, write_scene))
    err = info.value
    assert err.key == "effects.axial"
    assert fragment in err.message
    assert "inextensible" in err.hint and "auto" in err.hint and "quasi_static" in err.hint


def test_structure_key_unchanged_unless_inextensible(dimless_path):
    """Scenes whose bars are all dynamic or rigid keep their cache keys (and generated/
    fingerprints): the structure names the axial model of each bar only when one is
    inextensible or quasi-static."""
    base = structure_of(load_scene(dimless_path))
    assert "axial" not in base["effects"]
    inext = structure_of(load_scene(dimless_path, ["effects.axial=inextensible"]))
    assert set(inext["effects"]["axial"].values()) == {"inextensible"}
    # same mode counts; the rod's point load at xi = 0.5 gets a static correction function, an
    # axial one only while the rod keeps its axial dynamics
    assert base["bodies"][1]["static_points"] == {"transverse": [0.5], "axial": [0.5]}
    assert inext["bodies"][1]["static_points"] == {"transverse": [0.5]}
    strip = lambda bodies: [{k: v for k, v in b.items() if k != "static_points"} for b in bodies]
    assert strip(inext["bodies"]) == strip(base["bodies"])
    assert structure_key(inext) != structure_key(base)
    off = structure_of(load_scene(dimless_path, ["effects.axial=false"]))
    assert "axial" not in off["effects"] and off["bodies"][1]["na"] == 0
