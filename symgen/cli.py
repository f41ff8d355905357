"""The ``symgen`` command line (thin: every command calls one stage function)."""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from . import __version__
from .errors import SceneError, SimulationError, SymgenError


def _scene(args):
    from .scene import load_scene
    return load_scene(args.scene, args.set or [])


def _check_out(path: str, suffixes: tuple, key: str) -> Path:
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise SceneError("command line", key, f"{path!r} should end in {' or '.join(suffixes)}",
                         f"give a file name like out/result{suffixes[0]}")
    return p


def _prepare_run(args):
    """Check the output paths, load the scene, compile it: (out, scene, compiled, mech, build_s)."""
    from .pipeline import compile_scene
    from .run.mechanism import Mechanism

    out = _check_out(args.output, (".csv",), "-o")
    if args.plot:
        _check_out(args.plot, (".png",), "--plot")
    scene = _scene(args)
    compiled = compile_scene(scene, use_cache=not args.no_cache)
    t0 = time.perf_counter()
    mech = Mechanism(compiled, scene)
    return out, scene, compiled, mech, compiled.build_s + (time.perf_counter() - t0)


def _attempt(run):
    """(result, failure): a run that stopped early keeps its partial result."""
    try:
        return run(), None
    except SimulationError as err:
        return getattr(err, "partial", None), err


def _write_run(args, out, scene, result, meta, failure, title: str) -> Path:
    """CSV + JSON (partial when the run stopped), the plot if asked; re-raise a failure."""
    from .run.results import write_results

    written = write_results(out, result.tau, result.outputs, result.output_names, meta,
                            complete=failure is None)
    if args.plot:
        from .plot import plot_outputs
        drv = scene.driver
        turn = 2 * math.pi / abs(drv.rate) if drv is not None and drv.kind == "angle" and drv.rate else None
        plot_path = Path(args.plot)
        if failure is not None:
            plot_path = plot_path.with_name(plot_path.stem + ".partial.png")
        plot_outputs(plot_path, result.tau, result.outputs, result.output_names, [o.kind for o in scene.outputs],
                     title, partial=failure is not None, turn=turn)
    if failure is not None:
        print(f"symgen: partial result kept in {written}", file=sys.stderr)
        raise failure
    return written


def cmd_simulate(args) -> int:
    from .run.simulate import simulate

    out, scene, compiled, mech, build_s = _prepare_run(args)
    result, failure = _attempt(lambda: simulate(mech))
    meta = _sidecar(scene, compiled, build_s, result, failure)
    if result is None or len(result.tau) == 0:
        raise failure if failure is not None else SimulationError(None, "the run produced no output")
    written = _write_run(args, out, scene, result, meta, failure, f"{scene.name}: {Path(scene.path).name}")
    print(f"wrote {written} ({len(result.tau)} rows; closure residual max "
          f"{result.closure_max:.2e}; IDAS steps {result.steps}; "
          f"derive {compiled.derive_s:.2f}s{' (cached)' if compiled.cached else ''}, "
          f"simulate {result.simulate_s:.2f}s)")
    return 0


def _sidecar(scene, compiled, build_s, result, failure) -> dict:
    sim = scene.simulation
    meta = compiled.meta
    return {
        "scene": str(scene.path),
        "scene_hash": scene.hash,
        "symgen_version": __version__,
        "status": "complete" if failure is None else "partial",
        "failure": None if failure is None else str(failure),
        "groups": scene.groups,
        "effects": {
            "axial": scene.effects.axial, "transverse": scene.effects.transverse,
            "geometric_stiffening": scene.effects.geometric_stiffening,
            "coriolis": scene.effects.coriolis, "rotary_inertia": scene.effects.rotary_inertia,
            "strain": scene.effects.strain, "gravity": list(scene.effects.gravity),
            "damping": scene.effects.damping,
        },
        "modes": meta["modes"],
        "model_key": meta["key"],
        "coordinates": [c["name"] for c in meta["coords"]],
        "partition": None if result is None else {
            "independent": [meta["coords"][i]["name"] for i in result.partition.ind],
            "dependent": [meta["coords"][i]["name"] for i in result.partition.dep]},
        "solver": {"name": "idas", "rtol": sim.rtol, "atol": sim.atol,
                   "steps": None if result is None else result.steps},
        "timings": {"derive_s": compiled.derive_s, "derive_cached": compiled.cached,
                    "build_s": build_s, "simulate_s": None if result is None else result.simulate_s},
        "closure_residual_max": None if result is None else result.closure_max,
        "outputs": [{"name": o.name, "kind": o.kind, "body": o.body, "joint": o.joint, "at": o.xi,
                     "component": o.component} for o in scene.outputs],
        "t_end": sim.t_end, "output_step": sim.output_step,
    }


