"""The symgen-vs-Exudyn benchmark harness (benchmarks/bench_exudyn.py, exudyn_models.py, run.py):
its error measure, configuration pick, RESULTS.md section merge and the four-bar's rigid start.
No timing here (speed targets live in benchmarks/), and no Exudyn needed."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"
sys.path.insert(0, str(BENCH))

import bench_exudyn as B  # noqa: E402
import exudyn_models as E  # noqa: E402
import run as R  # noqa: E402


def test_on_grid_picks_the_grid_samples_and_skips_the_others():
    dt = 0.01
    t = np.array([0.0, 0.005, 0.01, 0.0125, 0.02, 0.03])  # steps of dt/2 and dt/4
    assert B.on_grid(t, dt, 4).tolist() == [0, 2, 4, 5]


def test_on_grid_refuses_a_missing_grid_point():
    with pytest.raises(ValueError, match="1 of 4 grid points missing"):
        B.on_grid(np.array([0.0, 0.01, 0.03]), 0.01, 4)
    with pytest.raises(ValueError, match="grid points missing"):  # drifted samples are not on the grid
        B.on_grid(np.array([0.0, 0.0101, 0.0201]), 0.01, 3)


def test_peak_error_is_relative_to_the_reference_peak():
    ref = np.array([0.0, 2.0, -4.0, 1.0])
    y = np.array([0.1, 2.0, -3.8, 1.0])
    assert B.peak_error(y, ref) == pytest.approx(0.2 / 4.0)
    assert B.peak_error(np.array([0.0, np.nan, 0.0, 0.0]), ref) == math.inf
    with pytest.raises(ValueError, match="shapes differ"):
        B.peak_error(y[:3], ref)


def test_run_error_is_the_worst_output_on_the_grid():
    dt = 0.5
    t = np.arange(0.0, 2.01, 0.25)  # twice the grid's rate
    a, b = np.sin(t), np.cos(t)
    ref = {"a": np.sin(np.arange(5) * dt), "b": np.cos(np.arange(5) * dt) * 1.01}
    expect = max(0.0, np.abs(np.cos(np.arange(5) * dt) * 0.01).max() / np.abs(ref["b"]).max())
    assert B.run_error(t, {"a": a, "b": b}, ref, dt, ("a", "b")) == pytest.approx(expect)
    assert B.run_error(t, {"a": a, "b": b}, ref, dt, ("a",)) == pytest.approx(0.0, abs=1e-15)


def test_cheapest_needs_the_next_refinement_within_the_target_too():
    rows = [
        {"id": 1, "finer": 2, "error": 0.009, "cpu": 1.0},  # lucky: its refinement is off
        {"id": 2, "finer": 3, "error": 0.02, "cpu": 2.0},
        {"id": 3, "finer": 4, "error": 0.005, "cpu": 4.0},  # 4 not run: counts on its own
        {"id": 5, "finer": 6, "error": 0.001, "cpu": 9.0},
    ]
    assert B.cheapest(rows, 0.01)["id"] == 3
    assert B.cheapest(rows, 0.002)["id"] == 5
    assert B.cheapest(rows, 1e-4) is None


def test_error_against_reads_the_run_on_the_reference_grid():
    t_ref = np.linspace(0.0, 1.0, 11)
    ref = (t_ref, {"y": np.sin(t_ref)})
    t = np.linspace(0.0, 1.0, 101)  # a finer run: its samples at the reference's times
    y = np.sin(t)
    y[50] += 0.3  # off the reference grid (t = 0.5 is on it: index 50 of 101 is t = 0.5)
    assert B.error_against(t, {"y": y}, ref) == pytest.approx(0.3 / np.sin(1.0))
    y[50] -= 0.3
    y[51] += 0.3  # t = 0.51: between reference samples, not read
    assert B.error_against(t, {"y": y}, ref) == pytest.approx(0.0, abs=1e-12)


def _acceptance_results(ex_int, ex_proc, floor, sg):
    """A results dict of bench_exudyn.run for the steel scene at 1 %: symgen's variants (name ->
    (integration s, process s))."""
    symgen = {v: {"int": i, "proc": p} for v, (i, p) in sg.items()}
    targets = {1e-2: {"ex_int": ex_int, "ex_proc": ex_proc, "floor": floor, "symgen": symgen}}
    return {"slider_crank_steel_rest": {"targets": targets}}


def test_acceptance_lines_compare_each_variant_with_its_target():
    sg = {"default": (0.1, 0.5), "estimate off": (0.01, 0.1), "c": (0.05, 0.4), "c, estimate off": (0.0149, 0.02)}
    lines = B.acceptance_lines(_acceptance_results(0.2, 0.35, 0.01, sg))
    default_int, default_proc, c_floor, c_proc = lines
    # Exudyn 0.2 s / 0.1 s = 2x (< 10x, not met), / 0.01 s = 20x (met)
    assert "2x" in default_int and "20x" in default_int
    assert default_int.index("**not met**") < default_int.index("; ") < default_int.rindex(", met")
    # whole process 0.35 / 0.5 = 0.7x, 0.35 / 0.1 = 3.5x (>= 3x: met)
    assert "0.7x" in default_proc and "3.5x" in default_proc and default_proc.endswith(", met.")
    # the floor is an upper bound: 5x the floor not met, 1.49x met
    assert "5.00x the floor" in c_floor and "1.49x the floor" in c_floor and c_floor.endswith(", met.")
    assert "**not met**" in c_floor.split("; ")[0]
    assert "17.5x" in c_proc and c_proc.endswith(", met.")


def test_results_sections_round_trip_and_replace_one():
    text = (
        "# title\n\nMachine: x.\n\n## A\n\nalpha\n\n_(section `examples` took 3 s)_\n\n"
        "## B one\n\n## B two\n\n_(section `c` took 10 s)_\n"
    )
    header, sections = R.split_sections(text)
    assert header == "# title\n\nMachine: x.\n\n"
    assert list(sections) == ["examples", "c"]
    assert R.merge(text, header, {}) == text
    merged = R.merge(text, "# new\n\n", {"exudyn": "## E\n\n_(section `exudyn` took 1 s)_"})
    assert merged.index("## A") < merged.index("## E") < merged.index("## B one")  # in SECTIONS order
    assert merged.startswith("# new\n\n## A")
    again = R.merge(merged, "# new\n\n", {"exudyn": "## E2\n\n_(section `exudyn` took 2 s)_"})
    assert "## E2" in again and "## E\n" not in again


def test_four_bar_rigid_start_closes_the_loop_and_its_velocities():
    raw = E._scene("four_bar_steel")
    bars = E._bars(raw)
    A, Bp, O4, th3, th4, vA, w3, w4 = E.four_bar_geometry(raw)
    a, c, r = (bars[k]["length"] for k in ("crank", "coupler", "rocker"))
    assert np.linalg.norm(A) == pytest.approx(a)
    assert np.linalg.norm(Bp - A) == pytest.approx(c)
    assert np.linalg.norm(Bp - O4) == pytest.approx(r)
    assert Bp[1] > 0  # the open (upper) assembly
    # the velocities: differentiate the assembly numerically (closed form of two circles' crossing)
    omega, h = raw["scene"]["omega"], 1e-7

    def joint_b(theta):
        Ap = a * np.array([math.cos(theta), math.sin(theta)])
        d = np.linalg.norm(O4 - Ap)
        x = (d * d + c * c - r * r) / (2 * d)
        u = (O4 - Ap) / d
        return Ap + x * u + math.sqrt(c * c - x * x) * np.array([-u[1], u[0]])

    vB = (joint_b(h) - joint_b(-h)) / (2 * h) * omega
    assert vB == pytest.approx(w4 * np.array([-(Bp - O4)[1], (Bp - O4)[0]]), rel=1e-6)
    assert vB == pytest.approx(vA + w3 * np.array([-(Bp - A)[1], (Bp - A)[0]]), rel=1e-6)
    assert math.atan2(*(Bp - A)[::-1]) == pytest.approx(th3)


def test_six_bar_rigid_start_closes_both_loops_and_its_velocities():
    """The Exudyn six-bar's start (benchmarks/exudyn_models.six_bar_geometry): both loops closed,
    the branch of the scene's [initial] guess, velocities the assembly's time derivative."""
    raw = E._scene("six_bar_steel")
    bars = E._bars(raw)
    g = E.six_bar_geometry(raw)
    length = {k: bars[k]["length"] for k in bars}
    A, Bp, C, D, O4, O6 = (g[k] for k in ("A", "B", "C", "D", "O4", "O6"))
    assert np.linalg.norm(A) == pytest.approx(length["crank"])
    assert np.linalg.norm(Bp - A) == pytest.approx(length["coupler"])
    assert np.linalg.norm(Bp - O4) == pytest.approx(length["rocker"])
    assert C == pytest.approx((A + Bp) / 2)  # the ternary link's midspan
    assert np.linalg.norm(D - C) == pytest.approx(length["link"])
    assert np.linalg.norm(D - O6) == pytest.approx(length["rocker2"])
    for k, guess in raw["initial"]["guess"].items():  # the scene's branch
        assert abs(g["theta"][k] - guess) < 0.05, k
    omega, h = raw["scene"]["omega"], 1e-7
    plus, minus = E.six_bar_geometry(raw, h), E.six_bar_geometry(raw, -h)
    for k in ("coupler", "rocker", "link", "rocker2"):
        assert (plus["theta"][k] - minus["theta"][k]) / (2 * h) * omega == pytest.approx(g["w"][k], rel=1e-6)
    assert (plus["C"] - minus["C"]) / (2 * h) * omega == pytest.approx(g["vC"], rel=1e-6)


def _stand_in_exudyn(monkeypatch, tmp_path, fake_run, counts, name):
    """bench_validation.reference on a stand-in for Exudyn (``fake_run``, ``counts``: the
    elements per bar), the reference written to ``tmp_path``, the ladder started at (4, 4)."""
    import types

    import bench_validation as V

    import symgen.numerics.mechanism as M
    import symgen.scene as S

    fake_x = types.ModuleType("exudyn_scene")
    fake_x.to_result_units = lambda scene, tau, outputs: (tau, outputs)
    fake_x.element_counts = counts
    monkeypatch.setitem(sys.modules, "exudyn_scene", fake_x)
    monkeypatch.setattr(V, "_exudyn", fake_run)
    monkeypatch.setattr(V, "REF", tmp_path)
    monkeypatch.setattr(V, "scene_path", lambda name: tmp_path / f"{name}.toml")
    # the first sample's judgement (bench_validation.first_sample) reads the scene's output step
    scene = types.SimpleNamespace(simulation=types.SimpleNamespace(output_step=1.0))
    monkeypatch.setattr(S, "load_scene", lambda path: scene)
    monkeypatch.setattr(M, "load_mechanism", lambda scene: None)
    monkeypatch.setitem(V.START, name, (4, 4))


def test_the_reference_ladder_does_not_keep_a_mesh_refinement_whose_change_grows(monkeypatch, tmp_path):
    """bench_validation.reference: a mesh doubled at a coarse step can meet the step's limit (the
    shorter elements' fast modes against the step): its change grows. That run is not kept: the
    step is converged on the coarser mesh, then the mesh again at the converged step (a kept-out
    four-bar's reference was written from such a run, unconverged). A model whose error is
    a/n^2 + b/k^2, plus an artefact where n >= 64 at k < 16, stands in for Exudyn."""
    import types

    import bench_validation as V

    def fake_run(scene, mech, n, k, t_end=None, newton=None):
        err = 2.0 / n**2 + 0.05 / k**2 + (1e-2 if n >= 64 and k < 16 else 0.0)
        return types.SimpleNamespace(
            elements={"bar": n},
            cpu=1e-3 * n * k,
            outputs={"y": np.array([1.0 + err, -1.0 - err])},
            tau=np.array([0.0, 1.0]),
            step=1.0 / k,
            skipped=(),
        )

    _stand_in_exudyn(monkeypatch, tmp_path, fake_run, lambda scene, n: {"bar": n}, "ladder")
    table = V.reference("ladder", log=lambda *a: None)
    kept = [r for r in table["rows"] if r.get("change") and r.get("kept", True)]
    dropped = [r for r in table["rows"] if r.get("kept") is False]
    assert dropped and dropped[0]["elements"] == {"bar": 64} and dropped[0]["per_output"] == 4
    assert table["converged_mesh"] and table["converged_step"]
    final = table["final"]
    assert final["per_output"] >= 16  # the step refined (before: the mesh ladder ended the reference at k = 4)
    # the stored reference is within TOL of the exact answer (1.0) in each ladder: 2 TOL together
    t, out = V.read_reference("ladder")
    assert np.max(np.abs(np.abs(out["y"]) - 1.0)) < 2 * V.TOL
    assert all(r["refined"] in ("mesh", "step") for r in kept)


def test_the_reference_ladder_refines_the_mesh_it_runs(monkeypatch, tmp_path):
    """bench_validation.reference: the output points round the elements per bar (0.3 and 0.5 ->
    multiples of 10), so 4 and 8 elements are the same mesh of 10. A doubling that leaves the mesh
    as it was is no refinement: its change of 0 must not end the mesh ladder (a kept-out pump's
    reference had its mesh "converged" at 10 against 10 elements). A model whose error is
    2/E^2 + 0.05/k^2 in the elements E it really runs stands in for Exudyn."""
    import types

    import bench_validation as V

    def counts(scene, n):
        return {"bar": max(10, -(-n // 10) * 10)}

    def fake_run(scene, mech, n, k, t_end=None, newton=None):
        e = counts(scene, n)["bar"]
        err = 2.0 / e**2 + 0.05 / k**2
        return types.SimpleNamespace(
            elements={"bar": e},
            cpu=1e-3 * e * k,
            outputs={"y": np.array([1.0 + err, -1.0 - err])},
            tau=np.array([0.0, 1.0]),
            step=1.0 / k,
            skipped=(),
        )

    _stand_in_exudyn(monkeypatch, tmp_path, fake_run, counts, "rounded")
    table = V.reference("rounded", log=lambda *a: None)
    mesh = [r for r in table["rows"] if r.get("refined") == "mesh"]
    assert mesh and all(max(r["change"].values()) > 0 for r in mesh)  # every mesh run is a new mesh
    assert table["final"]["elements"]["bar"] > 10
    # its first sample judged on its own after the ladder (three meshes from the final one)
    assert sorted(table["first_sample"]["meshes"]) == [table["final"]["elements"]["bar"] * f for f in (1, 2, 4)]
    t, out = V.read_reference("rounded")
    assert np.max(np.abs(np.abs(out["y"]) - 1.0)) < 2 * V.TOL
