"""Output files: checked before any work, written atomically.

* ``check_file`` / ``check_folder``: what a command will write is checked up front (the
  suffix, the target not a folder (a file), the nearest existing ancestor a writable folder),
  without creating anything: a bad path is exit 2 before minutes of work, with nothing written.
* ``atomic_write`` / ``atomic_path``: every file appears complete or not at all: written to a
  temporary file in the same folder, then renamed over the target (``os.replace``); the
  temporary file is removed when anything fails (or the run is interrupted). Files get the
  usual mode (0666 less the umask), not ``mkstemp``'s 0600.
* ``stale_removed_on_failure``: a command that fails or is interrupted leaves none of its
  output files from an earlier run behind looking like its own result (every command that
  writes files runs inside it: ``symgen.cli.main``).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from collections.abc import Iterable, Iterator

from symgen.errors import SceneError, SymgenError


class OutputError(SymgenError):
    """An output file could not be written (disk full, permissions changed during the run, ...)."""

    def __init__(self, path: Path, err: OSError) -> None:
        self.path = Path(path)
        super().__init__(f"cannot write {str(path)!r}: {err.strerror or err}")


#: Bytes that the names symgen writes beside an output add to its name: the temporary file of
#: an atomic write of the partial twin, ``.OUT.partial.csv.XXXXXXXX.tmp.csv``, is the longest.
NAME_MARGIN = 32


def _writable_ancestor(path: Path, key: str, what: str) -> None:
    """The nearest existing ancestor of ``path`` must be a folder we may create files in, and
    the names of ``path`` and of the files written beside it must fit in that folder."""
    parent = _existing_ancestor(path)
    _name_fits(path, parent, key)
    if not parent.is_dir():
        raise SceneError(
            "command line",
            key,
            f"cannot write {str(path)!r}: {str(parent)!r} is not a folder",
            f"choose {what} in an existing folder (or one that can be created)",
        )
    if not os.access(parent, os.W_OK | os.X_OK):
        raise SceneError(
            "command line",
            key,
            f"cannot write {str(path)!r}: the folder {str(parent)!r} is not writable",
            f"choose {what} in a folder you can write to",
        )


def _existing_ancestor(path: Path) -> Path:
    parent = path.parent
    while not parent.exists():
        if parent.is_symlink():  # a dangling link: cannot be created through
            break
        parent = parent.parent
    return parent


def _name_fits(path: Path, existing: Path, key: str) -> None:
    """Every component of ``path`` fits the file system's name length (NAME_MAX), the last one
    with :data:`NAME_MARGIN` to spare: a legal name whose temporary or partial twin is too long
    failed after the work (an internal error)."""
    try:
        limit = os.pathconf(existing if existing.is_dir() else existing.parent, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    parts = path.parts
    for i, part in enumerate(parts):
        size = len(os.fsencode(part))
        room = limit - (NAME_MARGIN if i == len(parts) - 1 else 0)
        if size > room:
            raise SceneError(
                "command line",
                key,
                f"the name {part[:40]!r}... is {size} bytes: "
                + (
                    f"symgen writes files beside it with names up to {NAME_MARGIN} bytes longer, and "
                    if i == len(parts) - 1
                    else ""
                )
                + f"this file system allows names of at most {limit} bytes",
                f"choose a name of at most {room} bytes",
            )


def check_file(path: str | os.PathLike, suffixes: tuple, key: str, also: Iterable[str | os.PathLike] = ()) -> Path:
    """Check an output file before any work (``also``: companion files written beside it,
    e.g. the JSON sidecar, which must not be folders either). Creates nothing."""
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise SceneError(
            "command line",
            key,
            f"{str(path)!r} should end in {' or '.join(suffixes)}",
            f"give a file name like out/result{suffixes[0]}",
        )
    _name_fits(p, _existing_ancestor(p), key)  # first: is_dir() raises on a name too long
    for q in (p, *map(Path, also)):
        if q.is_dir():
            raise SceneError(
                "command line",
                key,
                f"{str(q)!r} is a folder, not a file",
                f"give a file name like {q / ('result' + suffixes[0])}",
            )
    _writable_ancestor(p, key, "a file")
    if p.exists() and not os.access(p.parent, os.W_OK | os.X_OK):
        raise SceneError(
            "command line",
            key,
            f"cannot replace {str(p)!r}: its folder is not writable",
            "choose a file in a folder you can write to",
        )
    return p


def check_folder(path: str | os.PathLike, key: str) -> Path:
    """Check an output folder before any work: a folder (existing, writable) or creatable."""
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise SceneError(
                "command line", key, f"{str(path)!r} exists and is not a folder", "give a folder name, e.g. out/results"
            )
        if not os.access(p, os.W_OK | os.X_OK):
            raise SceneError(
                "command line", key, f"the folder {str(path)!r} is not writable", "choose a folder you can write to"
            )
        _name_fits(p, p, key)
        return p
    _writable_ancestor(p, key, "a folder")
    return p


def _mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix) to write to; on success it is
    renamed over ``path``, on any failure (or interrupt) it is removed. For writers that want
    a file name (``savefig``, ``zipfile``)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    except OSError as err:
        raise OutputError(path, err) from None
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, _mode())
        os.replace(tmp, path)
    except BaseException as err:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise OutputError(path, err) from None
        raise


def atomic_write(path: str | os.PathLike, data: str | bytes) -> Path:
    """Write ``data`` (text: UTF-8) to ``path`` atomically; return ``path``."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
            fh.flush()
            os.fsync(fh.fileno())
    return Path(path)


def remove(paths: Iterable[str | os.PathLike]) -> None:
    """Remove files that are there (stale results); folders are left alone."""
    for p in paths:
        p = Path(p)
        if p.is_file() or p.is_symlink():
            p.unlink(missing_ok=True)


def _identity(path: Path) -> tuple | None:
    try:
        st = os.lstat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_mtime_ns, st.st_size)


@contextlib.contextmanager
def stale_removed_on_failure(paths: Iterable[str | os.PathLike]) -> Iterator[None]:
    """The output files of one command: when the block fails or is interrupted, those that are
    still the files of an earlier run (unchanged since the block began) are removed, so that no
    complete-looking result of an earlier run is left where this one failed. Files this run
    wrote itself (a partial result, which says so) are kept: atomic writes give them a new
    identity. Folders are never removed."""
    before = {Path(p): _identity(Path(p)) for p in paths}
    try:
        yield
    except BaseException:
        remove([p for p, ident in before.items() if ident is not None and _identity(p) == ident])
        raise


def printable(text: object) -> str:
    """Text from outside (a file name) made safe to show in a one-line context: a TeX ``%``
    comment, a figure title. Every character that is not printable (a line break, which would
    end a comment and make the rest live TeX, a carriage return, a tab, a Unicode line
    separator) becomes ``?``."""
    return "".join(c if c.isprintable() else "?" for c in str(text))
