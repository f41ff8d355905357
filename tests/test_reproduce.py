"""``symgen reproduce --quick`` writes every figure of the paper it can (G.1-G.10, and G.11-G.12
when the inverted slider-crank example exists) and a README that names each one."""

from __future__ import annotations

from pathlib import Path

import pytest

from symgen.cli import main

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow  # ~14 s: every figure's runs; the figures' physics is tested elsewhere
def test_reproduce_quick_writes_every_figure(tmp_path):
    out = tmp_path / "figures"
    assert main(["reproduce", "-o", str(out), "--quick"]) == 0
    expected = 12 if (ROOT / "examples" / "inverted_slider_crank.toml").exists() else 10
    pngs = sorted(out.glob("G*.png"))
    assert [p.name[:3] for p in pngs] == [f"G{k:02d}" for k in range(1, expected + 1)]
    for p in pngs:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 20_000, p.name
    readme = (out / "README.md").read_text()
    for p in pngs:
        assert p.name in readme
    for section in ("6.1 Slider-crank", "6.2 Four-bar"):
        assert section in readme
    assert "Measured in this run" in readme and "--quick" in readme
    # the README states the function counts of the scenes it ran (they were once hard-coded, stale)
    assert "crank 4 axial + 4 transverse, coupler 4 axial + 4 transverse, rocker 4 axial + 4 transverse" in readme
    assert "rod 3 axial + 4 transverse functions" in readme


def test_figure_texts_state_the_scenes_function_counts():
    from symgen.apps.reproduce import ACCURATE_SC, FIGURE_TEXT, _functions
    from symgen.scene import load_scene

    fb = load_scene(str(ROOT / "examples" / "four_bar.toml"))
    text = FIGURE_TEXT["four_bar"].format(functions=_functions(fb))
    counts = {b.name: (b.axial_modes, b.transverse_modes) for b in fb.bodies}
    for name, (na, nt) in counts.items():
        assert f"{name} {na} axial + {nt} transverse" in text
    sc = load_scene(str(ROOT / "examples" / "slider_crank.toml"), ACCURATE_SC)
    assert "rod 3 axial + 4 transverse functions" in FIGURE_TEXT["slider_crank"].format(functions=_functions(sc))
