"""numpy (or another module: :class:`LazyModule`) imported on first use, not at the import of the modules that use it (issue 20, a lean
process): a cached run of the C solver (``symgen simulate --solver c --estimate off``) loads its
scene with the remembered bases, runs the library through ctypes and writes its CSV and sidecar
without numpy (tests/test_lean_start.py), although the modules on its way compute with numpy
everywhere else. A module that uses numpy only inside functions imports it as::

    if TYPE_CHECKING:
        import numpy as np
    else:
        from symgen.lazy import numpy as np

(the type checker sees numpy itself). The first attribute read imports numpy and copies its
namespace into the stand-in, so that later reads are plain module-attribute reads.
"""

from __future__ import annotations

import importlib
import types
from typing import Any

__all__ = ["LazyModule", "numpy"]


class LazyModule(types.ModuleType):
    """A stand-in for the module ``name``, imported at its first attribute read."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self._lazy_target = name

    def __getattr__(self, attr: str) -> Any:  # only for names not (yet) in the stand-in's namespace
        target = self.__dict__.get("_lazy_target")
        if target is None:
            raise AttributeError(attr)
        real = importlib.import_module(target)
        if "_lazy_loaded" not in self.__dict__:
            self.__dict__.update(vars(real))
            self.__dict__["_lazy_loaded"] = True
        value = getattr(real, attr)  # also a submodule the module itself imports on first use
        self.__dict__[attr] = value
        return value


numpy = LazyModule("numpy")
