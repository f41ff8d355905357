"""The model's run-time CasADi Functions compiled to a shared library, cached and verified.

A run's Functions (the DAE residual and its Jacobian for IDAS, the algebraic polish, the
record of an output) are written as C by CasADi's code generator, one translation unit per
Function (one of more operations than ``policy.UNITS`` allows in parts of its output rows, each a
unit of its own, :func:`parts`: the compiler's memory bounded, the same numbers), compiled once by
the system C compiler (the units in parallel, as many at once as there are cores, each compiler
in a process group of its own that an interrupt kills) and linked into one shared library,
loaded with ``casadi.external``; IDAS (``ca.integrator``) then evaluates them as machine code
instead of in CasADi's virtual machine. The C performs the very operations of the virtual
machine in the same order (``-ffp-contract=off``: no fused multiply-adds), so both give the
same numbers to the last bit.

A run's library not in the cache (:func:`start_library`): its C is written, then the compilers
run in a background thread (:class:`PendingLibrary`) while the run starts in the virtual
machine and switches to the library between chunks once it is installed; an interrupt cancels
the build (the compilers' groups killed, the temporary folder removed: nothing that loads is left).

Cache: ``<cache root>/compiled/<entry>/`` with ``model.so`` and ``manifest.json`` (format,
symgen and CasADi versions, the model's structure key and coordinate partition, the compiler's
path and ``--version`` text, the flags, the Function names and the keyed hash of ``model.so``,
``symgen.cache.seal``). The
entry's name hashes all of these, so a change of compiler or flags builds a new library. An
entry is verified before use (manifest fields, then the keyed hash of the library's bytes, which
are then loaded from a private copy, never from the shared folder); one that does not verify is
reported in one line and rebuilt, never loaded.

Environment: ``SYMGEN_CC`` (the compiler; default the first of cc, gcc, clang on PATH),
``SYMGEN_CFLAGS`` (default :data:`DEFAULT_CFLAGS`, and :data:`COLD_CFLAGS` for the Functions a
caller names cold), ``SYMGEN_BACKEND`` (auto, compiled, vm).
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import json
import os
import re
import shutil
import sys
import tempfile
import threading
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypeAlias

from symgen import __version__, cache
from symgen.policy import UNITS
from symgen.processes import Cancelled, announce_compile, jobs, run_group, run_groups

if TYPE_CHECKING:
    import casadi as ca  # imported where used: a cached run of the C solver never imports CasADi

CC_ENV = "SYMGEN_CC"
CFLAGS_ENV = "SYMGEN_CFLAGS"
BACKEND_ENV = "SYMGEN_BACKEND"
#: -O1: most of -O2's speed on CasADi's straight-line code at half its compile time;
#: -ffp-contract=off: the same rounding as the virtual machine (no fused multiply-add)
DEFAULT_CFLAGS = "-O1 -ffp-contract=off"
#: The flags of the cold Functions (a caller's ``cold``: evaluated once per Newton matrix or per
#: output, not per residual) under the default flags: -O0 compiles CasADi's C 4-5 times faster
#: than -O1 (the 12-bar chain's Jacobian: 1.6 MB of C, 16.5 s at -O1), and the run spends little
#: in them. The same IEEE operations in the same order: the same numbers as -O1 to the last bit.
#: A user's $SYMGEN_CFLAGS applies to every unit.
COLD_CFLAGS = "-O0 -ffp-contract=off"
BACKENDS = ("auto", "compiled", "vm")
FORMAT = "symgen-compiled-cache"
FORMAT_VERSION = 2  # 2: keyed hashes (HMAC-SHA256 with the user's key)
LIBRARY = "model.so"
MANIFEST = "manifest.json"
_MAX_MANIFEST = 1 << 16
_MAX_LIBRARY = 1 << 30
COMPILE_TIMEOUT_S = 600


class Unavailable(Exception):
    """No compiled library can be had (no compiler, a failed compile); ``reason`` says why."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def backend_choice(backend: str | None = None) -> str:
    """``backend``, else ``$SYMGEN_BACKEND``, else "auto" (checked against :data:`BACKENDS`)."""
    from symgen.errors import SceneError

    if backend is None:
        env = os.environ.get(BACKEND_ENV, "").strip()
        if env and env not in BACKENDS:
            raise SceneError(
                "environment",
                BACKEND_ENV,
                f"is {env!r}; it must be one of {', '.join(BACKENDS)}",
                f"unset {BACKEND_ENV} or set it to auto, compiled or vm",
            )
        return env or "auto"
    if backend not in BACKENDS:
        raise SceneError(
            "command line", "--backend", f"is {backend!r}; it must be one of {', '.join(BACKENDS)}", "e.g. --backend vm"
        )
    return backend


