"""Parameter sweeps: one derived model, many parameter values, run in parallel.

``--vary KEY=SPEC`` names any scene key that ``--set`` accepts (``driver.rate``,
``bodies.rod.lambda``, ``scene.omega``) and a grid: ``start:stop:n`` (evenly spaced),
``start:stop:n:log`` (geometric) or a comma list. Several ``--vary`` give the full grid.

Every point is loaded and validated up front (a bad value stops the sweep before any run, with
no output). Points are grouped by the *structure key* of their scene (symgen.model.structure): a
group is derived once, in this process, and its CasADi Functions are shipped serialised to the
workers (local processes, or Dask workers that share no disk with this machine); keys that
change the structure (mode counts, effects) form several groups, each derived once.

Each point is an independent, deterministic computation (the same Functions, the same inputs):
the table is identical whatever runs it, in any order, except the measured ``cpu_s``.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import os
import re
import signal
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from symgen.errors import SceneError, SimulationError
from symgen.outputs import printable

if TYPE_CHECKING:
    from symgen.scene.model import Scene

KEY = "--vary"
NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
MAX_POINTS = 100_000


# --------------------------------------------------------------------------- the grid
@dataclass(frozen=True)
class Vary:
    key: str  # dotted scene key, as for --set
    texts: tuple  # the values as written into the override (exact TOML numbers)
    log: bool = False

    @property
    def values(self) -> np.ndarray:
        return np.array([float(t) for t in self.texts])


def _bad(item: str, message: str, hint: str = "") -> SceneError:
    return SceneError(
        "command line",
        KEY,
        f"{item!r}: {message}",
        hint or "give KEY=start:stop:n, KEY=start:stop:n:log or KEY=v1,v2,... e.g. --vary driver.rate=0.5:3:20",
    )


def _number(text: str, item: str) -> str:
    text = text.strip()
    if not NUMBER.fullmatch(text) or not math.isfinite(float(text)):
        raise _bad(item, f"{text!r} is not a number")
    return text


def parse_vary(item: str) -> Vary:
    """``KEY=SPEC`` of ``--vary`` (see the module docstring)."""
    key, sep, spec = item.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or not key or not spec:
        raise _bad(item, "expected KEY=SPEC")
    if not re.fullmatch(r"[A-Za-z0-9_\-\[\]]+(\.[A-Za-z0-9_\-\[\]]+)*", key):
        raise _bad(item, f"{key!r} is not a dotted scene key", "use the keys of --set, e.g. bodies.rod.lambda")
    if ":" in spec:
        parts = spec.split(":")
        log = len(parts) == 4 and parts[3].strip() == "log"
        if len(parts) not in (3, 4) or (len(parts) == 4 and not log):
            raise _bad(item, f"a grid is start:stop:n or start:stop:n:log, got {spec!r}")
        start, stop = (float(_number(p, item)) for p in parts[:2])
        n_text = parts[2].strip()
        if not re.fullmatch(r"\d+", n_text) or int(n_text) < 1:
            raise _bad(item, f"the number of points must be a whole number >= 1, got {n_text!r}")
        n = int(n_text)
        if n > MAX_POINTS:
            raise _bad(item, f"{n} points is more than {MAX_POINTS}")
        if n == 1 and start != stop:
            raise _bad(item, "one point between two different ends", "give n >= 2, or a single value as a list")
        if log:
            if start <= 0 or stop <= 0:
                raise _bad(item, "a log grid needs start and stop > 0")
            vals = np.geomspace(start, stop, n)
        else:
            vals = np.linspace(start, stop, n)
        return Vary(key, tuple(repr(float(v)) for v in vals), log)
    texts = tuple(_number(t, item) for t in spec.split(","))
    return Vary(key, texts)


def vary_from(key: str, values) -> Vary:
    """A Vary from the Python API: a SPEC string or a sequence of numbers."""
    if isinstance(values, str):
        return parse_vary(f"{key}={values}")
    vals = list(np.atleast_1d(np.asarray(values)))
    if not vals:
        raise _bad(f"{key}=[]", "no values")
    texts = []
    for v in vals:
        if (
            isinstance(v, (bool, np.bool_))
            or not isinstance(v, (int, float, np.integer, np.floating))
            or not math.isfinite(float(v))
        ):
            raise _bad(f"{key}={values!r}", f"{v!r} is not a finite number")
        texts.append(str(int(v)) if isinstance(v, (int, np.integer)) else repr(float(v)))
    return parse_vary(f"{key}={','.join(texts)}")


def grid(varies: Sequence[Vary]) -> list[tuple]:
    """Points of the full grid, row-major in the order of ``varies`` (each a tuple of texts)."""
    keys = [v.key for v in varies]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise SceneError("command line", KEY, f"{dup[0]!r} is varied twice", "give each key one --vary")
    total = math.prod(len(v.texts) for v in varies)
    if total > MAX_POINTS:
        raise SceneError(
            "command line", KEY, f"the grid has {total} points (more than {MAX_POINTS})", "use fewer values"
        )
    return list(itertools.product(*(v.texts for v in varies)))


# --------------------------------------------------------------------------- one point (worker side)
@dataclass(frozen=True)
class Task:
    index: int
    scene: Any  # the point's validated Scene (shipped: workers need no scene file)
    key: str  # structure key of its model
    window: float | None  # last crank turns over which peaks are taken (None: the whole run)
    campbell: bool
    campbell_at: float
    solver: str = "idas"  # "idas" or "c" (symgen.numerics.csolver.run)


_MODELS: dict = {}  # structure key -> CompiledModel, per worker process
# One point at a time per process: CasADi is not safe to drive from several threads (plugin
# loading, Function memory), and holds the GIL anyway; a Dask worker with several threads thus
# runs its points in turn (give workers --nthreads 1 and more processes for parallel runs).
_LOCK = threading.Lock()


def model_blob(compiled) -> dict:
    """A derived model as plain data (serialised CasADi Functions + its ModelInfo's JSON) for a worker."""
    return {
        "info": compiled.info.to_json(),
        "derive_s": compiled.derive_s,
        "funcs": {name: f.serialize() for name, f in compiled.funcs.items()},
    }


def _model(key: str, blobs: Mapping[str, dict]):
    if key not in _MODELS:
        import casadi as ca

        from symgen.backends.casadi.pipeline import CompiledModel
        from symgen.ir.info import ModelInfo

        b = blobs[key]
        t0 = time.perf_counter()
        funcs = {name: ca.Function.deserialize(s) for name, s in b["funcs"].items()}
        _MODELS[key] = CompiledModel(
            funcs, ModelInfo.from_json(b["info"]), b["derive_s"], time.perf_counter() - t0, True
        )
    return _MODELS[key]


def run_point(task: Task, blobs: Mapping[str, dict]) -> dict:
    """Simulate one point; peaks of |output| and, with ``campbell``, the natural frequencies."""
    with _LOCK:
        return _run_point(task, blobs)


def _run_point(task: Task, blobs: Mapping[str, dict]) -> dict:
    from symgen.numerics.csolver import run
    from symgen.numerics.mechanism import Mechanism

    scene = task.scene
    mech = Mechanism(_model(task.key, blobs), scene)
    names = list(mech.info.outputs)
    row: dict[str, Any] = {
        "status": "ok",
        "failure": "",
        "steps": 0,
        "cpu_s": 0.0,
        "peaks": [math.nan] * len(names),
        "speed": math.nan,
        "freqs": [],
    }
    # the crank speed: the first angle driver turning at a constant rate (else the first angle driver's)
    drv = scene.turning_driver or next(iter(scene.angle_drivers), None)
    if drv is not None:
        row["speed"] = float(drv.rate)
    t0 = time.thread_time()
    try:
        res = run(mech, task.solver)
    except SimulationError as err:
        res = None
        row["status"], row["failure"] = "failed", str(err)
    row["cpu_s"] = time.thread_time() - t0
    if res is not None:
        row["steps"] = int(res.steps)
        tau, out = res.tau, res.outputs
        if task.window is not None and np.isfinite(row["speed"]) and row["speed"] != 0:
            keep = tau >= tau[-1] - task.window * 2 * math.pi / abs(row["speed"]) - 1e-12
            out = out[keep]
        row["peaks"] = [float(x) for x in np.abs(out).max(axis=0)]
    if task.campbell:
        from symgen.numerics.modes import modes

        try:
            md = modes(mech, tau=task.campbell_at, shapes=False)
            row["freqs"] = [m.natural_frequency for m in md.modes]
        except (SimulationError, ArithmeticError, ValueError, np.linalg.LinAlgError) as err:
            row["status"] = "failed" if row["status"] == "failed" else "modes failed"
            row["failure"] = (row["failure"] + "; " if row["failure"] else "") + f"modes: {err}"
    return {"index": task.index, **row}


def _init_worker(blobs: Mapping[str, dict]) -> None:
    """Local worker processes: the parent handles Ctrl-C (and stops them); keep the models."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a forked worker drops the parent's handler
    global _BLOBS
    _BLOBS = blobs


_BLOBS: Mapping[str, dict] = {}


def _run_local(task: Task) -> dict:
    return run_point(task, _BLOBS)


# --------------------------------------------------------------------------- the sweep
@dataclass
class SweepResult:
    """One row per grid point (grid order). ``columns``: name -> numpy array."""

    columns: dict
    varied: list  # varied keys, in order
    output_names: list
    structures: dict  # structure key -> number of points
    executor: str
    complete: bool = True
    notes: dict = field(default_factory=dict)
    units: str = "dimensionless"  # "SI": peaks in their SI units, speed and f<k> in Hz (speed_rpm in rpm)

    def __len__(self) -> int:
        return len(self.columns["status"])

    def frame(self):
        """The table as a pandas DataFrame (needs pandas)."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError(
                "SweepResult.frame() needs pandas: pip install pandas (or use .columns, a dict of numpy arrays)"
            ) from None
        return pd.DataFrame(self.columns)

    def frequencies(self) -> np.ndarray:
        """(points, modes) natural frequencies (NaN where a point has fewer or none)."""
        ks = sorted((c for c in self.columns if re.fullmatch(r"f\d+", c)), key=lambda c: int(c[1:]))
        return np.column_stack([self.columns[c] for c in ks]) if ks else np.zeros((len(self), 0))


