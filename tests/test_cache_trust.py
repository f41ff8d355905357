"""What a cache that others can write may hold, and what symgen does with it (docs/threat-model.md).

Each planted payload is first shown to work (it creates a marker file when it runs); then
symgen meets it in its cache, in a fresh process, and the marker must stay absent: nothing the
user did not build runs, and the run still gives its result. Whoever can write the cache folder
can recompute a plain sha256, but not the keyed hash of this user's key.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from symgen import cache

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "slider_crank.toml"
# one model entry per run: the error estimate's richer model (a second entry) is left out here
# (tests/test_error_estimate.py covers it)
SHORT = ["--set", "simulation.cycles=0.05", "--estimate", "off"]

pytestmark = pytest.mark.skipif(
    shutil.which("cc") is None and shutil.which("gcc") is None,
    reason="needs a C compiler to build the planted libraries",
)


def _env(tmp: Path, **extra: str) -> dict:
    env = {
        **os.environ,
        "SYMGEN_CACHE_DIR": str(tmp / "cache"),
        "XDG_CONFIG_HOME": str(tmp / "config"),
        "MPLBACKEND": "Agg",
        "PYTHONPATH": str(ROOT),
    }
    env.update(extra)
    return env


def _symgen(tmp: Path, *args: str, timeout: float = 300, **extra: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "symgen.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=_env(tmp, **extra),
        cwd=tmp,
        stdin=subprocess.DEVNULL,
    )


def _evil_library(tmp: Path, marker: Path, extra_c: str = "") -> Path:
    """A shared library whose constructor creates ``marker`` when it is loaded."""
    src = tmp / "evil.c"
    src.write_text(
        "#include <stdio.h>\n"
        f'__attribute__((constructor)) static void pwn(void) {{ FILE *f = fopen("{marker}", "w"); '
        "if (f) fclose(f); }\n" + extra_c
    )
    lib = tmp / "evil.so"
    cc = shutil.which("cc") or shutil.which("gcc")
    subprocess.run([cc, "-shared", "-fPIC", str(src), "-o", str(lib)], check=True, capture_output=True)
    return lib


def _loads_marker(lib: Path, marker: Path) -> None:
    """The payload works: loading the library creates the marker."""
    subprocess.run([sys.executable, "-c", f"import ctypes; ctypes.CDLL({str(lib)!r})"], check=True)
    assert marker.exists()
    marker.unlink()


def test_planted_compiled_library_never_runs(tmp_path):
    marker = tmp_path / "pwned-so"
    evil = _evil_library(tmp_path, marker)
    _loads_marker(evil, marker)
    first = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "a.csv", SYMGEN_BACKEND="compiled")
    assert first.returncode == 0, first.stderr
    (entry,) = [p for p in (tmp_path / "cache" / "compiled").iterdir() if not p.name.startswith(".")]
    blob = evil.read_bytes()
    (entry / "model.so").write_bytes(blob)
    manifest = json.loads((entry / "manifest.json").read_text())
    manifest["files"]["model.so"] = cache.sha256_hex(blob)  # all that a writer without the key can do
    (entry / "manifest.json").write_text(json.dumps(manifest))
    again = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "b.csv", SYMGEN_BACKEND="compiled")
    assert again.returncode == 0, again.stderr
    assert not marker.exists()
    assert "model.so does not match the keyed hash" in again.stderr and "rebuilding it" in again.stderr
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def test_planted_casadi_file_never_loads_a_library(tmp_path):
    """A serialized CasADi Function may name a library that CasADi's deserializer loads: a
    planted one is refused before a byte reaches the deserializer."""
    import casadi as ca

    marker = tmp_path / "pwned-casadi"
    x = ca.SX.sym("x")
    gen = tmp_path / "gen"
    gen.mkdir()
    ca.Function("f", [x], [2 * x]).generate("f.c", {"with_header": False})
    shutil.move("f.c", gen / "f.c")
    evil = _evil_library(tmp_path, marker, (gen / "f.c").read_text())
    _loads_marker(evil, marker)
    text = ca.external("f", str(evil)).serialize()
    marker.unlink(missing_ok=True)
    probe = subprocess.run(
        [sys.executable, "-c", "import sys, casadi; casadi.Function.deserialize(sys.stdin.read())"],
        input=text,
        capture_output=True,
        text=True,
    )
    assert marker.exists(), probe.stderr  # the deserializer loads the library it names
    marker.unlink()

    first = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "a.csv")
    assert first.returncode == 0, first.stderr
    (entry,) = [p for p in (tmp_path / "cache" / "models").iterdir() if not p.name.startswith(".")]
    (entry / "res.casadi").write_text(text)
    manifest = json.loads((entry / "manifest.json").read_text())
    manifest["files"]["res.casadi"] = cache.sha256_hex(text.encode())
    (entry / "manifest.json").write_text(json.dumps(manifest))
    again = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "b.csv")
    assert again.returncode == 0, again.stderr
    assert not marker.exists()
    assert "res.casadi does not match the keyed hash" in again.stderr


def test_a_copied_cache_never_verifies_and_a_key_others_can_read_is_refused(tmp_path):
    """A cache written under another user's key (a copied folder) is re-derived; a key file
    that others can read is not used (the run goes on uncached, saying why)."""
    other = tmp_path / "other"
    other.mkdir()
    made = _symgen(other, "simulate", str(SCENE), *SHORT, "-o", "a.csv")
    assert made.returncode == 0, made.stderr
    shutil.copytree(other / "cache", tmp_path / "cache")
    run = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "b.csv")
    assert run.returncode == 0, run.stderr
    assert "does not match the keyed hash" in run.stderr and "re-deriving it" in run.stderr
    assert (tmp_path / "b.csv").read_text() == (other / "a.csv").read_text()

    key = tmp_path / "config" / "symgen" / "cache.key"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600
    assert stat.S_IMODE(key.parent.stat().st_mode) & 0o077 == 0
    key.chmod(0o644)
    loose = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "c.csv")
    assert loose.returncode == 0, loose.stderr
    assert "can be read by others" in loose.stderr and "chmod 600" in loose.stderr
    assert (tmp_path / "c.csv").read_text() == (other / "a.csv").read_text()


def test_a_fifo_in_the_cache_never_hangs_a_run(tmp_path):
    first = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "a.csv")
    assert first.returncode == 0, first.stderr
    (entry,) = [p for p in (tmp_path / "cache" / "models").iterdir() if not p.name.startswith(".")]
    (entry / "manifest.json").unlink()
    os.mkfifo(entry / "manifest.json")
    run = _symgen(tmp_path, "simulate", str(SCENE), *SHORT, "-o", "b.csv", timeout=120)
    assert run.returncode == 0, run.stderr
    assert "manifest.json is not a regular file" in run.stderr
    assert (tmp_path / "b.csv").read_text() == (tmp_path / "a.csv").read_text()


def test_cache_clear_never_follows_a_linked_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    elsewhere = tmp_path / "precious"
    victim = elsewhere / ("0" * 20)  # named like a model entry
    victim.mkdir(parents=True)
    (victim / "data.txt").write_text("keep me")
    (tmp_path / "cache").mkdir()
    os.symlink(elsewhere, tmp_path / "cache" / "models")
    assert cache.clear() == (0, 0)
    assert (victim / "data.txt").read_text() == "keep me"
    assert "is a link" in capsys.readouterr().err


@pytest.mark.parametrize("where", ["file", "devnull", "readonly"])
def test_a_cache_folder_that_cannot_be_written_degrades_with_a_warning(tmp_path, where):
    """$SYMGEN_CACHE_DIR at a regular file, at /dev/null or at a read-only folder: every cache
    (shapes, models, the compiled library) warns and the run goes on uncached (the compiled
    library's folder was an internal error)."""
    if where == "readonly" and os.geteuid() == 0:
        pytest.skip("root writes into a read-only folder")
    target = {"file": tmp_path / "a-file", "devnull": Path("/dev/null"), "readonly": tmp_path / "ro"}[where]
    if where == "file":
        target.write_text("not a folder\n")
    elif where == "readonly":
        target.mkdir()
        target.chmod(0o555)
    run = _symgen(
        tmp_path, "simulate", str(SCENE), *SHORT, "-o", "a.csv", SYMGEN_CACHE_DIR=str(target), SYMGEN_BACKEND="compiled"
    )
    assert run.returncode == 0, run.stderr
    assert "internal error" not in run.stderr and "could not write the cache entry" in run.stderr
    assert "compiled" in run.stderr and (tmp_path / "a.csv").exists()
