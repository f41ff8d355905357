"""The model-form estimate of a finished run: how much each output would change with a
geometrically exact bar, as a fraction of the output's peak.

What a run's bar leaves out of the bending energy of a geometrically exact, inextensible
Euler-Bernoulli bar, whose curvature is kappa = eta'' / sqrt(1 - eta'^2) (eta(xi) the transverse
displacement of the material point xi, lengths over l), so that

    (mu/2) int kappa^2 = (mu/2) int eta''^2 (1 + s + s^2 + ...),   s = eta'^2:

* von Karman (``effects.strain = "von_karman"``) keeps eta''^2: it leaves out
  dU = (mu/2) int eta''^2 h(s), h = s / (1 - s) (to fourth order the exact bar's eta'^2 eta''^2
  term, tables E4 of :class:`symgen.model.shapes.CurvatureProducts`: docs/exact-bars.md);
* the exact bar (``"exact"``) keeps eta''^2 (1 + s + s^2) (``EXACT_ORDER``, sixth order in the
  amplitudes: tables E4, E6): it leaves out the eighth- and higher-order terms, h = s^3 / (1 - s).

The integrals are sums over quadrature nodes of the bar's shape functions, sampled when the model
was derived (:class:`symgen.ir.shape_samples.ShapeSamples`, in the signed cache): a run on a
cached model evaluates them with numpy alone. ``s`` is taken at most ``SLOPE2_MAX`` (a slope
beyond 0.7 is outside every expansion of the curvature in the amplitudes).

At each output sample of the run, for each elastic bar, the generalized force dQ = d(dU)/dg is
applied to the bar's transverse stiffness at that instant, bending plus the geometric stiffness
of its axial force N,

    K = mu Kt + sum_k n_k C3[k],   n_k = lambda e_k (dynamic axial: e = f + Ka^-1 c, the strain
                                   the axial basis carries), or the multipliers N_k (quasi-static,
                                   inextensible)

so that dg = -K^-1 dQ: the static change of the deflection (the axial amplitudes follow it,
df = -Ka^-1 dc, so that the strain the axial basis carries stays). Compression lowers K towards zero at
the bar's Euler load, which amplifies dg by 1 / (1 - P/P_cr) with no separate factor, however
large: while K is positive definite the amplification is real (the near-buckling column of
tests/test_model_form_euler.py, pinned on a slider at 0.5 .. 0.99 P_cr, lambda 1e8: the estimate
is 1.00x the large-deflection elastica's difference from von Karman's closed form at 0.5 .. 0.97
and 1.07x at 0.99, amplification 99; until estimator version 13 it was capped at 20 and read 0.19x
there; at lambda 1e4 and below the stretch's share of the curvature matters, charged since version 14: see
``STRETCH_CURVATURE`` and docs/exact-bars.md, "Near the Euler load"). The axial force K and dQ
take is the bar's slow one (``SLOW_AXIAL``, :meth:`_Bar.slow_axial_force`, estimator version 15):
its content below the bar's first bending frequency, which the bending follows quasi-statically; a
faster part (a slider's mass ringing on the bar's axial stiffness) it does not follow, and taken at
each instant its peaks were amplified (the kept-out heavy steel slider-crank's rod at 0.72 P_cr for
an instant against 0.42 slow: its static change 2.5x von Karman vs the exact bar's slow part;
tests/test_model_form_fastaxial.py, the column with a fast end load: 3.4-5.8x, 1.00-1.10x since). Where
K is not positive definite the bar is at or beyond its Euler load at that instant: a static change
about a state that is no stable equilibrium is not an estimate, so each output the bar moves there
(its unamplified change not zero) is charged ``BEYOND_BUCKLING`` of its peak, a value that cannot
flatter, and the method text names the bar and the instants. K has bending and the axial force's
geometric stiffness only (the axial amplitudes follow the change at a constant strain, below): a
bar buckled into a stable equilibrium that its kept nonlinear terms hold (a von Karman bar between
fixed ends held by its stretching, the exact bar's own eta''^2 eta'^2) reads not positive definite
too, so it is charged the whole peak, an over-estimate (not measured). Each
output's change is the model's output function at q + dq minus at q, its maximum over the run
divided by the output's peak.

Dynamics: the left-out terms harden the bars, and so move the modes the run rings: the
mechanism's coupled modes (:func:`coupled_modes`: the run's own model linear about its state, the
tangent of its dynamics on the closure's null space, at ``MODE_SAMPLES`` configurations along
the run), not each bar alone. A mode phi (mass-normalised) moves at each sample by the fraction
shift(t) = (1/2) phi^T H phi / omega^2, H the Hessian of the bars' left-out energy (each bar's
second difference along its part of phi, times the model's scale of the bar's generalized
forces, nu alpha^3); for a bar whose coupled mode is its own first mode this is
(1/2) v^T H v / v^T (mu Kt) v; the mode's own vibration (the bars' content within its band) by
half its share of that, the backbone of a hardening oscillator (:func:`backbone`: the tangent's
mean over a cycle is twice it; the tests/data slewing arm undamped, ringing after the slew: von
Karman vs the exact bar move its frequency by 1.01e-3, the tangent by 2.11e-3, the backbone by
1.08e-3). The mode's own coordinate then changes by its oscillator's first-order response to the
shift (:func:`perturbed_along`, estimator version 10): its content within a band from 0.75x its
lowest to 1.25x its highest frequency along the run (no nearer a neighbour's than the geometric
mean of the two: :func:`swept_bands`, estimator version 18; within 25 % of its mean frequency
until then, which missed a slot guide's modes where its contact sweeps them), read from its modal velocity
phi^T M (v - v_rigid) along the run (v_rigid the rigid coordinates' motion the closure gives v:
:func:`_coordinate_rows`, version 14; phi^T M v also carried the rigid mechanism's motion, 5-6x
the five-bar's links' own content in the modes' bands), drives x'' + c W^2 x' + W^2 x = -2 shift W^2 x, solved as the envelope
of the change along the mode's own phase int W (W(t) the mode's frequency along the run: a
crank-driven bar's sweeps within a turn). A free vibration so drifts in phase by omega times the
integral of shift since it came in (a start's ringing from the start, a vibration a load step
or a passage through a resonance builds up from then), decaying with it (Kelvin-Voigt damping
c); a response the driver forces at frequencies the mode's phase does not follow changes by its
receptance's change, shift W / |W - w + i c W^2 / 2|, which does not grow with the time rung.
Each output changes by its participation in the mode (the output at q + e phi and the multipliers
that hold phi on the closure, lam + e dlam) times the coordinate's change, the modes' changes
summed as the signals they are (their analytic signals: two modes an output sees in opposite
phase cancel there), the largest along the run. Version 7's drift charged each output's whole content
in the band, by its envelope, the free vibration's phase since the envelope's running maximum
rose: the driver's harmonics within a band drifted as free vibration (the kept-out aluminium
slider-crank c_alu_long: its rod's mode sweeping 4.1-7.2 per unit tau, harmonics 5-7 in its band,
1.42x the von Karman vs exact change), and an output that sees a mode through a participation
changing along a turn was charged the envelope's age, not the mode's (docs/exact-bars.md,
"Forced content within a band"). The
coupled modes, because a tool on an overhang makes with the linkage a mode far below any bar's
own (the four-bar with its rocker pinned to the coupler at xi = 0.6 and a 50 g tool at the
coupler's end: 5.5 per unit tau against the coupler's own first bending at 15.3; von Karman vs
the exact bar 2.6e-3 of the coupler's peak, growing turn by turn at 5.5; estimated 0.9e-3 with
the bars' own modes, 3.8e-3 with the coupled ones: tests/test_model_form_drift.py), and because
two bars at one frequency ring as two modes, not one band counted twice. Where the mass matrix
is not positive definite on the null space (quasi-static amplitudes) the bars' own first modes
are used. Along the run, not the mean shift times the run's length times a mean amplitude: the
vibration a start or a load step excites is largest, and its slopes with it, where a windowed
spectrum of the whole run sees least of it (the five-bar's links: 0.38x of the true error with
the mean, 0.93x along the run; benchmarks/RESULTS.md). Each output's estimate is its static
change plus its drift, the modes' drifts and the static change summed as sizes at each instant, the
largest along the run (not each one's largest, reached at other times: :func:`combined`), as a
fraction of its peak; outputs that q does not move (a driver torque)
have their drift only. The driver's harmonics below a mode's band that the run tells apart from
its free vibration are fitted and taken out of the modal velocity first (:func:`forced_harmonics`,
:func:`without_harmonics`): left in, large low harmonics leave their slope at the run's end as a
kink of the mirrored signal whose broad spectrum reads as content in the band (a steel
slider-crank pump's torque 12x the von Karman vs exact difference with version 3's drift,
tests/test_model_form_torque.py). Those within the band stay: the oscillator tells them apart.
Where the problem has no coupled modes (quasi-static amplitudes) each output's own content in each
bar's band is taken as the mode's coordinate.

A torque-driven crank's timing (estimator version 11; measured as 10a on its branch, :func:`_free_lead`): a crank a torque
driver turns is a free coordinate, and the change of its acceleration that the rigid rows give
with the static change's accelerations builds up, integrated twice, into a drift of its angle that
grows with the time run; each output runs ahead by its rate times the lead, drift / speed. On the
kept-out torque-driven aluminium four-bar with von Karman forced that timing was most of the error
(the coupler's deflection 9.0e-2 of peak at equal times, 3.3e-2 at equal crank angles) and version
10 read 0.04-0.37 of it; with the lead 0.63-1.70. With its bars twice as stiff the static change's
forcing gives 0.15 of the crank's drift; what else pushes the crank is not found (docs/exact-bars.md,
"A torque-driven crank's timing").

The axial strain: von Karman keeps eps = zeta' + eta'^2 / 2 of the exact
|r'| - 1 = eps (1 - eta'^2 / 2) + eta'^4 / 8 + eta'^6 / 16 + ... (nearly inextensible), the exact
bar zeta' + eta'^2 / 2 + eta'^4 / 8 (``STRAIN_ORDER``) and, with dynamic axial amplitudes, the
stretch's - eps eta'^2 / 2 (``STRETCH_KEPT``, DERIVE_VERSION 9). What each leaves out enters as the
work of the axial force (``_Bar.force``): von Karman int N (eta'^4 / 8 - eps eta'^2 / 2); the
exact bar int N eta'^6 / 16, and - eps eta'^2 / 2 only on a quasi-static or inextensible bar (whose
strain is held at 0). Until the exact bar had the stretch's term this part charged it to the
exact bar too: on the torque-driven soft slider-crank (dynamic axial, N/lambda ~ 1e-3, slopes
~ 0.2) the part was 5.2e-3 of rod_mid's peak, that term alone 5.4e-3 (its static change 8.7e-4
and the phase drift of the rod's first mode, softened by it, 4.5e-3), against a true model-form
error, the converged exact bar against the converged ANCF reference, of 2.9e-4; without it the
estimate is 5.4e-4 (the curvature's eta''^2 eta'^6 and the strain's eta'^6 / 16: static 1.7e-4,
drift 3.7e-4).

The stretch's share of the curvature (``STRETCH_CURVATURE``, on since estimator version 14): the
exact curvature per undeformed length is kappa ~ eta'' / (1 + eps), whose -mu int (eps eta''^2 +
eps' eta' eta''), eps = N / lambda (eps' at the nodes from each quadrature piece's polynomial), the
exact bar has with dynamic axial amplitudes and von Karman lacks: a compressed bar bends 2 |eps|
stiffer. It is charged where the stretch's term is (``stretch_kept``): on the five-bar
(benchmarks/validation/five_bar_elastic.toml, link_a compressed to eps = -1.7e-4) it is half the
start's static change (docs/exact-bars.md, "The five-bar's start, found"); on the near-buckling
column at lambda 1e4 and 1e3 without it the estimate read 0.04-0.46x (tests/test_model_form_euler.py),
with it 1.00-1.08x. Its static change and the five-bar's coupled-mode shifts match the exact bar's
run (tests/test_model_form_stretch.py). Until version 14 it was off: with it the five-bar's link_b
read 2.50x its true error as users run it, an over-read of the modes' drift that was the modal
coordinate's (phi^T M v, above), not the term's nor the oscillator's (a shift swinging with the
loop's load within each turn is followed: tests/test_model_form_inband.py); with version 14's
coordinate 1.80x (docs/exact-bars.md, "The drift's modal coordinate").

What it leaves out: the strain's terms second order
in eps (eps^2 eta'^2 beyond the stretch's),
resonance of the change itself, the response of the
rigid coordinates of a closed loop to dq, the timing of a free motion other than one torque
driver's crank (a pendulum's swing, two torque drivers) and the part of a torque-driven crank's
drift that the static change's forcing does not give. A slot guide (its functions psi(xi, beta)
move with the contact, :class:`_Guide`) is charged its curvature beyond the fourth order its model
keeps, at each sample's contact, against its bending stiffness alone; the couplings of its
shortening's motion are not charged (estimator version 17: on slot_dyad and a kept-out steel dyad at
5-6 % deflection the estimate is 1.05-1.45x the true error). Measured against von Karman vs exact runs in
docs/exact-bars.md and against the validation suite's references in benchmarks/RESULTS.md.
"""

