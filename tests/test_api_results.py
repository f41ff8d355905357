"""``symgen.api`` writes a run's files as the command line does (one writer,
``symgen.numerics.results.write_run``): the same CSV, byte for byte, and the same JSON sidecar
but for the wall-clock times each process measures for itself."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from symgen import api
from symgen.cli import main
from symgen.errors import SimulationError
from tests.test_cli import FOUR_BAR_TOGGLE

ROOT = Path(__file__).resolve().parent.parent
SLIDER = str(ROOT / "examples" / "slider_crank.toml")
FOUR_BAR = str(ROOT / "examples" / "four_bar.toml")

#: The sidecar keys that differ between two runs of the same scene, model from the cache both
#: times: each is a wall-clock time measured by the process that ran (timings.build_s: the
#: model's load from the cache and the Mechanism's set-up; timings.simulate_s: the integration,
#: for quasi-static the solve; timings.solve_s: the quasi-static solve). Every other key is equal
#: (derive_s is 0.0 and cached_model_derive_s the cache entry's, the same for both).
TIMED = {"simulate": {"build_s", "simulate_s"}, "quasistatic": {"build_s", "simulate_s", "solve_s"}}


def _same_files(cli_csv: Path, api_csv: Path, command: str) -> None:
    assert cli_csv.read_bytes() == api_csv.read_bytes()
    a, b = (json.loads(p.with_suffix(".json").read_text()) for p in (cli_csv, api_csv))
    assert list(a) == list(b)  # same keys, same order
    timings_a, timings_b = a.pop("timings"), b.pop("timings")
    assert a == b
    assert list(timings_a) == list(timings_b)
    differ = {k for k in timings_a if timings_a[k] != timings_b[k]}
    assert differ <= TIMED[command], differ
    assert timings_a["derive_cached"] and timings_b["derive_cached"]
    assert {k: v for k, v in timings_a.items() if k not in TIMED[command]} == {
        k: v for k, v in timings_b.items() if k not in TIMED[command]
    }


@pytest.mark.parametrize(
    "scene, overrides, extra",
    [
        (SLIDER, ["simulation.cycles=0.25"], ["--states"]),
        (FOUR_BAR, ["simulation.cycles=0.1"], ["--units", "dimensionless"]),
        (FOUR_BAR, ["simulation.cycles=0.1"], []),  # SI results: t in s, N, N m
    ],
    ids=["slider-states", "four-bar-dimensionless", "four-bar-SI"],
)
def test_simulate_scene_writes_the_files_of_symgen_simulate(tmp_path, capsys, scene, overrides, extra):
    api.mechanism(scene, overrides)  # the model in the cache for both runs
    cli_csv, api_csv = tmp_path / "cli" / "run.csv", tmp_path / "api" / "run.csv"
    sets = [a for o in overrides for a in ("--set", o)]
    assert main(["simulate", scene, "-o", str(cli_csv), "--plot", str(cli_csv.with_suffix(".svg")), *sets, *extra]) == 0
    units = extra[1] if "--units" in extra else None
    result = api.simulate_scene(
        scene, overrides, out=api_csv, plot=api_csv.with_suffix(".svg"), states="--states" in extra, units=units
    )
    assert result.complete
    _same_files(cli_csv, api_csv, "simulate")
    assert api_csv.with_suffix(".svg").stat().st_size > 10_000
    assert sorted(p.name for p in api_csv.parent.iterdir()) == sorted(p.name for p in cli_csv.parent.iterdir())


def test_quasi_static_scene_writes_the_files_of_symgen_quasistatic(tmp_path, capsys):
    api.mechanism(SLIDER)
    cli_csv, api_csv = tmp_path / "cli" / "qs.csv", tmp_path / "api" / "qs.csv"
    assert main(["quasistatic", SLIDER, "-o", str(cli_csv), "--cycles", "0.1", "--states"]) == 0
    api.quasi_static_scene(SLIDER, out=api_csv, cycles=0.1, states=True)
    _same_files(cli_csv, api_csv, "quasistatic")
    side = json.loads(api_csv.with_suffix(".json").read_text())
    assert side["analysis"] == "quasi-static response (18)-(20)" and "states" in side


def test_a_run_that_stops_writes_the_same_partial_files(tmp_path, capsys):
    """The toggle four-bar meets its singular position: both write OUT.partial.csv/.json (status
    "partial") and no complete files; the API raises the failure with the partial result."""
    scene = tmp_path / "toggle.toml"
    scene.write_text(FOUR_BAR_TOGGLE)
    api.mechanism(scene)
    cli_csv, api_csv = tmp_path / "cli" / "t.csv", tmp_path / "api" / "t.csv"
    assert main(["simulate", str(scene), "-o", str(cli_csv)]) == 2
    with pytest.raises(SimulationError, match="singular position") as info:
        api.simulate_scene(scene, out=api_csv)
    assert not info.value.partial.complete and len(info.value.partial.tau) > 50
    assert sorted(p.name for p in api_csv.parent.iterdir()) == ["t.partial.csv", "t.partial.json"]
    assert sorted(p.name for p in cli_csv.parent.iterdir()) == ["t.partial.csv", "t.partial.json"]
    _same_files(cli_csv.with_name("t.partial.csv"), api_csv.with_name("t.partial.csv"), "simulate")
    assert json.loads(api_csv.with_name("t.partial.json").read_text())["status"] == "partial"


def test_files_of_a_run_are_checked_before_any_work_and_kwargs_that_the_sidecar_would_not_record_refused(tmp_path):
    from symgen.errors import SceneError

    with pytest.raises(SceneError, match="should end in .csv"):
        api.simulate_scene(tmp_path / "no-such-scene.toml", out=tmp_path / "run.txt")
    with pytest.raises(ValueError, match="rtol"):
        api.simulate_scene(SLIDER, out=tmp_path / "run.csv", rtol=1e-9)
    with pytest.raises(ValueError, match="out="):
        api.simulate_scene(SLIDER, plot=tmp_path / "run.png")
    assert list(tmp_path.iterdir()) == []
