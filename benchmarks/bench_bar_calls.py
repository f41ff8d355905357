"""symgen's runner with each bar structure's generalized forces as one CasADi Function called per
bar ("landed": the exact-strain bar blocks as call nodes, the runner's Jacobian by the chain rule
over each block's own Jacobian Function, the virtual machine's IDAS given the same Jacobian,
``functions.call_functions`` / ``simulate._chain_rule``) against the inline runner ("inline":
``functions.CALL_STRAINS = ()``, every block inline) (issue 20, items 4-5): the C of the compiled library (kB, compile CPU s of
its units one at a time with a first run's flags: -O0 the cold units, -O1 ``dae``), the virtual
machine's and the compiled library's CPU per IDAS step (the integration alone: ``simulate._integrate``), the steps, and the states after the run
(max relative difference, bit-identical or not).

    python benchmarks/bench_bar_calls.py [--bars 4 12] [--strain exact von_karman] [--repeats 3] [--t-end 1]

The variants measured before the calls landed ("calls": CasADi's AD through the call nodes; "chain",
"chainvm": the chain rule in a prototype) are in benchmarks/RESULTS.md's history; their prototype
was removed once symgen's own runner did the same.

Each (scene, runner) in a fresh process with an empty cache of its own; the two runners
interleaved; medians of the repeats for the timings.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_derivation import scene_text  # noqa: E402

MEASURE = r"""
import json, os, resource, subprocess, sys, time, shlex
import numpy as np
from pathlib import Path
from symgen.backends.casadi import functions
if {calls!r} == "inline":  # else symgen's own runner with the bar blocks as calls (exact strain)
    functions.CALL_STRAINS = ()  # every block inline
from symgen.scene import load_scene
from symgen.model.derive import derive
from symgen.backends.casadi import pipeline
from symgen.numerics.mechanism import Mechanism
from symgen.numerics import simulate as sim, compiled

def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime

scene = load_scene({path!r}, {sets!r})
c0 = time.process_time()
model = derive(scene)
c1 = time.process_time()
cm = pipeline.compile_model(model)
c2 = time.process_time()
mech = Mechanism(cm, scene)
q, v, a, lam, part = mech.initial_state(0.0)
part = mech.run_partition(part)
c3 = time.process_time()
run = sim.DaeRunner(mech, part, 1e-6, 1e-6, backend="vm", use_cache=False)
funcs = run._compiled_functions()
c4 = time.process_time()
out = {{"derive": c1 - c0, "build": c2 - c1, "runner": c4 - c3, "n": len(model.coords)}}
out["ops"] = {{f.name(): int(f.n_instructions()) for f in funcs}}
folder = Path({work!r})
units = compiled.write_units(funcs, folder, cold=sim.COLD)
out["kB"] = sum(u.stat().st_size for u in units) / 1e3
cc = compiled.compiler()
comp = 0.0
cold = compiled.cold_units(funcs, sim.COLD) if hasattr(compiled, "cold_units") else sim.COLD
for u in units:
    flags = shlex.split(compiled.COLD_CFLAGS if compiled.unit_of(u) in cold else compiled.DEFAULT_CFLAGS)
    b = child_cpu()
    subprocess.run([cc.path, *flags, "-fPIC", "-c", str(u), "-o", str(u.with_suffix(".o"))], check=True)
    comp += child_cpu() - b
out["compile"] = comp
integrate = sim._integrate
spent = [0.0]

def timed(*args, **kwargs):  # the integration's CPU alone (not the start, not the set-up)
    b = time.process_time()
    try:
        return integrate(*args, **kwargs)
    finally:
        spent[0] += time.process_time() - b

sim._integrate = timed
res = {{}}
for backend in ("vm", "compiled", "compiled"):  # the second compiled run: the library from the cache
    spent[0] = 0.0
    r = sim.simulate(mech, t_end={t_end}, backend=backend)
    res[backend] = (spent[0], r)
