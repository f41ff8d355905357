"""Where the jinja2 templates of the backends are: the top-level ``templates/`` folder, one
folder per backend (``templates/c/``, its FMI headers in ``templates/c/fmi2/``,
``templates/latex/``).

A wheel carries them as the package data of ``symgen.templates`` (pyproject.toml maps the
folder there with ``package-dir``), so an installed symgen finds them at ``symgen/templates/``
through ``importlib.resources``; a source checkout (``PYTHONPATH``, or an editable install, whose
``symgen`` is the checkout's) finds them beside the ``symgen`` package.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

BACKENDS = ("c", "latex")


def package_files(package: str) -> Traversable:
    """``importlib.resources.files(package)``; for a package in a folder (not in an archive), that
    folder as a Path without importing importlib.resources (a cached run's library key reads the
    templates: ~3 ms of its process)."""
    import importlib

    module = importlib.import_module(package)
    spec = getattr(module, "__spec__", None)
    locations = list(getattr(spec, "submodule_search_locations", None) or ())
    if len(locations) == 1 and getattr(spec, "origin", None) and Path(locations[0]).is_dir():
        return Path(locations[0])
    from importlib import resources

    return resources.files(package)


def _installed() -> Traversable:
    return package_files("symgen") / "templates"


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
