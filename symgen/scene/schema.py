"""The scene-file schema: every table and key the loader accepts, with type, default, unit,
allowed values, meaning and an example.

The key lists and allowed values are the loader's own constants (imported here, never
retyped); this module adds what a reader needs to know about each of them. Two renderings come
from it: ``docs/scene-format.md`` (the reference in the repository) and a JSON Schema for
editors (``symgen schema``). ``tests/scene/test_schema.py`` fails when the loader accepts a key
this module does not describe, when a described key is not accepted, when a stated default is
not what the loader does, or when ``docs/scene-format.md`` differs from :func:`markdown`.

Examples
--------
>>> from symgen.scene.schema import TABLES, markdown
>>> [t.path for t in TABLES][:3]
['scene', 'bodies', 'joints']
>>> markdown().startswith("# Scene files")
True
"""

from __future__ import annotations

from dataclasses import dataclass, field

from symgen.scene import excitation as _ex
from symgen.scene import loader as _ld
from symgen.scene import masses as _ma
from symgen.scene import mechanism as _me
from symgen.scene import outputs as _ou
from symgen.scene.expressions import ALLOWED_FUNCTIONS
from symgen.scene.model import OUTPUT_KINDS
from symgen.scene.names import MAX_NAME_LENGTH
from symgen.policy import SOLVERS, TOLERANCES, tolerances
from symgen.scene.bases import DEFAULT_ACCURACY

NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_]*$"
NAME_RULE = (
    f"a C identifier: letters, digits and _, not starting with a digit, at most "
    f"{MAX_NAME_LENGTH} characters, no C/C++ keyword"
)


def _tolerance_default(key: str) -> str:
    """The documented default of simulation.rtol / atol: the rule of ``symgen.policy`` (one home),
    with its values at the default accuracy."""
    rule = TOLERANCES
    if key == "rtol":
        how = ", ".join(f"{rule.rtol_factor(s):g} x accuracy ({SOLVER_NAMES[s]})" for s in SOLVERS)
        how += f", within [{rule.rtol_min:g}, {rule.rtol_max:g}]"
    else:
        how = ", ".join(f"rtol x {rule.atol_factor(s):g} ({SOLVER_NAMES[s]})" for s in SOLVERS)
    at = ", ".join(f"{tolerances(DEFAULT_ACCURACY, s)[key == 'atol']:g} ({SOLVER_NAMES[s]})" for s in SOLVERS)
    return f"from simulation.accuracy (neither rtol nor atol stated): {how}; at accuracy {DEFAULT_ACCURACY:g}: {at}"


#: how the documented defaults name the solvers of symgen.policy.SOLVERS
SOLVER_NAMES = {"idas": "IDAS", "c": "--solver c"}


@dataclass(frozen=True)
class Key:
    """One key of a table.

    ``type`` is the TOML type in words; ``json`` its JSON Schema fragment; ``required`` says
    when it must be given ("yes", "no" or the condition); ``default`` is the value the loader
    uses when it is absent, as text ("" when required or when there is none).
    """

    name: str
    type: str
    description: str
    json: dict
    required: str = "no"
    default: str = ""
    unit: str = ""
    allowed: tuple = ()
    example: str = ""


@dataclass(frozen=True)
class Table:
    """A table of the file: ``[path]``, ``[[path]]`` (array) or ``[path]`` of named entries (map)."""

    path: str
    form: str  # "table" | "array" | "map"
    description: str
    keys: tuple[Key, ...]
    required: bool = False
    example: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)

    def key(self, name: str) -> Key:
        return next(k for k in self.keys if k.name == name)


def _num(**kw) -> dict:
    return {"type": "number", **kw}


NUMBER_OR_EXPRESSION = {"oneOf": [{"type": "number"}, {"type": "string", "minLength": 1}]}
EXPRESSION_TEXT = (
    "a number, or a string: an expression with + - * / ^ (or **), parentheses, numbers, pi, the "
    "functions " + ", ".join(ALLOWED_FUNCTIONS) + " and the time: tau in a dimensionless scene; t, "
    "in seconds, in an SI scene (tau = omega t may be used there too), where the value is in SI and "
    "converted exactly to the model's (t = tau / omega)"
)
NAME_JSON = {"type": "string", "pattern": NAME_PATTERN, "maxLength": MAX_NAME_LENGTH}

SCENE = Table(
    "scene",
    "table",
    "The scene's name and its unit system.",
    required=True,
    keys=(
        Key(
            "name",
            "string",
            f"Identifier of the scene, used in generated file and C symbol names ({NAME_RULE}).",
            NAME_JSON,
            required="yes",
            example='"slider_crank"',
        ),
        Key(
            "reference_length",
            "number > 0",
            "The reference length l0 that makes lengths dimensionless.",
            _num(exclusiveMinimum=0),
            default="the first elastic bar's length (else the first bar's)",
            unit="m (SI) or the file's length unit",
            example="0.1",
        ),
        Key(
            "omega",
            "number > 0",
            "The reference frequency: tau = omega t. A dimensionless scene is already scaled by it (1.0).",
            _num(exclusiveMinimum=0),
            required='when units = "SI"',
            default="1.0 (dimensionless)",
            unit="rad/s (SI)",
            example="230.0",
        ),
        Key(
            "units",
            "string",
            "Unit system of the file's data. Results of an SI scene are written in SI "
            "(--units dimensionless keeps the model's units).",
            {"enum": list(_ld.UNITS)},
            default='"dimensionless"',
            allowed=_ld.UNITS,
            example='"SI"',
        ),
    ),
    example='[scene]\nname = "four_bar"\nunits = "SI"\nomega = 230.0\nreference_length = 0.1',
)

