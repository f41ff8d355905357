"""Slot guides whose overhang bends (issue 12, Deliver 2).

With the contact held at a fixed beta the guide is a beam pinned at 0, simply supported at
beta, overhanging to 1 (dimensionless: mass per length 1, bending group mu = 1). Its static
deflections under a tip load and a uniform load have closed forms; its natural frequencies
come from a fine Hermite-cubic finite-element model written here (no symgen code). The
guide's Galerkin matrices are the closed-form inner products of ``slot.SlotIPTable``
evaluated at that beta.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
import sympy as sp

from symgen.errors import SceneError
from symgen.scene.loader import load_scene
from symgen.model.slot import XI, SlotBasis, SlotIPTable, _derivative
from symgen.model.structure import effective_modes, overhang_modes, structure_of
from tests.oracles import _hermite_matrices, hermite_geometric_stiffness, write_scene
from tests.test_slot import FROZEN, frozen_frequencies

BETA = sp.Symbol("beta_A", real=True)
SCENE = "examples/inverted_slider_crank.toml"


def _matrices(nspan: int, nover: int, beta: float):
    """The guide's matrices with ``nover`` overhang functions of its own (``overhang_modes``; 0:
    the rigid overhang): the basis adds the contact-slope function chi_0 to them."""
    nfun = nover + 1 if nover else 0
    basis = SlotBasis(nspan + nfun, BETA, nfun)
    ipt = SlotIPTable(basis)
    nt = basis.nt
    at = {BETA: beta}
    K = np.array(ipt.Kt.xreplace(at).evalf(), dtype=float)
    M = np.array(ipt.G[2 : 2 + nt, 2 : 2 + nt].xreplace(at).evalf(), dtype=float)
    load = np.array(ipt.G[0, 2 : 2 + nt].xreplace(at).evalf(), dtype=float).ravel()  # (psi_k, 1)
    tip = np.array([float(basis.expr(k, 1.0).xreplace(at)) for k in range(nt)])  # psi_k(1)
    return K, M, load, tip


def _tip_deflections(nspan: int, nover: int, beta: float) -> tuple[float, float]:
    """Far-end deflection under a unit tip load and under a unit uniform load (mu = 1)."""
    K, _, load, tip = _matrices(nspan, nover, beta)
    return float(tip @ np.linalg.solve(K, tip)), float(tip @ np.linalg.solve(K, load))


def _fe_frequencies(beta: float, n: int = 120) -> np.ndarray:
    """First three frequencies of the pinned / supported-at-beta / free beam (EI = m = 1)."""
    return _fe_frequencies_in_tension(beta, 0.0, 0.0, n)


def _frequencies(nspan: int, nover: int, beta: float) -> np.ndarray:
    K, M, _, _ = _matrices(nspan, nover, beta)
    return np.sqrt(sl.eigh(K, M, eigvals_only=True)[:3])


def test_fe_oracle_is_converged():
    assert np.allclose(_fe_frequencies(0.5, 60), _fe_frequencies(0.5, 120), rtol=1e-6)


@pytest.mark.parametrize("beta", [0.5, 0.6, 0.75])
def test_static_overhang_tip_deflection_matches_closed_forms(beta):
    span, over = beta, 1.0 - beta
    tip_load = over**2 * (span + over) / 3  # P c^2 (l + c) / 3EI
    uniform = over * (4 * over**2 * span + 3 * over**3 - span**3) / 24  # w c (4c^2 l + 3c^3 - l^3) / 24EI
    d_tip, d_uni = _tip_deflections(2, 4, beta)  # the defaults
    assert d_tip == pytest.approx(tip_load, rel=5e-3)
    assert d_uni == pytest.approx(uniform, rel=5e-3)
    r_tip, _ = _tip_deflections(2, 0, beta)  # the seed's rigid overhang
    assert abs(r_tip / tip_load - 1) > 0.2  # it misses the overhang's own bending


@pytest.mark.parametrize("beta", [0.5, 0.6, 0.75])
def test_frequencies_match_finite_elements(beta):
    ref = _fe_frequencies(beta)
    assert _frequencies(2, 4, beta) == pytest.approx(ref, rel=5e-3)  # the defaults: three
    assert _frequencies(2, 3, beta)[:2] == pytest.approx(ref[:2], rel=5e-3)  # three functions: two
    if beta <= 0.6:  # overhang >= 2/3 span: the rigid one is far off
        assert abs(_frequencies(2, 0, beta)[0] / ref[0] - 1) > 0.1


def test_functions_are_admissible_at_the_moving_contact():
    """Every function (span, contact slope, overhang) is 0 at the contact with continuous value
    and slope there (eta stays C1: admissible for bending), and psi_beta is continuous there, so
    the velocity g'^T psi + beta' g^T psi_beta is continuous in time at a point the contact passes
    and the acceleration has no impulse (no point mass at the contact). The span functions and the
    overhang's own are zero beyond / before the contact; the contact-slope function chi_0 has unit
    slope there and the curvature of the span's static shape under a moment at the contact (a
    curvature jump: the support takes the moment's change as a kink of the shear, not of eta)."""
    basis = SlotBasis(6, BETA, 4)
    assert [f.label for f in basis.functions] == ["s_{1}", "s_{2}", r"\chi_{0}", r"\chi_{1}", r"\chi_{2}", r"\chi_{3}"]
    at = {XI: BETA}
    for fn in basis.functions:
        assert sp.simplify(fn.span.xreplace(at)) == 0
        for d in range(2):
            assert sp.simplify((sp.diff(fn.span, XI, d) - sp.diff(fn.overhang, XI, d)).xreplace(at)) == 0
        s, o = sp.diff(fn.span, BETA), sp.diff(fn.overhang, BETA)
        assert sp.simplify((s - o).xreplace(at)) == 0
    s1, s2, c0 = basis.functions[:3]
    assert s1.overhang == 0 and s2.overhang == 0 and all(f.span == 0 for f in basis.functions[3:])
    assert sp.simplify(sp.diff(c0.span, XI).xreplace(at) - 1) == 0
    assert sp.simplify(sp.diff(c0.span, XI, 2).xreplace({XI: 0})) == 0  # no moment at the pin
    assert sp.simplify(sp.diff(c0.span, XI, 4)) == 0  # unloaded: a cubic
    rigid = SlotBasis(2, BETA, 0)  # the seed's form: C2 at the contact
    for fn in rigid.functions:
        for order in range(3):
            s, o = sp.diff(fn.span, BETA, order), sp.diff(fn.overhang, BETA, order)
            for d in range(3 - order):
                assert sp.simplify((sp.diff(s, XI, d) - sp.diff(o, XI, d)).xreplace(at)) == 0