from __future__ import annotations

import json
import weakref
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen import cache
from symgen.ir.records import CoordKind, RowKind
from symgen.ir.shape_samples import GAUSS_POINTS, GuideSamples, ShapeSamples, samples_question
from symgen.numerics.run_result import MeasuredOnce
from symgen.scene.model import CHECK_KINDS

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import SimResult
    from symgen.scene.model import Scene

__all__ = [
    "BEYOND_BUCKLING",
    "EXACT_ORDER",
    "ModelFormEstimate",
    "ModelFormNotEstimated",
    "estimate",
    "model_form_estimate",
]

#: the estimate (fraction of peak) of an output a bar moves at an instant when the bar's tangent
#: stiffness is not positive definite (at or beyond its Euler load): no static change is an estimate
#: there; the whole peak, which cannot flatter (until estimator version 13 the amplification was
#: capped at 20 instead, 0.18x of the true error at 0.99 P_cr)
BEYOND_BUCKLING = 1.0
#: the powers of s = eta'^2 the exact bar keeps in eta''^2 (1 + s + ...): 2 (sixth order in
#: the amplitudes, symgen/model/bars.py: E4, E6); a longer expansion there raises it here
EXACT_ORDER = 2
#: the exact strain's left-out part (its work with the axial force) is estimated too
STRAIN_LEFT_OUT = True
#: the powers of s = eta'^2 each strain keeps of the exact strain of a nearly inextensible bar,
#: |r'| - 1 = zeta' + s/2 + s^2/8 + s^3/16 + ... (zeta' = sqrt(1 - s) - 1 + the stretch): von Karman
#: 1 (s/2), the exact bar 2 (s/2 + s^2/8: symgen/model/bars.py, table C5, DERIVE_VERSION 8)
STRAIN_ORDER = {"von_karman": 1, "exact": 2}
#: the strains whose energy keeps the stretch's -eps eta'^2 / 2 of the exact |r'| - 1 =
#: eps (1 - eta'^2 / 2) + ... (the exact bar, DERIVE_VERSION 9: -(lambda/2) int (P eps)^2 eta'^2,
#: table Q4 of symgen/model/bars.py), on a bar with dynamic axial amplitudes only: a quasi-static or
#: inextensible bar holds P eps = 0 and has the term nowhere (the estimate charges it there)
STRETCH_KEPT = {"von_karman": False, "exact": True}
#: the stretch's share of the curvature, -mu int (eps eta''^2 + eps' eta' eta'') (kappa per undeformed
#: length ~ eta'' / (1 + eps)), charged where the bar's energy lacks it (as the stretch's term); on
#: since estimator version 14 (off until then: the five-bar's drift over-read with it, the modal
#: coordinate's, :func:`_coordinate_rows`)
STRETCH_CURVATURE = True
#: the coefficients of s^n in 1 - sqrt(1 - s), n = 1, 2, 3, 4
_STRAIN_SERIES = (0.5, 0.125, 0.0625, 0.0390625)
#: the largest eta'^2 the series is evaluated at
SLOPE2_MAX = 0.5
#: the static change takes each bar's axial force less its content at and above the bar's first
#: bending frequency (:meth:`_Bar.slow_axial_force`, estimator version 15): the bending follows only
#: the slower part; until then the force at each instant (a fast axial ringing's peaks amplified)
SLOW_AXIAL = True


class ModelFormNotEstimated(Exception):
    """The model-form part cannot be estimated for this run (the reason)."""


@dataclass(frozen=True)
class ModelFormEstimate:
    """The estimate of a run: ``outputs`` maps each output to its estimated change with the exact
    curvature as a fraction of its peak; ``bars`` each elastic bar to (the shift of its first
    bending frequency, max amplification by its axial compression); ``method`` how; ``guides``
    the slot guides (:class:`_Guide`)."""

    outputs: dict[str, float]
    bars: dict[str, tuple[float, float]]
    method: str = "static response of each bar's stiffness to the curvature's left-out terms"
    guides: tuple[str, ...] = ()  # the slot guides estimated (model_form._Guide)


#: the shape samples read in this process, by their question (a bar's samples are a function
#: of it: every later estimate of a run of the bar reads them from here)
_READ: dict[str, ShapeSamples] = {}


def _samples(body: dict[str, Any]) -> ShapeSamples:
    """A bar's shape samples from the signed cache (taken when the model was derived), or sampled
    now where the cache does not hold them (a model cache written by an older symgen); once per
    process."""
    question = samples_question(body)
    key = json.dumps(question, sort_keys=True)
    if key in _READ:
        return _READ[key]
    known, answer = cache.recall(question)
    samples = None
    if known:
        try:
            samples = ShapeSamples.from_json(answer)
        except ValueError:
            pass
    if samples is None:
        from symgen.model.shape_samples import shape_samples

        samples = shape_samples(body)
    _READ[key] = samples
    return samples


def _power(x: np.ndarray, k: int) -> np.ndarray:
    """x^k (k >= 0 an integer) by products: numpy's pow is 100x slower where the slopes are tiny
    (a bar at rest: subnormal powers)."""
    out = np.ones_like(x)
    for _ in range(k):
        out = out * x
    return out


