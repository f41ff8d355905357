"""The on-disk caches: where they live, how an entry is verified, written and removed.

Three caches live under :func:`cache_root` (``$SYMGEN_CACHE_DIR``, default ``~/.cache/symgen``):

``models/<structure key>/``
    derived models: one ``<function>.casadi`` per CasADi Function (CasADi's serialized text),
    ``model.json`` and ``manifest.json`` (format version, symgen and CasADi versions, the
    structure key and the sha256 of every other file); see :mod:`symgen.backends.casadi.store`.
``compiled/<entry>/``
    shared libraries of a model's run-time Functions (``model.so`` and ``manifest.json``), one
    per model, coordinate partition, compiler and flags; see :mod:`symgen.numerics.compiled`.
``shapes/v<version>__<bases>.json``
    closed-form inner products of one bar's shape bases: one file, a header line with the sha256
    of the JSON payload that follows; see :mod:`symgen.model.shapes`.
``code/<interpreter>-<bytecode magic>.bin``
    the methods :mod:`dataclasses` compiles for symgen's record classes, as code objects by their
    text (:mod:`symgen.classcode`): one :func:`pack` file, verified before it is unmarshalled.
``checks/<hash of the question>.json``
    remembered verdicts of checks that need SymPy (is a scene's expression finite over the run?):
    one :func:`pack` file holding the question and its answer (:func:`recall`, :func:`remember`),
    so that a run on a cached model checks its scene without importing SymPy.

The cache is data from elsewhere (a shared home, a copied folder): nothing in it is ever
unpickled or evaluated (but ``code/``'s code objects, which run only once their file verifies,
as a compiled library is loaded only then), and every entry is checked against the keyed hashes (HMAC-SHA256)
recorded when it was written *before* any of its bytes reach a parser, CasADi's deserializer
or the dynamic loader. The key is this user's secret (:func:`key_path`, outside the cache
folder, mode 0600, made on first use): whoever can write the cache folder but cannot read the
key cannot make an entry that verifies, and a cache folder copied from elsewhere never does.
An entry that does not verify is reported in one line on stderr (which entry, why) and
re-derived. ``docs/threat-model.md`` says what is trusted and what is not.

Writers build an entry under a temporary name next to its final place and rename it there in
one step, so a reader sees a whole entry or none; a writer that loses a race, fails or is
interrupted removes its temporary files, and temporaries older than :data:`STALE_TEMP_S`
(left by a killed process) are swept on every write and by ``symgen cache clear``.

Kept free of SymPy and CasADi.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import os
import re
import shutil
import stat
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar
from collections.abc import Callable, Iterator

__all__ = [
    "CACHE_ENV",
    "STALE_TEMP_S",
    "InvalidEntry",
    "StaleEntry",
    "KeyUnavailable",
    "cache_root",
    "models_dir",
    "compiled_dir",
    "shapes_dir",
    "checks_dir",
    "recall",
    "remember",
    "key_path",
    "sha256_hex",
    "seal",
    "verify",
    "read_bytes",
    "pack",
    "unpack",
    "report_invalid",
    "report_unwritable",
    "temp_dir",
    "install_dir",
    "sweep_stale",
    "info",
    "clear",
]

CACHE_ENV = "SYMGEN_CACHE_DIR"
#: A temporary entry older than this (seconds) belongs to a writer that died: swept away.
STALE_TEMP_S = 15 * 60
#: Prefix of every temporary file or folder a writer makes.
TEMP_PREFIX = ".tmp-"

_MODEL_ENTRY = r"[0-9a-f]{20}"
_CHECK_ENTRY = r"[0-9a-f]{32}\.json"
_CODE_ENTRY = r"[0-9A-Za-z_.-]+-[0-9a-f]{8}\.bin"
#: The kind of a remembered verdict's file (:func:`pack`) and the most bytes it may have.
_CHECK_KIND = "check"
_MAX_CHECK_BYTES = 1 << 20
_SHAPE_ENTRY = r"v[0-9A-Za-z.]+__[0-9A-Za-z_.-]+\.json"
_SHAPE_OLD = r"v[0-9A-Za-z.]+__[0-9A-Za-z_.-]+\.pkl(\.[0-9A-Za-z_]+\.tmp)?"
_HEADER = re.compile(rb"symgen-cache ([a-z-]+) hmac-sha256=([0-9a-f]{64})\n")
#: The per-user key of the cache's keyed hashes: 64 hex digits in a file of its own.
_KEY = re.compile(rb"[0-9a-f]{64}\n?")

T = TypeVar("T")


class InvalidEntry(Exception):
    """A cache entry that does not verify; ``reason`` says why (one line)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class StaleEntry(InvalidEntry):
    """An entry written by another symgen, cache format or CasADi: not damage, so it is re-derived
    and overwritten without a warning (an upgrade is not the user's problem)."""


