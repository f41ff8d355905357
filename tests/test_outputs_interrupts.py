"""Outputs and interrupts (issue 9): output paths checked before any work, atomic writes in
the order CSV -> JSON -> plot, stale results removed when a run fails, and SIGINT/SIGTERM
stopping a run within two seconds (exit 130/143) with its partial result marked
"interrupted" -- the last ones with real processes and real signals."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import symgen.apps.effects
import symgen.apps.reproduce
import symgen.apps.study
import symgen.scene
from symgen.cli import main
from symgen.errors import Interrupted
from symgen.outputs import OutputError, atomic_path, atomic_write
from symgen.numerics import interrupt
from tests.test_cli import FOUR_BAR_TOGGLE

ROOT = Path(__file__).resolve().parent.parent
SLIDER = str(ROOT / "examples" / "slider_crank.toml")


def _complete(out: Path) -> None:
    """Files of an earlier complete run named like ``out``."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("tau,x\n0.0,1.0\n")
    out.with_suffix(".json").write_text(json.dumps({"status": "complete"}))


def _no_temp_files(folder: Path) -> None:
    assert [p.name for p in folder.rglob(".*")] == []


# --------------------------------------------------------------------------- stale and partial results
def test_failed_run_removes_stale_complete_results_and_keeps_partial(tmp_path, capsys):
    scene = tmp_path / "toggle.toml"
    scene.write_text(FOUR_BAR_TOGGLE)
    out, png = tmp_path / "res" / "t.csv", tmp_path / "res" / "t.png"
    _complete(out)
    png.write_bytes(b"\x89PNG old")
    code = main(["simulate", str(scene), "-o", str(out), "--plot", str(png)])
    assert code == 2 and "singular position" in capsys.readouterr().err
    assert not out.exists() and not out.with_suffix(".json").exists() and not png.exists()
    meta = json.loads((tmp_path / "res" / "t.partial.json").read_text())
    assert meta["status"] == "partial" and "tau" in meta["failure"]
    rows = (tmp_path / "res" / "t.partial.csv").read_text().splitlines()
    assert rows[0] == "tau,rocker" and len(rows) > 50
    assert (tmp_path / "res" / "t.partial.png").read_bytes()[:4] == b"\x89PNG"
    _no_temp_files(tmp_path / "res")


def test_successful_run_removes_stale_partials(tmp_path, capsys):
    out = tmp_path / "sc.csv"
    stale = [tmp_path / "sc.partial.csv", tmp_path / "sc.partial.json"]
    for p in stale:
        p.write_text("old")
    assert main(["simulate", SLIDER, "-o", str(out), "--set", "simulation.cycles=0.05"]) == 0
    assert json.loads(out.with_suffix(".json").read_text())["status"] == "complete"
    assert len(out.read_text().splitlines()) == 20  # header + tau = 0, 1 deg, ..., 18 deg
    assert not any(p.exists() for p in stale)
    _no_temp_files(tmp_path)


