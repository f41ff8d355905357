"""SymPy expressions as plain JSON trees, for the caches (never pickle, never parsed as text).

A tree is a list whose first item names the node; only these nodes exist::

    ["int", "<decimal digits>"]                         Integer
    ["rat", "<p>", "<q>"]                               Rational p/q
    ["float", sign, "<mantissa hex>", exp, prec]        Float (-1)^sign * man * 2^exp, prec bits
    ["const", "pi" | "E"]                               pi, E
    ["sym", "<name>", real]                             Symbol (real: True/False)
    ["add", t...], ["mul", t...], ["pow", base, exp]    Add, Mul, Pow
    ["fn", "<name>", t]                                 sin cos tan exp log sinh cosh tanh

:func:`decode` builds each node with its SymPy constructor (``sympy.Add(*args)``...): no text
of a file ever goes to ``sympify``, ``eval`` or ``srepr``; anything else raises ``ValueError``.
Numbers are bounded (digits, exponents, precision) and so is the depth of a tree.
"""

from __future__ import annotations

import itertools
import math
import re

import sympy

__all__ = ["encode", "decode", "encode_tensor", "decode_tensor"]

_FUNCS = {
    "sin": sympy.sin,
    "cos": sympy.cos,
    "tan": sympy.tan,
    "exp": sympy.exp,
    "log": sympy.log,
    "sinh": sympy.sinh,
    "cosh": sympy.cosh,
    "tanh": sympy.tanh,
}
_CONSTS = {"pi": sympy.pi, "E": sympy.E}
_INT = re.compile(r"-?[0-9]{1,1000}")
_HEX = re.compile(r"[0-9a-f]{1,2500}")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")
MAX_DEPTH = 64
_MAX_PREC = 10_000  # bits of a Float (50 digits need 169)
_MAX_EXP = 100_000  # |binary exponent| of a Float


def encode(e: sympy.Basic) -> list:
    """The tree of ``e``; ``ValueError`` for a node outside the list above."""
    if isinstance(e, sympy.Integer):
        return ["int", str(int(e))]
    if isinstance(e, sympy.Rational):
        return ["rat", str(e.p), str(e.q)]
    if isinstance(e, sympy.Float):
        sign, man, exp, _ = e._mpf_
        if man == 0 and exp != 0:
            raise ValueError(f"cannot encode the special Float {e}")
        return ["float", int(sign), format(int(man), "x"), int(exp), int(e._prec)]
    for name, c in _CONSTS.items():
        if e is c:
            return ["const", name]
    if isinstance(e, sympy.Symbol) and type(e) is sympy.Symbol:
        real = e.is_real is True
        if (
            e.assumptions0 != sympy.Symbol(e.name, real=True).assumptions0
            and e.assumptions0 != sympy.Symbol(e.name).assumptions0
        ):
            raise ValueError(f"cannot encode the assumptions of the symbol {e}")
        return ["sym", e.name, real]
    if isinstance(e, sympy.Add):
        return ["add", *(encode(a) for a in e.args)]
    if isinstance(e, sympy.Mul):
        return ["mul", *(encode(a) for a in e.args)]
    if isinstance(e, sympy.Pow):
        return ["pow", encode(e.base), encode(e.exp)]
    for name, f in _FUNCS.items():
        if e.func is f:
            return ["fn", name, encode(e.args[0])]
    raise ValueError(f"cannot encode {type(e).__name__} {e}")


def _int(s) -> int:
    if not isinstance(s, str) or not _INT.fullmatch(s):
        raise ValueError(f"not an integer literal: {s!r:.40}")
    return int(s)


def _plain_int(x, lo: int, hi: int) -> int:
    if not isinstance(x, int) or isinstance(x, bool) or not lo <= x <= hi:
        raise ValueError(f"integer out of range [{lo}, {hi}]: {x!r:.40}")
    return x


