"""The ``symgen`` command line (thin: every command calls one stage function)."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import warnings
from pathlib import Path

from symgen import __version__
from symgen.errors import Interrupted, SceneError, SymgenError
from symgen.outputs import check_file, check_folder, stale_removed_on_failure
from symgen.numerics import interrupt


def _scene(args):
    from symgen.scene import load_scene
    from symgen.scene.bases import remembered

    with remembered():  # a cached run's bases recalled, not chosen again
        return load_scene(args.scene, args.set or [])


def _check_out(path: str, suffixes: tuple, key: str, also=()) -> Path:
    """An output file checked before any work (suffix, not a folder, its folder writable)."""
    return check_file(path, suffixes, key, also)


def _say(args, text: str) -> None:
    if getattr(args, "verbose", False):
        print(f"symgen: {text}", file=sys.stderr, flush=True)


def _run_files(args):
    """The files of simulate/quasistatic, checked before any work (nothing is created)."""
    from symgen.numerics.results import run_files

    return run_files(args.output, args.plot)


@contextlib.contextmanager
def _scene_warnings():
    """Print scene warnings (loose tolerances, ...) as one plain line on stderr."""
    from symgen.scene.limits import SceneWarning

    with warnings.catch_warnings():
        previous = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, SceneWarning):
                print(f"symgen: warning: {message}", file=sys.stderr)
            else:
                previous(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def _bounded(kind=float, *, gt=None, ge=None, lt=None, le=None):
    """An argparse type: a finite ``kind`` (float or int) within the given bounds."""
    bounds = " and ".join(f"{op} {b:g}" for op, b in ((">", gt), (">=", ge), ("<", lt), ("<=", le)) if b is not None)
    wanted = f"{'an integer' if kind is int else 'a finite number'}{' ' + bounds if bounds else ''}"

    def parse(text: str):
        try:
            x = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {wanted}, got {text!r}") from None
        if not (
            math.isfinite(x)
            and (gt is None or x > gt)
            and (ge is None or x >= ge)
            and (lt is None or x < lt)
            and (le is None or x <= le)
        ):
            raise argparse.ArgumentTypeError(f"must be {wanted}, got {text!r}")
        return x

    return parse


_RTOL = _bounded(ge=1e-14, lt=1.0)  # the scene loader's range of simulation.rtol


def cmd_check(args) -> int:
    from symgen.scene.summary import summary
    from symgen.model.structure import static_points

    from symgen.numerics.strain_choice import resolved

    scene = resolved(_scene(args))  # effects.strain = "auto": with the decision a run remembered
    print(summary(scene, {b.name: static_points(scene, b) for b in scene.bodies}))
    return 0


def _prepare_run(args):
    """Load the scene, check --units against it, derive or load its model: the mechanism."""
    from symgen.numerics.mechanism import load_mechanism as mechanism  # symgen.api's, without the API's module
    from symgen.numerics.units import choose_system

    from symgen.numerics.strain_choice import resolved

    scene = resolved(_scene(args))  # effects.strain = "auto": a decision remembered for the scene
    choose_system(scene, args.units)  # before any work: --units SI needs an SI scene
    _say(args, f"loading the model of {scene.name} from the cache, or deriving it")
    # --solver c: the model's CasADi Functions read only if used (a cached C run never uses them)
    mech = mechanism(scene, use_cache=not args.no_cache, lazy=getattr(args, "solver", "idas") == "c")
    _say(
        args,
        "model loaded from the cache" if mech.compiled.cached else f"model derived in {mech.compiled.derive_s:.2f} s",
    )
    return mech


def _results_run(args, body) -> int:
    """Run ``body(files)``; if it fails or is interrupted, no result of this name from an
    earlier run is left looking complete (``ResultFiles.discard``)."""
    files = _run_files(args)
    try:
        return body(files)
    except BaseException:
        files.discard()
        raise


def _write_run(args, files, mech, result, failure, solver: str):
    """CSV, JSON (partial when the run stopped), then the plot if asked; re-raise a failure."""
    from symgen.numerics.results import write_run

    written = write_run(
        files,
        mech.scene,
        mech.compiled,
        mech.build_s,
        result,
        failure,
        solver=solver,
        units=args.units,
        states=getattr(args, "states", False),
        estimate=getattr(args, "estimate", "off"),
        mech=mech,
    )
    _say_range(written.sidecar, args.scene)
    if failure is not None:
        print(f"symgen: partial result kept in {written.csv} ({written.sidecar['status']})", file=sys.stderr)
    if written.plot is not None:
        from symgen.apps.plot import plot_run

        plot_run(written.plot)
    if failure is not None:
        raise failure
    return written


def cmd_simulate(args) -> int:
    return _results_run(args, lambda files: _simulate(args, files))


def _simulate(args, files) -> int:
    from symgen.numerics.results import attempt

    mech = _prepare_run(args)
    sc = mech.scene
    seconds = f" (t 0 -> {sc.simulation.t_end / sc.omega:.6g} s)" if sc.units == "SI" else ""
    _say(args, f"integrating tau 0 -> {sc.simulation.t_end:.6g}{seconds}")
    from symgen.numerics.mechanism import load_mechanism as mechanism
    from symgen.numerics.strain_choice import run_with_strain_choice

    def run(m):
        if args.solver == "c":
            from symgen.numerics.csolver import simulate_c

            return attempt(lambda: simulate_c(m, use_cache=not args.no_cache, progress=True))
        from symgen.numerics.simulate import simulate

        return attempt(lambda: simulate(m, backend=args.backend, use_cache=not args.no_cache, progress=True))

    # effects.strain = "auto": the von Karman run's model-form estimate may call for the exact bar
    mech, result, failure = run_with_strain_choice(
        mech,
        lambda sc: mechanism(sc, use_cache=not args.no_cache),
        run,
        lambda text: _say(args, text),
        getattr(args, "estimate", "off"),
    )
    written = _write_run(args, files, mech, result, failure, args.solver)
    assert result is not None  # write_run raises when the run has no result
    compiled = mech.compiled
    print(
        f"wrote {written.csv} ({result.n_rows} rows; closure residual max "
        f"{result.closure_max:.2e}; {_steps_text(args.solver, result)}; "
        + (
            f"model loaded from cache {mech.build_s:.2f}s, "
            if compiled.cached
            else f"derived {compiled.derive_s:.2f}s, "
        )
        + _backend_text(result.stats)
        + f"simulate {result.simulate_s:.2f}s)"
    )
    _say_raised(mech.scene)
    _say_estimate(written.sidecar, written.csv.with_suffix(".json").name, args.scene)
    return 0


def _say_raised(scene) -> None:
    """The chosen counts a run's truncation estimate raised (this run's or a remembered one's),
    and the cap where it was reached."""
    from symgen.numerics.counts_choice import cap_text

    raised = [c for c in scene.bases if c.raised]
    if not raised:
        return
    counts = ", ".join(f"{c.bar} {c.axial} + {c.transverse}" for c in raised)
    why = scene.counts_raised.reason if scene.counts_raised is not None else raised[0].raised
    print(f"chosen counts raised ({counts} axial + transverse functions): {why}")
    cap = cap_text(scene)
    if cap:
        print(f"symgen: note: {cap}; no further raise (the error estimate says what remains)", file=sys.stderr)


#: what lowers each part of the error estimate, for the warning of :func:`_say_estimate`
_ESTIMATE_ADVICE = {
    "truncation": "more shape functions: remove the bars' mode counts to let symgen choose them, or raise them",
    "model_form": 'the bar formulation: effects.strain = "exact"',
    "axial": 'keeping the bars\' axial dynamics: effects.axial = "dynamic" (the quasi-static stretch carries no inertia)',
    "time_integration": "tighter integrator tolerances (simulation.rtol, simulation.atol)",
}


def _axial_method(sidecar: dict) -> str:
    """How the run's error estimate measured its axial part (the sidecar's text; empty without)."""
    return str(((sidecar.get("error_estimate_detail") or {}).get("methods") or {}).get("axial", ""))


def _counts_all_chosen(sidecar: dict) -> bool:
    """Every elastic bar's counts chosen by symgen (the scene states none): the sidecar's bases."""
    bases = sidecar.get("bases") or {}
    return bool(bases) and all(all(b.get("chosen") or [False]) for b in bases.values())


def _richer_counts(sidecar: dict) -> str:
    """The keys that state the richer model's counts the truncation estimate ran (the sidecar's
    error_estimate_detail.richer: bar -> [axial, transverse]), else the keys to raise."""
    richer = (sidecar.get("error_estimate_detail") or {}).get("richer") or {}
    bases = sidecar.get("bases") or {}
    keys = [
        f"bodies.{bar}.axial_modes = {ax}, bodies.{bar}.transverse_modes = {tr}"
        for bar, (ax, tr) in richer.items()
        if bar in bases and (ax, tr) != (bases[bar].get("axial"), bases[bar].get("transverse"))
    ]
    if keys:
        return "e.g. the richer model's the estimate ran: " + "; ".join(keys)
    return "bodies.NAME.axial_modes and transverse_modes above the chosen ones (the sidecar's bases)"


def _say_range(sidecar: dict, scene: str) -> None:
    """The exact bar's range warnings (the sidecar's ``range``, ``symgen.numerics.checks.range_record``):
    a bar whose slope passed the accuracy's limit, and when, on stderr."""
    for warning in (sidecar.get("range") or {}).get("warnings", []):
        print(f"symgen: warning: {scene}: {warning['message']}", file=sys.stderr)


