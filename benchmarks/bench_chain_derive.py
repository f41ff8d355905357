"""The derivation of chains of N bars, before/after (issue 20, item 4): CPU s of
``symgen.model.derive.derive`` and of the CasADi Functions' construction (``build``), each in a fresh
process with an empty model cache (the shape tables' cache warm: ``--cold`` empties it too), the
two trees interleaved, medians.

    python benchmarks/bench_chain_derive.py BASE_TREE [--repeats 3] [--cold]

BASE_TREE is a checkout of the code before (``git worktree add`` or ``git archive | tar -x``); the
tree after is this one. Scenes: open chains ``bench_derivation.scene_text("chain", N, na, nt)`` and
the four-bar example; ``exact`` the same chain at ``effects.strain = "exact"`` (the model the 12-bar
chain's default first run chooses).
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
from bench_derivation import measure, scene_text  # noqa: E402

CASES = (  # label, (bars, axial, transverse) or an example, --set
    ("chain 2 (2+4)", (2, 2, 4), []),
    ("chain 6 (2+4)", (6, 2, 4), []),
    ("chain 12 (2+4)", (12, 2, 4), []),
    ("chain 12 (4+6)", (12, 4, 6), []),
    ("chain 12 (2+4) exact", (12, 2, 4), ["effects.strain=exact"]),
    ("four_bar", "four_bar", []),
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base", type=Path)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cold", action="store_true", help="empty shape cache too")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="chain-derive-"))
    shapes = None
    if not args.cold:  # one derivation of each scene fills the shape tables' cache
        shapes = work / "shapes"
        shapes.mkdir()
    rows = []
    for label, what, sets in CASES:
        if isinstance(what, str):
            path = ROOT / "examples" / f"{what}.toml"
        else:
            path = work / f"chain{what[0]}_{what[1]}_{what[2]}.toml"
            path.write_text(scene_text("chain", *what))
        if shapes is not None:
            env = dict(os.environ, PYTHONPATH=str(ROOT), SYMGEN_CACHE_DIR=str(shapes))
            fill = f"from symgen.scene import load_scene; from symgen.model.derive import derive; derive(load_scene({str(path)!r}, {list(sets)!r}))"
            subprocess.run([sys.executable, "-c", fill], capture_output=True, env=env, check=True, cwd=work)
            for sub in shapes.iterdir():  # keep the shape tables only, not the derived models
                if sub.name == "models":
                    subprocess.run(["rm", "-rf", str(sub)], check=True)
        runs: dict[str, list] = {"before": [], "after": []}
        for _ in range(args.repeats):
            runs["before"].append(measure(path, sets, args.base, shapes))
            runs["after"].append(measure(path, sets, ROOT, shapes))
        med = {k: {x: statistics.median(r[x] for r in v) for x in ("derive_s", "build_s")} for k, v in runs.items()}
        rows.append((label, runs["after"][0]["n"], med))
        print(label, json.dumps(med), flush=True)
    print("\n| scene | coordinates | before derive | after derive | ratio | before build | after build |")
    print("|---|---|---|---|---|---|---|")
    for label, n, m in rows:
        b, a = m["before"], m["after"]
        print(
            f"| {label} | {n} | {b['derive_s']:.2f} | {a['derive_s']:.2f} | {b['derive_s'] / a['derive_s']:.1f}x "
            f"| {b['build_s']:.2f} | {a['build_s']:.2f} |"
        )


if __name__ == "__main__":
    main()