@dataclass(frozen=True)
class Compiler:
    path: str  # resolved path of the executable
    version: str  # its --version output
    flags: tuple[str, ...]  # SYMGEN_CFLAGS, split like a shell

    def identity(self) -> dict[str, str | list[str]]:
        return {"path": self.path, "version": self.version, "flags": list(self.flags)}


@functools.cache
def _probe(path: str) -> str:
    """The ``--version`` text of the compiler at ``path``, remembered in the signed cache for the
    executable as it is on disk (its size, times, inode and device: a compiler replaced or
    upgraded in place is asked again): a cached run starts no process for it. A wrapper (a script,
    ccache) whose own file stays the same while the compiler behind it changes keeps its remembered
    text: its libraries are not rebuilt for the new compiler (``symgen cache clear`` forgets it)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise Unavailable(f"the C compiler {path} cannot be run ({exc})") from None
    disk = [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev]
    question = {"check": "compiler.version", "symgen": __version__, "path": path, "file": disk}
    known, answer = cache.recall(question)
    if known and isinstance(answer, str):
        return answer
    version = _ask_version(path)
    cache.remember(question, version)
    return version


def _ask_version(path: str) -> str:
    import subprocess

    try:
        proc = run_group([path, "--version"], timeout=60)
    except (OSError, subprocess.SubprocessError) as exc:
        raise Unavailable(f"the C compiler {path} cannot be run ({exc})") from None
    if proc.returncode != 0:
        raise Unavailable(f"'{path} --version' exited with code {proc.returncode}")
    version: str = proc.stdout.strip()
    return version


def compiler() -> Compiler:
    """The C compiler to use (``$SYMGEN_CC``, else cc, gcc or clang on PATH) and the flags."""
    wanted = os.environ.get(CC_ENV, "").strip()
    if wanted:
        found = shutil.which(wanted)
        if found is None:
            raise Unavailable(f"${CC_ENV} = {wanted!r} is not an executable")
    else:
        found = next((p for p in map(shutil.which, ("cc", "gcc", "clang")) if p), None)
        if found is None:
            raise Unavailable("no C compiler (cc, gcc or clang) on PATH")
    path = os.path.realpath(found)
    try:
        flags = _split(os.environ.get(CFLAGS_ENV, DEFAULT_CFLAGS))
    except ValueError as exc:
        raise Unavailable(f"${CFLAGS_ENV} cannot be split into flags ({exc})") from None
    return Compiler(path, _probe(path), flags)


def _entry_name(key: dict[str, object]) -> str:
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]


#: A Function's name and sizes: [name, [[rows, cols] per input], [[rows, cols] per output]].
Signature: TypeAlias = list[str | list[list[int]]]


def _signature(f: ca.Function) -> Signature:
    return [f.name(), [list(f.size_in(i)) for i in range(f.n_in())], [list(f.size_out(i)) for i in range(f.n_out())]]


def library(
    funcs: list[ca.Function], model_key: str, variant: str, store: bool = True, cold: tuple[str, ...] = ()
) -> tuple[dict[str, ca.Function], bool]:
    """Compiled twins of ``funcs`` (SX Functions; a Function named ``jac_NAME`` becomes the
    Jacobian of ``NAME``): ``({name: external Function}, built_now)``.

    ``model_key``: the structure key of the derived model; ``variant``: what else the Functions
    depend on (the coordinate partition). ``store=False``: build without using the cache.
    ``cold``: the names of Functions the run evaluates rarely (:data:`COLD_CFLAGS`).
    Raises :class:`Unavailable` when there is no compiler or the compile fails.
    """
    return library_of([_signature(f) for f in funcs], lambda: funcs, model_key, variant, store, cold)


def cold_flags(comp: Compiler) -> tuple[str, ...]:
    """The flags of a cold Function: :data:`COLD_CFLAGS` under the default flags, else the user's."""
    return _split(COLD_CFLAGS) if comp.flags == _split(DEFAULT_CFLAGS) else comp.flags


