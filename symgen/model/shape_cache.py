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
from symgen.model.static_shapes import STATIC_VERSION, SixthOrderProducts, corrected_basis

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


def _encode_tables(kind: str, version: str, name: str, na: int, nt: int, source: Any, arrays: tuple[str, ...]) -> bytes:
    """One cache entry of kind ``kind``: the float arrays ``arrays`` of ``source`` (attributes)
    and their exact values (``source.exact``), written for entry ``name`` at ``version``."""
    doc = {
        "key": name,
        "version": version,
        "na": na,
        "nt": nt,
        "floats": {a: [float(x) for x in getattr(source, a).ravel()] for a in arrays},
        "exact": {a: exprdata.encode_tensor(source.exact[a]) for a in arrays},
    }
    return cache.pack(kind, json.dumps(doc, separators=(",", ":"), allow_nan=False).encode())


def _decode_tables(
    data: bytes, name: str, kind: str, version: str, what: str, shapes_of: Any, exact_shape: Any = None
) -> tuple[int, int, dict[str, Any], dict[str, Any]]:
    """``(na, nt, float arrays, exact values)`` of a verified entry of kind ``kind`` written by
    :func:`_encode_tables` for ``name`` at ``version``, holding exactly the arrays of
    ``shapes_of(na, nt)`` (``{array: shape}``; ``exact_shape(array, shape)`` the shape of its
    exact values where it differs); ``cache.InvalidEntry`` for anything else (``what`` names
    the entry in the message)."""
    payload = cache.unpack(kind, data)  # keyed hash checked before any parsing

    def bad(reason: str) -> Exception:
        return cache.InvalidEntry(f"is not a valid {what} entry ({reason})")

    def no_constant(c):
        raise ValueError(f"non-finite number {c}")

    try:
        doc = json.loads(payload.decode("utf-8"), parse_constant=no_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise bad(f"JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("key") != name or doc.get("version") != version:
        raise bad(f"written for {doc.get('key') if isinstance(doc, dict) else None!r}")
    na, nt = doc.get("na"), doc.get("nt")
    if not (_is_count(na) and _is_count(nt)):
        raise bad("mode counts")
    shapes_ = shapes_of(na, nt)
    floats, exact = doc.get("floats"), doc.get("exact")
    if (
        not isinstance(floats, dict)
        or not isinstance(exact, dict)
        or set(floats) != set(shapes_)
        or set(exact) != set(shapes_)
    ):
        raise bad(f"it must hold exactly {', '.join(shapes_)}")
    arrays: dict[str, Any] = {}
    values: dict[str, Any] = {}
    for a, shape in shapes_.items():
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
        want = exact_shape(a, shape) if exact_shape else shape
        if tuple(values[a].shape) != want:
            raise bad(f"{a}: exact values of shape {tuple(values[a].shape)}, not {want}")
    return na, nt, arrays, values


def _encode_entry(name: str, ip: InnerProducts) -> bytes:
    return _encode_tables(_CACHE_KIND, SHAPES_VERSION, name, ip.na, ip.nt, ip, _ARRAYS)


def _decode_entry(data: bytes, name: str) -> InnerProducts:
    """The inner products of a verified entry; ``cache.InvalidEntry`` for anything else."""
    na, nt, arrays, values = _decode_tables(
        data,
        name,
        _CACHE_KIND,
        SHAPES_VERSION,
        "shape",
        _shapes_of,
        lambda a, shape: (shape[0], 1) if a == "psid1" else shape,  # psid1: an nt x 1 column
    )
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
    _cached_sixth.cache_clear()
    _cached_nodes.cache_clear()


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
    return _encode_tables(_CURVATURE_KIND, CURVATURE_VERSION, name, cp.na, cp.nt, cp, _CURVATURE_ARRAYS)


def _decode_curvature(data: bytes, name: str) -> CurvatureProducts:
    """The tables of a verified entry; ``cache.InvalidEntry`` for anything else."""
    na, nt, arrays, values = _decode_tables(
        data, name, _CURVATURE_KIND, CURVATURE_VERSION, "curvature", _curvature_shapes
    )
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


# --------------------------------------------------------------------------------------
# The exact bar's sixth-order tables: computed by quadrature in well under a second for the
# counts symgen uses (faster than reading an entry of nt^6 / 720 numbers), so held in memory only
# --------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=64)
def _cached_sixth(akey: tuple, apts: tuple, tkey: tuple, tpts: tuple, mpts: tuple) -> SixthOrderProducts:
    ba = corrected_basis(basis_of_key(akey), apts)
    bt = corrected_basis(basis_of_key(tkey), tpts, mpts)
    return static_shapes.sixth_order_products(ba.functions, bt.functions)


@functools.lru_cache(maxsize=64)
def _cached_nodes(akey: tuple, apts: tuple, tkey: tuple, tpts: tuple, mpts: tuple) -> tuple:
    ba = corrected_basis(basis_of_key(akey), apts)
    bt = corrected_basis(basis_of_key(tkey), tpts, mpts)
    return _nodes_of(ba, bt)


def _nodes_of(axial: Basis, transverse: Basis) -> tuple:
    n = static_shapes.node_form_nodes(max(len(axial.functions), len(transverse.functions)))
    return static_shapes.quadrature_nodes(axial.functions, transverse.functions, n)


def node_form_nodes(axial: Basis, transverse: Basis) -> tuple:
    """(W, A, B, F) of the exact bar's node form (:func:`static_shapes.quadrature_nodes` with
    :func:`static_shapes.node_form_nodes` per piece) of one bar's bases, cached in memory."""
    if not _is_keyed(axial, transverse):  # hand-made basis: nothing to key a cache on
        return _nodes_of(axial, transverse)
    return _cached_nodes(
        axial.key, tuple(axial.points), transverse.key, tuple(transverse.points), tuple(transverse.moment_points)
    )


def _is_keyed(axial: Basis, transverse: Basis) -> bool:
    """Whether both bases are what their keys rebuild (then cached by key)."""
    try:
        return all(
            r is b or r == b
            for r, b in (
                (corrected_basis(basis_of_key(axial.key), axial.points), axial),
                (
                    corrected_basis(basis_of_key(transverse.key), transverse.points, transverse.moment_points),
                    transverse,
                ),
            )
        )
    except ValueError:
        return False


def sixth_order_products(axial: Basis, transverse: Basis) -> SixthOrderProducts:
    """The exact bar's sixth-order tables (:class:`symgen.model.static_shapes.SixthOrderProducts`)
    of one bar's bases, cached in memory."""
    try:
        same = all(
            r is b or r == b
            for r, b in (
                (corrected_basis(basis_of_key(axial.key), axial.points), axial),
                (
                    corrected_basis(basis_of_key(transverse.key), transverse.points, transverse.moment_points),
                    transverse,
                ),
            )
        )
    except ValueError:
        same = False
    if not same:  # hand-made basis: nothing to key a cache on
        return static_shapes.sixth_order_products(axial.functions, transverse.functions)
    return _cached_sixth(
        axial.key, tuple(axial.points), transverse.key, tuple(transverse.points), tuple(transverse.moment_points)
    )