def test_csv_write_failure_leaves_no_complete_json(tmp_path, capsys, monkeypatch):
    """The disk fills while the CSV is written: exit 2 naming the file, no JSON that says
    "complete" (neither a new one nor the earlier run's), no CSV, no temporary file."""
    import symgen.numerics.results as results

    real = results.atomic_write

    def failing(path, data):
        if Path(path).suffix == ".csv":
            raise OutputError(Path(path), OSError(28, "No space left on device"))
        return real(path, data)

    monkeypatch.setattr(results, "atomic_write", failing)
    out = tmp_path / "sc.csv"
    _complete(out)
    code = main(["simulate", SLIDER, "-o", str(out), "--set", "simulation.cycles=0.05"])
    err = capsys.readouterr().err
    assert code == 2 and "No space left on device" in err and str(out) in err
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_keeps_the_old_file_when_the_writer_fails(tmp_path):
    target = tmp_path / "a.png"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"half a fi")
            raise RuntimeError("savefig failed")
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["a.png"]
    atomic_write(target, "new")
    assert target.read_text() == "new" and oct(target.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


# --------------------------------------------------------------------------- paths checked before any work
@pytest.fixture
def no_work(monkeypatch):
    """Loading a scene is the start of the work: it must not happen."""

    def boom(*a, **k):
        raise AssertionError("the scene was loaded before the output path was checked")

    monkeypatch.setattr(symgen.scene, "load_scene", boom)
    monkeypatch.setattr("symgen.apps.study.load_scene", boom)
    monkeypatch.setattr("symgen.apps.effects.load_scene", boom)
    monkeypatch.setattr("symgen.apps.reproduce.load_scene", boom)


def test_plot_onto_a_folder_exits_2_up_front(tmp_path, capsys, no_work):
    folder = tmp_path / "plots"
    folder.mkdir()
    code = main(["simulate", SLIDER, "-o", str(tmp_path / "r.csv"), "--plot", str(folder)])
    err = capsys.readouterr().err
    assert code == 2 and "--plot" in err and "should end in .png" in err
    folder2 = tmp_path / "p.png"
    folder2.mkdir()
    code = main(["quasistatic", SLIDER, "-o", str(tmp_path / "r.csv"), "--plot", str(folder2)])
    err = capsys.readouterr().err
    assert code == 2 and "--plot" in err and "is a folder" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png", "plots"]
    assert list(folder.iterdir()) == [] and list(folder2.iterdir()) == []


def _commands(base: Path) -> list[list[str]]:
    return [
        ["simulate", SLIDER, "-o", str(base / "r.csv")],
        ["quasistatic", SLIDER, "-o", str(base / "r.csv")],
        ["modes", SLIDER, "-o", str(base / "m.json")],
        ["study", SLIDER, "-o", str(base / "study")],
        ["effects", SLIDER, "--auto", "1e-3", "-o", str(base / "s.toml")],
        ["reproduce", "-o", str(base / "figs")],
        ["latex", SLIDER, "-o", str(base / "e.tex")],
        ["derive", SLIDER, "-o", str(base / "gen")],
        ["emit-c", SLIDER, "-o", str(base / "c")],
        ["emit-fmu", SLIDER, "-o", str(base / "m.fmu")],
    ]


@pytest.mark.parametrize("k", range(10), ids=[c[0] for c in _commands(Path("x"))])
def test_unwritable_output_exits_2_before_any_work(tmp_path, capsys, no_work, k):
    """Every command that writes: an output under a regular file (cannot be created, also
    as root) is exit 2 naming -o, before the scene is even loaded; nothing is written."""
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    cmd = _commands(blocker / "sub")[k]
    code = main(cmd)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "command line: -o" in err and "is not a folder" in err and "Traceback" not in err
    assert [p.name for p in tmp_path.iterdir()] == ["file"] and blocker.read_text() == "not a folder"


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root ignores folder permissions")
def test_read_only_folder_exits_2_before_any_work(tmp_path, capsys, no_work):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code = main(["simulate", SLIDER, "-o", str(ro / "deep" / "r.csv")])
        err = capsys.readouterr().err
        assert code == 2 and "is not writable" in err
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o755)


# --------------------------------------------------------------------------- the interrupt mechanism
def test_handler_raises_interrupted_and_is_restored():
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Interrupted) as info:
        with interrupt.handling():
            assert interrupt.requested() is None
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(10**7):  # pure Python: the handler raises within a bytecode
                pass
    assert info.value.exit_code == 143 and "SIGTERM" in str(info.value)
    assert signal.getsignal(signal.SIGTERM) is before and interrupt.requested() is None
    # a failure while a signal is pending is the interrupt; without one it is itself
    err = RuntimeError('IDASolve returned "IDA_RES_FAIL"')
    assert interrupt.interrupted(err) is err
    with interrupt.handling():
        interrupt._pending.append(signal.SIGINT)
        stop = interrupt.interrupted(err, tau=1.5)
        assert isinstance(stop, Interrupted) and stop.exit_code == 130 and "tau = 1.5" in str(stop)
        with pytest.raises(Interrupted):
            interrupt.check()