def _say_estimate(sidecar: dict, json_name: str, scene: str) -> None:
    """The run's error estimate in one line; warnings on stderr where it exceeds the accuracy
    (naming the output, the parts and what lowers the largest) and where its time-integration
    part takes more than the tenth of the accuracy the tolerances from the accuracy are chosen
    to keep (symgen.policy.tolerances)."""
    from symgen.numerics.error_estimate import BUDGET_PREFIX

    detail = sidecar.get("error_estimate_detail") or {}
    reasons = detail.get("reasons") or {}
    zero = detail.get("zero") or {}
    if zero:
        from symgen.policy import ZERO_PEAK

        listed = ", ".join(f"{n} (peak {p:.1e})" for n, p in zero.items())
        print(
            f"symgen: note: {scene}: zero to round-off over the run (at most {ZERO_PEAK:g} of its unit): {listed}; "
            f"no error estimate is given for {'it' if len(zero) == 1 else 'them'} and no choice was made on "
            f"{'it' if len(zero) == 1 else 'them'}",
            file=sys.stderr,
        )
    # the parts whose rerun was stopped at its budget: not estimated, and so no total
    stopped = {p: r for p, r in reasons.items() if isinstance(r, str) and r.startswith(BUDGET_PREFIX)}
    for part, reason in stopped.items():
        print(
            f"symgen: warning: {scene}: the error estimate's {part.replace('_', ' ')} part is not estimated, "
            f"its rerun too dear ({reason[len(BUDGET_PREFIX) :]}); the counts as chosen were kept, the results "
            f"are written; the error estimate has no total (see {json_name})",
            file=sys.stderr,
        )
    estimate = {n: v for n, v in sidecar["error_estimate"].items() if v is not None}
    if not estimate:
        if stopped:
            print(f"error estimate (fraction of peak, in {json_name}): not estimated (a rerun's budget)")
        return
    worst = max(estimate, key=lambda n: estimate[n])
    parts_of = (sidecar.get("error_estimate_detail") or {}).get("parts") or {}
    parts = {p: v.get(worst) for p, v in parts_of.items()}
    missing = sorted(p.replace("_", " ") for p, v in parts.items() if v is None)
    print(
        f"error estimate (fraction of peak, in {json_name}): largest {estimate[worst]:.1e} on {worst}"
        + (f" ({', '.join(missing)} not estimated)" if missing else "")
    )
    accuracy = sidecar.get("accuracy")
    if not accuracy:
        return
    if estimate[worst] > accuracy:
        known = {p: v for p, v in parts.items() if v is not None}
        split = ", ".join(f"{p.replace('_', ' ')} {v:.1e}" for p, v in known.items())
        largest = max(known, key=lambda p: known[p]) if known else ""
        if largest == "model_form" and (sidecar.get("strain") or {}).get("strain") == "exact":
            advice = (
                "; its largest part, the model form, is the exact bar's terms beyond fourth order in the slopes: "
                "no key of the scene lowers it (a deflection at the edge of the model)"
            )
        elif largest == "model_form" and (sidecar.get("strain") or {}).get("requested") == "auto":
            advice = (
                '; its largest part, the model form, is lowered by the exact bar: effects.strain = "exact" '
                '("auto" kept von Karman because its model-form estimate was within what the accuracy leaves beside '
                "the bases' a-priori truncation estimate and the time bound; the run's measured parts add more)"
            )
        elif (
            largest == "axial"
            and _axial_method(sidecar).startswith("the start's ringing")
            and "the quasi-static start's axial force" in _axial_method(sidecar)
        ):
            advice = (
                "; its largest part, the axial, is the quasi-static axial treatment's error over the run from the "
                "quasi-static start, read with the axial dynamics kept (docs/exact-bars.md): "
                'effects.axial = "dynamic" runs it (at the cost of resolving the axial mode)'
            )
        elif largest == "axial" and _axial_method(sidecar).startswith("the start's ringing"):
            advice = (
                "; its largest part, the axial, is the start's axial ringing (the run does not start on its "
                'quasi-static deformation): effects.axial = "dynamic" runs it (at the cost of resolving the axial '
                'mode); initial.deformation = "quasi-static" removes it where the mechanism is meant to start on '
                "its quasi-static deformation (a different start)"
            )
        elif largest == "truncation" and _counts_all_chosen(sidecar):
            advice = (
                "; its largest part, the truncation, is lowered by more shape functions: symgen chose the counts "
                "from simulation.accuracy (its a-priori estimate met it, this run's estimate does not): state more, "
                + _richer_counts(sidecar)
            )
        elif largest in _ESTIMATE_ADVICE:
            advice = f"; its largest part, the {largest.replace('_', ' ')}, is lowered by {_ESTIMATE_ADVICE[largest]}"
        else:
            advice = ""
        print(
            f"symgen: warning: {scene}: the error estimate of {worst}, {estimate[worst]:.1e} of peak ({split}), "
            f"exceeds simulation.accuracy = {accuracy:g}{advice}",
            file=sys.stderr,
        )
    timed = {n: v for n, v in (parts_of.get("time_integration") or {}).items() if v is not None}
    slowest = max(timed, key=lambda n: timed[n]) if timed else None
    if slowest is not None and timed[slowest] > accuracy / 10:
        solver = sidecar.get("solver", {})
        print(
            f"symgen: warning: {scene}: the time integration's estimated error on {slowest} is "
            f"{timed[slowest]:.1e} of peak, more than a tenth of simulation.accuracy {accuracy:g} (rtol "
            f"{solver.get('rtol')}, atol {solver.get('atol')}, {solver.get('tolerances')}): state a tighter "
            "simulation.rtol and atol",
            file=sys.stderr,
        )


