"""The model-form estimate of a finished von Karman run: how much each output would change with
the exact bar's curvature (``effects.strain = "exact"``, docs/exact-bars.md), as a fraction of
the output's peak.

The exact bar adds to the bending energy, to fourth order in the amplitudes,

    dU = (mu/2) int eta'^2 eta''^2 - mu int (eps eta''^2 + eps' eta' eta'')

(tables E4, G3 of :class:`symgen.model.shapes.CurvatureProducts`). At each output sample of the
run, for each elastic bar, its generalized force dQ = d(dU)/dg is applied to the bar's transverse
stiffness at that instant, bending plus the geometric stiffness of its axial force N,

    K = mu Kt + sum_k n_k C3[k],   n_k = lambda e_k (dynamic axial: e = f + Ka^-1 c, the strain
                                   the axial basis carries), or the multipliers N_k (quasi-static,
                                   inextensible)

so that dg = -K^-1 dQ: the static change of the deflection (the axial amplitudes follow it,
df = -Ka^-1 dc, so that the strain the axial basis carries stays). Compression lowers K towards zero at
the bar's Euler load, which amplifies dg by 1 / (1 - P/P_cr) with no separate factor; the
amplification is capped at ``AMPLIFICATION_CAP`` (a bar at or beyond buckling in the run). Each
output's change is the model's output function at q + dq minus at q, its maximum over the run
divided by the output's peak.

Dynamics: the fourth-order terms harden each bar; its first bending frequency omega (the bar
alone, pinned or clamped as its frame) moves by the fraction shift = (1/2) mean over the run of
v^T H v / v^T (mu Kt) v, H = 6 mu E4 g g the Hessian of the added energy and v the bar's first mode.
The free vibration of the bar in an output (its amplitude within 25 % of omega in the output's
spectrum) then drifts in phase by omega T shift over the run's length T (with Kelvin-Voigt
damping c, at most its decay time 2 / (c omega^2)), and the output by that phase times the
amplitude (at most twice it). Each output's estimate is its static change plus its drift, as a
fraction of its peak; outputs that q does not move (a driver torque) have their drift only.

What it leaves out: the eps terms of the exact bar (their share is of the order N/lambda and the
axial ringing averages them out: the slider-crank's change is the same with and without them),
resonance of the change itself, the response of the rigid coordinates of a closed loop to dq.
Measured against von Karman vs exact runs in docs/exact-bars.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg

from symgen.ir.records import RowKind
from symgen.model.shape_cache import curvature_products, inner_products
from symgen.model.static_shapes import bar_bases

if TYPE_CHECKING:
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import SimResult

__all__ = ["AMPLIFICATION_CAP", "ModelFormEstimate", "model_form_estimate"]

#: output kinds the bar's constitutive law does not change (to round-off)
UNAFFECTED = ("closure_residual",)
#: the largest amplification of the static change by axial compression that is believed
AMPLIFICATION_CAP = 20.0


@dataclass(frozen=True)
class ModelFormEstimate:
    """The estimate of a run: ``outputs`` maps each output to its estimated change with the exact
    curvature as a fraction of its peak; ``bars`` each elastic bar to (max relative stiffness
    change of its bending |dQ|/|K g|, max amplification by its axial compression)."""

    outputs: dict[str, float]
    bars: dict[str, tuple[float, float]]
    method: str = "static response of each bar's stiffness to the exact curvature's fourth-order terms"


class _Bar:
    """The tables of one elastic bar and its places in q and lam."""

    def __init__(
        self, mech: Mechanism, name: str, body: dict[str, Any], f_idx: tuple[int, ...], g_idx: tuple[int, ...]
    ) -> None:
        ba, bt = bar_bases(body)
        ip = inner_products(ba, bt)
        cp = curvature_products(ba, bt)
        self.name, self.f_idx, self.g_idx = name, list(f_idx), list(g_idx)
        self.na, self.nt = len(f_idx), len(g_idx)
        self.Kt, self.C3, self.E4, self.G3 = ip.Kt, ip.C3, cp.E4, cp.G3
        nb = 2 + self.na
        M = ip.gram[nb : nb + self.nt, nb : nb + self.nt]
        self.Ka_inv = np.linalg.inv(ip.Ka) if self.na else np.zeros((0, 0))
        sc = mech.scene.body(name)
        self.lam, self.mu = float(sc.lam or 0.0), float(sc.mu or 0.0)
        rows = [i for i, r in enumerate(mech.info.lam_rows) if r.kind is RowKind.INEXTENSIBLE and r.joint == name]
        self.n_rows = rows  # multipliers N_k of a constrained (quasi-static or inextensible) bar
        # the first bending mode of the bar alone and its frequency (per unit tau): where its free
        # vibration rings
        w2, modes = scipy.linalg.eigh(self.mu * self.Kt, M)
        self.omega, self.mode = float(np.sqrt(max(w2[0], 0.0))), modes[:, 0]

    def change(self, q: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, float, float]:
        """(dg, the relative change of the first mode's tangent stiffness, amplification) at one
        sample."""
        g = q[self.g_idx]
        mu = self.mu
        # dQ_a of (mu/2) sum E4 g^4: 2 mu sum E4[a, b, c, d] g_b g_c g_d; its Hessian 6 mu E4 g g
        dQ = 2.0 * mu * np.einsum("abcd,b,c,d->a", self.E4, g, g, g)
        hess = 6.0 * mu * np.einsum("abcd,c,d->ab", self.E4, g, g)
        v = self.mode
        tangent = float(v @ hess @ v / (v @ (mu * self.Kt) @ v))
        K0 = mu * self.Kt
        K = K0
        if self.na:
            if self.n_rows:
                n = lam[self.n_rows]  # the multipliers N_k
            else:
                c = 0.5 * np.einsum("kab,a,b->k", self.C3, g, g)
                n = self.lam * (q[self.f_idx] + self.Ka_inv @ c)  # lambda P eps
            K = K0 + np.einsum("k,kab->ab", n, self.C3)
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


def model_form_estimate(mech: Mechanism, result: SimResult, samples: int = 400) -> ModelFormEstimate:
    """The estimate of a finished run ``result`` (:class:`symgen.numerics.simulate.SimResult`) of
    ``mech`` (:class:`symgen.numerics.mechanism.Mechanism`), at up to ``samples`` evenly spaced
    output rows. A run already with the exact strain estimates 0 for every output."""
    names = list(result.output_names)
    if mech.scene.effects.strain == "exact" or not mech.scene.effects.geometric_stiffening:
        return ModelFormEstimate({k: 0.0 for k in names}, {}, "none: the run has the exact bar's curvature")
    bodies = {b["name"]: b for b in mech.info.structure["bodies"]}
    bars = [
        _Bar(mech, name, bodies[name], f_idx, g_idx)
        for name, (f_idx, g_idx) in mech.amplitudes.items()
        if g_idx and not mech.scene.body(name).rigid
    ]
    rows = np.unique(np.linspace(0, len(result.tau) - 1, min(samples, len(result.tau))).astype(int))
    change = np.zeros((len(rows), len(names)))
    tangent: dict[str, list[float]] = {b.name: [] for b in bars}
    amplification = {b.name: 1.0 for b in bars}
    for r, i in enumerate(rows):
        q, v, lam = result.q[i], result.v[i], result.lam[i]
        dq = np.zeros_like(q)
        for b in bars:
            dg, tan, amp = b.change(q, lam)
            dq[b.g_idx] = dg
            if b.na:  # the axial amplitudes follow: the strain P eps (= N / lambda) stays, to first order
                g = q[b.g_idx]
                dq[b.f_idx] = -b.Ka_inv @ np.einsum("kab,a,b->k", b.C3, g, dg)
            tangent[b.name].append(tan)
            amplification[b.name] = max(amplification[b.name], amp)
        t = float(result.tau[i])
        change[r] = mech.call("out", t, q + dq, v, None, lam) - mech.call("out", t, q, v, None, lam)
    # the first bending frequency moves by half the mean relative change of its tangent stiffness
    shift = {name: 0.5 * float(np.mean(t)) for name, t in tangent.items()}
    stiff = {b.name: (shift[b.name], amplification[b.name]) for b in bars}
    peaks = np.abs(result.outputs).max(axis=0)
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    span = float(result.tau[-1] - result.tau[0])
    damping = float(mech.scene.effects.damping or 0.0)
    moved: dict[str, float] = {}
    still = []
    for j, name in enumerate(names):
        if kinds.get(name) in UNAFFECTED or peaks[j] == 0:
            continue
        size = float(np.abs(change[:, j]).max())
        drift = sum(
            _drift(result.tau, result.outputs[:, j], b.omega, shift[b.name], _ringing(span, b.omega, damping))
            for b in bars
        ) / float(peaks[j])
        if size > 1e-12 * peaks[j]:
            moved[name] = size / float(peaks[j]) + drift
        else:
            still.append((name, drift))
    # outputs that q does not move (a driver torque): their own drift only
    out = {name: 0.0 for name in names}
    out.update(moved)
    out.update(dict(still))
    return ModelFormEstimate(out, stiff)


def _band_amplitude(tau: np.ndarray, y: np.ndarray, omega: float) -> float:
    """Amplitude of the content of ``y(tau)`` within 25 % of the angular frequency ``omega``
    (Hann-windowed spectrum; 0 when the run is shorter than two periods)."""
    n = len(y)
    span = float(tau[-1] - tau[0])
    if n < 8 or omega <= 0 or omega * span < 4 * np.pi:
        return 0.0
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft((y - y.mean()) * w)) * 2.0 / w.sum()
    freq = 2 * np.pi * np.fft.rfftfreq(n, span / (n - 1))
    band = (freq > 0.75 * omega) & (freq < 1.25 * omega)
    return float(spec[band].max()) if band.any() else 0.0


def _ringing(span: float, omega: float, damping: float) -> float:
    """How long a bar's free vibration drifts in phase: the run, or with Kelvin-Voigt damping c
    (per unit tau) its decay time 1 / sigma, sigma = c omega^2 / 2, if that is shorter."""
    sigma = 0.5 * damping * omega**2
    return min(span, 1.0 / sigma) if sigma > 0 else span


def _drift(tau: np.ndarray, y: np.ndarray, omega: float, shift: float, span: float) -> float:
    """The phase drift of a bar's free vibration in an output over ``span``: with its frequency
    moved by the fraction ``shift``, the phase moves by omega span shift, the output by that times
    the vibration's amplitude in it (at most twice the amplitude: opposite phase)."""
    amp = _band_amplitude(tau, y, omega)
    return min(omega * span * shift, 2.0) * amp