BODIES = Table(
    "bodies",
    "array",
    "The bars, in any order; each is rigid or elastic.",
    required=True,
    keys=(
        Key(
            "name",
            "string",
            f'The bar\'s name ({NAME_RULE}); "ground" is reserved.',
            NAME_JSON,
            required="yes",
            example='"rod"',
        ),
        Key(
            "length",
            "number > 0",
            "The bar's length l_i.",
            _num(exclusiveMinimum=0),
            required="yes",
            unit="m (SI), else in the file's length unit",
            example="1.0",
        ),
        Key(
            "rigid",
            "boolean",
            "A rigid bar has no deformation unknowns and no elastic keys.",
            {"type": "boolean"},
            default="false",
            example="true",
        ),
        Key(
            "mass_per_length",
            "number > 0",
            "Mass per length (SI: instead of density x area).",
            _num(exclusiveMinimum=0),
            default="1.0 (dimensionless); SI: density x area",
            unit="kg/m (SI), else relative to the reference bar",
            example="1.0",
        ),
        Key(
            "lambda",
            "number > 0",
            "Axial group EA/(m_i l_i^2 omega^2) of this bar (dimensionless scenes).",
            _num(exclusiveMinimum=0),
            required="when axial_modes > 0 (dimensionless); without counts, lambda or mu",
            example="18246.0",
        ),
        Key(
            "mu",
            "number > 0",
            "Bending group EI/(m_i l_i^4 omega^2) of this bar (dimensionless scenes).",
            _num(exclusiveMinimum=0),
            required="when transverse_modes > 0 (dimensionless); without counts, lambda or mu",
            example="0.495",
        ),
        Key(
            "E",
            "number > 0",
            "Young's modulus (SI scenes).",
            _num(exclusiveMinimum=0),
            required="for an elastic bar (SI)",
            unit="Pa",
            example="69e9",
        ),
        Key(
            "area",
            "number > 0",
            "Cross-section area (SI scenes).",
            _num(exclusiveMinimum=0),
            required="when axial_modes > 0 (SI), or with density; without counts, area or inertia",
            unit="m^2",
            example="5e-5",
        ),
        Key(
            "inertia",
            "number > 0",
            "Second moment of area for in-plane bending (SI scenes).",
            _num(exclusiveMinimum=0),
            required="when transverse_modes > 0 (SI); without counts, area or inertia",
            unit="m^4",
            example="4.1667e-10",
        ),
        Key(
            "density",
            "number > 0",
            "Density; the mass per length is density x area (SI scenes).",
            _num(exclusiveMinimum=0),
            required="without mass_per_length (SI)",
            unit="kg/m^3",
            example="2700.0",
        ),
        Key(
            "frame",
            "string",
            'Deformation reference. "pinned-pinned": chord frame, eta(0) = eta(1) = 0, '
            'zeta(0) = 0, the far end free axially ("pinned-sliding" is an alias). "cantilever": tangent frame '
            "clamped at xi = 0.",
            {"enum": list(_me.FRAMES)},
            required="for an elastic bar",
            allowed=_me.FRAMES,
            example='"pinned-pinned"',
        ),
        Key(
            "axial_modes",
            "integer >= 0",
            "Number of axial shape functions (0: axially rigid). With von Karman strain use at least 3. "
            "Absent: chosen from simulation.accuracy (the bar's axial frequencies against the run's fastest "
            "content, and the static truncation of its axial loads; `symgen check`, `symgen effects` and the "
            "sidecar's bases say what and why); raised after a run whose error estimate's truncation part "
            "(`symgen simulate --estimate rerun`, the default) exceeds the accuracy (with transverse_modes, "
            "when neither is given). Given: used as written, with a warning when the a-priori "
            "estimate of the count exceeds simulation.accuracy.",
            {"type": "integer", "minimum": 0},
            default="chosen from simulation.accuracy (0 without lambda, or area in SI)",
            example="3",
        ),
        Key(
            "transverse_modes",
            "integer >= 0",
            "Number of transverse shape functions (0: no bending). Absent: chosen from simulation.accuracy: "
            "the bending modes below the band where a static treatment errs by more than the accuracy are "
            "dynamic, the rest contribute their static shape; functions are added until the static "
            "truncation of the inertia loads and the frequencies of the dynamic modes meet the accuracy; "
            "then the mechanism's coupled modes at its start position add functions where an undeformed "
            "start rings them (their phase over the run, in deflections and driver torques) or their "
            "frequencies miss. Where neither count of the bar is given, a run whose error estimate's truncation "
            "part (a rerun with two more functions of each kind per bar) exceeds the accuracy is made again with "
            "those counts (at most twice; remembered for the scene, said in the sidecar's bases.raised). "
            "Given: used as written, with a warning when the a-priori estimate exceeds the accuracy.",
            {"type": "integer", "minimum": 0},
            default="chosen from simulation.accuracy (0 without mu, or inertia in SI)",
            example="4",
        ),
        Key(
            "axial_shapes",
            "string",
            '"complete" = {xi, sin(k pi xi)} (no locking) or "stress-free" = sin((2k-1) pi xi/2) (the seed\'s).',
            {"enum": list(_me.AXIAL_SHAPES)},
            default='"complete"',
            allowed=_me.AXIAL_SHAPES,
            example='"complete"',
        ),
        Key(
            "transverse_shapes",
            "string",
            '"modes": sines for pinned frames; for cantilevers the clamped-free '
            'eigenfunctions, preceded by the static tip-load shape when a joint acts at the tip. "eigen": '
            'eigenfunctions only (the seed). "polynomial".',
            {"enum": list(_me.TRANSVERSE_SHAPES)},
            default='"modes"',
            allowed=_me.TRANSVERSE_SHAPES,
            example='"modes"',
        ),
        Key(
            "static_correction",
            "boolean",
            "Static correction functions at interior points: for each joint "
            "end, point load, lumped mass or [[masses]] entry at 0 < xi_K < 1 of this bar, its static deflection under a unit "
            "force at xi_K (piecewise cubic transverse, piecewise linear axial when the bar keeps its axial "
            "dynamics), mass-orthogonalised against the bar's other functions, is added after its "
            "transverse_modes (axial_modes) functions: the sines alone converge slowly on the kink a point "
            "force makes. Where a point moment acts too ([[masses]] entry with an inertia or an offset, a joint's "
            "inertia), its static deflection under a unit couple at xi_K follows (transverse, slope 1 at xi_K). "
            "false: the standard functions only (the seed).",
            {"type": "boolean"},
            default="true (adds nothing without interior points)",
            example="false",
        ),
        Key(
            "quasi_static_transverse",
            "integer",
            "How many of the highest of the bar's transverse_modes functions are quasi-static "
            "(residual flexibility): they keep their stiffness and every load on them, the inertia loads of the "
            "rigid motion and of the other functions included, but not their own inertia, so their amplitudes "
            "are algebraic (solved at each instant) and add no eigenvalues for the integrator to follow "
            "(docs/quasi-static-modes.md). Their rates read 0. Refused where such a function moves a joint "
            "(an interior pin of the bar), on a slot's guide with a rigid overhang and with polynomial "
            "transverse_shapes. IDAS and the emitted C solver (--solver c, emit-c, emit-fmu) treat them alike. "
            "A run stops (exit 2, naming this key) where a bar deflects so far that the quasi-static form's mass "
            "turns singular (docs/quasi-static-modes.md, the impasse); lower the count then. Absent on a bar "
            "whose transverse_modes symgen chooses: symgen chooses it from the mechanism's coupled modes where "
            "that saves integration steps within simulation.accuracy; state 0 to keep every function dynamic.",
            {"type": "integer", "minimum": 0},
            default="0 (every function dynamic); chosen by symgen where transverse_modes is absent",
            example="2",
        ),
    ),
    example='[[bodies]]\nname = "rod"\nlength = 1.0\nlambda = 18246.0\nmu = 0.495\nframe = "pinned-pinned"\n'
    "axial_modes = 3\ntransverse_modes = 4",
    notes=(
        "SI scenes give E, area, inertia, density (or mass_per_length); dimensionless scenes give lambda "
        "and mu. The other system's keys are rejected.",
        "A rigid bar takes only name, length, rigid and mass_per_length.",
    ),
)