def _steps_text(solver: str, result) -> str:
    """The run's steps: its integrator's, or Newton's where it had no differential states."""
    if result.stats.get("differential_states") == 0 and solver != "c":
        return f"no differential states: Newton at each output, {result.stats.get('newton_iterations')} iterations"
    return f"{'Radau IIA (C)' if solver == 'c' else 'IDAS'} steps {result.steps}"


def _backend_text(stats: dict) -> str:
    if stats.get("backend") == "c":
        how = "built" if stats.get("library") == "built" else "loaded"
        return f"C solver {how} {stats.get('setup_s', 0.0):.2f}s, "
    wait = stats.get("library_wait_s") or 0.0
    waited = f", waited {wait:.2f}s for it" if wait >= 0.01 else ""
    if stats.get("vm_until") is not None:  # started in the virtual machine while the library compiled
        return f"virtual machine to tau {stats['vm_until']:.4g} then the library compiled meanwhile, "
    if stats.get("backend") != "compiled":
        if stats.get("backend_choice") == "auto" and wait:
            return f"virtual machine while the library compiled{waited}, "
        return "virtual machine, "
    how = "built" if stats.get("library") == "built" else "loaded"
    return f"compiled library {how} {stats.get('setup_s', 0.0):.2f}s, "


def cmd_latex(args) -> int:
    from symgen.model.derive import derive
    from symgen.backends.latex.document import latex_document
    from symgen.outputs import atomic_write

    from symgen.numerics.strain_choice import resolved

    out = _check_out(args.output, (".tex",), "-o")
    scene = resolved(_scene(args))  # effects.strain = "auto": the formulation a run decided, if any
    model = derive(scene)
    atomic_write(out, latex_document(scene, model))
    print(f"wrote {out}")
    return 0


def cmd_derive(args) -> int:
    from symgen.apps.golden import write_generated
    from symgen.scene import load_scene

    check_folder(args.output, "-o")
    for path in args.scenes:
        scene = load_scene(path, args.set or [])
        target = write_generated(scene, Path(args.output))
        print(f"wrote {target}")
    return 0


