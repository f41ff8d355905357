"""The axial response by default (issue 8): ``effects.axial = "auto"`` picks per bar.

* A bar whose first axial frequency (pi/2) sqrt(lambda) is >= 10 x the fastest motion the run
  must resolve (2 x its first bending frequency, 4 x the driver rate), and whose stretch is a
  negligible share (<= 1e-4) of a closed loop's compliance, is **quasi-static**: the
  inextensible constraint form (no axial vibration, the axial force N its multiplier), with the
  stretch N / lambda added where outputs read the bar's shape. It costs what the inextensible
  model costs at any lambda.
* Otherwise **dynamic**: axial amplitudes with inertia and the strain energy of the strain the
  basis can carry, lambda/2 ||P eps||^2 (no locking: tests/test_hard_cases.py).

Oracles: the stretch of a bar spinning at constant rate, 1/(3 lambda) (closed form: the
centrifugal axial force (1 - xi^2)/2 over the axial stiffness); the converged full-dynamics model
(6 axial + 8 transverse functions, tight tolerance) of the same slider-crank for the midspan
deflection, the quantity the issue measures; and, where the full model is too stiff to run, its
lambda -> oo limit with many functions (inextensible 6 + 8), which differs from it by O(1/lambda).
"""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from symgen.api import simulate_scene
from symgen.cli import main
from symgen.scene import load_scene
from symgen.model.structure import AXIAL_SEPARATION, axial_treatments
from tests.oracles import write_scene

SLIDER = "examples/slider_crank.toml"
FOUR_BAR = "examples/four_bar.toml"
ACCURATE = [
    "effects.strain=von_karman",
    "bodies.rod.axial_shapes=complete",  # the accurate defaults
    "bodies.rod.axial_modes=3",
    "bodies.rod.transverse_modes=4",
]

SPINNING = """
[scene]
name = "spinning_bar"
[[bodies]]
name = "bar"
length = 1.0
lambda = {lam}
mu = 1.0
frame = "cantilever"
axial_modes = 3
transverse_modes = 2
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "angle"
body = "bar"
initial = 0.0
rate = 1.0
[effects]
axial = "{axial}"
[outputs]
stretch = {{ kind = "chord_elongation", body = "bar" }}
zeta_tip = {{ kind = "axial", body = "bar", at = 1.0 }}
[simulation]
cycles = 0.25
output_step = 0.05
"""


def _four_bar_lambda_times(scale: float) -> list[str]:
    """Overrides that multiply every bar's lambda = E / (rho l^2 omega^2) by ``scale`` and keep
    mu = E I / (rho A l^4 omega^2): E x scale, I / scale (the four-bar is an SI scene)."""
    with open(FOUR_BAR, "rb") as fh:
        raw = tomllib.load(fh)
    over = []
    for b in raw["bodies"]:
        if "E" in b:
            over += [f"bodies.{b['name']}.E={b['E'] * scale!r}", f"bodies.{b['name']}.inertia={b['inertia'] / scale!r}"]
    return over


def _peak_error(y: np.ndarray, ref: np.ndarray) -> float:
    return float(np.abs(y - ref).max() / np.abs(ref).max())


# --------------------------------------------------------------------------- the choice
def test_auto_picks_per_bar_from_the_frequencies_and_says_why():
    seed = load_scene(SLIDER)  # the paper's linear strain: its model
    t = axial_treatments(seed)["rod"]
    assert t.treatment == "dynamic" and "linear strain" in t.reason
    for lam, want in ((1e3, "dynamic"), (1e5, "quasi_static"), (1e10, "quasi_static")):
        sc = load_scene(SLIDER, ACCURATE + [f"bodies.rod.lambda={lam:g}"])
        t = axial_treatments(sc)["rod"]
        assert t.treatment == want, (lam, t)
        assert (t.omega_axial / t.omega_run >= AXIAL_SEPARATION) == (want == "quasi_static")
        assert f"{t.omega_axial:.4g}" in t.reason and "auto" in t.reason
    # in a closed loop of bending bars the stretch strains the loop: quasi-static only when its
    # share of the loop's compliance is negligible (the quasi-static stretch is not in the kinematics)
    t = axial_treatments(load_scene(FOUR_BAR, _four_bar_lambda_times(10.0)))["coupler"]
    assert t.treatment == "dynamic" and "closed loop" in t.reason
    assert axial_treatments(load_scene(FOUR_BAR, _four_bar_lambda_times(100.0)))["coupler"].treatment == "quasi_static"
    steel = load_scene("benchmarks/scenes/four_bar_steel.toml")
    assert {t.treatment for t in axial_treatments(steel).values()} == {"dynamic"}
    # written values mean what they say, for every bar
    for value, want in (
        ("true", "dynamic"),
        ('"dynamic"', "dynamic"),
        ('"quasi_static"', "quasi_static"),
        ('"inextensible"', "inextensible"),
        ("false", "off"),
    ):
        sc = load_scene(FOUR_BAR, [f"effects.axial={value}"])
        assert {t.treatment for t in axial_treatments(sc).values()} == {want}, value