def prepare(scene_path: str, varies: Sequence[Vary], overrides: Sequence[str] = ()):
    """Load every point's scene (validating it) and group the points by structure key.

    Returns (points, the scene of each point, structure key of each point, first scene by key)."""
    from symgen.scene import load_scene
    from symgen.model.structure import structure_key, structure_of

    points = grid(varies)
    keys: list[str] = []
    first: dict[str, Scene] = {}
    scenes: list[Scene] = []
    for pt in points:
        ov = list(overrides) + [f"{v.key}={t}" for v, t in zip(varies, pt)]
        try:
            scene = load_scene(scene_path, ov)
        except SceneError as err:
            raise SceneError(
                err.file,
                err.key,
                f"{err.message} (at sweep point {', '.join(f'{v.key}={t}' for v, t in zip(varies, pt))})",
                err.hint,
            ) from None
        k = structure_key(structure_of(scene))
        keys.append(k)
        scenes.append(scene)
        first.setdefault(k, scene)
    return points, scenes, keys, first


def sweep(
    scene_path: str | os.PathLike,
    varies: Sequence[Vary],
    overrides: Sequence[str] = (),
    *,
    workers: int | None = None,
    scheduler: Any = None,
    window: float | None = None,
    campbell: bool = False,
    campbell_at: float = 0.0,
    use_cache: bool = True,
    progress: bool | None = None,
    say: Callable[[str], object] | None = None,
    units: str | None = None,
    solver: str = "idas",
) -> SweepResult:
    """Run the grid of ``varies`` over the scene; see the module docstring.

    workers : local processes (default: the machine's cores; 1 runs in this process)
    scheduler : a Dask scheduler address (``tcp://host:8786``), a ``distributed.Client`` or a
        ``LocalCluster``: run there instead of on local processes
    window : peaks over the last ``window`` crank turns (skips start-up transients)
    campbell : also the natural frequencies (``modes``) at input position ``campbell_at``
    progress : a progress bar on stderr (None: only when stderr is a terminal)
    units : "SI" or "dimensionless" (default: SI for an SI scene, as ``symgen simulate``): in SI
        each point's peaks are in its outputs' SI units (its own scales: a varied key may change
        them), the crank speed and the natural frequencies in Hz, plus speed_rpm
    solver : "idas" (default) or "c": the emitted C Radau IIA solver (``--solver c``), its
        library compiled here once per model and start (points that differ in parameter values
        only share one) before the points run

    On KeyboardInterrupt (or any exception) the workers are stopped and the exception carries
    ``partial``: the SweepResult of the points done (the others have status "not run").
    """
    from symgen.backends.casadi.pipeline import compile_scene
    from symgen.numerics.solvers import check_solver

    check_solver(solver)
    scene_path = str(scene_path)
    say = say or (lambda _m: None)
    if window is not None and not window > 0:
        raise SceneError(
            "command line",
            "--window",
            f"the window must be > 0 crank turns, got {window!r}",
            "e.g. --window 1 (the last turn)",
        )
    points, scenes, keys, first = prepare(scene_path, varies, overrides)
    si = si_scales(scenes, units)
    counts = {k: keys.count(k) for k in first}
    if window is not None and any(sc.turning_driver is None for sc in first.values()):
        raise SceneError(
            "command line",
            "--window",
            "a window in crank turns needs an angle driver with a rate",
            "leave out --window: the peaks are then taken over the whole run",
        )
    if campbell:
        for sc in first.values():
            if not sc.angle_drivers:
                raise SceneError(
                    scene_path,
                    "driver",
                    "a Campbell diagram needs an angle driver (its rate is the speed)",
                    'drive the crank with [driver] kind = "angle"',
                )
    blobs, derive_note = {}, []
    for k, sc in first.items():
        compiled = compile_scene(sc, use_cache=use_cache)
        blobs[k] = model_blob(compiled)
        derive_note.append(f"{k}: {'cached' if compiled.cached else f'derived in {compiled.derive_s:.1f} s'}")
    if len(first) > 1:
        say(
            f"{len(first)} distinct model structures in the grid (the varied keys change the structure): "
            f"each derived once"
        )
    if solver == "c" and use_cache:
        _c_libraries(scenes, keys, blobs, say)
    tasks = [Task(i, scenes[i], keys[i], window, campbell, campbell_at, solver) for i in range(len(points))]
    sc0 = next(iter(first.values()))
    names = [o.name for o in sc0.outputs]
    rows: dict[int, dict] = {}
    executor = "serial"
    bar = _bar(len(tasks), progress, f"sweep {sc0.name}")
    try:
        if scheduler is not None:
            executor = "dask"
            _run_dask(tasks, blobs, scheduler, rows, bar)
        elif (workers or os.cpu_count() or 1) <= 1 or len(tasks) == 1:
            for t in tasks:
                rows[t.index] = run_point(t, blobs)
                bar.update(1)
        else:
            executor = "processes"
            _run_processes(tasks, blobs, workers or os.cpu_count() or 1, rows, bar)
    except BaseException as err:
        bar.close()
        # the rows measured so far ride on whatever stopped the sweep (an interrupt too): the CLI
        # reads them with getattr(err, "partial", None); an arbitrary exception has no such field
        err.partial = _result(  # type: ignore[attr-defined]
            varies,
            points,
            names,
            rows,
            counts,
            executor,
            complete=False,
            campbell=campbell,
            si=si,
        )
        raise
    bar.close()
    result = _result(varies, points, names, rows, counts, executor, complete=True, campbell=campbell, si=si)
    result.notes["models"] = derive_note
    result.notes["solver"] = solver
    return result


