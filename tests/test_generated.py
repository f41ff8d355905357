"""generated/ is up to date with the code: regenerate in memory and compare.

Regenerate with:  symgen derive examples/slider_crank.toml examples/four_bar.toml -o generated
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import sympy

from symgen.apps.golden import generated_payload
from symgen.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))
HINT = "generated/ is stale: run `symgen derive examples/*.toml -o generated` and commit the result"


@pytest.mark.parametrize("scene_path", EXAMPLES, ids=lambda p: p.stem)
def test_generated_matches_code(scene_path):
    scene = load_scene(scene_path)
    folder = ROOT / "generated" / scene.name
    assert folder.is_dir(), HINT
    fresh = generated_payload(scene)
    stored = json.loads((folder / "model.json").read_text())
    new = json.loads(fresh["model.json"])
    for key in sorted(set(stored) | set(new)):
        if key in ("fingerprint", "versions"):
            continue
        assert stored.get(key) == new.get(key), f"{key}: {HINT}"
    for fname, rows in new["fingerprint"].items():
        old = stored["fingerprint"][fname]
        for a, b in zip(old, rows):
            np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12, err_msg=f"{fname}: {HINT}")
    if stored["versions"]["sympy"] == sympy.__version__:
        assert (folder / "equations.tex").read_text() == fresh["equations.tex"], f"equations.tex: {HINT}"
    # the emitted C (symgen emit-c): the same files, and the same text under the same SymPy
    c_fresh = {name[2:] for name in fresh if name.startswith("c/")}
    c_stored = {p.name for p in (folder / "c").iterdir()} if (folder / "c").is_dir() else set()
    assert c_fresh and c_stored == c_fresh, f"c/ files {sorted(c_stored)} != {sorted(c_fresh)}: {HINT}"
    if stored["versions"]["sympy"] == sympy.__version__:
        for name in sorted(c_fresh):
            assert (folder / "c" / name).read_text() == fresh["c/" + name], f"c/{name}: {HINT}"


def test_every_example_has_generated_artefacts():
    names = {load_scene(p).name for p in EXAMPLES}
    have = {p.name for p in (ROOT / "generated").iterdir() if p.is_dir()}
    assert names <= have, HINT
