"""Tutorial: the derived equations of a mechanism as SymPy objects (``symgen.api.equations``).

Run it from the repository's root (the test suite runs it too)::

    python docs/tutorial_equations.py

symgen derives a scene's equations once, with its parameters as symbols. ``equations`` gives
them the way ``sympy.physics.mechanics`` users expect: a mass matrix, a forcing vector and the
constraints with their Jacobian, so that they can be linearised, simplified, compared with a
hand derivation or handed to other tools.
"""

import tempfile
from pathlib import Path

import sympy as sp

from symgen.api import equations

# 1. A rigid pendulum: one bar pinned to ground, under gravity, with a constant torque at the pin.
#    In the model's units (lengths / l0, masses / m_ref, time tau = omega t) the equation is
#    (1/3) theta'' = T - (g/2) cos(theta) for a bar of length 1 and mass 1.
PENDULUM = """
[scene]
name = "pendulum"
[[bodies]]
name = "bar"
length = 1.0
rigid = true
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "bar"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "torque"
body = "bar"
value = 0.3
[effects]
gravity = [0.0, -2.0]
[outputs]
theta = { kind = "angle", body = "bar" }
[simulation]
t_end = 1.0
"""

with tempfile.TemporaryDirectory() as folder:
    path = Path(folder) / "pendulum.toml"
    path.write_text(PENDULUM)
    eqs = equations(path)

(theta,) = eqs.coordinates
M = eqs.mass_matrix.xreplace(eqs.values)  # the parameters' values for this scene
f = eqs.forcing.xreplace(eqs.values)
print("coordinates:", eqs.coordinates)
print("mass matrix:", sp.nsimplify(M[0, 0]))
print("forcing:", sp.nsimplify(sp.simplify(f[0])))
(a,) = eqs.accelerations
print("theta'' =", sp.nsimplify(sp.simplify(sp.solve(sp.Eq((M * sp.Matrix([a]))[0], f[0]), a)[0])))

# 2. A closed loop: the seed's slider-crank. The multipliers are the cut joint's forces; the
#    constraint Jacobian is that of the loop closure (11) and the driver row.
eqs = equations("examples/slider_crank.toml")
print("slider-crank: q =", eqs.coordinates)
print(
    "mass matrix",
    eqs.mass_matrix.shape,
    "constraint Jacobian",
    eqs.constraint_jacobian.shape,
    "rows",
    [f"{r.kind} of {r.joint}" for r in eqs.rows],
)