def _split(text: str) -> tuple[str, ...]:
    """``shlex.split(text)``: of a text of letters, digits, ``-_=.,+/:@%`` and blanks (no quote,
    backslash or other whitespace), that is a split at the blanks (a cached run's flags without
    importing shlex)."""
    if text.isascii() and all(c.isalnum() or c in "-_=.,+/:@% \t\r\n" for c in text):
        return tuple(text.split())
    import shlex

    return tuple(shlex.split(text))


def library_of(
    signatures: list[Signature],
    build: Callable[[], list[ca.Function]],
    model_key: str,
    variant: str,
    store: bool = True,
    cold: tuple[str, ...] = (),
) -> tuple[dict[str, ca.Function], bool]:
    """:func:`library` of the Functions that ``build()`` makes, known before by their
    ``signatures`` (name and sizes, what the entry's key holds): ``build`` is called only when
    the library is not in the cache, so a cached run makes none of the symbolic Functions (their
    Jacobians are most of a runner's set-up). The Functions built must have these signatures."""
    found = start_library(signatures, build, model_key, variant, store, cold, background=False)
    assert not isinstance(found, PendingLibrary)
    return found


def start_library(
    signatures: list[Signature],
    build: Callable[[], list[ca.Function]],
    model_key: str,
    variant: str,
    store: bool = True,
    cold: tuple[str, ...] = (),
    background: bool = True,
) -> tuple[dict[str, ca.Function], bool] | PendingLibrary:
    """:func:`library_of`, except that a library not in the cache is compiled in a background
    thread (``background``): its C is written here, then a :class:`PendingLibrary` returned at
    once while the compilers run, so the caller can start in the virtual machine meanwhile."""
    import casadi as ca

    comp = compiler()
    key = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "symgen": __version__,
        "casadi": ca.__version__,  # type: ignore[attr-defined]  # casadi.pyi does not declare __version__
        "model": model_key,
        "variant": variant,
        "compiler": comp.identity(),
        "functions": signatures,
        "cold": {"functions": sorted(cold), "flags": list(cold_flags(comp))},
    }
    where = cache.compiled_dir() / _entry_name(key)
    replace = False
    if store and (where.exists() or where.is_symlink()):
        try:
            return _load(read_verified(where, key), signatures), False
        except cache.InvalidEntry as exc:
            report_rebuild(where, exc.reason)
            replace = True
        except FileNotFoundError:
            pass
    funcs = build()
    made = [_signature(f) for f in funcs]
    if made != signatures:  # the caller's sizes and its Functions disagree: symgen's own error
        raise AssertionError(f"compiled.library_of: built {made}, announced {signatures}")
    pending = PendingLibrary(funcs, comp, where, key, store, replace, cold, signatures, background)
    return pending if background else (pending.result(), True)


#: The background builds not finished yet: cancelled at the interpreter's exit (a daemon thread's
#: compilers would otherwise outlive the process).
_LIVE: weakref.WeakSet[PendingLibrary] = weakref.WeakSet()