def test_the_elastic_layout_contains_the_tangent_continuation_and_decouples_the_stiffness():
    """The seed's functions psi_k (sine with its tangent continuation) are s_k + psi_k'(beta) chi_0
    (the basis of the elastic overhang spans them: it is richer, not different), and the bending
    stiffness is block diagonal in (span, chi_0, overhang): chi_0 is the span's static shape for
    its end slope (K-orthogonal to the span functions by parts) and straight on the overhang."""
    beta = sp.Rational(3, 10)
    el, rigid = SlotBasis(5, BETA, 3), SlotBasis(2, BETA, 0)
    for k in range(2):
        slope = (-1) ** (k + 1) * (k + 1) * sp.pi / BETA
        for part in ("span", "overhang"):
            diff = (
                getattr(rigid.functions[k], part)
                - getattr(el.functions[k], part)
                - slope * getattr(el.functions[2], part)
            )
            assert sp.simplify(diff) == 0
    K = np.array(SlotIPTable(el).Kt.xreplace({BETA: beta}).evalf(), dtype=float)
    scale = np.sqrt(np.outer(np.diag(K), np.diag(K)))
    off = np.abs(K / scale)
    assert off[:2, 2:].max() < 1e-12 and off[2, 3:].max() < 1e-12
    assert off[0, 1] > 1e-3 and off[3:, 3:].min() > 1e-3  # coupled within the span and the overhang


def test_rigid_overhang_keeps_the_seed_matrices():
    """overhang = "rigid" (no overhang functions) gives the seed's inner products: the
    stiffness over the overhang adds nothing for the tangent continuation."""
    ipt = SlotIPTable(SlotBasis(2, BETA, 0))
    span_only = sp.Matrix(
        2,
        2,
        lambda i, j: sp.integrate(
            sp.diff(sp.sin((i + 1) * sp.pi * XI / BETA), XI, 2) * sp.diff(sp.sin((j + 1) * sp.pi * XI / BETA), XI, 2),
            (XI, 0, BETA),
        ),
    )
    assert sp.simplify(ipt.Kt - span_only) == sp.zeros(2, 2)


def test_elastic_overhang_is_the_default(tmp_path):
    text = FROZEN.format(L=2.0, d=1.2, mu=0.8, beta=0.6, overhang="elastic").replace('overhang = "elastic"\n', "")
    assert "overhang" not in text
    scene = load_scene(str(write_scene(tmp_path / "s.toml", text)))
    slot = next(j for j in scene.joints if j.kind == "slot")
    assert (slot.overhang, slot.overhang_modes) == ("elastic", 4)
    assert effective_modes(scene, scene.body("guide")) == (0, 3 + 1 + 4)  # span, contact slope, overhang


