"""symgen's modules import one way: scene -> model -> IR/emitters -> numerics -> apps -> entry
points (``docs/architecture.md``). Every module belongs to exactly one layer; an import of a
higher layer (also a lazy one inside a function) fails this test unless it is one of the known
exceptions listed below, which are debts to pay (issue 10), not a licence: the list may only
shrink (a paid debt that is still listed fails too). Within the model, no two modules import
each other, directly or round a longer circle (lazy imports included)."""

from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parent.parent / "symgen"

#: layer of each module (the longest matching prefix wins); lower layers never import higher ones
LAYERS = {
    0: (
        "symgen",
        "symgen.errors",
        "symgen.cache",
        "symgen.progress",
        "symgen.exprdata",
        "symgen.outputs",
        "symgen.policy",
        "symgen.processes",
    ),
    1: ("symgen.scene",),
    2: ("symgen.ir",),
    3: ("symgen.model",),
    4: ("symgen.backends",),
    5: ("symgen.numerics",),
    6: ("symgen.apps",),
    7: ("symgen.api", "symgen.cli"),
}
NAMES = {
    0: "base",
    1: "scene",
    2: "IR (contract)",
    3: "model",
    4: "backends",
    5: "numerics",
    6: "apps",
    7: "entry points (API, CLI)",
}

#: known upward imports (importer, imported): none left; a new one is a debt to justify here
KNOWN: set[tuple[str, str]] = set()


def _module(path: Path, root: Path = PKG) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> int:
    best, found = -1, None
    for lay, prefixes in LAYERS.items():
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, found = len(p), lay
    assert found is not None, f"{module} belongs to no layer: add it to LAYERS (and docs/architecture.md)"
    return found


def imports(path: Path, root: Path = PKG) -> set[str]:
    """symgen modules imported anywhere in ``path`` (top level or inside functions)."""
    mod = _module(path, root)
    pkg = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
    known = {_module(p, root) for p in root.rglob("*.py")}
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            base = (
                ".".join(pkg[: len(pkg) - node.level + 1] + ([node.module] if node.module else []))
                if node.level
                else (node.module or "")
            )
            for a in node.names:  # "from . import x" imports the module x when it is one
                out.add(f"{base}.{a.name}" if f"{base}.{a.name}" in known else base)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return {m for m in out if m in known and m != mod}


def _edges(root: Path = PKG) -> set[tuple[str, str]]:
    return {(_module(p, root), m) for p in root.rglob("*.py") for m in imports(p, root)}


def circles(edges: set[tuple[str, str]], package: str) -> list[list[str]]:
    """The import circles among the modules of ``package`` (each a sorted list of modules that
    reach each other): the strongly connected components of more than one module."""
    inside = {(a, b) for a, b in edges if a.startswith(package + ".") and b.startswith(package + ".")}
    graph: dict[str, set[str]] = {}
    for a, b in inside:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())

    def reach(start: str) -> set[str]:
        seen, todo = set(), [start]
        while todo:
            for n in graph[todo.pop()] - seen:
                seen.add(n)
                todo.append(n)
        return seen

    reached = {m: reach(m) for m in graph}
    out = {tuple(sorted({m} | {n for n in reached[m] if m in reached[n]})) for m in graph if m in reached[m]}
    return sorted(list(c) for c in out)


def test_every_module_has_a_layer():
    for p in PKG.rglob("*.py"):
        layer(_module(p))


def test_no_layer_imports_a_higher_one():
    upward = {(a, b) for a, b in _edges() if layer(b) > layer(a)}
    new = sorted(upward - KNOWN)
    assert not new, "upward imports: " + "; ".join(
        f"{a} ({NAMES[layer(a)]}) imports {b} ({NAMES[layer(b)]})" for a, b in new
    )
    paid = sorted(KNOWN - upward)
    assert not paid, f"no longer imported, remove from KNOWN: {paid}"


def test_no_model_modules_import_each_other():
    """The model's modules form no import circle (``shapes`` and ``static_shapes`` did: the
    term algebra is ``terms``, the cache ``shape_cache``, each imported one way)."""
    found = circles(_edges(), "symgen.model")
    assert not found, "import circles in the model: " + "; ".join(" <-> ".join(c) for c in found)


def _package(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)


