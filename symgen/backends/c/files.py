"""Temporary siblings of the emitted outputs, created with the modes of any other output.

``tempfile.mkstemp`` / ``mkdtemp`` create 0600 files and 0700 folders: renamed into place they
would keep those modes. These helpers create them with 0666 / 0777 masked by the umask (what
``open`` and ``mkdir`` give every other file symgen writes), under a fresh hidden name next to
the target so that ``os.replace`` onto it is atomic.
"""

from __future__ import annotations

import os
from pathlib import Path

_ATTEMPTS = 100


def new_file(folder: Path, prefix: str) -> Path:
    """A new empty file ``folder/<prefix><random>`` (mode 0666 & ~umask)."""
    import secrets  # here: a cached run that writes no C imports none of it

    for _ in range(_ATTEMPTS):
        path = Path(folder) / f"{prefix}{secrets.token_hex(6)}"
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return path
    raise FileExistsError(f"no free temporary name {prefix}* in {folder}")


def new_dir(folder: Path, prefix: str) -> Path:
    """A new empty folder ``folder/<prefix><random>`` (mode 0777 & ~umask)."""
    import secrets

    for _ in range(_ATTEMPTS):
        path = Path(folder) / f"{prefix}{secrets.token_hex(6)}"
        try:
            os.mkdir(path, 0o777)
        except FileExistsError:
            continue
        return path
    raise FileExistsError(f"no free temporary name {prefix}* in {folder}")