def test_casadi_reports_of_the_signal_are_filtered_from_stderr():
    """Once a signal is pending, CasADi's report of it inside an IDAS callback is dropped, as
    written (pieces captured from real runs): the residual callback, and -- 1 signal in about
    150 -- the linear solver setup ("psetup failed: ", "..., the linear solver setup failed
    unrecoverably."), which once reached stderr in the simulate SIGTERM test. Other text passes."""
    import io

    reports = [
        [
            "res failed: ",
            "KeyboardInterrupt",
            "\n",
            "At t = 2.01843, the residual function failed unrecoverably.",
            "\n",
        ],
        [
            "psetup failed: ",
            "KeyboardInterrupt",
            "\n",
            "At t = 1.7908, the linear solver setup failed unrecoverably.",
            "\n",
        ],
    ]
    for pieces in reports:
        sink = io.StringIO()
        noise = interrupt._SolverNoiseFilter(sink)
        noise.write("symgen: integrating\n")
        interrupt._pending.append(signal.SIGTERM)
        try:
            for piece in pieces:
                noise.write(piece)
            noise.write("symgen: interrupted by SIGTERM at tau = 0")
            noise.write("\n")
        finally:
            interrupt._pending.clear()
        assert sink.getvalue() == "symgen: integrating\nsymgen: interrupted by SIGTERM at tau = 0\n"


def test_effects_measure_interrupted_keeps_the_rows_measured(monkeypatch):
    from symgen.apps import effects

    calls = []

    class Runs:
        ref = {"steps": 10, "simulate_s": 0.1}
        t_end, step, compared = 1.0, 0.1, ["eta_mid"]

        def run(self, extra):
            calls.append(extra)
            if len(calls) == 2:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)  # the handler raises during the sleep
            return {"status": "ok", "steps": 5, "simulate_s": 0.05, "error": 2e-5, "worst": "eta_mid"}

    with pytest.raises(Interrupted) as info:
        with interrupt.handling():
            effects.measure_effects(SLIDER, runs=Runs())
    report = info.value.partial
    assert len(calls) == 2 and report.rows[0].status == "ok" and report.rows[0].error == 2e-5
    assert all(r.status == "not measured (interrupted)" for r in report.rows[1:])
    text = effects.table(report)
    assert "PARTIAL: interrupted by SIGINT" in text and "not measured (interrupted)" in text


# --------------------------------------------------------------------------- the signal inside a C extension
# The handler raises ``Interrupted`` wherever the main thread is. Inside CasADi's or NumPy's C code
# (numpy calling ``DM.__array__``, a SWIG wrapper running Python code) it does not always come out
# as itself: CPython reports a C function that returns a result with the exception set as
# ``SystemError: <function DM.__array__ ...> returned a result with an exception set`` (the
# ``Interrupted`` its cause), CasADi's ``__array__`` can turn a failed ``full()`` into a TypeError,
# and CasADi's own interrupt check raises a bare KeyboardInterrupt. A real SIGINT sent to
# ``symgen quasistatic`` came out as the SystemError in 2.5 to 10 % of runs (9 of 120 alone at 0 to
# 0.3 s after the first position, 6 of 60 under load, 1 of 40 alone and 2 of 40 under load at the
# test's 1.5 s; the quasi-static loop is many small CasADi calls, each converted by numpy): the
# loop caught only SimulationError, Interrupted and RuntimeError, so the run stopped without its
# tau and without its partial result.
# These tests put the signal exactly there, deterministically.
def _dm_array_error(stop):
    return SystemError("<function DM.__array__ at 0x7f0000000000> returned a result with an exception set")


def _casadi_type_error(stop):
    return TypeError("Implicit conversion of symbolic CasADi type to numeric matrix not supported.")