JOINTS = Table(
    "joints",
    "array",
    "Pins, sliders on ground lines and slots joining two bodies.",
    keys=(
        Key("name", "string", f"The joint's name ({NAME_RULE}).", NAME_JSON, required="yes", example='"A"'),
        Key(
            "kind",
            "string",
            '"pin"; "slider": a bar point on a fixed ground line; "slot": a point of the '
            "first bar sliding along the second (the guide), whose support distance beta(tau) becomes an "
            "unknown.",
            {"enum": list(_me.JOINT_KINDS)},
            required="yes",
            allowed=_me.JOINT_KINDS,
            example='"pin"',
        ),
        Key(
            "bodies",
            "array of 2 strings",
            'The two bodies joined: bar names or "ground".',
            {"type": "array", "items": {"type": "string"}, "minItems": 2, "maxItems": 2},
            required="yes",
            example='["crank", "rod"]',
        ),
        Key(
            "at",
            "array of 2",
            'Per body: a ground point [x, y], or a position xi in [0, 1] along a bar; a slot is [xi, "variable"].',
            {"type": "array", "minItems": 2, "maxItems": 2},
            required="yes",
            unit="ground points: m (SI) or file length unit",
            example="[1.0, 0.0]",
        ),
        Key(
            "direction",
            "array of 2 numbers",
            "Direction of a slider's ground line (sliders only).",
            {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2},
            required="for a slider",
            example="[1.0, 0.0]",
        ),
        Key(
            "mass",
            "number >= 0",
            "Lumped mass at the joint, carried by the first bar listed.",
            _num(minimum=0),
            default="0.0",
            unit="kg (SI), else relative to m_ref l0",
            example="0.25",
        ),
        Key(
            "inertia",
            "number >= 0",
            "Lumped rotary inertia at the joint (a hub, pulley or gear about its own "
            "centre of mass), carried by the first bar listed with the mass: it turns with that bar's cross-section, "
            "theta + eta'(xi) on an elastic bar, theta on a rigid one; in the equations, energy, modes, LaTeX and C.",
            _num(minimum=0),
            default="0.0",
            unit="kg m^2 (SI), else relative to m_ref l0^3",
            example="0.01",
        ),
        Key(
            "overhang",
            "string",
            'Slots only: the guide beyond the contact (xi in [beta, 1]). "elastic": it turns with the '
            "contact's slope (the contact-slope function: the span's static shape under a moment at the contact, "
            "straight beyond) and bends with overhang_modes functions of its own (the powers (xi - beta)^2 .. (xi - beta)^(m+1) made mass-orthogonal, zero value "
            "and slope at the moving contact); the span functions then vanish beyond the contact (zero slope there: "
            "they may be quasi-static), stiffness over span and overhang; the contact must stay short of the far "
            "end (beta < 1). "
            "\"rigid\": it moves with the span's end slope (the seed's form, for its reproduction).",
            {"enum": list(_me.OVERHANG_FORMS)},
            default='"elastic"',
            allowed=_me.OVERHANG_FORMS,
            example='"rigid"',
        ),
        Key(
            "overhang_modes",
            "integer 1 to 5",
            "Slots with an elastic overhang: number of the overhang's own bending "
            "functions, appended after the guide's transverse_modes span functions and the contact-slope function "
            "(an explicit initial g lists the span's sines with their tangent continuation, as for a rigid "
            "overhang; the overhang's own start at zero). 4 give the first three frequencies of a guide whose "
            "overhang is up to six spans within 2.5 % (up to one span within 0.5 %); at most 5 (beyond, the "
            "polynomial functions are nearly dependent).",
            {"type": "integer", "minimum": 1, "maximum": _me.OVERHANG_MODES_MAX},
            default=str(_me.OVERHANG_MODES_DEFAULT),
            example="4",
        ),
    ),
)

