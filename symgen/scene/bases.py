"""Accuracy-driven bases (issue 19, item 1): how many axial and transverse functions each
elastic bar gets when the scene does not say, from ``[simulation] accuracy`` (a fraction of each
output's peak), and the a-priori estimate of the counts a scene states.

The choice is a pure function of the scene's values (numpy only, no SymPy): it lives in the
scene layer because the loader fills the chosen counts into the :class:`~symgen.scene.model.Body`
records, so every later stage sees plain counts (a chosen basis is the same model, with the same
cache key, as the same counts written in the file). Its record, :class:`BasisChoice`, travels on
``Scene.bases``; the sidecar, ``symgen effects`` and ``symgen check`` print it.

What it estimates, per bar (tau units, omega = 1):

* ``omega_run``: the fastest content the run must resolve: ``DRIVER_HARMONICS`` x the fastest
  driver rate (an angle driver's rate, a torque driver's initial rate; a law, a torque or a load
  given as an expression of tau counts as rate 1), and for a chain without an angle driver under
  gravity its free swing sqrt(|g| / l) of its shortest bar.
* the bar's bending frequencies in its frame, with its interior point masses (``[[masses]]``,
  joint masses, half of each bar pinned there) and, for a cantilever, the same at its tip: a
  Hermite finite-element model of the bar (``FE_ELEMENTS`` elements), exact enough for the low
  modes that decide.
* a mode with frequency w_k is *dynamic* when treating it statically would err by more than the
  accuracy: the amplification r^2 / (1 - r^2) at r = omega_run / w_k exceeds it; the first mode is
  always dynamic (an undamped start rings it).
* the estimate of n functions is the largest of: the amplification of the first mode the n
  functions miss; ``STATIC_WEIGHT`` x the static truncation of the load content (the deflection,
  and the slope where an output reads it or the bar is coupled to other elastic bars or carries
  lumped masses, under uniform and linear inertia loads, and under point forces where no static
  correction function carries them), relative to the exact static response; and
  ``FREQUENCY_WEIGHT`` x the relative error of the Rayleigh-Ritz frequencies of the dynamic modes
  (a ringing mode at the wrong frequency drifts in phase over the run).
* the chosen count is the smallest n whose estimate is at most the accuracy (at most
  ``MAX_CHOSEN``); axial the same with the axial frequencies (pi/2)(2k-1) sqrt(lambda) and the
  static axial response where an output reads the stretch, and at least ``AXIAL_MIN_VON_KARMAN`` functions under von Karman strain
  (fewer lock: the basis must carry 1/2 eta'^2).

Then the mechanism's *coupled* modes (:func:`coupled_choice`), where symgen chooses counts: a
linear finite-element model of the whole mechanism at its start position (each elastic bar
``COUPLED_ELEMENTS`` Hermite beam and linear bar elements, rigid bars rigid, the lumped masses;
pins, sliders and angle drivers as constraints) and the floating-frame model with the counts
mapped into it (each bar's frame motion plus its functions: Rayleigh-Ritz in the same
equations) give each coupled mode's frequency error e_k. An undeformed start that is not
quasi-static rings every coupled mode with its static share of the start's loads, and the
driver torque and the reactions read that share undiminished at high frequency (a deflection
reads it relative to its peak); the mode's phase drifts by w_k T e_k over the run (or over its
Kelvin-Voigt decay time), a mode the counts lack misses its whole share, each as far as the
outputs' rows can see it: its amplitude decayed to the first row (:meth:`_CoupledEstimate.seen`,
:func:`ringing_left`; the quasi-static functions' check counts its modes so too). Each reference
mode is compared with the Ritz mode of its shape (mass-weighted overlap at least MODE_MATCH),
not of its index.
The floating-frame model carries each bar's static corrections at its interior points,
transverse and axial, as the derived model does (:class:`_CoupledEstimate`). Functions are added where the worst mode's shape is least
represented until the estimate meets the accuracy (measured: a steel crank-rocker's driver
torque 4.6 % -> 1.4 % of 6 + 8 functions, a released double pendulum's tips 3.8 % -> 0.27 %;
benchmarks/RESULTS.md "Accuracy-driven bases"). A slot's guide with an elastic overhang is
frozen at the start's contact beta0 (its span functions, the contact-slope function and the
overhang's own functions on its nodes, :func:`_guide_functions`; the slot keeps the pin's point
on the guide's line); its span functions may be quasi-static above the span's band
(:func:`guide_band`). Not covered: a guide with a rigid overhang, sliders between two bars,
masses beside a bar (the reason says so; each bar's own choice stands), the preload and speed
of the run (the model is linear about the undeformed start), other positions of the cycle (a
guide's other contacts).

The start's axial ringing (:func:`axial_ringing`): a start that is not quasi-static rings a bar's
first axial mode by the jump to its quasi-static stretch; where that exceeds the accuracy in the
outputs, ``effects.axial = "auto"`` keeps the axial dynamics of a bar whose axial band is far
above the run's (:func:`axial_separation`), and :func:`ringing_choice` adds functions until the
coupled axial mode's frequency, over positions of the whole cycle, keeps the ringing's phase
within the accuracy (the paper's slider-crank at accuracy 0.001: 3 + 5 quasi-static, 0.163 % of
peak, -> 5 + 8 dynamic, 0.070 %; docs/exact-bars.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import contextlib
import functools
import hashlib
import math
from collections.abc import Iterator
from dataclasses import dataclass, replace

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.scene.model import GROUND, Body, Joint, JointEnd, Scene

#: harmonics of the driver rate in the inertia loads of a mechanism (a slider-crank's piston
#: force has its 2nd and 4th harmonics): the run must resolve up to this multiple of the rate.
DRIVER_HARMONICS = 4.0
#: the default of ``[simulation] accuracy``: a fraction of each output's peak
DEFAULT_ACCURACY = 0.01
#: at most this many functions per family are chosen (the derivation's cost grows steeply)
MAX_CHOSEN = 12
#: the weight of the static truncation (relative to the bar's own static deflection and slope),
#: measured: benchmarks/RESULTS.md "Accuracy-driven bases"
STATIC_WEIGHT = 2.0
#: output kinds that read a bar's stretch (as symgen.apps.effects.STRETCH_OUTPUTS)
STRETCH_OUTPUTS = ("chord_elongation", "axial")
#: the axial static truncation counts once: the axial displacement is read only by the outputs
#: of a bar's stretch (chord_elongation, axial), and it is its own peak there
AXIAL_STATIC_WEIGHT = 1.0
#: a dynamic mode's relative frequency error counts ten times (its phase drifts over the run)
FREQUENCY_WEIGHT = 10.0
#: von Karman strain (and the exact bar, which keeps it) needs at least this many axial functions
#: (fewer lock, README/schema advice; the exact slewing arm at 14 % tip deflection with 1 was 2.5 %
#: of peak off its converged ANCF reference, with 3 0.13 %)
AXIAL_MIN_VON_KARMAN = 3
#: elements of the reference finite-element bar (Hermite cubics)
FE_ELEMENTS = 32


@dataclass(frozen=True)
class BasisChoice:
    """What one elastic bar's bases are and why.

    ``axial``, ``transverse``: the counts used; ``given``: (axial, transverse) as written in the
    file (None: chosen from the accuracy); ``needed``: the counts the a-priori estimate says meet
    the accuracy; ``dynamic``: (axial, transverse) numbers of modes in the band the run resolves;
    ``estimate``: the a-priori estimate of the counts used (fraction of peak);
    ``omega_run``, ``omega_bending``, ``omega_axial``: the frequencies used (tau units);
    ``reason``: one sentence; ``warning``: set when stated counts miss the accuracy;
    ``start_rings``: the run starts undeformed and undamped (:func:`with_start`);
    ``quasi``: how many of the highest transverse functions symgen made quasi-static
    (:func:`quasi_choice`; 0 where none, or where the file states ``quasi_static_transverse``),
    ``quasi_reason``: why (or why none); ``quasi_axial``: how many of the highest axial functions
    symgen made quasi-static (no key states them: symgen's choice only); ``raised``: why a run's
    truncation estimate raised the chosen counts to at least its floor (``Scene.counts_raised``,
    :mod:`symgen.numerics.counts_choice`; "" where none); ``quasi_stated``: the file states the
    bar's ``quasi_static_transverse`` (the chooser leaves it as stated)."""

    bar: str
    axial: int
    transverse: int
    given: tuple[int | None, int | None]
    needed: tuple[int, int]
    dynamic: tuple[int, int]
    estimate: float
    accuracy: float
    omega_run: float
    omega_bending: tuple[float, ...] = ()
    omega_axial: tuple[float, ...] = ()
    reason: str = ""
    warning: str = ""
    start_rings: bool = False
    quasi: int = 0
    quasi_reason: str = ""
    quasi_axial: int = 0
    raised: str = ""
    quasi_stated: bool = False

    def as_dict(self) -> dict:
        """The sidecar's ``bases`` entry of this bar (JSON)."""
        return {
            "axial": self.axial,
            "transverse": self.transverse,
            "chosen": [g is None for g in self.given],
            "needed": list(self.needed),
            "dynamic": {"axial": self.dynamic[0], "transverse": self.dynamic[1]},
            "static": {
                "axial": max(self.axial - self.dynamic[0], 0),
                "transverse": max(self.transverse - self.dynamic[1], 0),
            },
            "estimate": self.estimate,
            "accuracy": self.accuracy,
            "omega_run": self.omega_run,
            "omega_bending": list(self.omega_bending),
            "omega_axial": list(self.omega_axial),
            "reason": self.reason,
            "warning": self.warning,
            "start_rings": self.start_rings,
            "raised": self.raised,
            "quasi_static": {
                "functions": self.quasi,
                "axial_functions": self.quasi_axial,
                "reason": self.quasi_reason,
            },
        }


def amplification_error(omega_run: float, omega: float) -> float:
    """The error of treating a mode of frequency ``omega`` statically under forcing at
    ``omega_run``: r^2 / (1 - r^2), r = omega_run / omega (1.0 at or beyond resonance)."""
    r2 = (omega_run / omega) ** 2
    return 1.0 if r2 >= 0.5 else r2 / (1.0 - r2)


#: a ramped start is gentle for a mode at least this many times faster than the ramp's own
#: frequency 2 pi / T (below, the asymptotic ringing of its kinks does not hold: a sudden start)
ONSET_SEPARATION = 2.0


def start_onset(scene: Scene, omega: float, deformed: bool = False) -> float:
    """How much of a sudden start's ringing a mode of frequency ``omega`` (per unit tau) gets
    from the run's undeformed start, as a fraction (1.0: all of it).

    A start is sudden (1.0) where a load acts at once on the undeformed mechanism: a torque
    driver, an angle driver at speed from tau = 0 or by a law, gravity, a load, stated initial
    amplitudes (``deformed``). Where every driver is an angle driver spun up from rest by its
    ``ramp`` T (theta'' = (rate/T)(1 - cos(a tau)), a = 2 pi / T, symgen.scene.motion.ramp_law)
    and nothing else loads the bars, the inertia loads s = F theta'' + G theta'^2 start from
    zero with zero slope, and a mode x'' + w^2 x = w^2 s rings only where a derivative of s
    jumps: at tau = 0 by (rate/T) a^2 / (w^2 - a^2) (exact for the cosine ramp), at T (where
    the run gets there) by as much plus the jump of the third derivative of G theta'^2,
    2 rate^2 a^2 / (T w^3); while the ramp lasts the quasi-static lag is of the first's size.
    Both kinks add in the worst phase; relative to the largest load of the run
    (max |theta''|, theta'^2 over it: the shares of :class:`_CoupledEstimate` are relative to the
    static response of unit fields). The largest over the drivers, at most 1."""
    if deformed or not scene.drivers or scene.loads or math.hypot(*scene.effects.gravity) > 0:
        return 1.0
    worst = 0.0
    t_end = scene.simulation.t_end
    for d in scene.drivers:
        if d.kind != "angle" or d.law is not None or d.ramp is None or not d.rate:
            return 1.0
        rate, T = abs(d.rate), float(d.ramp)
        a = 2.0 * math.pi / T
        if omega < ONSET_SEPARATION * a:
            return 1.0
        tau = np.linspace(0.0, min(t_end, T), 2001)
        accel = rate / T * (1.0 - np.cos(a * tau))
        speed = rate / T * (tau - np.sin(a * tau) / a)
        peak = float(max(np.max(accel), np.max(speed**2), rate**2 if t_end > T else 0.0))
        if peak <= 0.0:
            return 1.0
        kink = rate / T * a * a / (omega * omega - a * a)
        ring = kink + ((kink + 2.0 * rate * rate * a * a / (T * omega**3)) if t_end > T else 0.0)
        worst = max(worst, ring / peak)
    return min(worst, 1.0)


#: points closer than this (in xi) share one static correction function; nearer the ends than this
#: they are not interior
POINT_TOL = 1e-9


def ringing_left(c: float, w: float, t: float) -> float:
    """The most a mode's free response to a sudden load keeps of its initial offset from the
    static response at time ``t``, as a fraction: the mode (frequency ``w`` per unit tau,
    Kelvin-Voigt c: x'' + c w^2 x' + w^2 x = 0, zeta = c w / 2) starts off by 1 at rest. Below
    critical damping x = e^(-s t) (cos(w_d t) + (s / w_d) sin(w_d t)), s = zeta w: at most
    e^(-s t) min(1 + s t, 1 / sqrt(1 - zeta^2)); above it the slow root s = 2 w / (c w +
    sqrt(c^2 w^2 - 4)), which tends to 1 / c (an overdamped mode creeps to its static shape, it
    does not vanish at once): x = e^(-s t) (1 + s (1 - e^(-(s2 - s) t)) / (s2 - s)) (s2 = w^2 / s
    the fast root), at most e^(-s t) (1 + s min(t, 1 / (s2 - s))). Undamped (c <= 0): 1."""
    if c <= 0.0 or t <= 0.0:
        return 1.0
    zeta = c * w / 2.0
    if zeta < 1.0:
        s = zeta * w
        bound = min(1.0 + s * t, 1.0 / math.sqrt(1.0 - zeta * zeta))
    else:
        s = 2.0 * w / (c * w + math.sqrt((c * w) ** 2 - 4.0))
        fast = w * w / s  # the other root (their product w^2)
        bound = 1.0 + s * min(t, 1.0 / (fast - s)) if fast > s else 1.0 + s * t
    return min(1.0, bound * math.exp(-s * t))


def interior_points(scene: Scene, name: str) -> tuple[float, ...]:
    """The interior points 0 < xi < 1 of bar ``name`` where a point force acts: joint ends (pins,
    sliders, a slot's sliding point; a joint's lumped mass sits on it), point loads and the
    ``[[masses]]``; sorted, merged within POINT_TOL."""
    xs = [e.xi for j in scene.joints for e in j.ends if e.body == name and e.xi is not None and not e.variable]
    xs += [ld.xi for ld in scene.loads if ld.body == name and ld.kind == "point" and ld.xi is not None]
    xs += [m.xi for m in scene.masses if m.body == name]
    out: list[float] = []
    for x in sorted(float(x) for x in xs):
        if POINT_TOL < x < 1 - POINT_TOL and not (out and x - out[-1] < POINT_TOL):
            out.append(x)
    return tuple(out)


# -- the run's spectrum -------------------------------------------------------------------------
def run_frequency(scene: Scene) -> tuple[float, str]:
    """(omega_run, how): the fastest content the run must resolve, in tau units."""
    rates: list[tuple[float, str]] = []
    for d in scene.drivers:
        if d.kind == "angle":
            rates.append(
                (1.0, f"the law of the driver of {d.body} (rate 1)")
                if d.law
                else (abs(d.rate), f"driver rate {abs(d.rate):.4g}")
            )
        else:
            rate = abs(d.rate)
            rates.append(
                (rate, f"torque driver of {d.body} (rate {rate:.4g})")
                if rate >= 1.0
                else (1.0, f"torque driver of {d.body} (the speed it reaches is the run's: rate 1, the time unit's)")
            )
    if any(isinstance(ld.axial, str) or isinstance(ld.transverse, str) for ld in scene.loads):
        rates.append((1.0, "loads given as expressions of tau (rate 1)"))
    g = math.hypot(*scene.effects.gravity)
    if g > 0 and not scene.angle_drivers:
        short = min(b.alpha for b in scene.bodies)
        rates.append((math.sqrt(g / short), f"free swing sqrt(g/l) {math.sqrt(g / short):.4g}"))
    rates = [(w, why) for w, why in rates if w > 0]
    if not rates:
        return DRIVER_HARMONICS, "no driver, load rate or gravity: rate 1"
    w, why = max(rates)
    return DRIVER_HARMONICS * w, f"{DRIVER_HARMONICS:g} x {why}"


# -- the bar's reference finite elements --------------------------------------------------------
def _mesh(points: tuple[float, ...], elements: int = FE_ELEMENTS) -> np.ndarray:
    xs = set(np.linspace(0.0, 1.0, elements + 1).round(12))
    xs |= {round(float(p), 12) for p in points}
    return np.array(sorted(xs))


def _beam_fe(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness (EI = 1) and consistent mass (unit mass per length) of Hermite beam elements
    on nodes ``x``; dofs (w, w') per node."""
    n = 2 * len(x)
    K, M = np.zeros((n, n)), np.zeros((n, n))
    for e in range(len(x) - 1):
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
            np.array(
                [
                    [156, 22 * h, 54, -13 * h],
                    [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                    [54, 13 * h, 156, -22 * h],
                    [-13 * h, -3 * h * h, -22 * h, 4 * h * h],
                ]
            )
            * h
            / 420
        )
        i = slice(2 * e, 2 * e + 4)
        K[i, i] += k
        M[i, i] += m
    return K, M


def _beam_load(x: np.ndarray, q) -> np.ndarray:
    """Consistent nodal loads of a distributed load q(xi) (Gauss, 4 points per element)."""
    f = np.zeros(2 * len(x))
    gp, gw = _gauss(4)
    gp, gw = 2 * gp - 1, 2 * gw
    for e in range(len(x) - 1):
        h = x[e + 1] - x[e]
        s = (gp + 1) / 2
        N = np.array([1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, h * (-(s**2) + s**3)])
        f[2 * e : 2 * e + 4] += N @ (gw * q(x[e] + h * s)) * h / 2
    return f


@functools.lru_cache(maxsize=4)
def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on [0, 1]."""
    gp, gw = np.polynomial.legendre.leggauss(n)
    return (gp + 1) / 2, gw / 2


def _node(x: np.ndarray, xi: float) -> int:
    return int(np.argmin(abs(x - xi)))


def _free(x: np.ndarray, frame: str) -> np.ndarray:
    fixed = [0, 1] if frame == "cantilever" else [0, 2 * len(x) - 2]
    return np.array([i for i in range(2 * len(x)) if i not in fixed])


@dataclass(frozen=True)
class _Bar:
    """A bar's reference model: nodes, free dofs, K, M (with the point masses), interior points."""

    x: np.ndarray
    free: np.ndarray
    K: np.ndarray
    M: np.ndarray
    interior: tuple[float, ...]
    corrected: bool  # static correction functions carry the interior point forces
    tip: bool  # cantilever with a joint or mass at its tip: the static tip-load shape is first


def _point_masses(scene: Scene, body) -> dict[float, float]:
    """xi -> lumped mass in units of the bar's own mass: ``[[masses]]`` on it, joint masses at
    its joints, half the mass of each other bar pinned to it."""
    own = body.nu * body.alpha
    out: dict[float, float] = {}
    for m in scene.masses:
        if m.body == body.name:
            out[m.xi] = out.get(m.xi, 0.0) + m.mass / own
    for j in scene.joints:
        mine = [e for e in j.ends if e.body == body.name and e.xi is not None and not e.variable]
        if not mine:
            continue
        xi = float(mine[0].xi)  # type: ignore[arg-type]
        extra = j.mass + sum(
            0.5 * scene.body(e.body).nu * scene.body(e.body).alpha for e in j.ends if e.body not in (GROUND, body.name)
        )
        out[xi] = out.get(xi, 0.0) + extra / own
    return out


def _reference_bar(
    scene: Scene, body, interior: tuple[float, ...], corrected: bool, elements: int = FE_ELEMENTS
) -> _Bar:
    masses = _point_masses(scene, body)
    x = _mesh(tuple(masses) + interior, elements)
    K, M = _beam_fe(x)
    for xi, m in masses.items():
        M[2 * _node(x, xi), 2 * _node(x, xi)] += m
    tip = body.frame == "cantilever" and any(abs(xi - 1.0) < 1e-9 for xi in masses)
    return _Bar(x, _free(x, body.frame), K, M, interior, corrected, tip)


def _eig(K: np.ndarray, M: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    L = np.linalg.cholesky(M)
    Li = np.linalg.inv(L)
    w, v = np.linalg.eigh(Li @ K @ Li.T)
    return w[:count], (Li.T @ v)[:, :count]


def _transverse_functions(bar: _Bar, frame: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(standard, corrections): the bar's first n standard transverse functions and its static
    correction functions, as dofs (columns)."""
    x, f = bar.x, bar.free
    cols = []
    if frame == "cantilever":
        if bar.tip:
            cols.append(np.ravel(np.column_stack([x**2 * (3 - x) / 2, 3 * x - 1.5 * x**2])))
        K, M = _beam_fe(x)
        _, v = _eig(K[np.ix_(f, f)], M[np.ix_(f, f)], max(n - len(cols), 0))
        for k in range(v.shape[1]):
            full = np.zeros(2 * len(x))
            full[f] = v[:, k]
            cols.append(full)
    else:
        cols += [
            np.ravel(np.column_stack([np.sin(k * np.pi * x), k * np.pi * np.cos(k * np.pi * x)]))
            for k in range(1, n + 1)
        ]
    corrections = []
    if bar.corrected:
        for xi in bar.interior:
            load = np.zeros(2 * len(x))
            load[2 * _node(x, xi)] = 1.0
            corrections.append(_static(bar, load))
    empty = np.zeros((2 * len(x), 0))
    return (np.array(cols[:n]).T if cols else empty), (np.array(corrections).T if corrections else empty)


def _static(bar: _Bar, load: np.ndarray) -> np.ndarray:
    f = bar.free
    out = np.zeros(len(load))
    out[f] = np.linalg.solve(bar.K[np.ix_(f, f)], load[f])
    return out


def _static_loads(bar: _Bar) -> list[tuple[np.ndarray, np.ndarray]]:
    """(load, exact static response) of the uniform and linear loads, and of unit point forces
    at the interior points that no static correction carries."""
    x = bar.x
    loads = [_beam_load(x, lambda s: np.ones_like(s)), _beam_load(x, lambda s: s)]
    if not bar.corrected:
        for xi in bar.interior:
            p = np.zeros(2 * len(x))
            p[2 * _node(x, xi)] = 1.0
            loads.append(p)
    return [(load, _static(bar, load)) for load in loads]


def _static_error(bar: _Bar, B: np.ndarray, cases: list[tuple[np.ndarray, np.ndarray]], slope: bool) -> float:
    """Largest relative truncation of the Galerkin static response in span(B) of the load
    ``cases``: its deflection, and its slope too when ``slope``."""
    f = bar.free
    Bf = B[f]
    Kr = Bf.T @ bar.K[np.ix_(f, f)] @ Bf
    worst = 0.0
    for load, exact in cases:
        approx = B @ np.linalg.solve(Kr, Bf.T @ load[f]) if B.shape[1] else np.zeros_like(exact)
        for part in (slice(0, None, 2), slice(1, None, 2)) if slope else (slice(0, None, 2),):
            scale = np.max(abs(exact[part]))
            if scale > 0:
                worst = max(worst, float(np.max(abs(exact[part] - approx[part])) / scale))
    return worst


def _ritz_error(bar: _Bar, B: np.ndarray, reference: np.ndarray, count: int) -> float:
    """Largest relative error of the first ``count`` Rayleigh-Ritz eigenvalues in span(B)."""
    if count == 0:
        return 0.0
    f = bar.free
    Bf = B[f]
    if Bf.shape[1] < count:
        return 1.0
    Kr = Bf.T @ bar.K[np.ix_(f, f)] @ Bf
    Mr = Bf.T @ bar.M[np.ix_(f, f)] @ Bf
    w, _ = _eig(Kr, Mr, count)
    return float(np.max(abs(np.sqrt(w) / np.sqrt(reference[:count]) - 1.0)))


# -- the mechanism's coupled spectrum -------------------------------------------------------------
#: elements per elastic bar of the coupled model (Hermite cubics: a hinged pair of bars' first six
#: bending modes within 1.2e-4 of the closed form; the Ritz model is compared with it on the same
#: elements, so its frequency errors are those of the functions)
COUPLED_ELEMENTS = 16
#: elements on a slot guide's span [0, beta] of the coupled model (besides COUPLED_ELEMENTS over
#: the whole guide): its span functions are sin(k pi xi / beta), up to MAX_CHOSEN half waves
GUIDE_SPAN_ELEMENTS = 3 * MAX_CHOSEN
#: a guide's contact at the start within this of an end of the guide: not checked (no span or
#: no overhang left for the functions)
CONTACT_MARGIN = 0.02
#: a ringing mode's phase error saturates: the run's and the reference's ringing then differ by up to
#: twice its amplitude
PHASE_CAP = 2.0
#: at most this many functions are added to the per-bar choice to meet the coupled estimate
COUPLED_STEPS = 16
#: a quasi-static function moves a joint when the closure reads it above this fraction of the
#: largest closure entry (sines at a node of theirs read about 1e-16)
QUASI_JOINT_TOL = 1e-9
#: a mode of one model is the same as a mode of another (the reference's and the floating-frame
#: model's in :meth:`_CoupledEstimate.check`, the dynamic and the quasi-static model's in
#: :meth:`_CoupledEstimate.quasi_check`) if the mass-weighted overlap of the two mass-normalised
#: shapes is at least this
MODE_MATCH = 0.9
#: the frequency shift quasi-static functions cause counts this many times: the coupled model is
#: linear about the undeformed start, and the run's own linearisation can amplify the shift (the
#: steel crank-rocker's coupled mode at 14 per unit tau is negatively damped along the run: its
#: coupler's top function quasi-static measured 1.5e-3 of peak over half a turn where the shift
#: alone predicts 3e-4; benchmarks/RESULTS.md "Quasi-static transverse functions")
QUASI_PHASE_SAFETY = 10.0
#: quasi-static functions are chosen only where they lower the fastest mode the run rings
#: (:meth:`_CoupledEstimate._fastest_ringing`, averaged over the run) at least this much (BDF
#: follows its ringing: the steel slider-crank's rod 2 of 3 transverse quasi-static, 9973 -> 1625
#: steps; the steel crank-rocker at 900 rpm's crank 2 of 3 axial, 4161 -> 1392 per unit tau,
#: 167835 -> 108419; the damped validation crank-rocker's rocker 1 of 4, its ringing decayed,
#: 7959 -> 8042); where none is left ringing the run's own content omega_run sets the steps (the
#: steel slider-crank's rod 3 of 3: IDAS 0 steps, the C solver 57)
QUASI_GAIN = 1.5


def _guide_functions(x: np.ndarray, beta: float, nspan: int, nover: int) -> tuple[np.ndarray, np.ndarray]:
    """A guide's transverse functions with an elastic overhang at the contact ``beta`` as dofs
    (w, dw/dxi) on nodes ``x`` (columns; ``symgen.model.slot``): (its ``nspan`` span functions
    s_k = sin(k pi xi / beta) - psi_k'(beta) C, zero beyond the contact; the contact-slope function
    chi_0 and the overhang's ``nover`` own functions). The overhang's functions as the powers
    v^2 .. v^(m+1), v = (xi - beta) / (1 - beta): the same span as the derived model's orthogonal
    polynomials (only the span enters a Ritz model)."""
    on = x <= beta
    C = np.where(on, x * (x * x - beta * beta) / (2 * beta * beta), x - beta)
    dC = np.where(on, (3 * x * x - beta * beta) / (2 * beta * beta), 1.0)
    span = []
    for k in range(1, nspan + 1):
        slope = (-1) ** k * k * np.pi / beta
        w = np.where(on, np.sin(k * np.pi * x / beta) - slope * C, 0.0)
        dw = np.where(on, k * np.pi / beta * np.cos(k * np.pi * x / beta) - slope * dC, 0.0)
        span.append(np.ravel(np.column_stack([w, dw])))
    v = np.where(on, 0.0, (x - beta) / (1 - beta))
    over = [np.ravel(np.column_stack([C, dC]))]
    for m in range(1, nover + 1):
        over.append(np.ravel(np.column_stack([v ** (m + 1), (m + 1) * v**m / (1 - beta)])))
    return np.array(span).T, np.array(over).T


@dataclass(frozen=True)
class _Part:
    """One body of the coupled model: its dofs in the global vector, its nodes (elastic bars:
    (u, w, dw/dxi) per node in the bar's axes; rigid bars: (x, y, phi) of its end xi = 0)."""

    body: Body
    start: int
    x: np.ndarray  # nodes in xi (elastic), [0.0] (rigid)
    theta: float
    origin: np.ndarray


def _placement(scene: Scene, guess: dict[str, float]) -> dict[str, tuple[np.ndarray, float]] | None:
    """Each bar's end xi = 0 and its angle at the start: the loop closure (pins, sliders, slots,
    angle drivers at their initial angles) solved by Gauss-Newton from the guess (None: not
    closed). A slot joint's entry (its name) holds its contact beta in place of an angle (the
    guess's key for it too)."""
    names = [b.name for b in scene.bodies]
    alpha = {b.name: b.alpha for b in scene.bodies}
    fixed = {d.body: float(d.initial) for d in scene.drivers if d.kind == "angle" and d.initial is not None}
    slots = [j for j in scene.joints if j.kind == "slot"]
    z = np.zeros(3 * len(names) + len(slots))
    for i, n in enumerate(names):
        z[3 * i + 2] = fixed.get(n, guess.get(n, 0.0))
    for k, j in enumerate(slots):
        z[3 * len(names) + k] = guess.get(j.name, 0.5)

    def point(z, end, joint=None):
        if end.body == GROUND:
            return np.array(end.point, dtype=float)
        i = names.index(end.body)
        th = z[3 * i + 2]
        xi = z[3 * len(names) + slots.index(joint)] if end.variable else float(end.xi)
        return z[3 * i : 3 * i + 2] + xi * alpha[end.body] * np.array([math.cos(th), math.sin(th)])

    def residual(z):
        out = []
        for j in scene.joints:
            a, b = j.ends
            if j.kind == "pin":
                out += list(point(z, a) - point(z, b))
            elif j.kind == "slot":  # the pin's point at the guide's contact beta
                out += list(point(z, a, j) - point(z, b, j))
            else:  # slider: the bar's point on the ground's line
                bar, ground = (a, b) if b.body == GROUND else (b, a)
                line = np.array(j.direction, dtype=float)
                r = point(z, bar) - point(z, ground)
                out.append(r[0] * line[1] - r[1] * line[0])
        for n, th in fixed.items():
            out.append(z[3 * names.index(n) + 2] - th)
        return np.array(out)

    # start each bar's end at its ground pin, or where the pins chain it from there
    for j in scene.joints:
        for a, b in (j.ends, j.ends[::-1]):
            if b.body == GROUND and a.body != GROUND and j.kind == "pin":
                ia = names.index(a.body)
                th = z[3 * ia + 2]
                z[3 * ia : 3 * ia + 2] = np.array(b.point) - float(a.xi or 0.0) * alpha[a.body] * np.array(
                    [math.cos(th), math.sin(th)]
                )
    for _ in range(len(names)):
        for j in scene.joints:
            if j.kind != "pin":
                continue
            for a, b in (j.ends, j.ends[::-1]):
                if b.body == GROUND or a.body == GROUND:
                    continue
                ib = names.index(b.body)
                if not z[3 * ib : 3 * ib + 2].any():
                    th = z[3 * ib + 2]
                    z[3 * ib : 3 * ib + 2] = point(z, a) - float(b.xi or 0.0) * alpha[b.body] * np.array(
                        [math.cos(th), math.sin(th)]
                    )
    for _ in range(60):
        r = residual(z)
        if np.max(abs(r), initial=0.0) < 1e-12:
            break
        J = np.array([(residual(z + h) - r) / 1e-7 for h in np.eye(len(z)) * 1e-7]).T
        z = z - np.linalg.lstsq(J, r, rcond=None)[0]
    if np.max(abs(residual(z)), initial=0.0) > 1e-8:
        return None
    out = {n: (z[3 * i : 3 * i + 2], float(z[3 * i + 2])) for i, n in enumerate(names)}
    for k, j in enumerate(slots):
        out[j.name] = (np.zeros(2), float(z[3 * len(names) + k]))
    return out


def _guide_slots(scene: Scene) -> dict[str, Joint]:
    """Elastic guide bar -> its slot joint (the guide is the slot's second end, ``variable``)."""
    out: dict[str, Joint] = {}
    for j in scene.joints:
        if j.kind == "slot" and not scene.body(j.ends[1].body).rigid:
            out.setdefault(j.ends[1].body, j)
    return out


#: a guide's elastic-overhang functions are checked up to an overhang of this many spans
#: (tests/test_slot_overhang.py: the frozen guide's first three frequencies within 2.5 % of the
#: finite-element beam's up to six spans, within 0.4 % up to one)
OVERHANG_SPANS_CHECKED = 6.0


def contact_range(scene: Scene, guess: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Slot joint -> (least, largest) contact beta over one turn of the angle drivers
    (``RINGING_POSITIONS`` positions of the rigid mechanism, each placed from the previous one;
    the start alone without a driver at a rate): the range the guide's basis must carry."""
    slots = [j for j in scene.joints if j.kind == "slot"]
    if not slots:
        return {}
    angle = [d for d in scene.drivers if d.kind == "angle" and d.initial is not None and d.law is None]
    rate = max((abs(d.rate) for d in angle), default=0.0)
    taus = [k * 2 * math.pi / rate / RINGING_POSITIONS for k in range(RINGING_POSITIONS)] if rate > 0 else [0.0]
    seen: dict[str, list[float]] = {j.name: [] for j in slots}
    prev = dict(guess)
    for tau in taus:
        drivers = tuple(
            replace(d, initial=float(d.initial or 0.0) + d.rate * tau) if d in angle else d for d in scene.drivers
        )
        place = _placement(replace(scene, drivers=drivers), prev)
        if place is None:
            continue
        prev = {n: a for n, (_, a) in place.items()}
        for j in slots:
            seen[j.name].append(place[j.name][1])
    return {n: (min(b), max(b)) for n, b in seen.items() if b}


def _overhang_warning(scene: Scene, name: str, guess: dict[str, float]) -> str:
    """A warning where guide ``name``'s elastic overhang exceeds OVERHANG_SPANS_CHECKED spans at a
    position of the turn ("" otherwise)."""
    joints = [j for j in scene.joints if j.kind == "slot" and j.ends[1].body == name and j.overhang_modes]
    if not joints:
        return ""
    ranges = contact_range(scene, guess)
    for j in joints:
        if j.name not in ranges:
            continue
        lo = ranges[j.name][0]
        if 0.0 < lo < 1.0 and (1.0 - lo) / lo > OVERHANG_SPANS_CHECKED:
            return (
                f"joints.{j.name}: the contact reaches beta = {lo:.3g} of {name} over the turn: its overhang is "
                f"{(1.0 - lo) / lo:.3g} spans, beyond the {OVERHANG_SPANS_CHECKED:g} the overhang's "
                f"{j.overhang_modes} functions were checked for (the guide's frequencies within 2.5 %); "
                f"compare a run with joints.{j.name}.overhang_modes raised"
            )
    return ""


def _coupled_supported(scene: Scene) -> str:
    """'' when the coupled model covers the scene, else what it does not cover. A slot's guide
    is covered with an elastic overhang (its span functions, the contact-slope function and
    the overhang's own functions at the start's contact, ``symgen.model.slot``); with a rigid
    overhang (each span function carries the overhang's rotation) it is not."""
    guides = [j.ends[1].body for j in scene.joints if j.kind == "slot" and not scene.body(j.ends[1].body).rigid]
    if len(set(guides)) < len(guides):
        return "a guide with two slots"
    if any(j.kind == "slot" and j.ends[1].body in guides and not j.overhang_modes for j in scene.joints):
        return "a slot's guide with a rigid overhang"
    if any(m.offset is not None for m in scene.masses):
        return "masses beside a bar (offset)"
    if any(j.kind == "slider" and all(e.body != GROUND for e in j.ends) for j in scene.joints):
        return "sliders between two bars"
    return ""


def _modes(K: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies ascending, M-normalised modes as columns) of K v = w^2 M v."""
    L = np.linalg.cholesky((M + M.T) / 2)
    Li = np.linalg.inv(L)
    lam, v = np.linalg.eigh(Li @ ((K + K.T) / 2) @ Li.T)
    return np.sqrt(np.maximum(lam, 0.0)), Li.T @ v


def _null(C: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the null space of C (columns)."""
    if not C.shape[0]:
        return np.eye(C.shape[1])
    _, sv, vt = np.linalg.svd(C)
    rank = int(np.sum(sv > 1e-10 * max(sv[0], 1.0)))
    return vt[rank:].T


class _Coupled:
    """The mechanism at its start position, linear about its undeformed state (no preload, no
    speed): every elastic bar a chain of Hermite beam and linear bar elements in its own axes,
    every rigid bar a rigid body, the joints' masses and ``[[masses]]`` lumped, the pins, sliders
    and angle drivers as linear constraints on the dofs. ``ritz`` maps the floating-frame model
    with given counts into it (each bar's frame motion plus its axial and transverse functions),
    so both spectra come from the same equations."""

    def __init__(self, scene: Scene, place: dict[str, tuple[np.ndarray, float]], inextensible: set[str]):
        self.scene = scene
        self.inextensible = inextensible
        self.parts: dict[str, _Part] = {}
        #: guide -> (its slot joint, the contact beta at the start)
        self.guides = {g: (j, float(place[j.name][1])) for g, j in _guide_slots(scene).items()}
        start = 0
        for body in scene.bodies:
            if body.rigid:
                x = np.zeros(1)
            else:
                x = _reference_bar(scene, body, interior_points(scene, body.name), True, COUPLED_ELEMENTS).x
                if body.name in self.guides:  # the span's functions (sin(k pi xi / beta)) need its own elements
                    b0 = self.guides[body.name][1]
                    x = np.unique(np.concatenate([x, np.linspace(0.0, b0, GUIDE_SPAN_ELEMENTS + 1)]).round(12))
            origin, theta = place[body.name]
            self.parts[body.name] = _Part(body, start, x, theta, origin)
            start += 3 * len(x)
        self.n = start
        self.K, self.M = np.zeros((start, start)), np.zeros((start, start))
        self.bending: dict[str, tuple[slice, np.ndarray]] = {}
        self._built: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for p in self.parts.values():
            self._body_matrices(p)
        self._lumped()
        self.C = self._constraints()

    # dofs ---------------------------------------------------------------------------------------
    def translation(self, end) -> np.ndarray:
        """2 x n: the global displacement of a joint end's point (zero for ground; a slot's
        guide end: its material point at the start's contact)."""
        row = np.zeros((2, self.n))
        if end.body == GROUND:
            return row
        p = self.parts[end.body]
        if end.xi is None:
            end = JointEnd(end.body, self.guides[end.body][1])
        c, s = math.cos(p.theta), math.sin(p.theta)
        if p.body.rigid:
            arm = float(end.xi) * p.body.alpha
            row[:, p.start : p.start + 3] = [[1.0, 0.0, -arm * s], [0.0, 1.0, arm * c]]
        else:
            k = p.start + 3 * _node(p.x, float(end.xi))
            row[:, k : k + 2] = [[c, -s], [s, c]]
        return row

    def rotation(self, body: str, xi: float = 0.0) -> np.ndarray:
        row = np.zeros(self.n)
        p = self.parts[body]
        if p.body.rigid:
            row[p.start + 2] = 1.0
        elif p.body.frame == "cantilever":
            row[p.start + 3 * _node(p.x, xi) + 2] = 1.0 / p.body.alpha
        elif body in self.guides:  # a guide's frame: the chord from its pin to the contact
            k = _node(p.x, self.guides[body][1])
            a, b = p.start, p.start + 3 * k
            row[b + 1], row[a + 1] = 1.0 / (p.body.alpha * p.x[k]), -1.0 / (p.body.alpha * p.x[k])
        else:  # the chord's rotation
            a, b = p.start, p.start + 3 * (len(p.x) - 1)
            row[b + 1], row[a + 1] = 1.0 / p.body.alpha, -1.0 / p.body.alpha
        return row

    # matrices -------------------------------------------------------------------------------------
    def _body_matrices(self, p: _Part) -> None:
        b = p.body
        m = b.nu * b.alpha
        i = slice(p.start, p.start + 3 * len(p.x))
        if b.rigid:
            c, s, L = math.cos(p.theta), math.sin(p.theta), b.alpha
            self.M[i, i] = [
                [m, 0.0, -m * L * s / 2],
                [0.0, m, m * L * c / 2],
                [-m * L * s / 2, m * L * c / 2, m * L * L / 3],
            ]
            return
        Kb, Mb = _beam_fe(p.x)  # (w, dw/dxi) per node, EI = 1, unit mass per length, xi in [0, 1]
        ei = (b.mu or 0.0) * b.nu * b.alpha**4 / b.alpha**3
        ea = (b.lam or 0.0) * b.nu * b.alpha**2 / b.alpha
        nn = len(p.x)
        wi = [3 * k + j for k in range(nn) for j in (1, 2)]
        K, M = np.zeros((3 * nn, 3 * nn)), np.zeros((3 * nn, 3 * nn))
        K[np.ix_(wi, wi)] = ei * Kb
        M[np.ix_(wi, wi)] = m * Mb
        for e in range(nn - 1):
            h = p.x[e + 1] - p.x[e]
            k = [3 * e, 3 * e + 3]
            K[np.ix_(k, k)] += ea / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
            M[np.ix_(k, k)] += m * h / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])
        self.K[i, i] += K
        self.M[i, i] += M
        self.bending[b.name] = (i, np.where(np.isin(np.arange(3 * nn), wi)[:, None], K, 0.0))

    def _lumped(self) -> None:
        for j in self.scene.joints:
            end = next((e for e in j.ends if e.body != GROUND), None)
            if end is not None and j.mass:
                T = self.translation(end)
                self.M += j.mass * T.T @ T
            if end is not None and j.inertia:
                r = self.rotation(end.body, float(end.xi or 0.0))
                self.M += j.inertia * np.outer(r, r)
        for d in self.scene.drivers:
            if d.rotor_inertia:
                r = self.rotation(d.body)
                self.M += d.rotor_inertia * np.outer(r, r)
        for pm in self.scene.masses:
            T = self.translation(JointEnd(pm.body, pm.xi))
            self.M += pm.mass * T.T @ T
            if pm.inertia:
                r = self.rotation(pm.body, pm.xi)
                self.M += pm.inertia * np.outer(r, r)

    def _constraints(self) -> np.ndarray:
        rows: list[np.ndarray] = []
        self.rows: dict[str, list[int]] = {}
        for j in self.scene.joints:
            a, b = j.ends
            self.rows[j.name] = [len(rows), len(rows) + 1] if j.kind == "pin" else [len(rows)]
            if j.kind == "pin":
                rows += list(self.translation(a) - self.translation(b))
            elif j.kind == "slot":  # the pin's point stays on the guide's line (it slides along it)
                th = self.parts[b.body].theta if b.body != GROUND else 0.0
                normal = np.array([-math.sin(th), math.cos(th)])
                rows.append(normal @ (self.translation(a) - self.translation(b)))
            else:
                bar = a if b.body == GROUND else b
                line = np.array(j.direction, dtype=float)
                rows.append(np.array([-line[1], line[0]]) @ self.translation(bar))
        for d in self.scene.drivers:
            if d.kind == "angle":
                self.rows[f"driver {d.body}"] = [len(rows)]
                rows.append(self.rotation(d.body))
        for p in self.parts.values():
            if p.body.name in self.inextensible:
                # a bar without axial functions: its nodes keep their spacing
                for k in range(1, len(p.x)):
                    row = np.zeros(self.n)
                    row[p.start + 3 * k], row[p.start] = 1.0, -1.0
                    rows.append(row)
        return np.array(rows) if rows else np.zeros((0, self.n))

    # spectra ------------------------------------------------------------------------------------
    def spectrum(self, T: np.ndarray, count: bool = False):
        """All frequencies (per unit tau, ascending, the free rigid motions' near zero first) of
        the model restricted to span(T); ``count``: only the number of its dofs."""
        B = T @ _null(self.C @ T)
        if count:
            return B.shape[1]
        Kr, Mr = B.T @ self.K @ B, B.T @ self.M @ B
        L = np.linalg.cholesky((Mr + Mr.T) / 2)
        Li = np.linalg.inv(L)
        lam = np.linalg.eigvalsh(Li @ ((Kr + Kr.T) / 2) @ Li.T)
        return np.sqrt(np.maximum(lam, 0.0))

    def spectrum_and_modes(self) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """(number of free rigid motions, frequencies, mass-normalised modes as dof columns, the
        constraint rows' forces per unit modal amplitude: (K - w^2 M) phi = C^T mu) of the
        reference model; the free rigid motions (as many as the rigid mechanism has) left out."""
        N = _null(self.C)
        Kr, Mr = N.T @ self.K @ N, N.T @ self.M @ N
        L = np.linalg.cholesky((Mr + Mr.T) / 2)
        Li = np.linalg.inv(L)
        lam, v = np.linalg.eigh(Li @ ((Kr + Kr.T) / 2) @ Li.T)
        rigid = self.spectrum(self.ritz({}), count=True)  # the mechanism's free rigid motions
        keep = np.arange(len(lam)) >= rigid
        phi = N @ (Li.T @ v[:, keep])
        w = np.sqrt(lam[keep])
        resid = self.K @ phi - self.M @ phi * w**2
        mu = np.linalg.lstsq(self.C.T, resid, rcond=None)[0] if self.C.shape[0] else np.zeros((0, len(w)))
        return rigid, w, phi, mu

    def _functions(self, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A bar's MAX_CHOSEN axial and transverse functions and its static corrections on its nodes."""
        if name not in self._built:
            self._built[name] = self._build_functions(name)
        return self._built[name]

    def _build_functions(self, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = self.parts[name]
        b = p.body
        if name in self.guides:
            joint, b0 = self.guides[name]
            std, corr = _guide_functions(p.x, b0, MAX_CHOSEN, joint.overhang_modes)
            return np.zeros((len(p.x), 0)), std, corr
        U, _ = _axial_functions(b.axial_shapes or "complete", MAX_CHOSEN, p.x)
        bar = _reference_bar(
            self.scene, b, interior_points(self.scene, name), b.static_correction is not False, COUPLED_ELEMENTS
        )
        std, corr = _transverse_functions(bar, b.frame, MAX_CHOSEN)
        return U, std, corr

    def local(self, name: str, na: int, nt: int) -> np.ndarray:
        """A bar's floating-frame columns on its own dofs: its frame's translation and rotation,
        its first ``na`` axial and ``nt`` transverse functions and its static corrections."""
        p = self.parts[name]
        b, nn = p.body, len(p.x)
        if b.rigid:
            return np.eye(3)
        cols = []

        def put(u=None, w=None, dw=None):
            c = np.zeros(3 * nn)
            if u is not None:
                c[0::3] = u
            if w is not None:
                c[1::3], c[2::3] = w, dw
            cols.append(c)

        one = np.ones(nn)
        put(u=one)
        put(w=one, dw=0 * one)
        put(w=b.alpha * p.x, dw=b.alpha * one)  # the frame's rotation (w per unit angle)
        U, std, corr = self._functions(name)
        for k in range(min(na, U.shape[1]) if b.lam else 0):
            put(u=U[:, k])
        for F in (std[:, : min(nt, std.shape[1])], corr) if nt else ():
            for k in range(F.shape[1]):
                put(w=F[0::2, k], dw=F[1::2, k])
        if na and b.lam:  # after every other column: top_columns counts from the bar's first
            for col in self._axial_corrections(name).T:
                put(u=col)
        return np.array(cols).T

    def _axial_corrections(self, name: str) -> np.ndarray:
        """A bar's axial static correction functions on its nodes (columns): the static stretch
        of a unit axial point force at each interior point, u = min(xi, xi_k) (as the derived
        model's, symgen.model.static_shapes.static_polynomials "axial", which has them where the
        bar keeps its axial dynamics and ``static_correction`` is not false). Without them a
        lumped mass part-way along a bar rings axially at a Ritz frequency the run's basis does
        not have (the kept-out aluminium crank-rocker's 0.2 kg at xi 0.4: 3.6 % high with 3
        axial functions, against 0.14 % with the correction)."""
        p = self.parts[name]
        if p.body.static_correction is False:
            return np.zeros((len(p.x), 0))
        pts = interior_points(self.scene, name)
        return np.array([np.minimum(p.x, xi) for xi in pts]).T if pts else np.zeros((len(p.x), 0))

    def ritz(self, counts: dict[str, tuple[int, int]]) -> np.ndarray:
        """The floating-frame model with ``counts`` (bar -> (axial, transverse)) as columns of
        the dofs (:meth:`local` per bar)."""
        blocks = []
        for name, p in self.parts.items():
            L = self.local(name, *counts.get(name, (0, 0)))
            full = np.zeros((self.n, L.shape[1]))
            full[p.start : p.start + L.shape[0]] = L
            blocks.append(full)
        return np.hstack(blocks)


@dataclass(frozen=True)
class CoupledCheck:
    """The coupled spectrum's verdict on a set of counts: ``estimate`` (fraction of peak), the
    mode that sets it (its frequency per unit tau, the Ritz frequency of the floating-frame
    model with the counts, its share of the outputs' peak) and what it measures; ``fastest``
    (:meth:`_CoupledEstimate.quasi_check`): the frequency of the fastest mode the run rings
    above its tolerance, averaged over the run, of the model with the quasi-static functions
    (the ringing BDF follows: its steps go as this); from a quasi-static start the fastest
    bending-dominated mode."""

    estimate: float
    omega: float = 0.0
    omega_ritz: float = 0.0
    share: float = 0.0
    what: str = ""
    fastest: float = 0.0  # quasi_check: the fastest mode the run rings, averaged over the run (per unit tau)


class _CoupledEstimate:
    """The a-priori estimate of the coupled modes' error for given counts, from :class:`_Coupled`.

    An undeformed start that is not quasi-static meets the inertia loads at once: each coupled
    mode k then rings with the static share of the load it carries, a_k = phi_k^T f / w_k^2 (f:
    the loads of a uniform acceleration of the mechanism along x and along y and of a rotation
    about the origin; mass-normalised phi_k). An output that reads a deflection (relative to the
    bar's frame) sees a_k |phi_k|, one that reads a force of a constraint (``driver_torque``,
    ``reaction``) a_k |mu_k| with (K - w_k^2 M) phi_k = C^T mu_k: undiminished with frequency,
    which is why reactions need the high modes. Each share is relative to the static response of
    the same loads. The floating-frame model rings at its Ritz frequency w_k (1 + e_k): over the
    run (or while the mode rings: Kelvin-Voigt damping c decays it in 2 / (c w_k^2)) its phase
    drifts by w_k T e_k, so the mode's part of the error is share_k min(PHASE_CAP, w_k T e_k);
    a mode the counts do not have at all (no Ritz mode of its shape, :meth:`partners`) misses
    its whole share; both as the outputs' rows see them (:meth:`seen`: a damped ringing decayed
    to the first row). Without a ringing start only
    the modes inside the run's band count, as for each bar's own: FREQUENCY_WEIGHT e_k."""

    def __init__(self, model: _Coupled, rings: bool, omega_run: float, deformed: bool = False):
        self.model = model
        sc = model.scene
        self.rigid, self.w, self.phi, self.mu = model.spectrum_and_modes()
        self.rings = rings
        self.omega_run = omega_run
        T = sc.simulation.t_end
        c = sc.effects.damping
        self.t_eff = np.array([T if c <= 0 else min(T, 2.0 / (c * w * w)) for w in self.w])
        self.share = self._shares()
        # the fraction of a sudden start's ringing each mode gets (a ramped start from rest: less)
        deformed = deformed or bool(sc.initial.deformation)
        self.onset = np.array([start_onset(sc, float(w), deformed) for w in self.w])

    def _fields(self) -> list[np.ndarray]:
        """The start's loads: a chain without a driver starts at rest, loaded by gravity alone (along
        it: a uniform field); a driven mechanism's inertia loads turn over the cycle (uniform fields
        along x and y and a rotation about the origin)."""
        m = self.model
        sc = m.scene
        gx, gy = sc.effects.gravity
        if not sc.drivers and math.hypot(gx, gy) > 0:
            x_part, y_part = gx / math.hypot(gx, gy), gy / math.hypot(gx, gy)
            kinds: tuple[str, ...] = ("gravity",)
        else:
            x_part, y_part = 0.0, 0.0
            kinds = ("x", "y", "turn")
        out = []
        for kind in kinds:
            g = np.zeros(m.n)
            for p in m.parts.values():
                c, s = math.cos(p.theta), math.sin(p.theta)
                if p.body.rigid:
                    g[p.start : p.start + 3] = {
                        "x": (1, 0, 0),
                        "y": (0, 1, 0),
                        "turn": (-p.origin[1], p.origin[0], 1),
                        "gravity": (x_part, y_part, 0),
                    }[kind]
                    continue
                pos = p.origin[:, None] + np.outer((c, s), p.x * p.body.alpha)
                d = {
                    "x": np.vstack([np.ones_like(p.x), np.zeros_like(p.x)]),
                    "y": np.vstack([np.zeros_like(p.x), np.ones_like(p.x)]),
                    "turn": np.vstack([-pos[1], pos[0]]),
                    "gravity": np.vstack([x_part * np.ones_like(p.x), y_part * np.ones_like(p.x)]),
                }[kind]
                g[p.start : p.start + 3 * len(p.x) : 3] = c * d[0] + s * d[1]
                g[p.start + 1 : p.start + 3 * len(p.x) : 3] = -s * d[0] + c * d[1]
                g[p.start + 2 : p.start + 3 * len(p.x) : 3] = p.body.alpha if kind == "turn" else 0.0
            out.append(m.M @ g)
        return out

    def _relative(self, v: np.ndarray) -> np.ndarray:
        """Per elastic bar the largest deflection relative to its frame (columns of v)."""
        out = []
        for p in self.model.parts.values():
            if p.body.rigid:
                continue
            w = v[p.start + 1 : p.start + 3 * len(p.x) : 3]
            if p.body.frame == "cantilever":
                dw = v[p.start + 2]
                rel = w - w[0] - np.outer(p.x, dw)
            elif p.body.name in self.model.guides:  # the frame: the chord to the contact
                k = _node(p.x, self.model.guides[p.body.name][1])
                rel = w - w[0] - np.outer(p.x / p.x[k], w[k] - w[0])
            else:
                rel = w - w[0] - np.outer(p.x, w[-1] - w[0])
            out.append(np.max(abs(rel), axis=0))
        return np.array(out)

    def _points(self, v: np.ndarray) -> np.ndarray:
        """What the outputs read of the deflections (columns of v): a chord or frame deflection at
        its point of its bar, any other output of a bar the largest deflection of that bar, of a
        rigid part or of none every elastic bar's (as :meth:`_relative`); forces apart."""
        rel = self._relative(v)
        elastic = [p for p in self.model.parts.values() if not p.body.rigid]
        out = []
        for o in self.model.scene.outputs:
            if o.kind in ("driver_torque", "reaction", "energy", "closure_residual"):
                continue
            p = self.model.parts.get(o.body or "")
            if p is None or p.body.rigid:
                out += list(rel)
                continue
            i = elastic.index(p)
            if o.kind in ("chord_deflection", "deflection") and o.xi is not None:
                out.append(abs(self._relative_at(p, v, float(o.xi))))
            else:
                out.append(rel[i])
        return np.array(out) if out else np.zeros((0, v.shape[1]))

    def _relative_at(self, p: _Part, v: np.ndarray, xi: float) -> np.ndarray:
        w = v[p.start + 1 : p.start + 3 * len(p.x) : 3]
        k = _node(p.x, xi)
        if p.body.frame == "cantilever":
            return w[k] - w[0] - p.x[k] * v[p.start + 2]
        if p.body.name in self.model.guides:  # the frame: the chord to the contact
            c = _node(p.x, self.model.guides[p.body.name][1])
            return w[k] - w[0] - p.x[k] / p.x[c] * (w[c] - w[0])
        return w[k] - w[0] - p.x[k] * (w[-1] - w[0])

    @functools.cached_property
    def point_share(self) -> np.ndarray:
        """Each mode's share as :attr:`share`, the deflections read where the outputs read them
        (:meth:`_points`): the measure of the quasi-static functions' change (:meth:`quasi_check`)."""
        return self._shares(self._points)

    def _shares(self, reading=None) -> np.ndarray:
        m, sc = self.model, self.model.scene
        rows: list[int] = []
        if any(o.kind == "driver_torque" for o in sc.outputs):
            rows += [i for k, v in m.rows.items() if k.startswith("driver ") for i in v]
        rows += [i for o in sc.outputs if o.kind == "reaction" and o.joint in m.rows for i in m.rows[o.joint]]
        deflect = any(o.kind not in ("driver_torque", "reaction", "energy", "closure_residual") for o in sc.outputs)
        read = reading or self._relative
        ring_d, ref_d, ring_f, ref_f = [], [], [], []
        for f in self._fields():
            # the static response to the loads, less what accelerates the free rigid motions: the
            # sum over every mode of the reference model; K us = f (less its rigid part) + C^T lam_s
            amp = (self.phi.T @ f) / self.w**2
            if deflect:
                ring = read(self.phi) * abs(amp)[None, :]
                ring_d.append(ring)
                ref_d.append(read((self.phi @ amp)[:, None])[:, 0] + np.sum(ring, axis=1))
            if rows:
                ref_f.append(float(np.max(abs((self.mu @ amp)[rows]))))
                ring_f.append(np.max(abs(self.mu[rows]), axis=0) * abs(amp))
        # each relative to the largest static response of the loads (the outputs' peaks)
        share = np.zeros(len(self.w))
        if ref_d:
            scale_d = np.max(np.array(ref_d), axis=0)  # per bar (per reading)
            ok = scale_d > 1e-9 * max(float(np.max(scale_d)), 1e-300)
            if ok.any():
                share = np.maximum(share, np.max(np.max(np.array(ring_d), axis=0)[ok] / scale_d[ok, None], axis=0))
        if ref_f and max(ref_f) > 0:
            share = np.maximum(share, np.max(np.array(ring_f), axis=0) / max(ref_f))
        return share

    def partners(self, counts: dict[str, tuple[int, int]]) -> np.ndarray:
        """Each reference mode's partner in the floating-frame model with ``counts``: the Ritz
        frequency of the Ritz mode of the largest mass-weighted overlap with it (both
        mass-normalised) where that overlap is at least MODE_MATCH, else 0 (the counts have no
        such mode). Pairing by index would compare two close modes the Ritz model reorders (one
        of them carried less well) each with the other's frequency, and a mode the counts miss
        with the next one's. (An overlap above 1 / sqrt(2) makes the pairing one to one.)"""
        m = self.model
        T = m.ritz(counts)
        B = T @ _null(m.C @ T)
        wr, v = _modes(B.T @ m.K @ B, B.T @ m.M @ B)
        wr, psi = wr[self.rigid :], (B @ v)[:, self.rigid :]
        out = np.zeros(len(self.w))
        if not len(wr):
            return out
        overlap = self.phi.T @ (m.M @ psi)
        best = np.argmax(np.abs(overlap), axis=1)
        for k, j in enumerate(best):
            # a repeated Ritz frequency's modes are any basis of their space: the overlap with it
            same = np.abs(wr - wr[j]) <= 1e-9 * max(float(wr[j]), 1.0)
            if math.sqrt(float(np.sum(overlap[k, same] ** 2))) >= MODE_MATCH:
                out[k] = wr[j]
        return out

    def check(self, counts: dict[str, tuple[int, int]]) -> CoupledCheck:
        acc = self.model.scene.simulation.accuracy
        partner = self.partners(counts)
        worst = CoupledCheck(0.0)
        for k, w in enumerate(self.w):
            if partner[k] > 0:
                e = abs(partner[k] / w - 1.0)
                if self.rings:
                    est = self.share[k] * self.seen(k, w * e)
                    what = "its phase over the run"
                else:
                    est = FREQUENCY_WEIGHT * e if amplification_error(self.omega_run, w) > acc else 0.0
                    what = "its frequency, in the run's band"
                wr = float(partner[k])
            else:
                est = self.share[k] * self.seen(k) if self.rings else 0.0
                what, wr = "missing: the counts have no such mode", 0.0
            if est > worst.estimate:
                worst = CoupledCheck(float(est), float(w), wr, float(self.share[k]), what)
        return worst

    def seen(self, k: int, drift: float | None = None) -> float:
        """How much of mode ``k``'s ringing share the outputs' rows can see wrong: the one rule
        for :meth:`check` and :meth:`quasi_check`. At tau = 0 every model starts alike; the
        outputs read the ringing at their rows tau = output_step, 2 output_step, ..., where at
        most :func:`ringing_left` of it is left (Kelvin-Voigt c; undamped: all of it). A mode
        the counts have (``drift``: its phase drift rate w_k e_k) drifts by at most
        drift max(t_eff, output_step) while it rings (t_eff: 2 / (c w_k^2), at most the run), a
        bound of drift t exp(-t / t_d) at every row; a mode the counts do not have at all (or
        quasi-static functions take away) misses its whole amplitude there. (The kept-out damped
        aluminium crank-rocker's coupled modes above 1000 per unit tau are gone within 1e-3 tau,
        its output step 0.026 tau: counted whole they asked for 16 more functions; the run with
        the bars' own counts differs from a rich one by 2.5e-4 of peak.)"""
        sc = self.model.scene
        T, step = sc.simulation.t_end, sc.simulation.output_step
        first = min(step, T) if step > 0 else 0.0
        amplitude = ringing_left(sc.effects.damping, float(self.w[k]), first)
        if drift is None:
            return amplitude
        return min(PHASE_CAP, drift * min(T, max(float(self.t_eff[k]), first))) * amplitude

    def culprit(
        self, check: CoupledCheck, refinable: list[tuple[str, str]], counts: dict[str, tuple[int, int]]
    ) -> tuple[str, str] | None:
        """(bar, "axial" | "transverse") whose functions miss the most strain energy of the mode
        that sets the estimate: the part of the mode's shape on the bar outside the span of its
        current columns, in the energy of that family."""
        k = int(np.argmin(abs(self.w - check.omega)))
        best, out = -1.0, None
        for name, kind in refinable:
            i, Kb = self.model.bending[name]
            K = Kb if kind == "transverse" else self.model.K[i, i] - Kb
            b = self.phi[i, k]
            T = self.model.local(name, *counts[name])
            c = np.linalg.lstsq(T.T @ K @ T, T.T @ K @ b, rcond=None)[0]
            r = b - T @ c
            missed = float(r @ K @ r)
            if missed > best:
                best, out = missed, (name, kind)
        return out

    def top_columns(self, counts: dict[str, tuple[int, int]], name: str, k: int, axial: bool = False) -> list[int]:
        """The columns of :meth:`_Coupled.ritz` of bar ``name``'s highest ``k`` standard
        transverse functions (before its static corrections), or with ``axial`` of its highest
        ``k`` axial functions."""
        start = 0
        for n, p in self.model.parts.items():
            if n == name:
                na, nt = counts[n]
                U, std, _ = self.model._functions(n)
                axial_count = min(na, U.shape[1]) if p.body.lam else 0
                first = start + 3 + (0 if axial else axial_count)
                last = first + (axial_count if axial else min(nt, std.shape[1]))
                return list(range(max(last - k, first), last))
            start += self.model.local(n, *counts.get(n, (0, 0))).shape[1]
        return []

    def quasi_check(
        self, counts: dict[str, tuple[int, int]], quasi: dict[str, int], axial: dict[str, int] | None = None
    ) -> CoupledCheck | None:
        """What making the highest ``quasi[bar]`` transverse functions and the highest
        ``axial[bar]`` axial functions of each bar quasi-static changes (None: one of them moves a
        joint). The floating-frame model with ``counts`` and the
        same model with those functions' inertia dropped (static condensation: their amplitudes
        follow the others through the stiffness, h = -K_hh^-1 K_hd d) are compared mode by mode
        (each of the first model's modes with the second's of the largest mass-weighted overlap):
        a mode that keeps its shape (overlap at least MODE_MATCH) rings at a shifted frequency,
        its error as :meth:`check`'s with the shift counted QUASI_PHASE_SAFETY times; a mode
        that has none left (the functions' own modes, the bar's lowest too where every function
        is quasi-static) misses its ringing share, plus its dynamic amplification r^2 / (1 - r^2)
        at the run's fastest content (``omega_run``: the driver harmonics and the loads' rate),
        counted as a fraction of the peak (the lowest mode carries about the whole deflection: for
        it this is the quasi-static response's error, about (Omega / w)^2 of it). Both ringing
        parts as the outputs' rows see them (:meth:`seen`, the rule :meth:`check` applies). The ringing
        shares are those of a sudden start times :func:`start_onset` (a ramped start from rest
        rings the modes far less). The estimate is the root of the sum of squares over the modes;
        the shares read the deflections where the outputs read them (:attr:`point_share`)."""
        m = self.model
        acc = m.scene.simulation.accuracy
        T = m.ritz(counts)
        H = sorted(
            {c for name, k in quasi.items() if k for c in self.top_columns(counts, name, k)}
            | {c for name, k in (axial or {}).items() if k for c in self.top_columns(counts, name, k, axial=True)}
        )
        D = [c for c in range(T.shape[1]) if c not in set(H)]
        CT = m.C @ T
        if H and CT.shape[0] and np.abs(CT[:, H]).max() > QUASI_JOINT_TOL * max(float(np.abs(CT).max()), 1e-300):
            return None
        if any(self._axial_moves_joint(name, counts[name][0], k) for name, k in (axial or {}).items() if k):
            return None
        N = _null(CT[:, D])
        Bm = np.hstack([T[:, D] @ N, T[:, H]])
        Kr, Mr = Bm.T @ m.K @ Bm, Bm.T @ m.M @ Bm
        nd = N.shape[1]
        wd, vd = _modes(Kr, Mr)
        X = np.linalg.solve(Kr[nd:, nd:], Kr[nd:, :nd]) if H else np.zeros((0, nd))
        wq, vq = _modes(Kr[:nd, :nd] - Kr[:nd, nd:] @ X, Mr[:nd, :nd])
        vq = np.vstack([vq, -X @ vq])
        r = self.rigid
        wd, vd, wq, vq = wd[r:], vd[:, r:], wq[r:], vq[:, r:]
        norm = np.sqrt(np.einsum("ij,ij->j", vq, Mr @ vq))
        overlap = np.abs(vd.T @ Mr @ vq) / norm[None, :]
        reference = np.argmax(np.abs((Bm @ vd).T @ m.M @ self.phi), axis=1)
        fastest = self._fastest_ringing(Bm @ vq, wq) if self.rings else self._fastest_bending(Bm @ vq, wq)
        total, worst = 0.0, CoupledCheck(0.0, fastest=fastest)
        for i, w in enumerate(wd):
            ref = int(reference[i])
            share = float(self.point_share[ref] * self.onset[ref])  # the ringing the start gives it
            j = int(np.argmax(overlap[i])) if overlap.shape[1] else -1
            amp = amplification_error(self.omega_run, float(w)) if w > 0 else 1.0
            if j >= 0 and overlap[i, j] >= MODE_MATCH:
                e = abs(wq[j] / w - 1.0)
                if self.rings:
                    est = share * self.seen(ref, QUASI_PHASE_SAFETY * w * e)
                    what = "its phase over the run"
                else:
                    est = QUASI_PHASE_SAFETY * FREQUENCY_WEIGHT * e if amp > acc else 0.0
                    what = "its frequency, in the run's band"
            else:
                est = (share * self.seen(ref) if self.rings else 0.0) + amp
                what = "quasi-static: its ringing and dynamic amplification missing"
            total += est * est
            if est > worst.estimate:
                worst = CoupledCheck(float(est), float(w), float(wq[j]) if j >= 0 else 0.0, share, what, worst.fastest)
        return replace(worst, estimate=math.sqrt(total))

    def _axial_moves_joint(self, name: str, na: int, k: int) -> bool:
        """Whether one of bar ``name``'s highest ``k`` of ``na`` axial functions is not zero at a
        joint of the bar: the closure reads it at some position of the cycle even where the start
        position's constraints do not (an axial displacement along a slider's line)."""
        p = self.model.parts[name]
        U = self.model._functions(name)[0][:, :na]
        top = U[:, max(na - k, 0) :]
        ends = [e.xi for j in self.model.scene.joints for e in j.ends if e.body == name and e.xi is not None]
        scale = max(float(np.abs(top).max(initial=0.0)), 1e-300)
        return any(float(np.abs(top[_node(p.x, float(xi))]).max(initial=0.0)) > QUASI_JOINT_TOL * scale for xi in ends)

    def _fastest_bending(self, u: np.ndarray, w: np.ndarray) -> float:
        """Where the start does not ring (a quasi-static start): the largest of the frequencies
        ``w`` whose mode (columns of ``u``, dofs) stores more than half its strain energy in
        bending (the start sets no mode ringing, the shares of :meth:`_fastest_ringing` do not
        apply; measured on the example slider-crank, 1607 -> 1118 steps; the crank-rocker at 900
        rpm from its quasi-static start keeps every function dynamic: its crank's bending at 894
        per unit tau stays, and the coupler's and rocker's functions the in-band estimate would
        allow change its outputs by 13 %)."""
        m = self.model
        bend = np.zeros(u.shape[1])
        for i, Kb in m.bending.values():
            bend += np.einsum("ij,ij->j", u[i], Kb @ u[i])
        total = np.einsum("ij,ij->j", u, m.K @ u)
        fast = [float(x) for x, b, t in zip(w, bend, total, strict=True) if t > 0 and b > 0.5 * t]
        return max(fast, default=0.0)

    def _fastest_ringing(self, u: np.ndarray, w: np.ndarray) -> float:
        """The frequency of the fastest mode the run rings, averaged over the run: BDF's steps
        follow the fastest ringing above its tolerance and step over one below it, whatever the
        mode's kind, so the run's steps go as the time integral of that frequency. A mode
        (columns of ``u``, dofs; frequencies ``w``) rings while its ringing share (:attr:`share`
        of the reference mode it overlaps most) decayed by the Kelvin-Voigt damping c,
        ``share exp(-t c w^2 / 2)``, is at least IDAS's rtol (undamped: the whole run). The
        slider-cranks' rods' axial modes (shares below 1e-13) cost nothing; the steel
        crank-rocker's crank's axial functions (shares 2e-5 and 4e-5 at rtol 1e-8, at 4161 and
        2407 per unit tau, undamped) set its step (benchmarks/RESULTS.md, "The steel
        crank-rocker's IDAS steps"); the damped validation crank-rocker's modes above 2000 per
        unit tau decay within 1e-4 of a turn and cost none."""
        if not u.shape[1]:
            return 0.0
        sc = self.model.scene
        rtol = sc.simulation.tolerances("idas")[0]
        T, c = sc.simulation.t_end, sc.effects.damping
        ref = np.argmax(np.abs(u.T @ self.model.M @ self.phi), axis=1)
        rings = []
        for x, r in zip(w, ref, strict=True):
            share = float(self.share[r])
            if x > 0 and share >= rtol:
                rings.append((float(x), T if c <= 0 else min(T, 2.0 / (c * x * x) * math.log(share / rtol))))
        total, covered = 0.0, 0.0
        for x, t in sorted(rings, reverse=True):  # the fastest ringing mode at each instant
            if t > covered:
                total, covered = total + x * (t - covered), t
        return total / T if T > 0 else 0.0


# -- the choice -----------------------------------------------------------------------------------
def coupled(scene: Scene, body) -> bool:
    """The bar's bending moves other parts: it is joined to another elastic bar, or a lumped
    mass (a joint's, a ``[[masses]]`` entry) sits on it. Its end slopes and rotations then set
    their motion, so the truncation of its slope counts (measured: a steel crank-rocker's coupler
    carrying a 0.15 kg tool at its rocker pin is 13 % off with 2 sines, 1.2 % without the tool)."""
    if any(m.body == body.name for m in scene.masses):
        return True
    for j in scene.joints:
        if any(e.body == body.name for e in j.ends):
            if j.mass > 0 or j.inertia > 0:
                return True
            if any(e.body not in (GROUND, body.name) and not scene.body(e.body).rigid for e in j.ends):
                return True
    return False


def transverse_estimates(
    scene: Scene, body, interior: tuple[float, ...], corrected: bool, omega_run: float, slope: bool = True
):
    """(omegas, dynamic count, estimate(n) for n = 1..MAX_CHOSEN) of a bar's bending; ``slope``:
    the truncation of the slope counts too (an output reads it, or a mass turns with it)."""
    bar = _reference_bar(scene, body, interior, corrected)
    f = bar.free
    lam, _ = _eig(bar.K[np.ix_(f, f)], bar.M[np.ix_(f, f)], MAX_CHOSEN + 1)
    omegas = np.sqrt(np.maximum(lam, 0.0) * body.mu)
    amp = [amplification_error(omega_run, w) for w in omegas]
    dynamic = max(1, sum(a > scene.simulation.accuracy for a in amp))
    standard, corrections = _transverse_functions(bar, body.frame, MAX_CHOSEN)
    cases = _static_loads(bar)
    estimates = []
    for n in range(1, MAX_CHOSEN + 1):
        B = np.hstack([standard[:, :n], corrections])
        missing = amp[n] if n < len(amp) else 0.0  # the first mode the n functions miss
        est = max(
            missing,
            STATIC_WEIGHT * _static_error(bar, B, cases, slope),
            FREQUENCY_WEIGHT * _ritz_error(bar, B, lam, min(dynamic, n)),
        )
        estimates.append(est)
    return omegas, int(dynamic), estimates


def _axial_functions(shapes: str, n: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(values, derivatives) of the first n axial functions on x (columns)."""
    if shapes == "stress-free":
        ks = [(2 * k - 1) * np.pi / 2 for k in range(1, n + 1)]
        return np.array([np.sin(k * x) for k in ks]).T, np.array([k * np.cos(k * x) for k in ks]).T
    vals = [x] + [np.sin(k * np.pi * x) for k in range(1, n)]
    ders = [np.ones_like(x)] + [k * np.pi * np.cos(k * np.pi * x) for k in range(1, n)]
    return np.array(vals[:n]).T, np.array(ders[:n]).T


def axial_estimates(scene: Scene, body, omega_run: float, points: tuple[float, ...]):
    """(omegas, dynamic count, estimate(n) for n = 1..MAX_CHOSEN) of a bar's axial functions:
    the first in-band axial mode missed, and the static truncation of the axial response to
    uniform and linear loads (u(0) = 0, far end free) at the ``points`` where outputs read the
    bar's stretch, relative to its largest value there (other outputs see the stretch, a fraction
    1/lambda of the bar's length, only through the positions it shifts, far below their peaks)."""
    omegas = np.array([(np.pi / 2) * (2 * k - 1) * math.sqrt(body.lam) for k in range(1, MAX_CHOSEN + 2)])
    amp = [amplification_error(omega_run, w) for w in omegas]
    dynamic = int(sum(a > scene.simulation.accuracy for a in amp))
    x, w = _gauss(64)
    at = np.array(points, dtype=float)
    exact = {"uniform": lambda s: s - s**2 / 2, "linear": lambda s: s / 2 - s**3 / 6}
    loads = {"uniform": np.ones_like(x), "linear": x}
    estimates = []
    for n in range(1, MAX_CHOSEN + 1):
        P, D = _axial_functions(body.axial_shapes or "complete", n, x)
        K = (D * w[:, None]).T @ D
        worst = 0.0
        if len(at):
            Pa, _ = _axial_functions(body.axial_shapes or "complete", n, at)
            for key, q in loads.items():
                u = Pa @ np.linalg.solve(K, P.T @ (w * q))
                ref = exact[key](at)
                worst = max(worst, float(np.max(abs(u - ref)) / np.max(abs(ref))))
        missing = amp[n] if n < len(amp) else 0.0
        estimates.append(max(missing, AXIAL_STATIC_WEIGHT * worst))
    return omegas, dynamic, estimates


def _first_meeting(estimates: list[float], accuracy: float, least: int) -> int:
    for n, est in enumerate(estimates, start=1):
        if n >= least and est <= accuracy:
            return n
    return len(estimates)


#: Whether :func:`choose_bases` recalls and remembers its choices in the signed cache
#: (:func:`remembered`; the command line turns it on for the scene it runs).
_REMEMBER = False


@contextlib.contextmanager
def remembered() -> Iterator[None]:
    """Within it, :func:`choose_bases` answers a choice it made before for the same inputs from
    the signed cache (``symgen.cache.recall``) instead of computing the bars' spectra again: a
    cached run's start (issue 20). The question holds the inputs' text (:func:`_canonical`), symgen's version and
    the hash of this module's source, so an edit of the chooser chooses again."""
    global _REMEMBER
    before, _REMEMBER = _REMEMBER, True
    try:
        yield
    finally:
        _REMEMBER = before


def _canonical(x: object) -> str:
    """A text of ``x`` that is the same in every process: sets and dicts in sorted order (the
    ``repr`` of a set follows the process's string hashes), dataclasses field by field."""
    if hasattr(x, "__dataclass_fields__"):
        fields = ",".join(f"{k}={_canonical(getattr(x, k))}" for k in x.__dataclass_fields__)
        return f"{type(x).__name__}({fields})"
    if isinstance(x, (set, frozenset)):
        return "{" + ",".join(sorted(_canonical(v) for v in x)) + "}"
    if isinstance(x, dict):
        return "{" + ",".join(sorted(f"{_canonical(k)}:{_canonical(v)}" for k, v in x.items())) + "}"
    if isinstance(x, (tuple, list)):
        return "(" + ",".join(_canonical(v) for v in x) + ")"
    return repr(x)


def _question(args: tuple) -> dict | None:
    from symgen import __version__

    text = _canonical(args)
    if " at 0x" in text:  # an object without a value repr: not a key
        return None
    with open(__file__, "rb") as fh:
        source = hashlib.sha256(fh.read()).hexdigest()
    return {
        "check": "scene.bases",
        "version": __version__,
        "chooser": source,
        "inputs": hashlib.sha256(text.encode()).hexdigest(),
    }


def _recalled(answer: object) -> dict[str, BasisChoice] | None:
    if not isinstance(answer, list):
        return None
    try:
        out = {}
        for d in answer:
            for k in ("given", "needed", "dynamic", "omega_bending", "omega_axial"):
                d[k] = tuple(d[k])
            c = BasisChoice(**d)
            out[c.bar] = c
    except (TypeError, KeyError, ValueError):
        return None
    return out


def choose_bases(
    scene: Scene,
    given: dict[str, tuple[int | None, int | None]],
    quasi_static_start: bool = False,
    guess: dict[str, float] | None = None,
    quasi_stated: frozenset[str] = frozenset(),
    deformed_start: bool = False,
) -> dict[str, BasisChoice]:
    """:func:`_choose_bases`, recalled from the signed cache within :func:`remembered`."""
    if not _REMEMBER:
        return _choose_bases(scene, given, quasi_static_start, guess, quasi_stated, deformed_start)
    from dataclasses import asdict

    from symgen import cache

    args = (
        scene,
        sorted(given.items()),
        quasi_static_start,
        sorted((guess or {}).items()),
        sorted(quasi_stated),
        deformed_start,
    )
    question = _question(args)
    if question is not None:
        try:
            known, answer = cache.recall(question)
        except (cache.InvalidEntry, OSError):  # e.g. a cache folder that is a file: choose
            known, answer = False, None
        got = _recalled(answer) if known else None
        if got is not None:
            return got
    chosen = _choose_bases(scene, given, quasi_static_start, guess, quasi_stated, deformed_start)
    if question is not None:
        cache.remember(question, [asdict(c) for c in chosen.values()])
    return chosen


def _choose_bases(
    scene: Scene,
    given: dict[str, tuple[int | None, int | None]],
    quasi_static_start: bool = False,
    guess: dict[str, float] | None = None,
    quasi_stated: frozenset[str] = frozenset(),
    deformed_start: bool = False,
) -> dict[str, BasisChoice]:
    """Per elastic bar: its counts (``given`` where the file states them, else chosen) and why.

    ``scene``: the scene with every stated count in place (absent ones may be anything);
    ``given``: bar -> (axial_modes, transverse_modes) as written (None: absent); a bar not in
    it keeps the counts on its record as stated; ``quasi_static_start``: the run starts on its
    quasi-static deformation (``initial.deformation = "quasi-static"``), else undeformed: the
    start rings the coupled modes; ``guess``: bar -> angle, the assembly guess (``initial.guess``);
    ``deformed_start``: the file states initial amplitudes (``initial.deformation`` as a table):
    the start is not at rest undeformed (:func:`start_onset`).

    Each bar's counts come from its own spectrum first, at least the floor a run's truncation
    estimate raised them to (``scene.counts_raised``: a bar whose file states neither count);
    where symgen chooses counts, the mechanism's coupled spectrum (:func:`coupled_choice`) then
    adds functions until its estimate meets the accuracy."""
    acc = scene.simulation.accuracy
    omega_run, how = run_frequency(scene)
    out: dict[str, BasisChoice] = {}
    own: dict[str, tuple[list[float], list[float]]] = {}
    for body in scene.bodies:
        if body.rigid:
            continue
        ga, gt = given.get(body.name, (body.axial_modes, body.transverse_modes))
        guide = any(j.kind == "slot" and any(e.body == body.name and e.variable for e in j.ends) for j in scene.joints)
        # bending
        if body.mu and scene.effects.transverse and not (gt == 0):
            corrected = body.static_correction is not False and not guide
            pts = interior_points(scene, body.name)
            slope = coupled(scene, body) or any(o.body == body.name and o.kind == "slope" for o in scene.outputs)
            wb, dyn_t, est_t = transverse_estimates(scene, body, pts, corrected, omega_run, slope)
            need_t = _first_meeting(est_t, acc, 1)
        else:
            wb, dyn_t, est_t, need_t = np.zeros(0), 0, [], 0
        # axial
        if body.lam and scene.effects.axial is not False and not guide and not (ga == 0):
            stretch = tuple(
                1.0 if o.xi is None else o.xi
                for o in scene.outputs
                if o.body == body.name and o.kind in STRETCH_OUTPUTS
            )
            wa, dyn_a, est_a = axial_estimates(scene, body, omega_run, stretch)
            least = AXIAL_MIN_VON_KARMAN if scene.effects.strain in ("von_karman", "exact") and need_t else 1
            need_a = _first_meeting(est_a, acc, least)
        else:
            wa, dyn_a, est_a, need_a = np.zeros(0), 0, [], 0
        na = need_a if ga is None else ga
        nt = need_t if gt is None else gt
        lifted = scene.counts_raised
        floor = lifted.floor(body.name) if lifted is not None and (ga, gt) == (None, None) else None
        raised = ""
        if lifted is not None and floor is not None:
            na = max(na, min(floor[0], MAX_CHOSEN)) if est_a else na
            nt = max(nt, min(floor[1], MAX_CHOSEN)) if est_t else nt
            if (na, nt) != (need_a, need_t):
                raised = f"raised to {na} axial + {nt} transverse functions by a run: {lifted.reason}"
        estimate = max(
            est_a[na - 1] if 0 < na <= len(est_a) else (0.0 if na or not est_a else 1.0),
            est_t[nt - 1] if 0 < nt <= len(est_t) else (0.0 if nt or not est_t else 1.0),
        )
        if (ga is None and need_a == MAX_CHOSEN and est_a and est_a[-1] > acc) or (
            gt is None and need_t == MAX_CHOSEN and est_t and est_t[-1] > acc
        ):
            estimate = max(est_a[-1] if est_a else 0.0, est_t[-1] if est_t else 0.0)
        shown_b = tuple(float(w) for w in wb[: max(dyn_t + 1, 3)])
        shown_a = tuple(float(w) for w in wa[: max(dyn_a + 1, 1)])
        reason = (
            f"fastest content {omega_run:.4g} ({how}); bending {', '.join(f'{w:.4g}' for w in shown_b) or 'none'}, "
            f"axial {', '.join(f'{w:.4g}' for w in shown_a) or 'none'} per unit tau: "
            f"{dyn_t} bending and {dyn_a} axial modes dynamic; the rest static shape; "
            f"{need_a} axial + {need_t} transverse functions meet accuracy {acc:g}"
        )
        if raised:
            reason += f"; {raised}"
        warning = ""
        if estimate > acc and (ga is not None or gt is not None):
            short = []
            if ga is not None and ga < need_a:
                short.append(f"axial_modes = {ga} (needs {need_a})")
            if gt is not None and gt < need_t:
                short.append(f"transverse_modes = {gt} (needs {need_t})")
            if short:
                warning = (
                    f"bodies.{body.name}: {' and '.join(short)}: the a-priori estimate {estimate:.2g} of peak "
                    f"exceeds simulation.accuracy = {acc:g}; remove the counts to let symgen choose, or raise them"
                )
        elif estimate > acc:
            warning = (
                f"bodies.{body.name}: even {MAX_CHOSEN} functions per family leave an a-priori estimate of "
                f"{estimate:.2g} of peak (> simulation.accuracy = {acc:g})"
            )
        if guide:
            over = _overhang_warning(scene, body.name, guess or {})
            warning = f"{warning}; {over}" if warning and over else warning or over
        own[body.name] = (est_a, est_t)
        out[body.name] = BasisChoice(
            body.name,
            na,
            nt,
            (ga, gt),
            (need_a, need_t),
            (dyn_a, dyn_t),
            float(estimate),
            acc,
            omega_run,
            shown_b,
            shown_a,
            reason,
            warning,
            raised=raised,
            quasi_stated=body.name in quasi_stated,
        )
    if any(None in c.given for c in out.values()):
        out = coupled_choice(
            scene, out, own, not quasi_static_start, guess or {}, omega_run, quasi_stated, deformed_start
        )
    return out


def _own_estimate(est: list[float], n: int) -> float:
    return est[n - 1] if 0 < n <= len(est) else 0.0


def coupled_choice(
    scene: Scene,
    choices: dict[str, BasisChoice],
    own: dict[str, tuple[list[float], list[float]]],
    rings: bool,
    guess: dict[str, float],
    omega_run: float,
    quasi_stated: frozenset[str] = frozenset(),
    deformed_start: bool = False,
) -> dict[str, BasisChoice]:
    """The per-bar choices checked against the mechanism's coupled spectrum at its start
    position (:class:`_CoupledEstimate`): while its estimate exceeds the accuracy, one more
    function for the chosen (not stated) family of the bar with the largest strain energy in
    the mode that sets it (at most COUPLED_STEPS more, MAX_CHOSEN per family). Every bar's
    estimate then includes the coupled one, its reason says what the check found. Then the
    functions that may be quasi-static (:func:`quasi_choice`)."""
    acc = scene.simulation.accuracy
    missing = _coupled_supported(scene)
    place = None if missing else _placement(scene, guess)
    if place is not None and any(
        not CONTACT_MARGIN < place[j.name][1] < 1 - CONTACT_MARGIN for j in _guide_slots(scene).values()
    ):
        place, missing = None, "the slot's contact at the start is at an end of its guide"
    if place is None:
        note = f"the coupled modes are not checked ({missing or 'the start position did not close'})"
        return {
            k: replace(c, reason=f"{c.reason}; {note}", quasi_reason=_not_checked(c, note)) for k, c in choices.items()
        }
    counts = {k: (c.axial, c.transverse) for k, c in choices.items()}
    inextensible = {
        b.name
        for b in scene.bodies
        if not b.rigid and (not b.lam or counts[b.name][0] == 0 or scene.effects.axial in (False, "inextensible"))
    }
    if any(b.mu is None or counts[b.name][1] == 0 for b in scene.bodies if not b.rigid) or not scene.effects.transverse:
        note = "the coupled modes are not checked (a bar without bending)"
        return {
            k: replace(c, reason=f"{c.reason}; {note}", quasi_reason=_not_checked(c, note)) for k, c in choices.items()
        }
    try:
        model = _CoupledEstimate(_Coupled(scene, place, inextensible), rings, omega_run, deformed_start)
    except np.linalg.LinAlgError:
        note = "the coupled modes are not checked (a massless part)"
        return {
            k: replace(c, reason=f"{c.reason}; {note}", quasi_reason=_not_checked(c, note)) for k, c in choices.items()
        }
    check = model.check(counts)
    first = check
    added = dict.fromkeys(counts, 0)
    stuck: set[str] = set()
    for _ in range(COUPLED_STEPS):
        if check.estimate <= acc:
            break
        refinable = [
            (name, kind)
            for name, c in choices.items()
            for kind, i in (("axial", 0), ("transverse", 1))
            if c.given[i] is None
            and 0 < counts[name][i] < MAX_CHOSEN
            and not (i == 0 and name in inextensible)
            and name not in stuck
        ]
        pick = model.culprit(check, refinable, counts)
        if pick is None:
            break
        name, kind = pick
        na, nt = counts[name]
        counts[name] = (na + 1, nt) if kind == "axial" else (na, nt + 1)
        trial = model.check(counts)
        if name in model.model.guides and trial.estimate >= check.estimate:
            # a guide's transverse count adds span functions: a mode of its overhang (its own
            # functions, the slot's overhang_modes) or of another part they do not carry
            counts[name] = (na, nt)
            stuck.add(name)
            continue
        added[name] += 1
        check = trial
    before = dict(counts)
    counts, ring_said, ring_est = ringing_choice(scene, choices, counts, not rings, guess, inextensible)
    if counts != before:
        for name in counts:
            added[name] += sum(counts[name]) - sum(before[name])
        check = model.check(counts)
    out = {}
    for name, c in choices.items():
        na, nt = counts[name]
        est_a, est_t = own[name]
        estimate = max(_own_estimate(est_a, na), _own_estimate(est_t, nt), check.estimate, ring_est.get(name, 0.0))
        if not added[name]:
            estimate = max(c.estimate, check.estimate, ring_est.get(name, 0.0))
        said = (
            f"the coupled modes at the start position ({'ringing from the start' if rings else 'in the band'}): "
            f"{first.estimate:.2g} of peak with the bars' own counts, from the mode at {first.omega:.4g} per unit tau "
            f"({first.what}, share {first.share:.2g})"
        )
        if any(added.values()):
            said += f"; {sum(added.values())} functions added ({', '.join(f'{k} +{v}' for k, v in added.items() if v)})"
            said += f": {check.estimate:.2g}"
        if name in ring_said:
            said += f"; {ring_said[name]}"
        warning = c.warning
        if check.estimate > acc and not warning:
            warning = (
                f"bodies.{name}: the coupled modes leave an a-priori estimate of {check.estimate:.2g} of peak "
                f"(> simulation.accuracy = {acc:g}; the mode at {check.omega:.4g} per unit tau, {check.what})"
            )
        if ring_est.get(name, 0.0) > acc and not warning:
            warning = (
                f"bodies.{name}: the phase of its axial ringing from the start leaves an a-priori estimate of "
                f"{ring_est[name]:.2g} of peak (> simulation.accuracy = {acc:g}); start with "
                'initial.deformation = "quasi-static", or damping, where the ringing is not wanted'
            )
        needed = (
            max(c.needed[0], na) if c.given[0] is None else c.needed[0],
            max(c.needed[1], nt) if c.given[1] is None else c.needed[1],
        )
        out[name] = replace(
            c,
            axial=na,
            transverse=nt,
            needed=needed,
            estimate=float(estimate),
            reason=f"{c.reason}; {said}",
            warning=warning,
        )
        if name in ring_said and c.given[1] is None and name not in quasi_stated:
            out[name] = replace(
                out[name],
                quasi_reason="every transverse function dynamic: the frequency of its axial ringing from the start "
                "needs them (the coupled check of quasi-static functions reads the start position only)",
            )
    # the bars whose axial ringing set their counts keep every transverse function dynamic
    return quasi_choice(scene, out, model, counts, quasi_stated | frozenset(ring_said))


def _not_checked(c: BasisChoice, note: str) -> str:
    """The quasi-static reason where the coupled modes are not checked."""
    return "" if c.given[1] is not None else f"every transverse function dynamic: {note}"


def known_content(scene: Scene, rigid: int) -> str:
    """Why the run's content may reach above ``omega_run`` ("" where it may not): the amplification
    of a quasi-static bar's lowest mode is estimated at ``omega_run``, which the angle drivers'
    rates bound (DRIVER_HARMONICS of them) only where every rigid motion is driven (``rigid``: the
    coupled model's free rigid modes) by an angle driver at a rate or a ramp; a torque (the speed
    it reaches), a law, a load given as an expression of tau or a free rigid motion (a swing) may
    have content beyond it. There the bar's lowest mode stays dynamic."""
    if rigid:
        return "a rigid motion no driver prescribes"
    for d in scene.drivers:
        if d.kind != "angle":
            return f"the torque driver of {d.body}"
        if d.law is not None:
            return f"the law of the driver of {d.body}"
    if any(isinstance(ld.axial, str) or isinstance(ld.transverse, str) for ld in scene.loads):
        return "a load given as an expression of tau"
    return ""


def _quasi_candidates(
    scene: Scene,
    choices: dict[str, BasisChoice],
    stated: frozenset[str],
    inextensible: set[str] | frozenset[str],
    unknown: str = "",
) -> dict[tuple[str, str], int]:
    """(bar, "transverse" | "axial") -> at most how many of its highest functions of that family
    may be quasi-static, where symgen chose the count: those above the modes the bar's own
    spectrum puts in the run's band (:func:`in_band`). Transverse: every function where no mode
    is in the band (the lowest, which the bases keep dynamic because a start may ring it, too:
    the coupled check counts that ringing and the lowest mode's amplification), unless the run's
    content is not bounded by its drivers' rates (``unknown``, :func:`known_content`: then
    above the bases' dynamic band, as before), where the file
    does not state ``quasi_static_transverse``, none on a slot's guide or with polynomial shapes
    (as ``symgen.numerics.mechanism.quasi_static_amplitudes`` refuses); axial: where symgen
    chose the axial count too, of a bar that keeps its axial functions in the coupled model (not
    inextensible). None on a bar whose file states its transverse treatment (the count or
    ``quasi_static_transverse``: the scene runs as written) or on a slot's guide with a rigid
    overhang; on a guide with an elastic overhang its span functions above the span's band
    (:func:`guide_band`)."""
    out: dict[tuple[str, str], int] = {}
    guides = _guide_slots(scene)
    for name, c in choices.items():
        body = scene.body(name)
        guide = any(j.kind == "slot" and any(e.body == name and e.variable for e in j.ends) for j in scene.joints)
        if c.given[1] is not None or name in stated or (guide and not (name in guides and guides[name].overhang_modes)):
            continue
        band = c.dynamic[1] if unknown else (guide_band(c) if guide else in_band(c))
        if body.transverse_shapes != "polynomial" and c.transverse - band > 0:
            out[(name, "transverse")] = c.transverse - band
        if c.given[0] is None and body.lam and name not in inextensible and c.axial - c.dynamic[0] > 0:
            out[(name, "axial")] = c.axial - c.dynamic[0]
    return out


def in_band(c: BasisChoice) -> int:
    """How many of the bar's own bending modes (:attr:`BasisChoice.omega_bending`, which holds
    the dynamic band and one more) the run's content amplifies beyond the accuracy
    (:func:`amplification_error`): ``dynamic[1]`` less the lowest mode the bases keep dynamic
    for a start that may ring it."""
    return min(c.dynamic[1], sum(amplification_error(c.omega_run, w) > c.accuracy for w in c.omega_bending))


def guide_band(c: BasisChoice) -> int:
    """How many of a guide's span functions the run's content may amplify beyond the accuracy:
    the span's modes (pinned at the pivot, clamped at the contact: the span functions have zero
    value and slope there, ``symgen.model.slot``) over the run are at least those of the whole
    length pinned-clamped (beta <= 1; their frequencies go as 1 / beta^2), the k-th
    ((k + 1/4) / k)^2 times the pinned-pinned bar's k-th (:attr:`BasisChoice.omega_bending`,
    the bar's own spectrum; the roots of tan x = tanh x are (k + 1/4) pi within 3e-4). The
    aluminium overhang reference's first: 1.562 x 7.31 = 11.4 per unit tau against its content
    4: in the band (its two span functions quasi-static were 3.4-18.8 % off its Exudyn
    reference)."""
    return sum(
        amplification_error(c.omega_run, w * ((k + 0.25) / k) ** 2) > c.accuracy
        for k, w in enumerate(c.omega_bending, 1)
    )


def _split(quasi: dict[tuple[str, str], int]) -> tuple[dict[str, int], dict[str, int]]:
    """(transverse, axial) counts per bar of a quasi-static set keyed by (bar, family)."""
    return (
        {n: k for (n, f), k in quasi.items() if f == "transverse" and k},
        {n: k for (n, f), k in quasi.items() if f == "axial" and k},
    )


def quasi_choice(
    scene: Scene,
    choices: dict[str, BasisChoice],
    model: _CoupledEstimate,
    counts: dict[str, tuple[int, int]],
    stated: frozenset[str] = frozenset(),
) -> dict[str, BasisChoice]:
    """The highest transverse and axial functions that may be quasi-static (residual
    flexibility, docs/quasi-static-modes.md), chosen from the mechanism's coupled modes: one
    function at a time (the bar and family whose next function changes the coupled estimate
    least), from the top of each bar's functions above its dynamic band
    (:func:`_quasi_candidates`), while the change the quasi-static functions make
    (:meth:`_CoupledEstimate.quasi_check`: every coupled mode's shift and the ringing of the
    modes they remove) stays within what the accuracy leaves over the bases' own estimate:
    ``accuracy - max(estimate)``. A function that moves a joint is not taken (nor any below it).
    Kept only where it lowers the fastest mode the run rings (:attr:`CoupledCheck.fastest`) by
    QUASI_GAIN, both taken at least ``omega_run`` (where no elastic mode is left ringing, every
    function quasi-static, the run's own content sets the steps). IDAS and the emitted C solver
    treat them alike (StartPlan.quasi)."""
    acc = scene.simulation.accuracy
    unknown = known_content(scene, model.rigid)
    limit = _quasi_candidates(scene, choices, stated, model.model.inextensible, unknown)
    budget = math.sqrt(max(acc * acc - max(c.estimate for c in choices.values()) ** 2, 0.0))
    quasi: dict[tuple[str, str], int] = {}
    last: CoupledCheck | None = None
    dynamic = model.quasi_check(counts, {})
    fastest = float(dynamic.fastest) if dynamic is not None else 0.0
    steps: list[tuple[dict[tuple[str, str], int], CoupledCheck]] = []
    while True:
        best: tuple[tuple[str, str], CoupledCheck, int] | None = None
        for key in list(limit):
            k = quasi.get(key, 0) + 1
            if k > limit[key]:
                continue
            check = model.quasi_check(counts, *_split({**quasi, key: k}))
            if check is None:  # moves a joint: so does every larger set of its highest functions
                limit[key] = k - 1
                continue
            if check.estimate <= budget and (best is None or check.estimate < best[1].estimate):
                best = (key, check, k)
        if best is None:
            break
        quasi[best[0]] = best[2]
        steps.append((dict(quasi), best[1]))
    # only what lowers the fastest mode the run rings saves steps (BDF follows that ringing, and
    # at least the run's own content omega_run, where no elastic mode rings): the shortest prefix
    # that lowers it most, if by QUASI_GAIN at least
    gain = ""
    quasi = {}
    if steps:
        low = min(c.fastest for _, c in steps)
        first = next(k for k, (_, c) in enumerate(steps) if c.fastest <= low)
        if max(fastest, model.omega_run) >= QUASI_GAIN * max(low, model.omega_run):
            quasi, last = _pruned(model, counts, *steps[first])
        else:
            floor = (
                f"; the steps follow at least the run's own content, {model.omega_run:.4g} per unit tau"
                if min(fastest, low) < model.omega_run
                else ""
            )
            gain = (
                f"the quasi-static functions the accuracy allows would lower the fastest mode the run rings only "
                f"from {fastest:.4g} to {low:.4g} per unit tau (less than {QUASI_GAIN:g}x{floor}: no steps saved)"
            )
    out = {}
    for name, c in choices.items():
        if c.given[1] is not None or name in stated:  # the file states the transverse treatment
            out[name] = c
            continue
        whys = [
            _quasi_reason((name, family), c, quasi, last, limit, steps, gain, fastest, budget, acc, model, counts)
            for family in ("transverse", "axial")
        ]
        if unknown and (name, "transverse") in limit and in_band(c) < c.dynamic[1]:
            whys.insert(
                1,
                f"its lowest mode stays dynamic whatever the accuracy: {unknown} may give the run content above "
                f"{model.omega_run:.4g} per unit tau",
            )
        out[name] = replace(
            c,
            quasi=quasi.get((name, "transverse"), 0),
            quasi_axial=quasi.get((name, "axial"), 0),
            quasi_reason="; ".join(w for w in whys if w),
        )
    return out


def _pruned(
    model: _CoupledEstimate, counts: dict[str, tuple[int, int]], quasi: dict[tuple[str, str], int], check: CoupledCheck
) -> tuple[dict[tuple[str, str], int], CoupledCheck]:
    """``quasi`` less the functions that do not lower the fastest mode the run rings: the greedy
    takes the cheapest change first, which may be a function whose mode does not ring (the
    slider-cranks' rods' axial functions); each family keeps the fewest of its highest functions
    with which the fastest ringing mode stays at ``check.fastest``."""
    quasi = dict(quasi)
    for key in list(quasi):
        while quasi[key]:
            trial = model.quasi_check(counts, *_split({**quasi, key: quasi[key] - 1}))
            if trial is None or trial.fastest > check.fastest * (1.0 + 1e-9):
                break
            quasi[key] -= 1
            check = trial
        if not quasi[key]:
            del quasi[key]
    return quasi, check


def _quasi_reason(
    key: tuple[str, str],
    c: BasisChoice,
    quasi: dict[tuple[str, str], int],
    last: CoupledCheck | None,
    limit: dict[tuple[str, str], int],
    steps: list[tuple[dict[tuple[str, str], int], CoupledCheck]],
    gain: str,
    fastest: float,
    budget: float,
    acc: float,
    model: _CoupledEstimate,
    counts: dict[str, tuple[int, int]],
) -> str:
    """Why bar ``key[0]``'s functions of family ``key[1]`` are (or are not) quasi-static, in
    words ("" for an axial family that was no candidate: nothing to say)."""
    name, family = key
    k = quasi.get(key, 0)
    n, band = (c.transverse, c.dynamic[1]) if family == "transverse" else (c.axial, c.dynamic[0])
    lead = "" if family == "transverse" else "axial: "
    none = f"{lead}every {family} function dynamic: "
    if k and last is not None:
        if name in model.model.guides and family == "transverse":
            which = (
                f"{'all' if k >= n else f'the highest {k} of'} {n} span functions of the guide are quasi-static "
                f"(the contact-slope and overhang functions dynamic; {guide_band(c)} span modes in the run's "
                "band, those of the whole length pinned-clamped bounding the span's over the run):"
            )
        else:
            which = (
                f"all {n} of its {family} functions are quasi-static (the bases' dynamic band of {band} included: "
                "the run's content is far below its lowest mode):"
                if k >= n and band
                else f"the highest {k} of its {n} {family} functions are quasi-static: above its {band} dynamic,"
            )
        onset = ""
        if model.rings and last.omega > 0:
            f = float(model.onset[int(np.argmin(abs(model.w - last.omega)))])
            if f < 1.0:
                onset = f"; the start from rest (the drivers' ramp) rings that mode at {f:.2g} of a sudden start's"
        low = (
            f"to {last.fastest:.4g} per unit tau"
            if last.fastest > 0
            else f"to none (no elastic mode rings: the run's own content, {model.omega_run:.4g} per unit tau, sets the steps)"
        )
        return (
            f"{lead}{which} they change the coupled modes by {last.estimate:.2g} of peak "
            f"(with the other quasi-static functions; the most at {last.omega:.4g} per unit tau, {last.what}{onset}), "
            f"within the {max(budget, 0.0):.2g} the accuracy {acc:g} leaves over the bases' estimate, and lower "
            f"the fastest mode the run rings from {fastest:.4g} {low}"
        )
    if key not in limit:
        return "" if family == "axial" else none + "none above its dynamic band"
    if limit[key] == 0:
        return none + "its highest function moves a joint"
    if steps and steps[-1][0].get(key, 0):  # within the accuracy, but saves no steps
        if gain:
            return none + gain
        return (
            none + "its highest quasi-static fits the accuracy but does not lower the fastest mode the run rings "
            f"(from {fastest:.4g} per unit tau) further"
        )
    t, a = _split({**quasi, key: 1})
    alone = model.quasi_check(counts, t, a)
    change = f"{alone.estimate:.2g} of peak" if alone is not None else "a moved joint"
    return none + (
        f"its highest quasi-static would change the coupled modes by {change}, more than the "
        f"{max(budget, 0.0):.2g} the accuracy {acc:g} leaves over the bases' estimate"
    )


#: what the start does, said where it rings
RINGING = (
    "the start (not quasi-static, undamped) rings the mechanism's coupled modes for the whole run; "
    "the estimate counts their phase at the start position (the coupled check), not their change over "
    'the cycle; start with initial.deformation = "quasi-static", or damping, where the ringing is not wanted'
)


def with_start(choices: tuple[BasisChoice, ...], quasi_static_start: bool, damping: float) -> tuple[BasisChoice, ...]:
    """The choices with ``start_rings`` set (and said in their reason) when the run starts
    neither on its quasi-static deformation nor damped."""
    if quasi_static_start or damping > 0:
        return choices
    return tuple(replace(c, start_rings=True, reason=f"{c.reason}; {RINGING}") for c in choices)


# -- the axial ringing of the start ----------------------------------------------------------------

#: a bar's end stretch under a uniform axial load (u(0) = 0, far end free) and its largest bending
#: deflection under a uniform transverse load, per unit load of the bar's own inertia (lengths in
#: the bar's length, loads in its m_i l_i omega^2): u = 1 / (2 lambda), w = c / mu
AXIAL_COMPLIANCE = 0.5
BENDING_COMPLIANCE = {"pinned-pinned": 5.0 / 384.0, "cantilever": 1.0 / 8.0}
#: output kinds the axial ringing is not estimated for: those of the axial force (the stretch, a
#: driver torque, a reaction), which an undeformed undamped start rings by its whole start value,
#: of the order of their peak: keeping the axial dynamics for them costs the steps of the axial
#: frequency (the stiff slider-crank of tests/test_axial_default.py, lambda = 1e5: 1517 -> 58419
#: IDAS steps), so they keep the separation's choice and the error estimate says what they miss
#: (docs/exact-bars.md); and those that read no bar's motion
AXIAL_RINGING_UNREAD = ("chord_elongation", "axial", "driver_torque", "reaction", "energy", "closure_residual")
#: ``effects.axial = "auto"`` (the default) eliminates a bar's axial dynamics when its first axial
#: frequency is at least this many times the fastest motion the run must resolve (and the axial
#: ringing a start that is not quasi-static excites is within the accuracy:
#: :func:`symgen.scene.bases.axial_ringing`): the quasi-static
#: axial response then misses the dynamic amplification 1 / (1 - r^2) - 1 ~ r^2 of the forcing at
#: a frequency ratio r <= 1/10, i.e. <= 1 % of the axial response, and far less of the bending
#: (tests/test_axial_default.py measures it against converged full-dynamics models).
AXIAL_SEPARATION = 10.0
#: first natural frequency / sqrt(group) of the standard bases: axial, any frame (phi(0) = 0, the
#: far end free along the bar: (pi/2) sqrt(lambda)); bending, by frame (pinned-pinned
#: pi^2 sqrt(mu), clamped-free 1.8751^2 sqrt(mu)); tau units (omega = 1).
AXIAL_FIRST = 1.5707963267948966
BENDING_FIRST = {"pinned-pinned": 9.869604401089358, "cantilever": 3.5160152028161017}
#: positions over one turn of the angle driver where the coupled axial mode's frequency is
#: compared (its phase drifts by the mean error over the cycle)
RINGING_POSITIONS = 8


def axial_separation(scene: Scene, body) -> tuple[float, float, float]:
    """(first axial frequency, the fastest motion the run must resolve, first bending frequency)
    of an elastic bar, per unit tau: what ``effects.axial = "auto"`` compares
    (:func:`symgen.model.structure.axial_treatment`): the run's is the larger of 2 x the first
    bending frequency and DRIVER_HARMONICS x the fastest driver rate (at least 1)."""
    w_axial = AXIAL_FIRST * (body.lam or 0.0) ** 0.5
    w_bend = BENDING_FIRST.get(body.frame, BENDING_FIRST["pinned-pinned"]) * body.mu**0.5 if body.mu else 0.0
    rate = max((abs(d.rate) for d in scene.drivers), default=0.0)
    return w_axial, max(2.0 * w_bend, DRIVER_HARMONICS * max(rate, 1.0)), w_bend


@dataclass(frozen=True)
class AxialRinging:
    """The axial ringing a run's start excites in one elastic bar (issue 19, the paper's
    slider-crank at accuracy 0.001): ``estimate`` (fraction of the outputs' peak) is what a
    quasi-static axial treatment leaves out, ``output`` the output that sets it, ``reason`` one
    sentence."""

    bar: str
    estimate: float
    output: str = ""
    reason: str = ""


def axial_ringing(scene: Scene, body, quasi_static_start: bool) -> AxialRinging:
    """The axial ringing a start that is not quasi-static excites in ``body``.

    An undeformed start (or one whose axial amplitudes are given) is not on the quasi-static
    axial state: the axial mode rings, undamped for the whole run, with the jump between the two,
    the start's quasi-static stretch. Its size relative to each output's peak, from the static
    responses of the bar to a load of its own inertia of the same magnitude along and across it
    (the inertia loads of a driven mechanism turn over the cycle; a chain's gravity likewise):

    * a deflection or slope of an elastic bar o: the stretch against o's bending,
      (1 / (2 lambda)) / (c_o / mu_o) (``BENDING_COMPLIANCE`` c: 5/384 pinned-pinned, 1/8 cantilever;
      in the loads' physical units the lengths cancel), the share the ringing stretch moves the
      points a deflection reads (measured on the paper's slider-crank: the estimate 1.0e-3,
      the ringing in eta_mid 5.5e-4 to 8.8e-4 of its peak over the run);
    * the positions and angles of the mechanism: the stretch against the bar's length, 1 / (2 lambda).

    Kelvin-Voigt damping c decays the first axial mode (w = (pi/2) sqrt(lambda)) in 2 / (c w^2):
    the estimate is the amplitude left at the end of the run, exp(-T c w^2 / 2) times the jump.
    0 where the run starts on its quasi-static deformation. The outputs of the axial force are not
    counted (``AXIAL_RINGING_UNREAD``)."""
    if quasi_static_start:
        return AxialRinging(body.name, 0.0, "", "the run starts on its quasi-static deformation")
    if body.rigid or not body.lam:
        return AxialRinging(body.name, 0.0, "", "no axial stiffness")
    stretch = AXIAL_COMPLIANCE / body.lam
    best, which, how = 0.0, "", ""
    for o in scene.outputs:
        if o.kind in AXIAL_RINGING_UNREAD:
            continue
        other = scene.body(o.body) if o.body not in (None, GROUND) else None
        if o.kind in ("chord_deflection", "deflection", "slope", "elastic_displacement") and (
            other is not None and not other.rigid and other.mu
        ):
            c = BENDING_COMPLIANCE.get(other.frame, BENDING_COMPLIANCE["pinned-pinned"])
            share = stretch / (c / other.mu)
            why = f"the start's stretch 1/(2 lambda) against the bending {c:.4g}/mu of {other.name}"
        else:
            share, why = stretch, "the start's stretch 1/(2 lambda) against the bar's length"
        if share > best:
            best, which, how = share, o.name, why
    c = scene.effects.damping
    if c > 0 and best > 0:
        w = (math.pi / 2) * math.sqrt(body.lam)
        decay = math.exp(-scene.simulation.t_end * c * w * w / 2)
        return AxialRinging(
            body.name,
            best * decay,
            which,
            f"the start (not quasi-static) rings its first axial mode by {best:.3g} of the peak of {which} "
            f"({how}), damped to {best * decay:.2g} by the end of the run (Kelvin-Voigt {c:g} at {w:.4g} per unit tau)",
        )
    return AxialRinging(
        body.name,
        best,
        which,
        f"the start (not quasi-static, undamped) rings its first axial mode for the whole run, by {best:.3g} "
        f"of the peak of {which} ({how})"
        if which
        else "no output reads the axial ringing",
    )


class _AxialRingingCheck:
    """The frequency of one bar's coupled axial mode over the cycle, against the floating-frame
    model with given counts (the phase of the axial ringing the start excites, :func:`axial_ringing`).

    At ``RINGING_POSITIONS`` positions over one turn of the angle drivers (the start alone without
    one) the linear model of the whole mechanism (:class:`_Coupled`) gives the mode of the bar's
    first axial frequency band with the most axial strain energy in the bar; away from a dead
    centre the joints couple it to the bar's bending (the paper's slider-crank: 212.3 at the dead
    centres, 210.2 per unit tau at 90 degrees), so its Ritz frequency converges with the
    transverse functions as well as the axial ones. The floating-frame model's mode is the one of
    the largest mass-weighted overlap; the ringing's phase drifts by the mean relative error over
    the positions times w T."""

    def __init__(self, scene: Scene, name: str, guess: dict[str, float], inextensible: set[str]):
        self.name = name
        self.t_end = scene.simulation.t_end
        self.damping = scene.effects.damping
        body = scene.body(name)
        w_first = (math.pi / 2) * math.sqrt(body.lam or 0.0)
        angle = [d for d in scene.drivers if d.kind == "angle" and d.initial is not None]
        start = {d.body: float(d.initial or 0.0) for d in angle}
        rate = max((abs(d.rate) for d in angle), default=0.0)
        taus = [k * 2 * math.pi / rate / RINGING_POSITIONS for k in range(RINGING_POSITIONS)] if rate > 0 else [0.0]
        self.positions: list[tuple[_Coupled, int, float, np.ndarray]] = []
        prev = dict(guess)
        for tau in taus:
            drivers = tuple(
                replace(d, initial=start[d.body] + d.rate * tau) if d in angle else d for d in scene.drivers
            )
            at = replace(scene, drivers=drivers)
            place = _placement(at, prev)
            if place is None:
                continue
            prev = {n: a for n, (_, a) in place.items()}
            model = _Coupled(at, place, inextensible)
            rigid, w, phi, _ = model.spectrum_and_modes()
            i, Kb = model.bending[name]
            axial = np.einsum("ij,ij->j", phi[i], (model.K[i, i] - Kb) @ phi[i])
            total = np.einsum("ij,ij->j", phi, model.K @ phi)
            frac = np.where(w < 2.0 * w_first, axial / np.maximum(total, 1e-300), 0.0)
            j = int(np.argmax(frac))
            if frac[j] > 0.5:
                self.positions.append((model, rigid, float(w[j]), phi[:, j]))

    def error(self, counts: dict[str, tuple[int, int]]) -> tuple[float, float]:
        """(mean relative frequency error, mean frequency) of the coupled axial mode; (0, 0)
        where no position has one."""
        errors, omegas = [], []
        for model, rigid, w, phi in self.positions:
            T = model.ritz(counts)
            Bm = T @ _null(model.C @ T)
            wr, vr = _modes(Bm.T @ model.K @ Bm, Bm.T @ model.M @ Bm)
            u = Bm @ vr[:, rigid:]
            k = int(np.argmax(np.abs(u.T @ model.M @ phi)))
            errors.append(abs(float(wr[rigid + k]) / w - 1.0))
            omegas.append(w)
        if not errors:
            return 0.0, 0.0
        return float(np.mean(errors)), float(np.mean(omegas))

    def phase(self, counts: dict[str, tuple[int, int]], ringing: float) -> tuple[float, float, float]:
        """(estimate, mean relative error, mean frequency): the ringing's part of the error,
        ``ringing`` x min(PHASE_CAP, w T e), T the run or the mode's Kelvin-Voigt decay time."""
        e, w = self.error(counts)
        t = self.t_end if self.damping <= 0 or w <= 0 else min(self.t_end, 2.0 / (self.damping * w * w))
        return ringing * min(PHASE_CAP, w * t * e), e, w


def ringing_choice(
    scene: Scene,
    choices: dict[str, BasisChoice],
    counts: dict[str, tuple[int, int]],
    quasi_static_start: bool,
    guess: dict[str, float],
    inextensible: set[str],
) -> tuple[dict[str, tuple[int, int]], dict[str, str], dict[str, float]]:
    """(counts, bar -> what was found, bar -> estimate) for the bars whose first axial frequency
    is far above the run's band (:func:`axial_separation`, at least AXIAL_SEPARATION x) and
    whose axial dynamics the start rings beyond the accuracy (:func:`axial_ringing`: the
    bars ``effects.axial = "auto"`` keeps dynamic for it): one more
    axial or transverse function (of the families symgen chooses: the one that lowers the
    estimate more) while the ringing's phase over the run, ringing x min(PHASE_CAP, w T e)
    (:class:`_AxialRingingCheck`; T the run, or the mode's Kelvin-Voigt decay time), exceeds the
    accuracy (at most COUPLED_STEPS functions, MAX_CHOSEN per family)."""
    acc = scene.simulation.accuracy
    said: dict[str, str] = {}
    estimates: dict[str, float] = {}
    if scene.effects.axial not in (True, "dynamic", "auto"):
        return counts, said, estimates
    counts = dict(counts)
    for name, c in choices.items():
        body = scene.body(name)
        if name in inextensible or not body.lam or not counts[name][0] or not body.mu or not counts[name][1]:
            continue
        w_axial, w_run, _ = axial_separation(scene, body)
        if w_axial < AXIAL_SEPARATION * w_run:
            continue  # its axial band is near the run's: its own estimate and the coupled check count it
        ring = axial_ringing(scene, body, quasi_static_start)
        if ring.estimate <= acc:
            continue
        check = _AxialRingingCheck(scene, name, guess, inextensible)
        est, e, w = first = check.phase(counts, ring.estimate)
        start = counts[name]
        for _ in range(COUPLED_STEPS):
            if est <= acc:
                break
            na, nt = counts[name]
            tries = []
            if c.given[1] is None and nt < MAX_CHOSEN:
                tries.append({**counts, name: (na, nt + 1)})
            if c.given[0] is None and na < MAX_CHOSEN:
                tries.append({**counts, name: (na + 1, nt)})
            if not tries:
                break
            scored = [(check.phase(t, ring.estimate), t) for t in tries]
            (est, e, w), counts = min(scored, key=lambda s: s[0][0])
        estimates[name] = est
        text = (
            f"its axial dynamics ring from the start ({ring.reason}): the coupled axial mode over the cycle "
            f"({len(check.positions)} positions, mean {first[2]:.4g} per unit tau) {first[1]:.2g} too high with "
            f"{start[0]} axial + {start[1]} transverse functions, its phase over the run {first[0]:.2g} of peak"
        )
        if counts[name] != start:
            text += f"; {counts[name][0]} + {counts[name][1]}: {e:.2g} too high, {est:.2g}"
        said[name] = text
    return counts, said, estimates
