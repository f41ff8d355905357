"""``symgen simulate --solver c``: the emitted C (``symgen emit-c``: model and Radau IIA solver)
compiled once into a cached shared library and run in this process through ctypes.

The library is cached under ``<cache root>/compiled/<entry>/`` (``solver.so`` and
``manifest.json``) like the compiled libraries of :mod:`symgen.numerics.compiled`: the entry's
name hashes the scene (without its [simulation] table: the emitted C holds the rest, e.g. the
initial guess), the derived model's structure key, the C templates and runtime, the symgen
version, the compiler's path and ``--version`` and the flags; the library's keyed hash
(``symgen.cache.seal``) is checked before it is loaded, from a private copy (never from the
shared folder), once per process.

The run: ``PREFIX_solver_init`` (the consistent start and its checks, in C) with the model's
parameters (their names checked against the library's), then ``PREFIX_solver_rows`` (dense
output: the steps are the error control's, whatever the output step; every row the collocation
polynomial at its time, the algebraic unknowns polished, the checks of an output run on it) in
calls of at most :data:`STEPS_PER_CALL` steps, so that SIGINT/SIGTERM stops the run between two
calls with the rows so far (``Interrupted.partial``, ``complete=False``), as a failure does
(``SimulationError.partial``). The rows hold the outputs and the states (q, v, lam): the result
is a ``SimResult`` like the IDAS path's (``partition`` None).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import re
import shutil
import time
import weakref
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from symgen import __version__, cache
from symgen.errors import BudgetExceeded, Interrupted, SceneError, SimulationError
from symgen.policy import POLICY, RANGE
from symgen.numerics import compiled, interrupt
from symgen.numerics.mechanism import Mechanism
from symgen.numerics.run_result import SimResult
from symgen.numerics.solvers import check_solver

if TYPE_CHECKING:
    from symgen.ir.plan import StartPlan

FORMAT = "symgen-c-solver-cache"
FORMAT_VERSION = 4  # 4: the Jacobians in a unit of their own (PREFIX_jac.c) at the cold flags; 2: keyed hashes (HMAC-SHA256 with the user's key); 3: a shared library, not an executable
LIBRARY = "solver.so"
#: Integrator steps per call into the library: between calls a SIGINT/SIGTERM stops the run
#: (a step costs 10-200 us: the run answers within tens of milliseconds)
STEPS_PER_CALL = 400
#: the values per bar of ``PREFIX_solver_range`` (``symgen.numerics.checks.C_RANGE_FIELDS``)
RANGE_FIELDS = 6
#: the counters of ``PREFIX_solver_counters``, in its order
COUNTERS = (
    *("t", "steps", "accepted", "rejected", "jacobians", "factorizations", "residuals"),
    *("closure_max", "divergence_rate", "status", "continuum_start"),
)


def emitted_key(mech: Mechanism, plan: StartPlan) -> str:
    """sha256 of what the emitted solver holds of the scene beyond its model (the structure key)
    and the parameters a run passes in (``mech.p``: any values): the start plan (partitions,
    initial guess, index sets of the start and the checks), the quasi-static start, the C prefix,
    the parameters' names, valid ranges and keys, the outputs. Scenes that differ only in
    parameter values (a sweep's points) share one library; the times and tolerances are a run's
    arguments too."""
    from symgen.backends.c.names import c_prefix
    from symgen.ir.parameters import parameter_records

    scene = mech.scene
    params = list(mech.info.params)
    data = {
        "prefix": c_prefix(scene),
        "start": dataclasses.asdict(plan),  # the partition, its quasi-static amplitudes included
        "quasi_static": bool(scene.initial.quasi_static),
        "parameters": [[r.name, r.valid.text(), r.key] for r in parameter_records(scene, params)],
        "outputs": list(mech.info.outputs),
        "units": scene.units,
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()


def templates_digest() -> str:
    """sha256 over the C templates and the C runtime (names and bytes): an edited template or
    runtime file is another executable."""
    from symgen.backends import templates

    runtime = templates.package_files("symgen.backends.c") / "runtime"  # emit.c.render.RUNTIME, without jinja2
    items = [
        item
        for folder in (templates.folder("c"), runtime)
        for item in sorted(folder.iterdir(), key=lambda e: e.name)
        if item.is_file()
    ]
    # files on disk (not in an archive): their digest is remembered in this process while none of
    # them changed (path, size, modification time, inode): a run's key without reading them again
    stamp = None
    if all(isinstance(item, Path) for item in items):
        stats = [(str(item), os.stat(item)) for item in items]  # type: ignore[arg-type]
        stamp = tuple((p, s.st_size, s.st_mtime_ns, s.st_ino) for p, s in stats)
        if stamp in _TEMPLATES_DIGEST:
            return _TEMPLATES_DIGEST[stamp]
    h = hashlib.sha256()
    for item in items:
        h.update(item.name.encode() + b"\0" + item.read_bytes() + b"\0")
    digest = h.hexdigest()
    if stamp is not None:
        _TEMPLATES_DIGEST.clear()
        _TEMPLATES_DIGEST[stamp] = digest
    return digest


_TEMPLATES_DIGEST: dict[tuple[tuple[str, int, int, int], ...], str] = {}


def _key(mech: Mechanism, plan: StartPlan, comp: compiled.Compiler) -> dict[str, object]:
    """What the library is made from (``radau``: the method's and the step control's constants,
    rendered into the C from symgen/backends/c/radau.py; ``policy``: the solver policy's tolerances
    and limits, from symgen/policy.py). ``model``: the derived model's structure key (derivation
    version, per-bar axial treatment, ...): the same scene file derives another model when
    symgen's rules change, and a library of the old model must not be loaded for it."""
    from symgen.backends.c import radau
    from symgen.backends.c.build import STRICT_C
    from symgen.model.structure import structure_key, structure_of

    known = _OF_MECHANISM.get(mech)
    if known is not None and known[0] is mech.scene and known[1] is plan:
        emitted, model = known[2], known[3]
    else:
        emitted, model = emitted_key(mech, plan), structure_key(structure_of(mech.scene))
        _OF_MECHANISM[mech] = (mech.scene, plan, emitted, model)
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "symgen": __version__,
        "emitted": emitted,
        "model": model,
        "templates": templates_digest(),
        "radau": json.loads(json.dumps(radau.constants())),  # as the manifest holds it (lists)
        "policy": POLICY.as_dict(),
        "compiler": comp.identity(),
        "strict": list(STRICT_C),
    }


