"""symgen benchmarks: prints a table and writes benchmarks/RESULTS.md.

    python benchmarks/run.py                 # every section, 3 repeats (medians)
    python benchmarks/run.py --repeats 5
    python benchmarks/run.py --only examples # one section (the others in RESULTS.md are kept)
    python benchmarks/run.py --only exudyn --quick   # small grids, one turn: a smoke run (not written)

Each section is a module ``benchmarks/bench_<name>.py`` with ``run(repeats) -> str`` (Markdown;
sections that have a quick mode take ``quick=True`` too).
Times are medians of repeats measured in one run on this machine (shared, noisy machines:
compare ratios within a run, not absolute numbers across runs).
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import os
import platform
import re
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

SECTIONS = [
    "examples",
    "derivation",
    "tolerances",
    "faster",
    "backends",
    "integrators",
    "exudyn",
    "exudyn_seed",
    "c",
    "hard",
    "spinup",
    "overhang",
    "sixbar",
    "lean",
    "compile",
    "perstep",
    "validation",
    "bases",
    "estimate",
    "estimate_cost",
    "rtol",
    "exact_nodes",
]
#: a section's last line: ``_(section `name` took N s)_``, or for a section run.py does not
#: write (its numbers from a script of its own) ``_(section `name`: how it was made)_``
FOOTER = re.compile(r"^_\(section `(\w+)`(?: took \d+ s|: [^\n]*)\)_$", re.M)


def split_sections(text: str) -> tuple[str, dict[str, str]]:
    """(header, {name: text with its footer}) of a RESULTS.md: each section ends with its footer
    line ``_(section `name` took N s)_``; the header is everything before the first section's
    first ``## `` heading."""
    sections: dict[str, str] = {}
    start = 0
    first = text.find("\n## ")
    header = text[: first + 1] if first >= 0 else text
    start = len(header)
    for m in FOOTER.finditer(text):
        sections[m.group(1)] = text[start : m.end()].strip("\n")
        start = m.end()
    return header, sections


def merge(old: str, header: str, new: dict[str, str]) -> str:
    """RESULTS.md with the ``new`` sections replacing (or added to) those of ``old``, in SECTIONS order."""
    _, sections = split_sections(old) if old else ("", {})
    sections.update(new)
    order = [n for n in SECTIONS if n in sections] + [n for n in sections if n not in SECTIONS]
    return header + "\n\n".join(sections[n] for n in order) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", action="append", choices=SECTIONS)
    ap.add_argument(
        "--quick",
        action="store_true",
        help="small grids for the sections that have them (printed, RESULTS.md left alone)",
    )
    args = ap.parse_args()
    header = "\n".join(
        [
            "# symgen benchmark results",
            "",
            f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
            f"written by `python benchmarks/run.py` (sections updated by `--only NAME`; this one on "
            f"{time.strftime('%Y-%m-%d')}).",
            "",
            "",
        ]
    )
    new = {}
    for name in args.only or SECTIONS:
        module = importlib.import_module(f"bench_{name}")
        t0 = time.perf_counter()
        kw = {"quick": True} if args.quick and "quick" in inspect.signature(module.run).parameters else {}
        text = module.run(args.repeats, **kw)
        print(text, flush=True)
        new[name] = f"{text.rstrip()}\n\n_(section `{name}` took {time.perf_counter() - t0:.0f} s)_"
    if args.quick:
        return
    path = HERE / "RESULTS.md"
    old = path.read_text() if path.exists() and args.only else ""
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text(merge(old, header, new))
    tmp.replace(path)


if __name__ == "__main__":
    main()
