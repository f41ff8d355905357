"""Benchmark section ``compile`` (issue 20, item 4): the first run of open chains of 2-12 elastic
bars (derivation, the compiled library's build, the simulation), before and after the library
was split into translation units compiled in parallel; the compile time against the flags and
the sizes of the biggest Functions.

*Before* is the tree of :data:`BASE` (one translation unit, one compiler), taken with
``git archive`` into a temporary folder; *after* is this checkout. The chains are those of the
``derivation`` section (``bench_derivation.scene_text``: a driven ground pin, 2 axial and 4
transverse modes per bar, one cycle).

1. First run: ``python -m symgen.cli simulate CHAIN -o out.csv`` in a fresh process with an
   empty model cache: wall and CPU (user + system of the process and its compilers), and the
   parts the command reports (derived, compiled library built, simulate).
2. Compile alone: the library's Functions written as C by CasADi, compiled as one unit (before)
   and as one unit per Function, as many at once as there are cores (after), at -O0, -O1 (the
   default) and -O2 (always with ``-ffp-contract=off``), wall and CPU; and the largest Functions
   (operations, kB of C) with their compile time alone at -O1.

    python benchmarks/run.py --only compile
"""

from __future__ import annotations

import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_derivation import scene_text
from bench_lean import base_tree as _lean_base_tree

ROOT = Path(__file__).resolve().parent.parent
#: The commit before the split into parallel translation units.
BASE = "8bcc5b0"
BARS = (2, 4, 6, 8, 10, 12)
FLAGS = ("-O0", "-O1", "-O2")
TARGET_S = 5.0
PARTS = re.compile(r"derived ([\d.]+)s, compiled library built ([\d.]+)s, simulate ([\d.]+)s")
#: the line of a first run that starts in the virtual machine while the library compiles
PARTS_VM = re.compile(r"derived ([\d.]+)s, virtual machine[^,]*(?:, waited ([\d.]+)s for it)?, simulate ([\d.]+)s")
#: the profiled parts of a first run: (label, module file suffix, function name)
PROFILED = (
    ("derive (SymPy, every model)", "symgen/model/derive.py", "derive"),
    ("simulate (every run)", "symgen/numerics/simulate.py", "simulate"),
    ("  waiting for a library", "symgen/numerics/simulate.py", "settle"),
    ("error estimate", "symgen/numerics/error_estimate.py", "estimate_errors"),
    ("  richer model: derive", "symgen/numerics/error_estimate.py", "richer_mechanism"),
    ("  richer model: rerun", "symgen/numerics/error_estimate.py", "_rerun"),
    ("  the run's model at tighter tolerances", "symgen/numerics/error_estimate.py", "_tight"),
    (
        "model-form estimate (the strain decision's and the estimate's)",
        "symgen/numerics/model_form.py",
        "model_form_estimate",
    ),
)


def base_tree(dest: Path) -> bool:
    return _lean_base_tree(dest, BASE)


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def first_run(
    tree: Path, scene: Path, tmp: Path, cflags: str | None = None, extra: tuple[str, ...] = ()
) -> dict[str, float]:
    """Wall and CPU s of a first run (empty cache) of ``scene`` with ``tree`` first on the path
    (``cflags``: ``$SYMGEN_CFLAGS``, else the default; ``extra``: more arguments of ``simulate``, e.g. ``--set KEY=VALUE``)."""
    with tempfile.TemporaryDirectory(dir=tmp) as cache:
        env = dict(os.environ, PYTHONPATH=str(tree), SYMGEN_CACHE_DIR=cache)
        for name in ("SYMGEN_BACKEND", "SYMGEN_CFLAGS", "SYMGEN_CC"):
            env.pop(name, None)
        if cflags is not None:
            env["SYMGEN_CFLAGS"] = cflags
        cmd = [sys.executable, "-m", "symgen.cli", "simulate", str(scene), "-o", str(tmp / "out.csv")]
        cmd += extra
        c0, t0 = _child_cpu(), time.perf_counter()
        proc = subprocess.run(cmd, cwd=tmp, env=env, capture_output=True, text=True, check=True)
        wall, cpu = time.perf_counter() - t0, _child_cpu() - c0
    m = PARTS.search(proc.stdout + proc.stderr)
    parts = dict(zip(("derive", "library", "simulate"), map(float, m.groups()))) if m else {}
    v = None if m else PARTS_VM.search(proc.stdout + proc.stderr)
    if v:  # started in the virtual machine: the library's build overlapped the run
        parts = {"derive": float(v[1]), "library": float(v[2] or 0.0), "simulate": float(v[3])}
    return {"wall": wall, "cpu": cpu, **parts}


