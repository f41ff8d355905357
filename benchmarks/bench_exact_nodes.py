"""Benchmark section ``exact_nodes`` (issue 20 item 4, issue 19 item 3): the code the exact bar
(``effects.strain = "exact"``) emits, its sums over the quadrature tables expanded against the
node form (docs/exact-bars.md, "The node form").

One elastic rod (3 axial + nt transverse functions, quasi-static axial, Kelvin-Voigt damping)
in a slider-crank with a rigid crank, nt = 4, 6, 8, 10; von Karman's bar beside it. Each model
in a fresh process with an empty cache: the CPU seconds of ``derive`` (SymPy) and of the CasADi
build, the operations (``n_instructions``) of the residual ``res`` and of the compiled runner's
``dae`` and ``jac_dae`` (its Jacobian, the largest unit), the kB of C of all the runner's units
(``compiled.write_units``) and the CPU seconds of compiling them (``compiled.cold_flags``' -O0
for the cold units, -O1 for ``dae``, as a first run does). *expanded* forces every sum over its
table (``bars._NODE_FORM``: the model before the node form, operation for operation);
*node form* is what symgen chooses.

    python benchmarks/run.py --only exact_nodes
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COUNTS = (4, 6, 8, 10)
AXIAL = 3

SCENE = """
[scene]
name = "rod_{strain}_{nt}"
reference_length = 1.0
omega = 1.0
units = "dimensionless"

[[bodies]]
name = "crank"
length = 0.5
rigid = true

[[bodies]]
name = "rod"
length = 1.0
lambda = 18246.0
mu = 0.495
frame = "pinned-pinned"
axial_modes = {na}
transverse_modes = {nt}

[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]

[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "rod"]
at = [1.0, 0.0]

[[joints]]
name = "B"
kind = "slider"
bodies = ["rod", "ground"]
at = [1.0, [0.0, 0.0]]
direction = [1.0, 0.0]
mass = 0.1

[driver]
kind = "angle"
body = "crank"
initial = 0.0
rate = 1.0

[effects]
strain = "{strain}"
axial = "quasi_static"
damping = 0.001

[outputs]
eta_mid = {{ kind = "chord_deflection", body = "rod", at = 0.5 }}
torque = {{ kind = "driver_torque" }}

[simulation]
cycles = 1
output_step = 0.05
"""

MEASURE = """
import json, os, subprocess, sys, time, warnings
from pathlib import Path
sys.path.insert(0, {root!r})
warnings.simplefilter("ignore")
import symgen.model.bars as bars
bars._NODE_FORM.update({force!r})
from symgen.scene import load_scene
from symgen.model.derive import derive
from symgen.backends.casadi.pipeline import compile_model
from symgen.api import mechanism
from symgen.numerics import compiled
from symgen.numerics.simulate import COLD, DaeRunner
scene = load_scene({path!r})
t0 = time.process_time()
model = derive(scene)
t1 = time.process_time()
funcs = compile_model(model).funcs
t2 = time.process_time()
mech = mechanism(scene)
*_, part = mech.initial_state(0.0)
runner = DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")._compiled_functions()
ops = {{f.name(): int(f.n_instructions()) for f in runner}}
ops["res"] = int(funcs["res"].n_instructions())
units = compiled.write_units(runner, Path({tmp!r}))
kb = sum(u.stat().st_size for u in units) / 1e3
cpu = None
if {compile!r}:
    comp = compiled.compiler()
    cold = list(compiled.cold_flags(comp))
    hot = compiled.DEFAULT_CFLAGS.split()
    c0 = os.times()
    for u in units:
        flags = cold if u.stem in COLD else hot
        subprocess.run(["nice", "-n", "5", comp.path, *flags, "-fPIC", "-c", str(u), "-o", str(u.with_suffix(".o"))], check=True)
    c1 = os.times()
    cpu = c1.children_user + c1.children_system - c0.children_user - c0.children_system
print(json.dumps({{"derive_s": t1 - t0, "build_s": t2 - t1, "ops": ops, "kB": kb, "compile_s": cpu}}))
"""


def measure(strain: str, nt: int, force: dict, compile_c: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        path.write_text(SCENE.format(strain=strain, na=AXIAL, nt=nt))
        env = dict(os.environ, SYMGEN_CACHE_DIR=str(Path(tmp) / "cache"))
        code = MEASURE.format(root=str(ROOT), path=str(path), tmp=tmp, force=force, compile=compile_c)
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def run(repeats: int, quick: bool = False) -> str:
    """Markdown of this section (``quick``: nt = 4 and 6, nothing compiled). One measurement per
    model: operation counts and sizes do not vary; the times are CPU seconds of one process."""
    counts = COUNTS[:2] if quick else COUNTS
    rows = []
    for nt in counts:
        for label, strain, force in (
            ("von Karman", "von_karman", {}),
            ("exact, expanded", "exact", {"e6": False, "c5": False}),
            ("exact, node form", "exact", {}),
        ):
            r = measure(strain, nt, force, compile_c=not quick)
            rows.append((nt, label, r))
            print(f"exact_nodes: nt = {nt}, {label}: {json.dumps(r)}", file=sys.stderr, flush=True)
    out = [
        "## Exact bar: sums over the tables against the node form (`bench_exact_nodes.py`)",
        "",
        f"One elastic rod, {AXIAL} axial + nt transverse functions, quasi-static axial, damped; "
        "CPU s of one fresh process each; ops = CasADi `n_instructions`; C = all units of the "
        "compiled runner; compile = CPU s of compiling them (-O1 `dae`, -O0 the cold units).",
        "",
        "| nt | bar | derive s | build s | res ops | dae ops | jac_dae ops | C kB | compile s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for nt, label, r in rows:
        ops = r["ops"]
        cs = "" if r["compile_s"] is None else f"{r['compile_s']:.1f}"
        out.append(
            f"| {nt} | {label} | {r['derive_s']:.1f} | {r['build_s']:.1f} | {ops['res']} | {ops['dae']} | "
            f"{ops['jac_dae']} | {r['kB']:.0f} | {cs} |"
        )
    return "\n".join(out)


if __name__ == "__main__":
    print(run(1, quick="--quick" in sys.argv))
