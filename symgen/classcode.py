"""The methods :mod:`dataclasses` compiles for symgen's record classes, recalled compiled.

Python (3.11, 3.12) makes each generated method of a dataclass (``__init__``, ``__repr__``,
``__eq__``, ``__hash__``, a frozen class's ``__setattr__`` and ``__delattr__``) by compiling its
text at class creation: ~350 compiles, ~60 ms of CPU in a process that imports the scene, the IR
and a run's records, about a third of a cached ``symgen simulate --solver c`` process
(benchmarks/RESULTS.md, "A cached `symgen simulate SCENE --solver c` process").

:func:`install` gives the module :mod:`dataclasses` an ``exec`` that, for a text compiled for a
class of a symgen module (its globals' ``__name__``), runs the code object an earlier process
compiled from that exact text (the lookup is by the whole text, so a changed class is compiled
anew), and otherwise compiles it as ``exec`` does (no inherited ``__future__`` flags: the same
code object). Any other module's dataclasses go to the builtin ``exec`` unchanged.

The code objects live in one sealed file of the cache, ``code/<interpreter>.bin``
(:func:`symgen.cache.pack`: its keyed hash is checked before a byte is unmarshalled, like a
library before the dynamic loader sees it; docs/threat-model.md), written at exit by a process
that compiled a text it did not find there. A file that does not verify is reported in one line
and the classes are compiled as without it; a cache that cannot be read or written (no key, a
read-only folder) only means they are compiled: nothing is said.
"""

from __future__ import annotations

import builtins
import marshal
import os
import sys
from types import CodeType

__all__ = ["KIND", "install", "path", "stats"]

#: The kind of the sealed file (:func:`symgen.cache.pack`).
KIND = "dataclass-code"
#: At most this many texts are kept (older ones dropped first when a process adds new ones).
MAX_TEXTS = 4000
#: A file larger than this is not read.
MAX_BYTES = 8 << 20

# the file's table: each text's code object, marshalled on its own (unmarshalled when a class
# asks for it: a process uses ~2/3 of the texts the file holds)
_codes: dict[str, bytes] | None = None  # None: not read yet
_used: dict[str, bytes] = {}  # this process's texts (kept first when the file is rewritten)
_new = 0
_loading = False
_stats = {"recalled": 0, "compiled": 0}


def _magic() -> bytes:
    from importlib._bootstrap_external import MAGIC_NUMBER  # already loaded: frozen

    return bytes(MAGIC_NUMBER)


def path() -> str:
    """The file for this interpreter (its bytecode's magic number in the name)."""
    from symgen.cache import code_dir

    tag = getattr(sys.implementation, "cache_tag", None) or "python"
    return os.path.join(os.fspath(code_dir()), f"{tag}-{_magic().hex()}.bin")


def _read() -> dict[str, bytes]:
    """The verified file's marshalled code objects by text; {} when there is none or it does not
    verify."""
    from symgen import cache

    where = path()
    try:
        data = cache.read_bytes(where, MAX_BYTES)
    except (OSError, cache.InvalidEntry):  # none yet, the folder a file, ...: compiled, silently
        return {}
    try:
        payload = cache.unpack(KIND, data)  # the keyed hash, before marshal sees a byte
    except cache.InvalidEntry as exc:
        if exc.reason.startswith("cannot be verified"):
            return {}  # no key: nothing loaded, nothing said (the model cache says it)
        print(f"symgen: warning: cache entry {where} {exc.reason}; compiling the classes again", file=sys.stderr)
        return {}
    magic = _magic()
    if payload[: len(magic)] != magic:
        return {}  # another interpreter's bytecode under this name: not an error
    try:
        table = marshal.loads(payload[len(magic) :])
    except (EOFError, ValueError, TypeError):
        table = None
    if not isinstance(table, dict) or not all(type(k) is str and type(v) is bytes for k, v in table.items()):
        print(
            f"symgen: warning: cache entry {where} is not a table of code; compiling the classes again", file=sys.stderr
        )
        return {}
    return table


def _recall(text: str) -> CodeType:
    global _codes, _new, _loading
    if _codes is None:
        if _loading:  # a class made while the file is read (symgen.cache's own): compiled
            return compile(text, "<string>", "exec", dont_inherit=True)
        _loading = True
        try:
            _codes = _read()
        finally:
            _loading = False
    blob = _codes.get(text)
    code = None
    if blob is not None:
        try:
            code = marshal.loads(blob)  # verified with the file
        except (EOFError, ValueError, TypeError):
            code = None
    if type(code) is CodeType and blob is not None:
        _stats["recalled"] += 1
    else:
        code = compile(text, "<string>", "exec", dont_inherit=True)
        blob = marshal.dumps(code)
        _codes[text] = blob
        _new += 1
        _stats["compiled"] += 1
    _used[text] = blob
    return code


def _exec(source: object, globals: dict | None = None, locals: object = None) -> None:
    """``exec`` as :mod:`dataclasses` calls it; a symgen class's text runs its recalled code."""
    if type(source) is str and globals is not None:
        module = str(globals.get("__name__", ""))
        if module == "symgen" or module.startswith("symgen."):
            source = _recall(source)
    builtins.exec(source, globals, locals)  # type: ignore[arg-type]  # noqa: S102 (dataclasses' own exec)


def _write() -> None:
    """At exit: the texts this process compiled anew, with the others read (this process's
    first, then the file's, up to :data:`MAX_TEXTS`), as one sealed file renamed into place."""
    if not _new or _codes is None:
        return
    try:
        from pathlib import Path

        from symgen import cache

        # only into a cache folder that exists, with a key that exists: a command that uses no
        # cache (schema, a --no-cache run on a fresh machine, ...) makes neither
        if not os.path.isdir(cache.cache_root()) or not os.path.isfile(cache.key_path()):
            return
        table = dict(_used)
        for text, code in _codes.items():
            if len(table) >= MAX_TEXTS:
                break
            table.setdefault(text, code)
        blob = cache.pack(KIND, _magic() + marshal.dumps(table))
        where = Path(path())
        where.parent.mkdir(parents=True, exist_ok=True)
        cache.write_atomic(where, blob)
    except Exception:  # a cache that cannot be written: compiled next time, nothing said
        return


def install() -> None:
    """Route :mod:`dataclasses`' compiles through :func:`_exec` (once per process)."""
    import dataclasses

    if getattr(dataclasses, "exec", None) is _exec:
        return
    if os.environ.get("SYMGEN_NO_CLASS_CODE"):
        return
    dataclasses.exec = _exec  # type: ignore[attr-defined]
    import atexit

    atexit.register(_write)


def stats() -> dict[str, int]:
    """How many symgen texts were recalled compiled and how many compiled in this process."""
    return dict(_stats)