def cmd_study(args) -> int:
    from symgen.apps.study import discard_study, run_study, write_study

    check_folder(args.output, "-o")
    levels = None
    if args.levels:
        try:
            levels = [tuple(int(x) for x in lev.split("+")) for lev in args.levels.split(",")]
            assert all(len(lev) == 2 and min(lev) >= 0 for lev in levels)
        except (ValueError, AssertionError):
            raise SceneError(
                "command line",
                "--levels",
                f"{args.levels!r} is not a list like 1+1,3+4,6+8",
                "give axial+transverse mode counts, poorest first, separated by commas",
            ) from None
    tols = None
    if args.tolerances:
        try:
            tols = [_RTOL(x) for x in args.tolerances.split(",")]
        except (ValueError, argparse.ArgumentTypeError):
            raise SceneError(
                "command line",
                "--tolerances",
                f"{args.tolerances!r} is not a list like 1e-4,1e-6",
                "give rtol values in [1e-14, 1) separated by commas",
            ) from None
    try:
        study = run_study(
            args.scene,
            args.set or [],
            quick=args.quick,
            repeats=args.repeats,
            window_turns=args.window,
            cutoff_per_turn=args.cutoff,
            levels=levels,
            tolerances=tols,
            ref_rtol=args.ref_rtol,
            progress=None if args.silent else _flush_print,
            solver=args.solver,
        )
    except BaseException as err:
        partial = getattr(err, "partial", None)
        if partial is not None:  # interrupted after the reference: the rows done, marked partial
            paths = write_study(partial, args.output, with_plot=False)
            print(f"symgen: partial study kept in {paths[1]} ({partial.status})", file=sys.stderr)
        else:
            discard_study(args.output)
        raise
    for path in write_study(study, args.output, fmt=args.format):
        print(f"wrote {path}")
    return 0


def _flush_print(text: str) -> None:
    print(text, flush=True)


def cmd_sweep(args) -> int:
    from symgen.apps.sweep import (
        check_table_path,
        parse_vary,
        plot_campbell,
        plot_resonance,
        sweep,
        sweep_meta,
        write_table,
    )
    from symgen.numerics.units import choose_system

    out = check_table_path(args.output)
    for path, key in ((args.plot, "--plot"), (args.campbell, "--campbell")):
        if path:
            _check_out(path, (".png", ".svg", ".pdf"), key)
    if args.workers is not None and args.workers < 1:
        raise SceneError("command line", "--workers", f"must be >= 1, got {args.workers}", "e.g. --workers 4")
    if args.orders < 1:
        raise SceneError("command line", "--orders", f"must be >= 1, got {args.orders}", "e.g. --orders 6")
    varies = [parse_vary(v) for v in args.vary]
    overrides = args.set or []
    scene = _scene(args)
    choose_system(scene, args.units)  # before any work: --units SI needs an SI scene
    campbell_at = args.campbell_at if args.campbell else None
    try:
        result = sweep(
            args.scene,
            varies,
            overrides,
            workers=args.workers,
            scheduler=args.scheduler,
            window=args.window,
            campbell=bool(args.campbell),
            campbell_at=args.campbell_at,
            use_cache=not args.no_cache,
            say=print,
            units=args.units,
            solver=args.solver,
        )
    except BaseException as err:
        partial = getattr(err, "partial", None)
        if partial is not None and any(s != "not run" for s in partial.columns["status"]):
            stopped = "partial" if isinstance(err, Exception) else "interrupted"
            written = write_table(
                out,
                partial,
                sweep_meta(partial, args.scene, varies, overrides, args.window, campbell_at, scene, stopped),
            )
            print(f"symgen: partial sweep kept in {written}", file=sys.stderr)
        raise
    written = write_table(
        out, result, sweep_meta(result, args.scene, varies, overrides, args.window, campbell_at, scene)
    )
    title = f"{scene.name}: {Path(scene.path).name}"
    if args.plot:
        plot_resonance(args.plot, result, varies, [o.kind for o in scene.outputs], title, scene)
    if args.campbell:
        hz = scene.omega / (2 * math.pi) if scene.units == "SI" else None  # a dimensionless table's
        plot_campbell(
            args.campbell,
            result,
            varies,
            f"{title}: Campbell diagram at tau = {args.campbell_at:g}"
            + (f" (t = {args.campbell_at / scene.omega:g} s)" if result.units == "SI" else ""),
            orders=args.orders,
            hz_per_unit=hz,
        )
    failed = int(sum(s != "ok" for s in result.columns["status"]))
    cpu = float(result.columns["cpu_s"].sum())
    print(f"wrote {written} ({len(result)} points on {result.executor}; {failed} not ok; CPU {cpu:.1f} s in the runs)")
    for path in (args.plot, args.campbell):
        if path:
            print(f"wrote {path}")
    return 0


def cmd_effects(args) -> int:
    from symgen.apps.effects import DEFAULT_TOL, auto_effects, estimate_effects, measure_effects, table

    outputs = [x.strip() for x in args.outputs.split(",") if x.strip()] if args.outputs else None
    if args.auto is not None:
        if not 0 < args.auto < 1:
            raise SceneError(
                "command line",
                "--auto",
                f"the tolerance must be > 0 and < 1, got {args.auto!r}",
                "give a relative tolerance such as 1e-3",
            )
        if not args.output:
            raise SceneError(
                "command line",
                "-o",
                "--auto writes the resulting scene: give -o FILE.toml",
                "e.g. symgen effects SCENE --auto 1e-3 -o out/pruned.toml",
            )
        _check_out(args.output, (".toml",), "-o")
        report = auto_effects(
            args.scene,
            args.set or [],
            tol=args.auto,
            output=args.output,
            cycles=args.cycles,
            outputs=outputs,
            solver=args.solver,
        )
    elif args.measure:
        try:
            report = measure_effects(
                args.scene,
                args.set or [],
                tol=args.tol or DEFAULT_TOL,
                cycles=args.cycles,
                outputs=outputs,
                solver=args.solver,
            )
        except Interrupted as err:
            if err.partial is not None:  # the rows measured before the signal
                print(table(err.partial), flush=True)
            raise
    else:
        from symgen.numerics.strain_choice import resolved

        # effects.strain = "auto": with the decision a run remembered
        report = estimate_effects(resolved(_scene(args)), args.tol or DEFAULT_TOL, outputs)
    print(table(report))
    return 0


