"""symgen benchmarks: prints a table and writes benchmarks/RESULTS.md.

    python benchmarks/run.py                 # every section, 3 repeats (medians)
    python benchmarks/run.py --repeats 5
    python benchmarks/run.py --only examples # one section

Each section is a module ``benchmarks/bench_<name>.py`` with ``run(repeats) -> str`` (Markdown).
Times are medians of repeats measured in one run on this machine (shared, noisy machines:
compare ratios within a run, not absolute numbers across runs).
"""
from __future__ import annotations

import argparse
import importlib
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

SECTIONS = ["examples", "derivation", "tolerances", "faster", "exudyn", "c", "hard"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", action="append", choices=SECTIONS)
    args = ap.parse_args()
    parts = ["# symgen benchmark results", "",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
             f"written by `python benchmarks/run.py` on {time.strftime('%Y-%m-%d')}.", ""]
    for name in args.only or SECTIONS:
        module = importlib.import_module(f"bench_{name}")
        t0 = time.perf_counter()
        text = module.run(args.repeats)
        print(text, flush=True)
        parts += [text, f"_(section `{name}` took {time.perf_counter() - t0:.0f} s)_", ""]
    (HERE / "RESULTS.md").write_text("\n".join(parts))


if __name__ == "__main__":
    main()
