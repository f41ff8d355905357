"""Issue 19, item 4: the validation suite, symgen against converged Exudyn ANCF references.

Scenes ``benchmarks/validation/*.toml``; references ``benchmarks/validation/ref/<scene>.csv.gz``:
the Exudyn model of the same TOML (``benchmarks/exudyn_scene.py``: ANCF cables, read through
symgen's loader), converged in mesh and step to ``bench_validation.TOL`` of each output's peak
(``ref/<scene>.json``: the ladder; ``benchmarks/validation/README.md``: the table). Only the
converter test needs Exudyn.

The error of an output is max over the run |symgen - ref| / peak |ref|, symgen with the mode
counts chosen from the default accuracy (the scenes state none).

* ``test_not_worse_than_measured``: every output, with von Karman strain and with the exact bar,
  within its error measured today (``MEASURED_BY_STRAIN``, with 30 % headroom, plus the references' own convergence tolerance
  ``bench_validation.TOL``, below which differences mean nothing): a regression guard, not the goal.
* ``test_within_one_percent``: the issue's acceptance, <= 1 % of peak for every output (with no
  mode counts once the accuracy-driven bases exist; converged symgen within 0.1 %). Where
  symgen exceeds it today the case is ``xfail(strict=True)`` with the measured number, so it
  flips when fixed.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_validation as V  # noqa: E402

#: max |symgen - ref| / peak |ref| measured with no mode counts (the bases chosen from the
#: default accuracy 0.01), by
#: ``python benchmarks/bench_validation.py compare [--strain exact]`` (README.md), per strain:
#: von Karman (the default) and the exact bar (``effects.strain = "exact"``). Measured after the
#: Kelvin-Voigt damping was put on the strain rate (it had damped the chord's shortening: the
#: damped scenes were 0.6-17 % off before, crank_rocker_steel 0.57 %, five_bar_elastic 0.88 %,
#: six_bar_soft 1.4 %, slider_crank_torque_soft 17 %). double_pendulum_alu, five_bar_elastic and
#: six_bar_soft remeasured with the coupled check of the bases (it adds functions to their bars).
MEASURED_BY_STRAIN: dict[str, dict[str, dict[str, float]]] = {
    "von_karman": {
        "crank_rocker_steel": {
            "crank_tip": 0.000839,
            "coupler_mid": 0.00111,
            "rocker_mid": 0.00137,
            "torque": 0.000876,
        },
        "double_pendulum_alu": {
            "upper_angle": 9.42e-07,
            "lower_angle": 2.24e-06,
            "upper_tip": 0.000219,
            "lower_tip": 0.00129,
        },
        # torque_b (five_bar) and torque (six_bar): their first samples are the continuum's (the
        # start's joint forces, symgen.numerics.start.continuum_start_outputs): 0.186 % -> 0.0398 %
        # and 1.09 % -> 0.196 %, their error after the start
        # links 4 + 7 -> 3 + 4 (the coupled check counts only the ringing the rows see and pairs the
        # modes by shape, branches wt-coupledD/E): 0.11, 0.075, 0.022, 0.040 % -> 0.106, 0.064, 0.030, 0.041 %
        "five_bar_elastic": {
            "link_a_mid": 0.00106,
            "link_b_mid": 0.000644,
            "P_x": 1e-06,
            "torque_a": 0.000298,
            "torque_b": 0.000407,
        },
        "six_bar_soft": {
            "coupler_mid": 0.000793,
            "rocker_mid": 0.00194,
            "rocker_q3": 0.00198,
            "link_mid": 0.0047,
            "xD": 9.34e-06,
            "torque": 0.00196,
        },
        "slewing_arm": {"tip": 0.032, "mid": 0.0313, "torque": 0.0293},
        "slider_crank_paper": {"eta_mid": 0.00266},
        # all 3 of the rod's functions quasi-static (symgen.scene.bases.quasi_choice: the lowest mode at
        # 37x the run's content, the ramp's ringing 4.6e-4 of a sudden start's): 0.0388 % -> 0.0774 %,
        # the lowest mode's dynamic amplification (a-priori 9.7e-4, tests/test_quasi_choice.py)
        "slider_crank_steel_rest": {"rod_mid": 0.000774},
        "slider_crank_torque_soft": {"rod_mid": 0.111, "theta": 0.00075, "xB": 0.00619},
    },
    "exact": {
        "crank_rocker_steel": {
            "crank_tip": 0.000643,
            "coupler_mid": 0.000799,
            "rocker_mid": 0.00108,
            "torque": 0.000663,
        },
        "double_pendulum_alu": {
            "upper_angle": 1.01e-06,
            "lower_angle": 2.43e-06,
            "upper_tip": 0.000219,
            "lower_tip": 0.00129,
        },
        # links 4 + 7 -> 3 + 4 (as above): the truncation of 3 + 4 functions shows where the exact bar
        # removes the model form: 0.017, 0.013, 0.0079, 0.0056 % -> 0.021, 0.026, 0.029, 0.020 % (the
        # accuracy asked is 1 %)
        "five_bar_elastic": {
            "link_a_mid": 0.000214,
            "link_b_mid": 0.000261,
            "P_x": 1.17e-07,
            "torque_a": 0.000294,
            "torque_b": 0.000197,  # the continuum's start (0.186 % with the model's own)
        },
        "six_bar_soft": {
            "coupler_mid": 0.000176,
            "rocker_mid": 8.48e-05,
            "rocker_q3": 0.000113,
            "link_mid": 0.00022,
            "xD": 4e-07,
            "torque": 0.00115,  # the continuum's start (1.09 % with the model's own)
        },
        # the sixth-order bar (DERIVE_VERSION 7): slewing arm 0.13 % -> 0.077-0.086 %; the soft
        # slider-crank measures rod_mid 0.020, theta 8.7e-5, xB 7.2e-4 with it (the fourth-order
        # numbers below, kept as the guard: docs/exact-bars.md, "Diagnosis")
        # DERIVE_VERSION 8 (the exact strain's eta'^4 / 8): 7.7e-4, 7.8e-4, 8.6e-4 before
        "slewing_arm": {"tip": 3.43e-05, "mid": 0.000142, "torque": 0.00037},
        "slider_crank_paper": {"eta_mid": 0.00169},
        "slider_crank_steel_rest": {"rod_mid": 0.000774},  # 0.000388 before all 3 functions quasi-static
        # DERIVE_VERSION 8 (the exact strain's eta'^4 / 8, the damping of the curvature's rate): 1.78 % -> 1.06 %;
        # DERIVE_VERSION 9 (the strain's -eps eta'^2 / 2: the axial force's geometric stiffness was
        # 1 + N / lambda too large): 1.06 % -> 0.383 % (rod_mid), 8.3e-5 -> 2.7e-5, 6.4e-4 -> 2.1e-4
        "slider_crank_torque_soft": {"rod_mid": 0.00383, "theta": 2.69e-05, "xB": 0.000212},
    },
}
MEASURED = MEASURED_BY_STRAIN["von_karman"]
#: why a scene's outputs exceed the acceptance today (README.md: "What it says"), per strain
CAUSE = {
    "von_karman": {
        "slewing_arm": "model form: the von Karman curvature at 14 % tip deflection (exact bar: 0.04 %)",
        "slider_crank_torque_soft": "model form: the von Karman curvature at 9 % deflection (exact bar: 0.38 %)",
    },
    "exact": {},
}
#: scenes whose symgen run takes more than ~15 s: under ``slow`` only
SLOW: set[str] = set()
#: the acceptance: every output within this fraction of its peak
ACCEPT = 0.01
HEADROOM = 1.3


def _cases(kind: str) -> list:
    cases = []
    for strain, measured in MEASURED_BY_STRAIN.items():
        for scene, outs in sorted(measured.items()):
            marks = [pytest.mark.slow] if scene in SLOW else []
            for out, err in outs.items():
                m = list(marks)
                if kind == "accept" and err > ACCEPT:
                    m.append(
                        pytest.mark.xfail(
                            strict=True,
                            reason=f"measured {100 * err:.2g} % of peak with the chosen bases and {strain} strain; "
                            f"{CAUSE[strain][scene]} (issue 19)",
                        )
                    )
                cases.append(pytest.param(strain, scene, out, err, marks=m, id=f"{strain}-{scene}-{out}"))
    return cases


_ERRORS: dict[tuple[str, str], dict[str, float]] = {}


def _errors(strain: str, scene: str) -> dict[str, float]:
    if (strain, scene) not in _ERRORS:
        _ERRORS[strain, scene] = V.errors(scene, [f'effects.strain="{strain}"'])
    return _ERRORS[strain, scene]


@pytest.mark.parametrize("strain, scene, output, measured", _cases("guard"))
def test_not_worse_than_measured(strain: str, scene: str, output: str, measured: float) -> None:
    err = _errors(strain, scene)[output]
    assert err <= HEADROOM * measured + 1e-6, (
        f"{scene}.{output} ({strain}): {100 * err:.3g} % of peak, measured {100 * measured:.3g} %"
    )


@pytest.mark.parametrize("strain, scene, output, measured", _cases("accept"))
def test_within_one_percent(strain: str, scene: str, output: str, measured: float) -> None:
    err = _errors(strain, scene)[output]
    assert err <= ACCEPT, f"{scene}.{output} ({strain}): {100 * err:.3g} % of peak (acceptance: 1 %)"


#: the driver torques whose error was their sample at tau = 0 alone while the run recorded the
#: model's own start there: 1.09 % (six_bar_soft torque) and 0.186 % (five_bar_elastic torque_b)
#: of peak, 0.196 % and 0.040 % after it (von Karman, no mode counts)
START_ONLY = {"six_bar_soft": ("torque",), "five_bar_elastic": ("torque_b",)}


@pytest.mark.parametrize("scene", sorted(START_ONLY))
def test_a_runs_first_torque_is_the_continuums_and_the_references(scene: str) -> None:
    """At an unstressed start an elastic bar transmits nothing, so the driver torque is that of
    the rigid parts alone (``symgen.numerics.start.continuum_start_outputs``: 0 for cranks at
    constant speed), not the model's own, which keeps about 1/N of the bars' mass on the joints.
    The reference is the continuum's there: Exudyn's first sample of a constraint force is its
    initial algebraic coordinate, 0 at every mesh from 2 to 32 elements. The run records the
    continuum's value as its first sample (``SimResult.start_forces``): it equals the
    reference's to its convergence tolerance, and the run's error is no longer at the start."""
    from symgen.numerics.mechanism import load_mechanism
    from symgen.numerics.start import continuum_start_outputs
    from symgen.numerics.units import result_units
    from symgen.scene import load_scene

    sc = load_scene(V.scene_path(scene))
    mech = load_mechanism(sc)
    q, v, a, lam, _ = mech.initial_state(0.0)
    cont = continuum_start_outputs(mech, 0.0, q, v)
    assert cont is not None
    names = list(mech.info.outputs)
    own = np.array(mech.call("out", 0.0, q, v, a, lam)).ravel()
    _, start = result_units(sc).convert(np.zeros(1), np.array([[cont.get(n, own[k]) for k, n in enumerate(names)]]))
    _, own_start = result_units(sc).convert(np.zeros(1), np.array([own]))
    t_ref, ref = V.read_reference(scene)
    t, out = V.symgen_run(scene)
    assert t[0] == t_ref[0] == 0.0
    for name in START_ONLY[scene]:
        k = names.index(name)
        peak = float(np.abs(ref[name]).max())
        assert abs(start[0, k] - ref[name][0]) < V.TOL * peak, name  # the continuum's is the reference's
        assert abs(own_start[0, k] - ref[name][0]) > 5 * V.TOL * peak, name  # the model's own is not (0.19 %, 1.09 %)
        assert out[name][0] == pytest.approx(start[0, k], rel=1e-12, abs=1e-12 * peak)  # the run records it
        y = np.interp(t_ref, t, out[name])
        total = float(np.abs(y - ref[name]).max()) / peak
        assert abs(y[0] - ref[name][0]) / peak < 0.2 * total, f"{name}: the largest error is still the start's"


def test_every_scene_has_a_converged_reference() -> None:
    """Each validation scene has its reference, converged in mesh and step (the error left in
    the finest run of each ladder, estimated from its last refinements by
    ``bench_validation.estimate``, < TOL of every output's peak), decimated to <= MAX_ROWS
    rows, and its outputs are the scene's (all of them: the converter leaves none out)."""
    from symgen.scene import load_scene

    assert len(V.scenes()) >= 8
    for name in V.scenes():
        table = json.loads((V.REF / f"{name}.json").read_text())
        assert table["converged_mesh"] and table["converged_step"], name
        for what in ("mesh", "step"):
            seen = [max(r["change"].values()) for r in table["rows"] if r.get("refined") == what and r.get("change")]
            assert V.estimate(seen) < V.TOL, (name, what, seen)
        t, ref = V.read_reference(name)
        assert len(t) <= V.MAX_ROWS and np.all(np.diff(t) > 0), name
        scene = load_scene(V.scene_path(name))
        assert list(ref) == [o.name for o in scene.outputs], name
        assert set(MEASURED[name]) == set(ref), name


def test_every_references_first_sample_was_judged_on_its_own() -> None:
    """Each committed reference's first sample went through ``bench_validation.first_sample``
    (the ladder judges its runs by their largest change over the whole run, which may be another
    instant's): three meshes each, and no output's first sample left TOL of its peak or more
    from its limit (replaced where it was). Measured: every in-repo first sample is converged
    (0 at every mesh, or within 6e-8 of peak: crank_rocker_steel's torque, second order)."""
    for name in V.scenes():
        record = json.loads((V.REF / f"{name}.json").read_text())["first_sample"]
        assert len(record["meshes"]) == len(V.FIRST_MESHES), name
        t, ref = V.read_reference(name)
        for k, o in record["outputs"].items():
            assert len(o["values"]) == len(V.FIRST_MESHES), (name, k)
            if o["limit"] is None:  # no asymptotic range: its larger change must be below TOL
                assert o["left"] < V.TOL, (name, k, o)
            else:
                peak = np.abs(ref[k]).max()
                assert abs(ref[k][0] - o["limit"]) < V.TOL * peak, (name, k, o)


def test_a_first_order_first_sample_is_replaced_by_its_limit(tmp_path, monkeypatch) -> None:
    """``bench_validation.first_sample`` on a synthetic ladder (its Exudyn runs replaced): a first
    sample that converges at first order in the mesh, L + C / n (an ANCF joint force at an
    unstressed start under gravity: 0.072 of one element's weight on the pin at every mesh,
    README.md), is replaced by L to round-off; one within TOL of its limit (second order, B / n^2
    small) and one the same at every mesh are kept; the later rows are untouched."""
    import types

    import exudyn_scene as X

    import symgen.numerics.mechanism as M
    from symgen.scene import load_scene

    name = "slewing_arm"
    scene = load_scene(V.scene_path(name))
    n, per_output, h = 8, 4, scene.simulation.output_step
    names = [o.name for o in scene.outputs]  # tip, mid, torque
    big, small, flat = names[2], names[1], names[0]
    L, C, A, B = 0.3, 0.8, 0.05, 0.005

    def first(m: int) -> dict[str, float]:
        return {big: L + C / m, small: A + B / m**2, flat: 0.0}

    def fake(scene_, mech, m, per, t_end=None, newton=None):
        tau = h * np.arange(3.0)
        outs = {k: np.array([v, 1.0, -1.0]) for k, v in first(m).items()}
        return types.SimpleNamespace(tau=tau, outputs=outs, elements=X.element_counts(scene_, m))

    monkeypatch.setattr(V, "REF", tmp_path)
    monkeypatch.setattr(V, "_exudyn", fake)
    monkeypatch.setattr(M, "load_mechanism", lambda scene_: None)
    run = fake(scene, None, n, per_output)
    t, out = X.to_result_units(scene, run.tau, run.outputs)
    V.write_reference(tmp_path / f"{name}.csv.gz", t, out)
    t, out = V.read_reference(name)  # as written (9 digits)
    final = {"elements": X.element_counts(scene, n), "per_output": per_output}
    (tmp_path / f"{name}.json").write_text(json.dumps({"final": final}))

    record = V.first_sample(name, log=lambda *a: None)

    t2, ref = V.read_reference(name)
    _, limit = X.to_result_units(scene, run.tau[:1], {k: np.array([L if k == big else 0.0]) for k in names})
    assert record["outputs"][big]["replaced"] and abs(record["outputs"][big]["ratio"] - 2.0) < 1e-9
    assert abs(ref[big][0] - limit[big][0]) < 1e-8 * abs(limit[big][0])
    assert abs(ref[big][0] - out[big][0]) > 0.1 * abs(out[big][0])  # it was C / 8 off: 0.1 / 0.4
    assert not record["outputs"][small]["replaced"] and not record["outputs"][flat]["replaced"]
    for k in names:
        assert np.array_equal(ref[k][1:], out[k][1:]), k
        if k != big:
            assert ref[k][0] == out[k][0], k
    assert np.array_equal(t2, t)
    assert json.loads((tmp_path / f"{name}.json").read_text())["first_sample"] == record


def test_converter_agrees_with_the_hand_written_model() -> None:
    """The general converter (``exudyn_scene``) and the hand-written Exudyn slider-crank of
    ``exudyn_models`` (same element count and step) give the same rod deflection. (The
    converter's driver torque, its sign and size, is checked against symgen by the suite
    itself: five_bar_elastic's two torques within 0.2 and 0.4 % of peak.)"""
    pytest.importorskip("exudyn")
    import exudyn_models as E
    import exudyn_scene as X

    from symgen.scene import load_scene

    path = ROOT / "benchmarks" / "scenes" / "slider_crank_steel.toml"
    scene = load_scene(path, ["simulation.cycles=0.25"])
    r = X.run(scene, 8, 2 * np.pi / 2000)
    t, out = X.to_result_units(scene, r.tau, r.outputs)
    te, oe, _ = E.slider_crank(8, 2000, 0.25)
    peak = np.abs(oe["rod_mid"]).max()
    assert np.abs(np.interp(t, te, oe["rod_mid"]) - out["rod_mid"]).max() < 1e-5 * peak


def test_the_reference_is_the_converters_finest_run() -> None:
    """The committed reference of the cheapest scene is what ``exudyn_scene`` gives at the
    finest resolution its ladder records (ref/slewing_arm.json): the files are reproducible."""
    pytest.importorskip("exudyn")
    import exudyn_scene as X

    from symgen.scene import load_scene

    name = "slewing_arm"
    final = json.loads((V.REF / f"{name}.json").read_text())["final"]
    scene = load_scene(V.scene_path(name))
    r = X.run(scene, max(final["elements"].values()), final["step_tau"])
    t, out = X.to_result_units(scene, r.tau, r.outputs)
    t_ref, ref = V.read_reference(name)
    for k, v in ref.items():
        assert np.abs(np.interp(t_ref, t, out[k]) - v).max() < 1e-6 * np.abs(v).max(), k


def test_a_sliver_steps_sample_is_not_the_references() -> None:
    """Over ~1e6 steps, n steps of h reach endTime short by ~1e-9 (round-off) and Exudyn takes
    one more step of that size, whose constraint multipliers are meaningless. The rows of a steel
    slider-crank press (20 turns, 128 steps per degree, 4 elements; the driver torque sensor's
    last three rows, model units): its sliver step's torque is 26 x the regular one and of the
    other sign, and it was the reference's last sample (21 % of peak off symgen, which agrees
    with the reference to 0.016 % of peak over the rest of the run). The converter keeps the
    regular rows, so the run's last grid time reads the last regular step (1.6e-9 earlier)."""
    import exudyn_scene as X

    step = 2 * np.pi / 360 / 128
    rows = np.array(
        [
            [125.66356978812516, -0.002605429387653389],
            [125.66370614197297, -0.002713569312442076],
            [125.66370614359172, 0.06995120609493169],  # the sliver step (1.6e-9 tau)
        ]
    )
    kept = X.regular_rows(rows, step)
    assert kept.tolist() == rows[:2].tolist()
    assert np.interp(125.66370614359172, kept[:, 0], kept[:, 1]) == rows[1, 1]
    # a repeated time is dropped too (the later row); regular rows, halved steps and a last
    # step of a tenth of the step are kept
    dup = np.array([[0.0, 1.0], [step, 2.0], [step, 3.0], [1.5 * step, 4.0], [1.6 * step, 5.0]])
    assert X.regular_rows(dup, step)[:, 1].tolist() == [1.0, 2.0, 4.0, 5.0]
    with pytest.raises(ValueError, match="decrease"):
        X.regular_rows(dup[::-1], step)
