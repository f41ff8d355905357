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
the bar's Euler load, which amplifies dg by 1 / (1 - P/P_cr) with no separate factor; the
amplification is capped at ``AMPLIFICATION_CAP`` (a bar at or beyond buckling in the run). Each
output's change is the model's output function at q + dq minus at q, its maximum over the run
divided by the output's peak.

Dynamics: the left-out terms harden each bar; its first bending frequency omega (the bar
alone, pinned or clamped as its frame) moves at each sample by the fraction
shift(t) = (1/2) v^T H v / v^T (mu Kt) v, H the Hessian of dU (its second difference along v)
and v the bar's first mode. The free vibration of the bar in an output (the envelope of its
content within 25 % of omega, and no nearer another bar's frequency than the geometric mean of
the two) then drifts in phase by omega times the integral of shift over the time it has rung:
the run so far, with Kelvin-Voigt damping c at most its decay time 2 / (c omega^2); the output
by that phase times the envelope there (at most twice it), the largest along the run. Along the
run, not the mean shift times the run's length times a mean amplitude: the vibration a start or
a load step excites is largest, and its slopes with it, where a windowed spectrum of the whole
run sees least of it (the five-bar's links: 0.38x of the true error with the mean, 0.93x along
the run; benchmarks/RESULTS.md). Each output's estimate is its static change plus its drift, as
a fraction of its peak; outputs that q does not move (a driver torque) have their drift only.

The axial strain: von Karman keeps zeta' + eta'^2 / 2 of the exact |r'| - 1, the exact bar
zeta' + eta'^2 / 2 + eta'^4 / 8 (``STRAIN_ORDER``); the next term (eta'^4 / 8, eta'^6 / 16) and
the stretch's - eps eta'^2 / 2 enter as the work of the axial force (``_Bar.force``).

What it leaves out: the strain's share of the curvature (eps eta''^2 terms: of the order N/lambda, and the axial ringing averages them out: the slider-crank's
change is the same with and without them), resonance of the change itself, the response of the
rigid coordinates of a closed loop to dq; slot guides (their span moves along the guide) are not
estimated and the method text names them. Measured against von Karman vs exact runs in
docs/exact-bars.md and against the validation suite's references in benchmarks/RESULTS.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from symgen import cache
from symgen.ir.records import RowKind
from symgen.ir.shape_samples import ShapeSamples, samples_question

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import SimResult

__all__ = [
    "AMPLIFICATION_CAP",
    "EXACT_ORDER",
    "ModelFormEstimate",
    "ModelFormNotEstimated",
    "estimate",
    "model_form_estimate",
]

#: output kinds the bar's constitutive law does not change (to round-off)
UNAFFECTED = ("closure_residual",)
#: the largest amplification of the static change by axial compression that is believed
AMPLIFICATION_CAP = 20.0
#: the powers of s = eta'^2 the exact bar keeps in eta''^2 (1 + s + ...): 2 (sixth order in
#: the amplitudes, symgen/model/bars.py: E4, E6); a longer expansion there raises it here
EXACT_ORDER = 2
#: the exact strain's left-out part (its work with the axial force) is estimated too
STRAIN_LEFT_OUT = True
#: the powers of s = eta'^2 each strain keeps of the exact strain of a nearly inextensible bar,
#: |r'| - 1 = zeta' + s/2 + s^2/8 + s^3/16 + ... (zeta' = sqrt(1 - s) - 1 + the stretch): von Karman
#: 1 (s/2), the exact bar 2 (s/2 + s^2/8: symgen/model/bars.py, table C5, DERIVE_VERSION 8)
STRAIN_ORDER = {"von_karman": 1, "exact": 2}
#: the coefficients of s^n in 1 - sqrt(1 - s), n = 1, 2, 3, 4
_STRAIN_SERIES = (0.5, 0.125, 0.0625, 0.0390625)
#: the largest eta'^2 the series is evaluated at
SLOPE2_MAX = 0.5


class ModelFormNotEstimated(Exception):
    """The model-form part cannot be estimated for this run (the reason)."""