#: the modules whose code makes the start plan (:func:`symgen.numerics.start.start_plan`): their
#: bytes are part of the question a remembered plan answers (:func:`_plan`)
PLAN_SOURCES = (
    *("numerics/start.py", "numerics/mechanism.py", "numerics/index1.py", "numerics/checks.py"),
    *("policy.py", "ir/plan.py", "ir/parameters.py"),
)


def _plan_question(mech: Mechanism) -> dict[str, object]:
    """What a scene's start plan is a function of: the scene (its canonical hash, after the
    overrides), its model (the structure key), symgen's version, the code that plans, and the
    quasi-static functions the loaded scene holds (each bar's count and whether symgen chose it,
    ``symgen.scene.bases.quasi_choice``: the choice's code is not in the scene's hash)."""
    root = Path(__file__).resolve().parent.parent
    code = hashlib.sha256(b"".join((root / s).read_bytes() for s in PLAN_SOURCES)).hexdigest()
    chosen = {c.bar: c.quasi for c in mech.scene.bases if c.quasi}
    return {
        "question": "c-start-plan",
        "scene": mech.scene.hash,
        "model": mech.info.key,
        "symgen": __version__,
        "code": code,
        "quasi": [[b.name, b.quasi_static_transverse, chosen.get(b.name, 0)] for b in mech.scene.bodies],
    }


#: mechanism -> (its scene, its start plan, the emitted key and the model key of that plan): a
#: mechanism's later runs (the estimate's rerun, a benchmark's repeats) neither plan nor hash again
_OF_MECHANISM: weakref.WeakKeyDictionary[Mechanism, tuple[object, StartPlan, str, str]] = weakref.WeakKeyDictionary()
#: library folder -> the key (JSON) its bytes were verified for, and those bytes, in this process
_VERIFIED: dict[Path, str] = {}
_VERIFIED_BLOB: dict[Path, bytes] = {}


