"""Test-session setup shared by every test folder.

Makes the checkout importable (``import symgen``) when the package is not pip-installed.
"""

from __future__ import annotations

import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

# The suite runs the model in CasADi's virtual machine unless SYMGEN_BACKEND says otherwise
# (SYMGEN_BACKEND=auto runs it compiled): a fresh cache would otherwise compile a library for
# every scene the tests build. tests/test_compiled.py runs the compiled backend itself and
# checks that it gives the virtual machine's numbers to the last bit.
import os  # noqa: E402


os.environ.setdefault("SYMGEN_BACKEND", "vm")


# ----------------------------------------------------------------------------- parallel runs
# Under pytest-xdist with ``--dist loadfile`` (the README's command: ``-n 2 --dist loadfile``)
# every module runs on one worker, so its module-scoped fixtures and lru_caches are computed once
# per session. The modules that take longest (cold cache, measured) are handed out first, so
# that neither worker is left with a long module at the end; the others keep their order.
# Without xdist (or with -n 0) nothing changes: same tests, same order.
_FIRST = [
    "tests/test_emit_c.py",
    "tests/test_packaging.py",
    "tests/test_generated.py",
    "tests/test_compiled.py",
    "tests/test_latex.py",
    "tests/test_hard_cases.py",
    "tests/test_slider_crank.py",
    "tests/test_axial_default.py",
    "tests/test_effects.py",
    "tests/test_prescribed_motion.py",
    "tests/test_slot.py",
    "tests/test_quasistatic.py",
    "tests/scene/test_fuzz.py",
    "tests/test_fmu.py",
    "tests/test_sweep.py",
    "tests/test_study.py",
]


def _by_file(config) -> bool:
    return config.pluginmanager.hasplugin("xdist") and getattr(config.option, "dist", "no") == "loadfile"


def pytest_configure(config):
    if _by_file(config):
        config.option.loadscopereorder = False  # hand the modules out in the order below, not by size


def pytest_collection_modifyitems(config, items):
    if _FIRST and (_by_file(config) or hasattr(config, "workerinput")):
        rank = {name: k for k, name in enumerate(_FIRST)}
        items.sort(key=lambda it: rank.get(it.path.relative_to(ROOT).as_posix(), len(rank)))  # stable
