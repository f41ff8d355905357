"""SI results of an SI scene: every column is the dimensionless run times a stated factor.

Oracle: the factors are recomputed here from the raw SI data of ``examples/four_bar.toml``
(omega, the crank's density x area as m_ref, the reference length, each bar's length), not from
symgen's scales; the run in SI and the run with ``--units dimensionless`` are compared column by
column, both ways.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from symgen.cli import main

ROOT = Path(__file__).resolve().parent.parent
FOUR_BAR = ROOT / "examples" / "four_bar.toml"
SHORT = ["--set", "simulation.cycles=0.1"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("units")
    out = {}
    for units in ("SI", "dimensionless"):
        csv = tmp / f"{units}.csv"
        extra = [] if units == "SI" else ["--units", "dimensionless"]
        assert main(["simulate", str(FOUR_BAR), "-o", str(csv), *SHORT, *extra]) == 0
        header = csv.read_text().splitlines()[0].split(",")
        out[units] = (
            header,
            np.loadtxt(csv, delimiter=",", skiprows=1),
            json.loads(csv.with_suffix(".json").read_text()),
        )
    return out


def test_si_four_bar_is_the_dimensionless_run_times_the_factors(runs):
    raw = tomllib.loads(FOUR_BAR.read_text())
    omega = raw["scene"]["omega"]
    l0 = raw["scene"]["reference_length"]
    crank = raw["bodies"][0]  # the reference bar: the first elastic bar
    m_ref = crank["density"] * crank["area"]  # kg/m
    length = {b["name"]: b["length"] for b in raw["bodies"]}
    h_si, si, meta_si = runs["SI"]
    h_nd, nd, meta_nd = runs["dimensionless"]
    assert h_si[0] == "t" and h_nd[0] == "tau" and h_si[1:] == h_nd[1:]
    col = {name: k for k, name in enumerate(h_si)}
    # time in s, torque in N m, deflections in m, angles unchanged
    np.testing.assert_allclose(si[:, 0], nd[:, 0] / omega, rtol=1e-14)
    np.testing.assert_allclose(si[:, col["torque"]], nd[:, col["torque"]] * m_ref * l0**3 * omega**2, rtol=1e-12)
    np.testing.assert_allclose(si[:, col["coupler_mid"]], nd[:, col["coupler_mid"]] * length["coupler"], rtol=1e-12)
    np.testing.assert_allclose(si[:, col["crank_tip_dx"]], nd[:, col["crank_tip_dx"]] * l0, rtol=1e-12)
    np.testing.assert_array_equal(si[:, col["rocker_angle"]], nd[:, col["rocker_angle"]])
    # the sidecar states units and factors; dividing by them gives the dimensionless run back
    units = meta_si["units"]
    assert units["system"] == "SI" and units["time"] == {"name": "t", "unit": "s", "factor": 1 / omega}
    assert units["columns"]["torque"]["unit"] == "N m" and units["columns"]["coupler_mid"]["unit"] == "m"
    back = si[:, 1:] / np.array([units["columns"][n]["factor"] for n in h_si[1:]])
    np.testing.assert_allclose(back, nd[:, 1:], rtol=1e-12, atol=1e-300)
    assert meta_nd["units"]["system"] == "dimensionless"
    assert all(c["factor"] == 1.0 for c in meta_nd["units"]["columns"].values())
    # a magnitude check in physical terms: the torque is of order (coupler+rocker mass) r omega^2 r
    peak = np.abs(si[:, col["torque"]]).max()
    masses = sum(b["density"] * b["area"] * b["length"] for b in raw["bodies"][1:])
    assert 0.1 < peak / (masses * 0.1**2 * omega**2) < 10


def test_api_results_table_matches_the_cli(runs):
    from symgen.api import results_table, simulate_scene
    from symgen.scene import load_scene

    scene = load_scene(str(FOUR_BAR), ["simulation.cycles=0.1"])
    cols = results_table(simulate_scene(scene), scene)
    h_si, si, _ = runs["SI"]
    assert list(cols) == h_si
    np.testing.assert_allclose(cols["torque"], si[:, h_si.index("torque")], rtol=1e-9)


def test_units_errors(tmp_path, capsys):
    code = main(
        [
            "simulate",
            str(ROOT / "examples" / "slider_crank.toml"),
            "-o",
            str(tmp_path / "x.csv"),
            "--units",
            "SI",
            *SHORT,
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "scene.units" in err and "SI results need an SI scene" in err
    assert list(tmp_path.iterdir()) == []
    # a dimensionless scene's results are dimensionless, with tau first
    out = tmp_path / "sc.csv"
    assert main(["simulate", str(ROOT / "examples" / "slider_crank.toml"), "-o", str(out), *SHORT]) == 0
    assert out.read_text().startswith("tau,")
    assert json.loads(out.with_suffix(".json").read_text())["units"]["system"] == "dimensionless"
    assert math.isfinite(np.loadtxt(out, delimiter=",", skiprows=1)[-1, 0])


def test_sweep_sidecar_gives_the_si_factors_of_the_peaks():
    from symgen.apps.sweep import _si_factors
    from symgen.scene import load_scene

    fb = load_scene(str(FOUR_BAR))
    raw = tomllib.loads(FOUR_BAR.read_text())
    m_ref = raw["bodies"][0]["density"] * raw["bodies"][0]["area"]
    f = _si_factors(fb)
    assert f["peak_torque"] == {"unit": "N m", "factor": pytest.approx(m_ref * 0.1**3 * 230.0**2)}
    assert f["peak_coupler_mid"] == {"unit": "m", "factor": pytest.approx(0.3)}
    assert _si_factors(load_scene(str(ROOT / "examples" / "slider_crank.toml"))) is None
