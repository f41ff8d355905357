"""Results files: OUT.csv + OUT.json (the contract), written atomically, CSV first.

A complete run writes ``OUT.csv``, then its sidecar ``OUT.json`` (status "complete"), then the
plot if asked, and removes any ``OUT.partial.*`` of an earlier run. A run that stops early
(a solver failure: status "partial"; SIGINT/SIGTERM: status "interrupted") writes
``OUT.partial.csv`` / ``OUT.partial.json`` (the cause in ``failure``) and ``PLOT.partial.png``
instead, and removes any older ``OUT.csv`` / ``OUT.json`` / ``PLOT`` first, so that nothing
left behind looks like a complete result. The sidecar is written after its CSV and removed
before it is rewritten: a failed write never leaves a JSON beside a CSV it does not describe.

``build_sidecar`` makes the sidecar record of a run and ``write_run`` writes the run; both are
shared by the command line (``symgen simulate``, ``symgen quasistatic``) and ``symgen.api``
(``simulate_scene(..., out=...)``), which therefore write the same files. The plot is drawn
above this layer: ``write_run`` returns it as data (``OutputsPlot``) and the application draws
it (``symgen.apps.plot.plot_run``).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar
from collections.abc import Callable, Iterable, Mapping, Sequence

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen import __version__
from symgen.errors import Interrupted, SceneError, SimulationError
from symgen.numerics.run_result import table_rows
from symgen.outputs import atomic_write, check_file, remove

if TYPE_CHECKING:
    from symgen.numerics.error_estimate import ErrorEstimate
    from symgen.scene.model import Scene
    from symgen.backends.casadi.pipeline import CompiledModel
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.quasistatic import QuasiStaticResult
    from symgen.numerics.simulate import SimResult
    from symgen.numerics.units import ResultUnits

__all__ = [
    "OutputsPlot",
    "PLOT_SUFFIXES",
    "ResultFiles",
    "WrittenRun",
    "atomic_write",
    "attempt",
    "decidable",
    "judged",
    "build_sidecar",
    "csv_text",
    "rows_text",
    "error_estimate",
    "partial_paths",
    "run_files",
    "states_block",
    "write_results",
    "write_run",
]

PLOT_SUFFIXES = (".png", ".svg", ".pdf")
STATE_PREFIX = "q."  # CSV columns of the coordinates: q.theta_crank, q.g_rod_1, ...

R = TypeVar("R")


def csv_text(tau: np.ndarray, values: np.ndarray, names: list[str], time_name: str = "tau") -> str:
    return rows_text(table_rows(tau, values), names, time_name)


def rows_text(rows: Iterable[Sequence[float]], names: list[str], time_name: str = "tau") -> str:
    """The CSV of ``rows`` ([time, values...] each): a header, then each number as ``repr``."""
    lines = [",".join([time_name, *names])]
    for row in rows:
        lines.append(",".join(repr(float(x)) for x in row))
    return "\n".join(lines) + "\n"


def partial_paths(out: Path) -> tuple[Path, Path]:
    out = Path(out)
    return out.with_name(out.stem + ".partial.csv"), out.with_name(out.stem + ".partial.json")


def partial_plot(plot: Path) -> Path:
    plot = Path(plot)
    return plot.with_name(plot.stem + ".partial" + plot.suffix)


class ResultFiles:
    """The files of one run: ``OUT.csv``, ``OUT.json``, ``PLOT`` and their ``.partial`` twins."""

    def __init__(self, out: str | os.PathLike[str], plot: str | os.PathLike[str] | None = None) -> None:
        self.out = Path(out)
        self.plot = None if plot is None else Path(plot)
        self.partial_written = False
        self.complete_written = False

    def complete_paths(self) -> list[Path]:
        return [self.out, self.out.with_suffix(".json")] + ([self.plot] if self.plot else [])

    def partial_paths(self) -> list[Path]:
        return [*partial_paths(self.out)] + ([partial_plot(self.plot)] if self.plot else [])

    def csv_json(self, complete: bool) -> tuple[Path, Path]:
        return (self.out, self.out.with_suffix(".json")) if complete else partial_paths(self.out)

    def plot_path(self, complete: bool) -> Path | None:
        if self.plot is None:
            return None
        return self.plot if complete else partial_plot(self.plot)

    def write(
        self,
        tau: Sequence[float] | np.ndarray,
        values: ArrayLike,
        names: list[str],
        sidecar: Mapping[str, object],
        complete: bool = True,
        time_name: str = "tau",
    ) -> Path:
        """CSV, then its JSON sidecar; return the CSV path. The first column is ``time_name``
        (``tau``, or ``t`` in seconds for SI results). Stale files of the other kind go first;
        if a write fails, neither file of this run is left."""
        rows = table_rows(np.asarray(tau), np.asarray(values).reshape(len(tau), -1))
        return self.write_rows(rows, names, sidecar, complete, time_name)

    def write_rows(
        self,
        rows: Iterable[Sequence[float]],
        names: list[str],
        sidecar: Mapping[str, object],
        complete: bool = True,
        time_name: str = "tau",
    ) -> Path:
        """:meth:`write` of the CSV's ``rows`` ([time, values...] each)."""
        csv_path, json_path = self.csv_json(complete)
        remove(self.partial_paths() if complete else self.complete_paths())
        remove([json_path])
        text = rows_text(rows, names, time_name)
        try:
            atomic_write(csv_path, text)
            atomic_write(json_path, json.dumps(sidecar, indent=1, default=_jsonable) + "\n")
        except BaseException:
            remove([csv_path, json_path])
            raise
        self.partial_written = not complete
        self.complete_written = complete
        return csv_path

    def discard(self) -> None:
        """A run failed: remove every complete result of this name, and the partial ones
        unless this run wrote them. (A failure after this run's complete CSV and JSON were
        written -- the plot -- leaves them: they are complete and correct.)"""
        if self.complete_written:
            remove([self.plot] if self.plot else [])
            return
        remove(self.complete_paths() + ([] if self.partial_written else self.partial_paths()))


