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

Not covered: the phase of the mechanism's *coupled* modes that an undeformed, undamped start
rings for the whole run (``BasisChoice.start_rings`` says when the start does; measured in
benchmarks/RESULTS.md "Accuracy-driven bases").
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from symgen.scene.model import GROUND, Scene

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
    ``start_rings``: the run starts undeformed and undamped (:func:`with_start`)."""

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
        }


def amplification_error(omega_run: float, omega: float) -> float:
    """The error of treating a mode of frequency ``omega`` statically under forcing at
    ``omega_run``: r^2 / (1 - r^2), r = omega_run / omega (1.0 at or beyond resonance)."""
    r2 = (omega_run / omega) ** 2
    return 1.0 if r2 >= 0.5 else r2 / (1.0 - r2)


#: points closer than this (in xi) share one static correction function; nearer the ends than this
#: they are not interior
POINT_TOL = 1e-9


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
            rates.append((max(abs(d.rate), 1.0), f"torque driver of {d.body} (rate {max(abs(d.rate), 1.0):.4g})"))
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
def _mesh(points: tuple[float, ...]) -> np.ndarray:
    xs = set(np.linspace(0.0, 1.0, FE_ELEMENTS + 1).round(12))
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


def _reference_bar(scene: Scene, body, interior: tuple[float, ...], corrected: bool) -> _Bar:
    masses = _point_masses(scene, body)
    x = _mesh(tuple(masses) + interior)
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


def choose_bases(scene: Scene, given: dict[str, tuple[int | None, int | None]]) -> dict[str, BasisChoice]:
    """Per elastic bar: its counts (``given`` where the file states them, else chosen) and why.

    ``scene``: the scene with every stated count in place (absent ones may be anything);
    ``given``: bar -> (axial_modes, transverse_modes) as written (None: absent); a bar not in
    it keeps the counts on its record as stated."""
    acc = scene.simulation.accuracy
    omega_run, how = run_frequency(scene)
    out: dict[str, BasisChoice] = {}
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
        )
    return out


#: what the estimate does not cover, said where the start rings
RINGING = (
    "the start (not quasi-static, undamped) rings the mechanism's coupled modes for the whole run; "
    "this estimate covers each bar's own spectrum, not their phase: measured, a steel crank-rocker's "
    "driver torque is 4.6 % off with the chosen basis, a released double pendulum's tip deflections "
    '3.8 % (benchmarks/RESULTS.md); start with initial.deformation = "quasi-static", or damping, or '
    "state richer counts"
)


def with_start(choices: tuple[BasisChoice, ...], quasi_static_start: bool, damping: float) -> tuple[BasisChoice, ...]:
    """The choices with ``start_rings`` set (and said in their reason) when the run starts
    neither on its quasi-static deformation nor damped."""
    if quasi_static_start or damping > 0:
        return choices
    return tuple(replace(c, start_rings=True, reason=f"{c.reason}; {RINGING}") for c in choices)
