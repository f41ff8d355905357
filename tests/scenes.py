"""Scene texts that several test modules share.

The tests of the axial estimate, the quasi-static start and the model's range all run one elastic
arm pinned to the ground; each module used to write that arm out again. Here it is written once;
each test adds what it is about (driver, effects, outputs, simulation).
"""

from __future__ import annotations


def pinned_arm(name: str, bar: str, rest: str, *, tip_mass: str | None = None) -> str:
    """A scene of one elastic bar ``arm``, 1 long, a cantilever frame, pinned to the ground at the
    origin with its angle 0 along x, in dimensionless units (omega 1, reference length 1).

    ``bar`` holds the bar's own lines (``lambda``, ``mu``, the counts), ``tip_mass`` (a number,
    or a placeholder the test replaces) adds a ``[[masses]]`` point at the tip, and ``rest`` is the
    remaining tables as written in the scene file. Placeholders in any of them are left for the
    test to replace.
    """
    mass = "" if tip_mass is None else f'[[masses]]\nbody = "arm"\nat = 1.0\nmass = {tip_mass}\n\n'
    return (
        f'\n[scene]\nname = "{name}"\nunits = "dimensionless"\nomega = 1.0\nreference_length = 1.0\n\n'
        f'[[bodies]]\nname = "arm"\nlength = 1.0\n{bar.strip()}\nframe = "cantilever"\n\n'
        '[[joints]]\nname = "O"\nkind = "pin"\nbodies = ["ground", "arm"]\nat = [[0.0, 0.0], 0.0]\n\n'
        f"{mass}{rest.lstrip()}"
    )
