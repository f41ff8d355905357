"""Hard cases: stiffness, long runs, singular positions, extreme ratios. Each case either runs
accurately (against an independent oracle or a limit model) or stops with a clear reason; the
test asserts which.

Stiffness (lambda from 1e3 to 1e9, mu = 0.495 fixed, the seed's slider-crank with the accurate
strain and basis family). Every run starts on the quasi-static state (``[initial] deformation =
"quasi-static"``) so that the stiff axial modes are not rung up at tau = 0; the default tests
use a short window (0.05 crank turn, 31 outputs) so that lambda = 1e9 costs seconds.
The limit model is ``effects.axial = "inextensible"`` (the lambda -> oo limit: the strain is
held to (phi'_k, eps) = 0, the axial force is its multiplier; no lambda, no axial vibration).
The sweeps run at rtol 1e-10, atol 1e-13 (``TIGHT``): the stretch is 3e-10 at lambda 1e9, and at
the scene's atol 1e-10 IDAS's error on the axial amplitudes reaches eta_mid above lambda 1e7
(2.1e-6 at 1e7 over this window) once the start does not ring (the quasi-static start holds the
loads of its deformation's rates and accelerations: docs/exact-bars.md, "A consistent
quasi-static start"). Measured (0.05 turn):

    lambda      1e3     1e4     1e5     1e6     1e7     1e8      1e9     inextensible
    5+2 diff    3.05e-4 3.05e-5 3.05e-6 3.05e-7 3.1e-8  2.9e-9   1.4e-8  (reference)
    5+2 steps   272     968     2859    8511    16886   81216    198     110
    3+4 diff    3.06e-4         3.06e-6         3.05e-8
    3+4 steps   272             1651            14792                    201

(diff: max |eta_mid - eta_mid(inextensible, same basis)| / its peak; at 1e9 IDAS steps past the
axial period, its amplitudes within atol of themselves). Earlier, from a start whose axial
accelerations missed the foreshortening's and rang, at rtol 1e-8: 5 + 2 diff 3.8e-4 ... 4.1e-7
at 1e9 in 718 ... 319654 steps. Both bases converge to the
inextensible model like 1/lambda down to the solver's tolerance: the strain energy is that of
the axial strain the basis can carry, lambda/2 ||P eps||^2 (P the projection onto span{phi'_k}),
so no part of eta'^2 is penalised by lambda. (With the full lambda/8 int eta'^4 the 3 + 4 model
locked: 0.4 % here at lambda >= 1e6, 1-2 % over a turn.) The inextensible model does not lock
with any basis (3 + 4 within 2.3e-4 of 9 + 8 over a turn).
IDAS steps grow like sqrt(lambda) (the axial frequency) although the axial modes hardly move:
BDF orders above 2 are not stable on undamped stiff oscillations, so IDAS keeps the step near
1/omega_axial where they ring (at 1e9 over this window, from the start that does not ring, it
steps past the axial period: 198 steps). The inextensible model costs the same at every lambda (and the default axial
treatment, "auto", eliminates the axial dynamics of such stiff bars: tests/test_axial_default.py).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from symgen.api import mechanism, simulate_scene
from symgen.cli import main
from symgen.errors import SimulationError
from symgen.ir.records import CoordKind, RowKind
from tests.oracles import imperfect_elastica_midspan
from tests.test_cli import FOUR_BAR_TOGGLE
from tests.test_rigid_limit import rigid_four_bar
from tests.test_rigid_limit import write_scene as write_rigid_limit_scene

SLIDER = "examples/slider_crank.toml"
# the full axial dynamics at every lambda (the default "auto" would eliminate them above ~1e4)
ACCURATE = ["effects.strain=von_karman", "bodies.rod.axial_shapes=complete", "effects.axial=true"]
QS = ["initial.deformation=quasi-static"]
INEXT = ["effects.axial=inextensible"]
LAMBDAS = [1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9]
WINDOW = ["simulation.cycles=0.05", "simulation.output_step=0.01"]
#: tolerances that resolve the axial amplitudes at every lambda of the sweep (3e-10 at 1e9)
TIGHT = ["simulation.rtol=1e-10", "simulation.atol=1e-13"]


def basis(na: int, nt: int) -> list:
    return [f"bodies.rod.axial_modes={na}", f"bodies.rod.transverse_modes={nt}"]


def sweep(na: int, nt: int, window: list, lambdas=LAMBDAS, torque: dict | None = None) -> tuple[dict, dict, object]:
    """max |eta_mid - inextensible| / peak and IDAS steps for every lambda (and, given ``torque``,
    the driver torque's max |difference| / peak into it)."""
    common = ACCURATE + basis(na, nt) + QS + window
    ref = simulate_scene(SLIDER, common + INEXT)
    eta, peak = ref.column("eta_mid"), np.abs(ref.column("eta_mid")).max()
    diff, steps = {}, {}
    for lam in lambdas:
        res = simulate_scene(SLIDER, common + [f"bodies.rod.lambda={lam:g}"])
        assert res.complete and res.closure_max < 1e-12
        diff[lam] = float(np.abs(res.column("eta_mid") - eta).max() / peak)
        steps[lam] = res.steps
        if torque is not None:
            t_ref = np.asarray(ref.column("torque"))
            torque[lam] = float(np.abs(np.asarray(res.column("torque")) - t_ref).max() / np.abs(t_ref).max())
    print(f"\n{na}+{nt}: inextensible steps {ref.steps}")
    for lam in lambdas:
        more = f"  torque {torque[lam]:.2e}" if torque is not None else ""
        print(f"  lambda {lam:.0e}: diff {diff[lam]:.2e}{more}  IDAS steps {steps[lam]}")
    return diff, steps, ref


# --------------------------------------------------------------------------- stiffness
def test_lambda_sweep_converges_to_the_inextensible_model():
    """Locking-free basis (5 axial for 2 transverse): every run completes, the distance to the
    inextensible model falls like 1/lambda to the solver's tolerance, steps grow no faster
    than sqrt(lambda) and the inextensible model is cheaper than any of them (110 steps against
    272 at lambda 1e3, where the start no longer rings: 718 from the earlier start)."""
    diff, steps, ref = sweep(5, 2, WINDOW + TIGHT)
    for lam in LAMBDAS:
        assert diff[lam] < 0.5 / lam + 1e-6
    assert diff[1e3] > diff[1e4] > diff[1e5]
    assert steps[1e9] / steps[1e3] < math.sqrt(1e9 / 1e3)
    assert ref.steps < min(steps.values())


def test_no_basis_locks_raising_lambda_only_approaches_the_inextensible_limit():
    """3 axial + 4 transverse (fewer axial functions than 2 nt + 1: the basis cannot carry
    eta'^2): raising lambda 100x at a time only brings the full model closer to the
    inextensible one (no locking), and the inextensible 3 + 4 model is within 5e-4 of the
    inextensible 9 + 8 one (mixed form: the axial force lives in span{phi'})."""
    lams = [1e3, 1e5, 1e7]
    diff, steps, ref = sweep(3, 4, WINDOW + TIGHT, lambdas=lams)
    for lo, hi in zip(lams, lams[1:]):
        assert diff[hi] < diff[lo] / 20, (lo, hi, diff)
    assert diff[1e7] < 1e-6
    fine = simulate_scene(SLIDER, ACCURATE + basis(9, 8) + QS + WINDOW + INEXT)
    peak = np.abs(fine.column("eta_mid")).max()
    assert np.abs(ref.column("eta_mid") - fine.column("eta_mid")).max() / peak < 5e-4


@pytest.mark.slow
@pytest.mark.parametrize("na, nt", [(5, 2), (3, 4)])
def test_lambda_sweep_full_turn(na, nt):
    """The same sweep over a whole crank turn at tolerances that resolve the axial amplitudes
    (rtol 1e-10, atol 1e-13: the stretch is 3e-10 at lambda 1e9): both bases converge to the
    inextensible model like 1/lambda, the midspan deflection and the driver torque alike
    (eta_mid 0.905 / lambda from 1e3 to 1e8 in both bases, then the tolerances' floor, 2.1e-7 at
    1e9 with 5 + 2; the torque 1.95e-3 at 1e3, 1.94e-5 at 1e5, 1.96e-6 at 1e6, then the floor,
    2.3e-6 / 4.0e-6 / 8.2e-6 at 1e7 / 1e8 / 1e9 with 5 + 2). IDAS steps 5327 / 19234 / 4172186 at
    1e3 / 1e4 / 1e9 with 5 + 2: from 1e4 on no faster than sqrt(lambda). The torque tends to the limit because the
    quasi-static start holds the loads of its deformation's rates and accelerations
    (symgen.numerics.start.quasi_static_start): from a start with its accelerations zero the
    dynamic bar's axial accelerations miss the foreshortening's, a ringing of the axial force
    that does not fall with lambda (the torque 1.9e-3 of peak at every lambda, 1e5 to 1e7).
    At the scene's own tolerances (1e-8 / 1e-10) a start that does not ring leaves IDAS free to
    step past the axial period, and above lambda 1e7 its error on the axial amplitudes (within
    atol of themselves) reaches eta_mid: 1.3e-5 to 2.7e-5 of peak at 1e7 to 1e10; the start
    that rang (before the rates were held) kept the steps near the axial period, 5.9 million at
    1e9 (within 7.3e-7), and was off by 1.3e-5 at 1e10 (docs/exact-bars.md)."""
    torque: dict = {}
    diff, steps, _ = sweep(na, nt, ["simulation.cycles=1", *TIGHT], torque=torque)
    for lam in LAMBDAS:
        # at 1e9 IDAS's floor at these tolerances: the start is 6.7e-12 off the limit at the first
        # outputs and the difference grows over the turn to 2.1e-7 (5 + 2; 3.2e-7 with the start's
        # differences over 1e-4 rad, 2.1e-8 on a path of session 9's start)
        assert diff[lam] < 1.5 / lam + (5e-8 if lam < 1e9 else 5e-7)
        # the torque at 1e9 is IDAS's floor too: where IDAS steps past the axial period it was 8.2e-6
        # (5 + 2); where it follows the axial ringing it is 4.33e-5 (3 + 4: 3.05 million steps, measured
        # 2026-11-29 with casadi 3.8.2 / numpy 2.4.6, the same with the code of the session's start,
        # bcec25a, which passed 2e-5 in 2026-11-28's CI: the packages', not the model's, difference)
        assert torque[lam] < 3.0 / lam + (2e-5 if lam < 1e9 else 1e-4)
    assert steps[1e9] / steps[1e4] < math.sqrt(1e9 / 1e4)


# --------------------------------------------------------------------------- the inextensible model
def test_inextensible_model_has_no_lambda_and_holds_the_chord_shortening():
    """The limit model derives without lambda, and its chord elongation is exactly the
    shortening -1/2 int eta'^2 that its constraint (phi'_1, eps) = 0 with phi_1 = xi demands
    (pinned-pinned frame: the chord elongation is zeta(1)); eta' from the sines psi_k."""
    mech = mechanism(SLIDER, ACCURATE + basis(3, 4) + QS + INEXT + ["simulation.cycles=0.25"])
    assert not any(p.startswith("lambda_") for p in mech.info.params)
    assert len(mech.info.rows(RowKind.INEXTENSIBLE)) == 3
    from symgen.numerics.simulate import simulate

    res = simulate(mech)
    g = res.q[:, list(mech.info.indices(CoordKind.G))]
    xi = np.linspace(0.0, 1.0, 4001)
    dpsi = np.array([k * np.pi * np.cos(k * np.pi * xi) for k in range(1, 5)])
    slope = g @ dpsi
    shortening = -0.5 * np.trapezoid(slope**2, xi, axis=1)
    assert np.abs(shortening).max() > 1e-5
    assert np.abs(res.column("eps_ax") - shortening).max() < 1e-9 * 1e3 * np.abs(shortening).max()


def test_inextensible_spinning_bar_conserves_energy(tmp_path):
    """A free bar spinning and vibrating (no load, no damping), inextensible: the constraint
    does no work, so the energy is conserved to the solver's tolerance (18 tau, 100 bending
    periods; measured 7.9e-9 of the energy at rtol 1e-10)."""
    res = simulate_scene(write_spinning_bar(tmp_path, t_end=18.0), INEXT)
    E = res.column("energy")
    assert np.abs(E - E[0]).max() / E[0] < 2e-7
    assert _periods(res) >= 95


# --------------------------------------------------------------------------- long runs
@pytest.mark.slow
def test_thousand_crank_turns_closure():
    """The seed's slider-crank (examples/slider_crank.toml as it is) for 1000 crank turns,
    output every 4 degrees: position closure <= 1e-10 at every output (about 2-3 minutes)."""
    res = simulate_scene(SLIDER, ["simulation.cycles=1000", f"simulation.output_step={4 * math.pi / 180!r}"])
    assert res.complete
    assert res.tau[-1] == pytest.approx(2000 * math.pi)
    assert len(res.tau) == 90_001
    assert res.closure_max <= 1e-10
    assert np.abs(res.column("closure")).max() <= 1e-10
    print(f"\n1000 turns: closure max {res.closure_max:.2e}, IDAS steps {res.steps}, {res.simulate_s:.0f} s")


SPINNING_BAR = """
[scene]
name = "spinning_bar"
[[bodies]]
name = "bar"
length = 1.0
lambda = 1000.0
mu = 5.0
frame = "pinned-pinned"
axial_modes = 3
transverse_modes = 3
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "torque"
body = "bar"
value = 0.0
initial = 0.0
rate = 1.0
[initial]
deformation = {{ bar = {{ g = [0.01, 0.0, 0.0] }} }}
[effects]
strain = "{strain}"
[outputs]
energy = {{ kind = "energy" }}
eta = {{ kind = "deflection", body = "bar", at = 0.5 }}
[simulation]
t_end = {t_end!r}
output_step = 0.05
rtol = {rtol!r}
atol = 1e-12
"""


def write_spinning_bar(path, t_end: float, rtol: float = 1e-10, strain: str = "von_karman") -> str:
    """A bar pinned to ground, free (zero torque), spinning at 1 and released with its first
    bending shape (deflection 0.01): no load, no damping; bending period about 0.18 tau."""
    file = path / f"spinning_{strain}_{rtol:g}.toml"
    file.write_text(SPINNING_BAR.format(strain=strain, t_end=float(t_end), rtol=float(rtol)))
    return str(file)


def _periods(res) -> int:
    eta = res.column("eta")
    return int(np.count_nonzero((eta[:-1] < 0) & (eta[1:] >= 0)))


@pytest.mark.slow
def test_von_karman_free_motion_conserves_energy_over_1000_periods(tmp_path):
    """The spinning, vibrating bar over 1000 bending periods (185 tau, about 20 s): the energy
    drift follows the solver's tolerance, so it is the integrator's, not the model's (measured
    max |E - E0| / E0 = 2.0e-6 at rtol 1e-8, 1.7e-7 at rtol 1e-10, over 990 periods); the
    vibration keeps its amplitude."""
    drift = {}
    for rtol in (1e-8, 1e-10):
        res = simulate_scene(write_spinning_bar(tmp_path, t_end=185.0, rtol=rtol))
        assert res.complete and _periods(res) >= 1000
        E = res.column("energy")
        drift[rtol] = float(np.abs(E - E[0]).max() / E[0])
        eta = res.column("eta")
        n = len(eta) // 10
        assert np.abs(eta[-n:]).max() > 0.9 * np.abs(eta[:n]).max()
        print(
            f"\nrtol {rtol:g}: energy drift {drift[rtol]:.2e} of E over {_periods(res)} periods, IDAS steps {res.steps}"
        )
    assert drift[1e-10] < 1e-6
    assert drift[1e-8] > 3 * drift[1e-10]


# --------------------------------------------------------------------------- singular positions
def _cli(tmp_path, text: str, capsys, *extra) -> tuple[int, str]:
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out.csv"), *extra])
    return code, capsys.readouterr().err


def test_mechanism_that_cannot_be_assembled_says_so(tmp_path, capsys):
    """The toggle four-bar of tests/test_cli.py with the rocker's ground pin at 5 (> 1.5 + 1 + 1):
    no assembly exists. Exit 2, the loop named, no output file."""
    code, err = _cli(tmp_path, FOUR_BAR_TOGGLE.replace("at = [[2.0, 0.0], 0.0]", "at = [[5.0, 0.0], 0.0]"), capsys)
    assert code == 2
    assert "cannot be assembled" in err and "loop closed by joint 'B'" in err and "tau = 0" in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]


