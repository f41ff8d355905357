"""The C prefix of a scene and safe spellings of names inside C text, comments and XML.

The scene loader already validates every name as a C identifier; these checks are repeated
here (a ``Scene`` can be built or altered in code) so that nothing raw reaches the C text:
a prefix that is not a plain ASCII identifier, a C/C++ keyword, or a reserved identifier
(``_`` + capital, or ``__``) is rejected with a ``SceneError``. Other strings (parameter,
output, coordinate names, file names) only ever appear inside string literals, comments or
XML attributes, escaped by the functions below.

>>> c_prefix_problem("slider crank")
"it contains characters other than ASCII letters, digits and '_' (' ')"
>>> c_string('say "hi"\\n')
'"say \\\\"hi\\\\"\\\\n"'
"""

from __future__ import annotations

from symgen.errors import SceneError
from symgen.scene.names import name_problem


#: Headers a compile of the emitted C includes by a bare name (``<math.h>``, and what the C
#: library's headers include in turn), and the FMI headers shipped beside an FMU's sources: the
#: scene's ``NAME.h`` would shadow them (the folder is on the include path). C23's standard
#: headers, glibc's top-level headers that they pull in, and the POSIX ones the C library may
#: use. ``tests/test_emit_c_names.py`` checks, by asking the compiler which headers a build of
#: the emitted C includes, that every one of them is here.
HEADER_NAMES = frozenset(
    """
    assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal stdalign
    stdarg stdatomic stdbit stdbool stdckdint stddef stdint stdio stdlib stdnoreturn string tgmath
    threads time uchar wchar wctype
    alloca endian features strings syslimits unistd fcntl pthread sched dlfcn malloc memory stdc_predef
    fmi2functions fmi2functiontypes fmi2typesplatform
""".split()
)
#: Target names CMake reserves (policy CMP0037, and the targets its generators add): the
#: emitted CMakeLists.txt names its library after the scene.
CMAKE_TARGETS = frozenset(
    """
    all clean help install test package package_source edit_cache rebuild_cache
    list_install_components depend preinstall all_build zero_check run_tests
""".split()
)
#: The C runtime's files and symbols (``symgen_solver.c``, ``symgen_runtime.h``...).
RUNTIME_PREFIX = "symgen"


def c_prefix_problem(name: str) -> str | None:
    """Why ``name`` cannot prefix the emitted C symbols and name its files, or ``None``."""
    if not isinstance(name, str):
        return "it is not a string"
    problem = name_problem(name)
    if problem:
        return problem
    if name.startswith("__") or (name.startswith("_") and len(name) > 1 and name[1].isupper()):
        return "identifiers that begin with '__' or '_' and a capital letter are reserved in C"
    low = name.lower()  # a case-insensitive file system shadows Math.h as well
    if low in HEADER_NAMES:
        return f"the emitted header {name}.h would hide the system or FMI header <{low}.h>"
    if low in CMAKE_TARGETS:
        return f"'{name}' is a target name that CMake reserves (the emitted CMakeLists.txt names its library after the scene)"
    if low == RUNTIME_PREFIX or low.startswith(RUNTIME_PREFIX + "_"):
        return "names that begin with 'symgen' are the C runtime's (symgen_solver.c, symgen_runtime.h)"
    return None


def c_prefix(scene) -> str:
    """The prefix of every exported C symbol: the scene name, validated (never mangled)."""
    problem = c_prefix_problem(scene.name)
    if problem:
        raise SceneError(
            getattr(scene, "path", "scene"),
            "scene.name",
            f"{scene.name!r} cannot prefix the emitted C symbols: {problem}",
            'rename the scene with [scene] name = "a_c_identifier"',
        )
    return scene.name


def c_string(text: str) -> str:
    """A C string literal for ``text`` (ASCII only: other characters as octal escapes of UTF-8)."""
    out = ['"']
    for byte in str(text).encode("utf-8"):
        ch = chr(byte)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "?":
            out.append("\\?")  # no trigraphs
        elif 32 <= byte < 127:
            out.append(ch)
        else:
            out.append(f"\\{byte:03o}")
    out.append('"')
    return "".join(out)


def c_comment(text: str) -> str:
    """``text`` made safe inside a /* */ comment: printable ASCII, no comment delimiters."""
    safe = "".join(c if 32 <= ord(c) < 127 else f"\\u{ord(c):04x}" for c in str(text))
    return safe.replace("*/", "*\\/").replace("/*", "/\\*")


def xml_attr(text: str) -> str:
    """``text`` escaped for a double-quoted XML attribute."""
    return (
        str(text)
        .replace("&", "&amp;")
        .replace("<", "&lt;")
        .replace(">", "&gt;")
        .replace('"', "&quot;")
        .replace("\n", "&#10;")
    )