# ----------------------------------------------------------------------------- location
def cache_root() -> Path:
    """``$SYMGEN_CACHE_DIR``, or ``~/.cache/symgen`` when it is unset or empty."""
    root = os.environ.get(CACHE_ENV)
    return Path(root) if root else Path.home() / ".cache" / "symgen"


def models_dir() -> Path:
    return cache_root() / "models"


def shapes_dir() -> Path:
    return cache_root() / "shapes"


def compiled_dir() -> Path:
    return cache_root() / "compiled"


def checks_dir() -> Path:
    return cache_root() / "checks"


def code_dir() -> Path:
    return cache_root() / "code"


class KeyUnavailable(OSError):
    """This user's cache key cannot be read or made (see :func:`key_path`): nothing is loaded
    from the cache and nothing is written to it; the run goes on uncached, with a warning."""


# ----------------------------------------------------------------------------- the key
def key_path() -> Path:
    """This user's cache key: ``$XDG_CONFIG_HOME/symgen/cache.key`` (default
    ``~/.config/symgen/cache.key``). It is never inside the cache folder, so a cache folder
    that is shared, copied or pointed elsewhere by ``$SYMGEN_CACHE_DIR`` brings no key of its own."""
    base = os.environ.get("XDG_CONFIG_HOME") or ""
    root = Path(base) if os.path.isabs(base) else Path.home() / ".config"
    return root / "symgen" / "cache.key"


_keys: dict[str, bytes] = {}


def _check_private(st: os.stat_result, what: str, path: Path, mode_mask: int) -> None:
    uid = os.geteuid() if hasattr(os, "geteuid") else st.st_uid
    if st.st_uid != uid:
        raise KeyUnavailable(
            f"the cache key's {what} {path} belongs to another user (uid {st.st_uid}): "
            f"remove it, or set XDG_CONFIG_HOME to a folder of your own"
        )
    if st.st_mode & mode_mask:
        raise KeyUnavailable(
            f"the cache key's {what} {path} can be {'written' if mode_mask == 0o022 else 'read'} "
            f"by others (mode {stat.S_IMODE(st.st_mode):o}): chmod "
            f"{'go-w' if mode_mask == 0o022 else '600'} {path}, or remove it to make a new key"
        )


def _read_key(path: Path) -> bytes:
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    fd = os.open(path, flags)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise KeyUnavailable(f"the cache key {path} is not a regular file: remove it")
        _check_private(st, "file", path, 0o077)
        data = os.read(fd, 130)
    finally:
        os.close(fd)
    if _KEY.fullmatch(data) is None:
        raise KeyUnavailable(f"the cache key {path} is not 64 hex digits (damaged): remove it to make a new key")
    return bytes.fromhex(data[:64].decode())


