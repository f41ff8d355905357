"""The valid ranges of the model parameters (symgen.ir.parameters.parameter_records), the one policy
the Python runs verify and the emitted C renders (tests/test_emit_c_sanitize.py checks the C
side against it)."""

from __future__ import annotations

import math

import pytest

from symgen.errors import SceneError
from symgen.ir.parameters import (
    FINITE,
    NON_NEGATIVE,
    POSITIVE,
    UNIT_COMPONENT,
    ParameterRange,
    parameter_records,
    parameter_values,
)
from symgen.scene import load_scene

from c_support import ALL_EXAMPLES, ROOT

SI_SCENE = ROOT / "tests" / "scene" / "data" / "si_slider_crank.toml"


def test_range_membership_and_wording():
    assert [POSITIVE.contains(x) for x in (1e-300, 0.0, -1.0, math.inf, math.nan)] == [True, False, False, False, False]
    assert [NON_NEGATIVE.contains(x) for x in (0.0, -5e-324, 1e300)] == [True, False, True]
    assert [UNIT_COMPONENT.contains(x) for x in (-1.0, 1.0, math.nextafter(1.0, 2.0), math.nan)] == [
        True,
        True,
        False,
        False,
    ]
    assert [FINITE.contains(x) for x in (-1e308, 1e308, math.inf, -math.inf, math.nan)] == [
        True,
        True,
        False,
        False,
        False,
    ]
    assert [r.text() for r in (POSITIVE, NON_NEGATIVE, UNIT_COMPONENT, FINITE)] == [
        "> 0",
        ">= 0",
        "in [-1, 1]",
        "finite",
    ]
    half_open = ParameterRange(lower=0.0, upper=1.0, upper_open=True)
    assert half_open.text() == "in [0, 1)" and half_open.contains(0.0) and not half_open.contains(1.0)


@pytest.mark.parametrize("path", [*ALL_EXAMPLES.values(), SI_SCENE], ids=lambda p: p.stem)
def test_every_parameter_of_a_valid_scene_is_in_range_and_names_a_scene_key(path):
    """Every kind of parameter (stiffness, lengths, masses, lumped masses, ground points, slider
    direction, gravity, damping, loads, driver, [[masses]]) of the examples and the SI scene."""
    scene = load_scene(path)
    recs = parameter_records(scene)
    assert recs and all(r.valid.contains(r.value) for r in recs)
    names = {r.name for r in recs}
    assert {"gx", "gy", "damping"} <= names
    for r in recs:
        section, entry, *_ = r.key.split(".") + [""]
        assert section in ("bodies", "joints", "effects", "driver", "drivers", "loads", "masses"), r
        if section == "masses":  # [[masses]] by position, like loads
            assert int(entry) < len(scene.masses), r
        if section == "drivers":  # several drivers: drivers.<index>.<key>
            assert len(scene.drivers) > 1 and int(entry) < len(scene.drivers), r
        if section == "bodies":
            assert entry in {b.name for b in scene.bodies}, r
        if section == "joints":
            assert entry in {j.name for j in scene.joints}, r
    by_name = {r.name: r for r in recs}
    if path == SI_SCENE:  # stiffness from E, lumped mass, slider direction, loads
        assert by_name["lambda_rod"].key == "bodies.rod.E" and by_name["lambda_rod"].valid == POSITIVE
        assert by_name["m_B"].valid == NON_NEGATIVE and by_name["dx_B"].valid == UNIT_COMPONENT
        assert any(n.startswith("load") for n in names)


def test_a_group_out_of_range_is_a_scene_error_naming_file_and_key(tmp_path):
    """E * area overflowing to inf would give lambda = inf: the loader refuses the number itself
    (naming the file and key); and parameter_values, the last gate before the numerics and the
    emitted C, refuses an out-of-range group in a scene built some other way."""
    import dataclasses

    text = SI_SCENE.read_text()
    assert "area = 1.0e-4" in text and "E = 2.0e11" in text
    bad = tmp_path / "huge.toml"
    bad.write_text(text.replace("E = 2.0e11", "E = 1.0e308", 1))
    with pytest.raises(SceneError) as err:
        load_scene(bad)
    assert err.value.file == str(bad) and err.value.key == "bodies.rod.E"
    scene = load_scene(SI_SCENE)
    rod = dataclasses.replace(scene.body("rod"), lam=float("inf"))
    scene = dataclasses.replace(scene, bodies=tuple(rod if b.name == "rod" else b for b in scene.bodies))
    names = [r.name for r in parameter_records(load_scene(SI_SCENE))]
    with pytest.raises(SceneError) as err:
        parameter_values(scene, names)
    assert err.value.file == str(SI_SCENE) and err.value.key == "bodies.rod.E"
    assert "lambda_rod" in err.value.message and "inf" in err.value.message and "> 0" in err.value.message