@dataclass(frozen=True)
class ModelFormEstimate:
    """The estimate of a run: ``outputs`` maps each output to its estimated change with the exact
    curvature as a fraction of its peak; ``bars`` each elastic bar to (the shift of its first
    bending frequency, max amplification by its axial compression); ``method`` how; ``skipped``
    the bars not estimated (slot guides)."""

    outputs: dict[str, float]
    bars: dict[str, tuple[float, float]]
    method: str = "static response of each bar's stiffness to the curvature's left-out terms"
    skipped: tuple[str, ...] = ()


def _samples(body: dict[str, Any]) -> ShapeSamples:
    """A bar's shape samples from the signed cache (taken when the model was derived), or sampled
    now where the cache does not hold them (a model cache written by an older symgen)."""
    known, answer = cache.recall(samples_question(body))
    if known:
        try:
            return ShapeSamples.from_json(answer)
        except ValueError:
            pass
    from symgen.model.shape_samples import shape_samples

    return shape_samples(body)


def _residual(s: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """(h, dh/ds) of h(s) = s^(order+1) / (1 - s): the terms of 1 / (1 - s) after s^order."""
    s = np.minimum(s, SLOPE2_MAX)
    k = order + 1
    h = s**k / (1.0 - s)
    dh = (k * s ** (k - 1) * (1.0 - s) + s**k) / (1.0 - s) ** 2
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
        self.Kt = self.P2.T @ (w[:, None] * self.P2)
        M = self.P0.T @ (w[:, None] * self.P0)
        self.C3 = np.einsum("i,ik,ia,ib->kab", w, A1, self.P1, self.P1)
        Ka = A1.T @ (w[:, None] * A1)
        self.Ka_inv = np.linalg.inv(Ka) if self.na else np.zeros((0, 0))
        sc = mech.scene.body(name)
        self.lam, self.mu = float(sc.lam or 0.0), float(sc.mu or 0.0)
        rows = [i for i, r in enumerate(mech.info.lam_rows) if r.kind is RowKind.INEXTENSIBLE and r.joint == name]
        self.n_rows = rows  # multipliers N_k of a constrained (quasi-static or inextensible) bar
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
        the energy changes by N's work)."""
        e1, e2 = self.P1 @ g, self.P2 @ g
        h, dh = _residual(e1 * e1, self.order)
        wq = self.w * self.mu
        dQ: np.ndarray = self.P2.T @ (wq * e2 * h) + self.P1.T @ (wq * e2 * e2 * dh * e1)
        if N is not None and STRAIN_LEFT_OUT:
            soft = N * N / self.lam if self.lam > 0 else 0.0 * N
            m = self.strain_order + 1
            left = _STRAIN_SERIES[m - 1] * 2 * m * e1 ** (2 * m - 1)  # d/d eta' of c_m eta'^(2m)
            dQ = dQ + self.P1.T @ (self.w * (N * left - soft * e1))
        return dQ

    def axial_force(self, q: np.ndarray, lam: np.ndarray) -> np.ndarray | None:
        """(the multipliers N_k or lambda e_k, the axial force at the nodes) of one sample, or
        None without axial functions."""
        if not self.na:
            return None
        if self.n_rows:
            return np.asarray(lam[self.n_rows])  # the multipliers N_k
        g = q[self.g_idx]
        c = 0.5 * np.einsum("kab,a,b->k", self.C3, g, g)
        if self.strain_order >= 2:  # the exact bar's (phi'_k, eta'^4 / 8)
            c = c + self.A1.T @ (self.w * (self.P1 @ g) ** 4) / 8
        return np.asarray(self.lam * (q[self.f_idx] + self.Ka_inv @ c))  # lambda P eps

    def change(self, q: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, float, float]:
        """(dg, the relative change of the first mode's tangent stiffness, amplification) at one
        sample."""
        g = q[self.g_idx]
        mu = self.mu
        n = self.axial_force(q, lam)
        N = None if n is None else self.A1 @ n
        dQ = self.force(g, N)
        v = self.mode
        step = 1e-4 * max(float(np.abs(self.P1 @ g).max()), 1e-3) / max(float(np.abs(self.P1 @ v).max()), 1e-300)
        vHv = float(v @ (self.force(g + step * v, N) - self.force(g - step * v, N))) / (2.0 * step)
        tangent = vHv / float(v @ (mu * self.Kt) @ v)
        K0 = mu * self.Kt
        K = K0 if n is None else K0 + np.einsum("k,kab->ab", n, self.C3)
        dg0 = -np.linalg.solve(K0, dQ)
        try:
            dg = -np.linalg.solve(K, dQ)
            ok = bool(np.all(np.isfinite(dg)) and np.all(np.linalg.eigvalsh((K + K.T) / 2) > 0))
        except np.linalg.LinAlgError:
            ok = False
        size0 = float(np.linalg.norm(dg0))
        amp = float(np.linalg.norm(dg)) / size0 if ok and size0 > 0 else 1.0
        if not ok or amp > AMPLIFICATION_CAP:
            amp = AMPLIFICATION_CAP
            dg = AMPLIFICATION_CAP * dg0
        return dg, tangent, amp


def _guides(structure: dict[str, Any]) -> set[str]:
    return {j["ends"][1][0] for j in structure.get("joints", []) if j.get("kind") == "slot"}


def model_form_estimate(mech: Mechanism, result: SimResult, samples: int = 400) -> ModelFormEstimate:
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
    structure = mech.info.structure
    bodies = {b["name"]: b for b in structure["bodies"]}
    guides = _guides(structure)
    bars = [
        _Bar(mech, name, _samples(bodies[name]), f_idx, g_idx, order, strain_order)
        for name, (f_idx, g_idx) in mech.amplitudes.items()
        if g_idx and not mech.scene.body(name).rigid and name not in guides
    ]
    skipped = tuple(name for name, (_, g_idx) in mech.amplitudes.items() if g_idx and name in guides)
    if skipped and not bars:
        raise ModelFormNotEstimated(
            f"the bending bars are slot guides ({', '.join(skipped)}), whose span moves along the guide: "
            "no estimate of their curvature's left-out terms"
        )
    rows = np.unique(np.linspace(0, len(result.tau) - 1, min(samples, len(result.tau))).astype(int))
    change = np.zeros((len(rows), len(names)))
    tangent: dict[str, list[float]] = {b.name: [] for b in bars}
    amplification = {b.name: 1.0 for b in bars}
    dqs = np.zeros((len(rows), mech.n))
    for r, i in enumerate(rows):
        q, lam = result.q[i], result.lam[i]
        for b in bars:
            dg, tan, amp = b.change(q, lam)
            dqs[r, b.g_idx] = dg
            if b.na:  # the axial amplitudes follow: the strain P eps (= N / lambda) stays, to first order
                g = q[b.g_idx]
                dc = np.einsum("kab,a,b->k", b.C3, g, dg)
                if b.strain_order >= 2:  # the exact bar's d(phi'_k, eta'^4 / 8) = (phi'_k, eta'^3 d eta') / 2
                    dc = dc + b.A1.T @ (b.w * (b.P1 @ g) ** 3 * (b.P1 @ dg)) / 2
                dqs[r, b.f_idx] = -b.Ka_inv @ dc
            tangent[b.name].append(tan)
            amplification[b.name] = max(amplification[b.name], amp)
    # the multipliers (driver torques, reactions, axial forces) change with the accelerations of
    # the change: d2(dq)/dt2 on the elastic coordinates, the rigid accelerations and multipliers
    # re-solved from the rigid rows of the dynamics and the acceleration-level closure
    ddq = _second_derivative(np.asarray(result.tau)[rows], dqs)
    elastic = sorted({i for b in bars for i in (*b.f_idx, *b.g_idx)})
    free = [i for i in range(mech.n) if i not in set(elastic)]
    eq_rows = free + list(range(mech.n, mech.n + mech.m))
    unknown = free + list(range(mech.n, mech.n + mech.m))
    for r, i in enumerate(rows):
        q, v, lam = result.q[i], result.v[i], result.lam[i]
        t = float(result.tau[i])
        dlam = np.zeros(mech.m)
        if mech.m and elastic:
            J = np.array(mech.kkt(t, q, v, np.zeros(mech.n), np.zeros(mech.m), mech.p)[0])
            A = J[np.ix_(eq_rows, unknown)]
            rhs = -J[np.ix_(eq_rows, elastic)] @ ddq[r, elastic]
            try:
                x = np.linalg.lstsq(A, rhs, rcond=None)[0]
                dlam = x[len(free) :]
            except np.linalg.LinAlgError:
                dlam = np.zeros(mech.m)
        change[r] = mech.call("out", t, q + dqs[r], v, None, lam + dlam) - mech.call("out", t, q, v, None, lam)
    # the first bending frequency moves by half the relative change of its tangent stiffness
    # (the mean over the run, reported; the drift integrates it along the run)
    shift = {name: 0.5 * float(np.mean(t)) for name, t in tangent.items()}
    tau_rows = np.asarray(result.tau, dtype=float)[rows]
    bands = _bands([b.omega for b in bars])
    stiff = {b.name: (shift[b.name], amplification[b.name]) for b in bars}
    peaks = np.abs(result.outputs).max(axis=0)
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    span = float(result.tau[-1] - result.tau[0])
    damping = float(eff.damping or 0.0)
    moved: dict[str, float] = {}
    still = []
    for j, name in enumerate(names):
        if kinds.get(name) in UNAFFECTED or peaks[j] == 0:
            continue
        size = float(np.abs(change[:, j]).max())
        drift = sum(
            _drift(
                result.tau,
                result.outputs[:, j],
                b.omega,
                (tau_rows, 0.5 * np.asarray(tangent[b.name])),
                _ringing(span, b.omega, damping),
                band,
            )
            for b, band in zip(bars, bands)
        ) / float(peaks[j])
        if size > 1e-12 * peaks[j]:
            moved[name] = size / float(peaks[j]) + drift
        else:
            still.append((name, drift))
    # outputs that q does not move (a driver torque): their own drift only
    out = {name: 0.0 for name in names}
    out.update(moved)
    out.update(dict(still))
    left = (
        "the eighth- and higher-order terms of the exact curvature (eta''^2 eta'^6 / (1 - eta'^2))"
        if order
        else "the exact curvature's terms beyond von Karman's eta''^2 (eta''^2 eta'^2 / (1 - eta'^2))"
    )
    method = (
        f"static response of each bar's stiffness (bending and its axial force) to {left}, "
        f"plus the phase drift of its first bending mode hardened by them, at {len(rows)} outputs"
        if bars
        else "none: no bar bends (the rigid bodies are exact)"
    )
    if skipped:
        method += f"; slot guides not estimated: {', '.join(skipped)}"
    return ModelFormEstimate(out, stiff, method, skipped)


def estimate(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """The model-form part of the error estimate (:func:`symgen.numerics.error_estimate.register_model_form`)."""
    est = model_form_estimate(mech, result)
    return est.outputs, est.method


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
    ext = np.concatenate([y - y.mean(), (y - y.mean())[::-1]])
    freq = 2 * np.pi * np.fft.fftfreq(2 * n, span / (n - 1))
    keep = (freq > lo) & (freq < hi)
    analytic = np.fft.ifft(np.where(keep, 2.0 * np.fft.fft(ext), 0.0))
    return np.asarray(np.abs(analytic[:n]))


def _ringing(span: float, omega: float, damping: float) -> float:
    """How long a bar's free vibration drifts in phase: the run, or with Kelvin-Voigt damping c
    (per unit tau) its decay time 1 / sigma, sigma = c omega^2 / 2, if that is shorter."""
    sigma = 0.5 * damping * omega**2
    return min(span, 1.0 / sigma) if sigma > 0 else span


def _drift(
    tau: np.ndarray,
    y: np.ndarray,
    omega: float,
    shift: tuple[np.ndarray, np.ndarray],
    memory: float,
    band: tuple[float, float] | None = None,
) -> float:
    """The phase drift of a bar's free vibration in an output: with its frequency moved by the
    fraction ``shift`` = (sample times, shift there), the vibration's phase moves by
    omega int shift dtau over the time it has rung (``memory``: the run, or its decay time), the
    output by that phase times the vibration's amplitude there (its envelope, at most twice it:
    opposite phase); the largest along the run. Integrated along the run rather than the mean
    shift times the run's length times the run's mean amplitude: the free vibration is largest
    where a start or a load step excites it, and so are the slopes that shift its frequency."""
    tau = np.asarray(tau, dtype=float)
    env = _band_envelope(tau, y, omega, band)
    if not env.any():
        return 0.0
    t_s, s = shift
    if len(t_s) == 0:
        return 0.0
    rate = np.interp(tau, t_s, s)
    acc = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(tau))])
    before = np.interp(tau - memory, tau, acc, left=0.0)
    phase = omega * np.abs(acc - before)  # signed: a shift that changes sign along the run unwinds
    return float(np.max(env * np.minimum(phase, 2.0)))