def test_driver_started_where_the_loop_cannot_close_says_so(tmp_path, capsys):
    """Same non-Grashof four-bar with the crank started at 2.0 rad, beyond its toggle (1.186):
    the crank cannot reach that angle."""
    code, err = _cli(tmp_path, FOUR_BAR_TOGGLE.replace("initial = 0.5", "initial = 2.0"), capsys)
    assert code == 2 and "cannot be assembled" in err and "loop closed by joint 'B'" in err


def test_start_exactly_at_a_toggle_says_so(tmp_path, capsys):
    code, err = _cli(tmp_path, FOUR_BAR_TOGGLE.replace("initial = 0.5", f"initial = {math.acos(0.375)!r}"), capsys)
    assert code == 2
    assert "singular position" in err and "loop closed by joint 'B'" in err and "tau = 0" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]


def test_toggle_with_an_inextensible_elastic_coupler_names_the_loop(tmp_path, capsys):
    """The toggle test of tests/test_cli.py with an elastic coupler under effects.axial =
    "inextensible": its constraint rows do not hide the singular position, which is met where
    the rigid one is (tau = acos(0.375) - 0.5 = 0.686) and named by its loop."""
    elastic = FOUR_BAR_TOGGLE.replace(
        'name = "coupler"\nlength = 1.0\nrigid = true',
        'name = "coupler"\nlength = 1.0\nlambda = 1e4\nmu = 2.0\n'
        'frame = "pinned-pinned"\naxial_modes = 2\ntransverse_modes = 2',
    )
    assert elastic != FOUR_BAR_TOGGLE
    code, err = _cli(
        tmp_path, elastic, capsys, "--set", "effects.axial=inextensible", "--set", "initial.deformation=quasi-static"
    )
    assert code == 2
    assert "singular position" in err and "loop closed by joint 'B'" in err
    assert "inextensibility" not in err
    tau = float(re.search(r"at tau = ([0-9.]+)", err).group(1))
    assert tau == pytest.approx(math.acos(0.375) - 0.5, abs=0.02)
    assert (tmp_path / "out.partial.csv").exists() and not (tmp_path / "out.csv").exists()


