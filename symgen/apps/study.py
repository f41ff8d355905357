"""Accuracy vs time: ``symgen study SCENE -o DIR``.

A study runs one scene in many *configurations* (mode counts per elastic bar, solver
tolerances, effect sets), measures the error of every output against a converged reference
and the CPU time of derivation, CasADi build and integration (medians of repeats), and writes

* ``DIR/study.csv``  one row per configuration (every output's error in its own columns),
* ``DIR/study.md``   the same as a Markdown table, the reference's own convergence, and the
  cheapest configuration for 1 %, 0.1 % and 0.01 % accuracy,
* ``DIR/study.png``  the Pareto plot: error against integration time, every point numbered (key beside it).

The reference is the richest model (every elastic bar at the richest mode level, von Karman
strain with the complete axial family, every effect on, rotary inertia included) at the
tightest tolerance. The mode and tolerance sweeps use the same effects; each effects row
switches one of them off (the speed-up that pruning buys is in its own column).
Its own convergence is shown by two rows: the next mode level down and a 10x looser tolerance.

Errors (see the formulation: the stiff axial modes ring at hundreds of periods per turn, and
mechanisms with several elastic bars slip in phase late in a run):

* ``error`` of an output: max over an *early window* (default: the first crank turn) of the
  difference to the reference, both low-pass filtered below ``cutoff`` (default 50 cycles per
  turn: the bending response stays, the axial ringing goes), divided by the reference's peak
  absolute value in the window;
* ``spectral`` error: over the whole run, the difference of the amplitude spectra below the
  cutoff, divided by the reference's spectral mass (insensitive to phase slips).

A configuration's error is the largest over its outputs (``closure_residual`` outputs are not
compared: they are zero to round-off in every configuration).

>>> from symgen.apps.study import run_study, write_study          # doctest: +SKIP
>>> study = run_study("examples/slider_crank.toml", quick=True)   # doctest: +SKIP
>>> write_study(study, "out/study_slider_crank")                   # doctest: +SKIP
"""

from __future__ import annotations

import csv
import io
import math
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Callable, Sequence

import numpy as np

from symgen.errors import Interrupted, SceneError, SymgenError
from symgen.outputs import atomic_path, atomic_write, remove
from symgen.scene import load_scene
from symgen.numerics import interrupt
from symgen.numerics.signals import DEFAULT_CUTOFF, edge, lowpass

#: mode levels (axial, transverse) per elastic bar, poorest to richest
LEVELS = ((1, 1), (2, 2), (3, 3), (3, 4), (4, 6), (6, 8))
QUICK_LEVELS = ((1, 1), (3, 3), (3, 4), (4, 6))
TOLERANCES = (1e-4, 1e-6, 1e-8)
QUICK_TOLERANCES = (1e-4, 1e-6)
REFERENCE_RTOL = 1e-9
ATOL_RATIO = 1e-2  # atol = rtol * ATOL_RATIO (amplitudes are O(1e-2) or larger)
TARGETS = (1e-2, 1e-3, 1e-4)

#: the groups whose rows carry the run's own error estimate (symgen.numerics.error_estimate: a
#: second run of a model with two more functions per bar), beside the error measured against
#: the reference
ESTIMATED = ("modes", "per-bar")

#: effect sets compared with the base model: label -> overrides
EFFECT_SETS = (
    ("linear strain (seed)", ("effects.strain=linear",)),
    ("no geometric stiffening", ("effects.geometric_stiffening=false",)),
    ("no Coriolis", ("effects.coriolis=false",)),
    ("inextensible bars", ('effects.axial="inextensible"',)),
    ("axial off", ("effects.axial=false",)),
    ("rotary inertia off", ("effects.rotary_inertia=false",)),
)


@dataclass(frozen=True)
class Config:
    """One configuration: a label, a group and the ``--set`` overrides that make it."""

    label: str
    group: str  # reference | reference check | modes | per-bar | effects | scene
    overrides: tuple
    rtol: float
    atol: float
    levels: tuple = ()  # ((bar, na, nt), ...)
    base_label: str = ""  # effects rows: the configuration they prune

    def sets(self) -> list[str]:
        return [*self.overrides, f"simulation.rtol={self.rtol:g}", f"simulation.atol={self.atol:g}"]


@dataclass
class Row:
    config: Config
    status: str = "ok"
    n_coords: int = 0
    ops: int = 0
    derive_s: float = math.nan
    build_s: float = math.nan
    integrate_s: float = math.nan
    steps: int = 0
    closure_max: float = math.nan
    error: float = math.nan
    worst: str = ""
    spectral: float = math.nan
    errors: dict = field(default_factory=dict)  # output -> window error
    spectra: dict = field(default_factory=dict)  # output -> spectral error
    estimates: dict = field(default_factory=dict)  # output -> estimated error (ESTIMATED groups' rows)
    tau: np.ndarray | None = None
    outputs: np.ndarray | None = None