def write_results(
    out: str | os.PathLike[str],
    tau: Sequence[float] | np.ndarray,
    values: ArrayLike,
    names: list[str],
    sidecar: Mapping[str, object],
    complete: bool = True,
    time_name: str = "tau",
) -> Path:
    """Write the CSV and its JSON sidecar (``ResultFiles.write``); return the CSV path written."""
    return ResultFiles(out).write(tau, values, names, sidecar, complete, time_name)


def run_files(
    out: str | os.PathLike[str],
    plot: str | os.PathLike[str] | None = None,
    out_key: str = "-o",
    plot_key: str = "--plot",
) -> ResultFiles:
    """The files of a run (``simulate``, ``quasistatic``), checked before any work (suffix, not a
    folder, its folder writable; nothing is created). ``out_key``, ``plot_key``: how the error
    names the argument."""
    out_path = check_file(out, (".csv",), out_key, also=[Path(out).with_suffix(".json"), *partial_paths(Path(out))])
    plot_path = check_file(plot, PLOT_SUFFIXES, plot_key, also=[partial_plot(Path(plot))]) if plot else None
    return ResultFiles(out_path, plot_path)


def attempt(run: Callable[[], R]) -> tuple[R | None, SimulationError | Interrupted | None]:
    """(result, failure) of ``run()``: a run that stopped early (a failure, SIGINT/SIGTERM) keeps
    its partial result (None when it had none)."""
    try:
        return run(), None
    except (SimulationError, Interrupted) as err:
        return getattr(err, "partial", None), err


def decidable(result: Any, failure: BaseException | None) -> bool:
    """A run whose outputs the run-time halves of the "auto" rules (the bar formulation, the
    axial treatment: :mod:`symgen.numerics.strain_choice`, :mod:`symgen.numerics.axial_choice`)
    may judge: a complete run, or one stopped early by a :class:`SimulationError` (the bars' range,
    a solver failure) with its partial result of at least two output samples, which they judge up
    to the stop (a run that whips beyond the model's range later must still get the model its
    first part needs: the soft triple pendulum of docs/exact-bars.md, "A run that stops early").
    Never an interrupted run (SIGINT/SIGTERM: the user stopped it)."""
    if result is None or isinstance(failure, Interrupted):
        return False
    if failure is None:
        return True
    return isinstance(failure, SimulationError) and len(getattr(result, "tau", ())) >= 2