def test_the_checker_sees_a_lazy_circle(tmp_path):
    """The circle test can fail: a model module importing another lazily, which imports it back
    at the top (and a three-module circle) are found; a one-way chain is not."""
    root = tmp_path / "symgen"
    _package(
        root,
        {
            "__init__.py": "",
            "model/__init__.py": "",
            "model/a.py": "def f():\n    from symgen.model.b import g\n",
            "model/b.py": "from .a import f\n",
            "model/c.py": "from symgen.model import d\n",
            "model/d.py": "from . import e\n",
            "model/e.py": "def h():\n    import symgen.model.c\n",
            "model/x.py": "from symgen.model import y\n",
            "model/y.py": "from symgen.model import a\n",
        },
    )
    assert circles(_edges(root), "symgen.model") == [
        ["symgen.model.a", "symgen.model.b"],
        ["symgen.model.c", "symgen.model.d", "symgen.model.e"],
    ]


def test_apps_may_not_import_the_entry_points(tmp_path):
    """The API and the CLI sit above the applications: ``symgen.api`` may import
    ``symgen.apps.sweep``; an application importing ``symgen.api`` (lazily too) is upward."""
    assert layer("symgen.api") > layer("symgen.apps.effects") and layer("symgen.cli") > layer("symgen.apps.study")
    root = tmp_path / "symgen"
    _package(
        root,
        {
            "__init__.py": "",
            "api.py": "from symgen.apps.sweep import sweep\n",
            "apps/__init__.py": "",
            "apps/sweep.py": "def sweep():\n    pass\n",
            "apps/reproduce.py": "def run():\n    from symgen.api import mechanism\n",
        },
    )
    edges = _edges(root)
    assert [(a, b) for a, b in sorted(edges) if layer(b) > layer(a)] == [("symgen.apps.reproduce", "symgen.api")]


def test_the_checker_sees_lazy_and_relative_imports(tmp_path):
    """The test can fail: in a package laid out like symgen, a scene module importing the
    numerics lazily and relatively (``from ..numerics.mechanism import``) is an upward edge."""
    root = tmp_path / "symgen"
    for name in ("__init__.py", "errors.py", "scene/__init__.py", "numerics/__init__.py", "numerics/mechanism.py"):
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("")
    bad = root / "scene" / "bad.py"
    bad.write_text("from ..errors import SceneError\n\ndef f():\n    from ..numerics.mechanism import Mechanism\n")
    found = imports(bad, root)
    assert found == {"symgen.errors", "symgen.numerics.mechanism"}
    assert [m for m in found if layer(m) > layer("symgen.scene.bad")] == ["symgen.numerics.mechanism"]


# --------------------------------------------------------------------------- backends take data
#: names under which a numerics object (a Mechanism) would enter a backend
_MECHANISM_NAMES = {"mech", "mechanism", "Mechanism"}


def mechanism_uses(path: Path) -> list[str]:
    """Where the module ``path`` takes or uses a numerics ``Mechanism``: a parameter or name
    ``mech`` / ``mechanism`` / ``Mechanism``, or a call of one of Mechanism's methods (by its
    name, on any object: a duck-typed mechanism is still the numerics called at run time)."""
    from symgen.numerics.mechanism import Mechanism

    methods = {n for n, v in vars(Mechanism).items() if not n.startswith("_") and callable(v)}
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        where = f"{path.name}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, ast.arg) and node.arg in _MECHANISM_NAMES:
            found.append(f"{where}: parameter {node.arg!r}")
        elif isinstance(node, ast.Name) and node.id in _MECHANISM_NAMES:
            found.append(f"{where}: name {node.id!r}")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in methods:
            found.append(f"{where}: call of Mechanism.{node.func.attr}")
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id == "getattr"
            and len(node.args) > 1
            and isinstance(node.args[1], ast.Constant)
            and node.args[1].value in methods
        ):
            found.append(f"{where}: getattr of Mechanism.{node.args[1].value}")
    return found


def test_backends_take_data_not_a_mechanism():
    """The backends run no numerics (issue 23): no backends module imports symgen.numerics (the
    layer rule above), and none takes a Mechanism or calls its methods; the C emitter receives
    the model, its ModelInfo and the StartPlan the numerics made, as data."""
    bad = [use for p in sorted((PKG / "backends").rglob("*.py")) for use in mechanism_uses(p)]
    assert not bad, "a backend uses the numerics' Mechanism: " + "; ".join(bad)


def test_the_mechanism_check_can_fail(tmp_path):
    """The check sees a mechanism passed in, one used through another name, and one read by getattr."""
    cases = {
        "passed.py": "def c_context(scene, model, mech):\n    return mech.n\n",
        "renamed.py": "def c_context(scene, m):\n    return m.initial_state(0.0)\n",
        "getattr.py": "def f(obj):\n    return getattr(obj, 'choose_partition')(0.0, None)\n",
    }
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        assert mechanism_uses(tmp_path / name), name
    (tmp_path / "data.py").write_text("def c_context(scene, model, plan, info=None):\n    return plan.dependent\n")
    assert mechanism_uses(tmp_path / "data.py") == []
