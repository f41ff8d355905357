"""A command that fails or is interrupted leaves no complete-looking file of an earlier run
(issue 22): each case first writes a real result, then reruns the command so that it fails."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from symgen.cli import main

ROOT = Path(__file__).resolve().parent.parent
SLIDER = str(ROOT / "examples" / "slider_crank.toml")
SHORT = ["--set", "simulation.cycles=0.05"]


def _sweep(out: Path, *extra: str) -> int:
    return main(["sweep", SLIDER, "--vary", "driver.rate=1,1.5", "-o", str(out), "--workers", "1", *SHORT, *extra])


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """A complete sweep table and its sidecar, written once; each test copies them."""
    d = tmp_path_factory.mktemp("sweep")
    assert _sweep(d / "s.csv") == 0
    assert json.loads((d / "s.json").read_text())["status"] == "complete"
    return {name: (d / name).read_bytes() for name in ("s.csv", "s.json")}


def _plant(tmp_path: Path, files: dict) -> Path:
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    return tmp_path / "s.csv"


@pytest.mark.parametrize("extra", [["--set", "bodies.rod.lambda=-5"], ["--vary", "bodies.nope=1,2"]])
def test_a_failed_sweep_rerun_leaves_no_complete_table(tmp_path, swept, extra):
    out = _plant(tmp_path, swept)
    assert _sweep(out, *extra) == 2
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_a_sweep_interrupted_before_its_first_point_leaves_no_complete_table(tmp_path, swept, monkeypatch):
    from symgen.apps import sweep as sw
    from symgen.errors import Interrupted

    out = _plant(tmp_path, swept)

    def stop(*args, **kwargs):
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(sw, "sweep", stop)
    assert _sweep(out) == 130
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_a_failed_latex_rerun_leaves_no_old_tex(tmp_path):
    tex = tmp_path / "eq.tex"
    tex.write_text("% an earlier run's equations\n")
    assert main(["latex", SLIDER, "-o", str(tex), "--set", "bodies.rod.lambda=-5"]) == 2
    assert not tex.exists()


def test_a_study_with_bad_levels_leaves_no_old_study(tmp_path):
    for name in ("study.csv", "study.md", "study.png"):
        (tmp_path / name).write_text("earlier\n")
    assert main(["study", SLIDER, "-o", str(tmp_path), "--levels", "1+x"]) == 2
    assert not any((tmp_path / n).exists() for n in ("study.csv", "study.md", "study.png"))


def test_an_unrelated_file_and_this_runs_partial_result_are_kept(tmp_path):
    """Only the command's own outputs go; a file the failing run wrote itself stays."""
    from symgen.outputs import stale_removed_on_failure

    mine, other, fresh = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "c.csv"
    for p in (mine, other, fresh):
        p.write_text("old\n")
    with pytest.raises(RuntimeError), stale_removed_on_failure([mine, fresh, tmp_path]):
        fresh.write_text("written by this run, replacing the old one\n")
        os.replace(fresh, fresh)  # (no-op) the content change alone gives it a new identity
        raise RuntimeError("the run failed")
    assert not mine.exists() and other.exists() and fresh.exists() and tmp_path.is_dir()


def test_sigterm_at_the_start_of_simulate_keeps_no_old_result(tmp_path):
    """SIGTERM soon after the start (once the command line is being read): exit 143 and the old
    complete files are gone, never a default-action kill that leaves them."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    for delay in (0.4, 0.55, 0.75):  # 0.1 s and more after main() is called
        out = tmp_path / f"r{delay}.csv"
        out.write_text("tau,x\n0,1\n")
        out.with_suffix(".json").write_text('{"status": "complete"}\n')
        proc = subprocess.Popen(
            [
                sys.executable,
                "-c",
                "import sys, signal; from symgen.cli import main; "
                "print('ready', flush=True); sys.exit(main(sys.argv[1:]))",
                "simulate",
                SLIDER,
                "--set",
                "simulation.cycles=20",  # a run that lasts past the signal (a cached 2 turns took < 0.45 s)
                "-o",
                str(out),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        assert proc.stdout.readline().strip() == "ready"  # symgen.cli imported: main() is next
        time.sleep(delay - 0.3)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 143, (delay, proc.returncode, err)
        assert not out.exists() and not out.with_suffix(".json").exists(), (delay, err)