@dataclass
class Study:
    scene_path: str
    scene_name: str
    overrides: tuple
    elastic: tuple
    turn: float  # tau of one crank turn (2 pi / rate, or 2 pi)
    t_end: float
    window: float  # tau
    cutoff: float  # cycles per unit tau
    repeats: int
    reference: Row
    rows: list
    output_names: list
    compared: list
    notes: list = field(default_factory=list)
    oversample: int = 1
    status: str = "complete"  # or "interrupted" (rows: the configurations run before the signal)
    stopped: str = ""  # the cause when not complete
    planned: int = 0  # configurations planned
    solver: str = "idas"  # the integrator of every run: "idas" or "c" (the emitted Radau IIA)


# --------------------------------------------------------------------------- errors
def window_error(y: np.ndarray, ref: np.ndarray, dt: float, cutoff: float, n_window: int) -> float:
    """max |y - ref| over the first ``n_window`` samples, both low-passed, / max |ref| there
    (leaving out the filter's edge transient: one cutoff period at the start, and at the end
    when the window reaches the end of the run)."""
    if not np.all(np.isfinite(y)):
        return math.inf
    a, b = lowpass(y, dt, cutoff), lowpass(ref, dt, cutoff)
    k = edge(dt, cutoff)
    stop = min(n_window, len(y) - k)
    if stop - k < 2:
        k, stop = 0, min(n_window, len(y))
    a, b = a[k:stop], b[k:stop]
    scale = float(np.abs(b).max())
    return float(np.abs(a - b).max() / scale) if scale > 0 else float(np.abs(a - b).max())


def spectral_error(y: np.ndarray, ref: np.ndarray, dt: float, cutoff: float) -> float:
    """Difference of Hann-windowed amplitude spectra below ``cutoff`` / spectral mass of ref."""
    w = np.hanning(len(ref))
    f = np.fft.rfftfreq(len(ref), dt)
    keep = f <= cutoff
    A = np.abs(np.fft.rfft((y - y.mean()) * w))[keep]
    B = np.abs(np.fft.rfft((ref - ref.mean()) * w))[keep]
    mass = float(B.sum())
    if not np.all(np.isfinite(A)):
        return math.inf
    return float(np.abs(A - B).sum() / mass) if mass > 0 else 0.0


# --------------------------------------------------------------------------- configurations
def _fmt_tol(x: float) -> str:
    return f"{x:.0e}".replace("e-0", "e-")


def _level_sets(levels: dict) -> tuple:
    out = []
    for bar, (na, nt) in levels.items():
        out += [f"bodies.{bar}.axial_modes={na}", f"bodies.{bar}.transverse_modes={nt}"]
    return tuple(out)


def _level_name(levels: dict, elastic: Sequence[str]) -> str:
    vals = list(levels.values())
    if len(set(vals)) == 1:
        na, nt = vals[0]
        return f"{na}+{nt}"
    return " ".join(f"{b}:{na}+{nt}" for b, (na, nt) in levels.items())


