"""SI scenes in seconds (issue 21, deliver 3): expressions of t, the run's duration, check's wording.

Oracle of the runs: the same mechanism written by hand as a dimensionless scene, its groups
computed here from their definitions (tau = omega t; mu = E I / (m l^4 omega^2); a moment per
m_ref l0^3 omega^2, a distributed load per m l omega^2, a point load per m l^2 omega^2, gravity
per l0 omega^2), with the laws rewritten by hand in tau. The two runs must agree.
"""

from __future__ import annotations

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.cli import main
from symgen.errors import SceneError
from symgen.numerics.simulate import simulate
from symgen.scene import load_scene
from tests.oracles import write_scene

OMEGA, LENGTH, MASS, E, INERTIA, G = 20.0, 0.5, 0.5, 70e9, 2e-10, 9.81
MU = E * INERTIA / (MASS * LENGTH**4 * OMEGA**2)  # 1.12
MOMENT = MASS * LENGTH**3 * OMEGA**2  # N m per model unit (25)
DISTRIBUTED = MASS * LENGTH * OMEGA**2  # N/m per model unit (100)
POINT = MASS * LENGTH**2 * OMEGA**2  # N per model unit (50)
GRAVITY = G / (LENGTH * OMEGA**2)


def _scene(header: str, bar: str, driver: str, load: str, gravity: float, simulation: str) -> str:
    return f"""
[scene]
name = "arm"
{header}
[[bodies]]
name = "arm"
length = {LENGTH}
{bar}
frame = "cantilever"
axial_modes = 0
transverse_modes = 2
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "arm"]
at = [[0.0, 0.0], 0.0]
[driver]
body = "arm"
{driver}
[[loads]]
body = "arm"
{load}
[effects]
gravity = [0.0, {-gravity!r}]
[outputs]
tip = {{ kind = "deflection", body = "arm", at = 1.0 }}
theta = {{ kind = "angle", body = "arm" }}
[simulation]
{simulation}
rtol = 1e-9
atol = 1e-11
"""


SI_HEADER = f'units = "SI"\nomega = {OMEGA}'
SI_BAR = f"E = {E}\ninertia = {INERTIA}\nmass_per_length = {MASS}"
DIMLESS_BAR = f"mu = {MU!r}"
SI_RUN = "duration = 0.5\noutput_interval = 0.01"
DIMLESS_RUN = f"t_end = {0.5 * OMEGA!r}\noutput_step = {0.01 * OMEGA!r}"

CASES = {
    # an angle law and a distributed load, in seconds and SI
    "law": (
        ('kind = "angle"\nlaw = "0.4*sin(15*t)"', 'kind = "distributed"\ntransverse = "3.0*cos(25*t) + 0.5*t"'),
        (
            'kind = "angle"\nlaw = "0.4*sin(0.75*tau)"',
            f'kind = "distributed"\ntransverse = "{3.0 / DISTRIBUTED!r}*cos(1.25*tau) + {0.5 / DISTRIBUTED / OMEGA!r}*tau"',
        ),
    ),
    # a torque expression and a point load expression
    "torque": (
        (
            'kind = "torque"\nvalue = "0.2*sin(15*t) + 0.05"\ninitial = 0.0',
            'kind = "point"\nat = 0.5\ntransverse = "-2.0*exp(-4*t)"',
        ),
        (
            f'kind = "torque"\nvalue = "{0.2 / MOMENT!r}*sin(0.75*tau) + {0.05 / MOMENT!r}"\ninitial = 0.0',
            f'kind = "point"\nat = 0.5\ntransverse = "{-2.0 / POINT!r}*exp(-0.2*tau)"',
        ),
    ),
}


def _pair(tmp, case: str):
    """(SI scene file, hand-written dimensionless scene file) of one of CASES."""
    (si_driver, si_load), (dl_driver, dl_load) = CASES[case]
    si = write_scene(tmp / "si.toml", _scene(SI_HEADER, SI_BAR, si_driver, si_load, G, SI_RUN))
    dl = write_scene(tmp / "dimless.toml", _scene("", DIMLESS_BAR, dl_driver, dl_load, GRAVITY, DIMLESS_RUN))
    return si, dl


@pytest.fixture(scope="module", params=sorted(CASES))
def pair(request, tmp_path_factory):
    return _pair(tmp_path_factory.mktemp(request.param), request.param)


def test_si_scene_is_the_hand_written_dimensionless_scene(pair):
    si, dl = (load_scene(p) for p in pair)
    assert si.bodies[0].mu == pytest.approx(MU, rel=1e-14)
    assert si.effects.gravity[1] == pytest.approx(-GRAVITY, rel=1e-14)
    assert si.simulation.t_end == pytest.approx(dl.simulation.t_end, rel=1e-14)
    assert si.simulation.output_step == pytest.approx(dl.simulation.output_step, rel=1e-14)