def _plan(mech: Mechanism, use_cache: bool) -> StartPlan:
    """The scene's start plan (the Python start: milliseconds, and CasADi's Functions), remembered
    in the signed cache (``symgen.cache.remember``) for the same question (:func:`_plan_question`):
    a cached run of the C solver neither plans again nor imports CasADi."""
    from symgen.ir.plan import StartPlan

    memo = _OF_MECHANISM.get(mech)
    if memo is not None and memo[0] is mech.scene:
        return memo[1]
    question = _plan_question(mech) if use_cache and mech.scene.hash else None
    if question is not None:
        known, answer = cache.recall(question)
        if known:
            try:
                return StartPlan.from_json(answer)
            except (TypeError, ValueError, KeyError):
                pass  # not a plan of this symgen's: planned again, and remembered anew
    from symgen.numerics.start import start_plan

    plan = start_plan(mech)  # a scene the Python start refuses is refused here
    if question is not None:
        cache.remember(question, plan.to_json())
    return plan


class NotBuilt(Exception):
    """The scene's C solver library is not in the cache, and was not to be built (``build=False``:
    the error estimate's richer model, whose compile must not hold up a run)."""


def library(mech: Mechanism, use_cache: bool = True, build: bool = True) -> tuple[bytes, bool]:
    """The verified bytes of the scene's C solver library and whether it was built now.
    Raises SceneError (``--solver``) when no C compiler works; :class:`NotBuilt` when the
    library is not in the cache and ``build`` is False."""
    try:
        comp = compiled.compiler()
    except compiled.Unavailable as exc:
        raise _no_compiler(exc.reason) from None
    plan = _plan(mech, use_cache)
    key = _key(mech, plan, comp)
    stated = json.dumps(key, sort_keys=True)
    where = cache.compiled_dir() / ("c" + hashlib.sha256(stated.encode()).hexdigest()[:19])
    replace = False
    if use_cache and _VERIFIED.get(where) == stated and where.exists():
        return _VERIFIED_BLOB[where], False  # read and verified for this key before, in this process
    if use_cache and where.exists():
        try:
            blob = compiled.read_verified(where, key, LIBRARY)
            _VERIFIED[where], _VERIFIED_BLOB[where] = stated, blob
            return blob, False
        except cache.InvalidEntry as exc:
            compiled.report_rebuild(where, exc.reason)
            replace = True
        except FileNotFoundError:
            pass
    if not build:
        raise NotBuilt(f"the C solver of {mech.scene.name} is not built")
    return _build(mech, plan, comp, where, key, use_cache, replace), True


def _no_compiler(reason: str) -> SceneError:
    return SceneError(
        "command line",
        "--solver",
        f"c: {reason}",
        f"install a C compiler or set ${compiled.CC_ENV} to one; or leave out --solver c (IDAS)",
    )


def _build(
    mech: Mechanism,
    plan: StartPlan,
    comp: compiled.Compiler,
    where: Path,
    key: dict[str, object],
    store: bool,
    replace: bool,
) -> bytes:
    """Emit the scene's C and compile the model, its Jacobians (at the cold flags) and the solver
    (three units, in parallel, each compiler in a process group of its own) into one shared
    library."""
    from symgen.backends.c import c_context
    from symgen.backends.casadi import pipeline
    from symgen.model.derive import derive
    from symgen.model.structure import structure_key, structure_of
    from symgen.backends.c.build import STRICT_C
    from symgen.backends.c.render import JAC_UNIT, library_sources, render_files

    scene = mech.scene
    # the model this process derived for the run (a first run), else derived now
    model = pipeline.take_derived(scene, structure_key(structure_of(scene))) or derive(scene)
    ctx = c_context(scene, model, plan, info=mech.info)
    files = render_files(ctx)
    prefix = ctx["prefix"]
    parent, store = compiled.build_folder(where, store)
    with cache.temp_dir(parent, where.name) as tmp:
        src = tmp / "src"
        src.mkdir()
        for name, text in files.items():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            (src / name).write_text(text)
        units = [src / name for name in library_sources(prefix)]
        # the Jacobians (evaluated once per Jacobian update, a few dozen times a run) at the cold
        # flags: slot_dyad's 0.74 MB of them took gcc 73 s of CPU and 1.8 GB at -O1, 3.4 s at -O0
        jac = src / f"{prefix}{JAC_UNIT}.c"
        cold = compiled.cold_flags(comp)
        try:
            blob = compiled.link_units(
                comp,
                units,
                [*STRICT_C, f"-I{src}"],
                tmp / LIBRARY,
                f"the C solver in {len(units)} parts",
                "leave out --solver c to run with IDAS without compiling it",
                " on the emitted C",
                flags_of=lambda unit: cold if unit == jac else comp.flags,
            )
        except compiled.Unavailable as exc:
            raise _no_compiler(exc.reason) from None
        if store:
            shutil.rmtree(src)
            compiled.install(tmp, where, key, LIBRARY, blob, replace)
    return blob


