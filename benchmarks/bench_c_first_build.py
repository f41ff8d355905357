"""The emitted C solver's first build: a first ``symgen simulate SCENE --solver c --estimate off``
on an empty model cache, in a fresh process, for the tree at REV and for this checkout,
interleaved scene by scene (benchmarks/RESULTS.md, "The emitted C solver's first build").

    python benchmarks/bench_c_first_build.py REV [SCENE.toml ...]

REV is checked out into a temporary git worktree. Each run's wall and CPU seconds (the process
and its compilers), its peak RSS (the largest process: ``/usr/bin/time``), the parts symgen
reports ("C solver built"), and the largest difference of the two trees' outputs over the run as
a fraction of each output's peak (the closure residual, round-off, left out). Prints a Markdown
table. Not a ``run.py`` section: a first build takes minutes on a slot scene.
"""

from __future__ import annotations

import csv
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = [
    ROOT / "benchmarks" / "scenes" / "slot_dyad.toml",
    ROOT / "examples" / "four_bar_tool.toml",
    ROOT / "examples" / "six_bar.toml",
    ROOT / "benchmarks" / "validation" / "slider_crank_steel_rest.toml",
]


def _first_run(tree: Path, scene: Path, work: Path) -> tuple[dict[str, str], Path]:
    cache = work / "cache"
    out = work / "out.csv"
    env = dict(os.environ, SYMGEN_CACHE_DIR=str(cache), PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
    cmd = ["/usr/bin/time", "-f", "TIME %e %U %S %M", sys.executable, "-m", "symgen.cli", "simulate", str(scene)]
    cmd += ["--solver", "c", "--estimate", "off", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env=env, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"{scene.name} at {tree}: {proc.stderr[-2000:]}")
    wall, user, system, rss = re.findall(r"TIME (\S+) (\S+) (\S+) (\S+)", proc.stderr)[-1]
    built = re.search(r"C solver built ([0-9.]+)s", proc.stdout + proc.stderr)
    return {
        "wall": f"{float(wall):.1f}",
        "cpu": f"{float(user) + float(system):.1f}",
        "built": built.group(1) if built else "—",
        "rss": f"{int(rss) / 1024:.0f} MB",
    }, out


def _outputs(path: Path) -> dict[str, list[float]]:
    with path.open() as f:
        rows = list(csv.reader(f))
    return {name: [float(r[j]) for r in rows[1:]] for j, name in enumerate(rows[0])}


def _difference(a: Path, b: Path) -> float:
    ya, yb = _outputs(a), _outputs(b)
    worst = 0.0
    for name, col in ya.items():
        peak = max(abs(x) for x in col)
        if name in ("t", "tau", "closure") or peak == 0:
            continue
        worst = max(worst, max(abs(x - y) for x, y in zip(col, yb[name])) / peak)
    return worst


def main(argv: list[str]) -> None:
    if not argv:
        raise SystemExit(__doc__)
    rev, scenes = argv[0], [Path(s).resolve() for s in argv[1:]] or DEFAULT
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "rev"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-f", "--detach", str(old), rev], check=True)
        try:
            print(
                f"| scene | {rev} wall / CPU s | C solver built | peak RSS | this tree wall / CPU s | C solver built | peak RSS | outputs |"
            )
            print("|---|---|---|---|---|---|---|---|")
            for scene in scenes:
                got = {}
                for label, tree in (("rev", old), ("now", ROOT)):
                    work = Path(tmp) / f"{scene.stem}-{label}"
                    work.mkdir()
                    got[label] = _first_run(tree, scene, work)
                diff = _difference(got["rev"][1], got["now"][1])
                a, b = got["rev"][0], got["now"][0]
                print(
                    f"| {scene.stem} | {a['wall']} / {a['cpu']} | {a['built']} s | {a['rss']} | "
                    f"{b['wall']} / {b['cpu']} | {b['built']} s | {b['rss']} | {diff:.2g} of peak |",
                    flush=True,
                )
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)], check=False)


if __name__ == "__main__":
    main(sys.argv[1:])