def _c_libraries(scenes: Sequence[Scene], keys: Sequence[str], blobs: Mapping[str, dict], say) -> None:
    """The C solver's library of every point, built (or found in the cache) here, before the
    points run: the workers then load it from the cache, none builds it twice. A point whose
    start fails is left to its run (which reports it)."""
    from symgen.numerics import csolver
    from symgen.numerics.mechanism import Mechanism

    built = 0
    for scene, key in zip(scenes, keys):
        try:
            _, now = csolver.library(Mechanism(_model(key, blobs), scene))
        except SimulationError:
            continue
        built += now
    if built:
        say(f"C solver: {built} librar{'y' if built == 1 else 'ies'} compiled for the grid")


def _bar(total: int, progress: bool | None, desc: str):
    from symgen.progress import progress_bar

    return progress_bar(total, desc, unit="point", enabled=progress)


def _run_processes(tasks, blobs, workers, rows, bar) -> None:
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    # fork where it is safe (Linux, no other Python thread): fast, and scripts need no
    # ``if __name__ == "__main__"`` guard; else spawn
    import sys

    method = "fork" if sys.platform.startswith("linux") and threading.active_count() == 1 else "spawn"
    before, threads = set(mp.active_children()), set(threading.enumerate())
    pool = ProcessPoolExecutor(
        max_workers=min(workers, len(tasks)),
        mp_context=mp.get_context(method),
        initializer=_init_worker,
        initargs=(blobs,),
    )
    try:
        pending = {pool.submit(_run_local, t) for t in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                r = fut.result()
                rows[r["index"]] = r
                bar.update(1)
    except BaseException:
        # stop at once: drop the queue, end the worker processes (they ignore SIGINT)
        pool.shutdown(wait=False, cancel_futures=True)
        _stop(set(mp.active_children()) - before)  # this pool's workers, however started
        # the pool's manager thread ends (pool broken); shutdown(wait=True) after a first
        # shutdown no longer joins it, so join the threads the pool started, then end any
        # worker process started meanwhile
        pool.shutdown(wait=True)
        for t in set(threading.enumerate()) - threads:
            if type(t).__module__.startswith("concurrent.futures"):
                t.join(timeout=10)
        _stop(set(mp.active_children()) - before)
        raise
    pool.shutdown(wait=True)


def _stop(procs) -> None:
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=10)
        if p.is_alive():
            p.kill()
            p.join()


