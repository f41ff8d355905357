"""Where the default error estimate's CPU goes, as ``symgen simulate`` runs it (issue 20), before
and after a change (by hand; not a section of benchmarks/run.py).

Each measurement is one process running ``symgen simulate SCENE -o OUT`` (the CLI's ``main``, a
warm model cache: run each scene once first), its CPU (``time.process_time``) split by wrapping
the functions that make the parts: the whole estimate (``results.error_estimate``), the truncation
part's rerun of the richer model (``error_estimate._rerun``), the time part's tighter rerun
(``_tighter_run``), the model-form part (``model_form.estimate``; an "auto" strain decision made
in the process calls it too) and its coupled modes along the run (``model_form._coupled_modes``).
The trees are interleaved, one process each in turn, ``--repeats`` times; medians, ms.

    python benchmarks/estimate_parts_cli.py --before main --repeats 5 benchmarks/validation/five_bar_elastic.toml

*before* is ``git archive REV`` of this repository; *after* this checkout. One model cache
(``SYMGEN_CACHE_DIR``) for both.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PARTS = {
    "estimate": ("symgen.numerics.results", "error_estimate"),
    "truncation rerun": ("symgen.numerics.error_estimate", "_rerun"),
    "tighter rerun": ("symgen.numerics.error_estimate", "_tighter_run"),
    "model form": ("symgen.numerics.model_form", "estimate"),
    "coupled modes": ("symgen.numerics.model_form", "_coupled_modes"),
}


def child(scene: str, out: str) -> None:
    """One ``symgen simulate`` in this process; prints its parts' CPU seconds as JSON."""
    import importlib

    from symgen import cli

    spent: dict[str, float] = {}

    def wrap(label: str, module: str, attr: str) -> None:
        owner = importlib.import_module(module)
        f = getattr(owner, attr)

        def timed(*a: object, **k: object) -> object:
            t = time.process_time()
            try:
                return f(*a, **k)
            finally:
                spent[label] = spent.get(label, 0.0) + time.process_time() - t

        setattr(owner, attr, timed)

    for label, (module, attr) in PARTS.items():
        wrap(label, module, attr)
    t0 = time.process_time()
    try:
        cli.main(["simulate", scene, "-o", out])
    except SystemExit:
        pass
    spent["process"] = time.process_time() - t0
    print(json.dumps(spent))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--before", default="main", help="the git revision of the tree before")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(*args.child)
        return
    with tempfile.TemporaryDirectory() as tmp:
        before = Path(tmp) / "before"
        blob = subprocess.run(["git", "archive", args.before], cwd=ROOT, capture_output=True, check=True).stdout
        with tarfile.open(fileobj=BytesIO(blob)) as tar:
            tar.extractall(before, filter="data")
        trees = {"before": before, "after": ROOT}
        got: dict[tuple[str, str], list[dict[str, float]]] = {}
        for scene in args.scenes:
            path = str(Path(scene).resolve())
            for _ in range(args.repeats):
                for name, tree in trees.items():
                    env = {**os.environ, "PYTHONPATH": str(tree)}
                    env.pop("PYTHONDONTWRITEBYTECODE", None)
                    out = str(Path(tmp) / f"{name}.csv")
                    run = subprocess.run(
                        [sys.executable, str(Path(__file__).resolve()), "--child", path, out],
                        cwd=tree,
                        env=env,
                        capture_output=True,
                        text=True,
                        check=True,
                    )
                    got.setdefault((Path(scene).stem, name), []).append(json.loads(run.stdout.splitlines()[-1]))
    cols = ["process", *PARTS]
    print("| scene | tree | processes | " + " | ".join(cols) + " |")
    print("|---" * (len(cols) + 3) + "|")
    for (scene, name), rows in got.items():
        med = [1e3 * statistics.median(r.get(c, 0.0) for r in rows) for c in cols]
        print(f"| {scene} | {name} | {len(rows)} | " + " | ".join(f"{x:.0f}" for x in med) + " |")


if __name__ == "__main__":
    main()
