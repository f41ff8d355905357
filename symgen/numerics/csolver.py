"""``symgen simulate --solver c``: the emitted C (``symgen emit-c``: model, Radau IIA solver,
CSV driver) compiled once into a cached executable and run for the scene.

The executable is cached under ``<cache root>/compiled/<entry>/`` (``sim`` and ``manifest.json``)
like the compiled libraries of :mod:`symgen.numerics.compiled`: the entry's name hashes the scene
(without its [simulation] table: the emitted C holds the rest, e.g. the initial guess), the
derived model's structure key, the C templates and runtime, the symgen version, the compiler's path and
``--version`` and the flags; the executable's keyed hash (``symgen.cache.seal``) is checked
before every run, and the verified bytes are run from a private copy. The model parameters are
passed with ``--set`` at full precision, the times and tolerances with ``--t-end``, ``--step``,
``--rtol`` and ``--atol``: the run is the scene's, in the model's units, and its rows are
written like those of the IDAS path.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import tempfile
import time
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from symgen import __version__, cache
from symgen.processes import announce_compile, run_group
from symgen.errors import Interrupted, SceneError, SimulationError
from symgen.policy import POLICY
from symgen.numerics import compiled, interrupt
from symgen.numerics.mechanism import Mechanism
from symgen.numerics.simulate import SimResult

if TYPE_CHECKING:
    from symgen.scene.model import Scene

FORMAT = "symgen-c-solver-cache"
FORMAT_VERSION = 2  # 2: keyed hashes (HMAC-SHA256 with the user's key)
EXECUTABLE = "sim"
_STATS = re.compile(r"(\d+) steps \(.*closure residual max ([^;\s]+)(?:; solver CPU (\S+) s)?")


def scene_key(scene: Scene) -> str:
    """sha256 of the scene without its [simulation] table (times, tolerances: given to the
    executable on its command line) and its file's path: what the emitted C is made from."""
    data = dataclasses.asdict(scene)
    for name in ("hash", "path", "simulation"):
        data.pop(name, None)
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()


def templates_digest() -> str:
    """sha256 over the C templates and the C runtime (names and bytes): an edited template or
    runtime file is another executable."""
    from symgen.backends import templates

    runtime = resources.files("symgen.backends.c") / "runtime"  # emit.c.render.RUNTIME, without jinja2
    h = hashlib.sha256()
    for folder in (templates.folder("c"), runtime):
        for item in sorted(folder.iterdir(), key=lambda e: e.name):
            if item.is_file():
                h.update(item.name.encode() + b"\0" + item.read_bytes() + b"\0")
    return h.hexdigest()


def _key(scene: Scene, comp: compiled.Compiler) -> dict[str, object]:
    """What the executable is made from (``radau``: the method's and the step control's constants,
    rendered into the C from symgen/backends/c/radau.py; ``policy``: the solver policy's tolerances
    and limits, from symgen/policy.py). ``model``: the derived model's structure key (derivation
    version, per-bar axial treatment, ...): the same scene file derives another model when
    symgen's rules change, and an executable of the old model must not be loaded for it."""
    from symgen.backends.c import radau
    from symgen.backends.c.build import STRICT_C
    from symgen.model.structure import structure_key, structure_of

    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "symgen": __version__,
        "scene": scene_key(scene),
        "model": structure_key(structure_of(scene)),
        "templates": templates_digest(),
        "radau": json.loads(json.dumps(radau.constants())),  # as the manifest holds it (lists)
        "policy": POLICY.as_dict(),
        "compiler": comp.identity(),
        "strict": list(STRICT_C),
    }


def executable(mech: Mechanism, use_cache: bool = True) -> tuple[bytes, bool]:
    """The verified bytes of the scene's C simulator and whether it was built now.
    Raises SceneError (``--solver``) when no C compiler works."""
    try:
        comp = compiled.compiler()
    except compiled.Unavailable as exc:
        raise _no_compiler(exc.reason) from None
    key = _key(mech.scene, comp)
    where = cache.compiled_dir() / ("c" + hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:19])
    replace = False
    if use_cache and where.exists():
        try:
            return compiled.read_verified(where, key, EXECUTABLE), False
        except cache.InvalidEntry as exc:
            compiled.report_rebuild(where, exc.reason)
            replace = True
        except FileNotFoundError:
            pass
    return _build(mech, comp, where, key, use_cache, replace), True


def _no_compiler(reason: str) -> SceneError:
    return SceneError(
        "command line",
        "--solver",
        f"c: {reason}",
        f"install a C compiler or set ${compiled.CC_ENV} to one; or leave out --solver c (IDAS)",
    )