@atexit.register
def _cancel_live() -> None:
    for pending in list(_LIVE):
        pending.cancel()


class PendingLibrary:
    """A compiled library being built: its C written (in the calling thread: CasADi's symbolic
    objects are not shared across threads), the compilers run and the entry installed in the
    cache (atomically, by one rename) by a background thread when ``background``, else at once.

    :meth:`done` says whether it finished; :meth:`result` waits and loads it (or raises
    :class:`Unavailable`); :meth:`cancel` kills the compilers' process groups and waits for the
    thread, which removes its temporary folder: an interrupted build leaves nothing that loads.
    A signal while :meth:`result` waits cancels it too."""

    def __init__(
        self,
        funcs: list[ca.Function],
        comp: Compiler,
        where: Path,
        key: dict[str, object],
        store: bool,
        replace: bool,
        cold: tuple[str, ...],
        signatures: list[Signature],
        background: bool,
    ) -> None:
        self.signatures = signatures
        self._cancel = threading.Event()
        self._outcome: bytes | BaseException | None = None
        parent, store = build_folder(where, store)
        stack = contextlib.ExitStack()
        try:
            tmp = stack.enter_context(cache.temp_dir(parent, where.name))
            units = write_units(funcs, tmp, cold)
            cold = cold_units(funcs, cold)
        except BaseException:
            stack.close()
            raise

        def work() -> None:
            with stack:
                try:
                    blob = link_units(
                        comp,
                        units,
                        [],
                        tmp / LIBRARY,
                        f"the model library in {len(units)} parts" + (" in the background" if background else ""),
                        "--backend vm runs the model without compiling (slower per step)"
                        if not background
                        else "the run goes on in CasADi's virtual machine meanwhile",
                        "",
                        lambda c: cold_flags(comp) if unit_of(c) in cold else comp.flags,
                        cancel=self._cancel if background else None,
                    )
                    if store:
                        for path in tmp.iterdir():
                            if path.name != LIBRARY:  # the C and the objects
                                path.unlink()
                        install(tmp, where, key, LIBRARY, blob, replace)
                    self._outcome = blob
                except BaseException as exc:  # handed to the waiting thread by result()
                    self._outcome = exc

        self._thread: threading.Thread | None = None
        if background:
            self._thread = threading.Thread(target=work, name=f"symgen-compile-{where.name}", daemon=True)
            _LIVE.add(self)
            self._thread.start()
        else:
            work()

    def done(self) -> bool:
        return self._thread is None or not self._thread.is_alive()

    def wait(self) -> None:
        """Until the build ends; a signal meanwhile cancels it and goes on."""
        try:
            while not self.done():
                assert self._thread is not None
                self._thread.join(0.05)
        except BaseException:
            self.cancel()
            raise
        _LIVE.discard(self)

    def cancel(self) -> None:
        """Kill the compilers and wait for the thread (its temporary folder removed)."""
        self._cancel.set()
        if self._thread is not None:
            self._thread.join()
        _LIVE.discard(self)

    def result(self) -> dict[str, ca.Function]:
        """The externals of the library (after :meth:`wait`); :class:`Unavailable` when the
        compile failed or was cancelled."""
        self.wait()
        out = self._outcome
        if isinstance(out, Cancelled):
            raise Unavailable("the compile was cancelled")
        if isinstance(out, BaseException):
            raise out
        assert out is not None
        try:
            return _load(out, self.signatures)
        except cache.InvalidEntry as exc:
            raise Unavailable(f"the library just built {exc.reason}") from None


def report_rebuild(where: Path, reason: str) -> None:
    print(f"symgen: warning: compiled entry {where} {reason}; rebuilding it", file=sys.stderr)


