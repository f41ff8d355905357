"""Where the CPU of a default first run goes, part by part (issue 20, item 4; benchmarks/RESULTS.md
"The default first run's parts"). One ``symgen simulate SCENE`` in this process (``symgen.cli.main``,
as a user runs it: default settings, so the default error estimate) with the calls below wrapped:
each call's CPU of this process (``self``, every thread: the compilers' background threads
included) and of its finished child processes (``children``: the C compilers), and wall seconds.
Run it with an empty ``SYMGEN_CACHE_DIR`` (a first run) and with ``OPENBLAS_NUM_THREADS=1`` set
before the start, as ``symgen.cli.main`` sets it for the command (this script imports numpy
first: set here when absent).

    SYMGEN_CACHE_DIR=$(mktemp -d) python benchmarks/first_run_parts.py CHAIN.toml -o out.csv

Chains: ``bench_derivation.scene_text("chain", N, 2, 4)``. Wrapped (nested calls overlap):
``derive`` (SymPy, every model), ``simulate`` (every run: the von Karman run that decides
``effects.strain = "auto"``, the exact bar's run when chosen, the estimate's run of the model at
tighter tolerances and its richer model's run; with the run's IDAS backend, where it switched to
the library, and the coordinates), ``model_form_estimate``, ``richer_mechanism`` (the richer
model's derivation and Functions), ``estimate_errors`` (the whole estimate); then the total.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import resource
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def _cpu() -> tuple[float, float]:
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime, b.ru_utime + b.ru_stime


def _wrap(mod: Any, name: str) -> None:
    f = getattr(mod, name)

    def timed(*args: Any, **kwargs: Any) -> Any:
        (s0, c0), t0 = _cpu(), time.perf_counter()
        out = f(*args, **kwargs)
        (s1, c1), t1 = _cpu(), time.perf_counter()
        rec: dict[str, Any] = {"what": name, "self": round(s1 - s0, 2), "children": round(c1 - c0, 2)}
        rec["wall"] = round(t1 - t0, 2)
        if name == "simulate":
            st = out.stats
            rec.update(n=args[0].info.n, rtol=kwargs.get("rtol"), steps=out.steps, backend=st.get("backend"))
            rec.update(vm_until=st.get("vm_until"), library=st.get("library"))
        print(rec, file=sys.stderr, flush=True)
        return out

    setattr(mod, name, timed)


def main(argv: list[str]) -> None:
    from symgen import cli
    from symgen.model import derive
    from symgen.numerics import error_estimate, model_form, simulate

    for mod, name in (
        (derive, "derive"),
        (simulate, "simulate"),
        (model_form, "model_form_estimate"),
        (error_estimate, "richer_mechanism"),
        (error_estimate, "estimate_errors"),
    ):
        _wrap(mod, name)
    s0, c0 = _cpu()
    code = cli.main(["simulate", *argv])
    s1, c1 = _cpu()
    print(f"TOTAL self {s1 - s0:.2f} children {c1 - c0:.2f} (exit {code})", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