# --------------------------------------------------------------------------- extreme ratios
RIGID_MASSES = [(1.0, 1e-6, 1e6), (1.0, 1e6, 1e-6), (1e-6, 1.0, 1e6), (1e6, 1e-6, 1.0)]


@pytest.mark.parametrize("masses", RIGID_MASSES, ids=lambda m: "-".join(f"{x:g}" for x in m))
def test_mass_ratios_rigid_four_bar_against_newton_euler(tmp_path, masses):
    """Mass ratios up to 1e12 between the bars of a rigid, driven four-bar: the driver torque
    against the Newton-Euler oracle of tests/test_rigid_limit.py (measured <= 2.5e-11)."""
    path = write_rigid_limit_scene(tmp_path, masses)
    text = open(path).read()
    text = re.sub(r"lambda = [^\n]*\nmu = [^\n]*\n", "", text)
    text = re.sub(r'frame = "[a-z-]*"\naxial_modes = 1\ntransverse_modes = 2\n', "rigid = true\n", text)
    text = text.replace('deformation = "quasi-static"\n', "")
    assert text.count("rigid = true") == 3
    open(path, "w").write(text)
    res = simulate_scene(path)
    ref = rigid_four_bar(res.tau, masses)
    torque = ref[:, 0] / masses[0]  # the crank is the reference bar (units)
    assert np.abs(res.column("torque") - torque).max() / np.abs(torque).max() < 1e-9
    assert np.abs(res.column("rocker_angle") - ref[:, 2]).max() < 1e-12


