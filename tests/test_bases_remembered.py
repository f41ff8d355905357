"""The command line recalls a scene's basis choice from the signed cache (issue 20: a cached
run's start does not compute the bars' spectra again), with the same scene as a fresh choice;
outside ``remembered()`` nothing is recalled, and a record that does not verify is chosen again."""

from __future__ import annotations

from pathlib import Path

import pytest

from symgen.scene import bases, load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "benchmarks" / "validation" / "slider_crank_steel_rest.toml"


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_recalled_choice_is_the_fresh_one(cache_dir, monkeypatch):
    fresh = load_scene(SCENE)
    assert not (cache_dir / "checks").exists()  # outside remembered(): nothing stored
    with bases.remembered():
        first = load_scene(SCENE)
    assert first == fresh
    assert len(list((cache_dir / "checks").iterdir())) == 1

    def refuse(*a, **k):
        raise AssertionError("chosen again")

    monkeypatch.setattr(bases, "_choose_bases", refuse)
    with bases.remembered():
        again = load_scene(SCENE)
    assert again == fresh and again.bases == fresh.bases
    with pytest.raises(AssertionError, match="chosen again"):
        load_scene(SCENE)  # outside remembered(): chosen
    with bases.remembered(), pytest.raises(AssertionError, match="chosen again"):
        load_scene(SCENE, ["simulation.accuracy=0.001"])  # other inputs: another question


def test_tampered_record_is_chosen_again(cache_dir, capsys):
    with bases.remembered():
        fresh = load_scene(SCENE)
    (entry,) = (cache_dir / "checks").iterdir()
    data = bytearray(entry.read_bytes())
    data[-3] ^= 1
    entry.write_bytes(bytes(data))
    with bases.remembered():
        again = load_scene(SCENE)
    assert again == fresh
    assert "checking again" in capsys.readouterr().err


def test_question_is_the_same_in_every_process():
    """The question does not follow the process's string hashes (a set's order)."""
    import os
    import subprocess
    import sys

    code = (
        "from symgen.scene import load_scene; from symgen.scene.bases import _question; "
        f"print(_question((load_scene({str(SCENE)!r}),)))"
    )
    got = {
        subprocess.run(
            [sys.executable, "-c", code],
            env=dict(os.environ, PYTHONHASHSEED=str(seed), PYTHONPATH=str(ROOT)),
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for seed in (1, 2, 3, 4)
    }
    assert len(got) == 1 and "scene.bases" in got.pop()