def profiled_first_run(tree: Path, scene: Path, tmp: Path) -> dict[str, float]:
    """A first run (empty cache) under cProfile: wall and CPU s of the whole process (compilers
    included) and the main thread's seconds in each of :data:`PROFILED` (cumulative, every call)."""
    import pstats

    prof = tmp / "first.prof"
    with tempfile.TemporaryDirectory(dir=tmp) as cache:
        env = dict(os.environ, PYTHONPATH=str(tree), SYMGEN_CACHE_DIR=cache)
        for name in ("SYMGEN_BACKEND", "SYMGEN_CFLAGS", "SYMGEN_CC"):
            env.pop(name, None)
        cmd = [sys.executable, "-m", "cProfile", "-o", str(prof), "-m", "symgen.cli", "simulate", str(scene)]
        c0, t0 = _child_cpu(), time.perf_counter()
        subprocess.run([*cmd, "-o", str(tmp / "out.csv")], cwd=tmp, env=env, capture_output=True, check=True)
        out = {"wall": time.perf_counter() - t0, "cpu": _child_cpu() - c0}
    stats = pstats.Stats(str(prof)).stats  # type: ignore[attr-defined]  # pstats keeps them there
    for label, file, func in PROFILED:
        out[label] = sum(st[3] for (f, _, name), st in stats.items() if f.endswith(file) and name == func)
    return out


def profile_table(base: str | None, bars: int, repeats: int) -> str:
    """Markdown: where a first run's time goes (:func:`profiled_first_run`), the tree of commit
    ``base`` (when given) against this checkout, interleaved run by run, medians."""
    with tempfile.TemporaryDirectory(prefix="symgen-profile-") as tmp_s:
        tmp = Path(tmp_s)
        trees = {"after": ROOT}
        if base:
            (tmp / "base").mkdir()
            if _lean_base_tree(tmp / "base", base):
                trees = {"before": tmp / "base", "after": ROOT}
        scene = tmp / f"chain{bars}.toml"
        scene.write_text(scene_text("chain", bars, 2, 4))
        runs: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
        for _ in range(repeats):
            for name, tree in trees.items():
                runs[name].append(profiled_first_run(tree, scene, tmp))
                print(f"(profile: {bars} bars, {name}: {runs[name][-1]})", file=sys.stderr, flush=True)
    keys = ["wall", "cpu", *(label for label, *_ in PROFILED)]
    med = {t: {k: statistics.median(r.get(k, float("nan")) for r in rs) for k in keys} for t, rs in runs.items()}
    lines = [
        f"Where a first run of the {bars}-bar chain goes (`symgen simulate CHAIN` under cProfile, empty cache, "
        f"medians of {repeats}, interleaved{'' if base is None else f'; before = {base}'}): wall and CPU s of the "
        "whole process (compilers included), then the main thread's seconds in each part (every call).",
        "",
        "| part | " + " | ".join(trees) + " |",
        "|---|" + "---|" * len(trees),
    ]
    lines += [f"| {k} | " + " | ".join(_fmt(med[t][k]) for t in trees) + " |" for k in keys]
    return "\n".join(lines)


def _functions(scene: Path):
    """The compiled library's Functions of ``scene`` (this checkout)."""
    from symgen.api import mechanism
    from symgen.numerics.simulate import DaeRunner

    mech = mechanism(scene)
    *_, part = mech.initial_state(0.0)
    return DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")._compiled_functions()


def _timed(cmds: list[list[str]], max_jobs: int) -> tuple[float, float]:
    from symgen.processes import run_groups

    c0, t0 = _child_cpu(), time.perf_counter()
    procs = run_groups(cmds, max_jobs=max_jobs, timeout=1800)
    assert all(p.returncode == 0 for p in procs), procs[-1].stderr[:500]
    return time.perf_counter() - t0, _child_cpu() - c0