def test_scene_keys_default_and_rigid():
    scene = load_scene(SCENE, ["joints.A.overhang=elastic"])  # the example sets the seed's form
    guide = scene.body("guide")
    assert overhang_modes(scene, guide) == 1 + 4  # the contact-slope function and the overhang's own
    assert effective_modes(scene, guide) == (0, guide.transverse_modes + 1 + 4)
    rigid = load_scene(SCENE)
    assert effective_modes(rigid, rigid.body("guide")) == (0, guide.transverse_modes)
    assert structure_of(rigid) != structure_of(scene)
    assert overhang_modes(load_scene(SCENE, ["joints.A.overhang=elastic", "joints.A.overhang_modes=5"]), guide) == 6


@pytest.mark.parametrize(
    "override, key",
    [
        (["joints.A.overhang=bent"], "joints.A.overhang"),
        (["joints.A.overhang=elastic", "joints.A.overhang_modes=0"], "joints.A.overhang_modes"),
        (["joints.A.overhang=elastic", "joints.A.overhang_modes=6"], "joints.A.overhang_modes"),  # nearly dependent
        (["joints.A.overhang_modes=2"], "joints.A.overhang_modes"),  # the file's overhang is rigid
        (["joints.O.overhang=rigid"], "joints.O.overhang"),
    ],
)
def test_bad_overhang_keys_are_scene_errors(override, key):
    with pytest.raises(SceneError) as err:
        load_scene(SCENE, override)
    assert err.value.key == key


@pytest.mark.slow
@pytest.mark.parametrize("d", [1.2, 1.5])
def test_frozen_slot_scene_with_elastic_overhang_matches_finite_elements(tmp_path, d):
    """The whole generated model (default elastic overhang) with the contact held at distance
    d on a guide 2 long: the guide's first three frequencies against the FE model (x sqrt(mu));
    the seed's rigid overhang misses the first by more than 1 %."""
    mu = 0.8
    beta, w = frozen_frequencies(tmp_path, L=2.0, d=d, mu=mu, overhang="elastic")
    ref = _fe_frequencies(beta) * np.sqrt(mu)
    assert w[:3] == pytest.approx(ref, rel=5e-3)
    _, rigid = frozen_frequencies(tmp_path, L=2.0, d=d, mu=mu)
    assert abs(rigid[0] / ref[0] - 1) > 0.01


