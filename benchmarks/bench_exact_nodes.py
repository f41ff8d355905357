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
JAC_COUNTS = (8, 10)
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
import json, os, statistics, subprocess, sys, time, warnings
from pathlib import Path
sys.path.insert(0, {root!r})
warnings.simplefilter("ignore")
import casadi as ca
import symgen.model.bars as bars
bars._NODE_FORM.update({force!r})
from symgen.scene import load_scene
from symgen.model.derive import derive
from symgen.backends.casadi.pipeline import compile_model
from symgen.api import mechanism
from symgen.numerics import compiled
from symgen.numerics import simulate as S
scene = load_scene({path!r})
t0 = time.process_time()
model = derive(scene)
t1 = time.process_time()
funcs = compile_model(model).funcs
t2 = time.process_time()
mech = mechanism(scene)
*_, part = mech.initial_state(0.0)
after = S.DaeRunner(mech, part, 1e-6, 1e-8, backend="vm")._compiled_functions()
variants = {{"after": after}}
if {before!r}:
    # the runner's Jacobian before: CasADi's own choice of AD mode (forward here), no cse
    sym = S._symbolic(mech, part)
    ins = sym["dae"].sx_in()
    outs = sym["dae"].call(ins)
    dae = ca.Function("dae", ins, outs, ca.dyn_in(), ca.dyn_out())
    variants["before"] = [dae, S._dae_jacobian(dae, ins, outs), sym["g"], sym["split"], sym["rec"]]
out = {{"derive_s": t1 - t0, "build_s": t2 - t1, "res": int(funcs["res"].n_instructions())}}
units = {{}}
for name, fs in variants.items():
    where = Path({tmp!r}) / name
    where.mkdir()
    units[name] = compiled.write_units(fs, where, S.COLD)
    out[name] = {{
        "ops": {{f.name(): int(f.n_instructions()) for f in fs}},
        "kB": sum(u.stat().st_size for u in units[name]) / 1e3,
        "jac_kB": sum(u.stat().st_size for u in units[name] if compiled.unit_of(u) == "jac_dae") / 1e3,
    }}
if {repeats!r}:
    comp = compiled.compiler()
    cold = list(compiled.cold_flags(comp))
    hot = compiled.DEFAULT_CFLAGS.split()
    times = {{name: [] for name in variants}}
    jac_times = {{name: [] for name in variants}}
    for _ in range({repeats!r}):
        for name in variants:  # interleaved
            total = 0.0
            for u in units[name]:
                flags = cold if compiled.unit_of(u) in S.COLD else hot
                c0 = os.times()
                subprocess.run(["nice", "-n", "5", comp.path, *flags, "-fPIC", "-c", str(u), "-o", str(u.with_suffix(".o"))], check=True)
                c1 = os.times()
                dt = c1.children_user + c1.children_system - c0.children_user - c0.children_system
                total += dt
                if compiled.unit_of(u) == "jac_dae":
                    jac_times[name].append(dt)
            times[name].append(total)
    for name in variants:
        out[name]["compile_s"] = statistics.median(times[name])
        out[name]["jac_compile_s"] = statistics.median(jac_times[name])
print(json.dumps(out))
"""


def measure(strain: str, nt: int, force: dict, repeats: int, before: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.toml"
        path.write_text(SCENE.format(strain=strain, na=AXIAL, nt=nt))
        env = dict(os.environ, SYMGEN_CACHE_DIR=str(Path(tmp) / "cache"))
        code = MEASURE.format(root=str(ROOT), path=str(path), tmp=tmp, force=force, repeats=repeats, before=before)
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def run(repeats: int, quick: bool = False) -> str:
    """Markdown of this section (``quick``: nt = 4 and 6, nothing compiled). One derivation per
    model (operation counts and sizes do not vary; derive and build are CPU seconds of one
    process); the runner's Jacobian before and after (``simulate.AD_WEIGHT`` and cse) compiled
    ``repeats`` times each, interleaved, at nt = 8 and 10 (medians)."""
    counts = COUNTS[:2] if quick else COUNTS
    rows = []
    for nt in counts:
        for label, strain, force in (
            ("von Karman", "von_karman", {}),
            ("exact, expanded", "exact", {"e6": False, "c5": False}),
            ("exact, node form", "exact", {}),
        ):
            jac = label == "exact, node form" and nt in JAC_COUNTS and not quick
            r = measure(strain, nt, force, repeats if jac else 0, before=jac)
            rows.append((nt, label, r))
            print(f"exact_nodes: nt = {nt}, {label}: {json.dumps(r)}", file=sys.stderr, flush=True)
    out = [
        "## Exact bar: sums over the tables against the node form (`bench_exact_nodes.py`)",
        "",
        f"One elastic rod, {AXIAL} axial + nt transverse functions, quasi-static axial, damped; "
        "CPU s of one fresh process each; ops = CasADi `n_instructions`; C = all units of the "
        "compiled runner (`jac_dae` by reverse mode, each unit's repeated operations made once: "
        "`simulate.AD_WEIGHT`, `simulate._shared`).",
        "",
        "| nt | bar | derive s | build s | res ops | dae ops | jac_dae ops | g ops | C kB |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for nt, label, r in rows:
        a = r["after"]
        ops = a["ops"]
        out.append(
            f"| {nt} | {label} | {r['derive_s']:.1f} | {r['build_s']:.1f} | {r['res']} | {ops['dae']} | "
            f"{ops['jac_dae']} | {ops['g']} | {a['kB']:.0f} |"
        )
    jac_rows = [(nt, r) for nt, _, r in rows if "before" in r]
    if jac_rows:
        out += [
            "",
            "The runner's Jacobian `jac_dae` of the node form before (CasADi's choice of AD mode, "
            "forward here; no cse) and after (reverse mode, `ad_weight` 1, and `casadi.cse` on "
            f"every compiled unit): compile = CPU s of all units, median of {repeats}, interleaved "
            "(-O1 `dae`, -O0 the cold units, as a first run does).",
            "",
            "| nt | runner | dae ops | jac_dae ops | g ops | C MB (jac_dae) | compile CPU s (jac_dae) |",
            "|---|---|---|---|---|---|---|",
        ]
        for nt, r in jac_rows:
            for name in ("before", "after"):
                v = r[name]
                out.append(
                    f"| {nt} | {name} | {v['ops']['dae']} | {v['ops']['jac_dae']} | {v['ops']['g']} | "
                    f"{v['kB'] / 1e3:.1f} ({v['jac_kB'] / 1e3:.1f}) | {v['compile_s']:.1f} ({v['jac_compile_s']:.1f}) |"
                )
    return "\n".join(out)


if __name__ == "__main__":
    print(run(1, quick="--quick" in sys.argv))
