"""Which effects a scene calls for: ``symgen effects SCENE [--measure] [--auto TOL -o OUT.toml]``.

Every switch of ``[effects]`` removes its terms from the derivation (never generated), so a
scene that does not need an effect runs faster without it. This module says which ones it needs:

* **estimate** (always): each effect's relative contribution to the bars' deformation response,
  from the dimensionless groups of every elastic bar (the largest over the bars), with
  Omega = the driver's rate (1 without one), the characteristic inertial load Omega^2 per unit
  length (in the bar's own units m l omega^2) and the first bending frequency w_b:

  =====================  ==========================================  ==========================
  change                 estimate                                     why
  =====================  ==========================================  ==========================
  axial -> inextensible  max((2 Omega / pi)^2, N0) / lambda           dynamic axial amplification
                         1 if an output reads the bar's stretch       and static strain dropped;
                         share of the stretch in an elastic           stretch outputs are lost
                         displacement output; in a loop, the bar's
                         axial compliance against the most compliant
                         bending of the other bars
  axial off              max(sigma, inextensible estimate)            also drops the axial force
  transverse off         1 (every deflection output is lost)          eta0 = c Omega^2 / mu shown
  geometric stiffening   sigma = N0 / N_Euler                         axial force / Euler load
  Coriolis off           max(2 N0 / lambda, 4 sigma eta0)             2 theta' zeta', 2 theta' eta'
  rotary inertia off     pi^2 mu / lambda                             (r_g / l)^2 of mode 1
  strain -> linear       sigma min(1, lambda pi^2 eta0^2 / (4 N0))    chord shortening of bending
                         (without sigma when an output reads the      (the stretch output carries
                         stretch; geometric stiffening likewise)      the foreshortening)
  gravity off            |g| / (Omega^2 alpha)                        weight / inertial load
  damping off            1 - exp(-c w_b^2 T / 2)                      bending decay over the run
  =====================  ==========================================  ==========================

  with N0 = Omega^2 / 2 (the centrifugal force of the bar's own mass at mid-length),
  N_Euler = pi^2 mu (pinned frame) or pi^2 mu / 4 (cantilever), eta0 the static deflection under
  the load Omega^2 (5/384 Omega^2/mu pinned, Omega^2/(8 mu) cantilever) and T the run's length.
  They are orders of magnitude: ``--measure`` gives the real numbers.

* **measure** (``--measure``): short runs (``--cycles``, default one crank turn, at most the
  scene's run) of the scene as it is and with each change; the error of a change is the largest
  over the scene's outputs (``closure_residual`` left out) of the low-passed early-window error
  of ``symgen study`` (``symgen.apps.study.window_error``: the axial ringing above 50 cycles per
  turn is filtered, outputs oversampled so that it does not alias), relative to each output's
  peak; with the IDAS steps and integration time of each run.

* **auto** (``--auto TOL``): the smallest effect set whose outputs stay within TOL of the full
  model. Changes are tried greedily, those with the smallest measured error first (for the axial
  switch "off" before "inextensible"); each is kept only if a run of the accumulated set stays
  within TOL, so the final set is verified by its own run. The scene, with the chosen
  ``[effects]``, is written as TOML.

>>> from symgen.apps.effects import estimate_effects            # doctest: +SKIP
>>> rows = estimate_effects(load_scene("examples/slider_crank.toml"))
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Sequence

import numpy as np

from symgen.errors import Interrupted, SceneError, SymgenError
from symgen.outputs import atomic_write
from symgen.model.structure import axial_treatments, loop_stretch_share
from symgen.scene.quasi import quasi_static_reasons
from symgen.numerics import interrupt
from symgen.scene import load_scene
from symgen.scene.summary import describe_basis, describe_tolerances
from symgen.scene.loader import read_toml
from symgen.scene.overrides import apply_overrides

DEFAULT_TOL = 1e-3


@dataclass(frozen=True)
class Change:
    """One way of pruning an effect: ``key`` (also the table's label), the ``[effects]`` key it
    changes, its override and its group (options of one switch exclude each other)."""

    key: str
    effect: str
    override: str
    group: str
    why: str


CHANGES = (
    Change(
        "axial -> inextensible",
        "axial",
        "effects.axial=inextensible",
        "axial",
        "dynamic axial amplification (2 Omega/pi)^2/lambda, static strain N0/lambda",
    ),
    Change(
        "axial off",
        "axial",
        "effects.axial=false",
        "axial",
        "drops the axial force and its stiffening: sigma = N0/N_Euler",
    ),
    Change(
        "transverse off",
        "transverse",
        "effects.transverse=false",
        "transverse",
        "drops every deflection (static eta0 shown)",
    ),
    Change(
        "geometric stiffening off",
        "geometric_stiffening",
        "effects.geometric_stiffening=false",
        "geometric_stiffening",
        "axial force / Euler load sigma",
    ),
    Change(
        "Coriolis off",
        "coriolis",
        "effects.coriolis=false",
        "coriolis",
        "2 theta' zeta' and 2 theta' eta' terms: 2 N0/lambda, 4 sigma eta0",
    ),
    Change(
        "rotary inertia off",
        "rotary_inertia",
        "effects.rotary_inertia=false",
        "rotary_inertia",
        "(r_g/l)^2 pi^2 = pi^2 mu/lambda",
    ),
    Change(
        "strain -> linear",
        "strain",
        "effects.strain=linear",
        "strain",
        "chord shortening of bending vs axial strain, times sigma",
    ),
    Change("gravity off", "gravity", "effects.gravity=[0.0, 0.0]", "gravity", "|g| / (Omega^2 alpha)"),
    Change("damping off", "damping", "effects.damping=0.0", "damping", "1 - exp(-c w_b^2 T/2)"),
)


def applicable(scene) -> list[Change]:
    """The changes that remove something this scene has."""
    e = scene.effects
    dynamic = any(t.treatment == "dynamic" for t in axial_treatments(scene).values())
    on = {
        "axial -> inextensible": dynamic,
        "axial off": e.axial is not False,
        "transverse off": e.transverse,
        "geometric stiffening off": e.geometric_stiffening,
        "Coriolis off": e.coriolis,
        "rotary inertia off": e.rotary_inertia,
        "strain -> linear": e.strain == "von_karman",
        "gravity off": any(g != 0 for g in e.gravity),
        "damping off": e.damping > 0,
    }
    elastic = any(not b.rigid and (b.axial_modes or b.transverse_modes) for b in scene.bodies)
    return [c for c in CHANGES if on[c.key] and (elastic or c.group == "gravity")]


@dataclass
class EffectRow:
    change: Change
    estimate: float
    detail: str  # the groups behind the estimate (worst bar)
    error: float | None = None  # measured (--measure): the worst output's
    worst: str = ""  # ... name
    steps: int | None = None
    simulate_s: float | None = None
    status: str = ""
    recommendation: str = ""


@dataclass
class EffectsReport:
    scene: str
    tol: float
    rows: list
    reference: dict = field(default_factory=dict)  # steps, simulate_s, window of the measure runs
    auto: dict = field(default_factory=dict)  # chosen overrides, verified error, file
    stopped: str = ""  # "interrupted by SIGINT ..." of a partial report
    axial: dict = field(default_factory=dict)  # bar -> (treatment, reason) of effects.axial
    bases: dict = field(default_factory=dict)  # bar -> its BasisChoice (counts, chosen or stated, and why)
    quasi: dict = field(default_factory=dict)  # bar -> (quasi-static transverse functions, why)
    strain: tuple[str, str] = ("", "")  # (effects.strain used, why: symgen.scene.strain)
    estimate: Any = None  # --measure: the ErrorEstimate of the scene's own measuring run
    tolerances: str = ""  # the integrators' tolerances of the runs and why (symgen.scene.summary)


# --------------------------------------------------------------------------- estimates
def _rate(scene) -> float:
    rate = max((abs(d.rate) for d in scene.drivers), default=0.0)  # the fastest driver
    return rate if rate > 0 else 1.0


#: Output kinds that read a bar's stretch (lost without axial deformation).
STRETCH_OUTPUTS = ("chord_elongation", "axial")


def _loop_stretch_share(scene, body) -> tuple[float, str]:
    """In a closed loop the stretch of ``body`` under the joint forces moves the other bars as
    much as their bending does under the same forces: the share of the axial compliance of this
    bar against the most compliant bending of another elastic bar of the mechanism
    (:func:`symgen.model.structure.loop_stretch_share`, which "auto" uses too)."""
    share, soft = loop_stretch_share(scene, body)
    if not soft:
        return 0.0, ""
    return share, f"loop: stretch of {body.name} vs bending of {soft} {share:.2g}; "


def _bar_estimates(scene, body, outputs: Sequence[str] | None = None) -> dict:
    W = _rate(scene)
    lam, mu, alpha = body.lam, body.mu, body.alpha
    cantilever = body.frame == "cantilever"
    n0 = W**2 / 2
    eff = scene.effects
    out = {}
    if mu:
        eta0 = (1 / 8 if cantilever else 5 / 384) * W**2 / mu
        euler = math.pi**2 * mu / (4 if cantilever else 1)
        sigma = n0 / euler
        w_b = (1.875**2 if cantilever else math.pi**2) * math.sqrt(mu)
    else:
        eta0 = sigma = w_b = 0.0
    has_axial = body.axial_modes > 0 and lam
    outs = [o for o in scene.outputs if o.body == body.name and (outputs is None or o.name in outputs)]
    reads_stretch = [o.name for o in outs if o.kind in STRETCH_OUTPUTS]
    reads_displacement = [o.name for o in outs if o.kind == "elastic_displacement"]
    detail = f"{body.name}: lambda {lam:.3g}, " if lam else f"{body.name}: "
    detail += f"mu {mu:.3g}, " if mu else ""
    # foreshortening 1/2 int eta'^2 ~ pi^2 eta0^2 / 4 against the stretch N0 / lambda
    foreshortening = min(1.0, lam * math.pi**2 * eta0**2 / (4 * n0)) if (has_axial and mu) else 0.0
    if has_axial and reads_stretch:
        # an output that reads the stretch is the stretch: without axial deformation it is lost
        inext = 1.0
        inext_detail = detail + f"output {reads_stretch[0]} reads the stretch, which the inextensible model lacks"
    else:
        inext = max((2 * W / math.pi) ** 2, n0) / lam if has_axial else 0.0
        inext_detail = detail + f"(2 Omega/pi)^2/lambda, N0/lambda = {inext:.2g}"
        if has_axial and reads_displacement:
            share = (n0 / lam) / (n0 / lam + eta0)
            if share > inext:
                inext = share
                inext_detail = detail + f"stretch share of {reads_displacement[0]}: {share:.2g}"
        loop, loop_detail = _loop_stretch_share(scene, body) if has_axial else (0.0, "")
        if loop > inext:
            inext, inext_detail = loop, detail + loop_detail.rstrip("; ")
    out["axial -> inextensible"] = (inext, inext_detail)
    out["axial off"] = (
        max(sigma, inext) if has_axial else 0.0,
        (inext_detail if inext >= sigma else detail + f"sigma = N0/N_Euler = {sigma:.2g}"),
    )
    out["transverse off"] = (
        1.0 if mu and body.transverse_modes else 0.0,
        detail + f"static deflection eta0 = {eta0:.2g} of its length",
    )
    if has_axial and reads_stretch:
        # the stretch output carries the foreshortening that the axial-transverse coupling makes
        stiff = max(sigma, foreshortening)
        out["geometric stiffening off"] = (
            stiff,
            detail + f"foreshortening in {reads_stretch[0]}: lambda pi^2 eta0^2/(4 N0) = {foreshortening:.2g}",
        )
        out["strain -> linear"] = (
            foreshortening,
            detail + f"foreshortening in {reads_stretch[0]}: lambda pi^2 eta0^2/(4 N0) = {foreshortening:.2g}",
        )
    else:
        out["geometric stiffening off"] = (sigma if has_axial else 0.0, detail + f"sigma = {sigma:.2g}")
        lin = sigma * foreshortening
        out["strain -> linear"] = (lin, detail + f"sigma x min(1, lambda pi^2 eta0^2/(4 N0)) = {lin:.2g}")
    cor = max(2 * n0 / lam if has_axial else 0.0, 4 * sigma * eta0)
    out["Coriolis off"] = (cor, detail + f"2 N0/lambda, 4 sigma eta0 = {cor:.2g}")
    rot = math.pi**2 * mu / lam if (mu and lam) else 0.0
    out["rotary inertia off"] = (rot, detail + f"pi^2 mu/lambda = {rot:.2g}")
    g = math.hypot(*eff.gravity)
    grav = g / (W**2 * alpha)
    out["gravity off"] = (grav, f"{body.name}: |g| {g:.3g}, alpha {alpha:.3g}: {grav:.2g}")
    T = scene.simulation.t_end
    damp = 1 - math.exp(-eff.damping * w_b**2 * T / 2) if w_b else 0.0
    out["damping off"] = (damp, detail + f"c {eff.damping:.3g}, w_b {w_b:.3g}, T {T:.3g}: {damp:.2g}")
    return out


def estimate_effects(scene, tol: float = DEFAULT_TOL, outputs: Sequence[str] | None = None) -> EffectsReport:
    """Estimated contribution of every applicable change (largest over the elastic bars) to the
    scene's outputs (or to ``outputs``, names, when given)."""
    if outputs is not None:
        unknown = [n for n in outputs if n not in {o.name for o in scene.outputs}]
        if unknown:
            raise SceneError(
                str(scene.path),
                "--outputs",
                f"no output named {', '.join(unknown)}",
                f"the scene's outputs: {', '.join(o.name for o in scene.outputs)}",
            )
    rows = []
    bars = [b for b in scene.bodies if not b.rigid and (b.axial_modes or b.transverse_modes)]
    per_bar = [_bar_estimates(scene, b, outputs) for b in bars]
    for change in applicable(scene):
        if change.group == "gravity" and not per_bar:
            g = math.hypot(*scene.effects.gravity)
            rows.append(EffectRow(change, 1.0, f"rigid mechanism: |g| {g:.3g} moves it"))
            continue
        value, detail = max((pb[change.key] for pb in per_bar), key=lambda x: x[0])
        rows.append(EffectRow(change, value, detail))
    report = EffectsReport(
        scene=str(scene.path),
        tol=tol,
        rows=rows,
        axial={n: (t.treatment, t.reason) for n, t in axial_treatments(scene).items()},
        bases={c.bar: c for c in scene.bases},
        quasi=quasi_static_reasons(scene),
        strain=(scene.effects.strain, scene.strain_choice.reason if scene.strain_choice else "as the scene says"),
        tolerances=describe_tolerances(scene.simulation),
    )
    recommend(report)
    return report


def recommend(report: EffectsReport) -> None:
    """Keep an effect whose (measured, else estimated) contribution reaches the tolerance."""
    for row in report.rows:
        value = row.error if row.error is not None else row.estimate
        basis = "measured" if row.error is not None else "estimated"
        if row.status.startswith("failed"):
            row.recommendation = "keep (the run without it failed)"
        elif value < report.tol:
            row.recommendation = f"prune: {basis} {value:.1e} < tol {report.tol:g}"
        else:
            row.recommendation = f"keep: {basis} {value:.1e} >= tol {report.tol:g}"


# --------------------------------------------------------------------------- measured
def _window(scene, cycles: float | None) -> float:
    d = scene.turning_driver
    turn = 2 * math.pi / abs(d.rate) if d is not None else 2 * math.pi
    length = turn * (1.0 if cycles is None else cycles)
    return min(length, scene.simulation.t_end)


class _Runs:
    """Short runs of the scene with extra overrides, compared with the reference run."""

    def __init__(
        self,
        path: str,
        overrides: Sequence[str],
        cycles: float | None,
        outputs: Sequence[str] | None = None,
        solver: str = "idas",
    ) -> None:
        from symgen.apps.study import DEFAULT_CUTOFF, oversampling
        from symgen.numerics.solvers import check_solver

        self.path, self.overrides, self.solver = path, list(overrides), check_solver(solver)
        scene = load_scene(path, self.overrides)
        self.t_end = _window(scene, cycles)
        d = scene.turning_driver
        turn = 2 * math.pi / abs(d.rate) if d is not None else 2 * math.pi
        self.cutoff = DEFAULT_CUTOFF / turn
        n_axial = max([b.axial_modes for b in scene.bodies if not b.rigid] or [0])
        self.step = scene.simulation.output_step / oversampling(scene, n_axial, self.cutoff)
        self.compared = [o.name for o in scene.outputs if o.kind != "closure_residual"]
        if outputs:
            unknown = [n for n in outputs if n not in self.compared]
            if unknown:
                raise SceneError(
                    path,
                    "--outputs",
                    f"no compared output named {', '.join(unknown)}",
                    f"the scene's outputs: {', '.join(self.compared)}",
                )
            self.compared = list(outputs)
        self.ref = self.run(())
        if self.ref["status"] != "ok":
            raise SymgenError(f"the scene itself does not run over the measuring window: {self.ref['status']}")

    def run(self, extra: Sequence[str]) -> dict:
        from symgen.numerics.csolver import run
        from symgen.numerics.mechanism import load_mechanism

        out: dict[str, Any] = {
            "status": "ok",
            "steps": None,
            "simulate_s": None,
            "error": None,
            "worst": "",
            "res": None,
        }
        try:
            mech = load_mechanism(self.path, [*self.overrides, *extra])
            res = run(mech, self.solver, t_end=self.t_end, output_step=self.step)
        except SymgenError as err:
            interrupt.check()  # a failure while SIGINT/SIGTERM is pending is the interrupt
            out["status"] = f"failed: {err}"
            return out
        out.update(steps=res.steps, simulate_s=res.simulate_s, res=res)
        if hasattr(self, "ref"):
            out["error"], out["worst"] = self.error(res)
        return out

    def error(self, res) -> tuple[float, str]:
        """Largest window error over the compared outputs, and that output's name."""
        from symgen.apps.study import window_error

        ref = self.ref["res"]
        n = min(len(res.tau), len(ref.tau))
        worst, name_w = 0.0, ""
        for name in self.compared:
            y, r = res.column(name)[:n], ref.column(name)[:n]
            if not np.abs(r).max() > 0:
                continue
            e = window_error(y, r, self.step, self.cutoff, n)
            if e >= worst:
                worst, name_w = e, name
        return worst, name_w


def measure_effects(
    path: str,
    overrides: Sequence[str] = (),
    *,
    tol: float = DEFAULT_TOL,
    cycles: float | None = None,
    outputs: Sequence[str] | None = None,
    runs: _Runs | None = None,
    solver: str = "idas",
) -> EffectsReport:
    """The estimates plus short runs with and without each effect (errors over ``outputs``,
    default every output but closure residuals; ``solver``: "idas" or "c", the runs' integrator)."""
    runs = runs or _Runs(str(path), overrides, cycles, outputs, solver)
    report = estimate_effects(load_scene(path, overrides), tol, runs.compared)
    report.reference = {
        "steps": runs.ref["steps"],
        "simulate_s": runs.ref["simulate_s"],
        "t_end": runs.t_end,
        "output_step": runs.step,
        "outputs": list(runs.compared),
        "solver": solver,
    }
    res = runs.ref.get("res")
    report.estimate = None if res is None else _estimate(str(path), overrides, res)
    from symgen.progress import progress_bar

    try:
        with progress_bar(len(report.rows), "effects --measure") as bar:
            for row in report.rows:
                interrupt.check()
                r = runs.run([row.change.override])
                row.error, row.steps, row.simulate_s, row.status = r["error"], r["steps"], r["simulate_s"], r["status"]
                row.worst = r["worst"]
                bar.update(1)
    except BaseException as err:
        # the rows measured so far: a partial report, its other rows marked not measured (any
        # failure while a signal is pending is the interrupt: CasADi reports it as its own error)
        stop = interrupt.interrupted(err)
        if not isinstance(stop, Interrupted):
            raise
        for row in report.rows:
            if not row.status:
                row.status = "not measured (interrupted)"
        report.stopped = str(stop)
        recommend(report)
        stop.partial = report
        if stop is err:
            raise
        raise stop from None
    recommend(report)
    return report


def _estimate(path: str, overrides: Sequence[str], res) -> Any:
    """The error estimate of the scene's own measuring run (``symgen.numerics.error_estimate``):
    how far the scene as it is stands from more functions per bar (and its tolerances)."""
    from symgen.numerics.error_estimate import estimate_errors
    from symgen.numerics.mechanism import load_mechanism

    mech = load_mechanism(path, overrides)
    rtol, atol = mech.scene.simulation.tolerances("c" if res.stats.get("backend") == "c" else "idas")  # the run's
    return estimate_errors(mech, res, rtol, atol)


def auto_effects(
    path: str,
    overrides: Sequence[str] = (),
    *,
    tol: float,
    output: str | Path,
    cycles: float | None = None,
    outputs: Sequence[str] | None = None,
    solver: str = "idas",
) -> EffectsReport:
    """Greedy smallest effect set within ``tol`` of the full model, verified by a run; writes
    the scene with those effects to ``output`` (TOML)."""
    runs = _Runs(str(path), overrides, cycles, outputs, solver)
    report = measure_effects(path, overrides, tol=tol, cycles=cycles, runs=runs)
    ok = [r for r in report.rows if r.status == "ok" and r.error is not None and r.error <= tol]
    groups: dict[str, list] = {}
    for row in sorted(ok, key=lambda r: r.error):
        groups.setdefault(row.change.group, []).append(row)
    for rows in groups.values():  # the switch's most aggressive option first
        rows.sort(key=lambda r: [c.key for c in CHANGES].index(r.change.key) * (-1 if r.change.group == "axial" else 1))
    chosen: list[Change] = []
    verified = {"error": 0.0, "steps": runs.ref["steps"], "simulate_s": runs.ref["simulate_s"]}
    tried = []
    for group in sorted(groups, key=lambda g: min(r.error for r in groups[g])):
        for row in groups[group]:
            trial = chosen + [row.change]
            r = (
                runs.run([c.override for c in trial])
                if len(trial) > 1
                else {"status": row.status, "error": row.error, "steps": row.steps, "simulate_s": row.simulate_s}
            )
            tried.append({"set": [c.key for c in trial], "error": r["error"], "status": r["status"]})
            if r["status"] == "ok" and r["error"] <= tol:
                chosen = trial
                verified = {"error": r["error"], "steps": r["steps"], "simulate_s": r["simulate_s"]}
                break
    raw = apply_overrides(read_toml(str(path)), [*overrides, *[c.override for c in chosen]], str(path))
    header = (
        f"written by `symgen effects --auto {tol:g}` from {Path(path).name}: "
        f"{', '.join(c.key for c in chosen) or 'no effect pruned'}; verified error "
        f"{verified['error']:.2e} of the full model over tau in [0, {runs.t_end:.4g}]"
    )
    text = toml_text(raw, header)
    load_scene_text_check(text, str(output))
    out = Path(output)
    atomic_write(out, text)
    report.auto = {
        "chosen": [c.key for c in chosen],
        "overrides": [c.override for c in chosen],
        "verified_error": verified["error"],
        "steps": verified["steps"],
        "simulate_s": verified["simulate_s"],
        "file": str(out),
        "tried": tried,
    }
    return report


# --------------------------------------------------------------------------- TOML out
_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _string(s: str) -> str:
    out = ['"']
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return "".join(out) + '"'


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }" if v else "{}"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def toml_text(raw: dict, header: str = "") -> str:
    """A scene dict as TOML: top-level tables as [table], arrays of tables as [[array]], nested
    tables inline. Checked to read back to the same dict."""
    header = "".join(c if " " <= c != "\x7f" else "?" for c in header)  # e.g. a file name with a newline
    lines = [f"# {header}"] if header else []
    plain = {
        k: v
        for k, v in raw.items()
        if not isinstance(v, (dict, list)) or (isinstance(v, list) and not (v and all(isinstance(x, dict) for x in v)))
    }
    for k, v in plain.items():
        lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in raw.items():
        if k in plain:
            continue
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        else:
            for item in v:
                lines += ["", f"[[{_key(k)}]]"] + [f"{_key(a)} = {_value(b)}" for a, b in item.items()]
    text = "\n".join(lines) + "\n"
    if tomllib.loads(text) != raw:
        raise SymgenError("internal error: the TOML written does not read back to the scene")
    return text