def plan(
    scene,
    elastic: Sequence[str],
    levels: Sequence[tuple],
    tolerances: Sequence[float],
    ref_rtol: float,
    per_bar: bool,
    effects: bool,
) -> tuple[Config, list[Config]]:
    """The reference and the configurations of a study (see the module docstring)."""
    base_sets = [
        "effects.strain=von_karman",
        "effects.geometric_stiffening=true",
        "effects.axial=true",
        "effects.transverse=true",
        "effects.coriolis=true",
        "effects.rotary_inertia=true",
    ]
    base = tuple(base_sets + [f"bodies.{b}.axial_shapes=complete" for b in elastic])
    ref_level = levels[-1]
    ref_modes = {b: ref_level for b in elastic}
    atol = lambda r: r * ATOL_RATIO
    ref = Config(
        f"reference {_level_name(ref_modes, elastic)} @{_fmt_tol(ref_rtol)}",
        "reference",
        base + _level_sets(ref_modes),
        ref_rtol,
        atol(ref_rtol),
        tuple((b, *ref_level) for b in elastic),
    )
    configs: list[Config] = []
    # the reference's own convergence
    if len(levels) > 1:
        lower = {b: levels[-2] for b in elastic}
        configs.append(
            Config(
                f"check: {_level_name(lower, elastic)} @{_fmt_tol(ref_rtol)}",
                "reference check",
                base + _level_sets(lower),
                ref_rtol,
                atol(ref_rtol),
                tuple((b, *levels[-2]) for b in elastic),
            )
        )
    configs.append(
        Config(
            f"check: {_level_name(ref_modes, elastic)} @{_fmt_tol(ref_rtol * 10)}",
            "reference check",
            ref.overrides,
            ref_rtol * 10,
            atol(ref_rtol * 10),
            ref.levels,
        )
    )
    # uniform mode levels x tolerances (the base effects: the scene's, made accurate)
    for lev in levels:
        modes = {b: lev for b in elastic}
        for tol in tolerances:
            configs.append(
                Config(
                    f"{_level_name(modes, elastic)} @{_fmt_tol(tol)}",
                    "modes",
                    base + _level_sets(modes),
                    tol,
                    atol(tol),
                    tuple((b, *lev) for b in elastic),
                )
            )
    mid_tol = sorted(tolerances)[len(tolerances) // 2]
    # one bar at a time below the reference level, the others at it
    if per_bar and len(elastic) > 1:
        for b in elastic:
            for lev in levels[:-1]:
                modes = dict(ref_modes)
                modes[b] = lev
                configs.append(
                    Config(
                        f"{b} {lev[0]}+{lev[1]}, others {ref_level[0]}+{ref_level[1]} @{_fmt_tol(mid_tol)}",
                        "per-bar",
                        base + _level_sets(modes),
                        mid_tol,
                        atol(mid_tol),
                        tuple((x, *modes[x]) for x in elastic),
                    )
                )
    # effect sets on a mid-level model
    if effects:
        mid_level = (3, 4) if (3, 4) in levels else levels[len(levels) // 2]
        modes = {b: mid_level for b in elastic}
        base_label = f"{_level_name(modes, elastic)} @{_fmt_tol(mid_tol)}"
        for label, sets in EFFECT_SETS:
            configs.append(
                Config(
                    f"{label}, {base_label}",
                    "effects",
                    base + _level_sets(modes) + tuple(sets),
                    mid_tol,
                    atol(mid_tol),
                    tuple((b, *mid_level) for b in elastic),
                    base_label,
                )
            )
        sim = scene.simulation
        configs.append(
            Config(
                f"scene as written @{_fmt_tol(sim.rtol)}",
                "scene",
                (),
                sim.rtol,
                sim.atol,
                tuple((b.name, b.axial_modes, b.transverse_modes) for b in scene.bodies if not b.rigid),
            )
        )
    # drop duplicates (same overrides and tolerances), keeping the first
    seen, unique = {tuple(ref.sets())}, []
    for c in configs:
        key = tuple(c.sets())
        if key not in seen:
            seen.add(key)
            unique.append(c)
    return ref, unique


# --------------------------------------------------------------------------- running
def _median(xs):
    xs = [x for x in xs if x == x]
    return statistics.median(xs) if xs else math.nan


class _Runner:
    """Derive each model structure once per repeat (timed), run each configuration."""

    def __init__(
        self,
        path: str,
        overrides: Sequence[str],
        repeats: int,
        t_end: float | None,
        step: float | None,
        turn: float = 2 * math.pi,
        solver: str = "idas",
    ):
        self.path, self.overrides, self.repeats = path, tuple(overrides), repeats
        self.solver = solver
        self.t_end, self.step, self.turn = t_end, step, turn
        self.models: dict = {}

    def scene(self, cfg: Config):
        sets = list(self.overrides) + cfg.sets()
        if self.t_end is None:
            return load_scene(self.path, sets)
        try:
            return load_scene(self.path, sets + [f"simulation.t_end={self.t_end!r}"])
        except SceneError:  # the file gives cycles (crank turns), not t_end
            return load_scene(self.path, sets + [f"simulation.cycles={self.t_end / self.turn!r}"])

    def compiled(self, scene):
        from symgen.model.derive import structure_key, structure_of
        from symgen.backends.casadi.pipeline import compile_scene
        import sympy

        key = structure_key(structure_of(scene))
        if key not in self.models:
            times = []
            for _ in range(self.repeats):
                sympy.core.cache.clear_cache()
                t0 = time.process_time()
                compiled = compile_scene(scene, use_cache=False)
                total = time.process_time() - t0
                # split CPU time by the wall-clock shares compile_scene measured
                wall = compiled.derive_s + compiled.build_s
                share = compiled.derive_s / wall if wall > 0 else 1.0
                times.append((total * share, total * (1 - share)))
            self.models[key] = (compiled, _median([t[0] for t in times]), _median([t[1] for t in times]))
        return self.models[key]

    def run(self, cfg: Config) -> Row:
        """Timed runs at the scene's output step (medians), then one run at the study's finer
        output step for the errors (the timing runs are not slowed by the extra outputs)."""
        from symgen.numerics import csolver
        from symgen.numerics.mechanism import Mechanism

        row = Row(cfg)
        try:
            scene = self.scene(cfg)
            compiled, row.derive_s, build_s = self.compiled(scene)
            row.n_coords = compiled.info.n
            row.ops = int(compiled.funcs["res"].n_instructions())
            mech_times, sim_times, result = [], [], None
            if self.solver == "c":  # its library compiled before the timed runs (a model's build, not its run)
                t0 = time.process_time()
                csolver.solver(Mechanism(compiled, scene))
                build_s += time.process_time() - t0
            for _ in range(self.repeats):
                t0 = time.process_time()
                mech = Mechanism(compiled, scene)
                t1 = time.process_time()
                result = csolver.run(mech, self.solver)
                t2 = time.process_time()
                mech_times.append(t1 - t0)
                sim_times.append(t2 - t1)
            assert result is not None, "the runner repeats every run at least once"
            row.build_s = build_s + _median(mech_times)
            row.integrate_s = _median(sim_times)
            row.steps, row.closure_max = result.steps, result.closure_max
            if self.step is not None and self.step < scene.simulation.output_step:
                result = csolver.run(mech, self.solver, output_step=self.step)
            row.tau, row.outputs = result.tau, result.outputs
            if cfg.group in ESTIMATED:
                from symgen.numerics.error_estimate import estimate_errors

                row.estimates = estimate_errors(mech, result, cfg.rtol, cfg.atol).outputs
        except SceneError:
            raise
        except SymgenError as err:
            interrupt.check()  # a failure while SIGINT/SIGTERM is pending is the interrupt
            row.status = f"failed: {err}"
        return row


def oversampling(scene, n_axial: int, cutoff: float) -> int:
    """Output-step divisor for the accuracy runs: the smallest (up to 16) that keeps every
    axial mode of every elastic bar from aliasing below twice the comparison cutoff. The
    start-up ringing of those modes is real but far above the response the study compares;
    sampled at the scene's step it would fold down onto it. Frequencies: (2k - 1)(pi/2)
    sqrt(lambda) per unit tau, k = 1..n_axial (a free-ended bar's axial modes)."""
    freqs = [
        (2 * k - 1) * 0.25 * math.sqrt(b.lam)
        for b in scene.bodies
        if not b.rigid and b.lam
        for k in range(1, max(1, n_axial) + 1)
    ]  # cycles per unit tau
    step = scene.simulation.output_step
    for K in range(1, 17):
        fs = K / step
        if all(abs(f - round(f / fs) * fs) > 2 * cutoff for f in freqs):
            return K
    return 16


def _compare(row: Row, ref: Row, names: list, compared: list, dt: float, cutoff: float, n_window: int) -> None:
    if row.status != "ok" or row.outputs is None or row.tau is None:
        return
    assert ref.tau is not None and ref.outputs is not None, "the reference ran"
    n = min(len(row.tau), len(ref.tau))
    for name in compared:
        k = names.index(name)
        y, r = row.outputs[:n, k], ref.outputs[:n, k]
        row.errors[name] = window_error(y, r, dt, cutoff, min(n_window, n))
        row.spectra[name] = spectral_error(y, r, dt, cutoff)
    if row.errors:
        row.worst = max(row.errors, key=lambda k: row.errors[k])
        row.error = row.errors[row.worst]
        row.spectral = max(row.spectra.values())


def run_study(
    scene_path: str,
    overrides: Sequence[str] = (),
    *,
    quick: bool = False,
    repeats: int = 3,
    window_turns: float = 1.0,
    cutoff_per_turn: float = DEFAULT_CUTOFF,
    levels: Sequence[tuple] | None = None,
    tolerances: Sequence[float] | None = None,
    ref_rtol: float = REFERENCE_RTOL,
    per_bar: bool | None = None,
    effects: bool = True,
    t_end: float | None = None,
    oversample: int | None = None,
    progress: Callable[[str], None] | None = None,
    solver: str = "idas",
) -> Study:
    """Run the study of a scene (see the module docstring); ``write_study`` writes its files.

    Parameters
    ----------
    quick : fewer mode levels and tolerances, no per-bar rows
    repeats : timed repeats of every derivation and integration (medians are reported)
    window_turns : early window for the pointwise error, in crank turns
    cutoff_per_turn : low-pass cutoff of the compared outputs, cycles per crank turn
    levels : (axial, transverse) mode levels, poorest to richest (the last is the reference's)
    tolerances : rtol values of the sweep (atol = rtol / 100)
    ref_rtol : the reference's rtol
    t_end : simulated tau (default: the scene's)
    oversample : the errors are measured on outputs this many times finer than the scene's
        output step (default: ``oversampling``: the axial ringing must not alias)
    solver : "idas" (default) or "c": every run (the reference too) with the emitted C Radau IIA
        solver, its library compiled per configuration outside the timed runs (in build s)
    """
    from symgen.numerics.solvers import check_solver

    check_solver(solver)
    say = progress or (lambda _msg: None)
    scene = load_scene(scene_path, list(overrides))
    elastic = tuple(b.name for b in scene.bodies if not b.rigid)
    if not elastic:
        raise SceneError(
            scene_path,
            "bodies",
            "the scene has no elastic bar: a study compares mode counts",
            "make at least one bar elastic (rigid = false with lambda and mu)",
        )
    levels = tuple(tuple(x) for x in (levels or (QUICK_LEVELS if quick else LEVELS)))
    tolerances = tuple(tolerances or (QUICK_TOLERANCES if quick else TOLERANCES))
    per_bar = (not quick) if per_bar is None else per_bar
    drv = scene.turning_driver
    turn = 2 * math.pi / abs(drv.rate) if drv is not None else 2 * math.pi
    k = (
        oversampling(scene, max(lev[0] for lev in levels), cutoff_per_turn / turn)
        if oversample is None
        else max(1, int(oversample))
    )
    runner = _Runner(scene_path, overrides, max(1, repeats), t_end, scene.simulation.output_step / k, turn, solver)
    ref_cfg, configs = plan(scene, elastic, levels, tolerances, ref_rtol, per_bar, effects)
    notes = []
    say(f"reference: {ref_cfg.label}")
    ref = runner.run(ref_cfg)
    # a reference that fails (e.g. a too-rich model the solver cannot carry) falls back a level
    while ref.status != "ok" and len(levels) > 2:
        notes.append(f"The richest model {ref_cfg.label} did not run ({ref.status}); the reference is one level lower.")
        say(notes[-1])
        levels = levels[:-1]
        ref_cfg, configs = plan(scene, elastic, levels, tolerances, ref_rtol, per_bar, effects)
        ref = runner.run(ref_cfg)
    if ref.status != "ok":
        raise SymgenError(f"the reference model of the study failed: {ref.status}")
    sc_ref = runner.scene(ref_cfg)
    names = [o.name for o in sc_ref.outputs]
    compared = [o.name for o in sc_ref.outputs if o.kind != "closure_residual"]
    assert ref.tau is not None, "the reference ran"
    t_end = float(ref.tau[-1])
    dt = float(np.median(np.diff(ref.tau)))
    cutoff = cutoff_per_turn / turn
    n_window = int(round(window_turns * turn / dt)) + 1
    rows: list[Row] = []

    def study(status: str = "complete", stopped: str = "") -> Study:
        return Study(
            scene_path=str(scene_path),
            scene_name=scene.name,
            overrides=tuple(overrides),
            elastic=elastic,
            turn=turn,
            t_end=t_end,
            window=min(window_turns * turn, t_end),
            cutoff=cutoff,
            repeats=max(1, repeats),
            reference=ref,
            rows=list(rows),
            output_names=names,
            compared=compared,
            notes=notes,
            oversample=k,
            status=status,
            stopped=stopped,
            planned=len(configs),
            solver=solver,
        )

    from symgen.progress import progress_bar

    try:
        with progress_bar(len(configs), f"study {scene.name}", unit="config") as bar:
            for i, cfg in enumerate(configs):
                interrupt.check()
                say(f"[{i + 1}/{len(configs)}] {cfg.label}")
                row = runner.run(cfg)
                _compare(row, ref, names, compared, dt, cutoff, n_window)
                rows.append(row)
                say(f"    error {row.error:.2e} ({row.worst}), integrate {row.integrate_s:.2f} s, {row.status}")
                bar.update(1)
    except BaseException as err:
        # the rows done so far are a partial study (written marked "interrupted"); any failure
        # while a signal is pending is the interrupt (CasADi reports it as its own error)
        stop = interrupt.interrupted(err)
        if not isinstance(stop, Interrupted):
            raise
        stop.partial = study("interrupted", str(stop))
        if stop is err:
            raise
        raise stop from None
    return study()


# --------------------------------------------------------------------------- choosing and writing
SOLVER_NAMES = {"idas": "IDAS", "c": "Radau IIA (C)"}


def _steps_of(study: Study) -> str:
    return f"{SOLVER_NAMES[study.solver]} steps"


def reference_uncertainty(study: Study) -> float:
    """Largest error of the reference-check rows: how far the reference itself is converged."""
    errs = [r.error for r in study.rows if r.config.group == "reference check" and r.status == "ok"]
    return max(errs) if errs else math.nan


def pick(study: Study, target: float) -> tuple[Row | None, bool]:
    """The configuration with the least integration time whose error is within ``target``,
    and whether that is certified: its error plus the reference's own uncertainty stays within
    the target. Reference-check rows are not candidates (their error hides the reference's)."""
    unc = reference_uncertainty(study)
    unc = 0.0 if not np.isfinite(unc) else unc
    cands = [r for r in study.rows if r.status == "ok" and r.config.group != "reference check"]
    sure = [r for r in cands if r.error + unc <= target]
    if sure:
        return min(sure, key=lambda r: r.integrate_s), True
    maybe = [r for r in cands if r.error <= target]
    return (min(maybe, key=lambda r: r.integrate_s), False) if maybe else (None, False)


def output_uncertainty(study: Study, name: str) -> float:
    """How far the reference is converged for one output (largest reference-check error)."""
    errs = [
        r.errors[name]
        for r in study.rows
        if r.config.group == "reference check" and r.status == "ok" and name in r.errors
    ]
    return max(errs) if errs else math.nan


def pick_output(study: Study, name: str, target: float) -> tuple[Row | None, bool]:
    """``pick`` for one output alone."""
    unc = output_uncertainty(study, name)
    unc = 0.0 if not np.isfinite(unc) else unc
    cands = [r for r in study.rows if r.status == "ok" and r.config.group != "reference check" and name in r.errors]
    sure = [r for r in cands if r.errors[name] + unc <= target]
    if sure:
        return min(sure, key=lambda r: r.integrate_s), True
    maybe = [r for r in cands if r.errors[name] <= target]
    return (min(maybe, key=lambda r: r.integrate_s), False) if maybe else (None, False)


def pareto(rows: Sequence[Row]) -> list[Row]:
    """Rows not beaten by another in both error and integration time, fastest first."""
    ok = sorted((r for r in rows if r.status == "ok" and np.isfinite(r.error)), key=lambda r: (r.integrate_s, r.error))
    front, best = [], math.inf
    for r in ok:
        if r.error < best:
            front.append(r)
            best = r.error
    return front


def _speedup(study: Study, row: Row) -> float:
    if row.config.group != "effects":
        return math.nan
    base = next((r for r in study.rows if r.config.label == row.config.base_label and r.status == "ok"), None)
    return base.integrate_s / row.integrate_s if base is not None and row.integrate_s > 0 else math.nan


def _nan(x: float | None) -> float:
    return math.nan if x is None else float(x)


def _estimate(study: Study, row: Row) -> float:
    """The row's estimated error (its run's own estimate, ``symgen.numerics.error_estimate``):
    the largest over the compared outputs, nan where not estimated."""
    vals = [float(v) for v in (row.estimates.get(n) for n in study.compared) if v is not None]
    return max(vals) if vals else math.nan


def csv_text(study: Study) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    head = [
        "label",
        "group",
        "status",
        "set",
        "rtol",
        "atol",
        "coordinates",
        "res_ops",
        "derive_cpu_s",
        "build_cpu_s",
        "integrate_cpu_s",
        "integrate_cpu_s_per_turn",
        "idas_steps",
        "closure_max",
        "error",
        "worst_output",
        "spectral_error",
        "speedup_vs_base",
        "estimated_error",
    ]
    head += [f"error_{n}" for n in study.compared] + [f"spectral_{n}" for n in study.compared]
    head += [f"estimated_{n}" for n in study.compared]
    w.writerow(head)
    turns = study.t_end / study.turn
    for row in [study.reference, *study.rows]:
        c = row.config
        err = 0.0 if c.group == "reference" else row.error
        w.writerow(
            [
                c.label,
                c.group,
                row.status,
                " ".join(c.overrides),
                repr(c.rtol),
                repr(c.atol),
                row.n_coords,
                row.ops,
                f"{row.derive_s:.6g}",
                f"{row.build_s:.6g}",
                f"{row.integrate_s:.6g}",
                f"{row.integrate_s / turns:.6g}",
                row.steps,
                f"{row.closure_max:.3g}",
                f"{err:.6g}",
                row.worst,
                f"{0.0 if c.group == 'reference' else row.spectral:.6g}",
                f"{_speedup(study, row):.4g}",
                f"{_estimate(study, row):.6g}",
            ]
            + [f"{row.errors.get(n, math.nan):.6g}" for n in study.compared]
            + [f"{row.spectra.get(n, math.nan):.6g}" for n in study.compared]
            + [f"{_nan(row.estimates.get(n)):.6g}" for n in study.compared]
        )
    return buf.getvalue()


def _pct(x: float) -> str:
    if not np.isfinite(x):
        return "—"
    return f"{100 * x:.3g} %"


def markdown(study: Study, png_name: str | None = "study.png") -> str:
    ref = study.reference
    turns = study.t_end / study.turn
    unc = reference_uncertainty(study)
    lines = [f"# Accuracy vs time: `{study.scene_path}`", ""]
    if study.status != "complete":
        lines += [
            f"**PARTIAL STUDY ({study.status}: {study.stopped}): {len(study.rows)} of {study.planned} "
            f"configurations were run; the picks below are among those only.**",
            "",
        ]
    if study.overrides:
        lines += [f"Scene overrides: `{' '.join('--set ' + o for o in study.overrides)}`", ""]
    lines += [
        f"Reference: **{ref.config.label}** ({ref.n_coords} coordinates, von Kármán strain, complete axial "
        f"family, rotary inertia on; {ref.steps} {_steps_of(study)}, integration {ref.integrate_s:.2f} s CPU). "
        f"Run: {turns:.3g} crank turns (tau = {study.t_end:.4g}). Errors: outputs low-passed below "
        f"{study.cutoff * study.turn:.3g} cycles per turn, sampled {study.oversample}x finer than the scene's output "
        f"step so that the axial ringing does not alias; **error** = max over the first "
        f"{study.window / study.turn:.3g} turn(s) of |y − y_ref| / max|y_ref|, worst output; **spectral** = "
        f"amplitude-spectrum difference over the whole run (insensitive to phase slips). CPU times: medians of "
        f"{study.repeats} repeat(s); derivation with SymPy's cache cleared, no model cache.",
        "",
    ]
    lines += ["## The reference's own convergence", "", "| check | error | spectral |", "|---|---|---|"]
    for r in study.rows:
        if r.config.group == "reference check":
            lines.append(
                f"| {r.config.label} | {_pct(r.error)} | {_pct(r.spectral)} |"
                if r.status == "ok"
                else f"| {r.config.label} | {r.status} | |"
            )
    lines += [
        "",
        f"The reference is converged to about {_pct(unc)} (the largest of these): a configuration "
        f"is certified for a target when its error plus this stays within the target.",
        "",
    ]
    for note in study.notes:
        lines += [f"Note: {note}", ""]
    lines += [
        "## Which configuration to pick",
        "",
        "| target | configuration | error | integrate CPU s / turn | `--set` |",
        "|---|---|---|---|---|",
    ]
    for target in TARGETS:
        r, certified = pick(study, target)
        if r is None:
            lines.append(f"| {_pct(target)} | none of the configurations reaches it | | | |")
        else:
            flag = "" if certified else " (not certified: within the reference's own uncertainty)"
            lines.append(
                f"| {_pct(target)} | {r.config.label}{flag} | {_pct(r.error)} | "
                f"{r.integrate_s / turns:.3g} | `{' '.join(r.config.sets())}` |"
            )
    lines += [
        "",
        "Per output (cheapest configuration whose error on that output alone is within the target; "
        "† = not certified: within the reference's own uncertainty for that output):",
        "",
        "| output | reference converged to | " + " | ".join(_pct(t) for t in TARGETS) + " |",
        "|---|---|" + "---|" * len(TARGETS),
    ]
    for name in study.compared:
        cells = []
        for target in TARGETS:
            r, certified = pick_output(study, name, target)
            cells.append(
                "—"
                if r is None
                else f"{r.config.label}{'' if certified else ' †'} "
                f"({_pct(r.errors[name])}, {r.integrate_s / turns:.3g} s/turn)"
            )
        lines.append(f"| {name} | {_pct(output_uncertainty(study, name))} | " + " | ".join(cells) + " |")
    lines += [""] + ([f"![error vs integration time]({png_name})", ""] if png_name else [])
    lines += [
        "## Every configuration",
        "",
        f"| configuration | group | coords | res ops | derive s | build s | integrate s / turn | {_steps_of(study)} | "
        "error | worst output | spectral | speed-up | estimated |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in study.rows:
        if r.status != "ok":
            lines.append(
                f"| {r.config.label} | {r.config.group} | {r.n_coords} | {r.ops} | {r.derive_s:.2f} | | "
                f"| | {r.status[:120]} | | | | |"
            )
            continue
        sp_ = _speedup(study, r)
        lines.append(
            f"| {r.config.label} | {r.config.group} | {r.n_coords} | {r.ops} | {r.derive_s:.2f} | "
            f"{r.build_s:.2f} | {r.integrate_s / turns:.3g} | {r.steps} | {_pct(r.error)} | {r.worst} | "
            f"{_pct(r.spectral)} | {'' if not np.isfinite(sp_) else f'{sp_:.2f}x'} | "
            f"{'' if not np.isfinite(_estimate(study, r)) else _pct(_estimate(study, r))} |"
        )
    lines += [
        "",
        "Per-output errors are in `study.csv` (`error_<output>`, `spectral_<output>`); the speed-up of an "
        "effects row is the integration time of the same model with every effect on divided by its own. "
        "**estimated**: the run's own error estimate (no reference needed: what `symgen simulate` writes "
        "in its sidecar), worst output over the whole run, for the mode rows (`estimated_<output>` in "
        "`study.csv`); it estimates the truncation error that **error** measures against the reference.",
        "",
    ]
    return "\n".join(lines)


GROUP_STYLE = {
    "modes": ("tab:blue", "o"),
    "per-bar": ("tab:green", "s"),
    "effects": ("tab:red", "^"),
    "scene": ("black", "*"),
    "reference check": ("tab:purple", "D"),
}


def plot(study: Study, path: str | Path) -> None:
    """Pareto plot: error (log) against integration CPU time per turn (log). Every point carries
    a number, placed clear of the other numbers and of the markers; the key beside the plot
    lists the numbers with their configurations (long labels never cross the data)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    turns = study.t_end / study.turn
    rows = [r for r in study.rows if r.status == "ok" and np.isfinite(r.error)]
    fig = plt.figure(figsize=(13, 7.5), layout="constrained")
    gs = fig.add_gridspec(1, 2, width_ratios=[2.5, 1])
    ax, key = fig.add_subplot(gs[0]), fig.add_subplot(gs[1])
    floor = 1e-7
    for group, (color, marker) in GROUP_STYLE.items():
        pts = [r for r in rows if r.config.group == group]
        if pts:
            ax.scatter(
                [r.integrate_s / turns for r in pts],
                [max(r.error, floor) for r in pts],
                c=color,
                marker=marker,
                s=40,
                label=group,
                zorder=3,
            )
    front = pareto([r for r in rows if r.config.group != "reference check"])
    if front:
        ax.step(
            [r.integrate_s / turns for r in front],
            [max(r.error, floor) for r in front],
            where="post",
            color="gray",
            lw=1,
            ls="--",
            label="Pareto front (reference checks left out)",
            zorder=2,
        )
    for target in TARGETS:
        ax.axhline(target, color="gray", lw=0.6, ls=":")
        ax.text(
            1.0,
            target,
            f"{_pct(target)} ",
            transform=ax.get_yaxis_transform(),
            fontsize=7,
            va="bottom",
            ha="right",
            color="gray",
        )
    unc = reference_uncertainty(study)
    if np.isfinite(unc) and unc > 0:
        ax.axhspan(floor, unc, color="tab:purple", alpha=0.07, label="within the reference's own uncertainty")
    ax.set_xlabel(f"integration CPU time per crank turn [s] ({SOLVER_NAMES[study.solver]}, median of repeats)")
    ax.set_ylabel(
        f"error: max over outputs of max|y − y_ref| / max|y_ref|, first {study.window / study.turn:.3g} turn(s)"
    )
    ax.set_title(f"{study.scene_name}: accuracy vs time ({study.reference.config.label})", fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, loc="lower left")
    _key(key, rows)
    _labels(ax, fig, [(r.integrate_s / turns, max(r.error, floor), str(k + 1)) for k, r in enumerate(rows)])
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=130, format=Path(path).suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)


def _key(ax, rows) -> None:
    """The numbers of the points and their configurations, in columns, coloured by group."""
    ax.axis("off")
    n = len(rows)
    if not n:
        return
    ncol = 1 if n <= 42 else 2
    per = -(-n // ncol)
    size = min(8.0, 430.0 / per)
    ax.set_title("key: point number, configuration", fontsize=9, loc="left")
    for k, r in enumerate(rows):
        col, line = divmod(k, per)
        ax.text(
            col / ncol,
            1 - (line + 0.5) / max(per, 24),
            f"{k + 1:>2}  {r.config.label}",
            transform=ax.transAxes,
            fontsize=size * (0.85 if ncol > 1 else 1),
            va="center",
            ha="left",
            family="monospace",
            color=GROUP_STYLE.get(r.config.group, ("black",))[0],
        )


def _labels(ax, fig, points) -> None:
    """Place every point's (short) label where it overlaps no marker and no label already
    placed (a greedy search over offsets around the point, in display coordinates); a label
    moved away from its point gets a leader line."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    if not points:
        return
    ax.set_xlim(min(xs) / 1.25, max(xs) * 1.6)
    ax.set_ylim(min(ys) / 3, max(ys) * 3)
    fig.canvas.draw()  # final layout, then freeze it: the labels are placed in points
    fig.set_layout_engine("none")
    scale = 72.0 / fig.dpi
    disp = [ax.transData.transform((x, y)) * scale for x, y, _ in points]
    placed: list = [(px - 4, py - 4, px + 4, py + 4) for px, py in disp]  # the markers
    char_w, line_h = 4.2, 8.5  # points, at fontsize 7
    offsets = [
        (dx, dy)
        for r in (5, 11, 18, 26, 35)
        for dx, dy in (
            (r, -line_h / 2),
            (-r, -line_h / 2),
            (0, r - 3),
            (0, -r - line_h + 3),
            (r, r - 3),
            (-r, r - 3),
            (r, -r - line_h + 3),
            (-r, -r - line_h + 3),
        )
    ]
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    for i in order:
        x, y, text = points[i]
        px, py = disp[i]
        w = char_w * len(text)
        choice = None
        for dx, dy in offsets:
            x0 = px + dx if dx > 0 else px + dx - w if dx < 0 else px - w / 2
            box = (x0, py + dy, x0 + w, py + dy + line_h)
            if not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in placed):
                choice = (box, np.hypot(dx, dy))
                break
        box, dist = choice or ((px + 5, py, px + 5 + w, py + line_h), 5.0)
        placed.append(box)
        cx, cy = (box[0] + box[2]) / 2 - px, (box[1] + box[3]) / 2 - py
        ax.annotate(
            text,
            (x, y),
            xytext=(cx, cy),
            textcoords="offset points",
            fontsize=7,
            zorder=4,
            ha="center",
            va="center",
            arrowprops=None
            if dist < 12
            else {"arrowstyle": "-", "lw": 0.4, "color": "gray", "shrinkA": 0, "shrinkB": 3},
        )


def study_paths(directory: str | Path, complete: bool = True, fmt: str = "png") -> list[Path]:
    """study.csv, study.md, study.png|svg|pdf (or their ``study.partial.*`` twins) in ``directory``."""
    stem = "study" if complete else "study.partial"
    return [Path(directory) / f"{stem}.{ext}" for ext in ("csv", "md", fmt)]


def write_study(study: Study, directory: str | Path, with_plot: bool = True, fmt: str = "png") -> list[Path]:
    """Write study.csv, study.md and study.png (or .svg / .pdf: ``fmt``) into ``directory`` (CSV first, the plot last);
    a partial study writes ``study.partial.*`` and removes the files of an earlier complete
    study, a complete one removes stale ``study.partial.*``. Return the paths written
    (``with_plot=False``: no PNG, e.g. when stopping on a signal, where time counts)."""
    d = Path(directory)
    complete = study.status == "complete"
    paths = study_paths(d, complete, fmt)
    remove(study_paths(d, not complete, fmt) + paths[1:])
    if not with_plot:
        paths = paths[:2]
    d.mkdir(parents=True, exist_ok=True)
    try:
        atomic_write(paths[0], csv_text(study))
        atomic_write(paths[1], markdown(study, paths[2].name if with_plot else None))
        if with_plot:
            plot(study, paths[2])
    except BaseException:
        remove(paths)
        raise
    return paths


def discard_study(directory: str | Path) -> None:
    """A study that failed before any result: remove the files of earlier studies there."""
    remove([p for fmt in ("png", "svg", "pdf") for done in (True, False) for p in study_paths(directory, done, fmt)])
