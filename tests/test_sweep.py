"""Parameter sweeps (symgen sweep / symgen.api.sweep): the grid, executors that agree to the
last bit, the Campbell diagram against ``modes`` and closed forms, the quasi-static limit of
the resonance curve, errors and interrupted sweeps."""

from __future__ import annotations

import csv
import json
import math
import multiprocessing
from pathlib import Path

import numpy as np
import pytest

from symgen.api import mechanism, quasi_static_scene
from symgen.api import sweep as api_sweep
from symgen.cli import main
from symgen.errors import SceneError
from symgen.apps import sweep as sw
from symgen.numerics.modes import modes

ROOT = Path(__file__).resolve().parent.parent
SLIDER = str(ROOT / "examples" / "slider_crank.toml")
SHORT = ["simulation.cycles=0.2"]  # 0.2 crank turns per point: a cheap run
LAM, MU = 18246.0, 0.495  # the slider-crank rod's groups (examples/slider_crank.toml)


def _without_cpu(result: sw.SweepResult) -> str:
    cols = {k: v for k, v in result.columns.items() if k != "cpu_s"}
    return sw.table_csv(sw.SweepResult(cols, result.varied, result.output_names, result.structures, result.executor))


# --------------------------------------------------------------------------- specs
def test_vary_specs():
    v = sw.parse_vary("driver.rate=0.5:2:4")
    assert v.key == "driver.rate" and np.allclose(v.values, [0.5, 1.0, 1.5, 2.0]) and not v.log
    v = sw.parse_vary("bodies.rod.lambda=1e4:1e8:5:log")
    assert v.log and np.allclose(v.values, [1e4, 1e5, 1e6, 1e7, 1e8])
    v = sw.parse_vary("bodies.rod.transverse_modes=1,2,3")
    assert v.texts == ("1", "2", "3")  # whole numbers stay integers in the override
    pts = sw.grid([sw.parse_vary("a=1,2"), sw.parse_vary("b=3,4,5")])
    assert pts == [("1", "3"), ("1", "4"), ("1", "5"), ("2", "3"), ("2", "4"), ("2", "5")]