cpu_vm, r_vm = res["vm"]
cpu_c, r_c = res["compiled"]
out["steps"] = int(r_vm.steps)
out["vm_cpu"] = cpu_vm
out["c_cpu"] = cpu_c
out["c_steps"] = int(r_c.steps)
np.save(folder / "q.npy", np.concatenate([r_vm.q[-1], r_vm.v[-1]]))
np.save(folder / "qc.npy", np.concatenate([r_c.q[-1], r_c.v[-1]]))
print(json.dumps(out))
"""


def measure(path: Path, sets: list, calls: str, t_end: float, work: Path) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, PYTHONPATH=str(ROOT), SYMGEN_CACHE_DIR=cache, OPENBLAS_NUM_THREADS="1")
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        work.mkdir(parents=True, exist_ok=True)
        code = MEASURE.format(calls=calls, path=str(path), sets=list(sets), work=str(work), t_end=t_end)
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=cache)
        if proc.returncode:
            raise SystemExit(proc.stderr[-3000:])
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    import numpy as np

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bars", type=int, nargs="+", default=[4, 12])
    ap.add_argument("--strain", nargs="+", default=["exact", "von_karman"])
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--runners", nargs="+", choices=["inline", "landed"], default=["inline", "landed"])
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bar-calls-"))
    rows = []
    for n in args.bars:
        for strain in args.strain:
            path = work / f"chain{n}.toml"
            path.write_text(scene_text("chain", n, 2, 4))
            sets = [f"effects.strain={strain}"]
            runs: dict = {k: [] for k in args.runners}
            for r in range(args.repeats):
                for calls in args.runners:
                    runs[calls].append(measure(path, sets, calls, args.t_end, work / f"{n}-{strain}-{calls}-{r}"))
            x0 = np.load(work / f"{n}-{strain}-{args.runners[0]}-0" / "q.npy")  # the reference: the first runner
            for calls in args.runners:
                m = runs[calls]
                x1 = np.load(work / f"{n}-{strain}-{calls}-0" / "q.npy")
                xc = np.load(work / f"{n}-{strain}-{calls}-0" / "qc.npy")
                rel = float(np.max(np.abs(x1 - x0)) / np.max(np.abs(x0)))

                def med(key: str, m: list = m) -> float:
                    return statistics.median(x[key] for x in m)

                rows.append(
                    {
                        "scene": f"chain {n} {strain}",
                        "runner": calls,
                        "n": m[0]["n"],
                        "ops": m[0]["ops"],
                        "kB": m[0]["kB"],
                        "compile": med("compile"),
                        "derive": med("derive"),
                        "build": med("build"),
                        "runner_s": med("runner"),
                        "steps": m[0]["steps"],
                        "c_steps": m[0]["c_steps"],
                        "vm_us": 1e6 * med("vm_cpu") / m[0]["steps"],
                        "c_us": 1e6 * med("c_cpu") / m[0]["c_steps"],
                        "rel": rel,
                        "identical": bool(np.array_equal(x0, x1)),
                        "c_vs_vm_identical": bool(np.array_equal(x1, xc)),
                    }
                )
                print(json.dumps(rows[-1]), flush=True)
    print(
        "| scene | runner | dae / jac_dae / g ops | kB of C | compile CPU s | build s | runner s | IDAS steps "
        "| VM CPU us/step | compiled CPU us/step | max diff of x / max abs x | bit-identical to inline | compiled = VM bit for bit |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        o = r["ops"]
        print(
            f"| {r['scene']} | {r['runner']} | {o['dae']} / {o['jac_dae']} / {o.get('g', '-')} | {r['kB']:.0f} | {r['compile']:.1f} "
            f"| {r['build']:.2f} | {r['runner_s']:.2f} | {r['steps']} | {r['vm_us']:.0f} | {r['c_us']:.0f} "
            f"| {r['rel']:.1e} | {'yes' if r['identical'] else 'no'} | {'yes' if r['c_vs_vm_identical'] else 'no'} |"
        )


if __name__ == "__main__":
    main()
