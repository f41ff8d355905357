"""``effects.axial``: the contract's true / false plus the project's "inextensible" model."""
from __future__ import annotations

import pytest

from symgen.errors import SceneError
from symgen.scene import Effects, load_scene
from symgen.structure import structure_key, structure_of


def _with_axial(path, value: str, write_scene):
    text = path.read_text()
    assert text.count("\naxial = true\n") == 1
    return write_scene(text.replace("\naxial = true\n", f"\naxial = {value}\n"))


@pytest.mark.parametrize("value, expected", [("true", True), ("false", False),
                                             ('"inextensible"', "inextensible")])
def test_axial_values(dimless_path, write_scene, value, expected):
    scene = load_scene(_with_axial(dimless_path, value, write_scene))
    assert scene.effects.axial == expected
    assert scene.effects.coriolis is False          # the rest of [effects] read as before


def test_axial_default_and_override(dimless_path):
    assert Effects().axial is True
    assert load_scene(dimless_path).effects.axial is True
    assert load_scene(dimless_path, ["effects.axial=inextensible"]).effects.axial == "inextensible"
    assert load_scene(dimless_path, ["effects.axial=false"]).effects.axial is False


@pytest.mark.parametrize("value, fragment", [
    ('"rigid"', "unknown value 'rigid'"),
    ('"Inextensible"', "unknown value 'Inextensible'"),
    ("1", "must be true or false, got integer 1"),
    ("[true]", "must be true or false"),
])
def test_bad_axial_values(dimless_path, write_scene, value, fragment):
    with pytest.raises(SceneError) as info:
        load_scene(_with_axial(dimless_path, value, write_scene))
    err = info.value
    assert err.key == "effects.axial"
    assert fragment in err.message
    assert "inextensible" in err.hint and "true, false" in err.hint


def test_structure_key_unchanged_unless_inextensible(dimless_path):
    """Scenes with axial = true/false keep their cache keys (and generated/ fingerprints):
    the structure names the axial model only when it is "inextensible"."""
    base = structure_of(load_scene(dimless_path))
    assert "axial" not in base["effects"]
    inext = structure_of(load_scene(dimless_path, ["effects.axial=inextensible"]))
    assert inext["effects"]["axial"] == "inextensible"
    assert inext["bodies"] == base["bodies"]                     # same mode counts
    assert structure_key(inext) != structure_key(base)
    off = structure_of(load_scene(dimless_path, ["effects.axial=false"]))
    assert "axial" not in off["effects"] and off["bodies"][1]["na"] == 0
