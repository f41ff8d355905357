"""The command line as a user meets it: results files, plots, errors (exit 2, no traceback,
no output file)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from symgen.cli import main
from tests.scene.test_scene_bad_files import BAD, BAD_CASES

ROOT = Path(__file__).resolve().parent.parent
SLIDER = str(ROOT / "examples" / "slider_crank.toml")


def test_simulate_writes_csv_json_and_plot(tmp_path, capsys):
    out = tmp_path / "res" / "sc.csv"
    png = tmp_path / "res" / "sc.png"
    code = main(["simulate", SLIDER, "-o", str(out), "--plot", str(png), "--set", "simulation.cycles=0.5"])
    assert code == 0
    lines = out.read_text().splitlines()
    assert lines[0] == "tau,eta_mid,eps_ax,torque,closure"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (181, 5)
    assert data[-1, 0] == pytest.approx(math.pi)
    meta = json.loads(out.with_suffix(".json").read_text())
    for key in ("scene_hash", "groups", "effects", "modes", "solver", "timings", "closure_residual_max"):
        assert key in meta
    assert meta["solver"]["name"] == "idas" and meta["solver"]["steps"] > 0
    assert set(meta["timings"]) >= {"derive_s", "build_s", "simulate_s"}
    assert meta["closure_residual_max"] <= 1e-10
    assert meta["groups"]["rod"]["lambda"] == 18246.0
    assert meta["modes"]["rod"] == {
        "axial": 1,
        "transverse": 1,
        "axial_shapes": "stress-free",
        "transverse_shapes": "modes",
    }
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("stem,key,fragment", BAD_CASES)
def test_bad_scene_exit_2_with_message_and_no_output(tmp_path, capsys, stem, key, fragment):
    bad = BAD / f"{stem}.toml"
    out = tmp_path / "out.csv"
    code = main(["simulate", str(bad), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert str(bad) in err and fragment in err
    if key:
        assert key in err
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_bad_override_and_bad_output_name(tmp_path, capsys):
    out = tmp_path / "o.csv"
    assert main(["simulate", SLIDER, "-o", str(out), "--set", "bodies.rood.length=2"]) == 2
    assert "no body named 'rood'" in capsys.readouterr().err
    assert main(["simulate", SLIDER, "-o", str(tmp_path / "o.txt")]) == 2
    assert "should end in .csv" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_real_process_exit_code_and_stderr(tmp_path):
    bad = BAD / "slot_joint.toml"
    proc = subprocess.run(
        [sys.executable, "-m", "symgen.cli", "simulate", str(bad), "-o", str(tmp_path / "x.csv")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode == 2
    assert "a slot joins a point of one bar to a second (guide) bar" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "x.csv").exists()


FOUR_BAR_TOGGLE = """
[scene]
name = "toggle"
[[bodies]]
name = "crank"
length = 1.5
rigid = true
[[bodies]]
name = "coupler"
length = 1.0
rigid = true
[[bodies]]
name = "rocker"
length = 1.0
rigid = true
[[joints]]
name = "O2"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "A"
kind = "pin"
bodies = ["crank", "coupler"]
at = [1.0, 0.0]
[[joints]]
name = "B"
kind = "pin"
bodies = ["coupler", "rocker"]
at = [1.0, 1.0]
[[joints]]
name = "O4"
kind = "pin"
bodies = ["ground", "rocker"]
at = [[2.0, 0.0], 0.0]
[driver]
kind = "angle"
body = "crank"
initial = 0.5
rate = 1.0
[initial]
guess = { coupler = 0.24, rocker = 1.28 }
[outputs]
rocker = { kind = "angle", body = "rocker" }
[simulation]
t_end = 6.0
output_step = 0.01
"""


def test_singular_position_stops_with_tau_and_loop_and_keeps_partial(tmp_path, capsys):
    """A non-Grashof four-bar (ground 2, input 1.5, coupler 1, rocker 1: s + l = 3 > p + q = 2.5)
    driven at constant rate from 0.5 rad: coupler and rocker align when |A - O4| = 2, i.e.
    cos(theta) = 0.375, theta = 1.1864 (tau = 0.686). The run must stop there, name tau and the
    loop, and keep what was computed in a file marked partial."""
    scene = tmp_path / "toggle.toml"
    scene.write_text(FOUR_BAR_TOGGLE)
    out = tmp_path / "t.csv"
    code = main(["simulate", str(scene), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert "tau =" in err and "loop closed by joint 'B'" in err
    assert not out.exists()
    partial = tmp_path / "t.partial.csv"
    assert partial.exists()
    meta = json.loads((tmp_path / "t.partial.json").read_text())
    assert meta["status"] == "partial" and "tau" in meta["failure"]
    tau_stop = float(err.split("tau =")[1].split(":")[0])
    assert tau_stop == pytest.approx(math.acos(0.375) - 0.5, abs=0.02)
    rows = np.loadtxt(partial, delimiter=",", skiprows=1)
    assert rows[-1, 0] <= tau_stop + 1e-9 and len(rows) > 50


def test_sidecar_derive_time_is_this_runs_not_the_caches(tmp_path, monkeypatch, capsys):
    """A model from the cache reports derive_s = 0 for this run and the cached derivation's own
    time apart (it used to report the old derivation time as if it had just happened)."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    metas = []
    for k in range(2):
        out = tmp_path / f"run{k}.csv"
        assert main(["simulate", SLIDER, "-o", str(out), "--set", "simulation.cycles=0.05"]) == 0
        metas.append(json.loads(out.with_suffix(".json").read_text())["timings"])
    first, second = metas
    assert first["derive_cached"] is False and first["derive_s"] > 0 and first["cached_model_derive_s"] is None
    assert second["derive_cached"] is True and second["derive_s"] == 0.0
    assert second["cached_model_derive_s"] == pytest.approx(first["derive_s"])
    assert "model loaded from cache" in capsys.readouterr().out