D = TypeVar("D")


def judged(decide: Callable[[Any, Any], D | None], mech: Any, result: Any, failure: BaseException | None) -> D | None:
    """``decide(mech, result)``, the decision of an "auto" rule's run-time half, for a run it may
    judge (:func:`decidable`); None for one it may not, and for a partial run whose estimate
    cannot judge it (its own failure stands, not an internal error of the decision). A complete
    run's error in deciding is raised."""
    if not decidable(result, failure):
        return None
    try:
        return decide(mech, result)
    except Exception:
        if failure is None:
            raise
        return None


def build_sidecar(
    scene: Scene,
    compiled: CompiledModel,
    build_s: float,
    result: SimResult | QuasiStaticResult | None,
    failure: BaseException | None,
    solver: str = "idas",
) -> dict[str, Any]:
    """The JSON sidecar of a run (before ``write_run`` adds its ``units`` and ``states``): the
    scene, its model and effects, the status (``failure``: what stopped the run early), the
    solver, timings and checks. ``compiled``: the model record
    (``symgen.backends.casadi.pipeline.CompiledModel``); ``build_s``: its build (or load from the
    cache) and set-up in this process. ``solver``: "idas" (``simulate``), "c" (``simulate
    --solver c``) or "quasi-static" (``result`` a ``QuasiStaticResult``)."""
    from symgen.model.structure import axial_treatments
    from symgen.scene.motion import driver_record
    from symgen.scene.quasi import quasi_static_reasons

    sim = scene.simulation
    info = compiled.info
    sidecar: dict[str, Any] = {  # a JSON document
        "scene": str(scene.path),
        "scene_hash": scene.hash,
        "symgen_version": __version__,
        "status": ("complete" if failure is None else "interrupted" if isinstance(failure, Interrupted) else "partial"),
        "failure": None if failure is None else str(failure),
        "groups": scene.groups,
        "effects": {
            "axial": scene.effects.axial,
            "transverse": scene.effects.transverse,
            "geometric_stiffening": scene.effects.geometric_stiffening,
            "coriolis": scene.effects.coriolis,
            "rotary_inertia": scene.effects.rotary_inertia,
            "strain": scene.effects.strain,
            "gravity": list(scene.effects.gravity),
            "damping": scene.effects.damping,
        },
        "axial_treatment": {
            name: {"treatment": t.treatment, "reason": t.reason} for name, t in axial_treatments(scene).items()
        },
        "quasi_static_transverse": {
            name: {"functions": k, "reason": why} for name, (k, why) in quasi_static_reasons(scene).items()
        },
        # effects.strain as written, the bar formulation used and why (symgen.scene.strain)
        "strain": (
            scene.strain_choice.as_dict()
            if scene.strain_choice is not None
            else {
                "requested": scene.effects.strain,
                "strain": scene.effects.strain,
                "reason": "the scene's effects.strain",
                "von_karman_model_form": None,
                "output": "",
                "accuracy": None,
            }
        ),
        "accuracy": sim.accuracy,
        "bases": {c.bar: c.as_dict() for c in scene.bases},
        "modes": {name: md.to_json() for name, md in info.modes.items()},
        "driver": driver_record(scene.drivers[0]) if len(scene.drivers) == 1 else None,
        "drivers": [driver_record(d) for d in scene.drivers],
        "model_key": info.key,
        "coordinates": list(info.coordinate_names),
        "partition": None
        if result is None or result.partition is None
        else {
            "independent": [info.coords[i].name for i in result.partition.ind],
            "dependent": [info.coords[i].name for i in result.partition.dep],
            "quasi_static": [info.coords[i].name for i in result.partition.quasi],
        },
        # the tolerances of the solver that ran, and where they come from (stated, or from the
        # accuracy by that solver's rule: symgen.policy.tolerances)
        "solver": {
            "name": "idas",
            "rtol": sim.tolerances(_rule_of(solver))[0],
            "atol": sim.tolerances(_rule_of(solver))[1],
            "tolerances": sim.tolerances_reason(),
            "steps": None if result is None else result.steps,
        },
        # derive_s is this process's derivation (0 when the model came from the cache); the
        # cached entry's own derivation time is kept apart so that it is never read as this run's
        "timings": {
            "derive_s": 0.0 if compiled.cached else compiled.derive_s,
            "derive_cached": compiled.cached,
            "cached_model_derive_s": compiled.derive_s if compiled.cached else None,
            "build_s": build_s,
            "simulate_s": None if result is None else result.simulate_s,
        },
        "closure_residual_max": None if result is None else result.closure_max,
        "outputs": [
            {"name": o.name, "kind": o.kind, "body": o.body, "joint": o.joint, "at": o.xi, "component": o.component}
            for o in scene.outputs
        ],
        "t_end": sim.t_end,
        "output_step": sim.output_step,
    }
    if solver == "c":
        sidecar["solver"].update(name="radau-iia (emitted C, symgen emit-c; dense output)", backend="c")
    elif solver == "quasi-static":
        from symgen.numerics.quasistatic import QuasiStaticResult  # here: a C run never imports CasADi

        if not isinstance(result, QuasiStaticResult):
            raise TypeError(f"a quasi-static sidecar needs a QuasiStaticResult, not {type(result).__name__}")
        sidecar["analysis"] = result.analysis
        sidecar["solver"] = result.solver_info()
        sidecar["timings"]["solve_s"] = result.solve_s
        sidecar["t_end"] = float(result.tau[-1])
    elif result is not None:
        sidecar["solver"]["backend"] = result.stats.get("backend")
        # x = [q_I, v_I] of the run's partition; none (every rigid coordinate driven, every elastic
        # amplitude quasi-static): IDAS not run, each output solved by Newton (its iterations)
        sidecar["solver"]["differential_states"] = result.stats.get("differential_states")
        sidecar["solver"]["newton_iterations"] = result.stats.get("newton_iterations")
    if result is not None and solver != "quasi-static":
        from symgen.numerics.run_result import SimResult  # no CasADi: its lean home

        if isinstance(result, SimResult):
            sidecar["start"] = _start_note(result.start_forces)
            if scene.axial_switch is not None:  # effects.axial = "auto", a damped start ringing
                at = result.stats.get("axial_switch")
                sidecar["axial_switch"] = {
                    "bars": [b for b, _ in scene.axial_kept],
                    "tau": at,
                    "decided": scene.axial_switch.tau,
                    "steps": [result.stats.get("steps_before_switch"), result.stats.get("steps_after_switch")],
                    "note": (
                        "axial dynamics kept to tau, quasi-static after it (the run continued from the state reached)"
                        if at is not None
                        else "the run kept the axial dynamics for its whole length (the emitted C solver starts "
                        "only from the scene's start)"
                        if solver == "c"
                        else "the run ended before the switch: axial dynamics kept for its whole length"
                    ),
                }
            # the bars' slopes over the run: the exact bar's range warning (the same for both solvers)
            from symgen.numerics.checks import range_record
            from symgen.policy import RANGE

            # (the C solver's record kept during its run: no numpy; else from the run's q)
            maxima = result.range_maxima
            if maxima is not None and maxima[0] == RANGE.warning_limit(sim.accuracy):
                sidecar["range"] = range_record(info, (), (), sim.accuracy, maxima=maxima[1])
            else:
                sidecar["range"] = range_record(info, result.tau, result.q, sim.accuracy)
    return sidecar