def load_scene_text_check(text: str, name: str) -> None:
    """The written scene must load (validated like any scene file)."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / (Path(name).name or "scene.toml")
        p.write_text(text)
        try:
            load_scene(p)
        except SceneError as err:
            raise SymgenError(f"internal error: the scene written does not load: {err}") from None


# --------------------------------------------------------------------------- table
def table(report: EffectsReport) -> str:
    """The report as a plain-text table (what ``symgen effects`` prints)."""
    measured = any(r.error is not None or r.status for r in report.rows)
    steps = "Radau IIA (C) steps" if report.reference.get("solver") == "c" else "IDAS steps"
    head = ["change", "estimate", "from the groups"]
    if measured:
        head += ["measured", "worst output", steps, "simulate s", "speed-up"]
    head.append("recommendation")
    body = []
    ref_s = report.reference.get("simulate_s")
    for r in report.rows:
        cells = [r.change.key, f"{r.estimate:.1e}", r.detail]
        if measured:
            if r.status != "ok" or r.error is None:
                cells += [r.status[:60] or "-", "-", "-", "-", "-"]
            else:
                speed = f"{ref_s / r.simulate_s:.2f}x" if (ref_s and r.simulate_s) else "-"
                cells += [f"{r.error:.1e}", r.worst, str(r.steps), f"{r.simulate_s:.2f}", speed]
        cells.append(r.recommendation)
        body.append(cells)
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body)]
    fmt = "  ".join("{:<%d}" % w for w in widths)
    lines = [f"effects of {report.scene} (tol {report.tol:g})"]
    for name, (treatment, reason) in report.axial.items():
        lines.append(f"axial treatment of {name}: {treatment} ({reason})")
    lines += [f"bases of {name}: {describe_basis(c)}" for name, c in report.bases.items()]
    lines += [f"quasi-static functions of {name}: {why}" for name, (_, why) in report.quasi.items()]
    if report.strain[0]:
        lines.append(f"strain: {report.strain[0]} ({report.strain[1]})")
    if report.tolerances:
        lines.append(f"tolerances: {report.tolerances}")
    if report.stopped:
        lines.append(f"PARTIAL: {report.stopped}; the rows not measured have no measured error")
    if report.reference:
        ref = report.reference
        lines.append(
            f"measured over tau in [0, {ref['t_end']:.4g}], output step {ref['output_step']:.3g}, outputs "
            f"{', '.join(ref['outputs'])}; the scene as it is: {ref['steps']} {steps}, "
            f"{ref['simulate_s']:.2f} s"
        )
    if report.estimate is not None:
        est = report.estimate
        shown = report.reference.get("outputs") or list(est.outputs)
        per_output = ", ".join(f"{n} {est.text(n)}" for n in shown if n in est.outputs)
        lines.append(f"error estimate of the scene as it is (fraction of peak, over the window): {per_output}")
        for part in ("truncation", "model_form"):
            how = est.methods[part]
            why = est.reasons.get(part)
            lines.append(f"  {part.replace('_', ' ')}: {how}" + (f" ({why})" if why else ""))
    lines += [fmt.format(*head), fmt.format(*["-" * w for w in widths])]
    lines += [fmt.format(*row) for row in body]
    if report.auto:
        a = report.auto
        lines += [
            "",
            f"auto (tol {report.tol:g}): {', '.join(a['chosen']) or 'nothing pruned'}; verified error "
            f"{a['verified_error']:.2e}, {a['steps']} IDAS steps, {a['simulate_s']:.2f} s; wrote {a['file']}",
        ]
    return "\n".join(lines)