@pytest.mark.slow
def test_latex_of_the_elastic_overhang_shows_and_gives_back_the_model(tmp_path):
    """`symgen latex` of the inverted slider-crank with the elastic overhang: the chi functions
    are shown, the displayed guide equations (closed-form inner products in beta) give back the
    model's generalized forces, and the document builds."""
    import shutil
    import subprocess

    from symgen.model.derive import derive
    from symgen.backends.latex.document import latex_document
    from tests.test_latex import test_guide_equations_give_back_the_model

    scene = load_scene(SCENE, ["joints.A.overhang=elastic"])
    model = derive(scene)
    doc = latex_document(scene, model)
    assert r"($\chi_1, \dots, \chi_{4}$" in doc and r"\psi_{7}(\xi, \beta)" in doc
    assert r"$\psi_{3} = \chi_0$ is the" in doc  # the contact-slope function after the 2 span functions
    assert "does not bend" not in doc
    test_guide_equations_give_back_the_model((scene, model, doc))
    if shutil.which("pdflatex"):
        (tmp_path / "isc.tex").write_text(doc)
        run = subprocess.run(
            ["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "isc.tex"],
            cwd=tmp_path,
            capture_output=True,
            timeout=300,
        )
        assert run.returncode == 0


@pytest.mark.parametrize("beta", [0.14, 0.2])
def test_short_span_functions_quasi_static_keep_the_guide_frequencies(beta):
    """With the span short (the overhang 4-6 spans: a crank-shaper's lever at its quick return)
    the span functions' own frequencies go as 1/beta^2, far above the guide's first ones: without
    their inertia (quasi-static: stiffness kept, mass dropped; their stiffness does not couple to
    the other functions, so they only lose their mass) the first two frequencies stay within
    0.5 % of the finite-element beam's, and the span functions' lowest own frequency is more
    than 10x the guide's second."""
    ref = _fe_frequencies(beta)
    K, M, _, _ = _matrices(4, 4, beta)
    span, rest = slice(0, 4), slice(4, None)
    assert np.abs(K[span, rest]).max() < 1e-9 * np.abs(K).max()
    w_rest = np.sqrt(sl.eigh(K[rest, rest], M[rest, rest], eigvals_only=True))
    assert w_rest[:2] == pytest.approx(ref[:2], rel=5e-3)
    w_span = np.sqrt(sl.eigh(K[span, span], M[span, span], eigvals_only=True))
    assert w_span[0] > 10 * ref[1]


@pytest.mark.slow
def test_stated_span_amplitudes_keep_their_meaning_with_the_contact_slope_function():
    """An explicit initial g on a guide lists the span's sines with their tangent continuation
    (as with a rigid overhang): with the elastic overhang the start puts sum_k g_k psi_k'(beta)
    on the contact-slope function chi_0 (beta at its guess), so the start's shape is the same
    function of xi; the overhang's own functions start at zero."""
    from symgen.api import mechanism
    from symgen.ir.records import CoordKind

    g = [0.01, -0.004]
    mech = mechanism(
        SCENE,
        ["joints.A.overhang=elastic", "joints.A.overhang_modes=2", f"initial.deformation={{guide = {{g = {g}}}}}"],
    )
    q, _ = mech.initial_guess()
    beta = next(q[i] for i, c in enumerate(mech.coords) if c.kind is CoordKind.BETA)
    amp = [q[i] for i in mech.amplitudes["guide"][1]]
    assert amp[:2] == pytest.approx(g, abs=0)
    assert amp[2] == pytest.approx(sum(gk * (-1) ** k * k * np.pi / beta for k, gk in enumerate(g, start=1)), rel=1e-12)
    assert amp[3:] == [0.0, 0.0]
    basis, rigid = SlotBasis(5, BETA, 3), SlotBasis(2, BETA, 0)
    for xi in (0.3 * beta, 0.9 * beta, beta + 0.4 * (1 - beta), 1.0):
        el = sum(a * float(basis.expr(k, xi).xreplace({BETA: beta})) for k, a in enumerate(amp))
        seed = sum(a * float(rigid.expr(k, xi).xreplace({BETA: beta})) for k, a in enumerate(g))
        assert el == pytest.approx(seed, rel=1e-12, abs=1e-15)


def _fe_frequencies_in_tension(
    beta: float, c1: float, w: float, n: int = 160, point: tuple[float, float] = (0.0, 1.0)
) -> np.ndarray:
    """First three frequencies of the pinned / supported-at-beta / free beam (EI = m = 1) turning at
    w about its pin, with the tension N = c1 (1 - xi) + w^2 (1 - xi^2) / 2 (an axial load c1 per
    unit length and the centrifugal one, plus P on [0, xi_p] of an axial point force ``point`` =
    (P, xi_p)) and the spin's softening -w^2 (eta, eta): Hermite cubic elements (tests/oracles.py),
    each element's geometric stiffness at its mid-point tension, nodes at beta and xi_p."""
    P, xp = point
    xs = np.unique(
        np.concatenate(
            [np.linspace(0.0, beta, round(n * beta) + 1), np.linspace(beta, 1.0, round(n * (1 - beta)) + 1), [xp]]
        ).round(12)
    )
    K, M = _hermite_matrices(xs)
    K = (
        K
        + hermite_geometric_stiffness(xs, lambda x: c1 * (1 - x) + w**2 * (1 - x**2) / 2 + (P if x < xp else 0.0))
        - w**2 * M
    )
    support = int(np.argmin(abs(xs - beta)))
    free = [i for i in range(2 * len(xs)) if i not in (0, 2 * support)]
    return np.sqrt(sl.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True)[:3])


@pytest.mark.parametrize("beta", [0.5, 0.75])
def test_tension_stiffening_of_a_turning_guide_matches_finite_elements(beta):
    """The guide's tension matrices (slot.TENSION_WEIGHTS, DERIVE_VERSION 12): an axially rigid guide
    turning at w about its pin with an axial load c1 along it has, in the model's equation (17),
    mu K + c1 (psi', (1 - xi) psi') + w^2 ((psi', (1 - xi^2)/2 psi') - (psi, psi)); its frequencies
    against finite elements with the same tension. Without the tension the first frequency is
    ~13 % (beta 0.5) off at these loads."""
    c1, w = 6.0, 8.0
    basis = SlotBasis(2 + 5, BETA, 5)  # the defaults' layout and one overhang function more
    ipt = SlotIPTable(basis)
    at = {BETA: beta}
    num = lambda m: np.array(m.xreplace(at).evalf(), dtype=float)
    nt = basis.nt
    K, M = num(ipt.Kt), num(ipt.G[2 : 2 + nt, 2 : 2 + nt])
    T1, T2 = num(ipt.matrix("T1")), num(ipt.matrix("T2"))
    ref = _fe_frequencies_in_tension(beta, c1, w)
    assert _fe_frequencies_in_tension(beta, c1, w, 80) == pytest.approx(ref, rel=2e-4)  # the oracle converged
    got = np.sqrt(sl.eigh(K + c1 * T1 + w**2 * (T2 - M), M, eigvals_only=True)[:2])
    assert got == pytest.approx(ref[:2], rel=2e-3)
    without = np.sqrt(sl.eigh(K - w**2 * M, M, eigvals_only=True)[0])
    assert abs(without / ref[0] - 1) > 0.05


