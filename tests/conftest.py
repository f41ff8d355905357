"""Test-session setup shared by every test folder.

Makes the checkout importable (``import symgen``) when the package is not pip-installed.
"""
from __future__ import annotations

import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
