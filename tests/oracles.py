"""Numerical helpers shared by the physics tests (independent of symgen's internals)."""

from __future__ import annotations

import numpy as np


def zero_crossing_frequency(t: np.ndarray, y: np.ndarray) -> float:
    """Angular frequency of a (near-)harmonic signal from its upward zero crossings.

    Crossing times are located by cubic interpolation through 4 samples around each sign
    change; the frequency is 2 pi / (mean period between the first and last crossing).
    """
    y = y - 0.0
    idx = np.where((y[:-1] < 0) & (y[1:] >= 0))[0]
    times = []
    for i in idx:
        lo, hi = max(i - 1, 0), min(i + 3, len(t))
        tt, yy = t[lo:hi], y[lo:hi]
        c = np.polyfit(tt - t[i], yy, min(3, len(tt) - 1))
        roots = np.roots(c)
        roots = roots[np.isreal(roots)].real
        h = t[i + 1] - t[i]
        roots = roots[(roots >= -1e-12) & (roots <= h + 1e-12)]
        times.append(t[i] + (roots[0] if len(roots) else -y[i] * h / (y[i + 1] - y[i])))
    if len(times) < 3:
        raise ValueError("too few zero crossings to measure a frequency")
    periods = (times[-1] - times[0]) / (len(times) - 1)
    return 2 * np.pi / periods


def write_scene(path, text: str):
    path.write_text(text)
    return path


def hermite_beam_frequencies(a: float, ne: int, far_end_pinned: bool, count: int = 3) -> np.ndarray:
    """First ``count`` circular frequencies (EI = m = l = 1) of a beam pinned at 0 and at the
    interior point a, pinned or free at 1: Hermite cubic elements (exact stiffness and consistent
    mass of Euler-Bernoulli), ``ne`` of them with a node at a. Independent of symgen's code."""
    import scipy.linalg as sl

    n1 = int(round(ne * a))
    x = np.concatenate([np.linspace(0, a, n1 + 1), np.linspace(a, 1, ne - n1 + 1)[1:]])
    N = len(x)
    K, M = _hermite_matrices(x)
    fixed = {0, 2 * n1} | ({2 * (N - 1)} if far_end_pinned else set())
    free = [i for i in range(2 * N) if i not in fixed]
    w2 = sl.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True, subset_by_index=[0, count - 1])
    return np.sqrt(w2)


