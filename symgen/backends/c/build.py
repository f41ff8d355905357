"""Compiler helpers: find a C compiler, compile sources into a shared library or executable.

Used by ``emit-fmu`` (the FMU's binary), the tests and the benchmarks. Flags are the strict
ones the generated code is written for (C99, every warning an error).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence
from pathlib import Path

from symgen.errors import SymgenError
from symgen.processes import run_group

STRICT_C = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")
STRICT_CXX = ("-x", "c++", "-Wall", "-Wextra", "-pedantic", "-Werror")


class BuildError(SymgenError):
    """The C compiler is missing or rejected the generated code."""


def find_cc() -> str:
    """The C compiler: $CC, else cc or gcc on PATH."""
    for cand in (os.environ.get("CC"), "cc", "gcc"):
        if cand and shutil.which(cand.split()[0]):
            return cand
    raise BuildError("no C compiler found (set CC, or install gcc: apt-get install gcc)")


def run(cmd: list[str], cwd: str | os.PathLike[str] | None = None) -> None:
    """Run a compile in a process group of its own (an interrupt kills cc1 too); BuildError if it fails."""
    proc = run_group(cmd, cwd=cwd)
    if proc.returncode != 0:
        raise BuildError(f"the C compiler failed ({' '.join(cmd)}):\n{proc.stderr.strip()[:4000]}")


def compile_shared(
    sources: Sequence[str | os.PathLike[str]],
    output: Path,
    include: Sequence[str | os.PathLike[str]] = (),
    flags: Sequence[str] = STRICT_C,
    opt: str = "-O2",
    cc: str | None = None,
    extra: Sequence[str] = (),
) -> Path:
    """Compile ``sources`` into the shared library ``output`` (position independent, libm)."""
    cc = cc or find_cc()
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    cmd = [
        *cc.split(),
        *flags,
        opt,
        "-shared",
        "-fPIC",
        *extra,
        *[f"-I{d}" for d in include],
        *[str(s) for s in sources],
        "-o",
        str(output),
        "-lm",
    ]
    run(cmd)
    return output


def compile_executable(
    sources: Sequence[str | os.PathLike[str]],
    output: Path,
    include: Sequence[str | os.PathLike[str]] = (),
    flags: Sequence[str] = STRICT_C,
    opt: str = "-O2",
    cc: str | None = None,
) -> Path:
    cc = cc or find_cc()
    output = Path(output)
    cmd = [*cc.split(), *flags, opt, *[f"-I{d}" for d in include], *[str(s) for s in sources], "-o", str(output), "-lm"]
    run(cmd)
    return output