DRIVER = Table(
    "driver",
    "table",
    "Optional guidance of a bar pinned to ground: a prescribed angle or an applied moment.",
    keys=(
        Key(
            "kind",
            "string",
            '"angle": theta = initial + rate tau; "torque": an applied moment.',
            {"enum": list(_ex.DRIVER_KINDS)},
            required="yes",
            allowed=_ex.DRIVER_KINDS,
            example='"angle"',
        ),
        Key("body", "string", "The driven bar (pinned to ground).", NAME_JSON, required="yes", example='"crank"'),
        Key(
            "initial",
            "number",
            "Initial angle (torque drivers: the start angle; default from the assembly).",
            _num(),
            default="0.0 (angle driver)",
            unit="rad",
            example="0.0",
        ),
        Key(
            "rate",
            "number",
            "d theta / d tau (angle drivers; torque drivers: the initial angular velocity). "
            "In an SI scene the crank turns at rate x omega rad/s.",
            _num(),
            required="for an angle driver",
            default="0.0 (torque driver)",
            unit="per tau",
            example="1.0",
        ),
        Key(
            "law",
            "string (expression)",
            "Prescribed angle theta - initial as an expression of the time (angle "
            "drivers, instead of rate; the run needs t_end, or duration): " + EXPRESSION_TEXT + ". theta' and "
            "theta'' are its exact derivatives.",
            {"type": "string", "minLength": 1},
            unit="rad; of tau, or (SI scene) of t in s",
            example='"0.5*sin(tau)" (SI: "0.5*sin(30*t)")',
        ),
        Key(
            "ramp",
            "number > 0",
            "Spin-up time T of a constant-speed drive (with rate): theta = (rate/T)(tau^2/2 + "
            "(T/2 pi)^2 (cos(2 pi tau/T) - 1)) for tau < T, rate (tau - T/2) after (Kane, Ryan & Banerjee 1987).",
            _num(exclusiveMinimum=0),
            unit="tau",
            example="15.0",
        ),
        Key(
            "value",
            "number or expression",
            "The applied moment (torque drivers): " + EXPRESSION_TEXT + ".",
            NUMBER_OR_EXPRESSION,
            required="for a torque driver",
            unit="N m (SI; an expression of t in s), else m_ref l0^3 omega^2",
            example='"0.5*Heaviside(tau - 1)" (SI: "4.0*tanh(t/0.1)")',
        ),
        Key(
            "rotor_inertia",
            "number >= 0",
            "Inertia of the motor rotor, gears or flywheel reflected to the driven "
            "bar's shaft; turns with the bar's angle theta. Adds J theta'' to the driven bar's moment equation and "
            "J theta'^2 / 2 to the kinetic energy; for an angle driver the reported driver torque is the motor's "
            "(rotor inertia included).",
            _num(minimum=0),
            default="0.0",
            unit="kg m^2 (SI), else relative to m_ref l0^3",
            example="0.02",
        ),
    ),
    example='[driver]\nkind = "angle"\nbody = "crank"\ninitial = 0.0\nrate = 1.0',
)

