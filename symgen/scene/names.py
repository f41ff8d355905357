"""Names in a scene (scene, bodies, joints, outputs) become C symbols: check them.

A valid name matches ``[A-Za-z_][A-Za-z0-9_]*`` (ASCII only), has at most 63 characters and
is not a C (C99/C11) or C++ keyword.

Examples
--------
>>> name_problem("rod_1") is None
True
>>> name_problem("int")
"'int' is a C/C++ keyword"
"""

from __future__ import annotations

import re

MAX_NAME_LENGTH = 63
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")

C_KEYWORDS = frozenset(
    """
    auto break case char const continue default do double else enum extern float for goto if
    inline int long register restrict return short signed sizeof static struct switch typedef
    union unsigned void volatile while _Bool _Complex _Imaginary
    _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
""".split()
)

CPP_KEYWORDS = frozenset(
    """
    alignas alignof and and_eq asm atomic_cancel atomic_commit atomic_noexcept bitand bitor bool
    catch char8_t char16_t char32_t class compl concept const_cast consteval constexpr constinit
    co_await co_return co_yield decltype delete dynamic_cast explicit export false friend mutable
    namespace new noexcept not not_eq nullptr operator or or_eq private protected public
    reflexpr reinterpret_cast requires static_assert static_cast synchronized template this
    thread_local throw true try typeid typename using virtual wchar_t xor xor_eq
""".split()
)

KEYWORDS = C_KEYWORDS | CPP_KEYWORDS

NAME_RULE = (
    "names must be C identifiers: an ASCII letter or '_' followed by ASCII letters, "
    f"digits or '_', at most {MAX_NAME_LENGTH} characters, not a C/C++ keyword"
)


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot be used as a C identifier, or ``None`` if it can.

    Parameters
    ----------
    name : the candidate name

    Returns
    -------
    A short phrase describing the problem, or ``None``.
    """
    if name == "":
        return "the name is empty"
    if len(name) > MAX_NAME_LENGTH:
        return f"it has {len(name)} characters (at most {MAX_NAME_LENGTH})"
    if not IDENTIFIER.fullmatch(name):
        if name[0].isdigit():
            return "it starts with a digit"
        bad = sorted({c for c in name if not (c.isascii() and (c.isalnum() or c == "_"))})
        shown = ", ".join(repr(c) for c in bad)
        return f"it contains characters other than ASCII letters, digits and '_' ({shown})"
    if name in KEYWORDS:
        return f"{name!r} is a C/C++ keyword"
    return None
