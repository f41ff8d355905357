"""Scene names that would collide in the emitted C: system and FMI headers, CMake's reserved
targets, the runtime's files (issue 22). Each is refused by emit-c with a message, and the list
of header names is checked against what a real compile of the emitted C includes."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from symgen.backends.c.names import CMAKE_TARGETS, HEADER_NAMES, c_prefix_problem
from symgen.cli import main

ROOT = Path(__file__).resolve().parent.parent
CC = shutil.which("cc") or shutil.which("gcc")
IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _scene(tmp_path: Path, name: str) -> Path:
    text = (ROOT / "examples" / "slider_crank.toml").read_text()
    text = re.sub(r'(?m)^name = "slider_crank"', f'name = "{name}"', text, count=1)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "name",
    [
        "math",
        "errno",
        "stdio",
        "Math",
        "all",
        "clean",
        "help",
        "install",
        "test",
        "symgen",
        "symgen_solver",
        "fmi2Functions",
    ],
)
def test_emit_c_refuses_a_colliding_name_with_a_message(tmp_path, capsys, name):
    assert main(["emit-c", str(_scene(tmp_path, name)), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "scene.name" in err and name in err and not (tmp_path / "out").exists(), err


def test_every_reserved_name_is_refused():
    for name in sorted(HEADER_NAMES | CMAKE_TARGETS):
        if IDENT.fullmatch(name):
            assert c_prefix_problem(name) is not None, name


@pytest.mark.skipif(CC is None, reason="needs a C compiler")
def test_the_header_list_covers_every_header_a_build_includes_by_a_bare_name():
    """Ask the compiler which headers a build of the emitted C (model, solver, driver, FMU glue)
    includes; each one found directly in a system include folder could be hidden by a scene's
    NAME.h: its name must be refused."""
    src = ROOT / "generated" / "slider_crank" / "c"
    probe = subprocess.run([CC, "-E", "-v", "-x", "c", "/dev/null"], capture_output=True, text=True)
    lines = probe.stderr.splitlines()
    start = lines.index("#include <...> search starts here:") + 1
    dirs = {Path(d.strip()).resolve() for d in lines[start : lines.index("End of search list.")]}
    fmi = ROOT / "templates" / "c" / "fmi2"
    deps = subprocess.run(
        [CC, "-M", f"-I{src}", f"-I{fmi}", *map(str, sorted(src.glob("*.c")))],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    found = set()
    for token in deps.replace("\\\n", " ").split():
        path = Path(token)
        if token.endswith(".h") and path.is_absolute() and path.resolve().parent in dirs:
            found.add(path.stem)
    found |= {p.stem for p in fmi.glob("*.h")}
    shadowable = {n for n in found if IDENT.fullmatch(n)}
    assert {"math", "stdio", "stdlib"} <= shadowable
    missing = sorted(n for n in shadowable if c_prefix_problem(n) is None)
    assert not missing, f"headers a build includes that a scene name could hide: {missing}"