DRIVERS = Table(
    "drivers",
    "array",
    "Optional: several drivers (a five-bar's two cranks, a two-arm robot); each [[drivers]] table takes "
    "exactly the keys of [driver] and drives a distinct bar pinned to ground. Angle and torque drivers "
    "mix; degrees of freedom left undriven move freely. Give either [driver] or [[drivers]], not both. "
    "With several angle drivers, a driver_torque output names its driven bar (body), and "
    "simulation.cycles counts the turns of the first angle driver that turns at a constant rate "
    "(no law, rate != 0). Each torque driver whose value is a number is a real input of the FMU.",
    keys=DRIVER.keys,
    example='[[drivers]]\nkind = "angle"\nbody = "crank_a"\nrate = 1.0\n\n'
    '[[drivers]]\nkind = "angle"\nbody = "crank_b"\ninitial = 1.5707963267948966\nrate = -1.0',
)

INITIAL = Table(
    "initial",
    "table",
    "Optional start: default the rigid assembly at tau = 0, undeformed.",
    keys=(
        Key(
            "guess",
            "table",
            "Rigid angles (rad) to start the assembly of closed loops, by bar name; a "
            "slot joint's name gives its beta.",
            {"type": "object", "additionalProperties": {"type": "number"}},
            example="{ coupler = 1.2, rocker = 1.9 }",
        ),
        Key(
            "deformation",
            "string or table",
            '"quasi-static" starts on the quasi-static deformation (no '
            "start-up ringing); or per bar { f = [...], g = [...], fdot = [...], gdot = [...] } amplitudes.",
            {"oneOf": [{"const": "quasi-static"}, {"type": "object"}]},
            default="undeformed, at rest",
            example='"quasi-static"',
        ),
    ),
)

EFFECTS = Table(
    "effects",
    "table",
    "Which physics is generated: a switched-off effect is never derived.",
    keys=(
        Key(
            "axial",
            "boolean or string",
            'Axial deformation, chosen per elastic bar. "auto" (the default): '
            "with von Karman strain, a bar whose first axial frequency (pi/2) sqrt(lambda) is at least 10 times "
            "the fastest motion the run must resolve (twice its first bending frequency, 4 times the driver "
            "rate), and whose stretch is at most 1e-4 of a closed loop's compliance (against the bending of "
            "the softest other bar: the quasi-static stretch is not fed back into the loop), and whose axial "
            "ringing from a start that is not quasi-static (the jump to the start's quasi-static stretch, "
            "against the peaks of the outputs that read deflections, positions and angles, less what damping "
            "takes over the run) is within simulation.accuracy, is quasi-static, "
            "else dynamic; after a run with quasi-static bars (complete, or stopped early: judged up to the stop), "
            "the run's own axial estimate decides again (the free motion's phase drift from the stretch's inertia, the start's axial ringing "
            "measured by a window run with the axial dynamics kept, force outputs included, and the stretch's own "
            "inertia, its centrifugal load on a spinning bar included): above "
            "simulation.accuracy the run is made again with the axial dynamics kept, and the decision is "
            "remembered for the scene; where that is the start's ringing alone and Kelvin-Voigt damping ends it "
            "within the first half of the run, only until then (every output within a tenth of the accuracy of "
            "the run that keeps them, measured by a window run), the run continued quasi-static from the state "
            "reached (the sidecar's axial_switch; the emitted C solver keeps them for the whole run); "
            'with the seed\'s linear strain, dynamic. "dynamic" (= true): '
            "axial amplitudes with inertia and the strain energy lambda/2 ||P eps||^2 of the strain the axial "
            'basis can carry (no locking at any lambda). "quasi_static": no axial vibration: the axial '
            "amplitudes follow the bending through (phi'_k, eps) = 0, the axial force N is its multiplier, and "
            "outputs that read the bar's shape (axial, chord_elongation, ...) add the stretch N/lambda; costs "
            "what the inextensible model costs. "
            '"inextensible": the lambda -> infinity limit (no stretch). false: no axial deformation (drops the '
            "axial force too). The JSON sidecar (axial_treatment) and `symgen effects` say what each bar got "
            "and why.",
            {"oneOf": [{"type": "boolean"}, {"enum": list(_ex.AXIAL_MODELS)}]},
            default='"auto"',
            allowed=(True, False) + _ex.AXIAL_MODELS,
            example='"quasi_static"',
        ),
        Key("transverse", "boolean", "Bending.", {"type": "boolean"}, default="true", example="true"),
        Key(
            "geometric_stiffening",
            "boolean",
            "The axial force's stiffening of bending, lambda (zeta' eta')'.",
            {"type": "boolean"},
            default="true",
            example="true",
        ),
        Key(
            "coriolis",
            "boolean",
            "Coriolis inertia of each bar's own mass.",
            {"type": "boolean"},
            default="true",
            example="true",
        ),
        Key(
            "rotary_inertia",
            "boolean",
            "Rotary inertia of the cross-sections (needs lambda).",
            {"type": "boolean"},
            default="false",
            example="false",
        ),
        Key(
            "strain",
            "string",
            '"auto" (the default): von Karman, or the exact bar where a run\'s model-form estimate of von '
            "Karman (the curvature and strain terms it leaves out) exceeds simulation.accuracy on an output (a "
            "run stopped early is judged up to the stop): symgen simulate then runs the scene again with the exact bar, remembers the decision for the scene, and "
            "the sidecar (strain) says which and why; later runs, check, effects and latex use the decision a run "
            "remembered, derive and emit-c von Karman (scenes "
            'with a slot joint or geometric_stiffening = false keep it). "von_karman" (energy-consistent: '
            'bending shortens the chord), "exact" (von Karman strain '
            "and the exact curvature of the bar's axis to sixth order in the amplitudes: the geometrically "
            "exact beam's answer at large deflection; needs geometric_stiffening, no slot joints) or "
            '"linear" (the seed\'s).',
            {"enum": list(_ex.STRAINS)},
            default='"auto"',
            allowed=_ex.STRAINS,
            example='"von_karman"',
        ),
        Key(
            "gravity",
            "array of 2 numbers",
            "Gravity in ground axes.",
            {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2},
            default="[0.0, 0.0]",
            unit="m/s^2 (SI), else g/(l0 omega^2)",
            example="[0.0, -9.81]",
        ),
        Key(
            "damping",
            "number >= 0",
            "Kelvin-Voigt ratio on the strain rates.",
            _num(minimum=0),
            default="0.0",
            unit="1/omega",
            example="0.002",
        ),
    ),
)

