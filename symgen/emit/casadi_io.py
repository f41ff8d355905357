"""Saved CasADi Functions of a derived model: write and read them without SymPy."""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import casadi as ca

FUNCTION_NAMES = ("phi", "phid", "phidd", "res", "out", "energy", "closure")
INPUT_NAMES = ("t", "q", "v", "a", "lam", "p")


def save(funcs: dict, meta: dict, directory: str | os.PathLike) -> None:
    """Write ``<fname>.casadi`` and ``model.json`` atomically into ``directory``."""
    directory = Path(directory)
    directory.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".tmp-", dir=directory.parent))
    for name, f in funcs.items():
        f.save(str(tmp / f"{name}.casadi"))
    (tmp / "model.json").write_text(json.dumps(meta, indent=1, sort_keys=True))
    if directory.exists():
        shutil.rmtree(directory, ignore_errors=True)
    os.replace(tmp, directory)


def load(directory: str | os.PathLike) -> tuple[dict, dict]:
    directory = Path(directory)
    meta = json.loads((directory / "model.json").read_text())
    funcs = {name: ca.Function.load(str(directory / f"{name}.casadi")) for name in FUNCTION_NAMES}
    return funcs, meta
