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
