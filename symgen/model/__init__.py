"""The derived model (SymPy only): topology, shape functions and their closed-form inner
products, bar kinematics (1), (10)-(11), the weak-form bar equations (8)-(17), constraints,
loads, the residual and the outputs. ``derive.derive(scene)`` is the one entry point."""