@pytest.mark.parametrize("nover", [0, 3])
def test_curvature_rate_matrices_match_quadrature(nover):
    """The beta_dot part of the guide's curvature rate (slot._rate_gram, its Kelvin-Voigt damping):
    (psi''_a, psi''_b,beta) and (psi''_a,beta, psi''_b,beta) against Gauss quadrature of the
    functions' own derivatives, on the span and the overhang apart; (psi''_a, psi''_b,beta) is not
    symmetric, and its symmetric part is not d/dbeta (psi''_a, psi''_b) where the curvature jumps at
    the contact (the elastic overhang)."""
    beta = 0.62
    basis = SlotBasis(3 + nover, BETA, nover)
    ipt = SlotIPTable(basis)
    at = {BETA: beta}
    nt = basis.nt
    Kb, Kbb = (np.array(ipt.matrix(n).xreplace(at).evalf(), dtype=float) for n in ("Kb", "Kbb"))
    x, wq = np.polynomial.legendre.leggauss(40)

    def curv(k: int, dbeta: int, lo: float, hi: float) -> np.ndarray:
        xi = lo + (hi - lo) * (x + 1) / 2
        piece = _derivative(k + 1, BETA, basis.nspan, nover, 2, dbeta)[0 if hi <= beta else 1]
        f = sp.lambdify(XI, piece.xreplace(at), "numpy")
        return np.broadcast_to(np.asarray(f(xi), dtype=float), xi.shape)

    def inner(a, da, b, db):
        return sum(
            (hi - lo) / 2 * np.sum(wq * curv(a, da, lo, hi) * curv(b, db, lo, hi))
            for lo, hi in ((0.0, beta), (beta, 1.0))
        )

    for a in range(nt):
        for b in range(nt):
            assert Kb[a, b] == pytest.approx(inner(a, 0, b, 1), rel=1e-9, abs=1e-9)
            assert Kbb[a, b] == pytest.approx(inner(a, 1, b, 1), rel=1e-9, abs=1e-9)
    assert not np.allclose(Kb, Kb.T)
    dKt = np.array(sp.diff(ipt.Kt, BETA).xreplace(at).evalf(), dtype=float)
    assert np.allclose(Kb + Kb.T, dKt) == (nover == 0)


def test_latex_of_a_damped_guide_gives_back_the_model():
    """A damped guide (DERIVE_VERSION 12): its curvature rate's beta_dot part ((psi''_a, psi''_b,beta),
    (psi''_a,beta, psi''_b,beta)) is shown in (17) and the beta equation, and the displayed
    equations give back the model's generalized forces."""
    from symgen.model.derive import derive
    from symgen.backends.latex.document import latex_document
    from tests.test_latex import test_guide_equations_give_back_the_model

    scene = load_scene(SCENE, ["effects.damping=0.01"])
    model = derive(scene)
    doc = latex_document(scene, model)
    kinds = {kind for kind, _ in model.bars["guide"].equations.inner_products.values()}
    assert {"Kb", "Kbb"} <= kinds
    assert r"\left(\psi''_{1},\psi''_{2,\beta}\right)" in doc
    test_guide_equations_give_back_the_model((scene, model, doc))