def test_mass_ratios_elastic_four_bar_beyond_what_a_light_bar_carries(tmp_path):
    """The stiff elastic four-bar of tests/test_rigid_limit.py (lambda = mu = 1e9 per bar) with
    a coupler 1e-6 as heavy as the crank driving a rocker 1e6 as heavy: the light coupler
    would have to stretch by 150 % of its length to carry those forces. The run stops at tau = 0
    naming the bar and the model's range."""
    with pytest.raises(SimulationError) as info:
        simulate_scene(write_rigid_limit_scene(tmp_path, (1.0, 1e-6, 1e6)))
    assert "bar 'coupler' is deformed beyond the range of the model" in str(info.value)
    assert info.value.tau == 0.0


SLIDER_MASS = ACCURATE + basis(3, 4) + QS + ["simulation.cycles=0.5"]


def test_slider_mass_ratios(capsys):
    """Lumped slider mass relative to the rod's: 1e-6 and 1e-3 run and differ from the massless
    slider in proportion to the mass (measured 1.2e-7 and 1.2e-4 of the peak: accurate); 1e2 and
    1e6 load the rod far beyond its Euler load (pi^2 mu = 4.9): stopped, naming the rod."""
    base = simulate_scene(SLIDER, SLIDER_MASS).column("eta_mid")
    peak = np.abs(base).max()
    diffs = {}
    for m in (1e-6, 1e-3):
        res = simulate_scene(SLIDER, SLIDER_MASS + [f"joints.B.mass={m}"])
        diffs[m] = np.abs(res.column("eta_mid") - base).max() / peak
    assert diffs[1e-6] < 1e-6
    assert 0.5e3 < diffs[1e-3] / diffs[1e-6] < 2e3  # linear in the mass
    for m in (1e2, 1e6):
        with pytest.raises(SimulationError) as info:
            simulate_scene(SLIDER, SLIDER_MASS + [f"joints.B.mass={m}"])
        assert "bar 'rod' is deformed beyond the range of the model" in str(info.value)


