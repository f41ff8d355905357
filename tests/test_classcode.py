"""symgen.classcode: the methods dataclasses compiles for symgen's classes, recalled compiled
from one sealed cache file (verified before it is unmarshalled), the same classes either way."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Imports the scene, the IR and the run's records (most of symgen's dataclasses), makes and
# compares records, and reports what classcode did and a fingerprint of the classes' behaviour.
DRIVER = r"""
import dataclasses, json, sys
from symgen import cache, classcode
if sys.argv[1] == "key":
    cache._user_key()
    cache.cache_root().mkdir(parents=True, exist_ok=True)
import symgen.scene.loader, symgen.numerics.results, symgen.numerics.csolver, symgen.ir.spec
from symgen.policy import POLICY, SolverPolicy
from symgen.scene import load_scene

@dataclasses.dataclass(frozen=True)
class Mine:  # not symgen's: the builtin exec, never recalled
    a: int = 1

if sys.argv[1] == "key":
    scene = load_scene(sys.argv[2], [])
    again = load_scene(sys.argv[2], [])
else:
    scene = again = POLICY
try:
    scene.name = "x"
    frozen = False
except dataclasses.FrozenInstanceError:
    frozen = True
fp = {
    "eq": scene == again and POLICY == SolverPolicy() and Mine() == Mine(),
    "hash": hash(POLICY) == hash(SolverPolicy()),
    "repr": repr(POLICY)[:60] + repr(Mine()),
    "scene_repr": len(repr(scene)),
    "frozen": frozen,
}
print("REPORT " + json.dumps({"stats": classcode.stats(), "fp": fp}))
"""

SCENE = str(ROOT / "examples" / "slider_crank.toml")


def _run(tmp: Path, mode: str = "key", **env_extra: str) -> tuple[dict, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT), SYMGEN_CACHE_DIR=str(tmp / "cache"))
    env["XDG_CONFIG_HOME"] = str(tmp / "config")
    env.pop("SYMGEN_NO_CLASS_CODE", None)
    env.update(env_extra)
    proc = subprocess.run(
        [sys.executable, "-c", DRIVER, mode, SCENE], cwd=tmp, env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("REPORT "))
    return json.loads(line[len("REPORT ") :]), proc.stderr


def _code_files(tmp: Path) -> list[Path]:
    folder = tmp / "cache" / "code"
    return sorted(folder.iterdir()) if folder.is_dir() else []


def test_a_second_process_compiles_none_of_symgens_classes(tmp_path):
    first, err1 = _run(tmp_path)
    total = first["stats"]["compiled"] + first["stats"]["recalled"]  # a text met twice: compiled once
    assert first["stats"]["compiled"] > 100, first
    (written,) = _code_files(tmp_path)
    assert written.name.startswith(sys.implementation.cache_tag)
    second, err2 = _run(tmp_path)
    assert second["stats"] == {"recalled": total, "compiled": 0}, second
    assert second["fp"] == first["fp"]
    assert second["fp"]["eq"] and second["fp"]["hash"] and second["fp"]["frozen"]
    assert "warning" not in err1 + err2
    # the same classes as without it (the builtin exec for every text)
    plain, _ = _run(tmp_path, SYMGEN_NO_CLASS_CODE="1")
    assert plain["stats"] == {"recalled": 0, "compiled": 0}
    assert plain["fp"] == second["fp"]


def test_a_changed_file_is_reported_and_not_loaded(tmp_path):
    _run(tmp_path)
    (path,) = _code_files(tmp_path)
    data = bytearray(path.read_bytes())
    data[-40] ^= 0x01  # inside a code object: the keyed hash no longer matches
    path.write_bytes(bytes(data))
    report, err = _run(tmp_path)
    assert f"cache entry {path} does not match the keyed hash" in err
    assert report["stats"]["compiled"] > 100
    again, err = _run(tmp_path)  # rewritten at the exit of the process that compiled them
    assert again["stats"]["compiled"] == 0 and "warning" not in err


def test_a_file_sealed_with_another_key_is_not_loaded(tmp_path):
    _run(tmp_path)
    (path,) = _code_files(tmp_path)
    (tmp_path / "config" / "symgen" / "cache.key").write_text("0" * 64 + "\n")  # another user's key
    report, err = _run(tmp_path)
    assert "does not match the keyed hash" in err and report["stats"]["compiled"] > 100


def test_nothing_is_written_without_a_cache_or_a_key(tmp_path):
    report, err = _run(tmp_path, mode="nokey")
    assert report["stats"]["compiled"] > 100
    assert not (tmp_path / "cache").exists() and not (tmp_path / "config").exists()
    assert err == ""


def test_cache_info_and_clear_know_the_file(tmp_path, monkeypatch):
    from symgen import cache

    _run(tmp_path)
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    assert "compiled methods of symgen's record classes" in cache.info()
    removed, _ = cache.clear()  # the code file
    assert removed == 1 and not (tmp_path / "cache" / "code").exists()