def _run_dask(tasks, blobs, scheduler, rows, bar) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SceneError(
            "command line",
            "--scheduler",
            "running on a Dask cluster needs dask.distributed",
            "pip install 'symgen[distributed]'",
        ) from None
    own = not isinstance(scheduler, Client)
    if own:
        address = getattr(scheduler, "scheduler_address", scheduler)  # a LocalCluster, or its address
        try:
            client = Client(address, timeout="20s")
        except (OSError, TimeoutError) as err:
            raise SceneError(
                "command line",
                "--scheduler",
                f"cannot reach the Dask scheduler at {address!r}: {err}",
                "start one (dask scheduler; dask worker ADDRESS) or leave out --scheduler",
            ) from None
    else:
        client = scheduler
    futures = []
    try:
        shipped = client.scatter(blobs, broadcast=True, hash=False)
        futures = client.map(
            run_point,
            tasks,
            blobs=shipped,
            pure=False,
            key=[f"symgen-sweep-{t.index}-{os.getpid()}-{time.time_ns()}" for t in tasks],
        )
        for fut in as_completed(futures):
            r = fut.result()
            rows[r["index"]] = r
            bar.update(1)
    except BaseException:
        if futures:
            client.cancel(futures)
        raise
    finally:
        if own:
            client.close()