def compile_alone(funcs, tmp: Path) -> dict[str, object]:
    """Wall/CPU s of compiling ``funcs`` as one unit and split (each flag), and the biggest Functions."""
    import casadi as ca

    from symgen.numerics import compiled
    from symgen.processes import jobs

    cc = compiled.compiler().path
    one = tmp / "one"
    one.mkdir()
    gen = ca.CodeGenerator("model.c", {"with_header": False})
    for f in funcs:
        gen.add(f)
    gen.generate(str(one) + os.sep)
    split = tmp / "split"
    split.mkdir()
    units = compiled.write_units(funcs, split)
    out: dict[str, object] = {"kB": sum(u.stat().st_size for u in units) / 1e3, "units": len(units)}
    for flag in FLAGS:
        base = [cc, flag, "-ffp-contract=off", "-fPIC", "-c"]
        out[f"one {flag}"] = _timed([[*base, str(one / "model.c"), "-o", str(one / "model.o")]], 1)
        cmds = [[*base, str(u), "-o", str(u.with_suffix(".o"))] for u in units]
        out[f"split {flag}"] = _timed(cmds, min(len(units), jobs()))
    sizes = []
    for f in funcs:
        unit = split / f"{f.name()}.c"
        wall, _ = _timed([[cc, "-O1", "-ffp-contract=off", "-fPIC", "-c", str(unit), "-o", str(tmp / "f.o")]], 1)
        sizes.append((f.name(), int(f.n_instructions()), unit.stat().st_size / 1e3, wall))
    out["sizes"] = sorted(sizes, key=lambda s: -s[2])
    return out


def run(repeats: int, quick: bool = False) -> str:
    """Markdown of this section (``quick``: chains of 2 and 4 bars, one run each)."""
    from symgen.processes import jobs

    rows_first: list[tuple[int, dict[str, dict[str, float]]]] = []
    rows_alone: list[tuple[int, dict[str, object]]] = []
    rows_flags: list[tuple[str, dict[str, float]]] = []
    with tempfile.TemporaryDirectory(prefix="symgen-compile-") as tmp_s:
        tmp = Path(tmp_s)
        trees = {"after": ROOT}
        base = tmp / "base"
        base.mkdir()
        if base_tree(base):
            trees = {"before": base, "after": ROOT}
        os.environ["SYMGEN_CACHE_DIR"] = str(tmp / "cache")  # this process's derivations
        for n in (2, 4) if quick else BARS:
            scene = tmp / f"chain{n}.toml"
            scene.write_text(scene_text("chain", n, 2, 4))
            runs: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
            for _ in range(1 if quick else repeats):  # interleaved run by run
                for name, tree in trees.items():
                    runs[name].append(first_run(tree, scene, tmp))
            med = {name: {k: statistics.median(r[k] for r in rs) for k in rs[0]} for name, rs in runs.items()}
            rows_first.append((n, med))
            print(f"(compile: {n} bars first run {med})", file=sys.stderr, flush=True)
            work = tmp / f"alone{n}"
            work.mkdir()
            rows_alone.append((n, compile_alone(_functions(scene), work)))
        # the flags' trade: compile time against the cost of the run, on the largest chain (after)
        for flag in FLAGS:
            runs_f = [first_run(ROOT, scene, tmp, f"{flag} -ffp-contract=off") for _ in range(1 if quick else repeats)]
            rows_flags.append((flag, {k: statistics.median(r[k] for r in runs_f) for k in runs_f[0]}))
    return render(rows_first, rows_alone, rows_flags, list(trees), jobs())


def _fmt(x: float) -> str:
    return f"{x:.2f}"


def first_runs(base: str, bars: list[int], repeats: int, extra: tuple[str, ...] = ()) -> str:
    """Markdown: the first run of the chains of ``bars`` bars, the tree of commit ``base``
    against this checkout, interleaved run by run, medians (wall, CPU and the reported parts);
    ``extra``: more arguments of ``simulate`` (``--set KEY=VALUE``, ``--estimate off``)."""
    global BASE
    rows = []
    with tempfile.TemporaryDirectory(prefix="symgen-first-") as tmp_s:
        tmp = Path(tmp_s)
        old, BASE = BASE, base
        try:
            trees = {"before": tmp / "base", "after": ROOT}
            trees["before"].mkdir()
            if not base_tree(trees["before"]):
                del trees["before"]
        finally:
            BASE = old
        for n in bars:
            scene = tmp / f"chain{n}.toml"
            scene.write_text(scene_text("chain", n, 2, 4))
            runs: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
            for _ in range(repeats):
                for name, tree in trees.items():
                    runs[name].append(first_run(tree, scene, tmp, extra=extra))
                    print(f"(first run: {n} bars, {name}: {runs[name][-1]})", file=sys.stderr, flush=True)
            rows.append(
                (
                    n,
                    {
                        k: {q: statistics.median(r.get(q, float("nan")) for r in rs) for q in rs[0]}
                        for k, rs in runs.items()
                    },
                )
            )
    keys = ("wall", "cpu", "derive", "library", "simulate")
    out = [
        f"First run (`symgen simulate CHAIN`, empty cache, {os.cpu_count()} cores, medians of {repeats}, "
        f"interleaved{', `' + ' '.join(extra) + '`' if extra else ''}): before = {base}, after = this tree. Wall and CPU s "
        "of the whole process (compilers included) and the parts it reports.",
        "",
        "| bars | " + " | ".join(f"{t} {k}" for t in runs for k in keys) + " | under 5 s |",
        "|---|" + "---|" * (len(runs) * len(keys) + 1),
    ]
    for n, med in rows:
        cells = [_fmt(med[t].get(k, float("nan"))) for t in runs for k in keys]
        out.append(f"| {n} | " + " | ".join(cells) + f" | {'yes' if med['after']['wall'] < TARGET_S else 'no'} |")
    return "\n".join(out)