def _start_note(forces: tuple[str, ...]) -> dict[str, Any]:
    """The sidecar's ``start``: what the run's first sample of the joint forces is."""
    from symgen.numerics.start import START_NOTE

    if not forces:
        return {"joint_forces": "model", "outputs": [], "note": "every output is the model's own, the first too"}
    return {"joint_forces": "continuum", "outputs": list(forces), "note": START_NOTE}


def states_block(scene: Scene, coordinates: list[str], model_key: str) -> dict[str, Any]:
    """The sidecar's ``states`` block: what ``animate --from`` needs to rebuild the geometry."""
    from symgen.model.structure import basis_sizes

    bars = {}
    for b in scene.bodies:
        na, nt = basis_sizes(scene, b)
        bars[b.name] = {
            "length": b.alpha,
            "rigid": b.rigid,
            "frame": b.frame,
            "axial": na,
            "transverse": nt,
            "axial_shapes": b.axial_shapes if na else "",
            "transverse_shapes": b.transverse_shapes if nt else "",
        }
    coords = list(coordinates)
    return {
        "columns": [STATE_PREFIX + c for c in coords],
        "coordinates": coords,
        "model_key": model_key,
        "lengths_in": "reference lengths l0",
        "bars": bars,
        "ground": _ground(scene),
    }