def test_si_expressions_match_the_dimensionless_run(pair):
    si_res, dl_res = (simulate(mechanism(p)) for p in pair)
    np.testing.assert_allclose(si_res.tau, dl_res.tau, rtol=1e-12, atol=1e-12)
    assert len(si_res.tau) == 51
    for name in ("tip", "theta"):
        a, b = si_res.column(name), dl_res.column(name)
        scale = np.abs(b).max()
        assert scale > 1e-4, name  # the motion is not trivial
        assert np.abs(a - b).max() < 1e-6 * scale, name


def test_si_law_follows_the_seconds_law(tmp_path):
    """Independent of the dimensionless scene: theta(t) = 0.4 sin(15 t) at t = tau / omega."""
    si = _pair(tmp_path, "law")[0]
    res = simulate(mechanism(si))
    t = res.tau / OMEGA
    np.testing.assert_allclose(res.column("theta"), 0.4 * np.sin(15 * t), atol=1e-9)


# ------------------------------------------------------------------ loader: keys and messages
def _si_text(**replace: str) -> str:
    text = _scene(
        SI_HEADER,
        SI_BAR,
        'kind = "torque"\nvalue = "0.2*sin(15*t)"\ninitial = 0.0',
        'kind = "distributed"\ntransverse = 1.0',
        G,
        SI_RUN,
    )
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return text


def _error(tmp_path, text: str) -> SceneError:
    with pytest.raises(SceneError) as info:
        load_scene(write_scene(tmp_path / "s.toml", text))
    return info.value


def test_si_torque_expression_is_converted_exactly(tmp_path):
    scene = load_scene(write_scene(tmp_path / "s.toml", _si_text()))
    assert scene.driver.torque == f"(0.2*sin(15*(tau/{OMEGA!r})))/{MOMENT!r}"


def test_tau_is_allowed_in_si_and_t_refused_in_dimensionless(tmp_path):
    """In an SI scene tau = omega t may be written too (a law of tau keeps its meaning), the value
    in SI all the same; a dimensionless scene knows no t."""
    from symgen.scene.expressions import parse_tau_expression, tau_symbol, value_at

    def torque(text: str) -> object:
        value = f'value = "{text}"'
        scene = load_scene(write_scene(tmp_path / "s.toml", _si_text(**{'value = "0.2*sin(15*t)"': value})))
        return parse_tau_expression(scene.driver.torque)

    tau = tau_symbol()
    for a, b in (("0.2*sin(15*t)", "0.2*sin(0.75*tau)"), ("0.1*t*tau", f"0.1*tau^2/{OMEGA!r}")):
        ea, eb = torque(a), torque(b)
        for x in (0.0, 0.3, 1.7, 9.0):
            assert value_at(ea, tau, x) == pytest.approx(value_at(eb, tau, x), rel=1e-14, abs=1e-300)
    text = _scene("", DIMLESS_BAR, 'kind = "angle"\nlaw = "sin(t)"', 'kind = "point"\nat = 1.0', 0.0, DIMLESS_RUN)
    err = _error(tmp_path, text)
    assert err.key == "driver.law"
    assert "unknown name 't'" in err.message


def test_si_pole_is_reported_in_seconds_as_written(tmp_path):
    err = _error(tmp_path, _si_text(**{'"0.2*sin(15*t)"': '"1/(t - 0.25)"'}))
    assert err.key == "driver.value"
    assert "'1/(t - 0.25)' is not a finite real number at t = 0.25 s" in err.message
    assert "the run goes from 0 to 0.5 s" in err.message
    err = _error(
        tmp_path,
        _si_text(**{'kind = "torque"\nvalue = "0.2*sin(15*t)"\ninitial = 0.0': 'kind = "angle"\nlaw = "log(0.3 - t)"'}),
    )
    assert err.key == "driver.law"
    assert "at t = 0.3 s" in err.message and "d theta/dt" not in err.message


def test_duration_and_output_interval(tmp_path):
    scene = load_scene(
        write_scene(tmp_path / "s.toml", _si_text(**{SI_RUN: "duration = 0.25\noutput_interval = 0.005"}))
    )
    assert scene.simulation.t_end == 0.25 * OMEGA
    assert scene.simulation.output_step == 0.005 * OMEGA
    # the tau keys still work in SI scenes (the contract never renames a key)
    scene = load_scene(write_scene(tmp_path / "s.toml", _si_text(**{SI_RUN: "t_end = 4.0\noutput_step = 0.1"})))
    assert (scene.simulation.t_end, scene.simulation.output_step) == (4.0, 0.1)
    scene = load_scene(write_scene(tmp_path / "s.toml", _si_text(**{SI_RUN: "t_end = 4.0\noutput_interval = 0.01"})))
    assert scene.simulation.output_step == pytest.approx(0.2, rel=1e-15)
    for run, key, fragment in (
        ("duration = 0.5\nt_end = 10.0", "simulation", "exactly one of t_end, cycles and duration (t_end and duration"),
        ("duration = 0.5\noutput_step = 0.1\noutput_interval = 0.01", "simulation.output_interval", "not both"),
        ("duration = -1.0", "simulation.duration", "must be > 0"),
        ("duration = 0.5\noutput_interval = 1.0", "simulation.output_interval", "(1 s) is longer than the run (0.5 s)"),
    ):
        err = _error(tmp_path, _si_text(**{SI_RUN: run}))
        assert (err.key, fragment in err.message) == (key, True), err.message
    text = _scene("", DIMLESS_BAR, 'kind = "angle"\nrate = 1.0', 'kind = "point"\nat = 1.0', 0.0, "duration = 1.0")
    err = _error(tmp_path, text)
    assert err.key == "simulation.duration" and "dimensionless" in err.message


