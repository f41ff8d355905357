"""Where a first run's model build spends its CPU and memory, phase by phase (issue 20: the exact
bar's first run; docs/exact-bars.md, "The first run's cost"). Not a ``run.py`` section: one scene
per process, on an empty cache, as a first run meets it.

Phases, each with its CPU seconds and the process's peak RSS so far: ``derive`` (SymPy, the
shape tables included when the cache lacks them), ``casadi_build`` (the model's Functions), the
runner's Functions (``dae``, ``g``, ``split``, ``rec``), ``jac_dae`` (CasADi's AD of ``dae``),
``cse`` (``simulate._shared`` on every compiled unit), the C emission (``compiled.write_units``:
a Function larger than ``policy.UNITS`` allows is written as parts, ``<name>_part<k>``, and a unit
that calls them), then each unit compiled alone with the flags of a first run (``/usr/bin/time``:
CPU s, peak RSS of the compiler): ``-O1`` for ``dae``, ``-O0`` for the cold units; ``gcc_sum``
adds each Function's units (CPU s in all, the largest unit's peak).

    SYMGEN_CACHE_DIR=$(mktemp -d) python benchmarks/bench_first_run.py SCENE.toml [--no-gcc]

prints one JSON line (``ops``: CasADi ``n_instructions`` of each unit; ``C_MB``: its C).
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main(argv: list[str]) -> dict:
    warnings.simplefilter("ignore")
    from symgen.api import mechanism
    from symgen.backends.casadi.pipeline import compile_model
    from symgen.model.derive import derive
    from symgen.numerics import compiled
    from symgen.numerics import simulate as S
    from symgen.scene import load_scene

    out: dict = {}
    clock = [time.process_time()]

    def phase(name: str) -> None:
        now = time.process_time()
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
        out[name] = {"cpu_s": round(now - clock[0], 2), "peak_MB": round(peak)}
        print(name, out[name], file=sys.stderr, flush=True)
        clock[0] = time.process_time()

    scene = load_scene(argv[0])
    model = derive(scene)
    phase("derive")
    compile_model(model)
    phase("casadi_build")
    mech = mechanism(scene)
    *_, part = mech.initial_state(0.0)
    run = S.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")
    fs = run._functions()
    phase("runner")
    dae = fs["dae"]
    dae_in = dae.sx_in()
    fs["jac_dae"] = S._dae_jacobian(dae, dae_in, dae.call(dae_in))
    phase("jac_dae")
    funcs = run._compiled_functions()
    phase("cse")
    with tempfile.TemporaryDirectory() as tmp:
        units = compiled.write_units(funcs, Path(tmp), S.COLD)
        phase("C")
        out["ops"] = {f.name(): int(f.n_instructions()) for f in funcs}
        out["C_MB"] = {u.stem: round(u.stat().st_size / 1e6, 2) for u in units}
        if "--no-gcc" not in argv:
            comp = compiled.compiler()
            for u in units:
                flags = list(compiled.cold_flags(comp)) if compiled.unit_of(u) in S.COLD else list(comp.flags)
                cmd = ["/usr/bin/time", "-f", "%U %S %M", comp.path, *flags, "-fPIC", "-c", str(u), "-o", f"{u}.o"]
                r = subprocess.run(cmd, capture_output=True, text=True, check=True)
                user, system, kb = r.stderr.strip().splitlines()[-1].split()
                gcc = {
                    "flags": " ".join(flags),
                    "cpu_s": round(float(user) + float(system), 1),
                    "peak_MB": round(int(kb) / 1e3),
                }
                out.setdefault("gcc", {})[u.stem] = gcc
                print(u.stem, gcc, file=sys.stderr, flush=True)
                whole = out.setdefault("gcc_sum", {}).setdefault(compiled.unit_of(u), {"cpu_s": 0.0, "peak_MB": 0})
                whole["cpu_s"] = round(whole["cpu_s"] + gcc["cpu_s"], 1)
                whole["peak_MB"] = max(whole["peak_MB"], gcc["peak_MB"])
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main(sys.argv[1:])