def read_verified(where: Path, key: dict[str, object], name: str = LIBRARY) -> bytes:
    """The bytes of the file ``name`` of the entry ``where``, after checking that its manifest
    holds every field of ``key`` and the file's keyed hash (else :class:`symgen.cache.InvalidEntry`)."""
    try:
        manifest = json.loads(cache.read_entry_file(where, MANIFEST, _MAX_MANIFEST).decode("utf-8"))
    except FileNotFoundError:
        raise cache.InvalidEntry(f"has no {MANIFEST}") from None
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise cache.InvalidEntry(f"{MANIFEST} is not valid JSON ({exc})") from None
    if not isinstance(manifest, dict) or {k: manifest.get(k) for k in key} != key:
        raise cache.InvalidEntry(f"{MANIFEST} is not for this model, symgen, CasADi, compiler and flags")
    mac = manifest["files"].get(name) if isinstance(manifest.get("files"), dict) else None
    try:
        blob = cache.read_entry_file(where, name, _MAX_LIBRARY)
    except FileNotFoundError:
        raise cache.InvalidEntry(f"has no {name}") from None
    cache.verify(_label(where, name), blob, mac)  # before a byte reaches the loader
    return blob


def _label(where: Path, name: str) -> str:
    """What a file's keyed hash is bound to: its entry and its name."""
    return f"compiled/{where.name}/{name}"


def install(tmp: Path, where: Path, key: dict[str, object], name: str, blob: bytes, replace: bool) -> None:
    """Write the manifest of the built file ``name`` into ``tmp`` and rename ``tmp`` to ``where``."""
    try:
        manifest = dict(key, files={name: cache.seal(_label(where, name), blob)})
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True))
        cache.install_dir(tmp, where, replace=replace)
    except OSError as exc:
        cache.report_unwritable(where, exc)


def build_folder(where: Path, store: bool) -> tuple[Path, bool]:
    """Where to build the entry ``where``, and whether it can be stored: its cache folder, or
    (not storing, or a cache folder that cannot be made or written: a file, ``/dev/null``, a
    read-only folder; said in one line) a private temporary folder, the result uncached."""
    if store:
        try:
            where.parent.mkdir(parents=True, exist_ok=True)
            if not os.access(where.parent, os.W_OK | os.X_OK):
                raise PermissionError(13, "Permission denied", str(where.parent))
            cache.sweep_stale(where.parent)
            return where.parent, True
        except OSError as exc:
            cache.report_unwritable(where, exc)
    return Path(tempfile.gettempdir()), False


def link_units(
    comp: Compiler,
    units: list[Path],
    flags: list[str],
    out: Path,
    what: str,
    instead: str,
    on: str,
    flags_of: Callable[[Path], tuple[str, ...]] | None = None,
    cancel: threading.Event | None = None,
) -> bytes:
    """The bytes of the shared library ``out`` linked from the C files ``units``, compiled in
    parallel (as many at once as there are cores, the largest first; each compiler in a process
    group of its own: an interrupt kills cc1 too) with ``flags`` before the compiler's (those of
    ``flags_of(unit)`` when given); a progress line names ``what``, and a long compile is
    announced with ``instead`` (how to run without it). Raises :class:`Unavailable` when the
    compiler cannot be run or fails (``on``: what it failed on, e.g. " on the emitted C").
    ``cancel``: run in a background thread, where no signal arrives: setting it from another
    thread kills the compilers (:class:`symgen.processes.Cancelled`), and no progress line."""
    import subprocess

    units = sorted(units, key=lambda c: -c.stat().st_size)
    objects = [c.with_suffix(".o") for c in units]
    of = flags_of or (lambda c: comp.flags)
    cmds = [[comp.path, *flags, *of(c), "-fPIC", "-c", str(c), "-o", str(o)] for c, o in zip(units, objects)]
    link = [comp.path, *comp.flags, "-fPIC", "-shared", *map(str, objects), "-o", str(out), "-lm"]
    sizes = [c.stat().st_size for c in units]
    max_jobs = min(len(units), jobs())
    try:
        label = announce_compile(f"{what}, {max_jobs} at a time", sum(sizes), instead, max_jobs, max(sizes))
        procs = run_groups(
            cmds, max_jobs=max_jobs, timeout=COMPILE_TIMEOUT_S, progress=None if cancel else label, cancel=cancel
        )
        if cancel is not None and cancel.is_set():
            raise Cancelled("cancelled")
        if all(p.returncode == 0 for p in procs):
            procs.append(run_group(link, timeout=COMPILE_TIMEOUT_S))
    except (OSError, subprocess.SubprocessError) as exc:
        raise Unavailable(f"the C compiler {comp.path} cannot be run ({exc})") from None
    proc = next((p for p in procs if p.returncode != 0), procs[-1])
    if proc.returncode != 0:
        first = next((ln for ln in proc.stderr.splitlines() if ln.strip()), "no message")
        raise Unavailable(f"the C compiler {comp.path} failed{on} (exit {proc.returncode}: {first[:200]})")
    return out.read_bytes()