_DYAD = """
[scene]
name = "slot_dyad"
units = "SI"
omega = 22.0
reference_length = 0.95

[[bodies]]
name = "crank"
length = 0.12
rigid = true
mass_per_length = 0.5

[[bodies]]
name = "guide"
length = 0.95
E = 70e9
area = 2e-4
inertia = 1.6666666666667e-9
density = 2700.0
frame = "pinned-pinned"
axial_modes = 0
transverse_modes = 2

[[bodies]]
name = "link1"
length = 0.4
rigid = true
mass_per_length = 0.6

[[bodies]]
name = "link2"
length = 0.5
rigid = true
mass_per_length = 0.6

{grounded}

[[joints]]
name = "A"
kind = "slot"
bodies = ["crank", "guide"]
at = [1.0, "variable"]
overhang_modes = 2

[[joints]]
name = "B"
kind = "pin"
bodies = ["guide", "link1"]
at = [1.0, 0.0]

[[joints]]
name = "C"
kind = "pin"
bodies = ["link1", "link2"]
at = [1.0, 1.0]

[driver]
kind = "angle"
body = "crank"
initial = 0.0
rate = 1.0

[initial]
guess = {{ guide = 0.0, A = 0.7578947368421053, link1 = 0.001, link2 = -1.5308 }}

[outputs]
guide_end = {{ kind = "deflection", body = "guide", at = 1.0 }}
guide_mid = {{ kind = "deflection", body = "guide", at = 0.4 }}

[simulation]
cycles = 0.5
rtol = 1e-8
atol = 1e-11
"""

_GROUND_PINS = {
    "O": '[[joints]]\nname = "O"\nkind = "pin"\nbodies = ["ground", "crank"]\nat = [[0.0, 0.0], 0.0]\n',
    "P": '[[joints]]\nname = "P"\nkind = "pin"\nbodies = ["ground", "guide"]\nat = [[-0.6, 0.0], 0.0]\n',
    "Q": '[[joints]]\nname = "Q"\nkind = "pin"\nbodies = ["ground", "link2"]\nat = [[0.73, 0.5], 0.0]\n',
}


def test_a_bar_hanging_from_the_guide_pulls_on_it_as_a_cut_joints_force_does(tmp_path):
    """The guide's tension from the force of a bar at xi = 1 (DERIVE_VERSION 12): an inverted
    slider-crank whose guide's far end drives a dyad (link1 to link2, pinned to the ground). With the
    joints listed O, P, Q the spanning tree hangs link1 from the guide (B a tree joint: link1 follows
    the guide's shortened end, ``slot.SlotBarKinematics``, and its subtree resultant does virtual
    work on that shortening); listed O, Q, P it hangs link1 from link2 and B is a cut joint (its
    closure reads the same shortened end, its multipliers are a point force in the guide's
    equations with the weight int_0^1 psi'_a psi'_b). The two routes give the same motion to 1e-8
    of peak, and the tension (the dyad thrusts the guide by up to ~20 N, the guide's own centrifugal
    tension) moves the guide's deflections by percents (geometric_stiffening off)."""
    from symgen.api import mechanism, results_table
    from symgen.numerics.simulate import simulate

    def run(order: str, overrides: tuple = ()) -> tuple:
        text = _DYAD.format(grounded="\n".join(_GROUND_PINS[k] for k in order))
        path = write_scene(tmp_path / f"dyad_{order}_{len(overrides)}.toml", text)
        mech = mechanism(path, list(overrides))
        res = simulate(mech)
        assert res.complete, res.failure
        cols = results_table(res, mech.scene)
        return mech, {k: np.asarray(cols[k]) for k in ("guide_end", "guide_mid")}

    from symgen.model.derive import derive
    from symgen.model.topology import build_topology

    tree_mech, tree = run("OPQ")
    cut_mech, cut = run("OQP")
    assert build_topology(tree_mech.scene).edges["link1"].parent == "guide"
    assert build_topology(cut_mech.scene).edges["link1"].parent == "link2"
    kinds = {kind for kind, _ in derive(cut_mech.scene).bars["guide"].equations.inner_products.values()}
    assert "H1.0" in kinds  # the cut joint's force in the guide's equation (17)
    _, plain = run("OPQ", ("effects.geometric_stiffening=false",))
    for k in tree:
        peak = np.abs(tree[k]).max()
        assert np.abs(tree[k] - cut[k]).max() <= 1e-8 * peak, k
        assert np.abs(tree[k] - plain[k]).max() >= 0.02 * peak, k  # measured 4.2 % / 2.8 %


