"""The quasi-static axial part of the error estimate: the phase drift of the free motion that the
quasi-static (constraint) axial treatment leaves out (issue 19, item 2).

A bar whose axial dynamics are quasi-static (``effects.axial = "quasi_static"``, or ``"auto"``
where its first axial frequency is far above the motion: ``symgen.model.structure``) moves as the
inextensible bar; its stretch N/lambda is added to the outputs read from its shape, not to its
kinematics. The mechanism's inertia therefore misses the stretch: a soft arm spinning freely at
w is stretched by its centrifugal force and its moment of inertia grows by

    dJ = (2 w^2 / lambda) (M^2 + 2M/3 + 2/15)     (uniform arm, tip mass M, lengths over l),

so that the dynamic bar spins dJ/J slower at the same angular momentum. A motion that the run
prescribes (an angle driver) does not drift; a free one (a torque driver, a released pendulum)
runs ahead by a time that grows over the run, with nothing in the truncation rerun (same
treatment) or the curvature's model form to see it.

Along the run, at each output sample: the kinetic energy T of the model at (q, v) and dT, its
change when each quasi-static bar's axial amplitudes read f + N/lambda (N its multipliers: the
stretched bar the outputs show), both from the model's energy function (kinetic + elastic +
potential, so T = E(q, v) - E(q, 0)). Where the free motion's inertia grows by the fraction
dT/T, it runs slower by that fraction: the run is ahead of the dynamic bar by the time

    dt(t) = int_0^t dT/T ds

and each output is off by |dy/dt| dt(t), its largest along the run over its peak. On the spinning
arm dT/T = dJ/J exactly (``tests/test_axial_drift.py``: the closed form above). For a pendulum
under gravity the stretch also lengthens the arm of its weight, which halves the period change
of a uniform stretch: there the part is up to 2x high. Zero where the run has no free rigid
coordinate (every rigid motion prescribed) or no quasi-static bar.

Not charged: the start's axial ringing of force outputs (driver torques, reactions) at an
undeformed start at speed (the auto rule keeps the axial dynamics where the ringing of
deflections and positions exceeds the accuracy: ``symgen.scene.bases.axial_ringing``), and the
stretch's own rate f' + N'/lambda in T (of the order of the axial force's rate over lambda).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from symgen.ir.records import RowKind
from symgen.numerics.model_form import _mapped

if TYPE_CHECKING:
    from symgen.numerics.index1 import Partition
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import SimResult

__all__ = ["KEY", "AxialNotEstimated", "estimate", "free_rates", "quasi_static_bars", "stretch_inertia"]

#: bar -> (its axial amplitudes, the rows of its multipliers, the index of its lambda in the parameters)
Bars = dict[str, tuple[list[int], list[int], int]]
#: the key that removes the error this part charges
KEY = 'effects.axial = "dynamic"'
#: sampled outputs (all of them when the run has fewer)
MAX_SAMPLES = 4000
#: kinetic energies below this fraction of the run's largest are taken as at rest (dT/T = 0)
REST = 1e-9


class AxialNotEstimated(Exception):
    """The quasi-static axial part cannot be estimated for this run (the reason)."""


def quasi_static_bars(mech: Mechanism) -> Bars:
    """bar -> (its axial amplitudes, the rows of its multipliers N_k, the index of its lambda in
    the parameters) of every bar whose axial dynamics are quasi-static in this model."""
    from symgen.ir.spec import QUASI_STATIC
    from symgen.model.structure import axial_treatments

    treat = axial_treatments(mech.scene)
    params = list(mech.info.params)
    out: Bars = {}
    for name, t in treat.items():
        if t.treatment != QUASI_STATIC:
            continue
        rows = [i for i, r in enumerate(mech.info.lam_rows) if r.kind is RowKind.INEXTENSIBLE and r.joint == name]
        f_idx = list(mech.amplitudes.get(name, ((), ()))[0])
        lam_name = f"lambda_{name}"
        if not rows or len(rows) != len(f_idx) or lam_name not in params:
            raise AxialNotEstimated(f"the quasi-static bar {name!r} has no multipliers matching its axial amplitudes")
        out[name] = (f_idx, rows, params.index(lam_name))
    return out


def _stretched(mech: Mechanism, Q: np.ndarray, Lam: np.ndarray, bars: Bars) -> np.ndarray:
    """The coordinates (rows per sample) with every quasi-static bar's axial amplitudes reading
    f + N/lambda."""
    Q2 = np.array(Q, dtype=float)
    for f_idx, rows, k in bars.values():
        Q2[:, f_idx] += np.asarray(Lam)[:, rows] / mech.p[k]
    return Q2


def _kinetic(mech: Mechanism, tau: np.ndarray, Q: np.ndarray, V: np.ndarray, Lam: np.ndarray) -> np.ndarray:
    """T = E(q, v) - E(q, 0) at each sample (the energy function's elastic and potential parts
    do not depend on v)."""
    zero = np.zeros_like(Q)
    k = len(tau)
    moving = _mapped(mech.f["energy"], k, tau, Q, V, zero, Lam, mech.p)[0]
    still = _mapped(mech.f["energy"], k, tau, Q, zero, zero, Lam, mech.p)[0]
    return np.asarray(moving - still, dtype=float).ravel()


def stretch_inertia(
    mech: Mechanism, tau: np.ndarray, Q: np.ndarray, V: np.ndarray, Lam: np.ndarray, bars: Bars
) -> tuple[np.ndarray, np.ndarray]:
    """(T, dT) at each sample (rows of Q, V, Lam): the kinetic energy and its change when every
    quasi-static bar's axial amplitudes carry their stretch N/lambda (``bars`` from
    :func:`quasi_static_bars`)."""
    T = _kinetic(mech, tau, Q, V, Lam)
    return T, _kinetic(mech, tau, _stretched(mech, Q, Lam, bars), V, Lam) - T


def _partition(mech: Mechanism, result: SimResult) -> Partition:
    return result.partition or mech.choose_partition(float(result.tau[0]), np.asarray(result.q[0]))


def free_rates(
    mech: Mechanism, tau: np.ndarray, Q: np.ndarray, V: np.ndarray, Lam: np.ndarray, part: Partition
) -> np.ndarray:
    """Each output's rate along the free motion alone (rows per sample): the outputs' directional
    derivative in q along the velocity of the free rigid coordinates (the other independent
    rates zero, the dependent coordinates following through the closure's Jacobian)."""
    free = [i for i in part.ind if i in mech.rigid]
    W = np.zeros_like(Q)
    W[:, free] = V[:, free]
    if part.dep:
        dep = list(part.dep)
        for r in range(len(tau)):
            J = mech.jac_q(float(tau[r]), Q[r])
            W[r, dep] = np.linalg.lstsq(J[:, dep], -J @ W[r], rcond=None)[0]
    h = 1e-6 / np.maximum(np.abs(W).max(axis=1, initial=0.0), 1.0)
    zero = np.zeros_like(Q)
    k = len(tau)
    up = _mapped(mech.f["out"], k, tau, Q + h[:, None] * W, V, zero, Lam, mech.p)[0]
    down = _mapped(mech.f["out"], k, tau, Q - h[:, None] * W, V, zero, Lam, mech.p)[0]
    rates: np.ndarray = ((up - down) / (2.0 * h[None, :])).T
    return rates


def estimate(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """output -> the drift of the free motion the quasi-static axial treatment leaves out, as a
    fraction of the output's peak, and how (see the module docstring). Raises
    :class:`AxialNotEstimated` where it cannot be evaluated."""
    names = list(result.output_names)
    if names != list(mech.info.outputs):
        raise AxialNotEstimated("the run's outputs are not the model's output function's")
    bars = quasi_static_bars(mech)
    if not bars:
        return dict.fromkeys(names, 0.0), "no bar has quasi-static axial dynamics: nothing to charge"
    part = _partition(mech, result)
    free = [i for i in part.ind if i in mech.rigid]
    listed = ", ".join(sorted(bars))
    if not free:
        return dict.fromkeys(names, 0.0), (
            f"the quasi-static axial bars ({listed}) change no prescribed motion: every rigid coordinate is driven"
        )
    tau = np.asarray(result.tau, dtype=float)
    if len(tau) < 3:
        raise AxialNotEstimated("the run has fewer than three output samples")
    idx = np.unique(np.linspace(0, len(tau) - 1, min(len(tau), MAX_SAMPLES)).round().astype(int))
    Q, V, Lam = (np.asarray(x, dtype=float)[idx] for x in (result.q, result.v, result.lam))
    T, dT = stretch_inertia(mech, tau[idx], Q, V, Lam, bars)
    rates = free_rates(mech, tau[idx], Q, V, Lam, part)
    if not np.all(np.isfinite(T)) or not np.all(np.isfinite(dT)):
        raise AxialNotEstimated("the kinetic energy is not finite along the run")
    moving = T > REST * max(float(np.max(np.abs(T))), 1e-300)
    share = np.where(moving, np.abs(dT) / np.where(moving, T, 1.0), 0.0)
    ts = tau[idx]
    ahead = np.concatenate(([0.0], np.cumsum(0.5 * (share[1:] + share[:-1]) * np.diff(ts))))
    out: dict[str, float] = {}
    for k, n in enumerate(names):
        peak = float(np.max(np.abs(np.asarray(result.column(n), dtype=float))))
        if peak == 0.0 or not np.isfinite(peak):
            out[n] = 0.0
            continue
        out[n] = float(np.max(np.abs(rates[:, k]) * ahead) / peak)
    how = (
        f"the phase drift of the free motion ({len(free)} free rigid coordinate(s)) with the stretch's inertia that "
        f"the quasi-static axial treatment of {listed} leaves out: the time the run is ahead, int dT/T "
        f"({float(ahead[-1]):.3g} tau at its end; largest dT/T {float(np.max(share)):.3g}), x each output's rate along the free motion; "
        f"lowered by {KEY}"
    )
    return out, how
