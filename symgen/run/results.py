"""Results files: OUT.csv + OUT.json (the contract), written atomically.

A run that stops early writes ``OUT.partial.csv`` / ``OUT.partial.json`` instead (status
"partial" and the cause in the JSON) and removes any older OUT.csv / OUT.json, so that nothing
left behind looks like a complete result.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np


def atomic_write(path: str | os.PathLike, text: str) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def csv_text(tau: np.ndarray, values: np.ndarray, names: list[str], time_name: str = "tau") -> str:
    lines = [",".join([time_name, *names])]
    for t, row in zip(tau, values):
        lines.append(",".join(repr(float(x)) for x in (t, *row)))
    return "\n".join(lines) + "\n"


def partial_paths(out: Path) -> tuple[Path, Path]:
    return out.with_name(out.stem + ".partial.csv"), out.with_name(out.stem + ".partial.json")


def write_results(out: str | os.PathLike, tau, values, names, meta: dict, complete: bool = True,
                  time_name: str = "tau") -> Path:
    """Write the CSV and its JSON sidecar; return the CSV path actually written. The first column
    is ``time_name`` (``tau``, or ``t`` in seconds for SI results)."""
    out = Path(out)
    pcsv, pjson = partial_paths(out)
    if complete:
        csv_path, json_path = out, out.with_suffix(".json")
        for stale in (pcsv, pjson):
            stale.unlink(missing_ok=True)
    else:
        csv_path, json_path = pcsv, pjson
        for stale in (out, out.with_suffix(".json")):
            stale.unlink(missing_ok=True)
    atomic_write(json_path, json.dumps(meta, indent=1, default=_jsonable) + "\n")
    atomic_write(csv_path, csv_text(np.asarray(tau), np.asarray(values).reshape(len(tau), -1), names,
                                        time_name))
    return csv_path


def _jsonable(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x)}")