@pytest.mark.parametrize("alpha", [0.01, 0.001])
def test_very_short_elastic_crank_next_to_the_long_rod(alpha):
    """An elastic crank 100 and 1000 times shorter than the rod (same section: lambda and mu
    scale as 1/alpha^2 and 1/alpha^4, up to 5e11) runs and matches the rigid crank (measured
    1.0e-5 and 6.5e-5 of the rod's peak deflection)."""
    common = ACCURATE + basis(3, 4) + QS + ["simulation.cycles=1", f"bodies.crank.length={alpha}"]
    rigid = simulate_scene(SLIDER, common).column("eta_mid")
    elastic = simulate_scene(
        SLIDER,
        common
        + [
            "bodies.crank.rigid=false",
            f"bodies.crank.lambda={18246 / alpha**2:g}",
            f"bodies.crank.mu={0.495 / alpha**4:g}",
            "bodies.crank.frame=cantilever",
            "bodies.crank.axial_modes=2",
            "bodies.crank.transverse_modes=2",
        ],
    )
    assert elastic.complete
    assert np.abs(elastic.column("eta_mid") - rigid).max() / np.abs(rigid).max() < 2e-4


FREE_FOUR_BAR = "tests/data/four_bar_free.toml"
ZERO_MODES = [
    "bodies.crank.axial_modes=0",
    "bodies.crank.transverse_modes=0",
    "bodies.coupler.axial_modes=0",
    "bodies.rocker.transverse_modes=0",
]


