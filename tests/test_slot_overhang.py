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
from symgen.model.slot import XI, SlotBasis, SlotIPTable
from symgen.model.structure import effective_modes, overhang_modes, structure_of
from tests.oracles import write_scene
from tests.test_slot import FROZEN, frozen_frequencies

BETA = sp.Symbol("beta_A", real=True)
SCENE = "examples/inverted_slider_crank.toml"


def _matrices(nspan: int, nover: int, beta: float):
    basis = SlotBasis(nspan + nover, BETA, nover)
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
    xs = np.unique(
        np.concatenate([np.linspace(0.0, beta, round(n * beta) + 1), np.linspace(beta, 1.0, round(n * (1 - beta)) + 1)])
    )
    N = len(xs)
    K, M = np.zeros((2 * N, 2 * N)), np.zeros((2 * N, 2 * N))
    for e in range(N - 1):
        L = xs[e + 1] - xs[e]
        k = (
            np.array(
                [
                    [12, 6 * L, -12, 6 * L],
                    [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                    [-12, -6 * L, 12, -6 * L],
                    [6 * L, 2 * L * L, -6 * L, 4 * L * L],
                ]
            )
            / L**3
        )
        m = (
            L
            / 420
            * np.array(
                [
                    [156, 22 * L, 54, -13 * L],
                    [22 * L, 4 * L * L, 13 * L, -3 * L * L],
                    [54, 13 * L, 156, -22 * L],
                    [-13 * L, -3 * L * L, -22 * L, 4 * L * L],
                ]
            )
        )
        idx = np.arange(2 * e, 2 * e + 4)
        K[np.ix_(idx, idx)] += k
        M[np.ix_(idx, idx)] += m
    support = int(np.argmin(abs(xs - beta)))
    free = [i for i in range(2 * N) if i not in (0, 2 * support)]
    return np.sqrt(sl.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True)[:3])


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
    """Every function (span and overhang) is 0 at the contact with continuous value and slope
    there (eta stays C1) and continuous curvature (so psi_beta keeps a continuous slope);
    psi_betabeta is continuous (eta'' stays square-integrable with no point mass at the contact)."""
    basis = SlotBasis(5, BETA, 3)
    assert [f.label for f in basis.functions][2:] == [r"\chi_{1}", r"\chi_{2}", r"\chi_{3}"]
    for fn in basis.functions:
        assert sp.simplify(fn.span.xreplace({XI: BETA})) == 0
        for order in range(3):
            s, o = sp.diff(fn.span, BETA, order), sp.diff(fn.overhang, BETA, order)
            for d in range(3 - order):
                assert sp.simplify((sp.diff(s, XI, d) - sp.diff(o, XI, d)).xreplace({XI: BETA})) == 0


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
    assert effective_modes(scene, scene.body("guide")) == (0, 3 + 4)


def test_scene_keys_default_and_rigid():
    scene = load_scene(SCENE, ["joints.A.overhang=elastic"])  # the example sets the seed's form
    guide = scene.body("guide")
    assert overhang_modes(scene, guide) == 4
    assert effective_modes(scene, guide) == (0, guide.transverse_modes + 4)
    rigid = load_scene(SCENE)
    assert effective_modes(rigid, rigid.body("guide")) == (0, guide.transverse_modes)
    assert structure_of(rigid) != structure_of(scene)
    assert overhang_modes(load_scene(SCENE, ["joints.A.overhang=elastic", "joints.A.overhang_modes=5"]), guide) == 5


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
    assert r"($\chi_1, \dots, \chi_{4}$" in doc and r"\psi_{6}(\xi, \beta)" in doc
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
