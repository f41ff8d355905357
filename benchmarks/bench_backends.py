"""How a run is executed: CasADi's virtual machine, the compiled model (default) and the emitted
C Radau IIA solver (``--solver c``), on the example scenes.

For each scene (two crank turns, the scene's own effects and function counts, model cached):
* in-process CPU of ``simulate`` with ``backend="vm"`` and ``backend="compiled"`` (set-up,
  consistent start, integration, outputs), and IDAS's steps;
* ``--solver c``: the C solver's own CPU time (``--stats``) and the wall time of the call from
  Python (process start, argument passing, reading the rows);
* the whole process: CPU (user + sys) of a fresh ``python -m symgen.cli simulate SCENE -o out.csv``
  with each choice, the model and the compiled files cached, bytecode cached as after a pip
  install;
* agreement: max |difference| / peak of every output between the compiled and the VM run (the
  compiled library is the VM's arithmetic: 0 expected) and between ``--solver c`` and IDAS (both
  within their tolerances of the true solution).
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

CASES = [
    ("slider-crank (example)", "examples/slider_crank.toml", []),
    ("four-bar (example)", "examples/four_bar.toml", []),
    ('slider-crank, `effects.axial="inextensible"`', "examples/slider_crank.toml", ['effects.axial="inextensible"']),
]
TURNS = ["simulation.cycles=2"]


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _process(args: list[str]) -> float:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env.pop("SYMGEN_BACKEND", None)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    c0 = _child_cpu()
    subprocess.run(
        [sys.executable, "-m", "symgen.cli", "simulate", *args],
        check=True,
        cwd=ROOT,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    return _child_cpu() - c0


def _gap(a, b) -> float:
    """max over outputs of max |a - b| / max |b| (rows of equal times); outputs that are zero to
    round-off in ``b`` (the closure residual, a stretch the model does not have) are left out."""
    n = min(len(a.tau), len(b.tau))
    peak = np.abs(b.outputs[:n]).max(axis=0)
    keep = peak > 1e-12
    return float((np.abs(a.outputs[:n, keep] - b.outputs[:n, keep]).max(axis=0) / peak[keep]).max())


def bench_case(scene: str, over: list[str], repeats: int) -> dict:
    from symgen.api import mechanism
    from symgen.numerics.csolver import simulate_c
    from symgen.numerics.simulate import simulate

    mech = mechanism(str(ROOT / scene), over + TURNS)
    row: dict = {}
    runs = {}
    for backend in ("vm", "compiled"):
        simulate(mech, backend=backend)  # the library built / loaded once
        cpu = []
        for _ in range(repeats):
            t0 = time.process_time()
            res = simulate(mech, backend=backend)
            cpu.append(time.process_time() - t0)
        row[backend] = statistics.median(cpu)
        runs[backend] = res
    row["steps"] = runs["vm"].steps
    simulate_c(mech)  # the executable built once
    wall, own = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = simulate_c(mech)
        wall.append(time.perf_counter() - t0)
        own.append(res.stats["solve_cpu_s"])
    row["c_wall"], row["c_cpu"], row["c_steps"] = statistics.median(wall), statistics.median(own), res.steps
    row["gap_compiled"] = _gap(runs["compiled"], runs["vm"])
    row["gap_c"] = _gap(res, runs["vm"])
    out = Path(tempfile.mkdtemp(prefix="symgen-bench-")) / "out.csv"
    sets = [w for o in over + TURNS for w in ("--set", o)]
    proc = {}
    for label, extra in (
        ("vm", ["--backend", "vm"]),
        ("compiled", ["--backend", "compiled"]),
        ("c", ["--solver", "c"]),
    ):
        args = [scene, "-o", str(out), *sets, *extra]
        _process(args)  # warm (files cached)
        proc[label] = statistics.median(_process(args) for _ in range(repeats))
    for f in out.parent.iterdir():
        f.unlink()
    out.parent.rmdir()
    row["proc"] = proc
    return row


def run(repeats: int) -> str:
    import compileall

    compileall.compile_dir(str(ROOT / "symgen"), quiet=1)
    lines = [
        "## Execution: virtual machine, compiled model, `--solver c`",
        "",
        "Two crank turns of each scene with its own effects and function counts, model (and compiled "
        "files) cached; medians of %d. In-process CPU s of `simulate` (set-up, consistent start, "
        "integration, outputs) with CasADi's virtual machine and with the compiled model (the default); "
        "`--solver c`: the C solver's own CPU s and the wall s of the call from Python; whole process: "
        "CPU s of a fresh `python -m symgen.cli simulate ...`. Gap: max |difference| / peak over the "
        "outputs against the virtual machine's run." % repeats,
        "",
        "| scene | VM s | compiled s | IDAS steps | `--solver c` CPU s (wall s) | C steps | whole process s: "
        "VM / compiled / `--solver c` | gap compiled | gap `--solver c` |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for label, scene, over in CASES:
        r = bench_case(scene, over, repeats)
        p = r["proc"]
        lines.append(
            f"| {label} | {r['vm']:.3f} | {r['compiled']:.3f} | {r['steps']} | {r['c_cpu']:.3f} "
            f"({r['c_wall']:.3f}) | {r['c_steps']} | {p['vm']:.2f} / {p['compiled']:.2f} / {p['c']:.2f} | "
            f"{r['gap_compiled']:.1e} | {r['gap_c']:.1e} |"
        )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(run(int(sys.argv[1]) if len(sys.argv) > 1 else 3))
