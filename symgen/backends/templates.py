"""Where the jinja2 templates of the backends are: the top-level ``templates/`` folder, one
folder per backend (``templates/c/``, its FMI headers in ``templates/c/fmi2/``,
``templates/latex/``).

A wheel carries them as the package data of ``symgen.templates`` (pyproject.toml maps the
folder there with ``package-dir``), so an installed symgen finds them at ``symgen/templates/``
through ``importlib.resources``; a source checkout (``PYTHONPATH``, or an editable install, whose
``symgen`` is the checkout's) finds them beside the ``symgen`` package.
"""

from __future__ import annotations

from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

BACKENDS = ("c", "latex")


def _installed() -> Traversable:
    return resources.files("symgen") / "templates"


def _checkout() -> Path:
    return Path(__file__).resolve().parent.parent.parent / "templates"


def folder(backend: str) -> Traversable:
    """The templates of ``backend`` ("c" or "latex"): installed ones first, else the checkout's."""
    if backend not in BACKENDS:
        raise ValueError(f"no templates for the backend {backend!r} (known: {', '.join(BACKENDS)})")
    installed = _installed() / backend
    if installed.is_dir():
        return installed
    checkout = _checkout() / backend
    if checkout.is_dir():
        return checkout
    raise FileNotFoundError(
        f"the {backend} templates are missing: neither {installed} (an installed symgen) "
        f"nor {checkout} (a source checkout) exists; reinstall symgen"
    )


def loader(backend: str):
    """A jinja2 loader of ``folder(backend)`` (through importlib.resources when installed)."""
    import jinja2  # here: the cache keys read folder() without jinja2

    if (_installed() / backend).is_dir():
        return jinja2.PackageLoader("symgen", f"templates/{backend}")
    return jinja2.FileSystemLoader(str(folder(backend)))