def _build(
    mech: Mechanism, comp: compiled.Compiler, where: Path, key: dict[str, object], store: bool, replace: bool
) -> bytes:
    from symgen.model.derive import derive
    from symgen.backends.c import c_context
    from symgen.backends.c.build import STRICT_C
    from symgen.backends.c.render import render_files
    from symgen.numerics.start import start_plan

    scene = mech.scene
    ctx = c_context(scene, derive(scene), start_plan(mech), info=mech.info)
    files = render_files(ctx)
    prefix = ctx["prefix"]
    parent, store = compiled.build_folder(where, store)
    with cache.temp_dir(parent, where.name) as tmp:
        src = tmp / "src"
        src.mkdir()
        for name, text in files.items():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            (src / name).write_text(text)
        cmd = [
            comp.path,
            *STRICT_C,
            *comp.flags,
            f"-I{src}",
            *(str(src / f"{prefix}{s}.c") for s in ("", "_solver", "_sim")),
            "-o",
            str(tmp / EXECUTABLE),
            "-lm",
        ]
        size = sum(len(text.encode()) for name, text in files.items() if name.endswith(".c"))
        label = announce_compile("the C solver", size, "leave out --solver c to run with IDAS without compiling it")
        try:  # in a process group of its own: an interrupt kills cc1 too
            proc = run_group(cmd, timeout=compiled.COMPILE_TIMEOUT_S, progress=label)
        except (OSError, subprocess.SubprocessError) as exc:
            raise _no_compiler(f"the C compiler {comp.path} cannot be run ({exc})") from None
        if proc.returncode != 0:
            first = next((ln for ln in proc.stderr.splitlines() if ln.strip()), "no message")
            raise _no_compiler(
                f"the C compiler {comp.path} failed on the emitted C (exit {proc.returncode}: {first[:200]})"
            )
        blob = (tmp / EXECUTABLE).read_bytes()
        if store:
            shutil.rmtree(src)
            compiled.install(tmp, where, key, EXECUTABLE, blob, replace)
    return blob


def simulate_c(mech: Mechanism, use_cache: bool = True) -> SimResult:
    """The scene's run with the emitted C Radau IIA solver (outputs only: no states)."""
    sim = mech.scene.simulation
    t_setup = time.perf_counter()
    blob, built = executable(mech, use_cache)
    setup_s = time.perf_counter() - t_setup
    n_rows = int(math.floor(sim.t_end / sim.output_step + 1e-9)) + 1
    args = [
        "--stats",
        "--t-end",
        repr(float(sim.t_end)),
        "--step",
        repr(float(sim.output_step)),
        "--rtol",
        repr(float(sim.rtol)),
        "--atol",
        repr(float(sim.atol)),
        "--max-rows",
        str(n_rows),
        "--max-t-end",
        repr(float(sim.t_end)),
    ]
    for name, value in zip(mech.info.params, mech.p):
        args += ["--set", f"{name}={float(value)!r}"]
    private = Path(tempfile.mkdtemp(prefix="symgen-sim-"))
    tic = time.perf_counter()
    try:
        exe = private / EXECUTABLE
        fd = os.open(exe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o700)
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        proc = subprocess.Popen(
            [str(exe), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL
        )
        try:
            out, err = proc.communicate()
        except BaseException as exc:
            proc.kill()
            proc.wait()
            stop = interrupt.interrupted(exc, 0.0)
            if isinstance(stop, Interrupted):
                raise stop from None
            raise
    finally:
        shutil.rmtree(private, ignore_errors=True)
    elapsed = time.perf_counter() - tic
    lines = out.splitlines()
    names = list(mech.info.outputs)
    if proc.returncode == 2 or not lines or lines[0].split(",") != ["tau", *names]:
        msg = err.strip().splitlines()[0] if err.strip() else f"exit code {proc.returncode}"
        raise SimulationError(None, f"the C solver refused the run: {msg}")
    rows = np.array([[float(w) for w in ln.split(",")] for ln in lines[1:]], dtype=float).reshape(-1, 1 + len(names))
    steps, closure, solve_cpu = 0, float("nan"), float("nan")
    m = _STATS.search(err)
    if m:
        steps, closure = int(m.group(1)), float(m.group(2))
        solve_cpu = float(m.group(3)) if m.group(3) else float("nan")
    n = len(rows)
    result = SimResult(
        tau=rows[:, 0],
        outputs=rows[:, 1:],
        output_names=names,
        q=np.zeros((n, 0)),
        v=np.zeros((n, 0)),
        lam=np.zeros((n, 0)),
        closure_max=closure,
        steps=steps,
        simulate_s=elapsed,
        partition=None,
        complete=proc.returncode == 0,
        stats={"backend": "c", "library": "built" if built else "cached", "setup_s": setup_s, "solve_cpu_s": solve_cpu},
    )
    if proc.returncode != 0:
        msg = next((ln for ln in reversed(err.strip().splitlines()) if "steps (" not in ln), "the C solver stopped")
        msg = msg.split(": ", 1)[-1]
        stopped = SimulationError(
            float(rows[-1, 0]) if n else 0.0,
            f"the C solver stopped: {msg}",
            "tighten or loosen simulation.rtol/atol, or use the IDAS path (leave out --solver c)",
        )
        result.failure = str(stopped)
        stopped.partial = result  # symgen.errors does not declare SimulationError.partial
        raise stopped
    return result