def cmd_quasistatic(args) -> int:
    return _results_run(args, lambda files: _quasistatic(args, files))


def _quasistatic(args, files) -> int:
    from symgen.numerics.quasistatic import NO_POSITION, quasi_static
    from symgen.numerics.results import attempt

    try:  # a signal while the model is loaded or derived: no position solved yet
        mech = _prepare_run(args)
    except BaseException as err:
        stop = interrupt.interrupted(err)
        if not isinstance(stop, Interrupted):
            raise
        raise Interrupted(stop.signum, detail=NO_POSITION) from None
    _say(args, "solving the quasi-static positions")
    result, failure = attempt(
        lambda: quasi_static(mech, kinematics=args.kinematics, cycles=args.cycles, say=lambda line: _say(args, line))
    )
    written = _write_run(args, files, mech, result, failure, "quasi-static")
    assert result is not None  # write_run raises when the run has no result
    info = written.sidecar["solver"]
    if result.kinematics == "equilibrium":
        print(
            f"wrote {written.csv} ({len(result.tau)} positions: the static equilibrium at each (the mechanism has "
            f"free rigid coordinates); Newton steps mean {info['iterations_mean']:.1f}, max {info['iterations_max']}; "
            f"residual max {info['residual_max']:.2e}; closure max {result.closure_max:.2e}; {result.solve_s:.2f}s)"
        )
        return 0
    print(
        f"wrote {written.csv} ({len(result.tau)} positions; fixed-point iterations mean {info['iterations_mean']:.1f}, "
        f"max {info['iterations_max']}; Newton at {info['newton_positions']} position(s); residual max "
        f"{info['residual_max']:.2e}; closure max {result.closure_max:.2e}; {result.solve_s:.2f}s)"
    )
    return 0


def cmd_animate(args) -> int:
    from symgen.api import mechanism
    from symgen.apps.animate import animate, check_target, fresh_run, read_states

    out = check_target(args.output)
    for key, val in (
        ("--fps", args.fps),
        ("--frames", args.frames),
        ("--stride", args.stride),
        ("--turns", args.turns),
        ("--t-end", args.t_end),
    ):
        if val is not None and not (val > 0 and math.isfinite(val)):
            raise SceneError("command line", key, f"must be a positive number, got {val!r}", "e.g. --fps 20")
    if args.magnify is not None and not (args.magnify >= 0 and math.isfinite(args.magnify)):
        raise SceneError(
            "command line",
            "--magnify",
            f"must be >= 0, got {args.magnify!r}",
            "e.g. --magnify 50 (0: the rigid mechanism, 1: to scale)",
        )
    scene = _scene(args)
    t_end = args.t_end
    if args.turns is not None:
        drv = scene.turning_driver
        if drv is None:
            raise SceneError(
                scene.path,
                "driver",
                "--turns needs an angle driver with a nonzero rate",
                "give the end time with --t-end TAU instead",
            )
        t_end = args.turns * 2 * math.pi / abs(drv.rate)
    mech = mechanism(scene, use_cache=not args.no_cache)
    compiled = mech.compiled
    if args.from_csv:
        motion = read_states(args.from_csv, scene, compiled.info)
        if t_end is not None:
            keep = motion.tau <= motion.tau[0] + t_end + 1e-12
            motion.tau, motion.q = motion.tau[keep], motion.q[keep]
    else:
        motion = fresh_run(mech, t_end)
    info = animate(
        out,
        scene,
        compiled,
        mech,
        motion,
        factor=args.magnify,
        fps=args.fps or 20.0,
        frames=args.frames,
        stride=args.stride,
    )
    chosen = "chosen: peak elastic displacement at 10 % of l0" if args.magnify is None else "given"
    print(
        f"wrote {info['path']} ({info['frames']} frames, tau {info['tau'][0]:.4g} to {info['tau'][1]:.4g}; "
        f"deformation x {info['factor']:g} ({chosen}; peak elastic displacement {info['peak']:.3g} l0))"
    )
    return 0


def cmd_modes(args) -> int:
    import json

    from symgen.api import mechanism
    from symgen.numerics.modes import modes, modes_json, modes_table
    from symgen.outputs import atomic_write, remove

    out = _check_out(args.output, (".json",), "-o") if args.output else None
    try:
        scene = _scene(args)
        mech = mechanism(scene, use_cache=not args.no_cache)
        compiled = mech.compiled
        result = modes(mech, tau=args.at)
        print(modes_table(result, scene))
        if out is not None:
            atomic_write(out, json.dumps(modes_json(result, scene, compiled.info), indent=1) + "\n")
            print(f"wrote {out}")
    except BaseException:
        if out is not None:
            remove([out])  # no result of an earlier run left behind looking like this one's
        raise
    return 0


def cmd_schema(args) -> int:
    import json

    from symgen.numerics.results import atomic_write
    from symgen.scene.schema import json_schema, markdown

    if args.markdown:
        out = _check_out(args.markdown, (".md",), "--markdown")
        atomic_write(out, markdown())
        print(f"wrote {out}")
    text = json.dumps(json_schema(), indent=1) + "\n"
    if args.output:
        out = _check_out(args.output, (".json",), "-o")
        atomic_write(out, text)
        print(f"wrote {out}")
    elif not args.markdown:
        sys.stdout.write(text)
    return 0


def cmd_reproduce(args) -> int:
    from symgen.apps.reproduce import reproduce

    check_folder(args.output, "-o")
    for path in reproduce(args.output, quick=args.quick, examples=args.examples, progress=print, fmt=args.format):
        print(f"wrote {path}")
    return 0