def write_units(funcs: list[ca.Function], folder: Path, cold: tuple[str, ...] = ()) -> list[Path]:
    """The C of ``funcs`` written by CasADi's code generator into ``folder``, one translation unit
    per Function (``<name>.c``, its internal symbols prefixed by its name, so the units link
    into one library), the largest first: the units are compiled in parallel, and each Function's
    C is what one unit holding them all would have (the same statements in the same order).

    A Function of more operations than ``policy.UNITS`` allows (``cold_ops`` for those named in
    ``cold``, else ``hot_ops``) is written as parts (:func:`parts`), each a unit
    ``<name>_part<k>.c`` of its own, and a unit ``<name>.c`` that calls them (:func:`caller_c`):
    the compiler's memory is then bounded by the largest part.

    The Functions the units call (``never_inline`` call nodes: the bar blocks,
    ``functions.BlockFunctions``) are compiled once (:func:`share_callees`): each a unit
    ``<callee>.c`` of its own, which the callers' units call instead of carrying its C."""
    import casadi as ca

    units = []
    shared = callees(funcs)
    written = {name: _write_callee(f, folder) for name, f in shared.items()}
    bodies = {name: body for name, body in written.items() if body is not None}
    units += [folder / f"{name}.c" for name in bodies]

    def write(f: ca.Function) -> None:
        gen = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
        gen.add(f)
        gen.generate(str(folder) + os.sep)
        path = folder / f"{f.name()}.c"
        if bodies:
            path.write_text(share_callees(path.read_text(), bodies))
        units.append(path)

    for f in funcs:
        bound = UNITS.cold_ops if f.name() in cold else UNITS.hot_ops
        split = parts(f, bound) if f.is_a("SXFunction") and f.n_instructions() > bound else None
        if split is None:
            write(f)
            continue
        for part, _ in split:
            write(part)
        (folder / f"{f.name()}.c").write_text(caller_c(f, split))
        units.append(folder / f"{f.name()}.c")
    return sorted(units, key=lambda c: -c.stat().st_size)


def callees(funcs: list[ca.Function]) -> dict[str, ca.Function]:
    """The Functions that ``funcs`` call (their call nodes: ``casadi.Function.find_functions``),
    by name; none of them named as one of ``funcs`` (their units would collide)."""
    found: dict[str, ca.Function] = {}
    names = {f.name() for f in funcs}
    for f in funcs:
        if not f.is_a("SXFunction"):
            continue
        for g in f.find_functions():
            if g.name() not in names and g.is_a("SXFunction"):
                found.setdefault(g.name(), g)
    return found


def cold_units(funcs: list[ca.Function], cold: tuple[str, ...]) -> tuple[str, ...]:
    """``cold`` and the callees (:func:`callees`) that only cold Functions call: the units that
    :data:`COLD_CFLAGS` compiles (a callee of a hot Function is compiled hot, once)."""
    hot = {g.name() for f in funcs if f.name() not in cold and f.is_a("SXFunction") for g in f.find_functions()}
    return tuple(cold) + tuple(sorted(name for name in callees(funcs) if name not in hot))


