"""Benchmark section ``lean`` (issue 20, items 1 and 2): the start-up and the IDAS path of a run
on a cached model, before and after, on the example scenes.

*Before* is the tree of :data:`BASE` (the commit before the lean start and the lean IDAS path),
taken with ``git archive`` into a temporary folder; *after* is this checkout. Both run from one
model cache, warmed first, with the compiled backend (the default when a C compiler is at hand),
and are interleaved run by run; the tables give medians of the CPU time (user + system).

1. Whole process: ``python -m symgen.cli simulate SCENE -o out.csv`` and ``symgen check SCENE``
   (fresh interpreters), and the import of ``symgen.numerics.simulate`` alone, with whether the
   process imported SymPy.
2. The IDAS path in one process: ``simulate(mech)`` at rtol 1e-4 / atol 1e-6 (the 1 % class of
   the Exudyn comparison), repeated on one mechanism, with the time of its parts outside IDAS:
   the runner's set-up, the creation of the integrators, the polish of the algebraic variables
   and the recording of the outputs.

    python benchmarks/run.py --only lean
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
#: The commit before issue 20's lean start and lean IDAS path.
BASE = "710fcf8"
EXAMPLES = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "examples").glob("*.toml"))
#: The folder the processes run in: not a checkout (``python -c`` and ``-m`` put it first on the path).
WORK = Path(tempfile.gettempdir())
LOOSE = {"rtol": 1e-4, "atol": 1e-6}
#: The commit before the remembered basis choice (``symgen.scene.bases.remembered``).
STEEL_BASE = "c67e386"
STEEL = "benchmarks/validation/slider_crank_steel_rest.toml"

# One process: the IDAS path of `simulate` repeated on one mechanism, its parts outside IDAS timed
# by wrapping the functions that make them (the same names in both trees).
IN_PROCESS = r"""
import collections, json, sys, time
import symgen
import symgen.numerics.simulate as S
from symgen.api import mechanism
acc = collections.defaultdict(float)
def wrap(owner, name, label):
    f = getattr(owner, name)
    def timed(*a, **k):
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            acc[label] += time.process_time() - t
    setattr(owner, name, timed)
wrap(S, "_runner", "runner")
wrap(S.DaeRunner, "integrator", "integrators")
wrap(S.DaeRunner, "polish_many", "polish")
wrap(S._Trajectory, "record_many", "record")
scene, repeats, kw = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
mech = mechanism(scene)
S.simulate(mech, **kw)
acc.clear()
cpu = []
for _ in range(repeats):
    t = time.process_time()
    res = S.simulate(mech, **kw)
    cpu.append(time.process_time() - t)
parts = {k: v / repeats for k, v in acc.items()}
print("RESULT " + json.dumps({"file": symgen.__file__, "cpu": cpu, "parts": parts, "steps": res.steps,
                              "backend": res.stats["backend"]}))
