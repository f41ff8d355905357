"""Static correction functions at interior points of elastic bars (issue 12, Deliver 1).

Oracles: Euler-Bernoulli closed forms for point-load deflections, and an independent numpy
Hermite finite-element model for the natural frequencies of a beam with an interior pin.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate as si
import scipy.linalg as sl

from symgen.model.shapes import axial_basis, transverse_basis
from symgen.model.static_shapes import Piecewise, piecewise_inner, static_correction
from tests.oracles import hermite_beam_frequencies

A = 0.3  # load / support point (a float, as a scene gives it)


def _ritz_static(fs, a, xs):
    """Rayleigh-Ritz static deflection (EI = 1, l = 1) under a unit transverse force at a."""
    K = np.array([[piecewise_inner(f, g, 2) for g in fs] for f in fs])
    F = np.array([f.value(a) for f in fs])
    q = np.linalg.solve(K, F)
    return np.array([q @ np.array([f.value(x) for f in fs]) for x in xs])


def _pp_deflection(x, a):
    """Pinned-pinned beam, unit force at a: P b x (l^2 - b^2 - x^2) / (6 EI l) left of a."""
    b = 1 - a
    return np.where(x <= a, b * x * (1 - b * b - x * x) / 6, a * (1 - x) * (1 - a * a - (1 - x) ** 2) / 6)


def _cantilever_deflection(x, a):
    return np.where(x <= a, x * x * (3 * a - x) / 6, a * a * (3 * x - a) / 6)


XS = np.linspace(0.05, 0.95, 10)


@pytest.mark.parametrize("n", [2, 3])
def test_pinned_pinned_point_load_deflection(n):
    basis = list(transverse_basis("pinned-pinned", "modes", n).functions)
    chi = static_correction("pinned-pinned", A, basis)
    exact_a = A * A * (1 - A) ** 2 / 3  # P a^2 b^2 / (3 EI l)
    w = _ritz_static(basis + [chi], A, [A, *XS])
    assert w[0] == pytest.approx(exact_a, rel=5e-3)
    assert np.max(np.abs(w[1:] - _pp_deflection(XS, A))) < 5e-3 * exact_a
    # without the correction the error at the load point is larger than the tolerance
    w0 = _ritz_static(basis, A, [A])
    assert abs(w0[0] / exact_a - 1) > 5e-3


def test_cantilever_point_load_deflection():
    basis = list(transverse_basis("cantilever", "eigen", 3).functions)
    chi = static_correction("cantilever", A, basis)
    w = _ritz_static(basis + [chi], A, [A, *XS])
    assert w[0] == pytest.approx(A**3 / 3, rel=5e-3)
    assert np.max(np.abs(w[1:] - _cantilever_deflection(XS, A))) < 5e-3 * A**3 / 3
    w0 = _ritz_static(basis, A, [A])
    assert abs(w0[0] / (A**3 / 3) - 1) > 5e-3


def test_axial_point_force():
    """u(0) = 0, free end, unit axial force at a: u = min(xi, a) (EA = 1)."""
    basis = list(axial_basis("stress-free", 2).functions)
    chi = static_correction("axial", A, basis)
    fs = basis + [chi]
    K = np.array([[piecewise_inner(f, g, 1) for g in fs] for f in fs])
    F = np.array([f.value(A) for f in fs])
    q = np.linalg.solve(K, F)
    u = np.array([q @ np.array([f.value(x) for f in fs]) for x in XS])
    assert np.max(np.abs(u - np.minimum(XS, A))) < 1e-9
    q0 = np.linalg.solve(K[:2, :2], F[:2])
    assert abs(q0 @ F[:2] / A - 1) > 5e-3


def _fe_pinned_with_interior_pin(a, ne=120):
    """First three circular frequencies (EI = rho A = l = 1) of a pinned-pinned beam with a pin at a."""
    return hermite_beam_frequencies(a, ne, far_end_pinned=True)


def _ritz_frequencies(fs, a):
    K = np.array([[piecewise_inner(f, g, 2) for g in fs] for f in fs])
    M = np.array([[piecewise_inner(f, g, 0) for g in fs] for f in fs])
    Z = sl.null_space(np.array([[f.value(a) for f in fs]]))  # the pin: w(a) = 0
    return np.sqrt(sl.eigh(Z.T @ K @ Z, Z.T @ M @ Z, eigvals_only=True)[:3])


def test_interior_pin_frequencies():
    ref = _fe_pinned_with_interior_pin(A)
    basis = list(transverse_basis("pinned-pinned", "modes", 4).functions)
    chi = static_correction("pinned-pinned", A, basis)
    w = _ritz_frequencies(basis + [chi], A)
    assert np.max(np.abs(w / ref - 1)) < 5e-3
    w0 = _ritz_frequencies(list(transverse_basis("pinned-pinned", "modes", 5).functions), A)
    assert np.max(np.abs(w0 / ref - 1)) > 5e-3


def test_closed_form_integrals_match_quadrature():
    """The piecewise closed-form inner products against adaptive quadrature, for products with
    sin terms (pinned) and exp/sin terms (clamped-free eigenfunctions)."""
    for frame, fam in (("pinned-pinned", "modes"), ("cantilever", "eigen")):
        basis = list(transverse_basis(frame, fam, 3).functions)
        chi = static_correction(frame, A, basis)
        for f in basis + [chi]:
            for d in (0, 2):
                num = sum(
                    si.quad(lambda x: chi.value(x, d) * f.value(x, d), lo, hi, epsabs=1e-13, epsrel=1e-12)[0]
                    for lo, hi in ((0, A), (A, 1))
                )
                assert piecewise_inner(chi, f, d) == pytest.approx(num, rel=1e-9, abs=1e-11)
        # orthogonal (mass) to the others, value 1 at the point
        assert max(abs(piecewise_inner(chi, f)) for f in basis) < 1e-12
        assert chi.value(A) == pytest.approx(1.0, rel=1e-12)


def test_static_shape_kink_and_continuity():
    chi = static_correction("pinned-pinned", A, [])
    pw = Piecewise.of(chi)
    for d in (0, 1, 2):
        assert pw.value(A, d, right=False) == pytest.approx(pw.value(A, d, right=True), abs=1e-12)
    # unit jump of the shear force w''' at the point (scaled by 1/t)
    jump = pw.value(A, 3, right=True) - pw.value(A, 3, right=False)
    assert jump * chi.scale == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("xi", [0.0, 1.0, -0.2, 1.5])
def test_point_must_be_inside(xi):
    with pytest.raises(ValueError, match="inside the bar"):
        static_correction("pinned-pinned", xi, [])


def test_unknown_kind():
    with pytest.raises(ValueError, match="unknown static correction kind"):
        static_correction("free-free", 0.5, [])


@pytest.mark.parametrize("frame,family", [("pinned-pinned", "modes"), ("cantilever", "eigen")])
def test_piecewise_inner_products_reproduce_the_exact_engine(frame, family):
    from symgen.model.shape_cache import inner_products
    from symgen.model.static_shapes import piecewise_inner_products

    ba, bt = axial_basis("stress-free", 2), transverse_basis(frame, family, 3)
    ref = inner_products(ba, bt)
    pw = piecewise_inner_products(ba.functions, bt.functions)
    for name in ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4"):
        np.testing.assert_allclose(getattr(pw, name), getattr(ref, name), rtol=1e-12, atol=1e-12)


def test_piecewise_inner_products_with_corrections_match_quadrature():
    from symgen.model.static_shapes import piecewise_inner_products

    ba, bt = axial_basis("stress-free", 2), transverse_basis("pinned-pinned", "modes", 3)
    cha = static_correction("axial", A, ba.functions)
    chi = static_correction("pinned-pinned", A, bt.functions)
    phi, psi = list(ba.functions) + [cha], list(bt.functions) + [chi]
    ip = piecewise_inner_products(phi, psi)

    def quad(fn):
        return sum(si.quad(fn, lo, hi, epsabs=1e-13, epsrel=1e-12)[0] for lo, hi in ((0, A), (A, 1)))

    d1 = psi[3].value
    assert ip.D4[3, 3, 3, 3] == pytest.approx(quad(lambda x: d1(x, 1) ** 4), rel=1e-9)
    assert ip.D4[0, 3, 3, 1] == pytest.approx(
        quad(lambda x: psi[0].value(x, 1) * d1(x, 1) ** 2 * psi[1].value(x, 1)), rel=1e-9, abs=1e-11
    )
    assert ip.C3[2, 3, 0] == pytest.approx(
        quad(lambda x: cha.value(x, 1) * d1(x, 1) * psi[0].value(x, 1)), rel=1e-9, abs=1e-11
    )
    assert ip.Ka[2, 2] == pytest.approx(quad(lambda x: cha.value(x, 1) ** 2), rel=1e-9)
    assert ip.gram[1, 2 + 2] == pytest.approx(quad(lambda x: x * cha.value(x)), rel=1e-9)
    assert ip.psid1[3] == pytest.approx(chi.value(1) - chi.value(0), abs=1e-12)


# --------------------------------------------------------------------------------------
# Moment correction functions (a unit couple at xi_K: a rigid body with an inertia or an arm)
# --------------------------------------------------------------------------------------
def _couple_deflection(closed_form, x, a, h=1e-5):
    """The deflection under a unit couple at a, from the point-force closed forms above: a couple
    is the limit of the force pair (+1/h at a + h, -1/h at a), so it is d/da of the force's
    deflection (central differences; independent of symgen's moment polynomials)."""
    return (closed_form(x, a + h / 2) - closed_form(x, a - h / 2)) / h


def _ritz_couple(fs, a, xs):
    """Rayleigh-Ritz static deflection (EI = 1, l = 1) under a unit couple at a: the load vector
    is the functions' slopes at a (the couple's virtual work M dw'(a))."""
    K = np.array([[piecewise_inner(f, g, 2) for g in fs] for f in fs])
    F = np.array([f.value(a, 1) for f in fs])
    q = np.linalg.solve(K, F)
    return np.array([q @ np.array([f.value(x) for f in fs]) for x in xs])


@pytest.mark.parametrize(
    "frame, family, closed_form",
    [("pinned-pinned", "modes", _pp_deflection), ("cantilever", "eigen", _cantilever_deflection)],
)
def test_moment_correction_gives_the_couple_deflection(frame, family, closed_form):
    """The bar's functions, the force correction and the moment correction at a hold the exact
    static deflection under a unit couple at a (the Ritz solution matches the closed form to
    1e-8 of its peak); without the moment correction it misses it by more than 0.5 %."""
    basis = list(transverse_basis(frame, family, 3).functions)
    force = static_correction(frame, A, basis)
    couple = static_correction(frame, A, basis + [force], load="moment")
    xs = np.array([A, *XS])
    exact = _couple_deflection(closed_form, xs, A)
    peak = np.abs(_couple_deflection(closed_form, np.linspace(0, 1, 201), A)).max()
    w = _ritz_couple(basis + [force, couple], A, xs)
    assert np.abs(w - exact).max() < 1e-8 * peak, (w, exact)
    w0 = _ritz_couple(basis + [force], A, xs)
    assert np.abs(w0 - exact).max() > 5e-3 * peak


@pytest.mark.parametrize("frame, family", [("pinned-pinned", "modes"), ("cantilever", "eigen")])
def test_moment_correction_is_orthogonal_continuous_with_a_curvature_jump(frame, family):
    """Mass-orthogonal to every function before it (the force correction too), slope 1 at the
    point, w and w' continuous there and w'' jumping by -1 (the unit couple's bending moment,
    scaled by 1/t); its closed-form inner products match quadrature."""
    basis = list(transverse_basis(frame, family, 3).functions)
    force = static_correction(frame, A, basis)
    others = basis + [force]
    chi = static_correction(frame, A, others, load="moment")
    assert chi.load == "moment" and chi.label == r"\chi^{M}_{0.3}"
    assert max(abs(piecewise_inner(chi, f)) for f in others) < 1e-12
    assert chi.value(A, 1) == pytest.approx(1.0, rel=1e-12)
    pw = Piecewise.of(chi)
    for d in (0, 1):
        assert pw.value(A, d, right=False) == pytest.approx(pw.value(A, d, right=True), abs=1e-12)
    jump = pw.value(A, 2, right=True) - pw.value(A, 2, right=False)
    assert jump * chi.scale == pytest.approx(-1.0, rel=1e-12)
    for f in others + [chi]:
        for d in (0, 1, 2):
            num = sum(
                si.quad(lambda x: chi.value(x, d) * f.value(x, d), lo, hi, epsabs=1e-13, epsrel=1e-12)[0]
                for lo, hi in ((0, A), (A, 1))
            )
            assert piecewise_inner(chi, f, d) == pytest.approx(num, rel=1e-9, abs=1e-11)


def test_an_axial_moment_correction_is_refused():
    with pytest.raises(ValueError, match="'moment' for a transverse kind"):
        static_correction("axial", A, [], load="moment")
    with pytest.raises(ValueError, match="unknown static load"):
        static_correction("cantilever", A, [], load="torque")