def _casadi_keyboard_interrupt(stop):
    return KeyboardInterrupt()


SURFACES = [_dm_array_error, _casadi_type_error, _casadi_keyboard_interrupt]
SURFACE_IDS = ["SystemError", "TypeError", "KeyboardInterrupt"]


def _signal_inside(real, at: int, surfaces=None):
    """``real`` wrapped: its ``at``-th call sends SIGINT to this process; the handler's
    ``Interrupted`` comes out as ``surfaces(stop)`` (chained as CPython chains it), or as itself."""
    calls = []

    def wrapped(*a, **k):
        calls.append(None)
        if len(calls) == at:
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)  # the handler raises during the sleep
            except Interrupted as stop:
                if surfaces is None:
                    raise
                raise surfaces(stop) from stop
            pytest.fail("the SIGINT handler did not raise")
        return real(*a, **k)

    return wrapped


@pytest.fixture(scope="module")
def slider_mech():
    from symgen.backends.casadi.pipeline import compile_scene
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene import load_scene

    scene = load_scene(SLIDER)
    return Mechanism(compile_scene(scene), scene)


@pytest.mark.parametrize("surfaces", SURFACES, ids=SURFACE_IDS)
def test_quasi_static_keeps_its_positions_when_casadi_reports_the_signal_as_another_error(
    slider_mech, monkeypatch, surfaces
):
    from symgen.numerics.quasistatic import QuasiStaticSystem, cycle_times, quasi_static

    taus = cycle_times(slider_mech, cycles=0.05)
    monkeypatch.setattr(QuasiStaticSystem, "state", _signal_inside(QuasiStaticSystem.state, 4, surfaces))
    with pytest.raises(KeyboardInterrupt) as info:  # (not a bare one: an Interrupted)
        with interrupt.handling():
            quasi_static(slider_mech, cycles=0.05)
    stop = info.value
    assert isinstance(stop, Interrupted), repr(stop)
    assert stop.exit_code == 130 and stop.tau == taus[2] and f"at tau = {taus[2]:.6g}" in str(stop)
    part = stop.partial
    assert part is not None and not part.complete and list(part.tau) == list(taus[:3])
    assert part.failure == str(stop) and len(part.reports) == 3 and part.outputs.shape[0] == 3


@pytest.mark.parametrize("surfaces", SURFACES, ids=SURFACE_IDS)
def test_quasistatic_cli_interrupted_inside_casadi_writes_the_partial_result(tmp_path, capsys, monkeypatch, surfaces):
    """The symptom of the full-suite failures: exit 130 but "interrupted by SIGINT" only, no tau
    and no OUT.partial.* -- here with the signal at the fourth position, every time."""
    from symgen.numerics.quasistatic import QuasiStaticSystem

    out = tmp_path / "res" / "qs.csv"
    _complete(out)
    monkeypatch.setattr(QuasiStaticSystem, "state", _signal_inside(QuasiStaticSystem.state, 4, surfaces))
    code = main(["quasistatic", SLIDER, "-o", str(out), "--cycles", "0.05"])
    err = capsys.readouterr().err
    assert code == 130, err
    assert "symgen: interrupted by SIGINT at tau = 0.0349066" in err and "Traceback" not in err
    assert not out.exists() and not out.with_suffix(".json").exists()
    meta = json.loads((out.parent / "qs.partial.json").read_text())
    assert meta["status"] == "interrupted" and meta["failure"] == "interrupted by SIGINT at tau = 0.0349066"
    rows = (out.parent / "qs.partial.csv").read_text().splitlines()
    assert rows[0].startswith("tau,eta_mid") and len(rows) == 4
    _no_temp_files(out.parent)


