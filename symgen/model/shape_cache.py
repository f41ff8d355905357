"""The on-disk (and in-memory) cache of the closed-form inner products of a bar's bases.

:func:`inner_products` is the entry point of the derivation: for two standard bases it caches
:func:`symgen.model.shapes.compute_inner_products`, for bases closed by static correction
functions :func:`symgen.model.static_shapes.piecewise_inner_products`. Results are cached in
memory per basis key (with the interior points of the corrections) and on disk as one JSON file
per pair of bases in :func:`cache_dir`, written atomically with the keyed hash of its content,
checked before it is parsed; an entry that does not verify is said on stderr, recomputed and
rewritten; pickles of older versions are never read.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, TypeGuard

import numpy as np

from symgen import cache, exprdata
from symgen.model import shapes, static_shapes
from symgen.model.shapes import SHAPES_VERSION, Basis, CurvatureProducts, InnerProducts, basis_of_key
from symgen.model.static_shapes import STATIC_VERSION, corrected_basis

__all__ = ["cache_dir", "clear_memory_cache", "corrected_inner_products", "curvature_products", "inner_products"]


def cache_dir() -> Path:
    """Directory of the on-disk inner-product cache: ``$SYMGEN_CACHE_DIR/shapes``
    (default ``~/.cache/symgen/shapes``)."""
    return cache.shapes_dir()


def _cache_name(akey: tuple, tkey: tuple) -> str:
    def part(k: tuple) -> str:
        direction, family, frame, n, tip = k
        return f"{direction}-{family}-{frame}-n{n}-tip{int(tip)}"

    return f"v{SHAPES_VERSION}__{part(akey)}__{part(tkey)}"


def _is_count(n: object) -> TypeGuard[int]:
    """A stored mode count: an integer in 0..1000."""
    return isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= 1000


def _freeze(ip: InnerProducts) -> InnerProducts:
    for name in ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4"):
        getattr(ip, name).flags.writeable = False
    return ip


# On disk an entry is one file made by symgen.cache.pack: a header line with the keyed hash of the
# JSON payload that follows. The payload holds the float arrays as lists (repr round-trips
# exactly) and the exact values as symgen.exprdata trees. Never pickle.
_CACHE_KIND = "shapes"
_ARRAYS = ("gram", "Ka", "Kt", "Pd", "psid1", "C3", "D4")
_MAX_ENTRY_BYTES = 1 << 28


def _shapes_of(na: int, nt: int) -> dict[str, tuple[int, ...]]:
    nb = 2 + na + nt
    return {
        "gram": (nb, nb),
        "Ka": (na, na),
        "Kt": (nt, nt),
        "Pd": (nt, nt),
        "psid1": (nt,),
        "C3": (na, nt, nt),
        "D4": (nt, nt, nt, nt),
    }


def _encode_entry(name: str, ip: InnerProducts) -> bytes:
    doc = {
        "key": name,
        "version": SHAPES_VERSION,
        "na": ip.na,
        "nt": ip.nt,
        "floats": {a: [float(x) for x in getattr(ip, a).ravel()] for a in _ARRAYS},
        "exact": {a: exprdata.encode_tensor(ip.exact[a]) for a in _ARRAYS},
    }
    return cache.pack(_CACHE_KIND, json.dumps(doc, separators=(",", ":"), allow_nan=False).encode())


def _decode_entry(data: bytes, name: str) -> InnerProducts:
    """The inner products of a verified entry; ``cache.InvalidEntry`` for anything else."""
    payload = cache.unpack(_CACHE_KIND, data)  # keyed hash checked before any parsing

    def bad(what: str) -> Exception:
        return cache.InvalidEntry(f"is not a valid shape entry ({what})")

    def no_constant(c):
        raise ValueError(f"non-finite number {c}")

    try:
        doc = json.loads(payload.decode("utf-8"), parse_constant=no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise bad(f"JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("key") != name or doc.get("version") != SHAPES_VERSION:
        raise bad(f"written for {doc.get('key') if isinstance(doc, dict) else None!r}")
    na, nt = doc.get("na"), doc.get("nt")
    if not (_is_count(na) and _is_count(nt)):
        raise bad("mode counts")
    floats, exact = doc.get("floats"), doc.get("exact")
    if (
        not isinstance(floats, dict)
        or not isinstance(exact, dict)
        or set(floats) != set(_ARRAYS)
        or set(exact) != set(_ARRAYS)
    ):
        raise bad(f"it must hold exactly {', '.join(_ARRAYS)}")
    arrays: dict[str, Any] = {}
    values: dict[str, Any] = {}
    for a, shape in _shapes_of(na, nt).items():
        flat = floats[a]
        if (
            not isinstance(flat, list)
            or len(flat) != math.prod(shape)
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in flat)
        ):
            raise bad(f"{a}: not {math.prod(shape)} finite numbers")
        arrays[a] = np.array(flat, dtype=float).reshape(shape)
        try:
            values[a] = exprdata.decode_tensor(exact[a])
        except (ValueError, TypeError, RecursionError) as exc:
            raise bad(f"{a}: {exc}") from None
        want = shape if a != "psid1" else (nt, 1)
        if tuple(values[a].shape) != want:
            raise bad(f"{a}: exact values of shape {tuple(values[a].shape)}, not {want}")
    return _freeze(InnerProducts(na=na, nt=nt, exact=values, **arrays))


def _load(path: Path, name: str) -> InnerProducts | None:
    """The verified entry at ``path``; None when there is none or it does not verify (then said
    in one line on stderr: it is recomputed and overwritten)."""
    try:
        data = cache.read_bytes(path, _MAX_ENTRY_BYTES)
        return _decode_entry(data, name)
    except FileNotFoundError:
        return None
    except cache.InvalidEntry as exc:
        cache.report_invalid(path, exc.reason)
    except OSError as exc:
        cache.report_invalid(path, f"cannot be read ({exc})")
    return None


def _store(path: Path, name: str, ip: InnerProducts) -> None:
    try:
        data = _encode_entry(name, ip)
    except (ValueError, cache.KeyUnavailable) as exc:  # no key of this user: not cached, said once per entry
        cache.report_unwritable(path, exc)
        return
    _write(path, data)


def _write(path: Path, data: bytes) -> None:
    """``data`` to ``path`` atomically (a failure said on stderr: the entry is recomputed next time)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        cache.sweep_stale(path.parent)
        fd, tmp = tempfile.mkstemp(prefix=f"{cache.TEMP_PREFIX}{path.name}-", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            os.replace(tmp, path)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
    except OSError as exc:
        cache.report_unwritable(path, exc)


@functools.lru_cache(maxsize=128)
def _cached(akey: tuple, tkey: tuple) -> InnerProducts:
    name = _cache_name(akey, tkey)
    path = cache_dir() / (name + ".json")
    ip = _load(path, name)
    if ip is None:
        ip = shapes.compute_inner_products(basis_of_key(akey), basis_of_key(tkey))
        _store(path, name, ip)
    return ip


def _static_cache_name(axial: Basis, transverse: Basis) -> str:
    def part(b: Basis) -> str:
        direction, family, frame, n, tip = b.key
        head = f"{direction}-{family}-{frame}-n{n}-tip{int(tip)}"
        if not b.points and not b.moment_points:
            return head
        pts = hashlib.sha256(repr([float(x).hex() for x in b.points]).encode()).hexdigest()[:12]
        if not b.moment_points:  # the names of entries without moment corrections are unchanged
            return f"{head}-s{len(b.points)}-{pts}"
        mpts = hashlib.sha256(repr([float(x).hex() for x in b.moment_points]).encode()).hexdigest()[:12]
        return f"{head}-s{len(b.points)}-{pts}-m{len(b.moment_points)}-{mpts}"

    return f"v{SHAPES_VERSION}s{STATIC_VERSION}__{part(axial)}__{part(transverse)}"


def corrected_inner_products(axial: Basis, transverse: Basis) -> InnerProducts:
    """:func:`symgen.model.static_shapes.piecewise_inner_products` of two bases made by
    :func:`symgen.model.static_shapes.corrected_basis`, cached in memory and on disk beside the
    standard bases' entries (same format and checks; the name holds the interior points)."""
    return _cached_corrected(
        axial.key, tuple(axial.points), transverse.key, tuple(transverse.points), tuple(transverse.moment_points)
    )


@functools.lru_cache(maxsize=64)
def _cached_corrected(akey: tuple, apts: tuple, tkey: tuple, tpts: tuple, mpts: tuple = ()) -> InnerProducts:
    ba = corrected_basis(basis_of_key(akey), apts)
    bt = corrected_basis(basis_of_key(tkey), tpts, mpts)
    name = _static_cache_name(ba, bt)
    path = cache_dir() / (name + ".json")
    ip = _load(path, name)
    if ip is None:
        ip = static_shapes.piecewise_inner_products(ba.functions, bt.functions)
        _store(path, name, ip)
    return ip


def clear_memory_cache() -> None:
    """Forget the in-memory inner products (the disk cache is kept)."""
    _cached.cache_clear()
    _cached_corrected.cache_clear()
    _cached_curvature.cache_clear()


def inner_products(axial: Basis, transverse: Basis) -> InnerProducts:
    """Closed-form inner products of one bar's axial and transverse bases (cached).

    Results are cached in memory per ``(family, frame, n, tip_joint)`` of both bases (and their
    static correction points), and on disk as JSON in :func:`cache_dir`.

    Parameters
    ----------
    axial : from :func:`symgen.model.shapes.axial_basis` (or
        :func:`symgen.model.static_shapes.corrected_basis` of one)
    transverse : from :func:`symgen.model.shapes.transverse_basis` (or a corrected one)

    Examples
    --------
    >>> from symgen.model.shapes import axial_basis, transverse_basis
    >>> ip = inner_products(axial_basis("stress-free", 1), transverse_basis("pinned-pinned", "modes", 1))
    >>> ip.exact["Kt"][0, 0]            # (psi'', psi'')
    pi**4/2
    """
    if axial.direction != "axial" or transverse.direction != "transverse":
        raise ValueError(
            "inner_products(axial, transverse): got bases with directions "
            f"{axial.direction!r}, {transverse.direction!r}"
        )
    akey, tkey = axial.key, transverse.key
    # static correction functions: piecewise inner products
    if axial.points or transverse.points or transverse.moment_points:
        return corrected_inner_products(axial, transverse)
    try:
        same = all(r is b or r == b for r, b in ((basis_of_key(akey), axial), (basis_of_key(tkey), transverse)))
    except ValueError:
        same = False
    if not same:  # hand-made basis: nothing to key a cache on
        return shapes.compute_inner_products(axial, transverse)
    return _cached(akey, tkey)


# --------------------------------------------------------------------------------------
# The exact bar's tables (effects.strain = "exact"): a separate entry beside the bases' one,
# computed only for the bars that need them (E4 is nt^4 entries)
# --------------------------------------------------------------------------------------
#: Bump whenever a change to ``shapes.curvature_tables`` changes a cached number.
CURVATURE_VERSION = "1"
_CURVATURE_KIND = "curvature"
_CURVATURE_ARRAYS = ("E4", "G3")


def _curvature_shapes(na: int, nt: int) -> dict[str, tuple[int, ...]]:
    return {"E4": (nt, nt, nt, nt), "G3": (na, nt, nt)}


def _encode_curvature(name: str, cp: CurvatureProducts) -> bytes:
    doc = {
        "key": name,
        "version": CURVATURE_VERSION,
        "na": cp.na,
        "nt": cp.nt,
        "floats": {a: [float(x) for x in getattr(cp, a).ravel()] for a in _CURVATURE_ARRAYS},
        "exact": {a: exprdata.encode_tensor(cp.exact[a]) for a in _CURVATURE_ARRAYS},
    }
    return cache.pack(_CURVATURE_KIND, json.dumps(doc, separators=(",", ":"), allow_nan=False).encode())


def _decode_curvature(data: bytes, name: str) -> CurvatureProducts:
    """The tables of a verified entry; ``cache.InvalidEntry`` for anything else."""
    payload = cache.unpack(_CURVATURE_KIND, data)

    def bad(what: str) -> Exception:
        return cache.InvalidEntry(f"is not a valid curvature entry ({what})")

    def no_constant(c):
        raise ValueError(f"non-finite number {c}")

    try:
        doc = json.loads(payload.decode("utf-8"), parse_constant=no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise bad(f"JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("key") != name or doc.get("version") != CURVATURE_VERSION:
        raise bad(f"written for {doc.get('key') if isinstance(doc, dict) else None!r}")
    na, nt = doc.get("na"), doc.get("nt")
    floats, exact = doc.get("floats"), doc.get("exact")
    if not (_is_count(na) and _is_count(nt)) or not isinstance(floats, dict) or not isinstance(exact, dict):
        raise bad("mode counts or tables")
    if set(floats) != set(_CURVATURE_ARRAYS) or set(exact) != set(_CURVATURE_ARRAYS):
        raise bad(f"it must hold exactly {', '.join(_CURVATURE_ARRAYS)}")
    arrays: dict[str, Any] = {}
    values: dict[str, Any] = {}
    for a, shape in _curvature_shapes(na, nt).items():
        flat = floats[a]
        if (
            not isinstance(flat, list)
            or len(flat) != math.prod(shape)
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in flat)
        ):
            raise bad(f"{a}: not {math.prod(shape)} finite numbers")
        arrays[a] = np.array(flat, dtype=float).reshape(shape)
        arrays[a].flags.writeable = False
        try:
            values[a] = exprdata.decode_tensor(exact[a])
        except (ValueError, TypeError, RecursionError) as exc:
            raise bad(f"{a}: {exc}") from None
        if tuple(values[a].shape) != shape:
            raise bad(f"{a}: exact values of shape {tuple(values[a].shape)}, not {shape}")
    return CurvatureProducts(na=na, nt=nt, exact=values, **arrays)


@functools.lru_cache(maxsize=64)
def _cached_curvature(akey: tuple, apts: tuple, tkey: tuple, tpts: tuple, mpts: tuple) -> CurvatureProducts:
    if apts or tpts or mpts:
        ba = corrected_basis(basis_of_key(akey), apts)
        bt = corrected_basis(basis_of_key(tkey), tpts, mpts)
        name = _static_cache_name(ba, bt)
    else:
        ba, bt = basis_of_key(akey), basis_of_key(tkey)
        name = _cache_name(akey, tkey)
    name = f"k{CURVATURE_VERSION}{name}"
    path = cache_dir() / (name + ".json")
    try:
        cp: CurvatureProducts | None = _decode_curvature(cache.read_bytes(path, _MAX_ENTRY_BYTES), name)
    except FileNotFoundError:
        cp = None
    except cache.InvalidEntry as exc:
        cache.report_invalid(path, exc.reason)
        cp = None
    except OSError as exc:
        cache.report_invalid(path, f"cannot be read ({exc})")
        cp = None
    if cp is None:
        if apts or tpts or mpts:
            cp = static_shapes.piecewise_curvature_products(ba.functions, bt.functions)
        else:
            cp = shapes.compute_curvature_products(ba, bt)
        try:
            data = _encode_curvature(name, cp)
        except (ValueError, cache.KeyUnavailable) as exc:
            cache.report_unwritable(path, exc)
            return cp
        _write(path, data)
    return cp


def curvature_products(axial: Basis, transverse: Basis) -> CurvatureProducts:
    """The exact bar's closed-form tables (:class:`symgen.model.shapes.CurvatureProducts`) of one
    bar's bases, cached in memory and on disk like :func:`inner_products` (an entry of its own,
    named after the bases' entry with a ``k`` prefix)."""
    try:
        same = all(
            r is b or r == b for r, b in ((basis_of_key(axial.key), axial), (basis_of_key(transverse.key), transverse))
        )
    except ValueError:
        same = False
    if axial.points or transverse.points or transverse.moment_points:
        return _cached_curvature(
            axial.key, tuple(axial.points), transverse.key, tuple(transverse.points), tuple(transverse.moment_points)
        )
    if not same:  # hand-made basis: nothing to key a cache on
        return shapes.compute_curvature_products(axial, transverse)
    return _cached_curvature(axial.key, (), transverse.key, (), ())
