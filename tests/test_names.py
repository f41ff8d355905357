"""Symbol names are made in one place (``symgen.ir.names``) from typed fields, and no module
parses them back: consumers find coordinates, multipliers and intermediates by their records.

The grep below holds the known ways the code once built or parsed names (``f"theta_{...}"``,
``name[len("beta_"):]``, a regular expression per symbol family, ``re.match(r"E(X|Y...)_")``);
the table test holds that every symbol of a derived model has its LaTeX name from the records,
so that the LaTeX backend needs no rule of its own.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import sympy as sp

from symgen.ir import names
from symgen.model.derive import derive
from symgen.scene import load_scene

PKG = Path(__file__).resolve().parent.parent / "symgen"
ROOT = PKG.parent
HOME = PKG / "ir" / "names.py"

#: prefixes of the model's symbol names (symgen.ir.names)
PREFIXES = (
    r"(d|dd)?(theta|beta|s|f|g)|alpha|nu|lambda|mu|rho|L|Lx|Ly|N|EX|EY|Eth|Ef|Eg|Ebeta|SX|SY|px|py|dx|dy|m|I|"
    r"xAdd|yAdd|xAd|yAd"
)
FORBIDDEN = {
    "a name built from a prefix and a field (use symgen.ir.names)": re.compile(rf"""f["']({PREFIXES})_\{{(?!\{{)"""),
    "a load parameter's name built by hand (use names.load_parameter)": re.compile(r"""f["']load\{(?!\{)"""),
    "a name's prefix cut off to recover a field": re.compile(r"""\[len\(["'][A-Za-z]+_["']\):\]"""),
    "a test of a name's prefix": re.compile(rf"""\.startswith\(["']({PREFIXES})_["']"""),
    "a regular expression over underscore-joined names": re.compile(
        r"""re\.(compile|match|fullmatch|search)\(\s*r?f?["'][^"']*(\)_|_\(|_\$)"""
    ),
    "a coordinate found by its name (use ir.records.find_coordinate)": re.compile(r"""\[["']name["']\]\s*==\s*f["']"""),
    "a symbol remade from a record's name (use model.q / the record's symbol)": re.compile(
        r"Symbol\(c(\.name|\[\"name\"\])"
    ),
}


def offences(text: str) -> list[str]:
    return [f"{what}: {m.group(0)!r}" for what, pat in FORBIDDEN.items() for m in pat.finditer(text)]


def test_no_module_builds_or_parses_symbol_names():
    found = []
    for path in sorted(PKG.rglob("*.py")):
        if path == HOME:
            continue
        for lineno, line in enumerate(path.read_text().splitlines(), 1):
            found += [f"{path.relative_to(ROOT)}:{lineno}: {o}" for o in offences(line)]
    assert not found, "\n".join(found)


@pytest.mark.parametrize(
    "line",
    [
        'name = f"theta_{drv.body}"',
        'q[i] = guess.get(c["name"][len("beta_"):], 0.5)',
        '(re.compile(rf"(|d|dd)theta_({b})$"), fmt)',
        'if re.match(r"E(X|Y|th|f|g|beta)_", n):',
        'i = next(i for i, c in enumerate(coords) if c["name"] == f"theta_{b}")',
        'put(f"load{i + 1}_{comp}", val)',
        "lhs = pr(sp.Symbol(c.name))",
    ],
)
def test_the_grep_sees_the_old_patterns(line):
    """The check can fail: each line here is one the code held before the records."""
    assert offences(line)


def test_names_are_typed_and_distinct():
    made = [
        names.bar_angle("rod"),
        names.bar_angle("rod", 2),
        names.amplitude("f", "rod_1", 0),
        names.amplitude("f", "rod", 0),
        names.amplitude("g", "rod", 1, 1),
        names.slider_travel("B"),
        names.slot_support("B", 1),
        names.joint_force("B", "x"),
        names.joint_force("B"),
        names.DRIVER_FORCE,
        names.axial_force("rod", 0),
        names.generalized_force("th", "rod"),
        names.generalized_force("f", "rod", 2),
        names.subtree_force("x", "rod"),
        names.bar_parameter("lambda", "rod"),
        names.joint_parameter("px", "A"),
        names.global_parameter("theta0"),
        names.load_parameter(0, "axial", point=True),
    ]
    assert len({n.text for n in made}) == len(made)
    assert names.amplitude("f", "rod_1", 0).latex == r"f_{\mathrm{rod\_1},1}"
    assert names.bar_angle("rod", 2).latex == r"\ddot \theta_{\mathrm{rod}}"
    assert names.load_parameter(0, "axial", point=False).latex == r"\bar\beta_{1}"
    assert names.coordinate("beta", "guide", joint="C").text == names.slot_support("C").text
    with pytest.raises(ValueError):
        names.amplitude("h", "rod", 0)
    with pytest.raises(ValueError, match="index"):  # an amplitude's force needs its index
        names.generalized_force("g", "rod")


@pytest.mark.parametrize("scene_file", ["slider_crank", "inverted_slider_crank", "motor_arm"])
def test_every_symbol_of_a_model_has_its_latex_name_from_the_records(scene_file):
    model = derive(load_scene(ROOT / "examples" / f"{scene_file}.toml"))
    prog = model.program
    exprs = [e for _, e in prog.assignments] + [e for out in prog.outputs.values() for e in out]
    used = set().union(*(sp.sympify(e).free_symbols for e in exprs)) | {s for s, _ in prog.assignments}
    missing = sorted(s.name for s in used if s.name not in model.latex)
    assert not missing, f"symbols without a LaTeX name: {missing}"
    # the coordinates' records and their symbols agree, field by field
    for c, x in zip(model.coords, model.q):
        assert names.coordinate(c.kind, c.body, c.joint, c.index).text == x.name == c.name