def si_scales(scenes: Sequence[Scene], units: str | None) -> list[tuple[dict, float]] | None:
    """Per point: (SI factor of each peak column, Hz per model frequency unit omega / 2 pi) when
    the table is in SI (``units``, default SI for an SI scene: symgen.numerics.units), else None.
    The factors are those of ``symgen simulate``'s SI columns for the point's own scene."""
    from symgen.numerics.units import choose_system, result_units

    if not scenes or choose_system(scenes[0], units) != "SI":
        return None
    return [
        (
            {f"peak_{c.name}": c.factor for c in result_units(sc, "SI").outputs},
            sc.omega / (2.0 * math.pi),
        )
        for sc in scenes
    ]


def _result(
    varies,
    points,
    names,
    rows: dict,
    counts: dict,
    executor: str,
    complete: bool,
    campbell: bool,
    si: list[tuple[dict, float]] | None = None,
) -> SweepResult:
    n = len(points)
    cols: dict[str, np.ndarray] = {}
    for j, v in enumerate(varies):
        cols[v.key] = np.array([float(pt[j]) for pt in points])
    get = [rows.get(i) for i in range(n)]
    cols["status"] = np.array([r["status"] if r else "not run" for r in get], dtype=object)
    cols["steps"] = np.array([r["steps"] if r else -1 for r in get], dtype=np.int64)
    cols["cpu_s"] = np.array([r["cpu_s"] if r else math.nan for r in get])
    for k, name in enumerate(names):
        cols[f"peak_{name}"] = np.array([r["peaks"][k] if r else math.nan for r in get])
    nf = max((len(r["freqs"]) for r in get if r), default=0)
    if campbell:
        cols["speed"] = np.array([r["speed"] if r else math.nan for r in get])
        for k in range(nf):
            cols[f"f{k + 1}"] = np.array([r["freqs"][k] if r and k < len(r["freqs"]) else math.nan for r in get])
    cols["failure"] = np.array([r["failure"] if r else "" for r in get], dtype=object)
    if si is not None:
        for name in names:
            cols[f"peak_{name}"] = cols[f"peak_{name}"] * np.array([f[f"peak_{name}"] for f, _ in si])
        hz = np.array([h for _, h in si])
        for c in [c for c in cols if c == "speed" or re.fullmatch(r"f\d+", c)]:
            cols[c] = cols[c] * hz
        if "speed" in cols:  # speed_rpm next to speed
            cols = dict(
                itertools.chain.from_iterable(
                    [(k, v), ("speed_rpm", v * 60.0)] if k == "speed" else [(k, v)] for k, v in cols.items()
                )
            )
    return SweepResult(
        columns=cols,
        varied=[v.key for v in varies],
        output_names=list(names),
        structures=counts,
        executor=executor,
        complete=complete,
        units="SI" if si is not None else "dimensionless",
    )