def test_bad_axial_value_names_the_key(tmp_path, capsys):
    assert main(["check", SLIDER, "--set", 'effects.axial="stiff"']) == 2
    err = capsys.readouterr().err
    assert "effects.axial" in err and "auto" in err and "quasi_static" in err


# --------------------------------------------------------------------------- the stretch
@pytest.mark.parametrize("lam", [1e4, 1e8])
def test_quasi_static_stretch_of_a_spinning_bar_is_the_closed_form(tmp_path, lam):
    """A bar spinning at the constant rate 1 carries the centrifugal axial force (1 - xi^2)/2;
    its elongation is the integral of N / lambda: 1/(3 lambda) at every instant (no axial
    ringing: quasi-static). The inextensible model reads 0 there (so the test can fail)."""
    path = write_scene(tmp_path / "qs.toml", SPINNING.format(lam=lam, axial="quasi_static"))
    res = simulate_scene(path)
    stretch = res.column("stretch")
    np.testing.assert_allclose(stretch[1:], 1.0 / (3.0 * lam), rtol=1e-6)
    np.testing.assert_allclose(res.column("zeta_tip")[1:], 1.0 / (3.0 * lam), rtol=1e-6)
    inext = simulate_scene(write_scene(tmp_path / "in.toml", SPINNING.format(lam=lam, axial="inextensible")))
    assert np.abs(inext.column("stretch")).max() < 1e-3 / lam


