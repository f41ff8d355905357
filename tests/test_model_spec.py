"""The typed derivation input (``symgen.ir.spec.ModelSpec``, built by
``symgen.model.structure.model_spec``) keeps every model key: its canonical JSON is the
structure dict the cache keys were made from before it was typed.

Oracles: the checked-in ``generated/*/model.json`` (key and structure of every example, written
before the spec was typed), and for the benchmark and test scenes (with the overrides that
switch on the fields that appear only when set) the sha256 of their structure computed by the
untyped ``structure_of`` of the main branch, with the version field blanked so that a version
bump does not touch this table.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from symgen.ir.spec import BodySpec, EffectsSpec, ModelSpec
from symgen.model.structure import model_spec, structure_key, structure_of
from symgen.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))

PENDULUM = """
[scene]
name = "driven_pendulum"
[[bodies]]
name = "bar"
length = 1.0
lambda = 1.0e4
mu = 10.0
axial_modes = 1
transverse_modes = 2
frame = "pinned-pinned"
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "{kind}"
body = "bar"
{driver}
[effects]
gravity = [0.0, -2.0]
[outputs]
theta = {{ kind = "angle", body = "bar" }}
[simulation]
t_end = 1.0
output_step = 0.05
"""
DRIVERS = {
    "law": ("angle", 'law = "0.3*sin(2*tau)"'),
    "ramp": ("angle", "rate = 1.0\nramp = 2.0"),
    "torque_expression": ("torque", 'value = "0.5*sin(tau)"\nrotor_inertia = 0.1'),
    "constant_speed": ("angle", "rate = 1.0"),
}
SCENES = [
    "benchmarks/scenes/four_bar_steel.toml",
    "benchmarks/scenes/inverted_slider_crank_overhang.toml",
    "benchmarks/scenes/six_bar_steel.toml",
    "benchmarks/scenes/slider_crank_spinup.toml",
    "benchmarks/scenes/slider_crank_steel.toml",
    "tests/data/four_bar_free.toml",
    "tests/scene/data/slider_crank.toml",
    "tests/scene/data/si_slider_crank.toml",
    *(f"examples/{p.name}" for p in EXAMPLES),
]
VARIANTS = {
    "": [],
    "inextensible": ['effects.axial="inextensible"'],
    "quasi_static": ['effects.axial="quasi_static"'],
    "no_axial": ["effects.axial=false"],
    "no_bending": ["effects.transverse=false"],
}


def cases(tmp: Path) -> dict:
    """label -> scene: the scenes above with each variant, and the pendulum with each driver."""
    out = {}
    for rel in SCENES:
        for tag, overrides in VARIANTS.items():
            out[f"{rel}:{tag}"] = load_scene(ROOT / rel, overrides)
    for tag, (kind, text) in DRIVERS.items():
        path = tmp / f"pendulum_{tag}.toml"
        path.write_text(PENDULUM.format(kind=kind, driver=text))
        out[f"pendulum:{tag}"] = load_scene(path)
    return out


def unversioned(structure: dict) -> str:
    return hashlib.sha256(json.dumps({**structure, "version": None}, sort_keys=True).encode()).hexdigest()[:20]


#: unversioned(structure_of(scene)) on the main branch before the spec was typed; the elastic
#: overhang's guide has one function more since DERIVE_VERSION 11 (the contact-slope function chi_0)
EXPECTED = {
    "benchmarks/scenes/four_bar_steel.toml:": "90d794edcce11a52e2a8",
    "benchmarks/scenes/four_bar_steel.toml:inextensible": "c84b518e80d10cb52c7e",
    "benchmarks/scenes/four_bar_steel.toml:quasi_static": "705ffb79524989637319",
    "benchmarks/scenes/four_bar_steel.toml:no_axial": "3619c74d31d052e98c49",
    "benchmarks/scenes/four_bar_steel.toml:no_bending": "63f46208a090439018f4",
    "benchmarks/scenes/inverted_slider_crank_overhang.toml:": "24ca0bc8f2a1077844ee",
    "benchmarks/scenes/inverted_slider_crank_overhang.toml:inextensible": "b6cb97b6653042337ecd",
    "benchmarks/scenes/inverted_slider_crank_overhang.toml:quasi_static": "ce7a6c4f8bf9c1f5b366",
    "benchmarks/scenes/inverted_slider_crank_overhang.toml:no_axial": "774516af98dd82fabe65",
    "benchmarks/scenes/inverted_slider_crank_overhang.toml:no_bending": "440045f3b783d2f879ec",
    "benchmarks/scenes/six_bar_steel.toml:": "5efebfa08dd9437d7f3e",
    "benchmarks/scenes/six_bar_steel.toml:inextensible": "0af32c7f06cd6da178e2",
    "benchmarks/scenes/six_bar_steel.toml:quasi_static": "d44c47cea1678da5dbb4",
    "benchmarks/scenes/six_bar_steel.toml:no_axial": "479150d0045909f7f68f",
    "benchmarks/scenes/six_bar_steel.toml:no_bending": "9865825b229b938f84d6",
    "benchmarks/scenes/slider_crank_spinup.toml:": "44ebc03999c0168336de",
    "benchmarks/scenes/slider_crank_spinup.toml:inextensible": "3b49b409a5c2619888ad",
    "benchmarks/scenes/slider_crank_spinup.toml:quasi_static": "507ff29ab090f6b14a3b",
    "benchmarks/scenes/slider_crank_spinup.toml:no_axial": "71b84ec0e7f1f0d8f611",
    "benchmarks/scenes/slider_crank_spinup.toml:no_bending": "6411ca2b69d7dd4ce1b1",
    "benchmarks/scenes/slider_crank_steel.toml:": "61e848a69d5d317321cf",
    "benchmarks/scenes/slider_crank_steel.toml:inextensible": "83884b4c8d367b1a7444",
    "benchmarks/scenes/slider_crank_steel.toml:quasi_static": "61e848a69d5d317321cf",
    "benchmarks/scenes/slider_crank_steel.toml:no_axial": "ae2b79d50cfe00704975",
    "benchmarks/scenes/slider_crank_steel.toml:no_bending": "3559d52f1c17c92830e9",
    "tests/data/four_bar_free.toml:": "3d50e9972fc9bdfafb49",
    "tests/data/four_bar_free.toml:inextensible": "e38088ce53b97ed4b02f",
    "tests/data/four_bar_free.toml:quasi_static": "5a4fe59c2390f34e8299",
    "tests/data/four_bar_free.toml:no_axial": "0cd31014cab1efd3d1ec",
    "tests/data/four_bar_free.toml:no_bending": "2eda8a812ca4fcfbe7b5",
    "tests/scene/data/slider_crank.toml:": "155af172ca134e7538d6",
    "tests/scene/data/slider_crank.toml:inextensible": "ff4d5d18c8c707423f38",
    "tests/scene/data/slider_crank.toml:quasi_static": "bf901d09dbcb108cb790",
    "tests/scene/data/slider_crank.toml:no_axial": "a99b12744122883a1666",
    "tests/scene/data/slider_crank.toml:no_bending": "c4c4b940eee4019b92ab",
    "tests/scene/data/si_slider_crank.toml:": "697e5365f302b98ce860",
    "tests/scene/data/si_slider_crank.toml:inextensible": "98e00f9a55bae2292174",
    "tests/scene/data/si_slider_crank.toml:quasi_static": "95242becf8eb99f4e90d",
    "tests/scene/data/si_slider_crank.toml:no_axial": "c2b4ddca60ca447f5539",
    "tests/scene/data/si_slider_crank.toml:no_bending": "70f3effa1a50f8c8f1cc",
    "examples/double_pendulum.toml:": "a663c15b73681eba4b37",
    "examples/double_pendulum.toml:inextensible": "31f8fcf11d44daecdc45",
    "examples/double_pendulum.toml:quasi_static": "a663c15b73681eba4b37",
    "examples/double_pendulum.toml:no_axial": "583aef6d0961a215924c",
    "examples/double_pendulum.toml:no_bending": "c75df45f7cfe1459fbfe",
    "examples/four_bar.toml:": "3ca12ea3be6e63bd9988",
    "examples/four_bar.toml:inextensible": "436bd615f8647283bbe8",
    "examples/four_bar.toml:quasi_static": "d917bc67a666680843c6",
    "examples/four_bar.toml:no_axial": "c04cecbfea44fc598d2f",
    "examples/four_bar.toml:no_bending": "3f646b64c11ae03f5bd7",
    # added with the example (issue 21, [[masses]]); changed once on purpose: its tool has a rotary
    # inertia and an arm, so the coupler gained the moment correction at xi = 0.4 (static_points
    # "moment"); its no_bending variant has no transverse functions and kept its key
    "examples/four_bar_tool.toml:": "2f1f24e36d0ee10713c9",
    "examples/four_bar_tool.toml:inextensible": "5e9039a3722731854f51",
    "examples/four_bar_tool.toml:quasi_static": "9d9b566bf1ba4aba7301",
    "examples/four_bar_tool.toml:no_axial": "667a98bed6605435c985",
    "examples/four_bar_tool.toml:no_bending": "172c4c16dde43a27ce56",
    "examples/inverted_slider_crank.toml:": "234f7b423fc2cfd4ffa0",
    "examples/inverted_slider_crank.toml:inextensible": "5b52b64db726d2749045",
    "examples/inverted_slider_crank.toml:quasi_static": "8dfb3f15ff474136a2ba",
    "examples/inverted_slider_crank.toml:no_axial": "f20bea5a6f64b29b44f6",
    "examples/inverted_slider_crank.toml:no_bending": "fd573ccd4b96f9045534",
    # the five-bar came with [[drivers]] (issue 21): its keys as first derived
    "examples/five_bar.toml:": "5aa625d3695fcc92dd0f",
    "examples/five_bar.toml:inextensible": "d116063fb4947ffaec7c",
    "examples/five_bar.toml:quasi_static": "773cc5959d92df98a0c9",
    "examples/five_bar.toml:no_axial": "4350a5a07c30dcc498a7",
    "examples/five_bar.toml:no_bending": "5a36222957638599617b",
    "examples/motor_arm.toml:": "691aa5d8619bac07a3ea",
    "examples/motor_arm.toml:inextensible": "5ecc6c15a2364418e3f3",
    "examples/motor_arm.toml:quasi_static": "954713e7851858d5b50c",
    "examples/motor_arm.toml:no_axial": "f9505b6d2ca729870df6",
    "examples/motor_arm.toml:no_bending": "d5c11810d6eec94121d4",
    "examples/six_bar.toml:": "a644891344f8af2ff790",
    "examples/six_bar.toml:inextensible": "c28c9447d6875b984433",
    "examples/six_bar.toml:quasi_static": "78ef929d8a91528b12ea",
    "examples/six_bar.toml:no_axial": "d3c5a2813e6ac0bd95e3",
    "examples/six_bar.toml:no_bending": "09712467bb6bf5865fb1",
    "examples/slider_crank.toml:": "c12b9758ca405ff6c1ec",
    "examples/slider_crank.toml:inextensible": "2f637a9ad28aec45db37",
    "examples/slider_crank.toml:quasi_static": "43b9b3f1d551c7ff6171",
    "examples/slider_crank.toml:no_axial": "c273669160c02bbdac9c",
    "examples/slider_crank.toml:no_bending": "4d56493ccc7832cc73c6",
    "pendulum:law": "8345751d695342f2cfce",
    "pendulum:ramp": "eeaaa857d7f650c968dd",
    "pendulum:torque_expression": "ea4489c01e6870221ee7",
    "pendulum:constant_speed": "f01f2cf0f69932f21231",
}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_examples_keep_their_generated_key_and_structure(path):
    meta = json.loads((ROOT / "generated" / path.stem / "model.json").read_text())
    spec = model_spec(load_scene(path))
    assert spec.to_json() == meta["structure"]
    assert spec.key() == structure_key(spec) == structure_key(meta["structure"]) == meta["key"]


def test_every_scene_keeps_its_structure(tmp_path):
    got = {label: unversioned(structure_of(scene)) for label, scene in cases(tmp_path).items()}
    assert set(got) == set(EXPECTED)
    changed = sorted(label for label in got if got[label] != EXPECTED[label])
    assert not changed, f"structure (so the model key) changed for {changed}"
    assert len(set(got.values())) > len(got) // 2  # the variants are different models


def test_fields_set_only_when_used_are_exercised(tmp_path):
    """The table above covers every field that the JSON holds only when it is set."""
    specs = [model_spec(s) for s in cases(tmp_path).values()]
    assert any(b.static_axial for s in specs for b in s.bodies)
    assert any(b.static_transverse for s in specs for b in s.bodies)
    assert any(b.static_moment for s in specs for b in s.bodies)
    assert any(j.inertia for s in specs for j in s.joints)
    assert any(m.inertia and m.offset for s in specs for m in s.masses)
    assert any(j.overhang is not None for s in specs for j in s.joints)
    drivers = [d for s in specs for d in s.drivers]
    assert any(len(s.drivers) > 1 for s in specs)  # the "drivers" list of several
    assert any(d.law for d in drivers) and any(d.ramp for d in drivers) and any(d.rotor_inertia for d in drivers)
    assert any(d.torque != "const" for d in drivers)
    assert any(ld.transverse != "const" for s in specs for ld in s.loads)
    assert {t for s in specs if s.effects.axial for _, t in s.effects.axial} >= {"quasi_static", "inextensible"}


def test_the_json_round_trips(tmp_path):
    for label, scene in cases(tmp_path).items():
        spec = model_spec(scene)
        assert ModelSpec.from_json(json.loads(json.dumps(spec.to_json()))) == spec, label


def test_axial_treatment_and_sizes_read_from_the_spec():
    spec = model_spec(load_scene(ROOT / "examples/six_bar.toml", ['effects.axial="quasi_static"']))
    assert set(spec.axial_treatments().values()) == {"quasi_static"}
    plain = model_spec(load_scene(ROOT / "examples/six_bar.toml"))
    assert plain.effects.axial is None
    assert plain.axial_treatments() == {b.name: ("dynamic" if b.na else "off") for b in plain.bodies if not b.rigid}
    corrected = [b for b in plain.bodies if b.static_transverse]
    assert corrected and all(
        b.sizes == (b.na + len(b.static_axial), b.nt + len(b.static_transverse)) for b in corrected
    )
    body = BodySpec("b", False, "cantilever", 2, 3, "complete", "modes", True, (0.5,), ())
    assert body.to_json()["static_points"] == {"axial": [0.5]} and BodySpec.from_json(body.to_json()) == body
    effects = EffectsSpec(True, True, False, "von_karman", False, False)
    assert "axial" not in effects.to_json() and EffectsSpec.from_json(effects.to_json()) == effects