# --------------------------------------------------------------------------- writing
TABLE_SUFFIXES = (".csv", ".parquet")


def check_table_path(path: str) -> Path:
    p = Path(path)
    if p.suffix.lower() not in TABLE_SUFFIXES:
        raise SceneError(
            "command line", "-o", f"{path!r} should end in .csv or .parquet", "give a file name like out/sweep.csv"
        )
    if p.suffix.lower() == ".parquet":
        _parquet_writer()
    return p


def _parquet_writer():
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401

        return "pyarrow"
    except ImportError:
        pass
    try:
        import pandas  # noqa: F401

        return "pandas"
    except ImportError:
        raise SceneError(
            "command line",
            "-o",
            "writing Parquet needs pyarrow (or pandas with a Parquet engine)",
            "pip install 'symgen[parquet]', or write a .csv",
        ) from None


def table_csv(result: SweepResult) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    names = list(result.columns)
    w.writerow(names)
    for i in range(len(result)):
        w.writerow([_cell(result.columns[c][i]) for c in names])
    return buf.getvalue()


def _cell(x) -> str:
    if isinstance(x, (float, np.floating)):
        return repr(float(x))
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    return str(x)


def write_table(out: str | os.PathLike, result: SweepResult, meta: dict) -> Path:
    """OUT.csv|.parquet + OUT.json; a partial sweep writes OUT.partial.* and removes older OUT.*."""
    from symgen.numerics.results import atomic_write

    out = Path(out)
    partial = out.with_name(out.stem + ".partial" + out.suffix)
    final_json, partial_json = out.with_suffix(".json"), partial.with_suffix(".json")
    if result.complete:
        path, jpath = out, final_json
        for stale in (partial, partial_json):
            stale.unlink(missing_ok=True)
    else:
        path, jpath = partial, partial_json
        for stale in (out, final_json):
            stale.unlink(missing_ok=True)
    atomic_write(jpath, json.dumps(meta, indent=1) + "\n")
    if out.suffix.lower() == ".parquet":
        _write_parquet(path, result)
    else:
        atomic_write(path, table_csv(result))
    return path


def _write_parquet(path: Path, result: SweepResult) -> None:
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    os.close(fd)
    try:
        cols = {k: (v.astype(str) if v.dtype == object else v) for k, v in result.columns.items()}
        if _parquet_writer() == "pyarrow":
            import pyarrow as pa
            import pyarrow.parquet as pq

            pq.write_table(pa.table(cols), tmp)
        else:
            import pandas as pd

            pd.DataFrame(cols).to_parquet(tmp, index=False)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def sweep_meta(
    result: SweepResult,
    scene_path: str,
    varies: Sequence[Vary],
    overrides: Sequence[str],
    window: float | None,
    campbell_at: float | None,
    scene,
    stopped: str = "interrupted",
) -> dict:
    from symgen import __version__

    done = int(sum(s != "not run" for s in result.columns["status"]))
    si = result.units == "SI"
    at = f"tau = {campbell_at:g}" if campbell_at is not None else ""
    if si and campbell_at is not None:
        at += f" (t = {campbell_at / scene.omega:g} s)"
    return {
        "scene": str(scene_path),
        "symgen_version": __version__,
        "status": "complete" if result.complete else stopped,
        "points": len(result),
        "points_done": done,
        "vary": [{"key": v.key, "values": [float(t) for t in v.texts], "log": v.log} for v in varies],
        "set": list(overrides),
        "executor": result.executor,
        "structures": result.structures,
        "models": result.notes.get("models", []),
        "solver": result.notes.get("solver", "idas"),
        "columns": {
            "status": "ok | failed (the run stopped; see failure) | modes failed | not run (interrupted)",
            "steps": "integrator steps of the run (IDAS, or Radau IIA with --solver c)",
            "cpu_s": "CPU time of the run in its worker thread, s (the only column that differs between runs)",
            "peak_<output>": "max |output| over the run"
            + (f", last {window:g} crank turns" if window else "")
            + (", in the output's SI unit (see column_units)" if si else ""),
            "speed": "crank speed = driver rate x omega / 2 pi, Hz (revolutions per second)"
            if si
            else "crank speed = driver rate, units of omega",
            **({"speed_rpm": "crank speed, rpm"} if si and campbell_at is not None else {}),
            "f<k>": f"natural frequencies from modes at {at}, " + ("Hz" if si else "units of omega")
            if campbell_at is not None
            else "",
        },
        "units": "SI"
        if si
        else "dimensionless (tau = omega t)" + (f"; omega = {scene.omega:g} rad/s" if scene.units == "SI" else ""),
        "column_units": _column_units(result, scene) if si else None,
        "si_factors": None if si else _si_factors(scene),
        "window_turns": window,
    }