@pytest.mark.parametrize("where", ["compile", "initial state", "system (20)", "first position"])
def test_quasistatic_cli_interrupted_before_any_position_says_so(tmp_path, capsys, monkeypatch, where):
    """A signal before the first position is solved (model loading, the start, building (20), the
    first position itself): exit 130, a message saying that no position was solved, and nothing
    written -- no OUT.partial.* with zero rows, and the earlier complete results gone."""
    import symgen.backends.casadi.pipeline
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.quasistatic import QuasiStaticSystem

    target, name = {
        "compile": (symgen.backends.casadi.pipeline, "compile_scene"),
        "initial state": (Mechanism, "initial_state"),
        "system (20)": (QuasiStaticSystem, "__init__"),
        "first position": (QuasiStaticSystem, "state"),
    }[where]
    monkeypatch.setattr(target, name, _signal_inside(getattr(target, name), 1, _dm_array_error))
    out = tmp_path / "res" / "qs.csv"
    _complete(out)
    code = main(["quasistatic", SLIDER, "-o", str(out), "--cycles", "0.05"])
    err = capsys.readouterr().err
    assert code == 130, err
    assert "symgen: interrupted by SIGINT before the first input position was solved (nothing to keep)" in err
    assert "Traceback" not in err and "at tau" not in err
    assert list(out.parent.iterdir()) == []


def test_simulate_cli_interrupted_inside_casadi_writes_the_partial_result(tmp_path, capsys, monkeypatch):
    """The dynamic run between IDAS chunks (recording the outputs: NumPy converting CasADi's
    results) has the same exposure; its loop caught KeyboardInterrupt but not the SystemError."""
    from symgen.numerics import checks

    out = tmp_path / "sim.csv"
    monkeypatch.setattr(checks, "beyond_range", _signal_inside(checks.beyond_range, 3, _dm_array_error))
    code = main(["simulate", SLIDER, "-o", str(out), "--set", "simulation.cycles=1"])
    err = capsys.readouterr().err
    assert code == 130, err
    assert "symgen: interrupted by SIGINT at tau =" in err and "Traceback" not in err
    meta = json.loads((tmp_path / "sim.partial.json").read_text())
    assert meta["status"] == "interrupted" and meta["failure"].startswith("interrupted by SIGINT at tau =")
    rows = (tmp_path / "sim.partial.csv").read_text().splitlines()
    assert len(rows) > 2 and float(rows[-1].split(",")[0]) > 0