@pytest.mark.parametrize("axial", ["true", "inextensible"])
def test_zero_modes_on_some_bars_conserve_energy(axial):
    """The free elastic four-bar of tests/test_closed_loop_energy.py with an elastic crank of
    0 + 0 functions, a coupler without axial and a rocker without transverse functions: the
    energy is conserved (measured 1.3e-8 and 8.4e-8)."""
    res = simulate_scene(FREE_FOUR_BAR, ZERO_MODES + [f"effects.axial={axial}"])
    E = res.column("E")
    assert np.abs(E - E[0]).max() / E[0] < 5e-7
    assert res.column("th")[-1] > 2 * np.pi


def test_elastic_bar_with_zero_modes_is_the_rigid_bar(tmp_path):
    """Crank elastic with 0 + 0 functions vs the same crank rigid = true. The reference bar (l0,
    m_ref: the first flexible bar) moves from the crank to the coupler (mass 0.5, length 3), so
    with reference_length fixed at 1 energies and forces differ by exactly m_ref: x 2."""
    text = open(FREE_FOUR_BAR).read().replace('name = "fb_free"', 'name = "fb_free"\nreference_length = 1.0')
    zero = tmp_path / "zero.toml"
    zero.write_text(text)
    rigid = tmp_path / "rigid.toml"
    rigid.write_text(
        text.replace(
            'name = "crank"\nlength = 1.0\nlambda = 1e4\nmu = 20.0\nframe = "cantilever"\n'
            "axial_modes = 2\ntransverse_modes = 3",
            'name = "crank"\nlength = 1.0\nrigid = true',
        )
    )
    a = simulate_scene(rigid)
    b = simulate_scene(zero, ["bodies.crank.axial_modes=0", "bodies.crank.transverse_modes=0"])
    assert np.abs(a.column("th") - b.column("th")).max() < 1e-6
    assert np.abs(a.column("E") - 2 * b.column("E")).max() < 1e-6 * np.abs(a.column("E")).max()
    assert np.abs(a.column("R") - 2 * b.column("R")).max() < 1e-5 * np.abs(a.column("R")).max()