LOADS = Table(
    "loads",
    "array",
    "Optional point or distributed loads on bars, in the bar's axes.",
    keys=(
        Key("body", "string", "The loaded bar.", NAME_JSON, required="yes", example='"rod"'),
        Key(
            "kind",
            "string",
            '"distributed" or "point".',
            {"enum": list(_ex.LOAD_KINDS)},
            required="yes",
            allowed=_ex.LOAD_KINDS,
            example='"distributed"',
        ),
        Key(
            "at",
            "number in [0, 1]",
            "Position xi of a point load along the bar.",
            _num(minimum=0, maximum=1),
            required="for a point load",
            example="0.5",
        ),
        Key(
            "axial",
            "number or expression",
            "Axial component: " + EXPRESSION_TEXT + ".",
            NUMBER_OR_EXPRESSION,
            default="0.0",
            unit="SI: N/m (distributed) or N (point), an expression of t in s; else q/(m_i l_i omega^2), "
            "F/(m_i l_i^2 omega^2)",
            example="0.0",
        ),
        Key(
            "transverse",
            "number or expression",
            "Transverse component (see axial).",
            NUMBER_OR_EXPRESSION,
            default="0.0",
            unit="as axial",
            example='"0.1*sin(2*tau)"',
        ),
    ),
)

MASSES = Table(
    "masses",
    "array",
    "Optional point masses and rigid attachments anywhere on a bar (a tool partway along a coupler). Each "
    "is carried by its bar: its inertia and weight enter that bar's equations (mass matrix, velocity terms, "
    "gravity) like a joint's lumped mass, with a static correction function at an interior xi "
    "(bodies.<name>.static_correction; with an inertia or an offset also a unit couple's), and it appears in the energy, modes, LaTeX, the emitted C, the FMU "
    "and the animation.",
    keys=(
        Key(
            "body",
            "string",
            "The bar that carries the mass (not a slot's guide).",
            NAME_JSON,
            required="yes",
            example='"coupler"',
        ),
        Key(
            "at",
            "number in [0, 1]",
            "Position xi along the bar of the point the mass is attached at.",
            _num(minimum=0, maximum=1),
            required="yes",
            example="0.4",
        ),
        Key(
            "mass",
            "number >= 0",
            "The point mass.",
            _num(minimum=0),
            required="yes",
            unit="kg (SI), else relative to m_ref l0",
            example="0.5",
        ),
        Key(
            "inertia",
            "number >= 0",
            "Rotary inertia about the mass's own centre: it turns with the bar's cross-section at xi, "
            "theta + eta'(xi) on an elastic bar, theta on a rigid one.",
            _num(minimum=0),
            default="0.0",
            unit="kg m^2 (SI), else relative to m_ref l0^3",
            example="0.002",
        ),
        Key(
            "offset",
            "array of 2 numbers",
            "[along, across]: the mass's centre from the bar's axis at xi, in the axes of the cross-section "
            "there (along the bar, and 90 degrees counter-clockwise from it): a rigid attachment that turns "
            "with the cross-section. Absent: the mass sits on the axis.",
            {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2},
            default="[0.0, 0.0]",
            unit="m (SI), else the file's length unit",
            example="[0.0, 0.05]",
        ),
    ),
    example='[[masses]]\nbody = "coupler"\nat = 0.4\nmass = 0.5\ninertia = 0.002\noffset = [0.0, 0.05]',
)

_OUTPUT_KEYS = sorted({k for keys in _ou.KIND_KEYS.values() for k in keys})
OUTPUT_KIND_TEXT = {
    "chord_deflection": "deflection of the point xi from the chord between the bar's ends / bar length",
    "chord_elongation": "(|chord| - length) / length",
    "deflection": "eta(xi) in the bar's own frame",
    "axial": "zeta(xi) in the bar's own frame",
    "slope": "eta'(xi): the elastic rotation",
    "elastic_displacement": "ground-axes x or y of a bar point from its rigid-frame position / l0",
    "position": "absolute x or y of a bar point / l0",
    "angle": "theta of a bar",
    "reaction": "force of the joint's first body on the second, ground axes",
    "driver_torque": "the moment the angle driver applies (body: the driven bar, required with several angle drivers)",
    "energy": "kinetic (rotary inertias included) + elastic + potential energy",
    "closure_residual": "max |position closure| (a solver check)",
}