def test_verbose_says_whether_the_model_was_derived_or_loaded(tmp_path, capsys, monkeypatch):
    """-v said "deriving" also when the model came from the cache."""
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    args = ["simulate", SLIDER, "-o", str(tmp_path / "a.csv"), "--set", "simulation.cycles=0.05", "-v"]
    assert main(args) == 0
    first = capsys.readouterr().err
    assert main(args) == 0
    second = capsys.readouterr().err
    assert "model derived in" in first and "model loaded from the cache" in second, (first, second)


# ----------------------------------------------------------------------------- one command's parser
def _parsers(ap) -> dict:
    import argparse

    (sub,) = (a for a in ap._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "s.toml", "-o", "o.csv", "--solver", "c", "--estimate", "off", "--set", "a=1", "--states"],
        ["--debug", "check", "s.toml"],
        ["cache", "clear"],
        ["sweep", "s.toml", "-o", "o.csv", "--vary", "bodies.crank.lambda=1e3,1e4"],
        ["emit-c", "s.toml", "-o", "out"],
    ],
)
def test_the_asked_commands_parser_alone_parses_as_the_full_one(argv):
    """``symgen CMD ...`` builds only CMD's parser (the others not made: ~1 ms each of a cached
    run's process) and parses ``argv`` as the full parser does."""
    from symgen.cli import COMMANDS, build_parser

    full, lean = build_parser(), build_parser(argv)
    assert tuple(_parsers(full)) == COMMANDS  # the list the lean parser's usage names
    cmd = next(w for w in argv if w != "--debug")
    assert list(_parsers(lean)) == [cmd]
    assert vars(lean.parse_args(argv)) == vars(full.parse_args(argv))
    assert lean.format_usage() == full.format_usage()


@pytest.mark.parametrize("argv", [[], ["--help"], ["--version"], ["bogus"], ["--help", "simulate"], ["-x", "check"]])
def test_anything_but_a_command_first_gets_the_full_parser(argv):
    from symgen.cli import COMMANDS, build_parser

    assert tuple(_parsers(build_parser(argv))) == COMMANDS