#: The signature of a Function's body in CasADi's C (``casadi_f<k>``)
_BODY_SIGNATURE = "(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {\n"
#: A Function's body in CasADi's C: its comment naming it, its static definition, its statements
#: (indented: the first line that is a lone ``}`` closes it). A pattern's text: compiled (and kept
#: by ``re``) where a library is built, not by every process that imports this module.
_BODY = (
    r"/\* (?P<name>[A-Za-z_][A-Za-z0-9_]*):\([^\n]*\) \*/\n"
    r"static int (?P<fn>casadi_f[0-9]+)" + re.escape(_BODY_SIGNATURE) + r"(?P<body>(?:[^\n]*\n)*?)\}\n"
)


def _write_callee(f: ca.Function, folder: Path) -> str | None:
    """Write the unit ``<name>.c`` of the callee ``f`` (its entry ``<name>`` of hidden
    visibility: the library's callers link to it, nothing outside the library does) and return
    its body's statements, as CasADi's C of a caller holds them; None (no unit) where CasADi's C
    is not laid out as this module reads it (another CasADi): the callers then keep its body, as
    before the callees were shared."""
    import casadi as ca

    gen = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    gen.add(f)
    gen.generate(str(folder) + os.sep)
    path = folder / f"{f.name()}.c"
    text = path.read_text()
    found = [m for m in re.finditer(_BODY, text) if m["name"] == f.name()]
    if len(found) != 1:  # not laid out as read here: not shared (each caller keeps its copy)
        path.unlink()
        return None
    hidden = '#if defined(__GNUC__)\n#define CASADI_SYMBOL_EXPORT __attribute__((visibility("hidden")))\n#endif\n'
    path.write_text(hidden + text)
    return found[0]["body"]


def share_callees(text: str, bodies: dict[str, str]) -> str:
    """The C ``text`` of a caller with the body of each callee of ``bodies`` (name -> statements
    as :func:`_write_callee` returned them) replaced by a call of the callee's own entry, compiled
    once in its unit. Replaced only where the caller's statements are the callee's own to the
    character (the same operations in the same order: the same numbers to the last bit); a body
    that differs stays in the caller."""

    def swap(m: re.Match[str]) -> str:
        name = m["name"]
        if bodies.get(name) != m["body"]:
            return m[0]
        sig = _BODY_SIGNATURE.rstrip(" {\n")
        return (
            f"/* {name}: compiled once, in the unit {name}.c */\n"
            f'#if defined(__GNUC__)\n__attribute__((visibility("hidden")))\n#endif\n'
            f"int {name}{sig};\n"
            f"static int {m['fn']}{_BODY_SIGNATURE}  return {name}(arg, res, iw, w, mem);\n}}\n"
        )

    return re.sub(_BODY, swap, text)


def unit_of(unit: Path) -> str:
    """The name of the Function whose C (or one of whose parts) the unit ``unit`` holds."""
    return unit.stem.split(PART)[0]


#: What separates a Function's name and a part's number in the part's name (``jac_dae_part3``)
PART = "_part"

#: A part: the SX Function of some of a Function's output entries (one output: their nonzeros,
#: in order) and, for each, [output index, nonzero index] in the Function's outputs.
Part: TypeAlias = tuple["ca.Function", list[tuple[int, int]]]