def cmd_emit_c(args) -> int:
    from symgen.api import write_c

    check_folder(args.output, "-o")
    scene = _scene(args)
    out = write_c(scene, args.output)
    print(f"wrote {out} (build: cmake -S {out} -B {out}/build && cmake --build {out}/build)")
    return 0


def cmd_emit_fmu(args) -> int:
    from symgen.api import write_fmu

    out = _check_out(args.output, (".fmu",), "-o")
    scene = _scene(args)
    print(f"wrote {write_fmu(scene, out)}")
    return 0


def cmd_cache(args) -> int:
    from symgen import cache

    if args.action == "info":
        print(cache.info())
        return 0
    n, size = cache.clear()
    print(f"removed {n} cache entr{'y' if n == 1 else 'ies'} ({size / 1e6:.1f} MB) from {cache.cache_root()}")
    return 0


def _solver_option(p: argparse.ArgumentParser, what: str) -> None:
    from symgen.numerics.solvers import SOLVER_HELP, SOLVERS

    p.add_argument("--solver", choices=SOLVERS, default="idas", help=SOLVER_HELP + what)


#: The commands, in the order of ``symgen --help`` (tests/test_cli.py checks it against the parser).
COMMANDS = (
    "check",
    "simulate",
    "latex",
    "derive",
    "study",
    "sweep",
    "effects",
    "quasistatic",
    "animate",
    "modes",
    "schema",
    "reproduce",
    "emit-c",
    "emit-fmu",
    "cache",
)


class _Unbuilt:
    """The parser of a command that was not asked for: its arguments are not made (each of the
    ~15 sub-parsers costs ~1 ms of a process that runs one command)."""

    def __getattr__(self, name: str):
        return self._ignore

    def _ignore(self, *args, **kwargs):
        return self