def _kind_keys_text(kind: str) -> str:
    """The keys an output kind takes, its optional ones marked."""
    keys = [*_ou.KIND_KEYS[kind], *(f"optional {k}" for k in _ou.OPTIONAL_KEYS.get(kind, ()))]
    return ", ".join(keys) or "no other keys"


OUTPUTS = Table(
    "outputs",
    "map",
    "Named signals written as columns, in this order after the time column. Each kind takes exactly the keys it needs.",
    required=True,
    keys=(
        Key(
            "kind",
            "string",
            "What is measured (see the kinds below).",
            {"enum": list(OUTPUT_KINDS)},
            required="yes",
            allowed=OUTPUT_KINDS,
            example='"chord_deflection"',
        ),
        Key(
            "body",
            "string",
            "The measured bar (elastic for deformation kinds; for driver_torque the driven bar).",
            NAME_JSON,
            required="by the kind",
            example='"rod"',
        ),
        Key(
            "at",
            "number in [0, 1]",
            "Position xi along the bar.",
            _num(minimum=0, maximum=1),
            required="by the kind",
            example="0.5",
        ),
        Key(
            "component",
            "string",
            "Ground-axes component.",
            {"enum": list(_ou.COMPONENTS)},
            required="by the kind",
            allowed=_ou.COMPONENTS,
            example='"x"',
        ),
        Key("joint", "string", "The joint of a reaction.", NAME_JSON, required="by the kind", example='"A"'),
    ),
    example='[outputs]\neta_mid = { kind = "chord_deflection", body = "rod", at = 0.5 }\n'
    'eps_ax = { kind = "chord_elongation", body = "rod" }',
    notes=(
        *(f"`{k}` ({_kind_keys_text(k)}): {OUTPUT_KIND_TEXT[k]}" for k in OUTPUT_KINDS),
        "the values above are the model's (dimensionless); an SI scene's columns are each that value times one "
        "factor (symgen/numerics/units.py; the sidecar's `units` states each column's unit and factor): lengths "
        "per bar length times l_i, those per l0 times l0, in m (so chord_elongation is |chord| - length in m), "
        "forces in N, moments in N m, energy in J, angles in rad; `--units dimensionless` writes them as listed",
    ),
)

SIMULATION = Table(
    "simulation",
    "table",
    "The run: its length, output grid and solver tolerances.",
    required=True,
    keys=(
        Key(
            "t_end",
            "number > 0",
            "End time (exactly one of t_end, cycles and duration).",
            _num(exclusiveMinimum=0),
            required="t_end, cycles or duration",
            unit="tau = omega t (both unit systems)",
            example="12.566370614359172",
        ),
        Key(
            "cycles",
            "number > 0",
            "Crank turns to run (angle drivers; with several, the turns of the first angle driver "
            "turning at a constant rate; else 2 pi per cycle).",
            _num(exclusiveMinimum=0),
            required="t_end, cycles or duration",
            example="2",
        ),
        Key(
            "output_step",
            "number > 0",
            "Step of the output grid.",
            _num(exclusiveMinimum=0),
            default=f"{_ld.DEFAULT_OUTPUT_STEP!r} (1 degree of a unit-rate crank)",
            unit="tau",
            example="0.017453292519943295",
        ),
        Key(
            "duration",
            "number > 0",
            "Length of the run in seconds (SI scenes only; exactly one of t_end, cycles and duration): "
            "t_end = duration x omega.",
            _num(exclusiveMinimum=0),
            required="t_end, cycles or duration",
            unit="s",
            example="0.5",
        ),
        Key(
            "output_interval",
            "number > 0",
            "Step of the output grid in seconds (SI scenes only; instead of output_step): "
            "output_step = output_interval x omega.",
            _num(exclusiveMinimum=0),
            default="output_step's",
            unit="s",
            example="0.001",
        ),
        Key(
            "rtol",
            "number > 0",
            "Relative tolerance of the integrator. A scene that states neither rtol nor atol takes both "
            "from simulation.accuracy, by the rule of the solver that runs it (IDAS, or the emitted C "
            "solver of --solver c): a time-integration error well below the accuracy. A scene that "
            "states one of them keeps the other's fixed default (rtol "
            f"{_ld.FIXED_RTOL:g}, atol {_ld.FIXED_ATOL:g}). `symgen check` and the run's sidecar "
            "(solver.rtol, solver.tolerances) say which were used and why.",
            _num(exclusiveMinimum=0),
            default=_tolerance_default("rtol"),
            example="1e-8",
        ),
        Key(
            "atol",
            "number > 0",
            "Absolute tolerance of the integrator, in the model's units (coordinates in units of a "
            "bar's length, angles in rad; the elastic amplitudes of metal bars at speed are 1e-5 to "
            "1e-3): from simulation.accuracy with rtol when the scene states neither (see rtol).",
            _num(exclusiveMinimum=0),
            default=_tolerance_default("atol"),
            example="1e-10",
        ),
        Key(
            "accuracy",
            "number, 0 < accuracy < 1",
            "The accuracy asked of every output, as a fraction of its peak over the run. It chooses the "
            "shape-function counts that a bar does not state (bodies.<name>.axial_modes, transverse_modes) "
            "and is the threshold of the warning on stated counts; when the scene states neither "
            "rtol nor atol, it sets them too (see rtol).",
            _num(exclusiveMinimum=0, exclusiveMaximum=1),
            default="0.01",
            example="0.001",
        ),
    ),
    example="[simulation]\ncycles = 2\noutput_step = 0.017453292519943295\nrtol = 1e-8",
)