def _ground(scene: Scene) -> dict[str, dict[str, list[float] | None]]:
    """Ground points (and slider directions) of the joints to ground, dimensionless."""
    from symgen.scene.model import GROUND

    out = {}
    for j in scene.joints:
        for e in j.ends:
            if e.body == GROUND:
                assert e.point is not None  # a ground end has its point (the scene loader checks it)
                out[j.name] = {"point": list(e.point), "direction": None if j.direction is None else list(j.direction)}
    return out


@dataclass(frozen=True)
class OutputsPlot:
    """The plot of a run's outputs against time, as data: the application layer draws it
    (``symgen.apps.plot.plot_run``); the numerics only say what it shows."""

    path: Path
    time: np.ndarray  # the time column, in the results' units
    values: np.ndarray  # (N, n_out) in the results' units
    names: list[str]
    kinds: list[str]
    title: str
    partial: bool
    turn: float | None  # one crank turn in the time unit (a steady angle driver), else None
    units: ResultUnits


@dataclass(frozen=True)
class WrittenRun:
    """What ``write_run`` wrote: the CSV (its JSON beside it), the sidecar record, and the plot
    still to draw (None: no plot asked, or the run was interrupted: stopping fast beats a plot)."""

    csv: Path
    sidecar: dict[str, Any]  # the JSON document (as json.loads gives it back)
    plot: OutputsPlot | None


def _rule_of(solver: str) -> str:
    """The tolerance rule (``symgen.policy.tolerances``) of a run's solver: the emitted C
    solver's for "c", else IDAS's."""
    return "c" if solver == "c" else "idas"


def error_estimate(
    scene: Scene,
    compiled: CompiledModel,
    result: SimResult | QuasiStaticResult,
    failure: BaseException | None,
    solver: str,
    estimate: str = "rerun",
    mech: Mechanism | None = None,
) -> tuple[ErrorEstimate, Interrupted | None]:
    """The error estimate of a run's outputs (``symgen.numerics.error_estimate``; ``estimate``:
    its truncation method, "rerun" or "linearized", or "off"), and the interrupt that stopped it
    (the run itself is complete: its files are written, the estimate marked not estimated,
    then the interrupt is raised). Only a complete dynamic run is estimated; the record of any
    other says why not. ``mech``: the mechanism that made the run (of ``compiled`` and
    ``scene``), whose set-up the reruns reuse; else one is made."""
    from symgen.numerics.error_estimate import ErrorEstimate, estimate_errors
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.run_result import SimResult  # a quasi-static result is not one

    names = list(result.output_names)
    if not isinstance(result, SimResult) or solver == "quasi-static":
        return ErrorEstimate.not_estimated(names, "a quasi-static analysis: estimated for dynamic runs only"), None
    if failure is not None:
        return ErrorEstimate.not_estimated(names, "the run did not complete"), None
    if estimate == "off":
        return ErrorEstimate.not_estimated(names, "not asked (--estimate off)"), None
    rtol, atol = scene.simulation.tolerances(_rule_of(solver))  # the run's own
    try:
        if mech is None or mech.compiled is not compiled or mech.scene is not scene:
            mech = Mechanism(compiled, scene)
        return estimate_errors(mech, result, rtol, atol, truncation=estimate), None
    except Interrupted as stop:
        return ErrorEstimate.not_estimated(names, f"interrupted while estimating: {stop}"), stop