class Solver:
    """The scene's C solver loaded in this process (ctypes) from verified library bytes, from a
    private copy (:func:`symgen.cache.load_private`). ``prefix``: the
    emitted symbols' prefix; the library's parameter names must be ``params`` (the model's
    order), its sizes ``n``, ``m``, ``nout`` the model's."""

    def __init__(self, blob: bytes, prefix: str, params: list[str], n: int, m: int, nout: int) -> None:
        import ctypes

        def load(path: Path) -> ctypes.CDLL:
            try:
                return ctypes.CDLL(str(path), mode=ctypes.RTLD_LOCAL)
            except OSError as exc:
                raise cache.InvalidEntry(f"{LIBRARY} cannot be loaded ({str(exc)[:200]})") from None

        lib = cache.load_private(blob, LIBRARY, load)
        D, L = ctypes.c_double, ctypes.c_long
        P, DP = ctypes.c_void_p, ctypes.POINTER(ctypes.c_double)

        def fn(name: str, res: object, *args: object) -> Any:
            try:
                f = getattr(lib, f"{prefix}_{name}")
            except AttributeError:
                raise cache.InvalidEntry(f"{LIBRARY} has no function {prefix}_{name}") from None
            f.restype, f.argtypes = res, list(args)
            return f

        self.lib, self.prefix = lib, prefix
        self.init = fn("solver_init", ctypes.c_int, P, DP, D, D, D)
        self.rows = fn("solver_rows", ctypes.c_int, P, D, D, L, ctypes.POINTER(L), L, L, DP)
        self.counters = fn("solver_counters", None, P, DP)
        self.range = fn("solver_range", ctypes.c_int, P, DP)
        self.range_warning = fn("solver_range_warning", None, P, D)
        self.message = fn("solver_message", ctypes.c_char_p, P)
        self.size = int(fn("solver_sizeof", ctypes.c_ulong)())
        try:
            names = (ctypes.c_char_p * max(len(params), 1)).in_dll(lib, f"{prefix}_parameter_names")
            model = (ctypes.c_int * 2).in_dll(lib, f"{prefix}_model")  # symgen_model starts with n, m
        except ValueError:
            raise cache.InvalidEntry(f"{LIBRARY} has no table {prefix}_parameter_names or {prefix}_model") from None
        got = [(names[k] or b"").decode() for k in range(len(params))]
        sizes = [model[0], model[1]]
        if got != list(params) or sizes != [n, m]:
            raise cache.InvalidEntry(f"{LIBRARY} is not this model's (parameters {got}, sizes {sizes})")
        self.stride = 1 + nout + 2 * n + m
        self.n, self.m, self.nout = n, m, nout


_LOADED: dict[str, Solver] = {}  # keyed hash of the library's bytes -> the loaded library


def solver(mech: Mechanism, use_cache: bool = True, build: bool = True) -> tuple[Solver, bool]:
    """The scene's C solver, loaded (once per process and library), and whether it was built now
    (``build=False``: :class:`NotBuilt` when it is not in the cache)."""
    blob, built = library(mech, use_cache, build)
    digest = hashlib.sha256(blob).hexdigest()
    if digest not in _LOADED:
        from symgen.backends.c.names import c_prefix

        info = mech.info
        try:
            _LOADED[digest] = Solver(blob, c_prefix(mech.scene), list(info.params), mech.n, mech.m, len(info.outputs))
        except cache.InvalidEntry as exc:
            raise _no_compiler(f"the C solver library {exc.reason}") from None
    return _LOADED[digest], built