def _user_key() -> bytes:
    """The key's bytes, made on first use (a 0700 folder, a 0600 file, linked into place in one
    step so that concurrent first runs agree on one key). :class:`KeyUnavailable` otherwise."""
    path = key_path()
    if str(path) in _keys:
        return _keys[str(path)]
    try:
        try:
            key = _read_key(path)
        except FileNotFoundError:
            path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
            _check_private(os.stat(path.parent), "folder", path.parent, 0o022)
            fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, dir=path.parent)  # mode 0600
            try:
                import secrets  # here: only a first use makes a key

                os.write(fd, secrets.token_hex(32).encode() + b"\n")
                os.close(fd)
                with contextlib.suppress(FileExistsError):  # another process made it first
                    os.link(tmp, path)
            finally:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
            key = _read_key(path)
        else:
            _check_private(os.stat(path.parent), "folder", path.parent, 0o022)
    except KeyUnavailable:
        raise
    except OSError as exc:
        raise KeyUnavailable(
            f"the cache key {path} cannot be read or made ({exc.strerror or exc}): "
            f"set XDG_CONFIG_HOME to a writable folder of your own"
        ) from None
    _keys[str(path)] = key
    return key


# ----------------------------------------------------------------------------- verifying
def sha256_hex(data: bytes) -> str:
    """The plain sha256 of ``data`` (names, fingerprints; never what an entry is verified by)."""
    return hashlib.sha256(data).hexdigest()


def seal(label: str, data: bytes) -> str:
    """The keyed hash (HMAC-SHA256 with this user's key) that a writer records for the file
    ``label`` (``<entry>/<file name>``: a valid file moved to another name or entry no longer
    verifies) holding ``data``. Raises :class:`KeyUnavailable` (an ``OSError``: the writer
    reports the entry unwritable and the run goes on)."""
    return hmac.new(_user_key(), label.encode() + b"\0" + data, hashlib.sha256).hexdigest()


def verify(label: str, data: bytes, recorded: object, name: str | None = None) -> None:
    """Check ``data`` of the file ``label`` against the keyed hash ``recorded`` when it was
    written; else :class:`InvalidEntry` naming the file (``name``, default the last part of
    ``label``; also when this user has no key: an entry that cannot be verified is never trusted)."""
    try:
        expected = seal(label, data)
    except KeyUnavailable as exc:
        raise InvalidEntry(f"cannot be verified: {exc}") from None
    if not isinstance(recorded, str) or not hmac.compare_digest(expected, recorded):
        name = label.rsplit("/", 1)[-1] if name is None else name
        raise InvalidEntry(
            f"{name + ' ' if name else ''}does not match the keyed hash recorded when it was written "
            "(changed, damaged, or written by another user or machine)"
        )