def cmd_latex(args) -> int:
    from .dae import derive
    from .emit.latex import latex_document
    from .run.results import atomic_write

    out = _check_out(args.output, (".tex",), "-o")
    scene = _scene(args)
    model = derive(scene)
    atomic_write(out, latex_document(scene, model))
    print(f"wrote {out}")
    return 0


def cmd_derive(args) -> int:
    from .golden import write_generated
    from .scene import load_scene

    for path in args.scenes:
        scene = load_scene(path, args.set or [])
        target = write_generated(scene, Path(args.output))
        print(f"wrote {target}")
    return 0


def cmd_study(args) -> int:
    from .run.study import run_study, write_study

    levels = None
    if args.levels:
        try:
            levels = [tuple(int(x) for x in lev.split("+")) for lev in args.levels.split(",")]
            assert all(len(lev) == 2 and min(lev) >= 0 for lev in levels)
        except (ValueError, AssertionError):
            raise SceneError("command line", "--levels", f"{args.levels!r} is not a list like 1+1,3+4,6+8",
                             "give axial+transverse mode counts, poorest first, separated by commas") from None
    tols = None
    if args.tolerances:
        try:
            tols = [float(x) for x in args.tolerances.split(",")]
        except ValueError:
            raise SceneError("command line", "--tolerances", f"{args.tolerances!r} is not a list like 1e-4,1e-6",
                             "give rtol values separated by commas") from None
    study = run_study(args.scene, args.set or [], quick=args.quick, repeats=args.repeats,
                      window_turns=args.window, cutoff_per_turn=args.cutoff, levels=levels, tolerances=tols,
                      ref_rtol=args.ref_rtol, progress=None if args.silent else print)
    for path in write_study(study, args.output):
        print(f"wrote {path}")
    return 0


def cmd_sweep(args) -> int:
    from .run.sweep import (check_table_path, parse_vary, plot_campbell, plot_resonance, sweep, sweep_meta,
                            write_table)

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
    campbell_at = args.campbell_at if args.campbell else None
    try:
        result = sweep(args.scene, varies, overrides, workers=args.workers, scheduler=args.scheduler,
                       window=args.window, campbell=bool(args.campbell), campbell_at=args.campbell_at,
                       use_cache=not args.no_cache, say=print)
    except BaseException as err:
        partial = getattr(err, "partial", None)
        if partial is not None and any(s != "not run" for s in partial.columns["status"]):
            stopped = "partial" if isinstance(err, Exception) else "interrupted"
            written = write_table(out, partial, sweep_meta(partial, args.scene, varies, overrides, args.window,
                                                           campbell_at, scene, stopped))
            print(f"symgen: partial sweep kept in {written}", file=sys.stderr)
        raise
    written = write_table(out, result, sweep_meta(result, args.scene, varies, overrides, args.window,
                                                  campbell_at, scene))
    title = f"{scene.name}: {Path(scene.path).name}"
    if args.plot:
        plot_resonance(args.plot, result, varies, [o.kind for o in scene.outputs], title)
    if args.campbell:
        hz = scene.omega / (2 * math.pi) if scene.units == "SI" else None
        plot_campbell(args.campbell, result, varies, f"{title}: Campbell diagram at tau = {args.campbell_at:g}",
                      orders=args.orders, hz_per_unit=hz)
    failed = int(sum(s != "ok" for s in result.columns["status"]))
    cpu = float(result.columns["cpu_s"].sum())
    print(f"wrote {written} ({len(result)} points on {result.executor}; {failed} not ok; "
          f"CPU {cpu:.1f} s in the runs)")
    for path in (args.plot, args.campbell):
        if path:
            print(f"wrote {path}")
    return 0


def cmd_effects(args) -> int:
    from .run.effects import DEFAULT_TOL, auto_effects, estimate_effects, measure_effects, table

    outputs = [x.strip() for x in args.outputs.split(",") if x.strip()] if args.outputs else None
    if args.auto is not None:
        if not args.auto > 0:
            raise SceneError("command line", "--auto", f"the tolerance must be > 0, got {args.auto!r}",
                             "give a relative tolerance such as 1e-3")
        if not args.output:
            raise SceneError("command line", "-o", "--auto writes the resulting scene: give -o FILE.toml",
                             "e.g. symgen effects SCENE --auto 1e-3 -o out/pruned.toml")
        _check_out(args.output, (".toml",), "-o")
        report = auto_effects(args.scene, args.set or [], tol=args.auto, output=args.output, cycles=args.cycles,
                              outputs=outputs)
    elif args.measure:
        report = measure_effects(args.scene, args.set or [], tol=args.tol or DEFAULT_TOL, cycles=args.cycles,
                                 outputs=outputs)
    else:
        report = estimate_effects(_scene(args), args.tol or DEFAULT_TOL)
    print(table(report))
    return 0