def render(rows_first, rows_alone, rows_flags, trees: list[str], cores: int) -> str:
    lines = [
        "## compile: the first run of a chain of N bars (issue 20, item 4)",
        "",
        f"First run (`symgen simulate CHAIN`, empty cache, {cores} cores, medians): before = {BASE} (one "
        "translation unit), after = one unit per Function compiled in parallel. Wall and CPU s of the whole "
        "process (compilers included), and the parts it reports (derive, library build including "
        "the Functions' construction, simulate).",
        "",
        "| bars | "
        + " | ".join(f"{t} wall | {t} CPU | {t} derive | {t} library | {t} simulate" for t in trees)
        + " | under 5 s |",
        "|---|" + "---|" * (5 * len(trees) + 1),
    ]
    for n, med in rows_first:
        cells = [
            _fmt(med[t].get(k, float("nan"))) for t in trees for k in ("wall", "cpu", "derive", "library", "simulate")
        ]
        lines.append(f"| {n} | " + " | ".join(cells) + f" | {'yes' if med[trees[-1]]['wall'] < TARGET_S else 'no'} |")
    lines += [
        "",
        "Compile alone (wall / CPU s): the library's C as one unit, and split into one unit per "
        f"Function compiled {cores} at a time, at each flag (with `-ffp-contract=off`).",
        "",
        "| bars | kB of C | " + " | ".join(f"one {f} | split {f}" for f in FLAGS) + " |",
        "|---|---|" + "---|---|" * len(FLAGS),
    ]
    for n, alone in rows_alone:
        cells = []
        for flag in FLAGS:
            for kind in ("one", "split"):
                wall, cpu = alone[f"{kind} {flag}"]
                cells.append(f"{wall:.2f} / {cpu:.2f}")
        lines.append(f"| {n} | {alone['kB']:.0f} | " + " | ".join(cells) + " |")
    n_last, last = rows_alone[-1]
    lines += [
        "",
        f"The flags on the first run of the {n_last}-bar chain (after; `SYMGEN_CFLAGS=FLAG -ffp-contract=off`): "
        "the compile saved against the cost of the run.",
        "",
        "| flag | wall | CPU | library | simulate |",
        "|---|---|---|---|---|",
    ]
    for flag, med in rows_flags:
        cells = [_fmt(med.get(k, float("nan"))) for k in ("wall", "cpu", "library", "simulate")]
        lines.append(f"| `{flag}` | " + " | ".join(cells) + " |")
    lines += [
        "",
        f"The Functions of the {n_last}-bar chain, largest first (-O1, each alone):",
        "",
        "| Function | operations | kB of C | compile s |",
        "|---|---|---|---|",
    ]
    for name, ops, kb, wall in last["sizes"]:
        lines.append(f"| `{name}` | {ops} | {kb:.0f} | {wall:.2f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    # bench_compile.py [REPEATS]: the section; --first BASE REPEATS N [N ...] [--set KEY=VALUE ...]
    # [--estimate E]: the first-run table alone (the options passed to simulate: --set effects.strain=exact);
    # --profile BASE|- REPEATS N: where the first run of the N-bar chain goes
    if len(sys.argv) > 4 and sys.argv[1] == "--profile":
        print(profile_table(None if sys.argv[2] == "-" else sys.argv[2], int(sys.argv[4]), int(sys.argv[3])))
    elif len(sys.argv) > 3 and sys.argv[1] == "--first":
        rest = sys.argv[4:]
        n_bars = next((i for i, a in enumerate(rest) if not a.isdigit()), len(rest))
        bars, extra = [int(a) for a in rest[:n_bars]], tuple(rest[n_bars:])
        print(first_runs(sys.argv[2], bars, int(sys.argv[3]), extra))
    else:
        print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 1))