def test_check_prints_si_scenes_in_seconds(tmp_path, capsys):
    path = write_scene(tmp_path / "s.toml", _si_text())
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "duration 0.5 s (t_end 10 tau), output interval 0.01 s (51 rows)" in out
    assert f"gravity  [0, {-G:g}] m/s^2" in out
    assert "t_end" in out and "tau," not in out.split("run")[1].split("(t_end")[0]
    path = write_scene(tmp_path / "a.toml", _si_text(**{'value = "0.2*sin(15*t)"': "value = 0.5"}))
    assert main(["check", str(path)]) == 0
    assert "torque on arm: 0.5 N m" in capsys.readouterr().out


# ------------------------------------------------------------------ sweep tables and plots in SI
def test_sweep_of_an_si_scene_is_in_si(tmp_path, capsys):
    """Peaks in m, speeds in Hz and rpm, frequencies in Hz: the dimensionless table times the
    scales; the first bending frequency of the slowly turning cantilever is the clamped-free
    beam's 1.8751^2 sqrt(EI / (m L^4)) / 2 pi Hz (closed form)."""
    import csv
    import json

    from symgen.api import sweep

    path = write_scene(
        tmp_path / "arm.toml",
        _si_text(
            **{
                'kind = "torque"\nvalue = "0.2*sin(15*t)"\ninitial = 0.0': 'kind = "angle"\nrate = 1.0',
                f"gravity = [0.0, {-G!r}]": "gravity = [0.0, 0.0]",
                "transverse = 1.0": 'transverse = "2.0*sin(40*t)"',
            }
        ),
    )
    vary = {"driver.rate": "0.01,0.5"}
    si = sweep(path, vary, workers=1, campbell=True)
    dl = sweep(path, vary, workers=1, campbell=True, units="dimensionless")
    hz = OMEGA / (2 * np.pi)
    np.testing.assert_array_equal(si["driver.rate"], dl["driver.rate"])
    np.testing.assert_allclose(si["peak_tip"], dl["peak_tip"] * LENGTH, rtol=1e-14)
    np.testing.assert_allclose(si["peak_theta"], dl["peak_theta"], rtol=1e-14)
    np.testing.assert_allclose(si["speed"], [0.01 * hz, 0.5 * hz], rtol=1e-14)
    np.testing.assert_allclose(si["speed_rpm"], [0.01 * OMEGA * 60 / (2 * np.pi), 0.5 * OMEGA * 60 / (2 * np.pi)])
    np.testing.assert_allclose(si["f1"], dl["f1"] * hz, rtol=1e-14)
    beam = 1.8751040687**2 * np.sqrt(E * INERTIA / (MASS * LENGTH**4)) / (2 * np.pi)
    assert si["f1"][0] == pytest.approx(beam, rel=2e-3)
    assert si["peak_tip"][1] > 1e-7  # a real deflection, in m

    out = tmp_path / "sweep.csv"
    args = ["sweep", str(path), "--vary", "driver.rate=0.01,0.5", "-o", str(out), "--workers", "1"]
    assert main([*args, "--campbell", str(tmp_path / "c.png"), "--plot", str(tmp_path / "r.png")]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [float(r["f1"]) for r in rows] == pytest.approx(list(si["f1"]), rel=1e-12)
    assert [float(r["peak_tip"]) for r in rows] == pytest.approx(list(si["peak_tip"]), rel=1e-12)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["units"] == "SI" and meta["si_factors"] is None
    assert meta["column_units"] == {
        "peak_tip": "m",
        "peak_theta": "rad",
        "f1": "Hz",
        "f2": "Hz",
        "speed": "Hz",
        "speed_rpm": "rpm",
    }
    for png in ("c.png", "r.png"):
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # --units dimensionless keeps the model's units and the factors to SI
    assert main([*args, "--units", "dimensionless"]) == 0
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["units"].startswith("dimensionless") and meta["si_factors"]["peak_tip"]["factor"] == LENGTH
    rows = list(csv.DictReader(out.open()))
    assert [float(r["peak_tip"]) for r in rows] == pytest.approx(list(dl["peak_tip"]), rel=1e-12)