def _hermite_matrices(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass (EI = m = 1) of Euler-Bernoulli Hermite cubic elements on the
    nodes ``x``; the unknowns are (w, w') at every node."""
    N = len(x)
    K = np.zeros((2 * N, 2 * N))
    M = np.zeros_like(K)
    for e in range(N - 1):
        h = x[e + 1] - x[e]
        k = (
            np.array(
                [
                    [12, 6 * h, -12, 6 * h],
                    [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                    [-12, -6 * h, 12, -6 * h],
                    [6 * h, 2 * h * h, -6 * h, 4 * h * h],
                ]
            )
            / h**3
        )
        m = (
            h
            / 420
            * np.array(
                [
                    [156, 22 * h, 54, -13 * h],
                    [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                    [54, 13 * h, 156, -22 * h],
                    [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
                ]
            )
        )
        d = [2 * e, 2 * e + 1, 2 * e + 2, 2 * e + 3]
        K[np.ix_(d, d)] += k
        M[np.ix_(d, d)] += m
    return K, M


def hermite_geometric_stiffness(x: np.ndarray, tension) -> np.ndarray:
    """Geometric stiffness (the work of an axial force N on the chord's shortening, N int w'^2 / 2)
    of Hermite cubic elements on the nodes ``x``, each element at ``tension`` (a function of xi) at
    its mid-point; the unknowns as ``_hermite_matrices``'. Independent of symgen's code."""
    N = len(x)
    G = np.zeros((2 * N, 2 * N))
    for e in range(N - 1):
        h = x[e + 1] - x[e]
        g = np.array(
            [
                [36, 3 * h, -36, 3 * h],
                [3 * h, 4 * h * h, -3 * h, -h * h],
                [-36, -3 * h, 36, -3 * h],
                [3 * h, -h * h, -3 * h, 4 * h * h],
            ]
        )
        d = [2 * e, 2 * e + 1, 2 * e + 2, 2 * e + 3]
        G[np.ix_(d, d)] += tension((x[e] + x[e + 1]) / 2) / (30 * h) * g
    return G


def cantilever_mass_frequencies(
    a: float, mass: float, inertia: float, offset: tuple[float, float], ne: int, count: int = 3
) -> np.ndarray:
    """First ``count`` circular frequencies (EI = m = l = 1) of a beam clamped at 0, free at 1,
    carrying at xi = a a rigid body of mass ``mass`` and rotary inertia ``inertia`` about its
    centre, the centre at ``offset`` = (along, across) from the axis: Hermite cubic elements,
    ``ne`` of them with a node at a. The body's centre moves by (-across w', w + along w')
    (small rotation w' of the section), so it adds to the node's (w, w') mass matrix
    m [[1, along], [along, along^2 + across^2]] + I [[0, 0], [0, 1]]. Independent of symgen."""
    import scipy.linalg as sl

    n1 = int(round(ne * a))
    x = np.concatenate([np.linspace(0, a, n1 + 1), np.linspace(a, 1, ne - n1 + 1)[1:]]) if 0 < n1 < ne else None
    if x is None:
        x = np.linspace(0, 1, ne + 1)
    K, M = _hermite_matrices(x)
    s, c = offset
    d = [2 * n1, 2 * n1 + 1]
    M[np.ix_(d, d)] += mass * np.array([[1.0, s], [s, s * s + c * c]]) + inertia * np.array([[0.0, 0.0], [0.0, 1.0]])
    free = list(range(2, 2 * len(x)))  # clamped: w(0) = w'(0) = 0
    w2 = sl.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True, subset_by_index=[0, count - 1])
    return np.sqrt(w2)


def hanging_chain_frequencies(
    bars: list[tuple[float, float, float]], g: float, ne: int = 40, count: int = 6
) -> np.ndarray:
    """First ``count`` circular frequencies of the small in-plane lateral vibration of a chain of
    Euler-Bernoulli bars hanging straight down under gravity ``g`` from a pin at the top, joined
    end to end by pins: ``bars`` = [(length, mass per length, EI), ...] from the top.

    Hermite cubic elements (``ne`` per bar: exact bending stiffness, consistent mass) with the
    geometric stiffness of the tension N(s) = g x (the mass below s), integrated exactly by
    3-point Gauss quadrature: int N u' du' ds. The rigid pendulum modes come out of the tension
    alone, the bending modes of the bending stiffness stiffened by it. A pin has one lateral
    displacement and the rotations of the two bar ends it joins; the top pin holds the
    displacement. Independent of symgen's code (no floating frame, no Lagrange multipliers)."""
    import scipy.linalg as sl

    gauss_x = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    gauss_w = np.array([5.0, 8.0, 5.0]) / 9.0
    total = sum(length * rho for length, rho, _ in bars)
    # dof numbering: per bar, lateral displacements u_0..u_ne (u_0 shared with the bar above's
    # last node), and rotations r_0..r_ne of its own
    dofs_u: list[list[int]] = []
    dofs_r: list[list[int]] = []
    nd = 0
    for b in range(len(bars)):
        first = dofs_u[-1][-1] if b else None
        us = [first] if first is not None else [nd]
        nd += 0 if first is not None else 1
        for _ in range(ne):
            us.append(nd)
            nd += 1
        dofs_u.append(us)
        dofs_r.append(list(range(nd, nd + ne + 1)))
        nd += ne + 1
    K = np.zeros((nd, nd))
    M = np.zeros((nd, nd))
    above = 0.0  # mass above the current bar
    for b, (length, rho, EI) in enumerate(bars):
        h = length / ne
        for e in range(ne):
            k = (
                EI
                / h**3
                * np.array(
                    [
                        [12, 6 * h, -12, 6 * h],
                        [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                        [-12, -6 * h, 12, -6 * h],
                        [6 * h, 2 * h * h, -6 * h, 4 * h * h],
                    ]
                )
            )
            m = (
                rho
                * h
                / 420
                * np.array(
                    [
                        [156, 22 * h, 54, -13 * h],
                        [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                        [54, 13 * h, 156, -22 * h],
                        [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
                    ]
                )
            )
            kg = np.zeros((4, 4))
            for xg, wg in zip(gauss_x, gauss_w):
                x = (xg + 1) / 2  # in [0, 1] along the element
                s = e * h + x * h  # from the bar's top
                tension = g * (total - above - rho * s)
                # derivatives d/ds of the Hermite functions
                dN = np.array(
                    [(-6 * x + 6 * x * x) / h, 1 - 4 * x + 3 * x * x, (6 * x - 6 * x * x) / h, -2 * x + 3 * x * x]
                )
                kg += wg * h / 2 * tension * np.outer(dN, dN)
            d = [dofs_u[b][e], dofs_r[b][e], dofs_u[b][e + 1], dofs_r[b][e + 1]]
            K[np.ix_(d, d)] += k + kg
            M[np.ix_(d, d)] += m
        above += rho * length
    free = [i for i in range(nd) if i != dofs_u[0][0]]
    w2 = sl.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True, subset_by_index=[0, count - 1])
    return np.sqrt(w2)


def imperfect_elastica_midspan(P: float, mu: float, gamma: float, lam: float | None = None) -> float:
    """The midspan deflection of an inextensible pinned-pinned elastica (bending stiffness mu,
    unit length) under the compressive end load P along the chord and a uniform dead lateral load
    gamma per unit length, by collocation (scipy's solve_bvp) of the large-deflection equations:
    x' = cos th, y' = sin th, mu th' = -M, M(s) = P y + R0 x - gamma (s x - int_0^s x), the
    reaction R0 at the pin s = 0 an unknown fixed by M(1) = 0 (the pin at s = 1 on the chord).
    Linear beam-column theory is its limit of small slopes; near the Euler load the geometric
    stiffening of the deflected shape (of order slope^2) is amplified by 1/(1 - P/P_cr).

    ``lam``: extensible (Reissner's elastica, axial stiffness lam): x' = (1 + e) cos th,
    y' = (1 + e) sin th, e = -P cos th / lam the strain of the end load's tangential component (the
    shear force's share, of order gamma th, is left out: 2e-5 of P on the near-buckling column),
    mu th' = -M with th' the curvature per undeformed length; the deflection of the material
    midpoint s = 1/2. The bar shortens, so it buckles at mu pi^2 / (1 + e): a compressed bar is
    stiffer in bending by about 2 |e| (the stretch's share of the curvature, eta'' / (1 + e))."""
    from scipy.integrate import solve_bvp

    def f(s, u, p):
        x, y, th, X = u
        M = P * y + p[0] * x - gamma * (s * x - X)
        stretch = 1.0 if lam is None else 1.0 - P * np.cos(th) / lam
        return np.vstack([stretch * np.cos(th), stretch * np.sin(th), -M / mu, x])

    def bc(a, b, p):
        return np.array([a[0], a[1], a[3], b[1], P * b[1] + p[0] * b[0] - gamma * (b[0] - b[3])])

    s = np.linspace(0.0, 1.0, 401)
    guess = 0.01
    u0 = np.vstack([s, guess * np.sin(np.pi * s), guess * np.pi * np.cos(np.pi * s), s**2 / 2])
    sol = solve_bvp(f, bc, s, u0, p=[-gamma / 2], tol=1e-10, max_nodes=200000)
    if not sol.success:
        raise RuntimeError(f"the elastica oracle did not converge: {sol.message}")
    return abs(float(sol.sol(0.5)[1]))