def parts(f: ca.Function, bound: int) -> list[Part] | None:
    """``f`` (an SX Function) cut into parts by its output rows, each of at most ``bound``
    operations where one row allows it: the rows (of all outputs together) are halved, by their
    nonzeros, until each part is small enough. Each entry of a part is the very expression it
    is in ``f`` (the same operations on the same operands: the same number to the last bit);
    values several rows share are computed in each part that needs them. ``None`` when ``f``
    cannot be cut (one row)."""
    import casadi as ca

    ins = f.sx_in()
    outs = f.call(ins)
    entries: dict[int, list[tuple[int, int]]] = {}
    for k, out in enumerate(outs):
        for j, row in enumerate(out.sparsity().row()):
            entries.setdefault(int(row), []).append((k, j))
    rows = sorted(entries)
    if len(rows) < 2:
        return None

    def part(group: list[int], n: int) -> Part:
        where = [e for r in group for e in entries[r]]
        expr = ca.vertcat(*[outs[k].nz[j] for k, j in where]) if where else ca.SX(0, 1)
        return ca.Function(f"{f.name()}{PART}{n}", ins, [expr], f.name_in(), ["nz"]), where

    made: list[Part] = []

    def cut(group: list[int]) -> None:
        p = part(group, len(made))
        if p[0].n_instructions() <= bound or len(group) == 1:
            made.append(p)
            return
        sizes = [len(entries[r]) for r in group]
        half = next(i for i in range(1, len(group)) if 2 * sum(sizes[:i]) >= sum(sizes) or i == len(group) - 1)
        cut(group[:half])
        cut(group[half:])

    cut(rows)
    return [p for p in made if p[1]] or None


def caller_c(f: ca.Function, split: list[Part]) -> str:
    """The C of ``f`` (CasADi's external interface: ``<name>``, ``<name>_work``,
    ``<name>_sparsity_in``, ...) computed by calling its ``split`` parts, each in a unit of its
    own, and copying each part's nonzeros into ``f``'s outputs (an output not asked for, a null
    pointer, skipped as CasADi's C skips it): ``templates/c/casadi_parts.c.jinja``."""
    from symgen.backends.c.render import render

    n_in, n_out = f.n_in(), f.n_out()
    sp = [f.sparsity_in(i) for i in range(n_in)] + [f.sparsity_out(i) for i in range(n_out)]
    most = max(len(where) for _, where in split)
    ctx = {
        "name": f.name(),
        "n_in": n_in,
        "n_out": n_out,
        "names_in": [f.name_in(i) for i in range(n_in)],
        "names_out": [f.name_out(i) for i in range(n_out)],
        "sparsities": [[int(v) for v in s.compress()] for s in sp],
        "parts": [{"name": p.name(), "k": [k for k, _ in where], "j": [j for _, j in where]} for p, where in split],
        "most": most,
        "sz_arg": max([n_in] + [int(p.sz_arg()) for p, _ in split]),
        "sz_res": n_out + max(int(p.sz_res()) for p, _ in split),
        "sz_iw": max(int(p.sz_iw()) for p, _ in split),
        "sz_w": most + max(int(p.sz_w()) for p, _ in split),
    }
    return render("casadi_parts.c.jinja", ctx)


def _load(blob: bytes, signatures: list[Signature]) -> dict[str, ca.Function]:
    """Externals of the Functions of ``signatures`` from verified library bytes, loaded from a
    private copy (:func:`symgen.cache.load_private`); signatures checked."""
    return cache.load_private(blob, LIBRARY, lambda path: _externals(path, signatures))


def _externals(path: Path, signatures: list[Signature]) -> dict[str, ca.Function]:
    import casadi as ca

    try:
        importer = ca.Importer(str(path), "dll")
    except RuntimeError as exc:
        raise cache.InvalidEntry(f"{LIBRARY} cannot be loaded ({str(exc).strip().splitlines()[-1][:200]})") from None
    out = {}
    for sig in signatures:
        name = str(sig[0])
        if name.startswith("jac_"):
            continue  # loaded by its function's external on demand
        try:
            ext = ca.external(name, importer, {"enable_fd": False})
        except RuntimeError:
            raise cache.InvalidEntry(f"{LIBRARY} has no function {name!r}") from None
        if _signature(ext) != sig:
            raise cache.InvalidEntry(f"{LIBRARY}: {name} has the signature {_signature(ext)}, not {sig}")
        out[name] = ext
    return out