def _column_units(result: SweepResult, scene) -> dict:
    """The unit of each column of an SI table (the varied keys are as written in the scene)."""
    from symgen.numerics.units import result_units

    out = {f"peak_{c.name}": c.unit for c in result_units(scene, "SI").outputs}
    for c in result.columns:
        if c == "speed" or re.fullmatch(r"f\d+", c):
            out[c] = "Hz"
    if "speed_rpm" in result.columns:
        out["speed_rpm"] = "rpm"
    return out


def _si_factors(scene) -> dict | None:
    """For an SI scene: the unit and factor that turn each peak column into SI (the factors of
    ``symgen simulate``'s SI columns, symgen.numerics.units); None for a dimensionless scene,
    and for an SI table (already converted, point by point). (The swept points share the
    scene's scales unless a varied key changes them: the factors are those of the scene as
    given.)"""
    if scene.units != "SI":
        return None
    from symgen.numerics.units import result_units

    return {f"peak_{c.name}": {"unit": c.unit, "factor": c.factor} for c in result_units(scene, "SI").outputs}


# --------------------------------------------------------------------------- plots
def _x_axis(result: SweepResult, varies: Sequence[Vary]):
    key = varies[0].key
    others = [v.key for v in varies[1:]]
    return key, others


def plot_resonance(
    path: str | os.PathLike,
    result: SweepResult,
    varies: Sequence[Vary],
    kinds: Sequence[str],
    title: str,
    scene: Scene | None = None,
) -> None:
    """Peak |output| against the first varied key (one line per value of the others). An SI
    table (``result.units``) is drawn in its SI units (those of ``scene``'s outputs), and a
    varied driver.rate as the crank speed in rpm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from symgen.apps.plot import LABELS, SI_LABELS

    key, others = _x_axis(result, varies)
    si = result.units == "SI" and scene is not None
    labels, x_scale, x_label = LABELS, 1.0, key
    if si:
        assert scene is not None
        from symgen.numerics.units import result_units

        unit = {c.name: c.unit for c in result_units(scene, "SI").outputs}
        labels = {k: f"{v} ({{}})" for k, v in SI_LABELS.items()}
        if key == "driver.rate":
            x_scale, x_label = scene.omega * 60.0 / (2.0 * math.pi), "crank speed (rpm; driver.rate x omega)"
    shown = [(n, k) for n, k in zip(result.output_names, kinds) if k != "closure_residual"]
    fig, axes = plt.subplots(len(shown), 1, figsize=(7.5, 2.1 * len(shown) + 1.0), sharex=True, squeeze=False)
    groups = _groups(result, others)
    x = result.columns[key] * x_scale
    ok = np.array([s == "ok" for s in result.columns["status"]])
    for ax, (name, kind) in zip(axes[:, 0], shown):
        y = result.columns[f"peak_{name}"]
        for label, idx in groups:
            sel = idx & ok
            ax.plot(x[sel], y[sel], "o-", ms=3, lw=1, label=label or None)
            bad = idx & ~ok
            if bad.any():
                ax.plot(x[bad], np.zeros(bad.sum()), "x", color="C3", label="failed / not run")
        label = labels.get(kind, "")
        ax.set_ylabel(f"peak |{name}|\n{label.format(unit[name]) if si else label}", fontsize=8)
        ax.grid(True, lw=0.3, alpha=0.6)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        if varies[0].log:
            ax.set_xscale("log")
    if len(groups) > 1 or not ok.all():
        axes[0, 0].legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel(x_label)
    fig.suptitle(printable(title) + ("  [PARTIAL]" if not result.complete else ""), fontsize=10, parse_math=False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _groups(result: SweepResult, others: Sequence[str]) -> list:
    if not others:
        return [("", np.ones(len(result), dtype=bool))]
    combos = sorted({tuple(result.columns[k][i] for k in others) for i in range(len(result))})
    return [
        (
            ", ".join(f"{k}={v:g}" for k, v in zip(others, c)),
            np.all([result.columns[k] == v for k, v in zip(others, c)], axis=0),
        )
        for c in combos
    ]


def plot_campbell(
    path: str | os.PathLike,
    result: SweepResult,
    varies: Sequence[Vary],
    title: str,
    orders: int = 6,
    hz_per_unit: float | None = None,
) -> None:
    """Natural frequencies against the crank speed with the 1x..``orders``x excitation lines.

    x: the crank speed when it varies over the grid (else the first varied key, with the order
    lines at each point's speed); y: frequencies in units of omega (Hz for SI scenes: an SI
    table, ``result.units``, is in Hz already, and its speed axis in rpm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    F = result.frequencies()
    speed = result.columns["speed"]
    si = result.units == "SI"
    s = 1.0 if si else hz_per_unit or 1.0
    unit = "Hz" if si or hz_per_unit else r"units of $\omega$"
    varies_speed = np.nanmax(speed) > np.nanmin(speed) if np.isfinite(speed).any() else False
    if varies_speed and si:
        x, xlabel = speed * 60.0, "crank speed (rpm)"
    elif varies_speed:
        x, xlabel = speed * s, f"crank speed ({unit})"
    else:
        x, xlabel = result.columns[varies[0].key], varies[0].key
    order = np.argsort(x, kind="stable")
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    if not F.size:
        F = np.full((len(x), 1), np.nan)
    # the window: the order lines and the lowest mode; higher modes (axial ones of stiff bars
    # sit far above any excitation order) are listed, not drawn off scale
    top = np.nanmax(speed) * s * orders * 1.1 if np.isfinite(speed).any() else 1.0
    if F.size and np.isfinite(F[:, 0]).any():
        top = max(top, np.nanmax(F[:, 0]) * s * 1.1)
    above = [k for k in range(F.shape[1]) if np.isfinite(F[:, k]).any() and np.nanmin(F[:, k]) * s > top]
    if above:
        text = ", ".join(f"f{k + 1} = {np.nanmin(F[:, k]) * s:.4g}..{np.nanmax(F[:, k]) * s:.4g}" for k in above[:4])
        ax.text(
            0.99,
            0.98,
            f"above the frame: {text}" + (" ..." if len(above) > 4 else ""),
            transform=ax.transAxes,
            ha="right",
            va="top",
            fontsize=7,
            color="0.25",
        )
    # one line per mode and per value of the other varied keys (not the x axis's)
    xkey = None if varies_speed else varies[0].key
    others = [v.key for v in varies if v.key != xkey and not (varies_speed and v.key == "driver.rate")]
    styles = ("o-", "s--", "^-.", "d:")
    for g, (label, idx) in enumerate(_groups(result, others)):
        sel = order[idx[order]]
        for k in range(F.shape[1]):
            if k not in above:
                ax.plot(
                    x[sel],
                    F[sel, k] * s,
                    styles[g % len(styles)],
                    ms=3,
                    lw=1.1,
                    color=f"C{k % 10}",
                    label=f"f{k + 1}" + (f" ({label})" if label else ""),
                )
    for n in range(1, orders + 1):
        ax.plot(x[order], n * speed[order] * s, "--", lw=0.8, color="0.45")
        i = order[-1]
        if n * speed[i] * s <= top:
            ax.annotate(
                f"{n}x",
                (x[i], n * speed[i] * s),
                fontsize=7,
                color="0.3",
                xytext=(3, 0),
                textcoords="offset points",
                va="center",
            )
    ax.set_ylim(0, top)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"natural frequency ({unit})")
    ax.grid(True, lw=0.3, alpha=0.6)
    handles = ax.get_legend_handles_labels()[0]
    if 0 < len(handles) <= 12:
        ax.legend(fontsize=8, loc="upper left")
    fig.suptitle(printable(title) + ("  [PARTIAL]" if not result.complete else ""), fontsize=10, parse_math=False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