COLUMN = """
[scene]
name = "column"
[[bodies]]
name = "col"
length = 1.0
lambda = 1e4
mu = {mu!r}
frame = "pinned-pinned"
axial_modes = {na}
transverse_modes = 3
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "col"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "B"
kind = "slider"
bodies = ["col", "ground"]
at = [1.0, [0.0, 0.0]]
direction = [1.0, 0.0]
[[loads]]
body = "col"
kind = "point"
at = 1.0
axial = {axial_load!r}
[[loads]]
body = "col"
kind = "distributed"
transverse = {gamma!r}
{initial}
[outputs]
mid = {{ kind = "deflection", body = "col", at = 0.5 }}
[simulation]
t_end = {t_end!r}
output_step = 0.05
"""
MU, GAMMA = 1e-2, 1e-4
P_CR = math.pi**2 * MU


def write_column(path, ratio: float, na: int = 7, quasi_static: bool = True, t_end: float = 1.0) -> str:
    """A pinned column (small mu = 0.01) with its far end on a slider along its axis, a
    compressive end load ratio * pi^2 mu and a small uniform lateral load (the imperfection)."""
    file = path / f"column_{ratio:g}_{na}_{quasi_static}.toml"
    initial = '[initial]\ndeformation = "quasi-static"' if quasi_static else ""
    file.write_text(
        COLUMN.format(mu=MU, na=na, axial_load=-ratio * P_CR, gamma=GAMMA, initial=initial, t_end=float(t_end))
    )
    return str(file)