def decode(t, depth: int = 0) -> sympy.Expr:
    """The expression of tree ``t`` (``ValueError`` for anything that is not a valid tree)."""
    if depth > MAX_DEPTH:
        raise ValueError(f"expression tree deeper than {MAX_DEPTH}")
    if not isinstance(t, list) or not t or not isinstance(t[0], str):
        raise ValueError(f"not an expression node: {t!r:.60}")
    tag, args = t[0], t[1:]

    def arity(n: int) -> None:
        if len(args) != n:
            raise ValueError(f"node {tag!r} takes {n} items, got {len(args)}")

    if tag == "int":
        arity(1)
        return sympy.Integer(_int(args[0]))
    if tag == "rat":
        arity(2)
        p, q = _int(args[0]), _int(args[1])
        if q <= 0:
            raise ValueError("rational with a denominator <= 0")
        return sympy.Rational(p, q)
    if tag == "float":
        arity(4)
        sign = _plain_int(args[0], 0, 1)
        if not isinstance(args[1], str) or not _HEX.fullmatch(args[1]):
            raise ValueError("Float mantissa is not hexadecimal digits")
        man = int(args[1], 16)
        exp = _plain_int(args[2], -_MAX_EXP, _MAX_EXP)
        prec = _plain_int(args[3], 1, _MAX_PREC)
        if man.bit_length() > prec:
            raise ValueError("Float mantissa wider than its precision")
        value = sympy.Rational((-man if sign else man) * 2 ** max(exp, 0), 2 ** max(-exp, 0))
        return sympy.Float(value, precision=prec)
    if tag == "const":
        arity(1)
        if args[0] not in _CONSTS:
            raise ValueError(f"unknown constant {args[0]!r:.40}")
        return _CONSTS[args[0]]
    if tag == "sym":
        arity(2)
        if not isinstance(args[0], str) or not _NAME.fullmatch(args[0]) or not isinstance(args[1], bool):
            raise ValueError(f"bad symbol node {t!r:.60}")
        return sympy.Symbol(args[0], real=True) if args[1] else sympy.Symbol(args[0])
    if tag in ("add", "mul"):
        if len(args) < 2:
            raise ValueError(f"node {tag!r} needs at least two terms")
        terms = [decode(a, depth + 1) for a in args]
        return sympy.Add(*terms) if tag == "add" else sympy.Mul(*terms)
    if tag == "pow":
        arity(2)
        return sympy.Pow(decode(args[0], depth + 1), decode(args[1], depth + 1))
    if tag == "fn":
        arity(2)
        if args[0] not in _FUNCS:
            raise ValueError(f"unknown function {args[0]!r:.40}")
        return _FUNCS[args[0]](decode(args[1], depth + 1))
    raise ValueError(f"unknown node {tag!r:.40}")


def encode_tensor(m) -> dict:
    """An ``ImmutableMatrix`` or ``ImmutableDenseNDimArray`` as ``{kind, shape, entries}``."""
    shape = [int(n) for n in m.shape]
    if isinstance(m, sympy.MatrixBase):
        return {"kind": "matrix", "shape": shape, "entries": [encode(x) for x in m]}
    if isinstance(m, sympy.NDimArray):
        # a dense array's entries in row-major order as stored (indexing each costs ~0.1 ms in
        # SymPy: 2 s of a first derivation's shape tables at 10 transverse functions)
        flat = getattr(m, "_array", None) if isinstance(m, sympy.tensor.array.DenseNDimArray) else None
        if flat is None or len(flat) != math.prod(shape):
            flat = [m[idx] for idx in itertools.product(*(range(n) for n in shape))]
        entries = [encode(x) for x in flat]
        return {"kind": "array", "shape": shape, "entries": entries}
    raise ValueError(f"cannot encode {type(m).__name__}")


def decode_tensor(d) -> sympy.Basic:
    if not isinstance(d, dict) or set(d) != {"kind", "shape", "entries"}:
        raise ValueError("not a tensor")
    shape = d["shape"]
    if not isinstance(shape, list) or not all(
        isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= 10_000 for n in shape
    ):
        raise ValueError(f"bad tensor shape {shape!r:.60}")
    size = 1
    for n in shape:
        size *= n
    entries = d["entries"]
    if not isinstance(entries, list) or len(entries) != size:
        raise ValueError(f"tensor of shape {shape} without {size} entries")
    values = [decode(x) for x in entries]
    if d["kind"] == "matrix":
        if len(shape) != 2:
            raise ValueError("matrix shape is not 2-d")
        return sympy.ImmutableMatrix(shape[0], shape[1], values)
    if d["kind"] == "array":
        return sympy.ImmutableDenseNDimArray(values, tuple(shape))
    raise ValueError(f"unknown tensor kind {d['kind']!r:.40}")