@pytest.mark.parametrize(("beta", "xp"), [(0.5, 1.0), (0.5, 0.3), (0.75, 0.3), (0.5, 0.8), (0.75, 0.9)])
def test_an_axial_point_force_stiffens_the_guide_as_finite_elements_do(beta, xp):
    """An axial point force P at xi_p pulls on [0, xi_p] (slot.point_tension_name: int_0^xi_p
    psi'_a psi'_b, piecewise in beta for an interior xi_p: on the span or on the overhang): the
    guide's frequencies with P = 30 (EI = m = 1) against finite elements with the same tension;
    without it they are several percent off."""
    P = 30.0
    basis = SlotBasis(2 + 5, BETA, 5)
    ipt = SlotIPTable(basis)
    at = {BETA: beta}
    nt = basis.nt
    num = lambda m: np.array(m.xreplace(at).evalf(), dtype=float)
    K, M = num(ipt.Kt), num(ipt.G[2 : 2 + nt, 2 : 2 + nt])
    from symgen.model.slot import point_tension_name

    H = num(ipt.matrix(point_tension_name(xp)))
    ref = _fe_frequencies_in_tension(beta, 0.0, 0.0, point=(P, xp))
    assert _fe_frequencies_in_tension(beta, 0.0, 0.0, 80, point=(P, xp)) == pytest.approx(ref, rel=2e-4)
    got = np.sqrt(sl.eigh(K + P * H, M, eigvals_only=True)[:2])
    assert got == pytest.approx(ref[:2], rel=3e-3)
    plain = np.sqrt(sl.eigh(K, M, eigvals_only=True)[:2])
    assert np.abs(plain / ref[:2] - 1).max() > 0.02


def test_a_guide_driving_a_dyad_runs_its_turn_and_its_range_is_not_read_with_other_bars_samples(tmp_path):
    """The range check read a slot guide's amplitudes with the fixed samples of a bar's own
    functions (a guide's psi(xi, beta) move with the contact): with 4 span functions this dyad
    scene stopped at 254 deg on "slope 0.70" while its guide's end deflects 2 % of its length
    (Exudyn's ANCF guide runs the turn, benchmarks/validation/README.md "session 15"). A guide's
    slopes are now read at the contact (``checks.guide_tables``, tests/test_guide_range.py): the
    record's largest is the model's own slope outputs' (at the far end and mid-span) or more, by
    at most the range points' spacing, and far below the stop. The slot's reaction (an internal error
    before: read as a ground slider's) is the slot force, normal to the guide but for the
    guide's slope at the contact: its chord-wise part stays below 5 % of its normal part."""
    import json

    from symgen.cli import main

    text = _DYAD.format(grounded="\n".join(_GROUND_PINS[k] for k in "OPQ"))
    text = text.replace("transverse_modes = 2", "transverse_modes = 4").replace("cycles = 0.5", "cycles = 1.0")
    text = text.replace("overhang_modes = 2", "mass = 0.05").replace(
        "[outputs]", "[effects]\ndamping = 0.01\n\n[outputs]"
    )
    text = text.replace(
        "[outputs]",
        '[outputs]\nAx = { kind = "reaction", joint = "A", component = "x" }\n'
        'Ay = { kind = "reaction", joint = "A", component = "y" }\nth = { kind = "angle", body = "guide" }\n'
        'sl_end = { kind = "slope", body = "guide", at = 1.0 }\nsl_mid = { kind = "slope", body = "guide", at = 0.4 }',
    )
    scene = write_scene(tmp_path / "dyad4.toml", text)
    out = tmp_path / "dyad4.csv"
    assert main(["simulate", str(scene), "-o", str(out), "--estimate", "off"]) == 0
    side = json.loads(out.with_suffix(".json").read_text())
    lines = out.read_text().splitlines()
    names = lines[0].split(",")
    data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    col = {k: data[:, names.index(k)] for k in ("Ax", "Ay", "th", "sl_end", "sl_mid")}
    own = max(np.abs(col["sl_end"]).max(), np.abs(col["sl_mid"]).max())
    largest = side["range"]["largest_slope"]["guide"]["slope"]
    assert "not_checked" not in side["range"] and 0.995 * own <= largest < 0.2
    c, s = np.cos(col["th"]), np.sin(col["th"])
    along, normal = col["Ax"] * c + col["Ay"] * s, -col["Ax"] * s + col["Ay"] * c
    assert np.abs(normal).max() > 1.0  # newtons: the slot carries the guide's load
    assert np.abs(along).max() < 0.05 * np.abs(normal).max()