def _asked(argv: list[str] | None) -> str | None:
    """The command ``argv`` asks for, when only its parser is needed: the first word, after any
    ``--debug``, is a command; None (all parsers) for anything else (``-h``, ``--version``, a
    mistyped command: the full parser answers, with every command listed)."""
    for word in argv or ():
        if word != "--debug":
            return word if word in COMMANDS else None
    return None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser; given ``argv``, the parser of the command it asks for only
    (the other commands named, their arguments not made: the same parse of ``argv``)."""
    only = _asked(argv)
    ap = argparse.ArgumentParser(
        prog="symgen",
        description="Planar mechanisms with elastic bars: "
        "SymPy derivation, CasADi/IDAS simulation, LaTeX and C output.",
    )
    ap.add_argument("--version", action="version", version=f"symgen {__version__}")
    ap.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    # one command's parser: its usage still lists every command (the full parser's own metavar)
    metavar = None if only is None else "{" + ",".join(COMMANDS) + "}"
    sub = ap.add_subparsers(dest="command", required=True, metavar=metavar)

    def command(name: str, **kwargs):
        return sub.add_parser(name, **kwargs) if only in (None, name) else _Unbuilt()

    def scene_cmd(name: str, help_: str):
        p = command(name, help=help_)
        p.add_argument("scene", help="scene file (TOML)")
        p.add_argument(
            "--set", action="append", metavar="KEY=VALUE", help="override a scene value by dotted path (repeatable)"
        )
        return p

    p = scene_cmd("check", "validate a scene (and --set overrides) without deriving; print a summary")
    p.set_defaults(func=cmd_check)

    p = scene_cmd("simulate", "simulate a scene with IDAS; write CSV + JSON sidecar")
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--plot", help="figure of the outputs against tau (.png, .svg or .pdf)")
    p.add_argument(
        "--states", action="store_true", help="also write the coordinates (q.NAME columns) for symgen animate --from"
    )
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.add_argument(
        "--units",
        choices=("SI", "dimensionless"),
        default=None,
        help="units of the results (default: SI for an SI scene: s, m, rad, N, N m, J; "
        "dimensionless keeps tau and the model's units)",
    )
    p.add_argument(
        "--backend",
        choices=("auto", "compiled", "vm"),
        default=None,
        help="how the model's functions run: compiled (C compiled once by the system compiler, "
        "cached; $SYMGEN_CC, $SYMGEN_CFLAGS), vm (CasADi's virtual machine, slower, same numbers) "
        "or auto (default, or $SYMGEN_BACKEND: compiled when a C compiler works, else vm, "
        "said in one line)",
    )
    _solver_option(p, "; the same CSV/JSON, --states too")
    p.add_argument(
        "--estimate",
        choices=("rerun", "linearized", "off"),
        default="rerun",
        help="the error estimate in the JSON sidecar (error_estimate: output -> fraction of peak): its "
        "truncation part by a second run of a richer model (rerun, default), the richer model "
        "linearised along the run (linearized: cheaper, low where the run rings freely), or off; where "
        "the scene states no counts of a bar and the rerun's truncation part exceeds simulation.accuracy, "
        "the run is made again with the richer counts (at most twice, remembered for the scene; only "
        "rerun decides)",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="say each stage on stderr")
    p.set_defaults(func=cmd_simulate)

    p = scene_cmd("latex", "write the derived equations as a LaTeX document")
    p.add_argument("-o", "--output", required=True, help=".tex file to write")
    p.set_defaults(func=cmd_latex)

    p = command("derive", help="write the derived artefacts of scenes (the generated/ folder)")
    p.add_argument("scenes", nargs="+")
    p.add_argument("-o", "--output", default="generated", help="folder (default: generated)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.set_defaults(func=cmd_derive)

    p = scene_cmd("study", "accuracy vs time: sweep modes, tolerances and effects against a converged reference")
    p.add_argument("-o", "--output", required=True, help="folder for study.csv, study.md, study.png")
    p.add_argument("--quick", action="store_true", help="fewer mode levels and tolerances, no per-bar rows")
    p.add_argument("--repeats", type=_bounded(int, ge=1), default=3, help="timed repeats, medians reported (default 3)")
    p.add_argument(
        "--window", type=_bounded(gt=0.0), default=1.0, help="early window of the pointwise error, crank turns"
    )
    p.add_argument(
        "--cutoff", type=_bounded(gt=0.0), default=50.0, help="low-pass cutoff of compared outputs, cycles per turn"
    )
    p.add_argument(
        "--levels", help="mode levels axial+transverse per elastic bar, e.g. 1+1,3+4,6+8 (the last is the reference's)"
    )
    p.add_argument("--tolerances", help="rtol values of the sweep, e.g. 1e-4,1e-6,1e-8 (atol = rtol/100)")
    p.add_argument("--ref-rtol", type=_RTOL, default=1e-9, help="rtol of the reference (default 1e-9)")
    p.add_argument("--silent", action="store_true", help="no progress lines")
    p.add_argument("--format", choices=("png", "svg", "pdf"), default="png", help="format of the Pareto plot")
    _solver_option(p, " (every run, the reference too)")
    p.set_defaults(func=cmd_study)
    p = scene_cmd(
        "sweep",
        "run a grid of parameter values (one derivation, parallel runs): peaks table, resonance plot, Campbell diagram",
    )
    p.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=SPEC",
        help="scene key (as for --set) and values: start:stop:n, start:stop:n:log or v1,v2,... (repeatable: full grid)",
    )
    p.add_argument("-o", "--output", required=True, help="table to write: .csv or .parquet (+ .json sidecar)")
    p.add_argument("--plot", help="resonance plot (PNG/SVG/PDF): peak of each output against the first varied key")
    p.add_argument(
        "--campbell",
        help="Campbell diagram (PNG/SVG/PDF): natural frequencies from modes against "
        "the crank speed, with the excitation orders; frequencies go into the table",
    )
    p.add_argument(
        "--campbell-at", type=float, default=0.0, metavar="TAU", help="input position of the modes (default 0)"
    )
    p.add_argument("--orders", type=int, default=6, help="excitation order lines 1x..Nx (default 6)")
    p.add_argument(
        "--window",
        type=float,
        default=None,
        metavar="TURNS",
        help="peaks over the last TURNS crank turns only (skip start-up transients)",
    )
    p.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores)")
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on this Dask distributed scheduler (e.g. tcp://scheduler-host:8786) instead of local processes",
    )
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.add_argument(
        "--units",
        choices=("SI", "dimensionless"),
        default=None,
        help="units of the table and plots (default: SI for an SI scene: peaks in m, rad, N, N m, J; "
        "speed and frequencies in Hz, speed_rpm; dimensionless keeps the model's units)",
    )
    _solver_option(p, " (every point; a library per model, shared by points that differ in values only)")
    p.set_defaults(func=cmd_sweep)

    p = scene_cmd(
        "effects",
        "which effects the scene needs: estimates from its groups, measured with --measure, "
        "the smallest verified effect set with --auto TOL",
    )
    p.add_argument("--measure", action="store_true", help="short runs with and without each effect")
    p.add_argument(
        "--auto",
        type=float,
        metavar="TOL",
        help="prune effects while outputs stay within TOL "
        "of the full model (verified by a run); write the scene with -o",
    )
    p.add_argument("-o", "--output", help="TOML file for the scene written by --auto")
    p.add_argument(
        "--tol", type=_bounded(gt=0.0, lt=1.0), default=None, help="tolerance of the recommendations (default 1e-3)"
    )
    p.add_argument(
        "--cycles", type=_bounded(gt=0.0), default=None, help="crank turns of the measuring runs (default 1)"
    )
    p.add_argument(
        "--outputs", help="compare only these outputs (comma-separated names; default all but closure residuals)"
    )
    _solver_option(p, " (the runs of --measure and --auto)")
    p.set_defaults(func=cmd_effects)

    p = scene_cmd(
        "quasistatic",
        "quasi-static response (18)-(20) over a cycle (free rigid coordinates: the static equilibrium at each position); write CSV + JSON sidecar",
    )
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--plot", help="figure of the outputs against tau (.png, .svg or .pdf)")
    p.add_argument(
        "--states", action="store_true", help="also write the coordinates (q.NAME columns) for symgen animate --from"
    )
    p.add_argument("--cycles", type=_bounded(gt=0.0), default=None, help="crank turns to cover (default 1)")
    p.add_argument(
        "--units",
        choices=("SI", "dimensionless"),
        default=None,
        help="units of the results (default: SI for an SI scene; dimensionless keeps tau)",
    )
    p.add_argument(
        "--kinematics",
        choices=("deformed", "rigid"),
        default="deformed",
        help="closure on the deformed bars (default) or the rigid mechanism's kinematics as they are",
    )
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.add_argument("-v", "--verbose", action="store_true", help="say each stage on stderr")
    p.set_defaults(func=cmd_quasistatic)

    p = scene_cmd(
        "animate", "the mechanism moving, deformation magnified: a GIF or MP4 from a fresh run or a run's CSV"
    )
    p.add_argument("-o", "--output", required=True, help=".gif (Pillow) or .mp4 (needs ffmpeg) file to write")
    p.add_argument(
        "--from",
        dest="from_csv",
        metavar="RUN.csv",
        help="animate a run written by symgen simulate ... --states (default: run the scene now)",
    )
    p.add_argument(
        "--magnify",
        type=float,
        default=None,
        metavar="F",
        help="deformation scale factor (default: peak elastic displacement drawn at 10 %% of the reference length)",
    )
    p.add_argument("--fps", type=float, default=None, help="frames per second (default 20)")
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--frames",
        type=int,
        default=None,
        help="number of frames, evenly spaced over the run (default: every output row, at most 150)",
    )
    g.add_argument("--stride", type=int, default=None, help="use every STRIDE-th output row")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--turns", type=float, default=None, help="crank turns to show (angle driver)")
    g.add_argument("--t-end", dest="t_end", type=float, default=None, help="end time in tau")
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.set_defaults(func=cmd_animate)

    p = scene_cmd(
        "modes",
        "natural frequencies and mode shapes about the quasi-static state (free rigid coordinates: about the static equilibrium)",
    )
    p.add_argument(
        "--at",
        type=_bounded(ge=-1e3, le=1e3),
        default=0.0,
        metavar="TAU",
        help="input position tau, |TAU| <= 1000 (default 0)",
    )
    p.add_argument("-o", "--output", help="JSON file to write")
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.set_defaults(func=cmd_modes)

    p = command("schema", help="the scene-file schema: JSON Schema for editors, or the Markdown reference")
    p.add_argument("-o", "--output", help="JSON file to write (default: print the JSON Schema)")
    p.add_argument("--markdown", metavar="FILE.md", help="write the scene reference (docs/scene-format.md)")
    p.set_defaults(func=cmd_schema)

    p = command("reproduce", help="the paper's figures G.1-G.12 as PNGs, with a README")
    p.add_argument("-o", "--output", required=True, help="folder to write")
    p.add_argument("--quick", action="store_true", help="coarse output step (a smoke run)")
    p.add_argument("--examples", default=None, help="folder of the example scenes (default: examples/)")
    p.add_argument("--format", choices=("png", "svg", "pdf"), default="png", help="format of the figures")
    p.set_defaults(func=cmd_reproduce)

    p = scene_cmd("emit-c", "write standalone C99 (model, Jacobians, solver, CSV driver, CMakeLists.txt)")
    p.add_argument("-o", "--output", required=True, help="folder to write")
    p.set_defaults(func=cmd_emit_c)

    p = scene_cmd("emit-fmu", "pack an FMI 2.0 Co-Simulation FMU (sources + linux64 binary)")
    p.add_argument("-o", "--output", required=True, help=".fmu file to write")
    p.set_defaults(func=cmd_emit_fmu)

    p = command(
        "cache",
        help="the derived-model and shape caches ($SYMGEN_CACHE_DIR, default "
        "~/.cache/symgen): info shows location, entries, sizes; clear removes them",
    )
    p.add_argument("action", choices=("info", "clear"))
    p.set_defaults(func=cmd_cache)

    return ap


#: BLAS threads of a command's process (numpy's OpenBLAS), unless the environment says otherwise:
#: symgen's dense matrices are small (a bar's reference FE model, the modes of a mechanism), where
#: threads only spin: one thread saves ~0.05 s of CPU of a cached ``simulate --solver c`` process
#: (0.29 against 0.34 s; benchmarks/bench_exudyn.py). Set before numpy is first imported.
BLAS_THREADS = {"OPENBLAS_NUM_THREADS": "1"}


def main(argv: list[str] | None = None) -> int:
    """Run one command. Exit codes: 0 done, 2 a user-facing error (bad input, a run that
    failed: message names the file/key or tau), 3 an internal error, 130 / 143 stopped by
    SIGINT / SIGTERM (a partial result kept, marked "interrupted")."""
    for key, value in BLAS_THREADS.items():
        os.environ.setdefault(key, value)
    try:
        with interrupt.handling():  # first: a signal from here on is reported and cleans up
            args = None
            try:
                with contextlib.ExitStack() as stack:
                    with interrupt.deferred():  # ... once the command's outputs are known
                        args = build_parser(sys.argv[1:] if argv is None else argv).parse_args(argv)
                        stack.enter_context(_scene_warnings())
                        stack.enter_context(stale_removed_on_failure(_output_files(args)))
                    interrupt.check()  # a signal while the command line was read
                    return args.func(args)
            except BaseException as err:
                return _report(err, args)
    except KeyboardInterrupt as err:  # a signal before the command began, or while reporting one
        return getattr(err, "exit_code", 130)


def _output_files(args) -> list[Path]:
    """The files the command of ``args`` writes (a failed or interrupted run leaves none of an
    earlier run's behind: ``outputs.stale_removed_on_failure``). Folders of files (emit-c,
    derive, reproduce) are written all or nothing by their commands."""
    out = getattr(args, "output", None)
    if out is None:
        return []
    out = Path(out)
    cmd = args.func
    if cmd is cmd_sweep:
        return [out, out.with_suffix(".json"), *(Path(x) for x in (args.plot, args.campbell) if x)]
    if cmd in (cmd_simulate, cmd_quasistatic):
        from symgen.numerics.results import ResultFiles

        return ResultFiles(out, args.plot).complete_paths()
    if cmd is cmd_study:
        from symgen.apps.study import study_paths

        return [p for fmt in ("png", "svg", "pdf") for p in study_paths(out, True, fmt)]
    if cmd in (cmd_latex, cmd_effects, cmd_animate, cmd_modes, cmd_schema, cmd_emit_fmu):
        return [out]
    return []


def _report(err: BaseException, args) -> int:
    if isinstance(err, SystemExit):
        raise err
    stop = interrupt.interrupted(err)  # any failure while a signal is pending is the interrupt
    if isinstance(stop, KeyboardInterrupt):
        print(f"symgen: {stop if isinstance(stop, Interrupted) else 'interrupted'}", file=sys.stderr)
        return getattr(stop, "exit_code", 130)
    if isinstance(err, SymgenError):
        print(f"symgen: error: {err}", file=sys.stderr)
        return err.exit_code
    if isinstance(err, Exception):  # an internal error: say so plainly
        if args is not None and args.debug:
            raise err
        print(
            f"symgen: internal error: {type(err).__name__}: {err} (rerun with --debug for the traceback; "
            f"please report it)",
            file=sys.stderr,
        )
        return 3
    raise err


if __name__ == "__main__":
    sys.exit(main())
