"""Saved CasADi Functions of a derived model: write and read them without SymPy.

An entry is a folder (see :mod:`symgen.cache`)::

    <fname>.casadi    one per name in FUNCTION_NAMES: CasADi's serialized text
                      (``Function.serialize()``; read back with ``casadi.Function.deserialize``),
                      and one per name in CALL_NAMES for a model whose bar blocks are calls
                      (``functions.call_functions``): all of them or none
    model.json        the model's description (``symgen.ir.info.ModelInfo.to_json``)
    manifest.json     format, format_version, symgen and casadi versions, the structure key,
                      and the keyed hash (``symgen.cache.seal``: HMAC-SHA256 with this user's
                      key, bound to the entry and the file name) of every file above

:func:`load` checks the manifest and every keyed hash before a byte reaches ``json`` or CasADi's
deserializer (which can crash the process on a damaged file), then that ``model.json``
is a valid :class:`~symgen.ir.info.ModelInfo` (``ModelInfo.from_json``) of the folder's
structure key and that each Function has the name, inputs and sizes that it states. Anything else raises :class:`symgen.cache.InvalidEntry`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from symgen import __version__
from symgen import cache
from symgen.ir.info import InvalidModelInfo, ModelInfo

if TYPE_CHECKING:
    import casadi as ca

FUNCTION_NAMES = ("phi", "phid", "phidd", "res", "out", "energy", "closure")
INPUT_NAMES = ("t", "q", "v", "a", "lam", "p")
#: The Functions of a model whose bar blocks a runner evaluates as calls (``functions.call_functions``)
CALL_NAMES = ("res_E", "out_E", "xin", "bars", "jac_bars")

FORMAT = "symgen-model-cache"
#: Bump when the layout of an entry changes (older entries are then re-derived).
FORMAT_VERSION = 4  # 4: the Functions CALL_NAMES of a model with bar blocks; 3: keyed hashes (HMAC-SHA256 with the user's key); model.json is ModelInfo.to_json
MANIFEST = "manifest.json"
META = "model.json"
_MAX_MANIFEST = 1 << 16
_MAX_FILE = 1 << 30


def __getattr__(name: str) -> Any:
    """``CASADI_VERSION``: the CasADi a cache entry is built with, read on first use (CasADi is
    imported only where a Function is made or read: :func:`load_lazy`)."""
    if name == "CASADI_VERSION":
        import casadi as ca

        return ca.__version__  # type: ignore[attr-defined]  # casadi.pyi omits the module's __version__
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _file_names(calls: bool = False) -> tuple[str, ...]:
    names = FUNCTION_NAMES + (CALL_NAMES if calls else ())
    return tuple(f"{n}.casadi" for n in names) + (META,)


def save(funcs: dict, info: ModelInfo, directory: str | os.PathLike, replace: bool = False) -> bool:
    """Write the entry ``directory`` (its name is the structure key, ``info.key``) atomically.

    The files are built in a temporary folder next to ``directory`` and renamed into place in
    one step. If ``directory`` exists meanwhile, another writer was first: its entry is kept
    (or, with ``replace``, given when the existing entry failed to verify, moved aside and
    removed). The temporary folder never outlives the call. Returns whether this call's entry
    was installed.
    """
    directory = Path(directory)
    if info.key != directory.name:
        raise ValueError(f"model cache entry {directory} for a model with key {info.key!r}")
    names = FUNCTION_NAMES + (CALL_NAMES if CALL_NAMES[0] in funcs else ())
    files = {f"{name}.casadi": funcs[name].serialize().encode("ascii") for name in names}
    files[META] = json.dumps(info.to_json(), indent=1, sort_keys=True, allow_nan=False).encode()
    manifest = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "symgen": __version__,
        "casadi": __getattr__("CASADI_VERSION"),
        "key": directory.name,
        "files": {name: cache.seal(f"models/{directory.name}/{name}", data) for name, data in files.items()},
    }
    directory.parent.mkdir(parents=True, exist_ok=True)
    cache.sweep_stale(directory.parent)
    with cache.temp_dir(directory.parent, directory.name) as tmp:
        for name, data in files.items():
            (tmp / name).write_bytes(data)
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True))
        return cache.install_dir(tmp, directory, replace=replace)


def load(directory: str | os.PathLike, key: str | None = None) -> tuple[dict, ModelInfo]:
    """The Functions and the ModelInfo of a verified entry (``key``: the structure key the
    caller expects, default the folder's name); :class:`symgen.cache.InvalidEntry` otherwise."""
    directory = Path(directory)
    key = directory.name if key is None else key
    if directory.name != key:
        raise cache.InvalidEntry(f"is in a folder not named after its structure key {key}")
    data, _ = _read_verified(directory, key)
    info = _model_info(_parse_json(data[META], META), key)
    return _functions(data, info), info


def load_lazy(directory: str | os.PathLike, key: str) -> tuple[LazyFunctions, ModelInfo]:
    """:func:`load` with the Functions read on first use (:class:`LazyFunctions`): every file's
    keyed hash and ``model.json`` checked now, CasADi's version and its reading of the Functions
    when a Function is first asked for. A cached run of the C solver never asks (its library
    holds the model): it never imports CasADi."""
    directory = Path(directory)
    if directory.name != key:
        raise cache.InvalidEntry(f"is in a folder not named after its structure key {key}")
    data, made_by = _read_verified(directory, key, casadi=False)
    info = _model_info(_parse_json(data[META], META), key)
    return LazyFunctions(directory, data, info, made_by), info


class LazyFunctions(Mapping[str, "ca.Function"]):
    """The Functions of a verified entry, read by CasADi on first use (:func:`load_lazy`). An
    entry this CasADi does not read is reported then (a SceneError naming the entry: run again,
    and it is derived anew)."""

    def __init__(self, where: Path, data: dict[str, bytes], info: ModelInfo, made_by: object) -> None:
        self._where, self._data, self._info, self._made_by = where, data, info, made_by
        self._funcs: dict[str, ca.Function] | None = None

    def _loaded(self) -> dict[str, ca.Function]:
        if self._funcs is None:
            from symgen.errors import SceneError

            try:
                version = __getattr__("CASADI_VERSION")
                if self._made_by != version:
                    raise cache.InvalidEntry(f"was written by CasADi {self._made_by!r}, this is {version}")
                self._funcs = _functions(self._data, self._info)
            except cache.InvalidEntry as exc:
                import shutil

                shutil.rmtree(self._where, ignore_errors=True)
                raise SceneError(
                    "model cache",
                    str(self._where),
                    f"the cache entry {exc.reason}; it is removed",
                    "run the command again: the model is derived anew",
                ) from None
            self._data = {}
        return self._funcs

    def __getitem__(self, name: str) -> ca.Function:
        return self._loaded()[name]

    def __contains__(self, name: object) -> bool:
        """Whether the entry holds the Function ``name`` (from its files: nothing read by CasADi)."""
        return name in FUNCTION_NAMES or (
            name in CALL_NAMES and (f"{name}.casadi" in self._data or (self._funcs is not None and name in self._funcs))
        )

    def _names(self) -> tuple[str, ...]:
        return tuple(n for n in FUNCTION_NAMES + CALL_NAMES if n in self)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())