def cmd_quasistatic(args) -> int:
    from .run.quasistatic import quasi_static

    out, scene, compiled, mech, build_s = _prepare_run(args)
    result, failure = _attempt(lambda: quasi_static(mech, kinematics=args.kinematics, cycles=args.cycles))
    if result is None or len(result.tau) == 0:
        raise failure if failure is not None else SimulationError(None, "no input position was solved")
    meta = _sidecar(scene, compiled, build_s, result, failure)
    meta["analysis"] = "quasi-static response (18)-(20)"
    meta["solver"] = result.solver_info()
    meta["timings"]["solve_s"] = result.solve_s
    meta["t_end"] = float(result.tau[-1])
    written = _write_run(args, out, scene, result, meta, failure,
                         f"{scene.name}: quasi-static response, {Path(scene.path).name}")
    info = meta["solver"]
    print(f"wrote {written} ({len(result.tau)} positions; fixed-point iterations mean {info['iterations_mean']:.1f}, "
          f"max {info['iterations_max']}; Newton at {info['newton_positions']} position(s); residual max "
          f"{info['residual_max']:.2e}; closure max {result.closure_max:.2e}; {result.solve_s:.2f}s)")
    return 0


def cmd_modes(args) -> int:
    import json

    from .pipeline import compile_scene
    from .run.mechanism import Mechanism
    from .run.modes import modes, modes_json, modes_table
    from .run.results import atomic_write

    out = _check_out(args.output, (".json",), "-o") if args.output else None
    scene = _scene(args)
    compiled = compile_scene(scene, use_cache=not args.no_cache)
    result = modes(Mechanism(compiled, scene), tau=args.at)
    print(modes_table(result, scene))
    if out is not None:
        atomic_write(out, json.dumps(modes_json(result, scene, compiled.meta), indent=1) + "\n")
        print(f"wrote {out}")
    return 0


def cmd_reproduce(args) -> int:
    from .run.reproduce import reproduce

    for path in reproduce(args.output, quick=args.quick, examples=args.examples, progress=print):
        print(f"wrote {path}")
    return 0


def cmd_emit_c(args) -> int:
    from .emit.c import write_c

    scene = _scene(args)
    out = write_c(scene, args.output)
    print(f"wrote {out} (build: cmake -S {out} -B {out}/build && cmake --build {out}/build)")
    return 0


