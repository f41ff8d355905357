"""``--set KEY=VALUE`` overrides: addressing by name, TOML values, string fallback, errors."""

from __future__ import annotations

import pytest

from symgen.errors import SceneError
from symgen.scene import apply_overrides, load_scene


def test_by_name_and_table_paths(si_path):
    scene = load_scene(
        si_path,
        [
            "bodies.rod.transverse_modes=3",
            "joints.B.mass=0.1",
            "effects.coriolis=false",
            "simulation.rtol=1e-6",
            "outputs.eta_mid.at=0.25",
            "driver.rate=200",
        ],
    )
    assert scene.body("rod").transverse_modes == 3
    assert scene.joint("B").mass == pytest.approx(0.1 / (0.78 * 0.3))
    assert scene.effects.coriolis is False
    assert scene.simulation.rtol == 1e-6
    assert scene.outputs[0].xi == 0.25
    assert scene.driver.rate == pytest.approx(200.0)


def test_string_fallback_and_toml_values(dimless_path):
    scene = load_scene(
        dimless_path,
        [
            "effects.strain=linear",  # not TOML: taken as the string "linear"
            "loads[0].transverse=0.2*cos(tau)",  # likewise, then validated as an expression
            'loads.1.axial="tau"',  # a TOML string; arrays also by position
            "effects.gravity=[0.0, -1.0]",
            'outputs.KE={kind = "energy"}',  # a new output goes last
        ],
    )
    assert scene.effects.strain == "linear"
    assert scene.loads[0].transverse == "0.2*cos(tau)"
    assert scene.loads[1].axial == "tau"
    assert scene.effects.gravity == (0.0, -1.0)
    assert scene.outputs[-1].name == "KE"


def test_missing_tables_are_created():
    raw = {"scene": {"name": "x"}}
    out = apply_overrides(raw, ["effects.rotary_inertia=true"], "s.toml")
    assert out["effects"] == {"rotary_inertia": True}
    assert raw == {"scene": {"name": "x"}}  # the input is not modified


def test_overridden_values_are_validated(dimless_path):
    with pytest.raises(SceneError) as info:
        load_scene(dimless_path, ["bodies.rod.length=-1"])
    assert info.value.key == "bodies.rod.length" and "must be > 0" in info.value.message
    # 3 transverse modes no longer match the 2 initial amplitudes given for the rod
    with pytest.raises(SceneError) as info:
        load_scene(dimless_path, ["bodies.rod.transverse_modes=3"])
    assert info.value.key == "initial.deformation.rod.g"
    with pytest.raises(SceneError) as info:
        load_scene(dimless_path, ["bodies.crank.name=ground"])
    assert info.value.key == "bodies[0].name" and "reserved" in info.value.message
    with pytest.raises(SceneError) as info:  # SI bars need E, area, ... not lambda
        load_scene(dimless_path, ["scene.units=SI"])
    assert info.value.key == "bodies.rod.lambda" and "SI" in info.value.message


@pytest.mark.parametrize(
    "override, key, fragment",
    [
        ("bodies.rood.length=1", "bodies.rood.length", "no body named 'rood'"),
        ("joints.C.mass=1", "joints.C.mass", "no joint named 'C'"),
        ("outputs.nope.at=0.5", "outputs.nope.at", "no output named 'nope'"),
        ("bodies.rod=1", "bodies.rod", "not the whole entry"),
        ("bodies.rod.length", "bodies.rod.length", "expected KEY=VALUE"),
        ("=3", "=3", "expected KEY=VALUE"),
        ("bodies..length=1", "bodies..length", "malformed --set key"),
        ("simulation.rtol.x=1", "simulation.rtol.x", "is not a table"),
        ("loads.5.axial=1", "loads.5.axial", "no entry 5"),
    ],
)
def test_override_errors(dimless_path, override, key, fragment):
    with pytest.raises(SceneError) as info:
        load_scene(dimless_path, [override])
    assert info.value.key == key
    assert fragment in info.value.message and "--set" in info.value.message


def test_set_rigid_on_an_elastic_si_bar_drops_its_elastic_data(tmp_path):
    """``--set bodies.X.rigid=true`` on an elastic bar of an SI scene was refused ("a rigid bar
    has no 'E'"): the file's elastic data of that bar no longer applies; its mass stays; what
    the same command line sets for it is still checked."""
    import re
    from pathlib import Path

    from symgen.errors import SceneError
    from symgen.scene import load_scene

    root = Path(__file__).resolve().parents[2]
    text = re.sub(r"(?m)^rocker_mid = .*\n", "", (root / "examples" / "four_bar.toml").read_text())
    path = tmp_path / "four_bar.toml"
    path.write_text(text)
    elastic = load_scene(path)
    scene = load_scene(path, ["bodies.rocker.rigid=true"])
    rocker = next(b for b in scene.bodies if b.name == "rocker")
    assert rocker.rigid and rocker.lam is None and rocker.frame == ""
    assert rocker.nu == next(b for b in elastic.bodies if b.name == "rocker").nu  # its mass stays
    with pytest.raises(SceneError, match="a rigid bar has no 'E'"):
        load_scene(path, ["bodies.rocker.rigid=true", "bodies.rocker.E=1e9"])