def _functions(data: dict[str, bytes], info: ModelInfo) -> dict[str, ca.Function]:
    """The Functions of an entry's verified files, each checked against ``info``."""
    import casadi as ca

    funcs = {}
    calls = f"{CALL_NAMES[0]}.casadi" in data
    for name in FUNCTION_NAMES + (CALL_NAMES if calls else ()):
        try:
            f = ca.Function.deserialize(data[f"{name}.casadi"].decode("ascii"))
        except (UnicodeDecodeError, RuntimeError) as exc:
            raise cache.InvalidEntry(f"{name}.casadi cannot be deserialized by this CasADi ({exc})") from None
        if name in CALL_NAMES:
            if f.name() != name:
                raise cache.InvalidEntry(f"{name}.casadi holds the function {f.name()!r}")
        else:
            _check_function(f, name, info)
        funcs[name] = f
    return funcs


def _read_verified(directory: Path, key: str, casadi: bool = True) -> tuple[dict[str, bytes], object]:
    """Every file of the entry, each checked against the manifest's keyed hash, and the CasADi
    version the manifest states (checked against this CasADi's unless ``casadi`` is False)."""
    use_fd = os.open in os.supports_dir_fd and hasattr(os, "O_DIRECTORY")
    dfd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY) if use_fd else None
    try:

        def read(name: str, limit: int) -> bytes:
            return cache.read_entry_file(directory, name, limit, dir_fd=dfd)

        try:
            manifest = _parse_json(read(MANIFEST, _MAX_MANIFEST), MANIFEST)
        except FileNotFoundError:
            raise cache.InvalidEntry(f"has no {MANIFEST} (written by an older symgen, or incomplete)") from None
        _check_manifest(manifest, key, casadi)
        data = {}
        for name in _file_names(f"{CALL_NAMES[0]}.casadi" in manifest["files"]):
            try:
                blob = read(name, _MAX_FILE)
            except FileNotFoundError:
                raise cache.InvalidEntry(f"has no {name}") from None
            cache.verify(f"models/{key}/{name}", blob, manifest["files"][name])
            data[name] = blob
        return data, manifest.get("casadi")
    finally:
        if dfd is not None:
            os.close(dfd)