def _residual(s: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """(h, dh/ds) of h(s) = s^(order+1) / (1 - s): the terms of 1 / (1 - s) after s^order."""
    s = np.minimum(s, SLOPE2_MAX)
    k = order + 1
    sk = _power(s, k)
    h = sk / (1.0 - s)
    dh = (k * _power(s, k - 1) * (1.0 - s) + sk) / (1.0 - s) ** 2
    return h, dh


class _Bar:
    """The tables of one elastic bar, from its shape samples, and its places in q and lam."""

    def __init__(
        self,
        mech: Mechanism,
        name: str,
        samples: ShapeSamples,
        f_idx: tuple[int, ...],
        g_idx: tuple[int, ...],
        order: int,
        strain_order: int = 1,
        stretch_kept: bool = False,
    ) -> None:
        self.name, self.f_idx, self.g_idx, self.order = name, list(f_idx), list(g_idx), order
        self.strain_order = strain_order
        self.na, self.nt = len(f_idx), len(g_idx)
        w = np.asarray(samples.w)
        self.w = w
        self.P0, self.P1, self.P2 = (
            np.asarray(t).reshape(len(w), -1) for t in (samples.trans0, samples.trans1, samples.trans2)
        )
        A1 = np.asarray(samples.axial1).reshape(len(w), -1) if self.na else np.zeros((len(w), 0))
        self.A1 = A1
        self.D = _piece_derivative(np.asarray(samples.xi, dtype=float))  # d/dxi at the nodes, piece by piece
        self.Kt = self.P2.T @ (w[:, None] * self.P2)
        M = self.P0.T @ (w[:, None] * self.P0)
        self.C3 = np.einsum("i,ik,ia,ib->kab", w, A1, self.P1, self.P1)
        Ka = A1.T @ (w[:, None] * A1)
        self.Ka_inv = np.linalg.inv(Ka) if self.na else np.zeros((0, 0))
        sc = mech.scene.body(name)
        self.lam, self.mu = float(sc.lam or 0.0), float(sc.mu or 0.0)
        # the model's generalized forces of the bar's amplitudes are its own times nu alpha^3
        # (symgen/model/bars.py, BarEquations.generalized): the scale of H in the model's coordinates
        self.scale = float(sc.nu) * float(sc.alpha) ** 3
        rows = [i for i, r in enumerate(mech.info.lam_rows) if r.kind is RowKind.INEXTENSIBLE and r.joint == name]
        self.n_rows = rows  # multipliers N_k of a constrained (quasi-static or inextensible) bar
        # the bar's energy has the stretch's -eps eta'^2 / 2 (``STRETCH_KEPT``): dynamic axial amplitudes
        self.stretch_kept = bool(stretch_kept and self.na and not rows)
        # the first bending mode of the bar alone and its frequency (per unit tau): where its free
        # vibration rings (mu Kt v = w^2 M v, by the Cholesky factor of M)
        L = np.linalg.cholesky(M)
        Li = np.linalg.inv(L)
        w2, y = np.linalg.eigh(Li @ (self.mu * self.Kt) @ Li.T)
        self.omega, self.mode = float(np.sqrt(max(w2[0], 0.0))), Li.T @ y[:, 0]

    def force(self, g: np.ndarray, N: np.ndarray | None = None) -> np.ndarray:
        """dQ_a = d/dg_a of the left-out energy: the curvature's (mu/2) int eta''^2 h(eta'^2),
        plus, where the axial force N(xi) is known (at the nodes), the exact strain's left-out
        int N (eps_x - eps) = int N (c_m s^m - eps eta'^2 / 2), s = eta'^2, m = ``STRAIN_ORDER`` + 1
        the first power the bar's strain leaves out (von Karman: eta'^4 / 8; the exact bar:
        eta'^6 / 16), eps = N / lambda (N held: the axial amplitudes re-equilibrate, to first order
        the energy changes by N's work); the stretch's - eps eta'^2 / 2 only where the bar's energy
        does not have it (``stretch_kept``). ``g``: one sample's amplitudes, or a stack of them (rows;
        ``N`` likewise): dQ of each row."""
        e1, e2 = g @ self.P1.T, g @ self.P2.T
        h, dh = _residual(e1 * e1, self.order)
        wq = self.w * self.mu
        dQ: np.ndarray = (wq * e2 * h) @ self.P2 + (wq * e2 * e2 * dh * e1) @ self.P1
        if N is not None and STRAIN_LEFT_OUT:
            soft = N * N / self.lam if self.lam > 0 and not self.stretch_kept else 0.0 * N
            m = self.strain_order + 1
            left = _STRAIN_SERIES[m - 1] * 2 * m * _power(e1, 2 * m - 1)  # d/d eta' of c_m eta'^(2m)
            dQ = dQ + (self.w * (N * left - soft * e1)) @ self.P1
            if STRETCH_CURVATURE and self.lam > 0 and not self.stretch_kept:
                # the stretch's share of the curvature per undeformed length, kappa ~ eta'' / (1 + eps):
                # d/dg_a of -mu int (eps eta''^2 + eps' eta' eta''), eps = N / lambda
                eps = N / self.lam
                deps = eps @ self.D.T
                dQ = dQ - (wq * (2.0 * eps * e2 + deps * e1)) @ self.P2 - (wq * deps * e2) @ self.P1
        return dQ

    def axial_force(self, Q: np.ndarray, Lam: np.ndarray) -> np.ndarray | None:
        """The multipliers N_k or lambda e_k, the axial force at the nodes, of each sample (rows of
        the coordinates ``Q`` and multipliers ``Lam``), or None without axial functions."""
        if not self.na:
            return None
        if self.n_rows:
            return np.asarray(Lam[:, self.n_rows])  # the multipliers N_k
        G = Q[:, self.g_idx]
        c = 0.5 * np.einsum("kab,ra,rb->rk", self.C3, G, G)
        if self.strain_order >= 2:  # the exact bar's (phi'_k, eta'^4 / 8)
            c = c + (self.w * _power(G @ self.P1.T, 4)) @ self.A1 / 8
        return np.asarray(self.lam * (Q[:, self.f_idx] + c @ self.Ka_inv.T))  # lambda P eps

    def slow_axial_force(self, tau: np.ndarray, Q: np.ndarray, Lam: np.ndarray) -> np.ndarray | None:
        """The axial force n_k (:meth:`axial_force`) of every row of the run (``tau`` evenly spaced)
        less its content at and above the bar's first bending frequency (``omega``: mirrored first,
        :func:`without_band`), or None without axial functions: the part of the axial force the
        bar's bending follows quasi-statically, which the static change's stiffness K and the
        forces that read the axial force take (``SLOW_AXIAL``). A faster axial force (a slider's
        mass ringing on the bar's axial stiffness from the start) the bending, slower, does not
        follow: it sees its mean over the fast cycle. Taken at each instant, it amplified the static
        change by 1 / (1 - P(t)/P_cr) at the fast force's peaks (the kept-out steel slider-crank at
        3000 rpm, a 0.5 kg slider: its rod's axial force at tau 2.0 was 0.72 P_cr with the slider's
        ringing at 31 per unit tau, 0.42 P_cr without; rod_mid's static change 1.39e-3 of peak
        against 5.5e-4 for von Karman vs the exact bar's slow part there: docs/exact-bars.md, "A
        fast axial force")."""
        n = self.axial_force(Q, Lam)
        span = float(tau[-1] - tau[0]) if len(tau) else 0.0
        if n is None or not SLOW_AXIAL or self.omega * span < 4 * np.pi:
            return n  # a run shorter than two bending periods tells no slow part from a fast one: as it is
        return without_band(tau, n, (self.omega, np.inf))

    def curvature_along(
        self, Q: np.ndarray, Lam: np.ndarray, v: np.ndarray, axial: np.ndarray | None = None
    ) -> np.ndarray:
        """v_r^T H_r v_r of each sample r: the second difference of the left-out energy along the
        bar's amplitudes ``v`` (rows: a mode's part in this bar at each sample), with the axial
        force of the state ``axial`` (default ``Q``: a state whose slopes are changed keeps the
        run's axial force)."""
        G = Q[:, self.g_idx]
        n = self.axial_force(Q if axial is None else axial, Lam)
        N = None if n is None else n @ self.A1.T
        slope = np.abs(G @ self.P1.T).max(axis=1)
        size = np.abs(v @ self.P1.T).max(axis=1)
        step = 1e-4 * np.maximum(slope, 1e-3) / np.maximum(size, 1e-300)
        dv = step[:, None] * v
        return np.asarray(np.einsum("ra,ra->r", self.force(G + dv, N) - self.force(G - dv, N), v) / (2.0 * step))

    def change(
        self, Q: np.ndarray, Lam: np.ndarray, slow: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(dg, the relative change of the first mode's tangent stiffness, amplification, dg0, beyond)
        of each sample (rows of the coordinates ``Q`` and multipliers ``Lam``): dg = -K^-1 dQ, however
        large the amplification where K is positive definite, 0 where it is not (``beyond``: at or
        beyond the bar's Euler load, no estimate); dg0 = -(mu Kt)^-1 dQ, without the axial force.
        ``slow``: the axial force the static change is taken with (rows of n_k, :meth:`slow_axial_force`:
        its content the bar's bending follows), default the run's at each sample."""
        G = Q[:, self.g_idx]
        mu = self.mu
        n = self.axial_force(Q, Lam) if slow is None else slow
        N = None if n is None else n @ self.A1.T
        dQ = self.force(G, N)
        v = self.mode
        slope = np.abs(G @ self.P1.T).max(axis=1)
        step = 1e-4 * np.maximum(slope, 1e-3) / max(float(np.abs(self.P1 @ v).max()), 1e-300)
        dv = step[:, None] * v
        vHv = ((self.force(G + dv, N) - self.force(G - dv, N)) @ v) / (2.0 * step)
        tangent = vHv / float(v @ (mu * self.Kt) @ v)
        K0 = mu * self.Kt
        K = np.broadcast_to(K0, (len(G), *K0.shape)) if n is None else K0 + np.einsum("rk,kab->rab", n, self.C3)
        dg0 = -np.linalg.solve(K0, dQ.T).T
        dg, ok = _solve_positive(K, dQ)
        size0 = np.linalg.norm(dg0, axis=1)
        size = np.linalg.norm(dg, axis=1)
        amp = np.where(ok & (size0 > 0), size / np.where(size0 > 0, size0, 1.0), 1.0)
        amp = np.where(ok, amp, np.inf)
        dg = np.where(ok[:, None], dg, 0.0)
        return dg, tangent, amp, dg0, ~ok


#: the powers of s = eta'^2 a slot guide keeps in eta''^2 (1 + s + ...): 1 (its curvature to fourth
#: order, table E4 of symgen/model/slot.py, on wherever the estimate is made: geometric stiffening and
#: a strain other than the seed's linear one), whatever the strain
GUIDE_ORDER = 1


class _Guide(_Bar):
    """A slot guide: its functions psi(xi, beta) move with the contact, so its tables are made at
    each sample's contact beta from its samples (:class:`symgen.ir.shape_samples.GuideSamples`:
    fixed numbers times powers of beta and 1 - beta on the span and the overhang, the weights beta w
    and (1 - beta) w). Left out, as of any bar, its curvature's terms beyond the kept ones,
    (mu/2) int eta''^2 h(eta'^2), h = s^2 / (1 - s) (``GUIDE_ORDER``), applied to its bending
    stiffness mu int psi''_a psi''_b at that contact (no axial amplitudes: the guide is axially
    rigid, its tension's geometric stiffness is not in K, so a guide in tension is estimated a little
    large and one in compression a little small; the inextensible axis's shortening beyond its
    -int eta'^2 / 2 is not charged)."""

    def __init__(
        self, mech: Mechanism, name: str, samples: GuideSamples, g_idx: tuple[int, ...], beta: int, beta_ref: float
    ) -> None:
        self.name, self.f_idx, self.g_idx, self.order = name, [], list(g_idx), GUIDE_ORDER
        self.strain_order, self.stretch_kept, self.n_rows = 1, False, []
        self.na, self.nt = 0, len(g_idx)
        self.samples, self.beta = samples, beta
        self.w = np.concatenate([np.asarray(samples.w)] * 2)
        self.F = [np.vstack([np.asarray(samples.span[n]), np.asarray(samples.over[n])]) for n in range(3)]
        self.half = len(samples.x)
        self.A1 = np.zeros((len(self.w), 0))
        self.C3 = np.zeros((0, self.nt, self.nt))
        self.Ka_inv = np.zeros((0, 0))
        sc = mech.scene.body(name)
        self.lam, self.mu = float(sc.lam or 0.0), float(sc.mu or 0.0)
        self.scale = float(sc.nu) * float(sc.alpha) ** 3
        # its first bending mode alone at the run's mean contact (the bands of the bars' own modes)
        P0, _, P2, wq = self.tables(np.array([beta_ref]))
        self.Kt = P2[0].T @ (wq[0][:, None] * P2[0])
        M = P0[0].T @ (wq[0][:, None] * P0[0])
        Li = np.linalg.inv(np.linalg.cholesky(M))
        w2, y = np.linalg.eigh(Li @ (self.mu * self.Kt) @ Li.T)
        self.omega, self.mode = float(np.sqrt(max(w2[0], 0.0))), Li.T @ y[:, 0]

    def tables(self, beta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(P0, P1, P2, weights) at each contact of ``beta``: P_n[r, j, a] = d^n psi_a / dxi^n at the
        node j (the span's, then the overhang's) at beta_r; weights[r, j] the quadrature's in xi."""
        b = np.asarray(beta, dtype=float)
        P = []
        for n in range(3):
            span, over = self.samples.scalings(b, n)  # functions x rows
            P.append(
                np.concatenate(
                    [
                        self.F[n][None, : self.half, :] * span.T[:, None, :],
                        self.F[n][None, self.half :, :] * over.T[:, None, :],
                    ],
                    axis=1,
                )
            )
        wq = self.w[None, :] * np.concatenate(
            [np.repeat(b[:, None], self.half, axis=1), np.repeat(1.0 - b[:, None], self.half, axis=1)], axis=1
        )
        return P[0], P[1], P[2], wq

    def guide_force(self, g: np.ndarray, P1: np.ndarray, P2: np.ndarray, wq: np.ndarray) -> np.ndarray:
        """dQ of each row r: d/dg of (mu/2) int eta''^2 h(eta'^2) with row r's tables."""
        e1, e2 = np.einsum("rja,ra->rj", P1, g), np.einsum("rja,ra->rj", P2, g)
        h, dh = _residual(e1 * e1, self.order)
        m = wq * self.mu
        return np.asarray(np.einsum("rj,rja->ra", m * e2 * h, P2) + np.einsum("rj,rja->ra", m * e2 * e2 * dh * e1, P1))

    def axial_force(self, Q: np.ndarray, Lam: np.ndarray) -> np.ndarray | None:
        return None

    def slow_axial_force(self, tau: np.ndarray, Q: np.ndarray, Lam: np.ndarray) -> np.ndarray | None:
        return None

    def _along(self, Q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """v_r^T H_r v_r at each row (tables at its contact): the second difference of the left-out
        energy along ``v``."""
        G = Q[:, self.g_idx]
        _, P1, P2, wq = self.tables(Q[:, self.beta])
        slope = np.abs(np.einsum("rja,ra->rj", P1, G)).max(axis=1)
        size = np.abs(np.einsum("rja,ra->rj", P1, v)).max(axis=1)
        step = 1e-4 * np.maximum(slope, 1e-3) / np.maximum(size, 1e-300)
        dv = step[:, None] * v
        diff = self.guide_force(G + dv, P1, P2, wq) - self.guide_force(G - dv, P1, P2, wq)
        return np.asarray(np.einsum("ra,ra->r", diff, v) / (2.0 * step))

    def curvature_along(
        self, Q: np.ndarray, Lam: np.ndarray, v: np.ndarray, axial: np.ndarray | None = None
    ) -> np.ndarray:
        return self._along(Q, v)

    def change(
        self, Q: np.ndarray, Lam: np.ndarray, slow: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(dg, the relative change of the guide's own first mode's tangent stiffness at each
        contact, amplification 1, dg, never beyond): dg = -(mu Kt(beta))^-1 dQ at each row."""
        G = Q[:, self.g_idx]
        P0, P1, P2, wq = self.tables(Q[:, self.beta])
        K = self.mu * np.einsum("rja,rj,rjb->rab", P2, wq, P2)
        M = np.einsum("rja,rj,rjb->rab", P0, wq, P0)
        dQ = self.guide_force(G, P1, P2, wq)
        dg, ok = _solve_positive(K, dQ)
        dg = np.where(ok[:, None], dg, 0.0)
        # the first mode at each contact: K v = w^2 M v
        Li = np.linalg.inv(np.linalg.cholesky(M))
        _, y = np.linalg.eigh(Li @ K @ np.swapaxes(Li, 1, 2))
        v = np.einsum("rba,rb->ra", Li, y[:, :, 0])
        vKv = np.einsum("ra,rab,rb->r", v, K, v)
        tangent = self._along(Q, v) / vKv
        return dg, tangent, np.ones(len(G)), dg, np.zeros(len(G), dtype=bool)


def _piece_derivative(xi: np.ndarray) -> np.ndarray:
    """The derivative at the nodes ``xi`` of the polynomial through each piece's ``GAUSS_POINTS``
    nodes (:class:`symgen.ir.shape_samples.ShapeSamples`: the bar's functions are smooth within a
    piece): a block-diagonal matrix."""
    n = len(xi)
    D = np.zeros((n, n))
    for s0 in range(0, n, GAUSS_POINTS):
        x = xi[s0 : s0 + GAUSS_POINTS]
        m = len(x)
        diff = x[:, None] - x[None, :] + np.eye(m)
        c = np.prod(diff, axis=1)  # barycentric: prod_{k != j} (x_j - x_k)
        B = (c[:, None] / c[None, :]) / diff
        np.fill_diagonal(B, 0.0)
        np.fill_diagonal(B, -B.sum(axis=1))
        D[s0 : s0 + m, s0 : s0 + m] = B
    return D


def _solve_positive(K: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, ok) with x_r = -K_r^-1 b_r for each row, ok_r where x_r is finite and K_r positive
    definite (its symmetric part); x_r is 0 where K_r is singular (not ok)."""
    sym = (K + np.swapaxes(K, 1, 2)) / 2
    try:
        ok = np.all(np.linalg.eigvalsh(sym) > 0, axis=1)
    except np.linalg.LinAlgError:  # a K not finite among them: each alone
        ok = np.zeros(len(K), dtype=bool)
        for r in range(len(K)):
            try:
                ok[r] = bool(np.all(np.linalg.eigvalsh(sym[r]) > 0))
            except np.linalg.LinAlgError:
                pass
    try:
        x = -np.linalg.solve(K, b[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:  # a singular K among them: each alone
        x = np.zeros_like(b)
        for r in range(len(b)):
            try:
                x[r] = -np.linalg.solve(K[r], b[r])
            except np.linalg.LinAlgError:
                ok[r] = False
    ok &= np.all(np.isfinite(x), axis=1)
    return x, ok


#: the output rows the estimate reads at most (evenly spaced)
SAMPLES = 400


def model_form_estimate(mech: Mechanism, result: SimResult, samples: int = SAMPLES) -> ModelFormEstimate:
    """The estimate of a finished run ``result`` (:class:`symgen.numerics.simulate.SimResult`) of
    ``mech`` (:class:`symgen.numerics.mechanism.Mechanism`), at up to ``samples`` evenly spaced
    output rows. Raises :class:`ModelFormNotEstimated` with the reason for a run of the seed's
    linear strain or without geometric stiffening."""
    names = list(result.output_names)
    eff = mech.scene.effects
    if eff.strain == "linear":
        raise ModelFormNotEstimated(
            "the seed's linear strain: its gap to a geometrically exact bar is the missing shortening and "
            'geometric stiffening, first order in the deflection (compare with effects.strain = "von_karman")'
        )
    if not eff.geometric_stiffening:
        raise ModelFormNotEstimated(
            "geometric_stiffening = false: the gap to a geometrically exact bar is the missing geometric "
            "stiffness, first order in the axial force"
        )
    order = EXACT_ORDER if eff.strain == "exact" else 0
    strain_order = STRAIN_ORDER.get(eff.strain, 1)
    stretch_kept = STRETCH_KEPT.get(eff.strain, False)
    structure = mech.info.structure
    bodies = {b["name"]: b for b in structure["bodies"]}
    slots = mech.info.slot_guides
    bars: list[_Bar] = [
        _Bar(mech, name, _samples(bodies[name]), f_idx, g_idx, order, strain_order, stretch_kept)
        for name, (f_idx, g_idx) in mech.amplitudes.items()
        if g_idx and not mech.scene.body(name).rigid and name not in slots
    ]
    guides = [name for name, (_, g_idx) in mech.amplitudes.items() if g_idx and name in slots]
    if guides:
        from symgen.numerics.checks import read_guide

        q_all = np.asarray(result.q, dtype=float)
        for name in guides:
            beta = mech.info.coordinate(CoordKind.BETA, name)
            read = read_guide(bodies[name], mech.info.slot_joints[name])
            bars.append(_Guide(mech, name, read, mech.amplitudes[name][1], beta, float(np.mean(q_all[:, beta]))))
    rows = np.unique(np.linspace(0, len(result.tau) - 1, min(samples, len(result.tau))).astype(int))
    Q, V, Lam = (np.asarray(x, dtype=float)[rows] for x in (result.q, result.v, result.lam))
    tau_rows = np.asarray(result.tau, dtype=float)[rows]
    tangent: dict[str, np.ndarray] = {}
    amplification = {b.name: 1.0 for b in bars}
    dqs = np.zeros((len(rows), mech.n))
    beyond: dict[str, np.ndarray] = {}  # each bar's samples at or beyond its Euler load, and dg0 there
    dq_beyond = np.zeros((len(rows), mech.n))
    tau_all = np.asarray(result.tau, dtype=float)
    q_all, lam_all = np.asarray(result.q, dtype=float), np.asarray(result.lam, dtype=float)
    for b in bars:
        slow = b.slow_axial_force(tau_all, q_all, lam_all)
        dg, tangent[b.name], amp, dg0, not_pd = b.change(Q, Lam, None if slow is None else slow[rows])
        dqs[:, b.g_idx] = dg
        if not_pd.any():
            beyond[b.name] = not_pd
            dq_beyond[:, b.g_idx] = np.where(not_pd[:, None], dg0, 0.0)
        if b.na:  # the axial amplitudes follow: the strain P eps (= N / lambda) stays, to first order
            G = Q[:, b.g_idx]
            dc = np.einsum("kab,ra,rb->rk", b.C3, G, dg)
            if b.strain_order >= 2:  # the exact bar's d(phi'_k, eta'^4 / 8) = (phi'_k, eta'^3 d eta') / 2
                dc = dc + (b.w * _power(G @ b.P1.T, 3) * (dg @ b.P1.T)) @ b.A1 / 2
            dqs[:, b.f_idx] = -dc @ b.Ka_inv.T
        amplification[b.name] = max(1.0, float(amp.max(initial=1.0)))  # inf: at or beyond buckling
    # the multipliers (driver torques, reactions, axial forces) change with the accelerations of
    # the change: d2(dq)/dt2 on the elastic coordinates, the rigid accelerations and multipliers
    # re-solved from the rigid rows of the dynamics and the acceleration-level closure
    ddq = _second_derivative(tau_rows, dqs)
    elastic = sorted({i for b in bars for i in (*b.f_idx, *b.g_idx)})
    free = [i for i in range(mech.n) if i not in set(elastic)]
    eq_rows = free + list(range(mech.n, mech.n + mech.m))
    unknown = free + list(range(mech.n, mech.n + mech.m))
    dlam = np.zeros((len(rows), mech.m))
    dacc = np.zeros((len(rows), len(free)))
    if mech.m and elastic:
        J = _mapped(mech.kkt, len(rows), tau_rows, Q, V, np.zeros_like(Q), np.zeros_like(Lam), mech.p)[0]
        J = J.reshape(mech.n + mech.m, len(rows), mech.n + mech.m).transpose(1, 0, 2)
        A = J[:, eq_rows][:, :, unknown]
        rhs = -np.einsum("rij,rj->ri", J[:, eq_rows][:, :, elastic], ddq[:, elastic])
        solved = _least_squares(A, rhs)
        dlam, dacc = solved[:, len(free) :], solved[:, : len(free)]
    lead = _free_lead(mech, result, rows, free, dacc)
    out_f = mech.f["out"]
    zero = np.zeros_like(Q)
    at_run = _mapped(out_f, len(rows), tau_rows, Q, V, zero, Lam, mech.p)[0]  # the outputs the run has
    change = (_mapped(out_f, len(rows), tau_rows, Q + dqs, V, zero, Lam + dlam, mech.p)[0] - at_run).T
    # outputs a bar at or beyond its Euler load moves there (its unamplified change): not estimated
    moved_beyond = np.zeros(len(names))
    if beyond:
        moved_beyond = np.nan_to_num(
            np.abs(_mapped(out_f, len(rows), tau_rows, Q + dq_beyond, V, zero, Lam, mech.p)[0] - at_run).max(axis=1),
            nan=np.inf,
        )
    # the first bending frequency moves by half the relative change of its tangent stiffness
    # (the mean over the run, reported; the drift integrates it along the run)
    shift = {name: 0.5 * float(np.mean(t)) for name, t in tangent.items()}
    bands = _bands([b.omega for b in bars])
    stiff = {b.name: (shift[b.name], amplification[b.name]) for b in bars}
    peaks = np.array(list(result.peaks().values()))  # 0 where an output is zero to round-off
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    span = float(result.tau[-1] - result.tau[0])
    damping = float(eff.damping or 0.0)
    # the modes the run rings: the mechanism's coupled modes along the run (each with its shift);
    # the bars' own first modes where the coupled problem has no modes (a singular mass matrix)
    ringing = _coupled_modes(mech, bars, result, rows, Q, V, Lam)
    if ringing is None:
        ringing = [
            (b.omega, 0.5 * tangent[b.name], band, np.full(len(rows), b.omega), None) for b, band in zip(bars, bands)
        ]
    # without coupled modes, each output less the driver's harmonics below each bar's band (those a
    # run tells apart from its free vibration: :func:`forced_harmonics`) is taken as the mode's content
    rate = driver_rate(mech.scene)
    unforced = [
        without_harmonics(
            result.tau,
            np.asarray(result.outputs, dtype=float),
            forced_harmonics(result.tau, w, band, rate, _ringing(span, w, damping)),
        )
        if own is None
        else np.zeros((0, 0))
        for w, _, band, _, own in ringing
    ]
    coordinate = mode_changes(np.asarray(result.tau, dtype=float), tau_rows, ringing, damping, rate)
    moved: dict[str, float] = {}
    still = []
    rates = np.gradient(np.asarray(result.outputs, dtype=float), np.asarray(result.tau, dtype=float), axis=0)
    prescribed = _prescribed(mech, tau_rows, Q, V, Lam, peaks)
    for j, name in enumerate(names):
        if kinds.get(name) in CHECK_KINDS or peaks[j] == 0 or j in prescribed:
            continue
        size = float(np.abs(change[:, j]).max())
        # the modes' drifts at the same instant (the coupled modes' changes as the signals they are,
        # each its participation times its coordinate's: two modes the output sees in opposite phase
        # cancel there as they do)
        drifts = np.abs(sum((c[1][:, j] * c[0] for c in coordinate if c is not None), np.zeros(len(result.tau)))) + sum(
            (
                perturbed_along(result.tau, y[:, j], (tau_rows, mode_w, mode_shift), damping, band)
                for (_, mode_shift, band, mode_w, _), y, c in zip(ringing, unforced, coordinate)
                if c is None
            ),
            np.zeros(len(result.tau)),
        )
        # the free coordinate's timing: the output runs ahead by its rate times the lead
        if lead is not None:
            drifts = drifts + np.abs(rates[:, j] * lead)
        drift = float(np.max(drifts, initial=0.0)) / float(peaks[j])
        if size > 1e-12 * peaks[j]:
            # the static change and the drifts as sizes at the same instant, the largest along the run
            moved[name] = combined(result.tau, tau_rows, change[:, j], drifts) / float(peaks[j])
        else:
            still.append((name, drift))
    # outputs that q does not move (a driver torque): their own drift only
    out = {name: 0.0 for name in names}
    out.update(moved)
    out.update(dict(still))
    # outputs a bar at or beyond its Euler load moves: no static change is an estimate there
    for j, name in enumerate(names):
        if kinds.get(name) not in CHECK_KINDS and peaks[j] > 0 and moved_beyond[j] > 1e-12 * peaks[j]:
            out[name] = max(out[name], BEYOND_BUCKLING)
    left = (
        "the eighth- and higher-order terms of the exact curvature (eta''^2 eta'^6 / (1 - eta'^2)) and the "
        "exact strain's eta'^6 / 16"
        if order
        else "the exact curvature's terms beyond von Karman's eta''^2 (eta''^2 eta'^2 / (1 - eta'^2)) and the "
        "exact strain's eta'^4 / 8 and -eps eta'^2 / 2"
        + (", and the stretch's share of the curvature -eps eta''^2" if STRETCH_CURVATURE else "")
    )
    if order and any(not b.stretch_kept and b.na for b in bars):
        curvature = " and -eps eta''^2" if STRETCH_CURVATURE else ""
        left += f" (and -eps eta'^2 / 2{curvature} where the axial strain is held at 0)"
    if guides:
        on_guides = (
            f"the curvature's terms of the slot guide{'s' if len(guides) > 1 else ''} {', '.join(guides)} beyond its "
            "fourth-order eta''^2 (1 + eta'^2) (eta''^2 eta'^4 / (1 - eta'^2)), against its bending stiffness at the "
            "contact (not: its tension's geometric stiffness, the couplings of its shortening's motion with its "
            "rotation and with the contact's, its axis's shortening beyond -int eta'^2 / 2)"
        )
        left = f"{left}; {on_guides}" if any(not isinstance(b, _Guide) for b in bars) else on_guides
    method = (
        f"static response of each bar's stiffness (bending and its axial force) to {left}, "
        f"plus the first-order change of the mechanism's coupled modes hardened by them, at {len(rows)} outputs"
        if bars
        else "none: no bar bends (the rigid bodies are exact)"
    )
    for name, at in beyond.items():
        t = tau_rows[at]
        method += (
            f"; bar {name!r} at or beyond its Euler load (its tangent stiffness not positive definite) at "
            f"{int(at.sum())} of {len(at)} samples, tau {t.min():.6g} .. {t.max():.6g}: no static change is an "
            f"estimate there, the outputs it moves charged {BEYOND_BUCKLING:g} of their peak"
        )
    return ModelFormEstimate(out, stiff, method, tuple(guides))


#: the speed below which a torque-driven crank's timing is not read from its angle's change, as a
#: fraction of its top speed (a start from rest, where the change has not built up yet)
LEAD_SPEED_FLOOR = 1e-2


def _free_lead(
    mech: Mechanism, result: SimResult, rows: np.ndarray, free: list[int], dacc: np.ndarray
) -> np.ndarray | None:
    """How far ahead in time (at each output sample) the run of a mechanism whose one free motion a
    torque driver makes would be with the bars' left-out terms: a torque-driven crank is a free
    coordinate, so the change of its acceleration (``dacc``, from the rigid rows re-solved with the
    change's accelerations, at ``rows``) builds up into a drift of its angle, d theta = int int
    d theta'', which grows with the time run (the static change and the modes' drifts do not see
    it). The drift is read as a time lead, d theta / theta' (regularised below
    ``LEAD_SPEED_FLOOR`` of the top speed: a start from rest), which moves every output by its
    rate times the lead. None without exactly one torque driver on a free coordinate (a pendulum's
    free swing, or two torque drivers, are not a timing along one path).

    The first-order response without the feedback of the crank's own dynamics (its reduced inertia
    along a turn): on the kept-out torque-driven aluminium four-bar (von Karman vs the exact bar at
    the same bases, docs/exact-bars.md "A torque-driven crank's timing") it follows the measured
    angle difference between the toggles (0.77x) and misses its spikes at them (0.56x of its peak)."""
    torque = [d.body for d in mech.scene.drivers if d.kind == "torque"]
    if len(torque) != 1 or len(mech.scene.drivers) != 1:
        return None
    at = [k for k, i in enumerate(free) if mech.coords[i].kind is CoordKind.THETA and mech.coords[i].body == torque[0]]
    if not at or len(rows) < 3:
        return None
    i = free[at[0]]
    tau = np.asarray(result.tau, dtype=float)
    t_r = tau[rows]
    rate = np.cumsum(np.concatenate([[0.0], 0.5 * (dacc[1:, at[0]] + dacc[:-1, at[0]]) * np.diff(t_r)]))
    angle = np.cumsum(np.concatenate([[0.0], 0.5 * (rate[1:] + rate[:-1]) * np.diff(t_r)]))
    speed = np.asarray(result.v, dtype=float)[:, i]
    floor = LEAD_SPEED_FLOOR * float(np.max(np.abs(speed), initial=0.0))
    if floor == 0:
        return None
    return np.asarray(np.interp(tau, t_r, angle) * speed / (speed**2 + floor**2))


def combined(tau: np.ndarray, at: np.ndarray, change: np.ndarray, drifts: np.ndarray) -> float:
    """An output's model-form estimate from its static change ``change`` (samples at the times ``at``,
    ascending, within ``tau``) and its modes' drifts ``drifts`` (their size at each of ``tau``): the
    two added as sizes at the same instant, the largest along the run (estimator version 8, kept in
    11). Not each one's largest added: the static change is largest where the deflection is, the
    drift where a vibration has rung long, and the two need not meet (the kept-out damped aluminium
    crank-rocker with a mass on its coupler: the drift's largest at its start's ringing, 3.1e-4 of
    peak, the static change's 7.6e-5 elsewhere; von Karman vs the exact bar 3.0e-4, estimated 3.8e-4
    as the largest of each added, 3.2e-4 at the same instant). Sizes, not signals: the drift of a
    free vibration is an envelope whose phase against the static change is not known, so no
    cancellation between the two is credited. Between two samples of the static change the larger
    of the two is taken (an upper envelope: an interpolation would take a peak between them lower)."""
    return float(np.max(static_envelope(tau, at, change) + drifts, initial=0.0))


def static_envelope(tau: np.ndarray, at: np.ndarray, change: np.ndarray) -> np.ndarray:
    """The size of the static change ``change`` (samples at the times ``at``) at each of ``tau``:
    between two samples the larger of the two (:func:`combined`)."""
    tau = np.asarray(tau, dtype=float)
    at = np.asarray(at, dtype=float)
    size = np.abs(np.asarray(change, dtype=float))
    above = np.clip(np.searchsorted(at, tau, side="left"), 0, len(at) - 1)
    below = np.clip(np.searchsorted(at, tau, side="right") - 1, 0, len(at) - 1)
    return np.asarray(np.maximum(size[above], size[below]))


def _prescribed(
    mech: Mechanism, tau: np.ndarray, Q: np.ndarray, V: np.ndarray, Lam: np.ndarray, peaks: np.ndarray
) -> set[int]:
    """The columns of the outputs that are functions of the time alone (a driven crank's angle,
    a point of a rigid driven crank): they read no coordinate, rate or multiplier but the angle
    drivers' own angles, so no bar model changes them, and their model-form estimate is 0 (the
    drift would read the prescribed motion's content in a mode's band as free vibration). Found by
    moving every other coordinate, rate and multiplier at a few of the rows."""
    driven = {d.body for d in mech.scene.drivers if d.kind == "angle"}
    fixed = [i for i, c in enumerate(mech.coords) if c.kind is CoordKind.THETA and c.body in driven]
    if not fixed:
        return set()
    rows = np.unique(np.linspace(0, len(tau) - 1, min(3, len(tau))).astype(int))
    rng = np.random.default_rng(0)
    q, v, lam = Q[rows], V[rows], Lam[rows]
    dq = rng.uniform(-1e-3, 1e-3, q.shape)
    dq[:, fixed] = 0.0
    dv = rng.uniform(-1e-3, 1e-3, v.shape)
    dv[:, fixed] = 0.0
    dlam = rng.uniform(-1e-3, 1e-3, lam.shape) * (1.0 + np.abs(lam))
    zero = np.zeros_like(q)
    out = mech.f["out"]
    base = _mapped(out, len(rows), tau[rows], q, v, zero, lam, mech.p)[0]
    moved = _mapped(out, len(rows), tau[rows], q + dq, v + dv, zero, lam + dlam, mech.p)[0]
    change = np.abs(moved - base).max(axis=1)
    return {j for j in range(len(peaks)) if peaks[j] > 0 and change[j] <= 1e-12 * peaks[j]}


#: the configurations along the run where the coupled modes are computed, at most (each output sample
#: the estimate reads takes the nearest's): every one of the estimate's 400, since a mode's phase
#: follows its frequency (:func:`perturbed_along`), which sweeps within a turn (c_alu_long's rod:
#: 4.1-7.2 per unit tau; 24 along its 30 turns missed the sweep)
MODE_SAMPLES = 400
#: a mode's modal velocity from the velocity less the rigid coordinates' motion the closure gives it
#: (:func:`_coordinate_rows`, estimator version 14); off: phi^T M v (versions 10-13)
COORDINATE_RIGID_OUT = True
#: the coupled modes whose drift is looked for: the lowest ones, at most this many
MODES_KEPT = 12
#: a coupled mode with w^2 at most this fraction of the largest is a free motion of the mechanism
FREE_MOTION = 1e-10


def _coupled_modes(
    mech: Mechanism,
    bars: list[_Bar],
    result: SimResult,
    rows: np.ndarray,
    Q: np.ndarray,
    V: np.ndarray,
    Lam: np.ndarray,
) -> list[Ringing] | None:
    """The modes the run rings and how the left-out terms move them: (frequency per unit tau,
    its relative shift at each of the output ``rows``, its band, its frequency at each of the
    ``rows``, its modal velocity phi^T M v at each of the run's samples) of each of the lowest coupled
    modes of the mechanism, linear about the run's state (the tangent K = d res / dq and mass
    M = d res / da of the model's own dynamics on the closure's null space), computed at
    ``MODE_SAMPLES`` configurations along the run. A mode phi (mass-normalised) moves by
    shift = (1/2) phi^T H phi / omega^2, H the Hessian of the bars' left-out energy (its second
    difference along phi's part in each bar): for a bar alone, its first bending mode's
    (1/2) v^T H v / v^T (mu Kt) v. The mode a tool on an overhang makes with the linkage rings far
    below the coupler's own first bending (the four-bar with its rocker pinned at xi = 0.6 and a
    50 g tool: 5.5 against 15.3 per unit tau), and its drift is the model-form error there
    (docs/exact-bars.md). None where the problem has no modes (a mass matrix not positive
    definite on the closure's null space: quasi-static amplitudes)."""
    if not bars or len(rows) < 3:
        return None
    modal = _modal_function(mech)
    tau = np.asarray(result.tau, dtype=float)
    at = np.unique(np.linspace(0, len(rows) - 1, min(MODE_SAMPLES, len(rows))).astype(int))
    along = _modes_along(mech, tau[rows][at], Q[at], V[at], modal)
    if along is None:
        return None
    # each sample's (views of the stacks)
    omegas, shapes, rows_of, forces = (list(x) for x in along)
    count = min(len(w) for w in omegas)
    if count == 0:
        return None
    # the modes' signs made continuous along the run (each sample's as the previous one's)
    for s in range(1, len(at)):
        flip = np.einsum("ik,ik->k", shapes[s][:, :count], rows_of[s - 1][:, :count]) < 0
        shapes[s][:, :count][:, flip] *= -1.0
        rows_of[s][:, :count][:, flip] *= -1.0
        forces[s][:, :count][:, flip] *= -1.0
    # each output's change per unit of each mode's coordinate (its participation) at the samples:
    # the output at q + e phi, lam + e dlam (central differences)
    out_f = mech.f["out"]
    t_at = tau[rows][at]
    n_at = len(at)
    Qa = np.repeat(Q[at], count, axis=0)
    dQ = np.concatenate([shapes[s][:, :count].T for s in range(n_at)])
    dL = np.concatenate([forces[s][:, :count].T for s in range(n_at)])
    step = 1e-6 / np.maximum(np.abs(dQ).max(axis=1), 1e-300)  # each mode moves q by at most 1e-6
    dQ, dL = dQ * step[:, None], dL * step[:, None]
    Va, La = np.repeat(V[at], count, axis=0), np.repeat(Lam[at], count, axis=0)
    ta, zero = np.repeat(t_at, count), np.zeros_like(Qa)
    plus = _mapped(out_f, len(ta), ta, Qa + dQ, Va, zero, La + dL, mech.p)[0]
    minus = _mapped(out_f, len(ta), ta, Qa - dQ, Va, zero, La - dL, mech.p)[0]
    part = ((plus - minus) / (2 * step)).reshape(-1, n_at, count)  # (outputs, samples, modes)
    tau_rows = tau[rows]
    near = np.abs(tau_rows[:, None] - tau_rows[at][None, :]).argmin(axis=1)
    sweep = np.array([w[:count] for w in omegas])  # (samples, modes): each mode's frequency along the run
    mean = [float(x) for x in sweep.mean(axis=0)]
    bending = sorted({i for b in bars for i in b.g_idx})
    out: list[Ringing] = []
    bands = swept_bands(sweep.min(axis=0), sweep.max(axis=0), np.array(mean)) if SWEPT_BANDS else _bands(mean)
    for k, band in zip(range(count), bands):
        phi_k = np.stack([shapes[s][:, k] for s in near])
        w2 = np.array([omegas[s][k] ** 2 for s in near])
        # the mode's own vibration (the bending amplitudes' content within its band) shifts it by
        # half its share of the tangent along the run (the backbone, :func:`backbone`)
        rest = Q.copy()
        rest[:, bending] = without_band(tau_rows, Q[:, bending], band)
        vHv, vHv_rest = np.zeros(len(rows)), np.zeros(len(rows))
        for b in bars:
            vHv += b.scale * b.curvature_along(Q, Lam, phi_k[:, b.g_idx])
            vHv_rest += b.scale * b.curvature_along(rest, Lam, phi_k[:, b.g_idx], axial=Q)
        # the mode's velocity phi^T M v at every output sample (M phi interpolated between the samples)
        proj = np.stack([r[:, k] for r in rows_of])
        velocity = np.zeros(len(tau))
        V_all = np.asarray(result.v, dtype=float)
        for i in range(proj.shape[1]):
            velocity += np.interp(tau, t_at, proj[:, i]) * V_all[:, i]
        share = np.column_stack([np.interp(tau, t_at, part[j, :, k]) for j in range(part.shape[0])])
        out.append((mean[k], 0.5 * backbone(vHv, vHv_rest) / w2, band, np.sqrt(w2), (velocity, share)))
    return out


if TYPE_CHECKING:
    #: a coupled mode along the run, as :func:`_coupled_modes` gives it: (mean frequency, its relative
    #: shift at each of the rows, its band, its frequency at each of the rows, (its modal velocity at
    #: each of the run's samples, each output's participation in it there) or None)
    Ringing = tuple[float, np.ndarray, tuple[float, float], np.ndarray, tuple[np.ndarray, np.ndarray] | None]


def mode_changes(
    tau: np.ndarray, tau_rows: np.ndarray, ringing: list[Ringing], damping: float, rate: float | None
) -> list[tuple[np.ndarray, np.ndarray] | None]:
    """Each coupled mode's coordinate's change along the run (complex, at the run's samples) and
    each output's participation in it (``tau``: the run's samples, ``tau_rows``: the rows the
    modes are given at, ``rate``: :func:`driver_rate`): from its modal velocity's content in its
    band, less the driver's harmonics below it (:func:`forced_harmonics`), by its oscillator's
    first-order response to its shift (:func:`_perturbed`); None for a mode without a modal velocity
    (the bars' own modes)."""
    tau = np.asarray(tau, dtype=float)
    span = float(tau[-1] - tau[0])
    out: list[tuple[np.ndarray, np.ndarray] | None] = []
    for w, mode_shift, band, mode_w, own in ringing:
        if own is None:
            out.append(None)
            continue
        velocity = without_harmonics(
            tau, own[0][:, None], forced_harmonics(tau, w, band, rate, _ringing(span, w, damping))
        )[:, 0]
        change = _perturbed(tau, velocity, (tau_rows, mode_w, mode_shift), damping, band)
        out.append((change / np.interp(tau, tau_rows, mode_w), own[1]))
    return out


#: the share of a vibration's own cycle-mean tangent stiffening that moves its frequency: the
#: backbone of x'' + w^2 x + beta x^3 = 0, w^2 (1 + (3/4) beta a^2 / w^2) (harmonic balance),
#: against the tangent w^2 + 3 beta x^2, whose mean over a cycle is w^2 + (3/2) beta a^2
BACKBONE_SHARE = 0.5


def backbone(along: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """A mode's stiffening phi^T H phi along the run, from ``along`` (H at the run's state) and
    ``rest`` (H at the state less the mode's own vibration, its band's content): the other content
    (the slow deformation, the other modes' vibrations) moves the mode's frequency by its tangent,
    mean over the run; the mode's own vibration by half its tangent's, ``BACKBONE_SHARE`` (a Duffing
    oscillator's backbone: a hardening whose tangent is 3 beta x^2 raises w^2 by (3/4) beta a^2, not
    by the cycle's mean (3/2) beta a^2). The slewing arm of tests/data, undamped, ringing freely
    after the slew: von Karman vs the exact bar move its frequency by 1.01e-3, the tangent along
    the run by 2.11e-3 (tests/test_model_form_backbone.py)."""
    return np.asarray(rest + BACKBONE_SHARE * (along - rest))


def without_band(tau: np.ndarray, X: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """The columns of ``X`` (rows at ``tau``, evenly spaced) less their content within ``band``
    (angular frequencies; mirrored first: :func:`_mirrored_spectrum`)."""
    n = len(tau)
    if n < 8 or float(tau[-1] - tau[0]) <= 0 or X.shape[1] == 0:
        return X
    spectrum, freq = _mirrored_spectrum(tau, X)
    freq = np.abs(freq)
    spectrum[(freq > band[0]) & (freq < band[1])] = 0.0
    return np.asarray(np.real(np.fft.ifft(spectrum, axis=0))[:n])


def _mirrored_spectrum(tau: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The spectrum (along axis 0) of ``X`` (rows at ``tau``, evenly spaced) mirrored first, so that
    it is continuous when made periodic, and its angular frequencies."""
    n = len(tau)
    ext = np.concatenate([X, X[::-1]], axis=0)
    return np.fft.fft(ext, axis=0), 2 * np.pi * np.fft.fftfreq(2 * n, float(tau[-1] - tau[0]) / (n - 1))


#: each mechanism's :func:`_modal_function`, made once (the later estimates of its runs reuse it)
_MODAL: weakref.WeakKeyDictionary[Mechanism, Any] = weakref.WeakKeyDictionary()


def _modal_function(mech: Mechanism) -> Any:
    """The CasADi Function (t, q, v, a, lam, p) -> (d res / dq, d res / da, d phi / dq) of the
    model: its tangent stiffness, mass matrix and the closure's Jacobian."""
    import casadi as ca

    if mech not in _MODAL:
        args, phi = mech._symbols
        res = mech.f["res"](*args)
        _MODAL[mech] = ca.Function(
            "modal", args, [ca.jacobian(res, args[1]), ca.jacobian(res, args[3]), ca.jacobian(phi, args[1])]
        )
    return _MODAL[mech]


def coupled_modes(
    mech: Mechanism, t: float, q: np.ndarray, v: np.ndarray, modal: Any = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """(frequencies per unit tau, ascending, and the mass-normalised modes as columns in q) of the
    mechanism linear about the state (t, q, v) of a run of its model: K phi = w^2 M phi on the
    closure's null space, K = d res / dq at the state's accelerations and multipliers (bending,
    geometric stiffness of the axial forces, gravity and speed terms), M = d res / da (symmetric
    parts). The free motions (w^2 <= ``FREE_MOTION`` of the largest) are left out. None where M
    is not positive definite there (quasi-static amplitudes: no inertia)."""
    got = _modes_at(mech, t, q, v, modal)
    return None if got is None else (got[0], got[1])


def _modes_at(
    mech: Mechanism, t: float, q: np.ndarray, v: np.ndarray, modal: Any = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """:func:`coupled_modes`, M phi (columns: phi^T M v is the mode's modal velocity) and the
    multipliers' change with each mode (columns): the constraint forces (d res / d lam) dlam that
    hold the mode on the closure, (K - w^2 M) phi + (d res / d lam) dlam = 0."""
    modal = modal if modal is not None else _modal_function(mech)
    z = np.zeros
    J, r = mech.kkt(t, q, v, z(mech.n), z(mech.m), mech.p)
    J = np.array(J)
    # least squares: at a toggle the closure's rows are dependent and the multipliers not unique
    sol = np.linalg.lstsq(J, -np.array(r).ravel(), rcond=None)[0]
    a, lam = sol[: mech.n], sol[mech.n :]
    K, M, C = (np.array(x) for x in modal(t, q, v, a, lam, mech.p))
    N = _null(C)
    Kr, Mr = N.T @ K @ N, N.T @ M @ N
    try:
        Li = np.linalg.inv(np.linalg.cholesky((Mr + Mr.T) / 2))
    except np.linalg.LinAlgError:
        return None
    w2, y = np.linalg.eigh(Li @ ((Kr + Kr.T) / 2) @ Li.T)
    keep = np.flatnonzero(w2 > FREE_MOTION * max(float(np.abs(w2).max(initial=0.0)), 1e-300))
    phi = (N @ (Li.T @ y))[:, keep]
    Ms, Ks = (M + M.T) / 2, (K + K.T) / 2
    held = -(Ks @ phi - (Ms @ phi) * w2[keep])
    dlam = np.linalg.lstsq(J[: mech.n, mech.n :], held, rcond=None)[0] if mech.m else np.zeros((0, len(keep)))
    return (
        np.sqrt(w2[keep]),
        phi,
        _coordinate_rows(mech, C[None], (Ms @ phi)[None])[0] if COORDINATE_RIGID_OUT else Ms @ phi,
        dlam,
    )


def _coordinate_rows(mech: Mechanism, C: np.ndarray, Mphi: np.ndarray) -> np.ndarray:
    """The rows (columns per mode, stacked over samples: (S, n, count)) whose product with a
    velocity v is each mode's modal velocity: phi^T M (v - v_rigid), v_rigid the motion of the rigid
    coordinates alone that the closure's rows ``C`` (S, m, n) give v's (C v_rigid = C v, its
    elastic amplitudes zero; least squares). v less it is on the closure's null space, where phi^T M
    is the mode's coordinate; phi^T M v itself also projects the rigid mechanism's motion, whose
    inertia M couples to the mode along the run (on the five-bar 4-7x the modes' own content in
    their bands: docs/exact-bars.md, "The drift's modal coordinate"). On the null space the rows are
    M phi's (phi^T M phi_other unchanged)."""
    rigid = [i for i, c in enumerate(mech.coords) if not c.kind.elastic]
    if C.shape[1] == 0 or not rigid:
        return Mphi
    E = np.zeros((C.shape[0], C.shape[2], C.shape[2]))
    E[:, rigid, :] = np.stack([np.linalg.lstsq(c[:, rigid], c, rcond=None)[0] for c in C])
    return np.asarray(Mphi - E.transpose(0, 2, 1) @ Mphi)


def _modes_along(
    mech: Mechanism, t: np.ndarray, Q: np.ndarray, V: np.ndarray, modal: Any, kept: int = MODES_KEPT
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """:func:`_modes_at` at each sample (``t[s]``, ``Q[s]``, ``V[s]``) at once, its lowest ``count``
    modes (the fewest any sample keeps, at most ``kept``): the stacks (frequencies (S, count),
    phi (S, n, count), M phi (S, n, count), dlam (S, m, count)) of the same numbers, from one mapped
    call of the KKT system and of ``modal`` and stacked factorizations (issue 20: a Python loop of
    two CasADi calls and eight small factorizations per sample was most of the model-form part).
    None where a sample's M is not positive definite on the closure's null space (as
    :func:`_modes_at`). Samples whose closure Jacobians differ in rank take :func:`_modes_at`
    one at a time."""
    S, n, m = len(t), mech.n, mech.m
    J, r = _mapped(mech.kkt, S, t, Q, V, np.zeros((S, n)), np.zeros((S, m)), mech.p)
    J = J.reshape(n + m, S, n + m).transpose(1, 0, 2)
    # least squares, as _modes_at: at a toggle the closure's rows are dependent
    sol = _lstsq_each(J, -r.T)
    K, M, C = _mapped(modal, S, t, Q, V, sol[:, :n], sol[:, n:], mech.p)
    K, M = (x.reshape(n, S, n).transpose(1, 0, 2) for x in (K, M))
    if m:
        C = C.reshape(-1, S, n).transpose(1, 0, 2)
        _, s, Vt = np.linalg.svd(C)
        rank = np.sum(s > s[:, :1] * max(C.shape[1:]) * np.finfo(float).eps, axis=1)
        if np.any(rank != rank[0]):
            return _modes_one_by_one(mech, t, Q, V, modal, kept)
        N = Vt[:, int(rank[0]) :].transpose(0, 2, 1)
    else:
        N = np.broadcast_to(np.eye(n), (S, n, n))
    Nt = N.transpose(0, 2, 1)
    Kr, Mr = Nt @ K @ N, Nt @ M @ N
    try:
        Li = np.linalg.inv(np.linalg.cholesky((Mr + Mr.transpose(0, 2, 1)) / 2))
    except np.linalg.LinAlgError:
        return None
    Lit = Li.transpose(0, 2, 1)
    w2, y = np.linalg.eigh(Li @ ((Kr + Kr.transpose(0, 2, 1)) / 2) @ Lit)
    # eigh's frequencies ascend: the kept (w^2 above FREE_MOTION of the largest) are the last ones
    limit = FREE_MOTION * np.maximum(np.abs(w2).max(axis=1, initial=0.0), 1e-300)
    first = np.sum(w2 <= limit[:, None], axis=1)
    count = min(int(np.min(w2.shape[1] - first)), kept)
    cols = first[:, None] + np.arange(count)
    w2 = np.take_along_axis(w2, cols, axis=1)
    phi = N @ (Lit @ np.take_along_axis(y, cols[:, None, :], axis=2))
    Ms, Ks = (M + M.transpose(0, 2, 1)) / 2, (K + K.transpose(0, 2, 1)) / 2
    Mphi = Ms @ phi
    held = -(Ks @ phi - Mphi * w2[:, None, :])
    dlam = _lstsq_each(J[:, :n, n:], held) if m else np.zeros((S, 0, count))
    return (
        np.sqrt(w2),
        phi,
        _coordinate_rows(mech, C if m else np.zeros((S, 0, n)), Mphi) if COORDINATE_RIGID_OUT else Mphi,
        dlam,
    )


def _modes_one_by_one(
    mech: Mechanism, t: np.ndarray, Q: np.ndarray, V: np.ndarray, modal: Any, kept: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """:func:`_modes_along` by :func:`_modes_at` at each sample."""
    got = []
    for s in range(len(t)):
        g = _modes_at(mech, float(t[s]), Q[s], V[s], modal)
        if g is None:
            return None
        got.append(g)
    count = min(min(len(g[0]) for g in got), kept)
    w = np.stack([g[0][:count] for g in got])
    phi, Mphi, dlam = (np.stack([g[i][:, :count] for g in got]) for i in (1, 2, 3))
    return w, phi, Mphi, dlam


def _lstsq_each(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``np.linalg.lstsq(A[r], B[r], rcond=None)[0]`` of each r (lstsq itself, one at a time: a
    stacked SVD's rounding differs from it, and two close modes' shapes turn it into 4e-12 of
    the five-bar's)."""
    return np.stack([np.linalg.lstsq(a, b, rcond=None)[0] for a, b in zip(A, B)])


def _null(C: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the null space of ``C`` (rows: the closure's Jacobian)."""
    if C.shape[0] == 0:
        return np.eye(C.shape[1])
    _, s, Vt = np.linalg.svd(C)
    rank = int(np.sum(s > s[0] * max(C.shape) * np.finfo(float).eps)) if len(s) else 0
    return np.asarray(Vt[rank:].T)


#: the estimate ``effects.strain = "auto"``'s decision made on the run it keeps (von Karman kept:
#: the same mechanism and result), read once by that run's error estimate instead of made again
#: (the 12-bar chain: 3.5-10 s of CPU); the key holds what the estimate reads of the scene that
#: the decision may change (``with_choice`` replaces the effects and the choice's record)
_KEPT: MeasuredOnce[ModelFormEstimate] = MeasuredOnce()


def _kept_key(scene: Scene, samples: int) -> tuple[object, ...]:
    return (samples, scene.effects, list(scene.outputs), list(scene.drivers))


def keep_for_estimate(mech: Mechanism, scene: Scene, result: SimResult, est: ModelFormEstimate) -> None:
    """Keep ``est`` (:func:`model_form_estimate` of ``mech``, ``result``, the default samples) for
    the run's error estimate (:func:`estimate`) to read once, when ``mech.scene`` is then ``scene``
    (equal effects, outputs and drivers: the estimate reads nothing else of it)."""
    _KEPT.keep(mech, result, est, _kept_key(scene, SAMPLES))


def estimate(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """The model-form part of the error estimate (:func:`symgen.numerics.error_estimate.register_model_form`):
    the one kept for this very run (:func:`keep_for_estimate`), else made."""
    est = _KEPT.take(mech, result, _kept_key(mech.scene, SAMPLES))
    if est is None:
        est = model_form_estimate(mech, result)
    return est.outputs, est.method


#: the maps of the model's Functions made in this process: (id of the Function, samples) -> (the
#: Function, held so that its id stays its own, and its map); the latest ``MAPS_KEPT``
_MAPS: OrderedDict[tuple[int, int], tuple[Any, Any]] = OrderedDict()
MAPS_KEPT = 16


def _map(f: Any, k: int) -> Any:
    """``f.map(k)``, made once (the later estimates of the same model and run length reuse it)."""
    key = (id(f), k)
    if key in _MAPS:
        _MAPS.move_to_end(key)
    else:
        _MAPS[key] = (f, f.map(k))
        if len(_MAPS) > MAPS_KEPT:
            _MAPS.popitem(last=False)
    return _MAPS[key][1]


def _mapped(f: Any, k: int, tau: np.ndarray, *args: np.ndarray) -> list[np.ndarray]:
    """The model Function ``f(t, q, v, a, lam, p)`` at ``k`` samples in one call (its map: each
    sample's numbers as alone): ``tau`` the times, the others rows per sample, ``p`` (the last)
    the same for all; its outputs side by side (a column, or a block of columns, per sample)."""
    *per_sample, p = args
    got = _map(f, k)(tau.reshape(1, -1), *(np.asarray(x).T for x in per_sample), p)
    return [np.array(x) for x in (got if isinstance(got, (list, tuple)) else [got])]


def _least_squares(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.lstsq(A[r], b[r], rcond=None)[0]`` of each row r at once (by the SVD, with
    lstsq's cutoff of the singular values); 0 where the SVD fails (as the run's estimate did)."""
    try:
        U, s, Vt = np.linalg.svd(A, full_matrices=False)
    except np.linalg.LinAlgError:
        out = np.zeros((len(A), A.shape[2]))
        for r in range(len(A)):
            try:
                out[r] = np.linalg.lstsq(A[r], b[r], rcond=None)[0]
            except np.linalg.LinAlgError:
                pass
        return out
    cut = np.finfo(float).eps * max(A.shape[1:]) * s[:, :1]
    inv = np.divide(1.0, s, out=np.zeros_like(s), where=s > cut)
    x: np.ndarray = np.einsum("rji,rj->ri", Vt, inv * np.einsum("rji,rj->ri", U, b))
    return x


def _second_derivative(tau: np.ndarray, y: np.ndarray) -> np.ndarray:
    """d2y/dtau2 of the samples ``y`` (rows at ``tau``), by second-order differences (zeros
    with fewer than three samples)."""
    if len(tau) < 3:
        return np.zeros_like(y)
    return np.asarray(np.gradient(np.gradient(y, tau, axis=0), tau, axis=0))


def _bands(omegas: list[float]) -> list[tuple[float, float]]:
    """Each bar's band of angular frequencies where its free vibration is looked for: within 25 %
    of its first bending frequency, and no further than the geometric mean with the bars' nearest
    frequencies below and above (a vibration near two bars' frequencies is counted once, with the
    bar whose frequency it is nearer)."""
    out = []
    for w in omegas:
        lo, hi = 0.75 * w, 1.25 * w
        for o in omegas:
            if 0 < o < w:
                lo = max(lo, float(np.sqrt(o * w)))
            elif o > w:
                hi = min(hi, float(np.sqrt(o * w)))
        out.append((lo, hi))
    return out


#: a coupled mode's band spans its frequency's sweep along the run (:func:`swept_bands`, estimator
#: version 18); off: within 25 % of its mean frequency (:func:`_bands`, versions 10-17)
SWEPT_BANDS = True


def swept_bands(low: np.ndarray, high: np.ndarray, mean: np.ndarray) -> list[tuple[float, float]]:
    """Each coupled mode's band of angular frequencies where its vibration is looked for, from
    its lowest (``low``) and highest (``high``) frequency along the run and its ``mean`` (modes
    ascending): from 0.75x its lowest to 1.25x its highest, no further than the geometric mean of
    its range's end and the neighbour's nearest end (of the two means where the neighbours' ranges
    overlap). A mode whose frequency sweeps within a turn (a slot guide's span, and so its
    frequencies, change with the contact: the kept-out aluminium dyad's first mode 3.0-6.6 per unit
    tau about a mean of 4.6) rings at frequencies a band about the mean misses: there the drift
    read 0.68x / 0.56x the change of a known shift (that run with E 0.1 % stiffer, its bending
    modes 0.05 % faster; tests/test_model_form_sweep.py), with the swept band 1.16x / 0.93x. A mode
    that does not sweep keeps :func:`_bands`'s band about its mean."""
    out = []
    n = len(mean)
    for k in range(n):
        lo, hi = 0.75 * float(low[k]), 1.25 * float(high[k])
        if k > 0:
            apart = high[k - 1] < low[k]
            lo = max(lo, float(np.sqrt(high[k - 1] * low[k] if apart else mean[k - 1] * mean[k])))
        if k + 1 < n:
            apart = high[k] < low[k + 1]
            hi = min(hi, float(np.sqrt(high[k] * low[k + 1] if apart else mean[k] * mean[k + 1])))
        out.append((lo, hi))
    return out


#: the driver's harmonics taken out of the outputs before a mode's band is read: at most this many
#: (the lowest: the largest forced content)
HARMONICS_KEPT = 32


def driver_rate(scene: Any) -> float | None:
    """The rate (per unit tau) whose harmonics are every frequency the scene's drivers force:
    the one constant rate of its angle drivers, the lowest where the others are whole multiples
    of it (the five-bar's cranks at 1 and 2); None with a torque driver, a law, a ramp, or rates
    not in whole ratios."""
    rates = [
        abs(float(d.rate)) if d.kind == "angle" and d.law is None and d.ramp is None else 0.0 for d in scene.drivers
    ]
    if not rates or min(rates) <= 0:
        return None
    base = min(rates)
    if any(abs(r / base - round(r / base)) > 1e-9 for r in rates):
        return None
    return base


def forced_harmonics(
    tau: np.ndarray, omega: float, band: tuple[float, float], rate: float | None, memory: float | None = None
) -> list[float]:
    """The driver's harmonics k ``rate`` (angular frequencies per unit tau) below ``band`` that a
    run over ``tau`` tells apart from a free vibration at ``omega`` ringing for ``memory`` (default
    the run; with damping its decay time, :func:`_ringing`): at least one beat over that time,
    |k rate - omega| memory >= 2 pi; the ``HARMONICS_KEPT`` lowest; none without one constant
    driver rate. Not those within the band: there a fit cannot tell the forced response from a
    free vibration that rings for a turn or less (the five-bar's links' start ringing at 26-27 per
    unit tau, decay time 2.8: with harmonics 20-24 fitted too, torque_b's estimate fell from
    0.68x to 0.40x the true error)."""
    span = float(tau[-1] - tau[0])
    if not rate or rate <= 0 or span <= 0:
        return []
    rung = min(span, memory) if memory and memory > 0 else span
    top = int(np.ceil(band[0] / rate)) - 1
    ks = [k for k in range(1, top + 1) if abs(k * rate - omega) * rung >= 2 * np.pi]
    return [k * rate for k in ks[:HARMONICS_KEPT]]


def without_harmonics(tau: np.ndarray, y: np.ndarray, freqs: list[float]) -> np.ndarray:
    """``y`` (a column per output) less its least-squares fit of cosines and sines at ``freqs``
    (and a constant) over the run: the response forced at the driver's harmonics below a mode's
    band. It does not drift (a mode's shift changes it by shift x omega^2 / |omega^2 - (k rate)^2|,
    a change that does not grow with the time rung), but the large forced content of a driver
    torque or a reaction (the rigid mechanism's inertia, at the low harmonics) leaves its slope at
    the run's end as a kink of the mirrored signal of :func:`_band_envelope`, whose broad spectrum
    reads as a free vibration there, where the phase drift is largest (the kept-out steel
    slider-crank pump: the driver torque's envelope in the rod's band 0.104 of its peak at the
    run's end against 0.05-0.07 along the run; 0.052 without harmonics 1-3)."""
    if not freqs:
        return y
    t = np.asarray(tau, dtype=float) - float(tau[0])
    A = np.column_stack([np.ones_like(t)] + [f(w * t) for w in freqs for f in (np.cos, np.sin)])
    c = np.linalg.lstsq(A, y, rcond=None)[0]
    return np.asarray(y - A[:, 1:] @ c[1:])


def _band_envelope(tau: np.ndarray, y: np.ndarray, omega: float, band: tuple[float, float] | None = None) -> np.ndarray:
    """The envelope along the run of the content of ``y(tau)`` within ``band`` (angular
    frequencies; default within 25 % of ``omega``): the magnitude of its analytic signal (the
    signal mirrored first, so that it is continuous when made periodic); zeros when the run is
    shorter than two periods of ``omega``."""
    n = len(y)
    span = float(tau[-1] - tau[0])
    if n < 8 or omega <= 0 or omega * span < 4 * np.pi:
        return np.zeros(n)
    lo, hi = band or (0.75 * omega, 1.25 * omega)
    y = np.asarray(y, dtype=float)
    spectrum, freq = _mirrored_spectrum(tau, y - y.mean())
    keep = (freq > lo) & (freq < hi)
    analytic = np.fft.ifft(np.where(keep, 2.0 * spectrum, 0.0))
    return np.asarray(np.abs(analytic[:n]))


def _ringing(span: float, omega: float, damping: float) -> float:
    """How long a bar's free vibration drifts in phase: the run, or with Kelvin-Voigt damping c
    (per unit tau) its decay time 1 / sigma, sigma = c omega^2 / 2, if that is shorter."""
    sigma = 0.5 * damping * omega**2
    return min(span, 1.0 / sigma) if sigma > 0 else span


def _band_signal(tau: np.ndarray, y: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """The analytic signal of the content of ``y(tau)`` (evenly spaced) within ``band`` (angular
    frequencies; the signal mirrored first, :func:`_mirrored_spectrum`): complex, its magnitude the
    envelope of :func:`_band_envelope`."""
    n = len(y)
    y = np.asarray(y, dtype=float)
    spectrum, freq = _mirrored_spectrum(tau, y - y.mean())
    keep = (freq > band[0]) & (freq < band[1])
    return np.asarray(np.fft.ifft(np.where(keep, 2.0 * spectrum, 0.0))[:n])


#: the largest decay (in e-folds) of the recursion of :func:`perturbed_along` summed in one piece
_DECAY_PIECE = 300.0


def perturbed_along(
    tau: np.ndarray,
    y: np.ndarray,
    mode: tuple[np.ndarray, np.ndarray, np.ndarray],
    damping: float,
    band: tuple[float, float],
) -> np.ndarray:
    """The envelope |v| of :func:`_perturbed`'s change (below)."""
    return np.asarray(np.abs(_perturbed(tau, y, mode, damping, band)))


def _perturbed(
    tau: np.ndarray,
    y: np.ndarray,
    mode: tuple[np.ndarray, np.ndarray, np.ndarray],
    damping: float,
    band: tuple[float, float],
) -> np.ndarray:
    """How much a mode's content in an output changes when the mode's frequency moves by the
    fraction shift: the envelope of the first-order change of the mode's oscillator, at each
    sample of the run (zeros where nothing rings or the run is shorter than two periods).

    ``mode`` = (sample times, the mode's frequency W there, its shift there). The mode's content
    z (the analytic signal of ``y``'s content within ``band``) is the response of
    x'' + c W^2 x' + W^2 x = f; the shift adds the stiffness 2 shift W^2, whose first-order change
    dx obeys the same oscillator forced by -2 shift W^2 z. With dx = v e^{i Theta}, Theta = int W
    (the mode's own phase along the run, its frequency sweeping as the mechanism moves), slowly
    varying v:

        v' = -sigma v + i shift W z e^{-i Theta},   sigma = c W^2 / 2,

    |v| the change's envelope (at most twice z's: opposite phase). A free vibration
    z = a e^{i Theta - sigma t} gives v = i a W int shift: the phase drift omega int shift dtau since
    it came in (a start's ringing from the start, a kick from the kick, a vibration a passage
    through a resonance builds up from then), decaying with it; a response forced at a frequency w
    that the mode's phase does not follow gives, steady, |v| = shift W |z| / |W - w + i sigma| (near the
    resonance the relative change of the receptance 1 / (W^2 - w^2 + i c W^2 w) with the stiffness
    2 shift W^2 added, 2 shift W^2 / |W^2 - w^2 + i c W^2 w|), which does not grow with the time
    rung. The drift rule of estimator versions 3-7 charged all of a
    band's content as free vibration: the driver's harmonics within a mode's band (the kept-out
    aluminium slider-crank c_alu_long, its rod's first coupled mode sweeping 4.1-7.2 per unit tau
    along a turn, harmonics 5-7 inside its band 4.2-6.9) drifted 4e-3 to 9e-3 rad after the start's
    ringing had decayed, against a measured von Karman vs exact phase difference under 5e-4
    (docs/exact-bars.md, "Forced content within a band"). Oracles: tests/test_model_form_inband.py,
    tests/test_model_form_age.py (integrated oscillators, forced and free: 0.87-1.03x)."""
    tau = np.asarray(tau, dtype=float)
    n = len(tau)
    t_s, w_s, s_s = (np.asarray(x, dtype=float) for x in mode)
    span = float(tau[-1] - tau[0]) if n else 0.0
    if n < 8 or len(t_s) == 0 or span <= 0 or float(np.min(w_s)) * span < 4 * np.pi:
        return np.zeros(n, dtype=complex)
    z = _band_signal(tau, y, band)
    if not np.any(z):
        return np.zeros(n, dtype=complex)
    W = np.interp(tau, t_s, w_s)
    shift = np.interp(tau, t_s, s_s)
    h = np.diff(tau)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (W[1:] + W[:-1]) * h)])
    g = 1j * shift * W * z * np.exp(-1j * theta)
    sigma = 0.5 * damping * W**2
    decay = np.minimum(sigma[:-1] * h, _DECAY_PIECE)  # e-folds over each step (beyond: nothing left)
    # v[k+1] = e^{-decay_k} v[k] + (h_k / 2) (e^{-decay_k} g[k] + g[k+1]) (trapezoid), summed in
    # pieces of at most _DECAY_PIECE e-folds (the partial products stay finite)
    b = 0.5 * h * (np.exp(-decay) * g[:-1] + g[1:])
    L = np.concatenate([[0.0], np.cumsum(decay)])  # e-folds from the start to each sample
    v = np.zeros(n, dtype=complex)
    start = 0
    while start < n - 1:
        stop = int(np.searchsorted(L, L[start] + _DECAY_PIECE, side="right"))
        stop = min(max(stop, start + 2), n)  # samples start..stop-1
        Lp = L[start:stop] - L[start]
        acc = np.concatenate([[0.0], np.cumsum(np.exp(Lp[1:]) * b[start : stop - 1])])
        v[start:stop] = np.exp(-Lp) * (v[start] + acc)
        start = stop - 1
    # at most twice z (opposite phase); the change as a signal, v e^{i Theta}
    size = np.abs(v)
    v = v * np.divide(np.minimum(size, 2.0 * np.abs(z)), size, out=np.zeros(n), where=size > 0)
    return np.asarray(v * np.exp(1j * theta))
