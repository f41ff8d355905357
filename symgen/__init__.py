"""symgen: symbolic dynamics of planar mechanisms with elastic bars.

Data flows one way through these stages::

    scene (symgen.scene) -> topology -> shapes -> kinematics (1), (10), (11)
      -> bars (8)-(9), (16)-(17) and rigid-body equations -> dae (assembled model)
      -> emit (casadi, latex) -> run (idas, outputs)
"""

__version__ = "0.1.0"

from symgen import classcode as _classcode

_classcode.install()  # symgen's dataclasses' methods recalled compiled (symgen.classcode)