@pytest.mark.parametrize(
    "spec, fragment",
    [
        ("driver.rate", "expected KEY=SPEC"),
        ("driver.rate=1:2", "start:stop:n"),
        ("driver.rate=1:2:0", "whole number >= 1"),
        ("driver.rate=1:2:2.5", "whole number >= 1"),
        ("driver.rate=0:2:3:log", "log grid needs start and stop > 0"),
        ("driver.rate=1:2:3:lin", "start:stop:n"),
        ("driver.rate=1,abc", "'abc' is not a number"),
        ("driver.rate=1,__import__('os')", "is not a number"),
        ("driver.rate=1,nan", "is not a number"),
        ("bodies.nope.lambda=1,2", "no body named 'nope'"),
        ("driver.rate=1;2", "is not a number"),
    ],
)
def test_bad_vary_exits_2_naming_the_option_and_writes_nothing(tmp_path, capsys, spec, fragment):
    out = tmp_path / "s.csv"
    code = main(["sweep", SLIDER, "--vary", spec, "-o", str(out), "--workers", "1"])
    err = capsys.readouterr().err
    assert code == 2
    assert ("--vary" in err or "bodies.nope" in err) and fragment in err, err
    assert "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_same_key_twice_and_bad_options(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["sweep", SLIDER, "--vary", "driver.rate=1,2", "--vary", "driver.rate=3", "-o", str(out)]) == 2
    assert "varied twice" in capsys.readouterr().err
    assert main(["sweep", SLIDER, "--vary", "driver.rate=1,2", "-o", str(tmp_path / "s.txt")]) == 2
    assert "-o" in capsys.readouterr().err
    assert main(["sweep", SLIDER, "--vary", "driver.rate=1,2", "-o", str(out), "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err
    assert (
        main(
            [
                "sweep",
                SLIDER,
                "--vary",
                "driver.rate=1,2",
                "-o",
                str(out),
                "--window",
                "-1",
                "--set",
                "simulation.cycles=0.1",
            ]
        )
        == 2
    )
    assert "--window" in capsys.readouterr().err
    # a value the loader refuses names the point
    assert main(["sweep", SLIDER, "--vary", "bodies.rod.lambda=1e4,-1", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "bodies" in err and "lambda" in err and "sweep point" in err
    assert not list(tmp_path.iterdir())


def test_parquet_table_reads_back_as_the_csv(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    args = ["sweep", SLIDER, "--vary", "driver.rate=0.5,1", "--workers", "1", "--set", "simulation.cycles=0.05"]
    assert main([*args, "-o", str(tmp_path / "s.parquet")]) == 0
    assert main([*args, "-o", str(tmp_path / "s.csv")]) == 0
    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    rows = list(csv.DictReader((tmp_path / "s.csv").open()))
    assert list(table) == list(rows[0])
    assert table["status"] == ["ok", "ok"]
    assert table["peak_eta_mid"] == [float(r["peak_eta_mid"]) for r in rows]


def test_parquet_without_a_writer_is_a_clear_error(tmp_path, capsys, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_parquet(name, *a, **k):
        if name.split(".")[0] in ("pyarrow", "pandas"):
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_parquet)
    assert main(["sweep", SLIDER, "--vary", "driver.rate=1,2", "-o", str(tmp_path / "s.parquet")]) == 2
    err = capsys.readouterr().err
    assert "Parquet" in err and "symgen[parquet]" in err
    assert not list(tmp_path.iterdir())


# --------------------------------------------------------------------------- executors
def test_dask_local_cluster_and_local_processes_give_identical_tables():
    """20 speeds on 2 local processes and on a Dask LocalCluster (2 in-process workers): the
    same table to the last bit (cpu_s apart), in grid order; the Campbell columns equal
    ``modes`` called directly at three points."""
    distributed = pytest.importorskip("distributed")
    varies = [sw.parse_vary("driver.rate=0.5:2:20")]
    local = sw.sweep(SLIDER, varies, SHORT, workers=2, campbell=True)
    assert local.executor == "processes"
    with distributed.LocalCluster(
        processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        dask = sw.sweep(SLIDER, varies, SHORT, scheduler=cluster, campbell=True)
    assert dask.executor == "dask"
    assert len(local) == 20 and all(s == "ok" for s in local.columns["status"])
    assert _without_cpu(local) == _without_cpu(dask)
    assert np.array_equal(local.columns["driver.rate"], np.linspace(0.5, 2.0, 20))
    F = local.frequencies()
    assert F.shape == (20, 2)
    for i in (0, 9, 19):
        rate = float(local.columns["driver.rate"][i])
        md = modes(mechanism(SLIDER, [*SHORT, f"driver.rate={rate!r}"]), tau=0.0, shapes=False)
        assert np.array_equal(F[i], [m.natural_frequency for m in md.modes])
        assert local.columns["speed"][i] == rate


def test_campbell_against_closed_forms_and_plots(tmp_path, capsys):
    """The rod's lowest bending frequency tends to the pinned-pinned beam's pi^2 sqrt(mu) as the
    crank slows (and rises with speed: rotation and axial load stiffen it); its axial one is the
    stress-free basis' (pi/2) sqrt(lambda) at every speed."""
    out = tmp_path / "campbell.csv"
    code = main(
        [
            "sweep",
            SLIDER,
            "--vary",
            "driver.rate=0.05,1,2,4",
            "-o",
            str(out),
            "--workers",
            "1",
            "--campbell",
            str(tmp_path / "c.png"),
            "--plot",
            str(tmp_path / "r.png"),
            "--set",
            "simulation.cycles=0.05",
        ]
    )
    assert code == 0, capsys.readouterr().err
    rows = list(csv.DictReader(out.open()))
    f1 = np.array([float(r["f1"]) for r in rows])
    f2 = np.array([float(r["f2"]) for r in rows])
    assert f1[0] == pytest.approx(math.pi**2 * math.sqrt(MU), rel=2e-3)
    assert np.all(np.diff(f1) > 0)
    assert f2 == pytest.approx(math.pi / 2 * math.sqrt(LAM), rel=1e-4)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["status"] == "complete" and meta["points"] == 4 and len(meta["structures"]) == 1
    for png in ("c.png", "r.png"):
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_resonance_curve_tends_to_the_quasi_static_solution_at_low_speed():
    """With damping (start-up transients gone) the steady peak deflection over the last turn
    tends to the quasi-static solver's peak as the speed falls; the dynamic amplification
    grows like the square of the speed (one-mode forced response, 1 / (1 - (k Omega/omega_1)^2))."""
    over = ["simulation.cycles=1.25", "effects.damping=0.05"]  # transients decay in ~1 tau
    t = api_sweep(SLIDER, {"driver.rate": [0.25, 0.5]}, over, workers=1, window=1.0)
    dev = []
    for k, rate in enumerate((0.25, 0.5)):
        qs = quasi_static_scene(SLIDER, [*over, f"driver.rate={rate}"], output_step=math.pi / 90 / rate)
        q = float(np.abs(qs.outputs[:, qs.output_names.index("eta_mid")]).max())
        dev.append(t["peak_eta_mid"][k] / q - 1)
    assert 0 < dev[0] < 0.01
    assert 0 < dev[1] < 0.03
    assert 3.0 < dev[1] / dev[0] < 5.5


# --------------------------------------------------------------------------- interruption
def test_interrupted_sweep_writes_only_the_partial_table(tmp_path, capsys, monkeypatch):
    real = sw.run_point
    calls = []

    def stop_at_third(task, blobs):
        calls.append(task.index)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(task, blobs)

    monkeypatch.setattr(sw, "run_point", stop_at_third)
    out = tmp_path / "s.csv"
    out.write_text("stale\n")
    code = main(
        [
            "sweep",
            SLIDER,
            "--vary",
            "driver.rate=0.5:2:5",
            "-o",
            str(out),
            "--workers",
            "1",
            "--set",
            "simulation.cycles=0.05",
        ]
    )
    assert code == 130
    assert "partial sweep kept" in capsys.readouterr().err
    assert not out.exists() and not out.with_suffix(".json").exists()
    rows = list(csv.DictReader((tmp_path / "s.partial.csv").open()))
    assert [r["status"] for r in rows] == ["ok", "ok", "not run", "not run", "not run"]
    meta = json.loads((tmp_path / "s.partial.json").read_text())
    assert meta["status"] == "interrupted" and meta["points_done"] == 2


def test_interrupt_stops_the_worker_processes(monkeypatch):
    """Ctrl-C while local processes run: the exception carries the partial result and no
    worker process is left behind."""

    class Bar:
        def __init__(self):
            self.n = 0

        def update(self, k):
            self.n += k
            if self.n == 1:
                raise KeyboardInterrupt

        def close(self):
            pass

    monkeypatch.setattr(sw, "_bar", lambda *a: Bar())
    before = set(multiprocessing.active_children())
    with pytest.raises(KeyboardInterrupt) as info:
        sw.sweep(SLIDER, [sw.parse_vary("driver.rate=0.5:1.5:6")], ["simulation.cycles=0.5"], workers=2)
    partial = info.value.partial
    assert not partial.complete and list(partial.columns["status"]).count("ok") == 1
    assert set(multiprocessing.active_children()) - before == set(), before


def test_api_rejects_bad_values():
    with pytest.raises(SceneError, match="not a finite number"):
        api_sweep(SLIDER, {"driver.rate": [1.0, float("inf")]})
    with pytest.raises(SceneError, match="not a finite number"):
        api_sweep(SLIDER, {"driver.rate": ["1"]})