def beam_column_midspan(P: float) -> float:
    """Oracle: pinned-pinned beam-column, uniform load gamma, compression P (series of sines)."""
    return sum(
        4 * GAMMA / (n * math.pi) * math.sin(n * math.pi / 2) / (MU * (n * math.pi) ** 4 - P * (n * math.pi) ** 2)
        for n in range(1, 4001, 2)
    )


@pytest.mark.parametrize("axial, na", [("true", 7), ("inextensible", 3)])
@pytest.mark.parametrize("ratio", [0.5, 0.9, 0.99])
def test_near_buckling_runs_accurately(tmp_path, ratio, axial, na):
    """Below the Euler load the static deflection is amplified by 1/(1 - P/P_cr) (x100 at 0.99)
    and symgen's quasi-static state, kept by the dynamic run, matches the large-deflection
    elastica (oracles.imperfect_elastica_midspan; the full model needs na >= 2 nt + 1). At 0.99
    the elastica is 2.0 % below the linear beam-column series (the deflected shape's geometric
    stiffening, slope^2 ~ 1.6e-3, amplified 100x): symgen's choice of the bar (effects.strain
    auto: the exact bar there) is within 9.9e-4 of it with 3 transverse functions; at 0.5 and 0.9
    within 3e-6 .. 1.4e-4. Von Karman, stated, is the linear series' model (its own closed form):
    within 5e-4 of the series, 2 % off the elastica."""
    res = simulate_scene(write_column(tmp_path, ratio, na), [f"effects.axial={axial}"])
    mid = res.column("mid")
    exact = imperfect_elastica_midspan(ratio * P_CR, MU, GAMMA)
    assert abs(mid[0] - exact) / exact < (2e-3 if ratio > 0.95 else 5e-4)
    assert np.abs(mid - mid[0]).max() < 1e-6 * abs(exact)
    if ratio > 0.95 and axial == "inextensible":
        vk = simulate_scene(write_column(tmp_path, ratio, na), [f"effects.axial={axial}", "effects.strain=von_karman"])
        series = beam_column_midspan(ratio * P_CR)
        assert abs(vk.column("mid")[0] - series) / series < 5e-4
        assert abs(vk.column("mid")[0] - exact) / exact > 0.015


@pytest.mark.parametrize("axial", ["true", "inextensible"])
def test_at_and_beyond_buckling_stops_with_the_reason(tmp_path, axial):
    """At P = P_cr the quasi-static state does not exist (named: near buckling); beyond it the
    quasi-static state is an unstable equilibrium (named, with its growth rate
    (pi^2 sqrt(mu)) sqrt(P/P_cr - 1) = 0.312 at 1.1); started undeformed, the column buckles and
    von Karman strain with a free axial end has no post-buckled equilibrium: the run stops where
    the deformation leaves the model's range."""
    over = [f"effects.axial={axial}"]
    with pytest.raises(SimulationError, match="quasi-static state did not converge.*near buckling"):
        simulate_scene(write_column(tmp_path, 1.0), over)
    with pytest.raises(SimulationError, match="quasi-static state is unstable") as info:
        simulate_scene(write_column(tmp_path, 1.1), over)
    rate = float(re.search(r"grows at rate ([0-9.e+-]+)", str(info.value)).group(1))
    assert rate == pytest.approx(math.pi**2 * math.sqrt(MU) * math.sqrt(0.1), rel=1e-3)
    assert "g_col_1" in str(info.value) and "buckling" in str(info.value)
    with pytest.raises(SimulationError, match="bar 'col' is deformed beyond the range of the model") as info:
        simulate_scene(write_column(tmp_path, 2.0, quasi_static=False, t_end=20.0), over)
    assert 5.0 < info.value.tau < 20.0
    assert len(info.value.partial.tau) > 100