def simulate_c(
    mech: Mechanism,
    use_cache: bool = True,
    t_end: float | None = None,
    output_step: float | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    progress: bool = False,
    build: bool = True,
    max_steps: int | None = None,
) -> SimResult:
    """The scene's run with the emitted C Radau IIA solver, in this process: outputs every
    ``output_step`` from 0 to ``t_end`` with tolerances ``rtol``, ``atol`` (None: the scene's,
    or the C solver's rule from its accuracy when it states none: ``Simulation.tolerances("c")``),
    the states with them. A run that stops early (a failure of the C solver or of a check,
    ``SimulationError``; SIGINT/SIGTERM, ``Interrupted``) raises with ``.partial``, the
    ``SimResult`` of the rows before it (``complete=False``). ``build=False``: only with a
    library already in the cache, else :class:`NotBuilt` before anything runs. ``max_steps``: a
    check run's budget of steps (``symgen.policy.rerun_budget``), checked every ``STEPS_PER_CALL``
    steps: past it the run stops with ``BudgetExceeded`` (its ``.partial`` the rows before)."""
    import ctypes

    from symgen.numerics.start import start_force_outputs

    sim = mech.scene.simulation
    t_end = float(sim.t_end if t_end is None else t_end)
    h = float(sim.output_step if output_step is None else output_step)
    rtol = float(sim.tolerances("c")[0] if rtol is None else rtol)
    atol = float(sim.tolerances("c")[1] if atol is None else atol)
    t_setup = time.perf_counter()
    try:
        lib, built = solver(mech, use_cache, build)
    except BaseException as err:
        cause = interrupt.interrupted(err, 0.0)
        if cause is err:
            raise
        raise cause from None
    setup_s = time.perf_counter() - t_setup
    warning = RANGE.warning_limit(sim.accuracy)
    n_rows = int(math.floor(t_end / h + 1e-9)) + 1
    stride = lib.stride
    rec = (ctypes.c_double * (n_rows * stride))()  # the rows, flat (zeros): no numpy on this path
    state = (ctypes.c_double * ((lib.size + 7) // 8))()
    done = ctypes.c_long(0)
    p = (ctypes.c_double * max(len(mech.p_values), 1))(*mech.p_values)
    DP = ctypes.POINTER(ctypes.c_double)
    row_bytes = stride * ctypes.sizeof(ctypes.c_double)
    tic, cpu = time.perf_counter(), time.process_time()
    rc = 0
    stop: Interrupted | SimulationError | None = None  # what ended the run early
    counts = (ctypes.c_double * len(COUNTERS))()
    try:
        with _progress(progress, n_rows) as advanced:
            rc = lib.init(state, ctypes.cast(p, DP), 0.0, rtol, atol)
            lib.range_warning(state, warning)  # the slope whose first passing the range record keeps
            while rc == 0 and done.value < n_rows:
                interrupt.check(rec[(done.value - 1) * stride] if done.value else 0.0)
                before = done.value
                at = ctypes.cast(ctypes.addressof(rec) + before * row_bytes, DP)  # the first row not written
                rc = lib.rows(state, 0.0, h, n_rows, ctypes.byref(done), 0, STEPS_PER_CALL, at)
                advanced(done.value - before)
                if rc == PAUSED:
                    rc = 0
                    if max_steps is not None and done.value < n_rows:
                        lib.counters(state, counts)
                        taken = int(dict(zip(COUNTERS, counts))["steps"])
                        if taken > max_steps:  # a check run past its budget
                            stop = BudgetExceeded(
                                rec[(done.value - 1) * stride] if done.value else 0.0, taken, max_steps
                            )
                            break
    except BaseException as err:
        cause = interrupt.interrupted(err, rec[(done.value - 1) * stride] if done.value else 0.0)
        if not isinstance(cause, Interrupted):
            raise
        stop = cause
    elapsed, cpu = time.perf_counter() - tic, time.process_time() - cpu
    lib.counters(state, counts)
    stats = dict(zip(COUNTERS, counts))
    n_bars = len(mech.info.amplitudes)
    bars = (ctypes.c_double * max(RANGE_FIELDS * n_bars, 1))()
    range_maxima = (  # over the rows written (None: not the model's bars; made from q then)
        (warning, tuple(tuple(bars[RANGE_FIELDS * g : RANGE_FIELDS * (g + 1)]) for g in range(n_bars)))
        if lib.range(state, bars) == n_bars
        else None
    )
    k = done.value
    result = SimResult.of_rows(  # its arrays made on first read (numpy), its CSV written from the rows
        rec,
        k,
        lib.nout,
        lib.n,
        lib.m,
        output_names=list(mech.info.outputs),
        closure_max=float(stats["closure_max"]),
        range_maxima=range_maxima,
        steps=int(stats["steps"]),
        simulate_s=elapsed,
        partition=None,
        complete=stop is None and rc == 0,
        # the first row's joint forces are the continuum's (the C start's symgen_continuum_start_)
        start_forces=tuple(mech.info.outputs[i] for i in start_force_outputs(mech)) if stats["continuum_start"] else (),
        stats={
            "backend": "c",
            "library": "built" if built else "cached",
            "setup_s": setup_s,
            "solve_cpu_s": cpu,
            "accepted": int(stats["accepted"]),
            "rejected": int(stats["rejected"]),
            "jacobians": int(stats["jacobians"]),
            "factorizations": int(stats["factorizations"]),
            "residuals": int(stats["residuals"]),
        },
    )
    if stop is None and rc != 0:
        msg = (lib.message(state) or b"").decode(errors="replace")
        if rc == BAD_ARGUMENT:
            raise SimulationError(None, f"the C solver refused the run: {msg}")
        msg = re.sub(r"^at tau = \S+: ", "", msg)
        stop = SimulationError(
            rec[(k - 1) * stride] if k else 0.0,
            f"the C solver stopped at tau = {stats['t']:.6g}: {msg}",
            "tighten or loosen simulation.rtol/atol, or use the IDAS path (leave out --solver c)",
        )
        if mech.quasi and k:  # the quasi-static form's mass at the last row (CasADi, at a failure only)
            from symgen.numerics.simulate import quasi_failure_at

            last = k - 1
            stop = quasi_failure_at(
                mech, rec[last * stride], result.q[last], result.v[last], result.lam[last], stop.cause
            )
    if stop is not None:
        result.failure = str(stop)
        stop.partial = result  # symgen.errors does not declare the errors' partial
        raise stop
    return result


def run(
    mech: Mechanism,
    solver: str = "idas",
    *,
    t_end: float | None = None,
    output_step: float | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    use_cache: bool = True,
    progress: bool = False,
    **idas_only: Any,
) -> SimResult:
    """One run of the scene with ``solver``: "idas" (:func:`symgen.numerics.simulate.simulate`,
    which also takes ``idas_only``: t0, initial, axial_atol, backend) or "c" (:func:`simulate_c`).
    The same result record, the same partial result on a failure or an interrupt."""
    check_solver(solver, "solver")
    if solver == "c":
        if idas_only:
            raise ValueError(f"the C solver does not take {', '.join(sorted(idas_only))} (IDAS only): leave them out")
        return simulate_c(mech, use_cache, t_end, output_step, rtol, atol, progress)
    from symgen.numerics.simulate import simulate

    return simulate(
        mech,
        t_end=t_end,
        output_step=output_step,
        rtol=rtol,
        atol=atol,
        use_cache=use_cache,
        progress=progress,
        **idas_only,
    )


#: the library's return codes (symgen_runtime.h)
FAILED, BAD_ARGUMENT, PAUSED = 1, 2, 3


@contextlib.contextmanager
def _progress(show: bool, n_rows: int) -> Iterator[Callable[[int], object]]:
    """A progress bar of the rows on stderr when ``show`` (a terminal's run), else nothing."""
    if not show:
        yield lambda k: None
        return
    from symgen.progress import progress_bar

    with progress_bar(n_rows, "simulate (C)", unit="output") as bar:
        yield bar.update