def write_run(
    files: ResultFiles,
    scene: Scene,
    compiled: CompiledModel,
    build_s: float,
    result: SimResult | QuasiStaticResult | None,
    failure: BaseException | None,
    solver: str = "idas",
    units: str | None = None,
    states: bool = False,
    estimate: str = "rerun",
    mech: Mechanism | None = None,
) -> WrittenRun:
    """A run's CSV and JSON sidecar (partial when the run stopped: ``failure``), columns in the
    scene's units (SI for an SI scene unless ``units="dimensionless"``), with the coordinates as
    ``q.NAME`` columns when ``states`` (for ``symgen animate --from``); and the plot to draw when
    ``files`` has one. Raises ``failure`` (or a ``SimulationError``) when there is no output to
    write. ``solver``, ``compiled``, ``build_s``: as for :func:`build_sidecar`; ``estimate``: the
    error estimate's truncation method (:func:`error_estimate`, ``mech`` the run's mechanism), in the sidecar as
    ``error_estimate`` (output -> fraction of peak, null where not estimated) and
    ``error_estimate_detail`` (its parts, methods and reasons)."""
    from symgen.numerics.units import result_units

    from symgen.numerics.run_result import SimResult

    count = 0 if result is None else result.n_rows if isinstance(result, SimResult) else len(result.tau)
    if result is None or count == 0:
        raise (
            failure
            if failure is not None
            else SimulationError(
                None, "no input position was solved" if solver == "quasi-static" else "the run produced no output"
            )
        )
    sidecar = build_sidecar(scene, compiled, build_s, result, failure, solver)
    record, stop = error_estimate(scene, compiled, result, failure, solver, estimate, mech)
    sidecar["error_estimate"] = dict(record.outputs)
    sidecar["error_estimate_detail"] = record.to_json()
    in_units = result_units(scene, units)
    sidecar["units"] = in_units.as_dict()
    names = list(result.output_names)
    if states:
        sidecar["states"] = states_block(scene, sidecar["coordinates"], sidecar["model_key"])
        clash = sorted(set(names) & set(sidecar["states"]["columns"]))
        if clash:
            raise SceneError(
                scene.path,
                f"outputs.{clash[0]}",
                "an output has the name of a state column",
                "rename the output, or leave out --states",
            )
        names += sidecar["states"]["columns"]
    complete = failure is None
    # the rows as the run holds them (a C run's record: no arrays made), in the results' units
    rows = (
        result.rows(states)
        if isinstance(result, SimResult)
        else table_rows(result.tau, result.outputs, result.q if states else None)
    )
    written = files.write_rows(in_units.convert_rows(rows), names, sidecar, complete, time_name=in_units.time.name)
    plot = None
    plot_path = files.plot_path(complete)
    if plot_path is not None and not isinstance(failure, Interrupted):  # stopping fast beats a plot
        t_col, values = in_units.convert(result.tau, result.outputs)
        # the turns of the first angle driver turning at a constant rate (as simulation.cycles);
        # a law or a ramp: plotted against tau
        drv = next((d for d in scene.angle_drivers if d.law is None and d.rate), None)
        turn = 2 * math.pi / abs(drv.rate) if drv is not None and drv.ramp is None else None
        what = "quasi-static response, " if solver == "quasi-static" else ""
        plot = OutputsPlot(
            plot_path,
            t_col,
            values,
            list(result.output_names),
            [o.kind for o in scene.outputs],
            f"{scene.name}: {what}{Path(scene.path).name}",
            partial=not complete,
            turn=None if turn is None else turn * in_units.time.factor,
            units=in_units,
        )
    if stop is not None:  # SIGINT/SIGTERM while estimating: the complete run is written
        raise stop
    return WrittenRun(written, sidecar, plot)


def _jsonable(x: object) -> object:
    if type(x).__module__ != "numpy":  # without importing numpy
        raise TypeError(f"not JSON serialisable: {type(x)}")
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x)}")