def _parse_json(blob: bytes, name: str):
    def no_constant(c):
        raise ValueError(f"non-finite number {c}")

    try:
        return json.loads(blob.decode("utf-8"), parse_constant=no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise cache.InvalidEntry(f"{name} is not valid JSON ({exc})") from None


def _check_manifest(m, key: str, casadi: bool = True) -> None:
    if not isinstance(m, dict) or m.get("format") != FORMAT:
        raise cache.InvalidEntry(f"{MANIFEST} is not a symgen model-cache manifest")
    if m.get("format_version") != FORMAT_VERSION:
        raise cache.StaleEntry(f"has cache format {m.get('format_version')!r}, this symgen reads {FORMAT_VERSION}")
    if m.get("symgen") != __version__:
        raise cache.StaleEntry(f"was written by symgen {m.get('symgen')!r}, this is {__version__}")
    if casadi and m.get("casadi") != (version := __getattr__("CASADI_VERSION")):
        raise cache.StaleEntry(f"was written by CasADi {m.get('casadi')!r}, this is {version}")
    if m.get("key") != key:
        raise cache.InvalidEntry(f"{MANIFEST} is for structure key {m.get('key')!r}, not {key}")
    files = m.get("files")
    if (
        not isinstance(files, dict)
        or set(files) not in (set(_file_names()), set(_file_names(True)))
        or not all(isinstance(h, str) and len(h) == 64 for h in files.values())
    ):
        raise cache.InvalidEntry(f"{MANIFEST} does not list the keyed hash of exactly {', '.join(_file_names())}")


def _model_info(data, key: str) -> ModelInfo:
    """``model.json``'s record, checked field by field, for the structure ``key``."""
    from symgen.model.structure import structure_key

    def bad(what: str):
        return cache.InvalidEntry(f"{META}: {what}")

    try:
        info = ModelInfo.from_json(data)
    except InvalidModelInfo as exc:
        raise bad(str(exc)) from None
    if info.key != key:
        raise bad(f"is for structure key {info.key!r}, not {key}")
    try:
        ok = structure_key(info.structure) == key
    except (KeyError, TypeError, ValueError):
        ok = False
    if not ok:
        raise bad(f"its structure does not hash to the key {key}")
    return info


def _expected_sizes(info: ModelInfo) -> tuple[dict, dict]:
    nq, nlam = info.n, info.m
    ins = {"t": 1, "q": nq, "v": nq, "a": nq, "lam": nlam, "p": len(info.params)}
    outs = {
        "phi": nlam,
        "phid": nlam,
        "phidd": nlam,
        "res": nq,
        "out": len(info.outputs),
        "energy": 1,
        "closure": info.n_loop_rows,
    }
    return ins, outs


def _check_function(f: ca.Function, name: str, info: ModelInfo) -> None:
    ins, outs = _expected_sizes(info)
    if f.name() != name:
        raise cache.InvalidEntry(f"{name}.casadi holds the function {f.name()!r}")
    if f.n_in() != len(INPUT_NAMES) or f.n_out() != 1 or tuple(f.name_in()) != INPUT_NAMES or f.name_out() != [name]:
        raise cache.InvalidEntry(
            f"{name}.casadi has the signature {f.name_in()} -> {f.name_out()}, not {list(INPUT_NAMES)} -> [{name!r}]"
        )
    got_in = [tuple(f.size_in(i)) for i in range(f.n_in())]
    want_in = [(ins[n], 1) for n in INPUT_NAMES]
    got_out, want_out = tuple(f.size_out(0)), (outs[name], 1)
    if got_in != want_in or got_out != want_out:
        raise cache.InvalidEntry(
            f"{name}.casadi has sizes {got_in} -> {got_out}, model.json states {want_in} -> {want_out}"
        )