def test_dynamic_stretch_rings_about_the_quasi_static_one(tmp_path):
    """The full dynamics started undeformed ring about the same stretch: their time mean is
    1/(3 lambda) within a few per cent (an independent route to the same number)."""
    lam = 1e3
    path = write_scene(tmp_path / "dyn.toml", SPINNING.format(lam=lam, axial="dynamic"))
    res = simulate_scene(path, ["simulation.output_step=0.002", "simulation.cycles=0.5"])
    mean = float(np.mean(res.column("stretch")[len(res.tau) // 4 :]))
    assert abs(mean * 3 * lam - 1) < 0.05


# --------------------------------------------------------------------------- accuracy and cost
def _slider(lam: float, extra: list[str]):
    return simulate_scene(
        SLIDER,
        ACCURATE
        + [f"bodies.rod.lambda={lam:g}", "simulation.cycles=0.5", "simulation.rtol=1e-8", "simulation.atol=1e-10"]
        + extra,
    )


#: the stiff bar's runs start on their quasi-static deformation: the quasi-static choice is about
#: the axial frequency against the motion; an undeformed start rings the axial mode, which the run
#: then resolves (test_an_undeformed_undamped_start_keeps_the_axial_dynamics_for_its_ringing)
QUASI_STATIC_START = 'initial.deformation="quasi-static"'


@pytest.mark.parametrize("lam", [1e3, 1e5])
def test_default_slider_crank_within_one_percent_of_the_converged_model(lam):
    """Default effects (auto) and function counts (3 + 4) against the converged full-dynamics
    6 + 8 model at the same lambda: midspan deflection within 1 % of its peak over half a turn.
    At lambda = 1e5 (every run started on its quasi-static deformation) auto is quasi-static and
    costs what the inextensible model costs."""
    start = [QUASI_STATIC_START] if lam >= 1e5 else []
    ref = _slider(
        lam,
        start
        + [
            "effects.axial=true",
            "bodies.rod.axial_modes=6",
            "bodies.rod.transverse_modes=8",
            "simulation.rtol=1e-10",
            "simulation.atol=1e-12",
        ],
    )
    auto = _slider(lam, start)
    err = _peak_error(auto.column("eta_mid"), ref.column("eta_mid"))
    assert err < 1e-2, err
    if lam >= 1e5:
        assert axial_treatments(load_scene(SLIDER, ACCURATE + [f"bodies.rod.lambda={lam:g}"]))["rod"].treatment == (
            "quasi_static"
        )
        inext = _slider(lam, start + ["effects.axial=inextensible"])
        assert auto.steps <= 2 * inext.steps
        assert auto.steps < ref.steps / 20


def test_an_undeformed_undamped_start_keeps_the_axial_dynamics_for_its_ringing():
    """The stiff slider-crank (lambda = 1e5, quasi-static by the frequencies) started undeformed at
    full speed, undamped: the rod rings axially for the whole run, and the driver torque reads the
    ringing through the crank (0.75 of its peak between the quasi-static and the dynamic rod). The
    run's axial estimate sees the ringing, so auto keeps the rod's axial dynamics and says why;
    the run is then the dynamic-axial model's: its torque within 0.5 % of its peak of the oracle,
    the dynamic-axial run (effects.axial = "dynamic") at tolerances 100x tighter; the quasi-static
    rod's torque is off that oracle by more than the scene's accuracy (0.07)."""
    from symgen.numerics.strain_choice import resolved

    stiff = ACCURATE + ["bodies.rod.lambda=1e5", "simulation.cycles=0.5"]
    scene = load_scene(SLIDER, stiff)
    assert axial_treatments(scene)["rod"].treatment == "quasi_static" and not scene.initial.quasi_static
    assert scene.effects.damping == 0
    auto = simulate_scene(SLIDER, stiff)
    kept = dict(resolved(load_scene(SLIDER, stiff)).axial_kept)
    assert "the start's axial ringing" in kept["rod"] and "on torque" in kept["rod"], kept
    assert 'initial.deformation = "quasi-static"' in kept["rod"]
    sim = scene.simulation
    oracle = simulate_scene(
        SLIDER,
        stiff + ["effects.axial=dynamic", f"simulation.rtol={sim.rtol / 100:g}", f"simulation.atol={sim.atol / 100:g}"],
    )
    quasi = simulate_scene(SLIDER, stiff + ["effects.axial=quasi_static"])
    assert _peak_error(auto.column("torque"), oracle.column("torque")) < 5e-3
    assert _peak_error(quasi.column("torque"), oracle.column("torque")) > sim.accuracy
    assert _peak_error(auto.column("eta_mid"), oracle.column("eta_mid")) < 1e-3


def test_stiff_four_bar_default_is_quasi_static_and_within_one_percent():
    """The aluminium four-bar with bars 100x stiffer axially (lambda ~ 5e6 / 5e5 / 8e5): auto
    eliminates every bar's axial dynamics; against the inextensible 4 + 6 model (the lambda -> oo
    limit with more bending functions: O(1/lambda) = 1e-6 from the full model) the couplers'
    and rocker's deflections are within 1 % of their peaks over a fifth of a turn."""
    base = load_scene(FOUR_BAR)
    stiff = _four_bar_lambda_times(100.0)
    stiff_scene = load_scene(FOUR_BAR, stiff)
    for b, b0 in zip(stiff_scene.bodies, base.bodies):
        if not b.rigid:
            assert b.lam == pytest.approx(100 * b0.lam) and b.mu == pytest.approx(b0.mu)
    assert {t.treatment for t in axial_treatments(stiff_scene).values()} == {"quasi_static"}
    window = ["simulation.cycles=0.2"]
    auto = simulate_scene(FOUR_BAR, stiff + window)
    ref = simulate_scene(
        FOUR_BAR,
        stiff
        + window
        + ["effects.axial=inextensible"]
        + [f"bodies.{b}.transverse_modes=6" for b in ("crank", "coupler", "rocker")],
    )
    for name in auto.output_names:
        if name.startswith(("coupler", "rocker", "crank")) and np.abs(ref.column(name)).max() > 1e-9:
            assert _peak_error(auto.column(name), ref.column(name)) < 1e-2, name


def test_sidecar_and_effects_say_which_treatment_each_bar_got(tmp_path, capsys):
    out = tmp_path / "sc.csv"
    assert (
        main(
            [
                "simulate",
                SLIDER,
                "-o",
                str(out),
                "--set",
                "simulation.cycles=0.02",
                *sum((["--set", o] for o in ACCURATE + ["bodies.rod.lambda=1e6", QUASI_STATIC_START]), []),
            ]
        )
        == 0
    )
    meta = json.loads(out.with_suffix(".json").read_text())
    rod = meta["axial_treatment"]["rod"]
    assert rod["treatment"] == "quasi_static" and "eliminated" in rod["reason"]
    capsys.readouterr()
    assert main(["effects", SLIDER, *sum((["--set", o] for o in ACCURATE + ["bodies.rod.lambda=1e6"]), [])]) == 0
    text = capsys.readouterr().out
    assert "axial treatment of rod: quasi_static" in text and "axial dynamics eliminated" in text


# --------------------------------------------------------------------------- the full sweep
SWEEP = [1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10]


@pytest.mark.slow
def test_lambda_sweep_slider_crank_default_within_one_percent():
    """lambda 1e3 ... 1e10 (mu fixed), default effects and functions, one turn (from lambda = 1e5,
    where the step bound applies, every run started on its quasi-static deformation: no axial
    ringing to resolve; at 1e4, quasi-static by the frequencies too, the undeformed start's
    ringing keeps the axial dynamics): every run within
    1 % of the converged reference (full dynamics 6 + 8 up to lambda = 1e6; beyond, the
    inextensible 6 + 8 model, O(1/lambda) from it); IDAS steps per turn at lambda >= 1e5 at most 2x
    those of the inextensible model; lambda = 1e10 in seconds."""
    import time

    rows = []
    for lam in SWEEP:
        base = (
            ACCURATE
            + [f"bodies.rod.lambda={lam:g}", "simulation.cycles=1"]
            + ([QUASI_STATIC_START] if lam >= 1e5 else [])
        )
        fine = [
            "bodies.rod.axial_modes=6",
            "bodies.rod.transverse_modes=8",
            "simulation.rtol=1e-10",
            "simulation.atol=1e-12",
        ]
        ref = simulate_scene(
            SLIDER, base + fine + (["effects.axial=true"] if lam <= 1e6 else ["effects.axial=inextensible"])
        )
        t0 = time.perf_counter()
        auto = simulate_scene(SLIDER, base)
        secs = time.perf_counter() - t0
        inext = simulate_scene(SLIDER, base + ["effects.axial=inextensible"])
        err = _peak_error(auto.column("eta_mid"), ref.column("eta_mid"))
        rows.append((lam, err, auto.steps, inext.steps, secs))
        print(
            f"lambda {lam:.0e}: error {100 * err:.3f} %  steps/turn {auto.steps} (inextensible {inext.steps})  "
            f"{secs:.2f} s"
        )
        assert err < 1e-2
        if lam >= 1e5:
            assert auto.steps <= 2 * inext.steps
    assert rows[-1][4] < 10.0


@pytest.mark.slow
def test_lambda_sweep_four_bar_default_within_one_percent():
    """The aluminium four-bar with every bar's lambda scaled (mu fixed) from 1e-1x to 1e5x the
    example's, default effects and functions, half a turn: within 1 % of the reference (full
    dynamics 5 + 6 while affordable, else inextensible 4 + 6); steps at lambda >= 1e5 at most 2x
    the inextensible model's."""
    for scale in (1e-1, 1e1, 1e2, 1e3, 1e5):
        over = _four_bar_lambda_times(scale) + ["simulation.cycles=0.5"]
        lams = [b.lam for b in load_scene(FOUR_BAR, over).bodies if not b.rigid]
        if max(lams) <= 1e6:
            fine = ["effects.axial=true"] + [f"bodies.{b}.axial_modes=5" for b in ("crank", "coupler", "rocker")]
        else:
            fine = ["effects.axial=inextensible"]
        fine += [f"bodies.{b}.transverse_modes=6" for b in ("crank", "coupler", "rocker")]
        ref = simulate_scene(FOUR_BAR, over + fine + ["simulation.rtol=1e-10", "simulation.atol=1e-12"])
        auto = simulate_scene(FOUR_BAR, over)
        inext = simulate_scene(FOUR_BAR, over + ["effects.axial=inextensible"])
        errs = {
            n: _peak_error(auto.column(n), ref.column(n))
            for n in auto.output_names
            if n.startswith(("crank", "coupler", "rocker")) and np.abs(ref.column(n)).max() > 1e-12
        }
        print(
            f"scale {scale:g}: lambda {min(lams):.1e}-{max(lams):.1e}: errors "
            + ", ".join(f"{k} {100 * v:.3f} %" for k, v in errs.items())
            + f"; steps {auto.steps} (inextensible {inext.steps})"
        )
        assert max(errs.values()) < 1e-2
        if min(lams) >= 1e5:
            assert auto.steps <= 2 * inext.steps