"""

SYMPY_AFTER = (
    "import sys, runpy; sys.argv = ['symgen'] + sys.argv[1:]\n"
    "try:\n    runpy.run_module('symgen.cli', run_name='__main__')\n"
    "except SystemExit as e:\n    assert not e.code, e.code\n"
    "print('SYMPY', 'sympy' in sys.modules)\n"
)


def base_tree(dest: Path, base: str = BASE) -> bool:
    """Extract the symgen package and templates of commit ``base`` (default :data:`BASE`) into
    ``dest``; False when git or the commit is not at hand (the section then measures this
    checkout only)."""
    try:
        blob = subprocess.run(
            ["git", "-C", str(ROOT), "archive", "--format=tar", base, "symgen", "templates"],
            capture_output=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        return False
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(dest, filter="data")
    return True


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _env(tree: Path, cache: str) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(tree), SYMGEN_CACHE_DIR=cache)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as installed: bytecode cached
    env.pop("SYMGEN_BACKEND", None)  # the default (compiled when a C compiler is at hand)
    return env


def process(cmd: list[str], tree: Path, cache: str) -> tuple[float, str]:
    """(CPU s of a fresh process running ``cmd`` with ``tree`` first on the path, its stdout)."""
    c0 = _child_cpu()
    proc = subprocess.run(cmd, cwd=WORK, env=_env(tree, cache), capture_output=True, text=True, check=True)
    return _child_cpu() - c0, proc.stdout


def _median(xs: list[float]) -> float:
    return statistics.median(xs)


def whole_process(trees: dict[str, Path], cache: str, repeats: int, out: Path) -> list[dict]:
    rows = []
    py = sys.executable
    cases: list[tuple[str, list[str]]] = [
        ("import symgen.numerics.simulate", [py, "-c", "import symgen.numerics.simulate"])
    ]
    for scene in EXAMPLES:
        path = str(ROOT / scene)
        cases.append((f"check `{scene}`", [py, "-c", SYMPY_AFTER, "check", path]))
        cases.append((f"simulate `{scene}`", [py, "-c", SYMPY_AFTER, "simulate", path, "-o", str(out)]))
    for label, cmd in cases:
        times: dict[str, list[float]] = {name: [] for name in trees}
        sympy: dict[str, str] = {}
        for tree in trees.values():
            process(
                [str(tree) if c == "{tree}" else c for c in cmd], tree, cache
            )  # warm: the model cache, the OS file cache, the bytecode
        for _ in range(repeats):
            for name, tree in trees.items():
                cpu, stdout = process([str(tree) if c == "{tree}" else c for c in cmd], tree, cache)
                times[name].append(cpu)
                if "SYMPY" in stdout:
                    sympy[name] = "yes" if "SYMPY True" in stdout else "no"
        rows.append({"case": label, "cpu": {k: _median(v) for k, v in times.items()}, "sympy": sympy})
    return rows


def idas_path(trees: dict[str, Path], cache: str, repeats: int) -> list[dict]:
    rows = []
    for scene in EXAMPLES:
        runs: dict[str, list[dict]] = {name: [] for name in trees}
        for _ in range(max(3, repeats)):
            for name, tree in trees.items():
                _, stdout = process(
                    [sys.executable, "-c", IN_PROCESS, str(ROOT / scene), "5", json.dumps(LOOSE)], tree, cache
                )
                got = json.loads(next(ln for ln in stdout.splitlines() if ln.startswith("RESULT "))[7:])
                assert got["file"].startswith(str(tree)), (got["file"], tree)  # the tree meant
                runs[name].append(got)
        row: dict = {"scene": scene}
        for name, got in runs.items():
            row[name] = {
                "cpu": _median([_median(g["cpu"]) for g in got]),
                "parts": {k: _median([g["parts"].get(k, 0.0) for g in got]) for k in got[0]["parts"]},
                "steps": got[0]["steps"],
                "backend": got[0]["backend"],
            }
        rows.append(row)
    return rows


def steel_whole(trees: dict[str, Path], cache: str, repeats: int, out: Path) -> list[dict]:
    """Issue 20's steel slider-crank, whole process on a cached model, ``--estimate off``: with
    ``--solver c`` and with the default (IDAS), before and after the remembered basis choice."""
    rows = []
    for label, extra in (("`--solver c`", ["--solver", "c"]), ("default", [])):
        cmd = [sys.executable, "-m", "symgen.cli", "simulate", str(ROOT / STEEL), *extra, "--estimate", "off"]
        cmd += ["-o", str(out)]
        times: dict[str, list[float]] = {name: [] for name in trees}
        for tree in trees.values():
            process(cmd, tree, cache)  # warm: the model, the C solver, the remembered choices
        for _ in range(max(7, repeats)):
            for name, tree in trees.items():
                times[name].append(process(cmd, tree, cache)[0])
        rows.append({"case": label, "cpu": {k: _median(v) for k, v in times.items()}, "n": max(7, repeats)})
    return rows


def render_steel(rows: list[dict], trees: dict[str, Path]) -> str:
    both = len(trees) == 2
    out = [
        "",
        f"### Steel slider-crank (`{STEEL}`), whole process on a cached model, `--estimate off`",
        "",
        f"Before: commit `{STEEL_BASE}` (each run chose the bars' bases again); after: this checkout (the "
        "choice recalled from the signed cache). Interleaved, medians of the CPU time (user + system), "
        f"{rows[0]['n'] if rows else 0} runs each; `python -c pass` and `import numpy` for scale.",
        "",
        "| process | before ms | after ms | after / before |" if both else "| process | after ms |",
        "|---|---|---|---|" if both else "|---|---|",
    ]
    for r in rows:
        c = r["cpu"]
        if both:
            out.append(
                f"| {r['case']} | {1e3 * c['before']:.0f} | {1e3 * c['after']:.0f} | {c['after'] / c['before']:.2f} |"
            )
        else:
            out.append(f"| {r['case']} | {1e3 * c['after']:.0f} |")
    return "\n".join(out) + "\n"


def floor_processes(cache: str, repeats: int) -> str:
    """CPU ms of an empty interpreter and of one that imports numpy (the floor of any process)."""
    rows = []
    for label, code in (("`python -c pass`", "pass"), ("`python -c 'import numpy'`", "import numpy")):
        cpu = [process([sys.executable, "-c", code], ROOT, cache)[0] for _ in range(max(7, repeats))]
        rows.append(f"| {label} | {1e3 * _median(cpu):.0f} |")
    return "\n| floor | ms |\n|---|---|\n" + "\n".join(rows) + "\n"


def render(whole: list[dict], path: list[dict], trees: dict[str, Path]) -> str:
    both = len(trees) == 2
    out = [
        "## Lean start and lean IDAS path (issue 20, items 1 and 2)",
        "",
        f"Before: commit `{BASE}`; after: this checkout. One warm model cache, the compiled backend, "
        "interleaved runs, medians of the CPU time (user + system).",
        "",
        "### Whole process on a cached model",
        "",
        "| process | before s | after s | after / before | SymPy imported (before / after) |"
        if both
        else "| process | after s | SymPy imported |",
        "|---|---|---|---|---|" if both else "|---|---|---|",
    ]
    for r in whole:
        c, sp = r["cpu"], r["sympy"]
        if both:
            imported = f"{sp.get('before', '-')} / {sp.get('after', '-')}"
            out.append(
                f"| {r['case']} | {c['before']:.3f} | {c['after']:.3f} | {c['after'] / c['before']:.2f} | {imported} |"
            )
        else:
            out.append(f"| {r['case']} | {c['after']:.3f} | {sp.get('after', '-')} |")
    out += [
        "",
        f"### The IDAS path in one process (rtol {LOOSE['rtol']:g}, atol {LOOSE['atol']:g}; ms per run)",
        "",
        "Outside IDAS: the runner's set-up, the integrators' creation, the polish of the algebraic "
        "variables at the outputs, the recording (and checks) of the outputs.",
        "",
        "| scene | IDAS steps | tree | simulate ms | runner | integrators | polish | record | outside IDAS |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in path:
        for name in trees:
            d = r[name]
            p = d["parts"]
            outside = sum(p.get(k, 0.0) for k in ("runner", "integrators", "polish", "record"))
            out.append(
                f"| `{r['scene']}` | {d['steps']} | {name} | {1e3 * d['cpu']:.1f} | {1e3 * p.get('runner', 0):.1f} | "
                f"{1e3 * p.get('integrators', 0):.1f} | {1e3 * p.get('polish', 0):.1f} | "
                f"{1e3 * p.get('record', 0):.1f} | {1e3 * outside:.1f} |"
            )
    return "\n".join(out) + "\n"


def run(repeats: int) -> str:
    """Markdown of this section."""
    repeats = max(3, repeats)
    with tempfile.TemporaryDirectory(prefix="symgen-lean-") as tmp:
        trees = {"after": ROOT}
        base = Path(tmp) / "base"
        base.mkdir()
        if base_tree(base):
            trees = {"before": base, "after": ROOT}
        cache = str(Path(tmp) / "cache")
        out = Path(tmp) / "out" / "run.csv"
        out.parent.mkdir()
        t0 = time.perf_counter()
        for scene in EXAMPLES:  # derive and compile once, outside the timings
            process([sys.executable, "-m", "symgen.cli", "simulate", str(ROOT / scene), "-o", str(out)], ROOT, cache)
        print(f"(lean: cache warmed in {time.perf_counter() - t0:.0f} s)", file=sys.stderr)
        whole = whole_process(trees, cache, repeats, out)
        path = idas_path(trees, cache, repeats)
        steel = steel_section(Path(tmp), cache, repeats, out)
    return render(whole, path, trees) + steel + c_process_section(repeats)


def steel_section(tmp: Path, cache: str, repeats: int, out: Path) -> str:
    trees = {"after": ROOT}
    base = tmp / "steel-base"
    base.mkdir()
    if base_tree(base, STEEL_BASE):
        trees = {"before": base, "after": ROOT}
    return render_steel(steel_whole(trees, cache, repeats, out), trees) + floor_processes(cache, repeats)


#: The commit before the lean-to-the-bone cached ``--solver c`` process (symgen.classcode, one
#: command's parser, the templates' digest without importlib.resources).
C_BASE = "793b723"
C_SCENES = (STEEL, "examples/slider_crank.toml")


def _process_env(cmd: list[str], tree: Path, cache: str, extra: dict[str, str]) -> float:
    c0 = _child_cpu()
    env = {**_env(tree, cache), **extra}
    subprocess.run(cmd, cwd=WORK, env=env, capture_output=True, text=True, check=True)
    return _child_cpu() - c0


def c_process_section(repeats: int = 7, python: str | None = None, scenes: tuple[str, ...] = C_SCENES) -> str:
    """A cached ``symgen simulate SCENE --solver c`` process, ``--estimate off`` and the default
    estimate, on the steel slider-crank and the paper's: before (:data:`C_BASE`), after this
    checkout, and after without the recalled dataclass methods (``SYMGEN_NO_CLASS_CODE=1``,
    symgen.classcode), interleaved, medians of the CPU time (user + system, the children
    included), with the floors. Its own cache, warmed first by every variant. ``python``: the
    interpreter (default this one; one without symgen's editable install models a wheel: no
    editable finder at start-up; it runs ``--estimate off`` only when it has no numpy). Run alone::

        python -c "import sys; sys.path.insert(0, 'benchmarks'); import bench_lean; print(bench_lean.c_process_section(7))"
    """
    repeats = max(7, repeats)
    py = python or sys.executable
    with tempfile.TemporaryDirectory(prefix="symgen-lean-c-") as tmp:
        variants: dict[str, tuple[Path, dict[str, str]]] = {}
        base = Path(tmp) / "base"
        base.mkdir()
        if base_tree(base, C_BASE):
            variants["before"] = (base, {})
        variants["after"] = (ROOT, {})
        variants["after, no classcode"] = (ROOT, {"SYMGEN_NO_CLASS_CODE": "1"})
        cache = str(Path(tmp) / "cache")
        out = Path(tmp) / "out" / "run.csv"
        out.parent.mkdir()
        has_numpy = subprocess.run([py, "-c", "import numpy"], capture_output=True).returncode == 0
        estimates = [("`--estimate off`", ["--estimate", "off"])]
        if has_numpy:
            estimates.append(("default estimate", []))
        rows = []
        for scene in scenes:
            for label, extra in estimates:
                cmd = [py, "-m", "symgen.cli", "simulate", str(ROOT / scene), "--solver", "c", *extra]
                cmd += ["-o", str(out)]
                times: dict[str, list[float]] = {name: [] for name in variants}
                for tree, env in variants.values():  # warm: the model, the C solvers, the remembered choices
                    for exe in dict.fromkeys([sys.executable, py]):  # this one derives (SymPy, CasADi)
                        _process_env([exe, *cmd[1:]], tree, cache, env)
                    _process_env(cmd, tree, cache, env)
                for _ in range(repeats):
                    for name, (tree, env) in variants.items():
                        times[name].append(_process_env(cmd, tree, cache, env))
                rows.append({"case": f"`{scene}`, {label}", "cpu": {k: _median(v) for k, v in times.items()}})
        names = list(variants)
        ref = "before" if "before" in variants else None
        text = [
            "",
            "### A cached `symgen simulate SCENE --solver c` process (issue 20: the whole process)",
            "",
            f"Interpreter `{py}`; before: commit `{C_BASE}`; after: this checkout; interleaved, medians of "
            f"the CPU time (user + system), {repeats} runs each; same CSV and sidecar.",
            "",
            "| process | " + " | ".join(f"{n} ms" for n in names) + (" | after / before |" if ref else " |"),
            "|---|" + "---|" * (len(names) + (1 if ref else 0)),
        ]
        for r in rows:
            c = r["cpu"]
            cells = " | ".join(f"{1e3 * c[n]:.0f}" for n in names)
            ratio = f" | {c['after'] / c['before']:.2f} |" if ref else " |"
            text.append(f"| {r['case']} | {cells}{ratio}")
        floors = []
        for flabel, code in (
            ("`python -c pass`", ["-c", "pass"]),
            ("`python -I -S -c pass`", ["-I", "-S", "-c", "pass"]),
        ):
            cpu = [_process_env([py, *code], ROOT, cache, {}) for _ in range(repeats)]
            floors.append(f"| {flabel} | {1e3 * _median(cpu):.0f} |")
        load = os.getloadavg()
        return (
            "\n".join(text)
            + "\n\n| floor | ms |\n|---|---|\n"
            + "\n".join(floors)
            + f"\n\nLoad average at the end: {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (1 / 5 / 15 min).\n"
        )


if __name__ == "__main__":
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 5))