@pytest.mark.parametrize("nspan, nover", [(3, 0), (2, 4), (4, 2)])
def test_curvature_table_matches_quadrature(nspan, nover):
    """The guide's curvature to fourth order (DERIVE_VERSION 13, slot._curvature_gram):
    E4[(a, b), (c, d)] = int_0^1 psi'_a psi'_b psi''_c psi''_d, a power of beta on the span and of
    1 - beta on the overhang times a number, against Gauss quadrature of the functions' own
    derivatives at two contact positions (span and overhang apart: the curvature jumps there)."""
    from symgen.model.slot import CURVATURE, curvature_pairs

    basis = SlotBasis(nspan + nover, BETA, nover)
    E4 = SlotIPTable(basis).matrix(CURVATURE)
    pairs = curvature_pairs(basis.nt)
    x, wq = np.polynomial.legendre.leggauss(120)
    for beta in (0.41, 0.66):
        at = {BETA: beta}

        def d(k: int, n: int, piece: int) -> tuple[np.ndarray, np.ndarray]:
            lo, hi = ((0.0, beta), (beta, 1.0))[piece]
            xi = lo + (hi - lo) * (x + 1) / 2
            f = sp.lambdify(XI, _derivative(k + 1, BETA, nspan, nover, n, 0)[piece].xreplace(at), "numpy")
            return np.broadcast_to(np.asarray(f(xi), dtype=float), xi.shape), wq * (hi - lo) / 2

        got = np.array(E4.xreplace(at).evalf(), dtype=float)
        want = np.zeros_like(got)
        for piece in (0, 1):
            s1 = [d(k, 1, piece) for k in range(basis.nt)]
            s2 = [d(k, 2, piece)[0] for k in range(basis.nt)]
            for i, (a, b) in enumerate(pairs):
                for j, (c, e) in enumerate(pairs):
                    want[i, j] += np.sum(s1[a][1] * s1[a][0] * s1[b][0] * s2[c] * s2[e])
        assert np.abs(got - want).max() <= 1e-10 * np.abs(want).max()
        assert np.abs(want).max() > 1.0


def test_guide_curvature_is_generated_only_where_called_for():
    """The guide's fourth-order curvature (E4) and its shortening's kinetic energy (Z) go with the
    effects that bend the guide beyond the seed's linear model: there by default, absent with the
    seed's linear strain or without geometric stiffening (a switched-off term is never
    generated). Shown as the symbols of ``bars._shown_as`` (their tables not listed in the LaTeX),
    whose values are the terms."""
    from symgen.model.derive import derive

    shown = {sp.Symbol(r"\mathcal{E}_{1}"), sp.Symbol(r"\mathcal{Z}_{1}")}

    def terms(overrides: list[str]) -> set:
        model = derive(load_scene(SCENE, overrides))
        values = model.bars["guide"].equations.values
        return {sym for sym in shown if sym in values and values[sym] != 0}

    assert terms([]) == shown
    assert not terms(["effects.strain=linear"])
    assert not terms(["effects.geometric_stiffening=false"])


@pytest.mark.parametrize("nspan, nover", [(3, 0), (2, 4)])
def test_shortening_table_matches_quadrature(nspan, nover):
    """The kinetic energy of the guide's shortening (DERIVE_VERSION 14, slot._shortening_gram):
    Z[(a, b), (c, d)] = int_0^1 H_ab H_cd, H_ab(xi) = int_0^xi psi'_a psi'_b, a sum of numbers times
    powers of beta and 1 - beta, against H integrated cumulatively (Simpson on a fine grid, the
    contact a grid point) from the functions' own slopes at two contact positions."""
    from symgen.model.slot import SHORTENING, curvature_pairs

    basis = SlotBasis(nspan + nover, BETA, nover)
    Z = SlotIPTable(basis).matrix(SHORTENING)
    pairs = curvature_pairs(basis.nt)
    for beta in (0.4, 0.7):
        at = {BETA: beta}
        n = 4000  # intervals per piece
        xi = np.concatenate([np.linspace(0.0, beta, n + 1), np.linspace(beta, 1.0, n + 1)[1:]])
        slopes = []
        for k in range(basis.nt):
            s_, o_ = (sp.lambdify(XI, e.xreplace(at), "numpy") for e in _derivative(k + 1, BETA, nspan, nover, 1, 0))
            span, over = xi <= beta, xi > beta
            v = np.zeros_like(xi)
            v[span] = np.broadcast_to(s_(xi[span]), xi[span].shape)
            v[over] = np.broadcast_to(o_(xi[over]), xi[over].shape)
            slopes.append(v)

        def cumulative(f: np.ndarray) -> np.ndarray:
            out = np.zeros_like(f)
            out[1:] = np.cumsum((f[1:] + f[:-1]) / 2 * np.diff(xi))
            return out

        H = [cumulative(slopes[a] * slopes[b]) for a, b in pairs]
        got = np.array(Z.xreplace(at).evalf(), dtype=float)
        want = np.array([[np.trapezoid(Hp * Hq, xi) for Hq in H] for Hp in H])
        assert np.abs(got - want).max() <= 1e-6 * np.abs(want).max()
        assert np.abs(want).max() > 1.0
