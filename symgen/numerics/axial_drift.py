"""The quasi-static axial part of the error estimate: what the quasi-static (constraint) axial
treatment leaves out (issue 19, item 2): the phase drift of the free motion, the start's axial
ringing and the stretch's own inertia.

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

and each output is off by |dy/dt| dt(t), its largest along the run over its peak, dy/dt its rate
along the run (:func:`run_rates`: its recorded history's derivative). The whole rate, not the
rate along the free rigid coordinates alone: a deflection reads only the elastic amplitudes, yet
its history is forced by the free motion and shifts with it (the soft free double pendulum of
issue 19, tips 17 % of the length: the quasi-static treatment moved its deflections by 2.7-4.3 %
of peak, the rate along the free coordinates charged them 0, the whole rate 1.1-1.3 %). Where a
mechanism has both a free and a prescribed rigid motion, an output's rate along the prescribed
one is charged too (on the safe side: the prescribed motion does not drift). On the spinning
arm dT/T = dJ/J exactly (``tests/test_axial_drift.py``: the closed form above). For a pendulum
under gravity the stretch also lengthens the arm of its weight, which halves the period change
of a uniform stretch: there the part is up to 2x high. Zero where the run has no free rigid
coordinate (every rigid motion prescribed) or no quasi-static bar.

The start's axial ringing (:func:`ringing`): a run that does not start on its quasi-static
deformation (an undeformed start at speed) rings the dynamic bar axially about the stretch the
quasi-static bar has from the first instant; a window from the start run with the axial dynamics
kept against the run's own model measures it (see :func:`ringing`). A quasi-static start
(``initial.deformation = "quasi-static"``) rings it too where the load varies: the start solves
the deformation with its rates zero and then sets the rates of the quasi-static motion, whose
loads (the Coriolis load 2 theta' w' of the bending rate on a turning bar) the run's axial force
N(0) carries and the dynamic bar's start does not (:func:`start_multipliers`). An arm whose angle
oscillates (sin(tau + 0.6), lambda 1e3, tip mass 0.5, mu 4): N(0) is 0.075 of its peak off the
start's; the dynamic bar rings about the stretch, the quasi-static run is 2.94 % of tip_u's peak
and 1.46 % of the torque's off it (0.031 % and 0.017 % at lambda 1e5), which this part charged 0;
now the window, and from a quasi-static start every output over the whole run with the axial
dynamics kept: 2.99 % and 1.47 % (``tests/test_axial_qs_start_ringing.py``). Its tip deflection is
0.60 % off too, and not from the ringing: started on the run's own stretch and its rate the
dynamic bar still differs by 0.59 % there (1/lambda: 6.7e-5 at 1e5; content at the bending
frequency, about 4 per unit tau, and the driver's harmonics): the whole run reads it (0.60 %);
its cause is not pinned (the stretch is not in the quasi-static bar's kinematics: the
transverse loads of the stretched bar are the likely one). Since, the start is consistent: it
solves the deformation again with its rates and accelerations held
(:func:`symgen.numerics.start.quasi_static_start`), the start's axial force jump is gone (~1e-16
of the peak) and the dynamic bar's axial ringing fell from 8.3e-3 to 7.9e-4 of tip_u's peak (3.9e-4
with the rates alone held); with the axial amplitudes' rates and accelerations taken along the
bending's held motion too (session 11) what is left, 0.47 % on tip_u, 0.42 % on the tip, 0.46 % on
the torque, is at the driver's harmonics: from a quasi-static start where the jump is below the
skip the whole run with the axial dynamics kept reads it (0.997x / 0.996x / 0.998x; at lambda 1e5
0.86x / 0.82x / 0.91x of 5.4e-5 / 5.1e-5 / 5.1e-5: docs/exact-bars.md, "The consistent start,
landed").

The stretch's own inertia (:func:`own_inertia`): the quasi-static stretch s = N/lambda balances
the axial loads of the inextensible motion alone; the dynamic bar's stretch also carries the
inertia of the stretch itself: its centrifugal load where the bar turns at w (rho w^2 s) and its
acceleration where the axial load varies at W (rho s''): to first order the dynamic amplification
1/(1 - r^2) - 1 ~ r^2, r = w (or W) over the first axial frequency. Measured from the model: at
each output sample the change dR of the model's residual (rows of the quasi-static bars' axial
amplitudes) when the amplitudes, rates and accelerations carry s, s', s'' (the rates by second
differences on the output grid; the run's accelerations likewise), the correction the dynamic
bar's stiffness lambda K gives it, ds = -K^-1 dR / lambda (K: the inextensibility rows'
Jacobian in the axial amplitudes, the dynamic bar's axial stiffness being lambda K), and each
output's change when it reads s + ds: its largest along the run over its peak. A steel arm
(lambda 1189) spun at a constant rate by an angle driver, started on its quasi-static deformation:
the tip's stretch is 3.36e-4 of itself short of the closed form (0.4/lambda), where the drift and
the ringing charge nothing; this part charges 3.35e-4 (0.997 x at lambda 1e3 to 1e6; at 1e8 0.997 x the closed form's
share, below the run's own solver error 2e-7 there; 0.999 x with a tip mass of half the arm's:
``tests/test_axial_own_inertia.py``). It reads only outputs of the
bar's shape (the stretch the quasi-static treatment adds to them); the stretch's inertia in the
joint forces and driver torques (the centrifugal force of the stretched mass, of relative order
s) is not charged here.

The part (:func:`estimate`) is the largest of the drift, the ringing and the stretch's own inertia
per output. All are measured once per run (:func:`parts`): ``effects.axial = "auto"`` decides on
them after the run (:mod:`symgen.numerics.axial_choice`), and the run's error estimate reads the
same numbers.

Not charged by the drift: the stretch's own rate f' + N'/lambda in T (of the order of the axial
force's rate over lambda).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen.ir.records import RowKind
from symgen.ir.names import bar_parameter
from symgen.numerics.run_result import MeasuredOnce
from symgen.scene.model import CHECK_KINDS, Simulation
from symgen.numerics.model_form import _mapped

if TYPE_CHECKING:
    from symgen.numerics.index1 import Partition
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import SimResult
    from symgen.scene.model import Scene

__all__ = [
    "KEY",
    "AxialNotEstimated",
    "AxialParts",
    "drift",
    "estimate",
    "keep_parts",
    "own_inertia",
    "parts",
    "quasi_static_bars",
    "ringing",
    "ringing_end",
    "run_rates",
    "start_multipliers",
    "stretch_inertia",
    "stretched",
]

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
        lam_name = bar_parameter("lambda", name).text
        if not rows or len(rows) != len(f_idx) or lam_name not in params:
            raise AxialNotEstimated(f"the quasi-static bar {name!r} has no multipliers matching its axial amplitudes")
        out[name] = (f_idx, rows, params.index(lam_name))
    return out


def stretched(mech: Mechanism, Q: np.ndarray, Lam: np.ndarray, bars: Bars) -> np.ndarray:
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
    return T, _kinetic(mech, tau, stretched(mech, Q, Lam, bars), V, Lam) - T


def _partition(mech: Mechanism, result: SimResult) -> Partition:
    return result.partition or mech.choose_partition(float(result.tau[0]), np.asarray(result.q[0]))


#: what a part says where no bar is axially quasi-static
NOTHING = "no bar has quasi-static axial dynamics: nothing to charge"


def _charged(mech: Mechanism, result: SimResult) -> tuple[list[str], Bars]:
    """The run's output names and the quasi-static axial bars a part charges; raises
    :class:`AxialNotEstimated` where the run's outputs are not the model's."""
    names = list(result.output_names)
    if names != list(mech.info.outputs):
        raise AxialNotEstimated("the run's outputs are not the model's output function's")
    return names, quasi_static_bars(mech)


def _sampled(result: SimResult, fewest: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """At most ``MAX_SAMPLES`` of the run's output samples, evenly spread: their indices, tau, q, v
    and multipliers. Raises :class:`AxialNotEstimated` where the run has fewer than ``fewest``."""
    tau = np.asarray(result.tau, dtype=float)
    if len(tau) < fewest:
        raise AxialNotEstimated(f"the run has fewer than {fewest} output samples")
    idx = np.unique(np.linspace(0, len(tau) - 1, min(len(tau), MAX_SAMPLES)).round().astype(int))
    Q, V, Lam = (np.asarray(x, dtype=float)[idx] for x in (result.q, result.v, result.lam))
    return idx, tau[idx], Q, V, Lam


def _peaks(result: SimResult) -> dict[str, float]:
    """Each output's largest |value| over the run; 0 where it is not finite or zero to round-off
    (:meth:`SimResult.peaks`: nothing charged)."""
    return {n: (p if np.isfinite(p) else 0.0) for n, p in result.peaks().items()}


def run_rates(result: SimResult) -> np.ndarray:
    """Each output's rate along the run (rows per output sample, columns per output): the time
    derivative of its recorded history, second-order differences on the run's output grid. A
    deflection reads the elastic amplitudes alone, but its history is forced by the free motion
    and shifts with it: its whole rate is what a lead moves it by (the rate along the free rigid
    coordinates with the amplitudes held is zero for it). An output whose first sample is the
    continuum's joint force (``SimResult.start_forces``) is differentiated from its second sample
    (its rate at the start taken as zero: the lead is zero there). Content faster than the output
    step is not seen: the rate is that of the samples the user reads."""
    tau = np.asarray(result.tau, dtype=float)
    Y = np.asarray(result.outputs, dtype=float)
    rates = np.zeros_like(Y)
    for k, n in enumerate(result.output_names):
        first = 1 if n in result.start_forces else 0
        if len(tau) - first >= 3:
            rates[first:, k] = np.gradient(Y[first:, k], tau[first:], edge_order=2)
        elif len(tau) - first == 2:
            rates[first:, k] = (Y[-1, k] - Y[first, k]) / (tau[-1] - tau[first])
    return rates


def drift(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """output -> the drift of the free motion the quasi-static axial treatment leaves out, as a
    fraction of the output's peak, and how (see the module docstring). Raises
    :class:`AxialNotEstimated` where it cannot be evaluated."""
    names, bars = _charged(mech, result)
    if not bars:
        return dict.fromkeys(names, 0.0), NOTHING
    part = _partition(mech, result)
    free = [i for i in part.ind if i in mech.rigid]
    listed = ", ".join(sorted(bars))
    if not free:
        return dict.fromkeys(names, 0.0), (
            f"the quasi-static axial bars ({listed}) change no prescribed motion: every rigid coordinate is driven"
        )
    idx, ts, Q, V, Lam = _sampled(result, 3)
    T, dT = stretch_inertia(mech, ts, Q, V, Lam, bars)
    rates = run_rates(result)[idx]
    if not np.all(np.isfinite(T)) or not np.all(np.isfinite(dT)):
        raise AxialNotEstimated("the kinetic energy is not finite along the run")
    moving = T > REST * max(float(np.max(np.abs(T))), 1e-300)
    share = np.where(moving, np.abs(dT) / np.where(moving, T, 1.0), 0.0)
    ahead = np.concatenate(([0.0], np.cumsum(0.5 * (share[1:] + share[:-1]) * np.diff(ts))))
    out: dict[str, float] = {}
    peaks = _peaks(result)
    for k, n in enumerate(names):
        peak = peaks[n]
        out[n] = float(np.max(np.abs(rates[:, k]) * ahead) / peak) if peak > 0.0 else 0.0
    how = (
        f"the phase drift of the free motion ({len(free)} free rigid coordinate(s)) with the stretch's inertia that "
        f"the quasi-static axial treatment of {listed} leaves out: the time the run is ahead, int dT/T "
        f"({float(ahead[-1]):.3g} tau at its end; largest dT/T {float(np.max(share)):.3g}), x each output's rate along the run; "
        f"lowered by {KEY}"
    )
    return out, how


# ---------------------------------------------------------------------- the stretch's own inertia
def _rates(tau: np.ndarray, X: np.ndarray) -> np.ndarray:
    """d/dtau of the rows of ``X`` (samples) on the grid ``tau``: second-order differences."""
    if len(tau) >= 3:
        return np.asarray(np.gradient(X, tau, axis=0, edge_order=2), dtype=float)
    if len(tau) == 2:
        return np.repeat((X[1:] - X[:1]) / (tau[1] - tau[0]), 2, axis=0)
    return np.zeros_like(X)


def own_inertia(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """output -> the error of the quasi-static stretch that misses its own inertia, as a fraction
    of the output's peak, and how (see the module docstring): at each output sample the stretch
    s = N/lambda of every quasi-static bar in its axial amplitudes, the change of the model's
    residual when the amplitudes, rates and accelerations carry s, s', s'' (dR: the inertia of the
    stretch, the centrifugal load of a spinning bar's stretch included), the correction
    ds = -K^-1 dR_f / lambda that the dynamic bar's stiffness lambda K (K: the bar's
    inextensibility rows in its axial amplitudes) gives it, and each output's change when it reads
    ds too. Raises :class:`AxialNotEstimated` where it cannot be evaluated."""
    names, bars = _charged(mech, result)
    if not bars:
        return dict.fromkeys(names, 0.0), NOTHING
    _, tau, Q, V, Lam = _sampled(result, 2)
    A = _rates(tau, V)
    S = np.zeros_like(Q)
    for f_idx, rows, k in bars.values():
        S[:, f_idx] = Lam[:, rows] / mech.p[k]
    Sd = _rates(tau, S)
    Sdd = _rates(tau, Sd)
    n = len(tau)
    R0 = _mapped(mech.f["res"], n, tau, Q, V, A, Lam, mech.p)[0].T
    R1 = _mapped(mech.f["res"], n, tau, Q + S, V + Sd, A + Sdd, Lam, mech.p)[0].T
    Jq = _mapped(mech.phi_q, n, tau, Q, V, A, Lam, mech.p)[0]  # (m, n * samples)
    Jq = Jq.reshape(Jq.shape[0], n, mech.n).transpose(1, 0, 2)  # per sample
    D = np.zeros_like(Q)
    for f_idx, rows, k in bars.values():
        K = Jq[:, rows][:, :, f_idx]
        dR = (R1 - R0)[:, f_idx]
        D[:, f_idx] = -np.linalg.solve(K, dR[..., None])[..., 0] / mech.p[k]
    if not np.all(np.isfinite(D)):
        raise AxialNotEstimated("the stretch's inertia is not finite along the run")
    out0 = _mapped(mech.f["out"], n, tau, Q, V, A, Lam, mech.p)[0].T
    out1 = _mapped(mech.f["out"], n, tau, Q + D, V, A, Lam, mech.p)[0].T
    change = np.abs(out1 - out0)
    first = {nm: 1 if nm in result.start_forces else 0 for nm in names}
    out: dict[str, float] = {}
    peaks = _peaks(result)
    for j, nm in enumerate(names):
        peak = peaks[nm]
        out[nm] = float(np.max(change[first[nm] :, j]) / peak) if peak > 0.0 else 0.0
    amp = [float(np.max(np.abs(D[:, f]))) / max(float(np.max(np.abs(S[:, f]))), 1e-300) for f, _, _ in bars.values()]
    how = (
        f"the stretch's own inertia that the quasi-static axial treatment of {', '.join(sorted(bars))} leaves out: "
        f"the model's residual with the stretch N/lambda and its rates (the stretch's inertia, its centrifugal load "
        f"included) over the bar's axial stiffness lambda K, {max(amp):.3g} of the stretch at most, read by each "
        f"output; lowered by {KEY}"
    )
    return out, how


# ---------------------------------------------------------------------- the start's ringing
#: the ringing's window: this many periods of the slowest quasi-static bar's first axial mode ...
RINGING_PERIODS = 5.0
#: ... or this many of its Kelvin-Voigt decay times 2 / (c w^2) where longer (light damping)
RINGING_DECAYS = 3.0
#: output samples per period of the fastest first axial mode in the window
RINGING_SAMPLES = 20
#: the window is doubled until the largest difference has crossed its mean this many times (two
#: periods of the ringing the window saw)
RINGING_CROSSINGS = 4
#: output kinds that read the axial force through the mechanism's levers (charged over the whole
#: run where the ringing lasts it)
RINGING_FORCE_KINDS = ("driver_torque", "reaction", "axial", "chord_elongation")
#: the whole run with the axial dynamics kept is not run for the force outputs beyond this many
#: periods of the stiffest bar's first axial mode (the stiff slider-crank, 250 periods: 58419 IDAS
#: steps, 0.5 s)
RINGING_WHOLE_PERIODS = 1000.0
#: the window is not made longer than this many output samples (an undamped stiff bar: the
#: amplitude of an undamped ringing is the same in every window)
RINGING_MAX_SAMPLES = 2000
#: the a-priori bound below which the window is not run: the start's axial force jump |N(0)| as
#: a fraction of its largest over the run, against this fraction of the accuracy
RINGING_SKIP = 0.1


#: the axial-dynamic models loaded in this process: (cache root, scene) -> the mechanism
_KEPT: dict[tuple[str, Any], Mechanism] = {}


def axial_dynamic_scene(scene: Scene, bars: list[str]) -> Scene:
    """``scene`` with the axial dynamics of ``bars`` kept: the auto rule's quasi-static bars through
    ``Scene.axial_kept`` (the model axial = "auto" would switch to: :mod:`symgen.numerics.axial_choice`),
    else (``effects.axial = "quasi_static"`` written) every bar dynamic."""
    if scene.effects.axial == "auto":
        reason = "the error estimate's start-ringing window keeps the axial dynamics"
        return replace(scene, axial_kept=(*scene.axial_kept, *((b, reason) for b in bars)))
    return replace(scene, effects=replace(scene.effects, axial="dynamic"))


def kept_mechanism(scene: Scene) -> Mechanism:
    from symgen import cache
    from symgen.numerics.mechanism import load_mechanism

    key = (str(cache.cache_root()), scene)
    try:
        hash(key)
    except TypeError:
        return load_mechanism(scene)
    if key not in _KEPT:
        _KEPT.clear()  # one model kept: a sweep estimates the same model's runs again
        _KEPT[key] = load_mechanism(scene)
    return _KEPT[key]


def ringing_window(mech: Mechanism, bars: Bars, t_run: float) -> tuple[float, float, str]:
    """(the window's length, its output step, how) in tau from the quasi-static bars' first axial
    modes w = (pi/2) sqrt(lambda) per unit tau: ``RINGING_PERIODS`` periods of the slowest, longer
    to ``RINGING_DECAYS`` decay times 2 / (c w^2) of Kelvin-Voigt damping c, at most the run;
    ``RINGING_SAMPLES`` samples per period of the fastest."""
    lams = [float(mech.p[k]) for _, _, k in bars.values()]
    w_slow, w_fast = (math.pi / 2) * math.sqrt(min(lams)), (math.pi / 2) * math.sqrt(max(lams))
    period = 2 * math.pi / w_slow
    c = float(mech.scene.effects.damping)
    decay = 2.0 / (c * w_slow**2) if c > 0 else math.inf
    step = 2 * math.pi / w_fast / RINGING_SAMPLES
    if c > 0 and RINGING_DECAYS * decay > RINGING_PERIODS * period:
        length, why = RINGING_DECAYS * decay, f"{RINGING_DECAYS:g} decay times 2/(c w^2) = {decay:.3g} tau"
    else:
        length, why = RINGING_PERIODS * period, f"{RINGING_PERIODS:g} periods of the first axial mode"
    length = min(length, t_run, RINGING_MAX_SAMPLES * step)
    return length, step, f"{why} (w {w_slow:.4g} per unit tau), {length:.3g} tau"


def _axial_periods(mech: Mechanism, bars: Bars, t_run: float) -> float:
    """The periods of the fastest quasi-static bar's first axial mode, (pi/2) sqrt(lambda) per unit
    tau, over ``t_run`` (the whole run with the axial dynamics kept is made up to
    ``RINGING_WHOLE_PERIODS``)."""
    lams = [float(mech.p[k]) for _, _, k in bars.values()]
    return t_run * (math.pi / 2) * math.sqrt(max(lams)) / (2 * math.pi)


def _whole_run(kept: Mechanism, tau: np.ndarray, sim: Simulation) -> SimResult:
    """The run again from its first output to its last, on its output grid and tolerances, with the
    axial dynamics kept (``kept``)."""
    from symgen.numerics.simulate import simulate

    return simulate(
        kept, t_end=float(tau[-1]), output_step=float(tau[1] - tau[0]), rtol=sim.rtol, atol=sim.atol, t0=float(tau[0])
    )


def start_multipliers(mech: Mechanism, result: SimResult) -> np.ndarray:
    """The multipliers the dynamic bar starts with, in the run's model: zero from an undeformed
    start; from a quasi-static start (``initial.deformation = "quasi-static"``,
    :func:`symgen.numerics.start.quasi_static_start`) those of the quasi-static state at the run's
    first sample with its deformation rates and accelerations held at the run's first sample's,
    as the start solves it: the axial loads of those rates (the Coriolis load 2 theta' w' of a
    bending rate on a turning bar) and accelerations are in them, as in the run's N(0)."""
    lam = np.asarray(result.lam, dtype=float)
    if not mech.scene.initial.quasi_static:
        return np.zeros(lam.shape[1])
    from symgen.numerics.start import quasi_static_state

    part = _partition(mech, result)
    q0, v0 = (np.asarray(x, dtype=float)[0] for x in (result.q, result.v))
    t0 = float(result.tau[0])
    a0 = mech.accelerations(t0, q0, v0)[0]
    return quasi_static_state(mech, t0, q0, v0, part, rates=v0, accels=a0)[2]


def ringing_bound(mech: Mechanism, result: SimResult, bars: Bars) -> float:
    """The a-priori bound of the start's ringing: the largest jump of a quasi-static bar's axial
    force at the start |N(0) - N_start| (the ringing's amplitude in the force; N_start: the force
    the dynamic bar starts with, :func:`start_multipliers`: 0 from an undeformed start) as a fraction of
    that force's largest over the run."""
    lam = np.asarray(result.lam, dtype=float)
    begin = start_multipliers(mech, result)
    worst = 0.0
    for _, rows, _ in bars.values():
        peak = float(np.max(np.abs(lam[:, rows])))
        if peak > 0:
            worst = max(worst, float(np.max(np.abs(lam[0, rows] - begin[rows]))) / peak)
    return worst


def ringing(mech: Mechanism, result: SimResult, enough: float = math.inf) -> tuple[dict[str, float], str]:
    """output -> the start's axial ringing the quasi-static treatment leaves out, as a fraction of
    the output's peak over the run, and how: a window from the start run with the quasi-static
    bars' axial dynamics kept and with the run's own model on the same fine output grid, the
    largest difference (the window: :func:`ringing_window`, doubled until that difference has
    crossed its mean ``RINGING_CROSSINGS`` times; where the ringing lasts the run, the force
    outputs ``RINGING_FORCE_KINDS`` over the whole run on its output grid, the levers that read the
    axial force turning). 0 where the start's axial force jump (:func:`ringing_bound`: from a
    quasi-static start, ``initial.deformation = "quasi-static"``, the loads of the deformation
    rates its equilibrium leaves out) is below ``RINGING_SKIP`` x the accuracy.

    ``enough``: a decision's threshold (:mod:`symgen.numerics.axial_choice`): where the window
    already shows more than it on some output, the whole run for the force outputs is not made
    (it could only raise them) and the values are lower bounds there, as the how says."""
    from symgen.numerics.simulate import simulate

    names = list(result.output_names)
    zero = dict.fromkeys(names, 0.0)
    bars = quasi_static_bars(mech)
    scene = mech.scene
    if not bars:
        return zero, "no bar has quasi-static axial dynamics"
    accuracy = float(scene.simulation.accuracy)
    bound = ringing_bound(mech, result, bars)
    qs_start = scene.initial.quasi_static
    jump = (
        "the quasi-static start's axial force (its equilibrium with the deformation rates held) is off the "
        f"run's N(0) by {bound:.2g} of its peak"
        if qs_start
        else f"the start is not on its quasi-static deformation; axial force jump {bound:.2g} of its peak"
    )
    tau = np.asarray(result.tau, dtype=float)
    sim = scene.simulation
    if bound < RINGING_SKIP * accuracy:
        skipped = f"{jump} (< {RINGING_SKIP:g} x simulation.accuracy): the start's ringing not run"
        if not qs_start or len(tau) < 2:
            return zero, skipped
        # a consistent quasi-static start rings little, but the quasi-static treatment still moves
        # every output over the run (the oscillating arm's 0.4-0.65 %, at the driver's harmonics):
        # the whole run with the axial dynamics kept reads it, as after a window
        periods = _axial_periods(mech, bars, float(tau[-1] - tau[0]))
        if periods > RINGING_WHOLE_PERIODS:
            return zero, (
                f"{skipped}; the whole run with the axial dynamics kept not made either: its {periods:.3g} "
                f"axial periods exceed {RINGING_WHOLE_PERIODS:g}"
            )
        whole = _whole_run(kept_mechanism(axial_dynamic_scene(scene, sorted(bars))), tau, sim)
        m = min(len(whole.tau), len(tau))
        out = dict(zero)
        kinds = {o.name: o.kind for o in scene.outputs}
        every = result.peaks()  # 0 where an output is zero to round-off
        for n in names:
            peak = every[n]
            ok = peak > 0 and np.isfinite(peak) and kinds.get(n) not in CHECK_KINDS
            # the first sample of a force output may be the continuum's in one run alone: from the second
            diff = np.abs(np.asarray(whole.column(n))[1:m] - np.asarray(result.column(n))[1:m])
            out[n] = float(diff.max()) / peak if ok and m > 1 else 0.0
        return out, (
            f"{skipped}; the whole run with the axial dynamics of {', '.join(sorted(bars))} kept against the run's "
            f"own model on its output grid ({whole.steps} IDAS steps), the largest difference"
        )
    if len(tau) < 2:
        raise AxialNotEstimated("the run has fewer than two output samples")
    t_run = float(tau[-1] - tau[0])
    length, step, window = ringing_window(mech, bars, t_run)
    kept = kept_mechanism(axial_dynamic_scene(scene, sorted(bars)))
    t0 = float(tau[0])
    every = result.peaks()  # 0 where an output is zero to round-off
    peaks = [every[n] for n in names]
    steps, doubled = 0, 0
    while True:
        own = simulate(mech, t_end=t0 + length, output_step=step, rtol=sim.rtol, atol=sim.atol, t0=t0)
        dyn = simulate(kept, t_end=t0 + length, output_step=step, rtol=sim.rtol, atol=sim.atol, t0=t0)
        steps += own.steps + dyn.steps
        k = min(len(own.tau), len(dyn.tau))
        signed = np.column_stack([dyn.column(n)[:k] - own.column(n)[:k] for n in names])
        diff = np.abs(signed)
        # the coupled axial mode (a bar carrying a mass rings slower than its own first mode): the
        # window is doubled until the largest difference (relative to its output's peak) has
        # crossed its mean RINGING_CROSSINGS times, i.e. the ringing has shown its amplitude (a
        # later growth of an undamped run's difference is the two models' phases drifting apart,
        # not the start's ringing: the paper's slider-crank)
        rel = [float(diff[:, j].max()) / p if p > 0 and np.isfinite(p) else 0.0 for j, p in enumerate(peaks)]
        worst = signed[:, int(np.argmax(rel))]
        crossings = int(np.count_nonzero(np.diff(np.sign(worst - worst.mean())) != 0))
        if crossings >= RINGING_CROSSINGS or length >= t_run or 2 * length > RINGING_MAX_SAMPLES * step:
            break
        length, doubled = min(2 * length, t_run), doubled + 1
    out = {
        n: (float(diff[:, j].max() / peaks[j]) if peaks[j] > 0 and np.isfinite(peaks[j]) else 0.0)
        for j, n in enumerate(names)
    }
    if doubled:
        window += f", doubled {doubled} x to {length:.3g} tau (until the largest difference crossed its mean {RINGING_CROSSINGS} times)"
    # an undamped ringing lasts the run, and the forces read the bar's axial force through the
    # mechanism's levers, which turn (a crank started at its dead centre: the driver torque's
    # ringing is 0.23 of its peak over the window, 2.4 over half a turn): for the force outputs the
    # whole run with the axial dynamics kept, on the run's own output grid
    c = float(scene.effects.damping)
    lams = [float(mech.p[k]) for _, _, k in bars.values()]
    decay = 2.0 / (c * (math.pi / 2) ** 2 * min(lams)) if c > 0 else math.inf
    kinds = {o.name: o.kind for o in scene.outputs}
    # from a quasi-static start every output over the whole run: the ringing is a small one about the
    # stretch, and what the whole run adds on a deflection is the same treatment's error (the stretch
    # left out of the kinematics moves the bending: the oscillating arm of docs/quasi-static-modes.md)
    forces = [
        n
        for j, n in enumerate(names)
        if (kinds.get(n) not in CHECK_KINDS if qs_start else kinds.get(n) in RINGING_FORCE_KINDS) and peaks[j] > 0
    ]
    which = "the outputs" if qs_start else "the force outputs"
    periods = _axial_periods(mech, bars, t_run)
    shown = max((v for n, v in out.items() if kinds.get(n) not in CHECK_KINDS), default=0.0)
    if forces and length < t_run and RINGING_DECAYS * decay > length and shown > enough:
        window += (
            f"; {which} ({', '.join(forces)}) over the window alone: it already shows {shown:.3g} of a "
            f"peak, above {enough:g} (the whole run is not made for a lower bound already enough to decide)"
        )
    elif forces and length < t_run and RINGING_DECAYS * decay > length and periods > RINGING_WHOLE_PERIODS:
        window += (
            f"; {which} ({', '.join(forces)}) over the window alone: the ringing lasts the run, whose "
            f"{periods:.3g} axial periods (> {RINGING_WHOLE_PERIODS:g}) the axial dynamics are not run through "
            "(a lower bound there)"
        )
    elif forces and length < t_run and RINGING_DECAYS * decay > length:
        whole = _whole_run(kept, tau, sim)
        steps += whole.steps
        m = min(len(whole.tau), len(tau))
        for n in forces:
            j = names.index(n)
            late = float(np.max(np.abs(whole.column(n)[:m] - result.column(n)[:m]))) / peaks[j]
            out[n] = max(out[n], late)
        window += (
            f"; {which} ({', '.join(forces)}) over the whole run on its output grid (the ringing "
            f"{'is undamped' if c == 0 else f'decays in {decay:.3g} tau'}: it lasts the run)"
        )
    how = (
        f"the start's axial ringing ({jump}): a window of {window} from the start run with the axial dynamics of "
        f"{', '.join(sorted(bars))} kept against the run's own model, {k} samples "
        f"({steps} IDAS steps in all), the largest difference"
    )
    return out, how


# ---------------------------------------------------------------------- the start's ringing's end
#: a damped start ringing ends the axial dynamics' phase (``Scene.axial_switch``) where the
#: difference between the runs with and without them stays below this share of the accuracy
#: (the switch is to cost the run little accuracy: at a quarter, the kept-out steel slider-crank
#: at 2400 rpm switched at tau 1.8 and its torque went from 1.8e-4 to 1.9e-3 of peak off its
#: converged reference, in as many IDAS steps: 10 466 against 11 098; at a tenth, with the charge
#: measured by the continued run, at tau 2.02 to 8.0e-4, estimated 1.33x) ...
SWITCH_SHARE = 0.1
#: ... for at least this many decay times (:func:`decay_time`) of the slowest bar's first axial
#: mode after it (a coupled mode slower than the bar's own shows there, where it lasts)
SWITCH_DECAYS = 3.0
#: the switch is made only where it leaves at least this share of the run quasi-static (the window
#: runs are made to at most this share of the run)
SWITCH_RUN_SHARE = 0.5


#: the window is not made longer than this many samples (the ringing does not end early then)
SWITCH_MAX_SAMPLES = 8000


def decay_time(c: float, w: float) -> float:
    """The time in which Kelvin-Voigt damping c decays a mode of frequency w by e: 2 / (c w^2)
    underdamped (c w < 2); overdamped, that of the slower root of s^2 + c w^2 s + w^2 (about c
    where c w >> 2: the stiffer the bar, the closer the decay to c itself)."""
    if c * w < 2:
        return 2.0 / (c * w * w)
    slow = 2 * w * w / (c * w * w + math.sqrt((c * w * w) ** 2 - 4 * w * w))  # without cancellation
    return 1.0 / slow


@dataclass(frozen=True)
class RingingEnd:
    """Where a damped start ringing has ended (:func:`ringing_end`): ``tau`` on the run's output
    grid, ``charge`` output -> the largest difference after it (fraction of the output's peak),
    ``how`` one sentence."""

    tau: float
    charge: dict[str, float]
    how: str


def ringing_end(mech: Mechanism, result: SimResult, level: float) -> RingingEnd | None:
    """Where the start's axial ringing of ``mech``'s quasi-static bars (Kelvin-Voigt damped) has
    ended: a window from the start run with their axial dynamics kept and with the run's own model
    (as :func:`ringing`'s), each output's difference as a fraction of its peak over ``result``;
    the first sample of the run's output grid after which every output's difference stays below
    ``level`` for at least ``SWITCH_DECAYS`` decay times to the window's end (the window doubled
    until it does, up to ``SWITCH_RUN_SHARE`` of the run). The charge: the run's own model
    continued from the kept run's state there against the kept run to the window's end. None
    without damping, without a quasi-static bar, where the ringing does not end within that share
    of the run, or where the charge exceeds ``level``."""
    from symgen.numerics.simulate import simulate

    scene = mech.scene
    c = float(scene.effects.damping)
    bars = quasi_static_bars(mech)
    tau = np.asarray(result.tau, dtype=float)
    if c <= 0 or not bars or len(tau) < 2:
        return None
    t0, h = float(tau[0]), float(tau[1] - tau[0])
    t_run = float(tau[-1] - t0)
    lams = [float(mech.p[k]) for _, _, k in bars.values()]
    w_slow, w_fast = (math.pi / 2) * math.sqrt(min(lams)), (math.pi / 2) * math.sqrt(max(lams))
    decay = decay_time(c, w_slow)
    # an underdamped ringing sampled along its period, an overdamped one along its decay
    step = min(h, 2 * math.pi / w_fast / RINGING_SAMPLES if c * w_fast < 2 else decay / RINGING_SAMPLES)
    step = h / math.ceil(h / step - 1e-9)  # the run's outputs on the window's grid (the switch among them)
    names = list(result.output_names)
    kinds = {o.name: o.kind for o in scene.outputs}
    every = result.peaks()
    read = [(j, n, every[n]) for j, n in enumerate(names) if every[n] > 0 and kinds.get(n) not in CHECK_KINDS]
    if not read:
        return None
    kept = kept_mechanism(axial_dynamic_scene(scene, sorted(bars)))
    sim = scene.simulation
    cap = SWITCH_RUN_SHARE * t_run
    length = min(cap, decay * (math.log(1.0 / level) + SWITCH_DECAYS))
    steps = 0
    while True:
        own = simulate(mech, t_end=t0 + length, output_step=step, rtol=sim.rtol, atol=sim.atol, t0=t0)
        dyn = simulate(kept, t_end=t0 + length, output_step=step, rtol=sim.rtol, atol=sim.atol, t0=t0)
        steps += own.steps + dyn.steps
        k = min(len(own.tau), len(dyn.tau))
        t = np.asarray(own.tau[:k], dtype=float)
        # the first sample of a force output may be the continuum's in one run alone: from the second
        rel = np.column_stack(
            [np.abs(dyn.column(n)[1:k] - own.column(n)[1:k]) / p for _, n, p in read]
        )  # (k - 1, outputs)
        above = np.flatnonzero(rel.max(axis=1) > level)  # rel's row i is the sample t[i + 1]
        settled = float(t[min(2 + above[-1], k - 1)]) if len(above) else t0
        if float(t[k - 1]) - settled >= SWITCH_DECAYS * decay:
            break
        if length >= cap or 2 * length > SWITCH_MAX_SAMPLES * step:
            return None
        length = min(2 * length, cap)
    # on the run's output grid, at or after the ringing's end, after one output step at least (an
    # overdamped ringing may end before the first output: the kept model runs that step)
    switch = t0 + max(1, math.ceil((settled - t0) / h - 1e-9)) * h
    at = int(np.argmin(np.abs(t - switch)))  # the window's sample of the switch
    if switch >= t0 + cap or abs(float(t[at]) - switch) > 1e-9 * h or at >= k - 1:
        return None
    # what the switch leaves out, measured: the run's own model continued from the kept run's state
    # at the switch, against the kept run, to the window's end (against the run's own model from
    # the start, the difference would also carry the ringing's past effect on the motion, which
    # the continued run keeps: 7x high on the steel slider-crank's rod_mid)
    from symgen.numerics.start import continued_start

    state = continued_start(mech, switch, dyn.q[at], dyn.v[at])
    cont = simulate(
        mech, t_end=float(t[k - 1]), output_step=step, rtol=sim.rtol, atol=sim.atol, t0=switch, initial=state
    )
    steps += cont.steps
    m = min(len(cont.tau), k - at)
    charge = dict.fromkeys(names, 0.0)
    for _, n, p in read:
        # from the second sample: the first's force outputs may be the continuum's in one run alone
        charge[n] = float(np.abs(dyn.column(n)[at + 1 : at + m] - cont.column(n)[1:m]).max()) / p if m > 1 else 0.0
    how = (
        f"the start's axial ringing (Kelvin-Voigt {c:g}, its decay time {decay:.3g} tau at w {w_slow:.4g}): "
        f"a window of {float(t[k - 1]) - t0:.3g} tau from the start run with the axial dynamics of "
        f"{', '.join(sorted(bars))} kept against the run's own model: every output within "
        f"{level:.3g} of its peak from tau {settled - t0:.4g} on; the run's own model continued from the kept "
        f"run's state at tau {switch - t0:.6g} against the kept run to the window's end ({steps} IDAS steps in all)"
    )
    if max(charge.values(), default=0.0) > level:
        return None
    return RingingEnd(switch, charge, how)


@dataclass(frozen=True)
class AxialParts:
    """The three measures of one run (output -> fraction of its peak, and how): the free motion's
    phase drift (:func:`drift`), the start's ringing (:func:`ringing`; empty where its window
    failed, ``ringing_how`` saying why) and the stretch's own inertia (:func:`own_inertia`). ``complete``: False where the ringing's force outputs
    are lower bounds (measured against a decision's threshold and above it)."""

    drift: dict[str, float]
    drift_how: str
    ringing: dict[str, float]
    ringing_how: str
    complete: bool = True
    own: dict[str, float] = field(default_factory=dict)
    own_how: str = ""


#: a run's parts measured for a decision that kept the run, for its error estimate to read once:
#: the windows are run once per run
_KEPT_PARTS: MeasuredOnce[AxialParts] = MeasuredOnce()


def keep_parts(mech: Mechanism, result: SimResult, found: AxialParts) -> None:
    """Keep the complete ``found`` of this run for its error estimate (:func:`parts` reads it
    once); the previous one is dropped."""
    if found.complete:
        _KEPT_PARTS.keep(mech, result, found)
    else:
        _KEPT_PARTS.drop()


def parts(mech: Mechanism, result: SimResult, enough: float = math.inf) -> AxialParts:
    """The drift and the ringing of ``result`` (a run of ``mech``); those :func:`keep_parts` kept
    for this very run are read instead (once). ``enough``: a decision's threshold (see
    :func:`ringing`). Raises :class:`AxialNotEstimated` where the drift cannot be evaluated; a
    failed ringing window leaves the ringing empty and says why."""
    from symgen.errors import SymgenError

    known = _KEPT_PARTS.take(mech, result)
    if known is not None:
        return known
    slow, slow_how = drift(mech, result)
    own, own_how = own_inertia(mech, result)
    try:
        ring, ring_how = ringing(mech, result, enough)
    except (SymgenError, ValueError, ArithmeticError, RuntimeError) as why:  # RuntimeError: CasADi's
        # the window's runs (or the axial-dynamic model) failed: the drift alone, said as such
        ring, ring_how = (
            {},
            f"not estimated (the window with the axial dynamics kept failed: {type(why).__name__}: {why})",
        )
    kinds = {o.name: o.kind for o in mech.scene.outputs}
    shown = max((v for n, v in ring.items() if kinds.get(n) not in CHECK_KINDS), default=0.0)
    return AxialParts(slow, slow_how, ring, ring_how, complete=shown <= enough, own=own, own_how=own_how)


def estimate(mech: Mechanism, result: SimResult) -> tuple[dict[str, float], str]:
    """The axial part: output -> the largest of the free motion's phase drift (:func:`drift`), the
    start's ringing (:func:`ringing`) and the stretch's own inertia (:func:`own_inertia`) the
    quasi-static axial treatment leaves out, as a fraction of the output's peak, and how (each,
    and which is the largest on which outputs). Raises :class:`AxialNotEstimated` where the drift
    or the stretch's inertia cannot be evaluated.

    A run that switched to the quasi-static treatment after its damped start ringing
    (``Scene.axial_switch``; the run's stats say where) is charged what the decision measured:
    each output the larger of the continued run's difference after the switch
    (:func:`ringing_end`) and the quasi-static run's drift and the stretch's own inertia."""
    switch = mech.scene.axial_switch
    at = result.stats.get("axial_switch")
    if switch is not None and isinstance(at, float):
        charge = dict(switch.charge)
        bars = ", ".join(b for b, _ in mech.scene.axial_kept)
        return {n: float(charge.get(n, 0.0)) for n in result.output_names}, (
            f"the axial dynamics of {bars} kept until tau {at:.6g}, quasi-static after it: {switch.how}; each "
            "output charged the larger of that difference after the switch and the quasi-static run's phase drift "
            "and the stretch's own inertia, as the decision measured them"
        )
    both = parts(mech, result)
    measures = {"drift": both.drift, "ringing": both.ringing, "own": both.own}
    out = {n: max(m.get(n, 0.0) for m in measures.values()) for n in both.drift}
    # the measure that gives each output its value (the drift where none is larger)
    larger: dict[str, list[str]] = {"ringing": [], "own": []}
    for n, v in out.items():
        if v > both.drift.get(n, 0.0):
            larger["ringing" if both.ringing.get(n, 0.0) == v else "own"].append(n)
    ringing_how = f"the start's ringing: {both.ringing_how}"
    own_how = both.own_how or "the stretch's own inertia: not measured"
    if not larger["ringing"] and not larger["own"]:
        return out, f"{both.drift_how}; {own_how} (not larger on any output); {ringing_how} (not larger on any output)"
    lead = "; ".join(
        f"{what} on {', '.join(sorted(larger[k]))}"
        for k, what in (("ringing", "the start's ringing"), ("own", "the stretch's own inertia"))
        if larger[k]
    )
    text = f"{lead} (the larger there; the phase drift on the others): {ringing_how}; {own_how}; the drift: {both.drift_how}"
    if larger["ringing"] and mech.scene.initial.quasi_static:
        text += f"; lowered by {KEY}"
    elif larger["ringing"]:
        text += f'; lowered by {KEY} or initial.deformation = "quasi-static"'
    return out, text