TABLES = (SCENE, BODIES, JOINTS, DRIVER, DRIVERS, INITIAL, EFFECTS, LOADS, MASSES, OUTPUTS, SIMULATION)

#: The loader's accepted keys per table (its own constants): the schema must describe exactly these.
LOADER_KEYS = {
    "": tuple(_ld.TOP_KEYS),
    "scene": tuple(_ld.SCENE_KEYS),
    "bodies": tuple(dict.fromkeys(_me.BODY_KEYS_DIMLESS + _me.BODY_KEYS_SI)),
    "joints": tuple(_me.JOINT_KEYS),
    "driver": tuple(_ex.DRIVER_KEYS),
    "drivers": tuple(_ex.DRIVER_KEYS),
    "initial": tuple(_ex.INITIAL_KEYS),
    "effects": tuple(_ex.EFFECT_KEYS),
    "loads": tuple(_ex.LOAD_KEYS),
    "masses": tuple(_ma.MASS_KEYS),
    "outputs": ("kind", *_OUTPUT_KEYS),
    "simulation": tuple(_ld.SIMULATION_KEYS),
}


def table(path: str) -> Table:
    return next(t for t in TABLES if t.path == path)


# --------------------------------------------------------------------------- markdown
def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def markdown() -> str:
    """The scene reference (``docs/scene-format.md``), rendered from :data:`TABLES`."""
    out = [
        "# Scene files: the reference",
        "",
        "<!-- Generated from symgen/scene/schema.py by `symgen schema --markdown docs/scene-format.md`; "
        "do not edit (tests/scene/test_schema.py compares). -->",
        "",
        "A scene file is TOML. This page lists every table and key symgen accepts: the contract's keys "
        "and the project's additions. Anything else is rejected with a message naming the file and the "
        "key. `--set KEY=VALUE` overrides any value by its dotted path, bodies and joints by name "
        "(`--set bodies.rod.transverse_modes=3`). A JSON Schema for editors: `symgen schema -o "
        "scene.schema.json`.",
        "",
        "Tables: " + ", ".join(f"[`{t.path}`](#{t.path})" for t in TABLES) + ".",
        "",
    ]
    for t in TABLES:
        head = {"table": f"[{t.path}]", "array": f"[[{t.path}]]", "map": f"[{t.path}]"}[t.form]
        out += [f"## {t.path}", "", f"`{head}`{' (required)' if t.required else ' (optional)'}: {t.description}"]
        if t.form == "array":
            out.append("An array of tables: one `[[" + t.path + "]]` block per entry.")
        if t.form == "map":
            out.append('A table of named entries: `NAME = { kind = "...", ... }`, NAME a C identifier.')
        out += [
            "",
            "| key | type | required | default | unit | allowed | meaning | example |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for k in t.keys:
            allowed = ", ".join(f"`{a!r}`" if isinstance(a, bool) else f'`"{a}"`' for a in k.allowed)
            out.append(
                "| "
                + " | ".join(
                    _cell(x)
                    for x in (
                        f"`{k.name}`",
                        k.type,
                        k.required,
                        k.default,
                        k.unit,
                        allowed,
                        k.description,
                        f"`{k.example}`" if k.example else "",
                    )
                )
                + " |"
            )
        out.append("")
        for note in t.notes:
            out.append(f"* {note}")
        if t.notes:
            out.append("")
        if t.example:
            out += ["```toml", t.example, "```", ""]
    return "\n".join(out).rstrip() + "\n"


# --------------------------------------------------------------------------- JSON Schema
def _object(t: Table) -> dict:
    props = {k.name: {**k.json, "description": k.description} for k in t.keys}
    required = [k.name for k in t.keys if k.required == "yes"]
    obj = {"type": "object", "description": t.description, "properties": props, "additionalProperties": False}
    if required:
        obj["required"] = required
    return obj


def json_schema() -> dict:
    """A JSON Schema (draft 2020-12) of scene files, for editors (TOML language servers such as
    Taplo and Even Better TOML accept it). The loader checks more than it can say (cross-key
    rules, units, names that exist); the schema catches spelling, types and ranges as you type."""
    props = {}
    for t in TABLES:
        obj = _object(t)
        if t.form == "array":
            props[t.path] = {"type": "array", "items": obj, "description": t.description}
        elif t.form == "map":
            props[t.path] = {
                "type": "object",
                "description": t.description,
                "propertyNames": {"pattern": NAME_PATTERN},
                "additionalProperties": obj,
            }
        else:
            props[t.path] = obj
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://symgen.invalid/scene.schema.json",
        "title": "symgen scene file",
        "type": "object",
        "properties": props,
        "required": [t.path for t in TABLES if t.required],
        "additionalProperties": False,
    }
