"""Each file in bad/ is a valid scene with exactly one thing wrong (see its first line)."""

from __future__ import annotations

import pathlib

import pytest

from symgen.errors import SceneError
from symgen.scene import load_scene

BAD = pathlib.Path(__file__).parent / "bad"

#: (file stem in bad/, expected SceneError.key, distinctive fragment of SceneError.message)
BAD_CASES = [
    ("unknown_key", "bodies.rod.lenght", "unknown key 'lenght'"),
    ("unknown_table", "extras", "unknown key 'extras'"),
    ("unknown_effect", "effects.corriolis", "unknown key 'corriolis'"),
    ("negative_length", "bodies.crank.length", "must be > 0"),
    ("slot_joint", "joints.B.bodies", "a slot joins a point of one bar to a second (guide) bar"),
    ("slot_rigid_guide", "joints.A.at", "is rigid; symgen models slots on elastic bars"),
    ("slot_axial_guide", "bodies.guide.axial_modes", "a bar carrying a slot is axially rigid"),
    ("slot_fixed_at", "joints.A.at", "for a slot"),
    ("bad_name_keyword", "bodies[0].name", "C/C++ keyword"),
    ("bad_name_cpp_keyword", "scene.name", "'namespace' is a C/C++ keyword"),
    ("bad_name_unicode", "outputs.η_mid", "characters other than ASCII"),
    ("bad_name_digit", "joints[1].name", "starts with a digit"),
    ("bad_name_too_long", "scene.name", "at most 63"),
    ("disconnected_body", "bodies.weight", "not connected to ground"),
    ("toml_syntax", "", "TOML syntax error"),
    ("missing_lambda", "bodies.rod.lambda", "missing required key 'lambda'"),
    ("missing_frame", "bodies.rod.frame", "missing required key 'frame'"),
    ("bad_at_range", "joints.A.at", "must be <= 1"),
    ("slider_two_bars", "joints.B.bodies", 'exactly one bar and "ground"'),
    ("bad_output_body", "outputs.eta_mid.body", "unknown body 'rood'"),
    ("output_rigid_body", "outputs.eta_mid.body", "is a rigid bar"),
    ("torque_expr_unknown_symbol", "driver.value", "unknown name 'T0'"),
    ("load_expr_syntax", "loads[0].transverse", "the '(' at character 8 is never closed"),
    ("load_expr_function", "loads[0].transverse", "unknown function 'erf'"),
    ("both_t_end_and_cycles", "simulation", "exactly one of t_end and cycles"),
    ("neither_t_end_nor_cycles", "simulation", "neither given"),
    ("zero_direction", "joints.B.direction", "direction vector is zero"),
    ("bad_direction_length", "joints.B.direction", "must have 2 entries"),
    ("deformation_length", "initial.deformation.rod.g", "transverse_modes = 2"),
    ("deformation_rigid", "initial.deformation.crank", "rigid bar"),
    ("bad_deformation_string", "initial.deformation", "unknown value 'static'"),
    ("guess_unknown_body", "initial.guess.rood", "unknown body 'rood'"),
    ("si_missing_E", "bodies.rod.E", "missing required key 'E'"),
    ("si_missing_omega", "scene.omega", "missing required key 'omega'"),
    ("si_lambda", "bodies.rod.lambda", "dimensionless group"),
    ("si_expression_load", "loads[0].transverse", "unknown name 'omega'"),
    ("si_both_masses", "bodies.crank.density", "either mass_per_length or density"),
    ("dimensionless_E", "bodies.rod.E", "SI quantity"),
    ("rigid_with_lambda", "bodies.crank.lambda", "a rigid bar has no 'lambda'"),
    ("rigid_with_modes", "bodies.crank.transverse_modes", "a rigid bar has no 'transverse_modes'"),
    ("duplicate_body", "bodies.rod.name", "duplicate body name 'rod'"),
    ("duplicate_joint", "joints.A.name", "duplicate joint name 'A'"),
    ("pin_to_itself", "joints.A.bodies", "cannot join 'rod' to itself"),
    ("unknown_joint_body", "joints.A.bodies", "unknown body 'rood'"),
    ("bool_as_number", "bodies.rod.mu", "must be a number, got boolean"),
    ("string_as_number", "simulation.rtol", "must be a number, got string"),
    ("float_modes", "bodies.rod.axial_modes", "must be an integer"),
    ("negative_modes", "bodies.rod.transverse_modes", "must be >= 0"),
    ("nonfinite_lambda", "bodies.rod.lambda", "must be a finite number"),
    ("negative_mu", "bodies.rod.mu", "must be > 0"),
    ("negative_rtol", "simulation.rtol", "must be > 0"),
    ("negative_mass", "joints.B.mass", "must be >= 0"),
    ("negative_damping", "effects.damping", "must be >= 0"),
    ("unknown_frame", "bodies.rod.frame", "unknown value 'clamped'"),
    ("unknown_shapes", "bodies.rod.transverse_shapes", "unknown value 'legendre'"),
    ("unknown_strain", "effects.strain", "unknown value 'green'"),
    ("unknown_units", "scene.units", "unknown value 'imperial'"),
    ("unknown_joint_kind", "joints.A.kind", "unknown value 'weld'"),
    ("unknown_driver_kind", "driver.kind", "unknown value 'speed'"),
    ("unknown_load_kind", "loads[0].kind", "unknown value 'uniform'"),
    ("unknown_output_kind", "outputs.eps_ax.kind", "unknown value 'strain'"),
    ("bad_component", "outputs.xB.component", "unknown value 'z'"),
    ("output_missing_key", "outputs.xB.component", "missing required key 'component'"),
    ("output_extra_key", "outputs.E.body", "takes no 'body'"),
    ("output_bad_at", "outputs.eta_mid.at", "must be >= 0"),
    ("reaction_unknown_joint", "outputs.RBy.joint", "unknown joint 'C'"),
    ("output_name_tau", "outputs.tau", "time column"),
    ("driver_torque_of_torque_driver", "outputs.M0.kind", "torque driver"),
    ("driver_not_grounded", "driver.body", 'no pin joint with "ground"'),
    ("angle_driver_with_value", "driver.value", "an angle driver has no value"),
    ("no_outputs", "outputs", "no outputs"),
    ("point_load_without_at", "loads[1].at", "missing required key 'at'"),
    ("distributed_load_with_at", "loads[0].at", "has no 'at'"),
    ("dimensionless_omega", "scene.omega", "must be 1.0"),
    ("output_step_too_long", "simulation.output_step", "longer than the run"),
    ("missing_scene_name", "scene.name", "missing required key 'name'"),
    ("pin_with_direction", "joints.A.direction", "a pin joint has no direction"),
    ("ground_at_not_point", "joints.O.at", "at[0] (ground) must be an array"),
    # limits (issue 9): sizes, run length, tolerances, magnitudes, groups, nesting, reserved names
    ("huge_modes", "bodies.rod.transverse_modes", "more than the limit of 24 per family"),
    ("modes_over_limit", "bodies.rod.axial_modes", "25 shape functions is more than the limit of 24"),
    ("huge_t_end", "simulation.t_end", "beyond 1e+30"),
    ("t_end_over_limit", "simulation.t_end", "more than the limit 1e+06"),
    ("cycles_over_limit", "simulation.cycles", "(2 turns at driver.rate 1e-20), more than the limit"),
    ("tiny_output_step", "simulation.output_step", "would write 6.283e+06 output rows"),
    ("huge_rtol", "simulation.rtol", "beyond 1e+30"),
    ("rtol_one", "simulation.rtol", "must be in [1e-14, 1), got 1"),
    ("tiny_rtol", "simulation.rtol", "must be in [1e-14, 1), got 1e-20"),
    ("huge_atol", "simulation.atol", "must be < 1, got 2"),
    ("huge_length", "bodies.rod.length", "is 1e+300: beyond 1e+30"),
    ("tiny_length", "bodies.crank.length", "alpha = l / l0 of bar 'crank' = 5e-301, outside [1e-30, 1e+30]"),
    ("int_length_overflow", "bodies.rod.length", "beyond TOML's 64-bit integers"),
    ("inf_load", "loads[1].transverse", "must be a finite number, got inf"),
    ("si_tiny_E", "bodies.rod.E", "lambda = EA/(m l^2 omega^2) of bar 'rod' = 1.4245e-37"),
    ("si_tiny_omega", "scene.omega", "lambda = EA/(m l^2 omega^2) of bar 'rod' = 2.849e+58"),
    ("joint_named_ground", "joints[0].name", "joint name 'ground' is not allowed: it is reserved"),
    ("output_named_ground", "outputs.ground", "output name 'ground' is not allowed: it is reserved"),
    ("joint_named_like_body", "joints.rod.name", "joint name 'rod' is also the name of a body"),
    ("deep_nesting", "", "nested too deeply at line 92 (at most 16 levels)"),
    ("deep_dotted_key", "simulation.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a", "nested more than 16 levels deep"),
    ("bigint_mass", "joints.B.mass", "an integer of 16000 bits, beyond TOML's 64-bit integers"),
]


@pytest.mark.parametrize("stem, key, fragment", BAD_CASES, ids=[c[0] for c in BAD_CASES])
def test_bad_scene(stem, key, fragment):
    path = BAD / f"{stem}.toml"
    with pytest.raises(SceneError) as info:
        load_scene(path)
    err = info.value
    assert err.key == key
    assert fragment in err.message
    assert err.hint, "every error says what to do"
    assert str(err).startswith(f"{path}: ")


def test_syntax_error_names_the_line():
    with pytest.raises(SceneError) as info:
        load_scene(BAD / "toml_syntax.toml")
    assert "line 15" in info.value.message and info.value.hint == "fix the TOML syntax"


def test_every_bad_file_is_in_the_table():
    files = {p.stem for p in BAD.glob("*.toml")}
    assert files == {c[0] for c in BAD_CASES}
    for stem in files:
        assert (BAD / f"{stem}.toml").read_text(encoding="utf-8").startswith("# BAD: ")