# --------------------------------------------------------------------------- real processes, real signals
def _env(tmp_path: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env["SYMGEN_CACHE_DIR"] = str(tmp_path / "cache")
    return env


def _interrupt(cmd: list[str], env: dict, marker: str, stream: str, sig: int, wait: float = 1.5):
    """Start ``symgen cmd``, wait for ``marker`` on ``stream``, then ``wait`` s, send ``sig``;
    return (exit code, seconds from the signal to the exit, stdout, stderr)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "symgen.cli", *cmd],
        cwd=ROOT,
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    seen = []
    try:
        for line in getattr(proc, stream):
            seen.append(line)
            if marker in line:
                break
        else:
            pytest.fail(f"no {marker!r} line; got {''.join(seen)}")
        time.sleep(wait)
        assert proc.poll() is None, "the run ended before the signal"
        proc.send_signal(sig)
        t0 = time.monotonic()
        out, err = proc.communicate(timeout=60)
        return proc.returncode, time.monotonic() - t0, "".join(seen) + out, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.fixture(scope="module")
def warm(tmp_path_factory):
    """A model cache with the slider-crank in it, and a complete short run's results."""
    tmp = tmp_path_factory.mktemp("warm")
    env = _env(tmp)
    out = tmp / "res" / "sc.csv"
    proc = subprocess.run(
        [sys.executable, "-m", "symgen.cli", "simulate", SLIDER, "-o", str(out), "--set", "simulation.cycles=0.05"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return tmp, env


@pytest.mark.parametrize(
    "command,sig,code",
    [
        ("simulate", signal.SIGINT, 130),
        ("simulate", signal.SIGTERM, 143),
        # quasistatic failed in 3 of 5 full-suite runs (exit 130, no tau, no partial file): the signal
        # came out of numpy/CasADi as a SystemError the loop did not catch -- see the tests above
        ("quasistatic", signal.SIGINT, 130),
    ],
)
def test_signal_stops_a_run_at_once_with_a_partial_result_marked_interrupted(warm, command, sig, code):
    """A long run (hundreds of crank turns) is stopped within 2 s of the signal -- not blamed
    on IDAS, not retried step by step -- and keeps what it computed as OUT.partial.*, status
    "interrupted"; the complete results of an earlier run of the same name are gone."""
    tmp, env = warm
    out = tmp / "res" / f"{command}_{sig}.csv"
    _complete(out)
    long = ["--set", "simulation.cycles=500"] if command == "simulate" else ["--cycles", "5000"]
    rc, dt, _, err = _interrupt(
        [command, SLIDER, "-o", str(out), "-v", *long],
        env,
        "integrating" if command == "simulate" else "first position solved",
        "stderr",
        sig,
    )
    assert rc == code, err
    assert dt < 2.0, f"took {dt:.2f} s to stop"
    name = signal.Signals(sig).name
    assert f"interrupted by {name} at tau =" in err and "IDAS failed" not in err and "Traceback" not in err
    assert "res failed" not in err and "failed unrecoverably" not in err  # CasADi's noise, filtered
    assert not out.exists() and not out.with_suffix(".json").exists()
    meta = json.loads(out.with_name(out.stem + ".partial.json").read_text())
    assert meta["status"] == "interrupted" and meta["failure"].startswith(f"interrupted by {name}")
    rows = out.with_name(out.stem + ".partial.csv").read_text().splitlines()
    assert rows[0].startswith("tau,eta_mid") and len(rows) > 2
    assert float(rows[-1].split(",")[0]) > 0
    _no_temp_files(out.parent)


def test_study_stops_at_once_on_sigint(warm, tmp_path):
    _, env = warm
    folder = tmp_path / "study"
    folder.mkdir()
    (folder / "study.csv").write_text("stale")
    (folder / "study.md").write_text("stale")
    rc, dt, out, err = _interrupt(
        ["study", SLIDER, "-o", str(folder), "--quick", "--repeats", "1", "--levels", "1+1,2+2"],
        env,
        "reference:",
        "stdout",
        signal.SIGINT,
        wait=0.5,
    )
    assert rc == 130, err
    assert dt < 2.0, f"took {dt:.2f} s to stop"
    assert "interrupted by SIGINT" in err and "Traceback" not in err
    assert not (folder / "study.csv").exists() and not (folder / "study.md").exists()
    assert list(folder.iterdir()) == []  # stopped during the reference: nothing to keep


def test_reproduce_stopped_leaves_no_complete_readme(tmp_path, capsys, monkeypatch):
    """``reproduce`` interrupted after its first figures: the README of an earlier complete
    run and its figures not redrawn go; README.partial.md says what was drawn and why."""
    from symgen.apps import reproduce as rep

    out = tmp_path / "figs"
    out.mkdir()
    (out / "README.md").write_text("complete, from an earlier run")
    (out / "G12_old_figure.png").write_bytes(b"\x89PNG old")

    def first(path, figs, quick, notes, progress):
        p = figs.out / "G01_new.png"
        atomic_write(p, b"\x89PNG new")
        figs.written.append(p)
        notes.append({"example": "slider_crank", "lines": ["peak 1e-3"]})

    def second(path, figs, quick, notes, progress):
        raise Interrupted(signal.SIGTERM, tau=2.5)

    monkeypatch.setattr(rep, "_slider_crank", first)
    monkeypatch.setattr(rep, "_four_bar", second)
    assert main(["reproduce", "-o", str(out)]) == 143
    assert "interrupted by SIGTERM at tau = 2.5" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["G01_new.png", "README.partial.md"]
    text = (out / "README.partial.md").read_text()
    assert "status: interrupted" in text and "`G01_new.png`" in text and "peak 1e-3" in text