def cmd_emit_fmu(args) -> int:
    from .emit.c import write_fmu

    out = _check_out(args.output, (".fmu",), "-o")
    scene = _scene(args)
    print(f"wrote {write_fmu(scene, out)}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="symgen", description="Planar mechanisms with elastic bars: "
                                 "SymPy derivation, CasADi/IDAS simulation, LaTeX and C output.")
    ap.add_argument("--version", action="version", version=f"symgen {__version__}")
    ap.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = ap.add_subparsers(dest="command", required=True)

    def scene_cmd(name: str, help_: str):
        p = sub.add_parser(name, help=help_)
        p.add_argument("scene", help="scene file (TOML)")
        p.add_argument("--set", action="append", metavar="KEY=VALUE",
                       help="override a scene value by dotted path (repeatable)")
        return p

    p = scene_cmd("simulate", "simulate a scene with IDAS; write CSV + JSON sidecar")
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--plot", help="PNG file: outputs against tau")
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.set_defaults(func=cmd_simulate)

    p = scene_cmd("latex", "write the derived equations as a LaTeX document")
    p.add_argument("-o", "--output", required=True, help=".tex file to write")
    p.set_defaults(func=cmd_latex)

    p = sub.add_parser("derive", help="write the derived artefacts of scenes (the generated/ folder)")
    p.add_argument("scenes", nargs="+")
    p.add_argument("-o", "--output", default="generated", help="folder (default: generated)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.set_defaults(func=cmd_derive)

    p = scene_cmd("study", "accuracy vs time: sweep modes, tolerances and effects against a converged reference")
    p.add_argument("-o", "--output", required=True, help="folder for study.csv, study.md, study.png")
    p.add_argument("--quick", action="store_true", help="fewer mode levels and tolerances, no per-bar rows")
    p.add_argument("--repeats", type=int, default=3, help="timed repeats, medians reported (default 3)")
    p.add_argument("--window", type=float, default=1.0, help="early window of the pointwise error, crank turns")
    p.add_argument("--cutoff", type=float, default=50.0, help="low-pass cutoff of compared outputs, cycles per turn")
    p.add_argument("--levels", help="mode levels axial+transverse per elastic bar, e.g. 1+1,3+4,6+8 "
                                    "(the last is the reference's)")
    p.add_argument("--tolerances", help="rtol values of the sweep, e.g. 1e-4,1e-6,1e-8 (atol = rtol/100)")
    p.add_argument("--ref-rtol", type=float, default=1e-9, help="rtol of the reference (default 1e-9)")
    p.add_argument("--silent", action="store_true", help="no progress lines")
    p.set_defaults(func=cmd_study)
    p = scene_cmd("sweep", "run a grid of parameter values (one derivation, parallel runs): peaks table, "
                           "resonance plot, Campbell diagram")
    p.add_argument("--vary", action="append", required=True, metavar="KEY=SPEC",
                   help="scene key (as for --set) and values: start:stop:n, start:stop:n:log or v1,v2,... "
                        "(repeatable: full grid)")
    p.add_argument("-o", "--output", required=True, help="table to write: .csv or .parquet (+ .json sidecar)")
    p.add_argument("--plot", help="resonance plot (PNG/SVG/PDF): peak of each output against the first varied key")
    p.add_argument("--campbell", help="Campbell diagram (PNG/SVG/PDF): natural frequencies from modes against "
                                      "the crank speed, with the excitation orders; frequencies go into the table")
    p.add_argument("--campbell-at", type=float, default=0.0, metavar="TAU",
                   help="input position of the modes (default 0)")
    p.add_argument("--orders", type=int, default=6, help="excitation order lines 1x..Nx (default 6)")
    p.add_argument("--window", type=float, default=None, metavar="TURNS",
                   help="peaks over the last TURNS crank turns only (skip start-up transients)")
    p.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on this Dask distributed scheduler "
                                                          "(e.g. tcp://scheduler-host:8786) instead of local processes")
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.set_defaults(func=cmd_sweep)

    p = scene_cmd("effects", "which effects the scene needs: estimates from its groups, measured with --measure, "
                             "the smallest verified effect set with --auto TOL")
    p.add_argument("--measure", action="store_true", help="short runs with and without each effect")
    p.add_argument("--auto", type=float, metavar="TOL", help="prune effects while outputs stay within TOL "
                   "of the full model (verified by a run); write the scene with -o")
    p.add_argument("-o", "--output", help="TOML file for the scene written by --auto")
    p.add_argument("--tol", type=float, default=None, help="tolerance of the recommendations (default 1e-3)")
    p.add_argument("--cycles", type=float, default=None, help="crank turns of the measuring runs (default 1)")
    p.add_argument("--outputs", help="compare only these outputs (comma-separated names; default all but "
                                     "closure residuals)")
    p.set_defaults(func=cmd_effects)

    p = scene_cmd("quasistatic", "quasi-static response (18)-(20) over a cycle; write CSV + JSON sidecar")
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--plot", help="PNG file: outputs against tau")
    p.add_argument("--cycles", type=float, default=None, help="crank turns to cover (default 1)")
    p.add_argument("--kinematics", choices=("deformed", "rigid"), default="deformed",
                   help="closure on the deformed bars (default) or the rigid mechanism's kinematics as they are")
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.set_defaults(func=cmd_quasistatic)

    p = scene_cmd("modes", "natural frequencies and mode shapes about the quasi-static state")
    p.add_argument("--at", type=float, default=0.0, metavar="TAU", help="input position tau (default 0)")
    p.add_argument("-o", "--output", help="JSON file to write")
    p.add_argument("--no-cache", action="store_true", help="derive again, ignoring the model cache")
    p.set_defaults(func=cmd_modes)

    p = sub.add_parser("reproduce", help="the paper's figures G.1-G.12 as PNGs, with a README")
    p.add_argument("-o", "--output", required=True, help="folder to write")
    p.add_argument("--quick", action="store_true", help="coarse output step (a smoke run)")
    p.add_argument("--examples", default=None, help="folder of the example scenes (default: examples/)")
    p.set_defaults(func=cmd_reproduce)

    p = scene_cmd("emit-c", "write standalone C99 (model, Jacobians, solver, CSV driver, CMakeLists.txt)")
    p.add_argument("-o", "--output", required=True, help="folder to write")
    p.set_defaults(func=cmd_emit_c)

    p = scene_cmd("emit-fmu", "pack an FMI 2.0 Co-Simulation FMU (sources + linux64 binary)")
    p.add_argument("-o", "--output", required=True, help=".fmu file to write")
    p.set_defaults(func=cmd_emit_fmu)

    return ap


def main(argv: list[str] | None = None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    try:
        return args.func(args)
    except SymgenError as err:
        print(f"symgen: error: {err}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print("symgen: interrupted", file=sys.stderr)
        return 130
    except Exception as err:  # an internal error: say so plainly
        if args.debug:
            raise
        print(f"symgen: internal error: {type(err).__name__}: {err} (rerun with --debug for the traceback; "
              f"please report it)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
