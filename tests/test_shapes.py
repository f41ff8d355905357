"""Tests of symgen.model.shapes against independent oracles.

The oracle functions below are written directly in numpy (the eigenfunctions in the
cancellation-free form ``A e^{b x} + B e^{-b x} - cos(b x) + sigma sin(b x)`` with
``1 - sigma`` from its own stable formula and roots from ``scipy.optimize.brentq``), and
every inner product is checked against ``scipy.integrate.quad`` of them.
"""

from __future__ import annotations

import itertools
import math
import pickle
import warnings
from collections.abc import Callable

import mpmath
import numpy as np
import pytest
import sympy
from scipy import integrate, optimize

from symgen.model import shape_cache as C
from symgen.model import shapes as S
from symgen.model import terms as T

Fn = Callable[[float, int], float]  # f(x, derivative order)
TOL = 1e-10


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory, monkeypatch):
    """Never touch the user's ~/.cache from the tests."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "symgen-cache"))


# ----------------------------------------------------------------------------- oracles
def _poly(coeffs: dict[int, float]) -> Fn:
    def f(x: float, d: int = 0) -> float:
        tot = 0.0
        for p, c in coeffs.items():
            if p >= d:
                tot += c * math.perm(p, d) * x ** (p - d)
        return tot

    return f


def _sin(w: float) -> Fn:
    """sin(w x) and its derivatives."""
    return lambda x, d=0: w**d * math.sin(w * x + d * math.pi / 2)


def oracle_roots(n: int) -> list[float]:
    """Roots of cos b cosh b = -1 by bracketing, one in each ((k-1) pi, k pi)."""
    f = lambda b: math.cos(b) + 1.0 / math.cosh(b)
    return [optimize.brentq(f, (k - 1) * math.pi + 1e-9, k * math.pi, xtol=1e-15, rtol=1e-15) for k in range(1, n + 1)]


def _eigen(beta: float) -> Fn:
    """Clamped-free eigenfunction, stable form, normalised to 1 at the tip."""
    one_minus_sigma = (math.sin(beta) - math.cos(beta) - math.exp(-beta)) / (math.sinh(beta) + math.sin(beta))
    sigma = 1.0 - one_minus_sigma
    A, B = one_minus_sigma / 2, 1.0 - one_minus_sigma / 2

    def raw(x: float, d: int = 0) -> float:
        return (
            A * beta**d * math.exp(beta * x)
            + B * (-beta) ** d * math.exp(-beta * x)
            - beta**d * math.cos(beta * x + d * math.pi / 2)
            + sigma * beta**d * math.sin(beta * x + d * math.pi / 2)
        )

    tip = raw(1.0)
    return lambda x, d=0: raw(x, d) / tip


def oracle_axial(family: str, n: int) -> list[Fn]:
    if family == "complete":
        return [_poly({1: 1.0})] + [_sin(k * math.pi) for k in range(1, n)] if n else []
    return [_sin((2 * k - 1) * math.pi / 2) for k in range(1, n + 1)]


def oracle_transverse(frame: str, family: str, n: int, tip: bool) -> list[Fn]:
    if frame == "pinned-pinned":
        if family == "polynomial":
            return [_poly({k: 1.0, k + 1: -1.0}) for k in range(1, n + 1)]
        return [_sin(k * math.pi) for k in range(1, n + 1)]
    if family == "polynomial":
        return [_poly({k + 1: 1.0}) for k in range(1, n + 1)]
    eig = [_eigen(b) for b in oracle_roots(n - (1 if family == "modes" and tip and n else 0))]
    if family == "modes" and tip and n:
        # the static tip-load shape, made orthogonal to the eigenfunctions that follow it
        # (mass inner product, by quadrature here) and scaled to 1 at the tip
        static = _poly({2: 1.5, 3: -0.5})
        c = [quad(lambda x, f=f: static(x) * f(x)) / quad(lambda x, f=f: f(x) ** 2) for f in eig]

        def rest(x: float, d: int = 0) -> float:
            return static(x, d) - sum(ck * f(x, d) for ck, f in zip(c, eig))

        tip_value = rest(1.0)
        return [lambda x, d=0: rest(x, d) / tip_value] + eig
    return eig


def quad(f: Callable[[float], float]) -> float:
    with warnings.catch_warnings():  # asking for ~1e-13 makes QUADPACK warn of roundoff
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        val, _err = integrate.quad(f, 0.0, 1.0, epsabs=1e-14, epsrel=1e-13, limit=400)
    return val


def close(got: float, ref: float, tol: float = TOL) -> bool:
    return abs(got - ref) <= tol * max(1.0, abs(ref))


CASES = [
    # (axial family, na, frame, transverse family, nt, tip_joint)
    ("complete", 4, "pinned-pinned", "modes", 4, False),
    ("stress-free", 3, "pinned-pinned", "modes", 3, False),
    ("complete", 3, "pinned-pinned", "polynomial", 4, False),
    ("complete", 3, "cantilever", "eigen", 6, False),
    ("stress-free", 2, "cantilever", "modes", 5, True),
    ("complete", 2, "cantilever", "polynomial", 3, False),
]


def _case_id(c: tuple) -> str:
    return f"{c[0]}{c[1]}-{c[2]}-{c[3]}{c[4]}{'-tip' if c[5] else ''}"


# ----------------------------------------------------------------------------- inner products
@pytest.mark.parametrize("case", CASES, ids=_case_id)
def test_every_inner_product_matches_quadrature(case):
    afam, na, frame, tfam, nt, tip = case
    ip = C.inner_products(S.axial_basis(afam, na), S.transverse_basis(frame, tfam, nt, tip))
    phi = oracle_axial(afam, na)
    psi = oracle_transverse(frame, tfam, nt, tip)
    assert (ip.na, ip.nt) == (na, nt)
    # the orthogonalised tip-load shape is a small remainder (~1e-4 of its parts): the
    # double-precision oracle loses digits to that cancellation, the 50-digit code does not
    tol = 1e-8 if (tfam == "modes" and tip) else TOL

    b = [_poly({0: 1.0}), _poly({1: 1.0})] + phi + psi
    N = len(b)
    assert ip.gram.shape == (N, N)
    for i, j in itertools.product(range(N), repeat=2):
        ref = quad(lambda x: b[i](x, 0) * b[j](x, 0))
        assert close(ip.gram[i, j], ref, tol), ("gram", i, j, ip.gram[i, j], ref)

    for i, j in itertools.product(range(na), repeat=2):
        ref = quad(lambda x: phi[i](x, 1) * phi[j](x, 1))
        assert close(ip.Ka[i, j], ref, tol), ("Ka", i, j, ip.Ka[i, j], ref)
    for i, j in itertools.product(range(nt), repeat=2):
        ref = quad(lambda x: psi[i](x, 2) * psi[j](x, 2))
        assert close(ip.Kt[i, j], ref, tol), ("Kt", i, j, ip.Kt[i, j], ref)
        ref = quad(lambda x: psi[i](x, 1) * psi[j](x, 1))
        assert close(ip.Pd[i, j], ref, tol), ("Pd", i, j, ip.Pd[i, j], ref)
    for i in range(nt):
        ref = quad(lambda x: psi[i](x, 1))
        assert close(ip.psid1[i], ref, tol), ("psid1", i)
        assert close(ip.psid1[i], psi[i](1.0) - psi[i](0.0))

    assert ip.C3.shape == (na, nt, nt)
    for k, a, c in itertools.product(range(na), range(nt), range(nt)):
        ref = quad(lambda x: phi[k](x, 1) * psi[a](x, 1) * psi[c](x, 1))
        assert close(ip.C3[k, a, c], ref, tol), ("C3", k, a, c, ip.C3[k, a, c], ref)

    # D4: one quadrature per unordered index set, every entry compared with it
    assert ip.D4.shape == (nt,) * 4
    refs = {}
    for idx in itertools.combinations_with_replacement(range(nt), 4):
        refs[idx] = quad(lambda x: math.prod(psi[m](x, 1) for m in idx))
    for idx in itertools.product(range(nt), repeat=4):
        ref = refs[tuple(sorted(idx))]
        assert close(ip.D4[idx], ref, tol), ("D4", idx, ip.D4[idx], ref)


@pytest.mark.parametrize("case", CASES, ids=_case_id)
def test_exact_tables_agree_with_floats(case):
    afam, na, frame, tfam, nt, tip = case
    ip = C.inner_products(S.axial_basis(afam, na), S.transverse_basis(frame, tfam, nt, tip))
    for name in ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4"):
        arr = getattr(ip, name)
        ex = ip.exact[name]
        exf = np.array(ex.tolist(), dtype=float).reshape(arr.shape)
        assert np.allclose(exf, arr, rtol=1e-14, atol=1e-14), name
        assert not arr.flags.writeable, f"{name} must be read-only (shared through the cache)"
    exact_family = frame == "pinned-pinned" or tfam == "polynomial"
    if exact_family:  # no Float anywhere
        for name in ("gram", "Kt", "C3", "D4"):
            assert not any(
                isinstance(e, sympy.Float) or e.atoms(sympy.Float) for e in sympy.flatten(ip.exact[name].tolist())
            ), name


def test_exact_values():
    ip = C.inner_products(S.axial_basis("stress-free", 1), S.transverse_basis("pinned-pinned", "modes", 1))
    g = ip.exact["gram"]  # b = [1, xi, sin(pi xi / 2), sin(pi xi)]
    pi = sympy.pi
    assert sympy.simplify(g[2, 3] - 4 / (3 * pi)) == 0
    assert sympy.simplify(g[1, 3] - 1 / pi) == 0
    assert sympy.simplify(g[3, 3] - sympy.Rational(1, 2)) == 0
    assert sympy.simplify(g[2, 2] - sympy.Rational(1, 2)) == 0
    assert sympy.simplify(g[0, 2] - 2 / pi) == 0
    assert sympy.simplify(ip.exact["Kt"][0, 0] - pi**4 / 2) == 0
    assert sympy.simplify(ip.exact["Ka"][0, 0] - pi**2 / 8) == 0
    assert sympy.simplify(ip.exact["Pd"][0, 0] - pi**2 / 2) == 0
    assert sympy.simplify(ip.exact["D4"][0, 0, 0, 0] - 3 * pi**4 / 8) == 0  # int pi^4 cos^4
    assert ip.exact["psid1"][0, 0] == 0
    # int (pi/2) cos(pi x/2) pi^2 cos^2(pi x) dx = pi^2 (1/2 + ... ) closed form by sympy
    x = S.XI
    ref = sympy.integrate(pi / 2 * sympy.cos(pi * x / 2) * pi**2 * sympy.cos(pi * x) ** 2, (x, 0, 1))
    assert sympy.simplify(ip.exact["C3"][0, 0, 0] - ref) == 0
    assert ip.gram[2, 3] == pytest.approx(4 / (3 * math.pi), rel=1e-15)
    assert ip.Kt[0, 0] == pytest.approx(math.pi**4 / 2, rel=1e-15)


def test_polynomial_exact_values():
    ip = C.inner_products(S.axial_basis("complete", 1), S.transverse_basis("pinned-pinned", "polynomial", 1))
    # psi = x(1-x): (psi, psi) = 1/30, (psi', psi') = 1/3, (psi'', psi'') = 4, D4 = 1/5
    assert ip.exact["gram"][3, 3] == sympy.Rational(1, 30)
    assert ip.exact["Pd"][0, 0] == sympy.Rational(1, 3)
    assert ip.exact["Kt"][0, 0] == 4
    assert ip.exact["D4"][0, 0, 0, 0] == sympy.Rational(1, 5)
    assert ip.exact["Ka"][0, 0] == 1


# ----------------------------------------------------------------------------- eigenfunctions
def test_eigen_roots_published():
    published = [1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839]
    roots = S.clamped_free_roots(5)
    assert np.allclose(roots, published, atol=6e-9)
    assert np.allclose(roots, oracle_roots(5), rtol=1e-14)
    t = S.transverse_basis("cantilever", "eigen", 8)
    assert [f.beta for f in t.functions] == list(S.clamped_free_roots(8))
    # the 50-digit roots satisfy cos(b) cosh(b) = -1 far beyond double precision
    with mpmath.workdps(60):
        for k in range(1, 9):
            beta = mpmath.mpf(T.MP.nstr(T.beta_mp(k), 50))
            assert abs(mpmath.cos(beta) * mpmath.cosh(beta) + 1) < mpmath.mpf(10) ** -45 * mpmath.cosh(beta)
    assert [f.label for f in t.functions[:2]] == [r"X_1(\xi)", r"X_2(\xi)"]


def test_eigen_orthogonality_and_rayleigh_quotient():
    nt = 8
    t = S.transverse_basis("cantilever", "eigen", nt)
    ip = C.inner_products(S.axial_basis("complete", 6), t)
    G = ip.gram[-nt:, -nt:]
    K = ip.Kt
    scale = np.sqrt(np.outer(np.diag(G), np.diag(G)))
    off = ~np.eye(nt, dtype=bool)
    assert np.max(np.abs(G[off] / scale[off])) < 1e-13
    kscale = np.sqrt(np.outer(np.diag(K), np.diag(K)))
    assert np.max(np.abs(K[off] / kscale[off])) < 1e-13
    betas = np.array([f.beta for f in t.functions])
    assert np.allclose(np.diag(K), betas**4 * np.diag(G), rtol=1e-13)
    # tip normalisation recorded
    for f in t.functions:
        assert abs(abs(f.tip_value) - 2.0) < 0.05  # |X_k(1)| -> 2 for clamped-free
        assert f.value(1.0) == pytest.approx(1.0, abs=1e-14)


def test_tip_shape_comes_first_and_counts():
    t = S.transverse_basis("cantilever", "modes", 3, tip_joint=True)
    assert len(t) == 3 and t.tip_joint
    assert t.functions[0].label == r"[\xi^2(3-\xi)/2]_{\perp X_{1..2}}"
    # the first function is the tip-load shape minus its projection on X_1, X_2: orthogonal
    # to them, 1 at the tip, and with the tip shear no eigenfunction has
    ip = C.inner_products(S.axial_basis("complete", 0), t)
    assert abs(ip.gram[2, 3]) < 1e-12 and abs(ip.gram[2, 4]) < 1e-12
    assert t.functions[0].value(1.0) == pytest.approx(1.0, abs=1e-13)
    assert abs(t.functions[0].value(1.0, 3)) > 1.0
    assert np.linalg.cond(ip.gram[2:, 2:]) < 10
    assert [f.label for f in t.functions[1:]] == [r"X_1(\xi)", r"X_2(\xi)"]
    no_tip = S.transverse_basis("cantilever", "modes", 3, tip_joint=False)
    assert not no_tip.tip_joint and no_tip.family == "modes"
    assert no_tip.functions == S.transverse_basis("cantilever", "eigen", 3).functions
    # tip_joint is irrelevant (and normalised away) where there is no tip shape
    assert not S.transverse_basis("cantilever", "eigen", 3, tip_joint=True).tip_joint
    assert not S.transverse_basis("pinned-pinned", "modes", 3, tip_joint=True).tip_joint
    assert len(S.transverse_basis("cantilever", "modes", 1, tip_joint=True)) == 1


# ----------------------------------------------------------------------------- point values
ALL_BASES = [
    (("axial", "complete", 5), oracle_axial("complete", 5)),
    (("axial", "stress-free", 4), oracle_axial("stress-free", 4)),
    (("pinned-pinned", "modes", 4, False), oracle_transverse("pinned-pinned", "modes", 4, False)),
    (("pinned-pinned", "eigen", 3, False), oracle_transverse("pinned-pinned", "eigen", 3, False)),
    (("pinned-pinned", "polynomial", 4, False), oracle_transverse("pinned-pinned", "polynomial", 4, False)),
    (("cantilever", "eigen", 10, False), oracle_transverse("cantilever", "eigen", 10, False)),
    (("cantilever", "modes", 4, True), oracle_transverse("cantilever", "modes", 4, True)),
    (("cantilever", "polynomial", 4, False), oracle_transverse("cantilever", "polynomial", 4, False)),
]


def _make(spec: tuple) -> S.Basis:
    if spec[0] == "axial":
        return S.axial_basis(spec[1], spec[2])
    return S.transverse_basis(*spec)


@pytest.mark.parametrize("spec,oracle", ALL_BASES, ids=[str(s[0]) for s in ALL_BASES])
def test_values_match_oracle_and_expr(spec, oracle):
    basis = _make(spec)
    assert len(basis) == len(oracle)
    grid = np.linspace(0.0, 1.0, 41)
    for d in range(4):
        # the double-precision oracle is good to ~1e-16 of the derivative's typical size
        scale = max([1.0] + [abs(f(x, d)) for f in oracle for x in grid])
        for x in (0.0, 0.137, 0.5, 0.91, 1.0):
            got = basis.values(x, d)
            ref = np.array([f(x, d) for f in oracle])
            assert np.allclose(got, ref, rtol=1e-12, atol=1e-12 * scale), (x, d, got, ref)
    # expr agrees with value() (expr evaluated at 50 digits by sympy)
    for f in basis.functions:
        for d in (0, 2):
            e = sympy.diff(f.expr, S.XI, d)
            for x in (0.25, 0.8):
                ref = float(e.evalf(40, subs={S.XI: sympy.Rational(x)}))
                assert f.value(x, d) == pytest.approx(ref, rel=1e-14, abs=1e-14 * (1 + abs(ref)))


def test_eigen_expr_is_stable_in_double_precision():
    t = S.transverse_basis("cantilever", "eigen", 12)
    f = t.functions[-1]  # beta ~ 36: cosh - sigma sinh would lose ~15 digits
    fn = sympy.lambdify(S.XI, f.expr, "math")
    for x in (0.3, 0.7, 0.99):
        assert fn(x) == pytest.approx(f.value(x), rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("spec,oracle", ALL_BASES, ids=[str(s[0]) for s in ALL_BASES])
def test_boundary_conditions(spec, oracle):
    basis = _make(spec)
    v0, v1 = basis.values(0.0), basis.values(1.0)
    d0 = basis.values(0.0, 1)
    if spec[0] == "axial":
        assert np.all(v0 == 0.0) or np.allclose(v0, 0.0, atol=1e-15)
        return
    frame, family = spec[0], spec[1]
    assert np.allclose(v0, 0.0, atol=1e-14)
    if frame == "pinned-pinned":
        assert np.allclose(v1, 0.0, atol=1e-13)
    else:
        assert np.allclose(d0, 0.0, atol=1e-13)
        if family != "polynomial":
            assert np.allclose(v1, 1.0, atol=1e-13)  # normalised tip value
        for f in basis.functions:
            if f.beta is not None:  # free end of an eigenfunction: no moment, no shear
                assert abs(f.value(1.0, 2)) < 1e-9 * f.beta**2
                assert abs(f.value(1.0, 3)) < 1e-9 * f.beta**3


def test_empty_bases_and_validation():
    for b in (
        S.axial_basis("complete", 0),
        S.axial_basis("stress-free", 0),
        S.transverse_basis("cantilever", "modes", 0, tip_joint=True),
        S.transverse_basis("pinned-pinned", "polynomial", 0),
    ):
        assert len(b) == 0 and b.values(0.5).shape == (0,)
    ip = C.inner_products(S.axial_basis("complete", 0), S.transverse_basis("cantilever", "eigen", 0))
    assert ip.gram.shape == (2, 2) and ip.C3.shape == (0, 0, 0) and ip.D4.shape == (0, 0, 0, 0)
    assert np.allclose(ip.gram, [[1, 0.5], [0.5, 1 / 3]])
    assert S.transverse_basis("pinned-sliding", "modes", 2) == S.transverse_basis("pinned-pinned", "modes", 2)
    with pytest.raises(ValueError, match="axial shape family"):
        S.axial_basis("bogus", 2)
    with pytest.raises(ValueError, match="frame"):
        S.transverse_basis("clamped", "modes", 2)
    with pytest.raises(ValueError, match="mode count"):
        S.axial_basis("complete", -1)
    with pytest.raises(ValueError, match="directions"):
        C.inner_products(S.transverse_basis("cantilever", "eigen", 1), S.axial_basis("complete", 1))


def test_bases_pickle():
    t = S.transverse_basis("cantilever", "modes", 3, tip_joint=True)
    t2 = pickle.loads(pickle.dumps(t))
    assert t2 == t
    assert np.allclose(t2.values(0.4, 3), t.values(0.4, 3), rtol=1e-15)


# ----------------------------------------------------------------------------- caching
def test_disk_cache_round_trip_and_corrupt_file(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path))
    a, t = S.axial_basis("complete", 2), S.transverse_basis("cantilever", "modes", 3, tip_joint=True)
    calls = []
    real_compute = S.compute_inner_products

    def counting(*args):
        calls.append(1)
        return real_compute(*args)

    monkeypatch.setattr(S, "compute_inner_products", counting)
    C.clear_memory_cache()
    ip1 = C.inner_products(a, t)
    assert len(calls) == 1
    assert C.inner_products(a, t) is ip1  # memory cache
    files = list((tmp_path / "shapes").iterdir())
    assert len(files) == 1 and files[0].suffix == ".json"
    assert S.SHAPES_VERSION in files[0].name and "cantilever" in files[0].name

    C.clear_memory_cache()
    ip2 = C.inner_products(a, t)  # from disk
    assert len(calls) == 1
    for name in ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4"):
        assert np.array_equal(getattr(ip1, name), getattr(ip2, name))
        assert not getattr(ip2, name).flags.writeable
        assert ip2.exact[name] == ip1.exact[name]
    assert capsys.readouterr().err == ""

    files[0].write_bytes(b"not a cache entry \x00\x01")
    C.clear_memory_cache()
    ip3 = C.inner_products(a, t)
    assert len(calls) == 2  # corrupt file ignored (said on stderr), recomputed
    assert "symgen: warning: cache entry" in capsys.readouterr().err
    assert np.array_equal(ip3.D4, ip1.D4)
    again = C._decode_entry(files[0].read_bytes(), files[0].stem)  # and rewritten
    assert np.array_equal(again.Kt, ip1.Kt)
    assert sorted(p.name for p in (tmp_path / "shapes").iterdir()) == [files[0].name]  # no temp files left

    from symgen import cache  # a verified entry written for another key is not used

    files[0].write_bytes(
        cache.pack("shapes", files[0].read_bytes().split(b"\n", 1)[1].replace(files[0].stem.encode(), b"someone else"))
    )
    C.clear_memory_cache()
    C.inner_products(a, t)
    assert len(calls) == 3
    assert "someone else" in capsys.readouterr().err
    C.clear_memory_cache()


def test_memory_cache_keyed_by_parameters(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path))
    C.clear_memory_cache()
    a = S.axial_basis("stress-free", 2)
    ip_a = C.inner_products(a, S.transverse_basis("cantilever", "modes", 2, tip_joint=True))
    ip_b = C.inner_products(a, S.transverse_basis("cantilever", "modes", 2, tip_joint=False))
    assert ip_a is not ip_b and not np.allclose(ip_a.gram, ip_b.gram)
    assert (
        C.inner_products(S.axial_basis("stress-free", 2), S.transverse_basis("cantilever", "modes", 2, tip_joint=True))
        is ip_a
    )
    assert len(list((tmp_path / "shapes").iterdir())) == 2
    C.clear_memory_cache()


def test_half_items_fold_conjugate_pairs_of_exact_terms_too():
    """``Re sum c e^{s xi}`` over the folded terms is the function, for exact coefficients as for
    mpc ones (the exact form raised a TypeError on ``2 * Exact``)."""
    t = T.sin_terms(3)  # sin(3 pi xi / 2): one conjugate exponent pair
    assert t.exact
    folded = {"exact": t.half_items(), "mp": t.as_mp().half_items()}
    assert len(folded["exact"]) == len(folded["mp"]) == 1
    for form, items in folded.items():
        for xi in (0.0, 0.3, 0.71, 1.0):
            value = sum(
                complex((c.to_mp() if form == "exact" else c) * mpmath.exp(T.s_value(s) * xi)) * xi**p
                for p, s, c in items
            ).real
            assert value == pytest.approx(math.sin(1.5 * math.pi * xi), abs=1e-14), (form, xi)