def read_bytes(name: str | os.PathLike, limit: int, dir_fd: int | None = None) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (else :class:`InvalidEntry`, whose
    reason does not name the file: the caller's report does, once, as the entry or its file).

    ``dir_fd``: read ``name`` relative to that open folder (a reader that opened an entry's
    folder keeps reading that folder even if a writer renames another one into its place).
    """
    flags = os.O_RDONLY | getattr(os, "O_BINARY", 0) | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(name, flags, dir_fd=dir_fd) if dir_fd is not None else os.open(name, flags)
    except OSError as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise InvalidEntry(f"cannot be opened ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):  # before fdopen, which refuses a folder with IsADirectoryError
            raise InvalidEntry("is not a regular file")
    except BaseException:
        os.close(fd)
        raise
    with os.fdopen(fd, "rb") as fh:
        if st.st_size > limit:
            raise InvalidEntry(f"is {st.st_size} bytes, more than the {limit} an entry may have")
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise InvalidEntry(f"grew beyond {limit} bytes while read")
    return data


def pack(kind: str, payload: bytes) -> bytes:
    """One self-verifying file: ``symgen-cache <kind> hmac-sha256=<seal of kind and payload>\\n<payload>``
    (the payload names what it holds: the reader checks that too)."""
    return b"symgen-cache %s hmac-sha256=%s\n" % (kind.encode(), seal(kind, payload).encode()) + payload


def unpack(kind: str, data: bytes) -> bytes:
    """The payload of a :func:`pack` file, after checking its kind and keyed hash."""
    end = data.find(b"\n")
    m = _HEADER.fullmatch(data[: end + 1]) if end >= 0 else None
    if m is None:
        raise InvalidEntry("has no valid symgen-cache header (not written by this symgen, or damaged)")
    if m.group(1).decode() != kind:
        raise InvalidEntry(f"is a {m.group(1).decode()!r} entry, not {kind!r}")
    payload = data[end + 1 :]
    verify(kind, payload, m.group(2).decode(), name="")
    return payload


def report_invalid(entry: os.PathLike | str, reason: str | InvalidEntry) -> None:
    """The one stderr line for an entry that did not verify (it is re-derived and overwritten);
    none for a :class:`StaleEntry`, which an upgrade leaves behind."""
    if isinstance(reason, StaleEntry):
        return
    if isinstance(reason, InvalidEntry):
        reason = reason.reason
    print(f"symgen: warning: cache entry {os.fspath(entry)} {reason}; re-deriving it", file=sys.stderr)


def report_unwritable(entry: os.PathLike | str, exc: BaseException) -> None:
    """The one stderr line for an entry that could not be written (the run goes on)."""
    print(
        f"symgen: warning: could not write the cache entry {os.fspath(entry)} ({exc}); the results are "
        f"correct, only not cached (set ${CACHE_ENV} to a writable folder)",
        file=sys.stderr,
    )


# ----------------------------------------------------------------------------- verdicts
def _check_path(question: dict[str, Any]) -> tuple[Path, bytes]:
    text = json.dumps(question, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()
    return checks_dir() / f"{sha256_hex(text)[:32]}.json", text


def read_entry_file(where: Path, name: str, limit: int, dir_fd: int | None = None) -> bytes:
    """:func:`read_bytes` of the file ``name`` of the entry folder ``where`` (relative to its open
    ``dir_fd`` where given), with a reason that names the file (the caller's report names the
    entry)."""
    try:
        return read_bytes(name if dir_fd is not None else where / name, limit, dir_fd=dir_fd)
    except InvalidEntry as exc:
        raise InvalidEntry(f"{name} {exc.reason}") from None


def recall(question: dict[str, Any]) -> tuple[bool, Any]:
    """``(True, answer)`` when a verdict for ``question`` (plain JSON data that names the check,
    its inputs and the symgen version) was remembered by :func:`remember` and verifies (its keyed
    hash, then the question it holds, which must be this one); else ``(False, None)``. A file that
    does not verify is reported in one line and the check is made again."""
    try:
        path, text = _check_path(question)
    except ValueError:  # not a question JSON can hold
        return False, None
    try:
        # an entry that cannot be opened (the cache folder a file, say) is checked again, as one
        # that does not verify
        data = read_bytes(path, _MAX_CHECK_BYTES)
        doc = json.loads(unpack(_CHECK_KIND, data))  # keyed hash checked before any parsing
        if not isinstance(doc, dict) or set(doc) != {"question", "answer"}:
            raise InvalidEntry("is not a remembered verdict")
        if json.dumps(doc["question"], sort_keys=True, separators=(",", ":")).encode() != text:
            raise InvalidEntry("holds the verdict of another question")
    except FileNotFoundError:
        return False, None
    except InvalidEntry as exc:
        print(f"symgen: warning: cache entry {path} {exc.reason}; checking again", file=sys.stderr)
        return False, None
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        print(f"symgen: warning: cache entry {path} is not valid JSON ({exc}); checking again", file=sys.stderr)
        return False, None
    return True, doc["answer"]


def remember(question: dict[str, Any], answer: Any) -> None:
    """Store the verdict ``answer`` (plain JSON data) of ``question`` for :func:`recall`: one
    sealed file, written under a temporary name and renamed into place. A cache that cannot be
    written (or no key) only means the check is made again next time: nothing is said (the model
    cache reports an unwritable folder)."""
    try:
        path, _ = _check_path(question)
        payload = json.dumps({"question": question, "answer": answer}, sort_keys=True, allow_nan=False).encode()
        blob = pack(_CHECK_KIND, payload)
        path.parent.mkdir(parents=True, exist_ok=True)
        sweep_stale(path.parent)
        write_atomic(path, blob)
    except (OSError, ValueError):  # KeyUnavailable included; ValueError: not JSON data
        return


def write_atomic(path: Path, blob: bytes) -> None:
    """``blob`` to ``path`` through a temporary file of the same folder (mode 0600) renamed over
    it: a reader sees the old file or the whole new one, never part of it; the temporary file is
    removed if the write fails (the error raised)."""
    fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def load_private(blob: bytes, name: str, loader: Callable[[Path], T]) -> T:
    """``loader(path)`` of a private copy of verified library bytes ``blob``: written as ``name``
    (read and execute for the user only, created anew: never a file someone else placed) into a
    fresh private folder, loaded (the loader keeps the library mapped), the copy removed at once,
    also when the loader raises. Libraries are loaded from here, never from the shared cache
    folder, and only after :func:`verify` has checked their keyed hash."""
    private = Path(tempfile.mkdtemp(prefix="symgen-lib-"))
    try:
        path = private / name
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o500)
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        return loader(path)
    finally:
        shutil.rmtree(private, ignore_errors=True)


# ----------------------------------------------------------------------------- writing
@contextlib.contextmanager
def temp_dir(parent: Path, name: str) -> Iterator[Path]:
    """A fresh temporary folder in ``parent`` for building entry ``name``; removed on exit
    unless :func:`install_dir` moved it into place (also on errors and KeyboardInterrupt)."""
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f"{TEMP_PREFIX}{name}-", dir=parent))
    try:
        yield tmp
    finally:
        _remove(tmp)


def install_dir(tmp: Path, target: Path, replace: bool) -> bool:
    """Rename the finished folder ``tmp`` to ``target`` in one step.

    When ``target`` exists: with ``replace`` (it failed to verify) it is moved aside and
    removed; without, another writer got there first and ``tmp`` is left for the caller's
    :func:`temp_dir` to remove. Returns whether ``tmp`` was installed.
    """
    try:
        os.rename(tmp, target)
        return True
    except OSError:
        if not os.path.lexists(target):
            raise
    if not replace:
        return False
    trash = Path(tempfile.mkdtemp(prefix=f"{TEMP_PREFIX}old-{target.name}-", dir=target.parent))
    try:
        try:
            os.rename(target, trash / "entry")
        except FileNotFoundError:
            pass
        try:
            os.rename(tmp, target)
            return True
        except OSError:
            if os.path.lexists(target):  # a concurrent writer installed its entry meanwhile
                return False
            raise
    finally:
        _remove(trash)


def _remove(path: Path) -> None:
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink()
    except FileNotFoundError:
        pass
    except OSError:
        pass


def _is_temp(name: str) -> bool:
    return name.startswith(TEMP_PREFIX) or (name.endswith(".tmp") and re.fullmatch(_SHAPE_OLD, name) is not None)


def sweep_stale(parent: Path, max_age: float = STALE_TEMP_S) -> int:
    """Remove temporaries in ``parent`` older than ``max_age`` seconds; returns how many."""
    now = time.time()
    removed = 0
    try:
        entries = list(os.scandir(parent))
    except OSError:
        return 0
    for e in entries:
        if not _is_temp(e.name):
            continue
        try:
            age = now - e.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        if age >= max_age:
            _remove(Path(e.path))
            removed += 1
    return removed


# ----------------------------------------------------------------------------- info / clear
@dataclass
class _Item:
    path: Path
    kind: str  # "model", "compiled", "shapes", "checks", "temp", "old"
    size: int


def _size(path: Path) -> int:
    try:
        if path.is_symlink() or not path.is_dir():
            return path.lstat().st_size
        return sum(_size(p) for p in path.iterdir())
    except OSError:
        return 0


def _owned() -> list[_Item]:
    """Everything under the cache folder that symgen wrote (and nothing else)."""
    items = []
    dirs = (
        (models_dir(), _MODEL_ENTRY),
        (compiled_dir(), _MODEL_ENTRY),
        (shapes_dir(), _SHAPE_ENTRY),
        (checks_dir(), _CHECK_ENTRY),
        (code_dir(), _CODE_ENTRY),
    )
    for sub, entry in dirs:
        try:
            if not stat.S_ISDIR(os.lstat(sub).st_mode):
                continue  # a link (or a file) where symgen makes a folder: never followed
            names = sorted(os.listdir(sub))
        except OSError:
            continue
        for name in names:
            path = sub / name
            if _is_temp(name):
                kind = "temp"
            elif re.fullmatch(entry, name):
                kind = {"models": "model", "compiled": "compiled", "checks": "checks", "code": "code"}.get(
                    sub.name, "shapes"
                )
            elif sub.name == "shapes" and re.fullmatch(_SHAPE_OLD, name):
                kind = "old"  # a pickle from an older symgen: never loaded
            else:
                continue
            items.append(_Item(path, kind, _size(path)))
    return items


def _human(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"  # pragma: no cover


def _count(n: int) -> str:
    return f"{n:4d} {'entry  ' if n == 1 else 'entries'}"


def info() -> str:
    """Text of ``symgen cache info``: location, entries and sizes."""
    root = cache_root()
    source = f"${CACHE_ENV}" if os.environ.get(CACHE_ENV) else f"default; set ${CACHE_ENV} to move it"
    lines = [f"cache: {root} ({source})"]
    items = _owned()
    labels = {
        "model": ("models", "derived models"),
        "compiled": ("compiled", "compiled model libraries"),
        "shapes": ("shapes", "shape inner products"),
        "checks": ("checks", "verdicts of scene checks that need SymPy"),
        "code": ("code", "compiled methods of symgen's record classes"),
        "temp": ("temporary", "unfinished writes"),
        "old": ("old", "pickles of an older symgen, never loaded"),
    }
    for kind, (label, what) in labels.items():
        sel = [i for i in items if i.kind == kind]
        if not sel and kind in ("temp", "old", "compiled", "checks", "code"):
            continue
        lines.append(f"  {label:<10} {_count(len(sel))} {_human(sum(i.size for i in sel)):>10}  ({what})")
    total = sum(i.size for i in items)
    lines.append(f"  {'total':<10} {_count(len(items))} {_human(total):>10}")
    if not root.exists():
        lines.append("  (the folder does not exist yet: it is made on the first derivation)")
    return "\n".join(lines)


def clear() -> tuple[int, int]:
    """Remove every entry, temporary and old-format file symgen wrote under the cache folder
    (nothing else: a cache folder pointed at a folder of other files keeps those).
    Returns (entries removed, bytes freed)."""
    items = _owned()
    for it in items:
        _remove(it.path)
    for sub in (models_dir(), compiled_dir(), shapes_dir(), checks_dir(), code_dir()):
        if os.path.islink(sub):
            print(
                f"symgen: warning: {sub} is a link (to {os.readlink(sub)}): not followed, nothing there "
                f"removed; remove the link by hand if the cache should own that folder",
                file=sys.stderr,
            )
    for sub in (models_dir(), compiled_dir(), shapes_dir(), checks_dir(), code_dir()):
        with contextlib.suppress(OSError):
            if stat.S_ISDIR(os.lstat(sub).st_mode):
                sub.rmdir()  # only when empty
    return len(items), sum(i.size for i in items)
