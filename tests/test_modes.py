"""Linearised modes about the quasi-static state (``symgen modes``) against published and
closed-form frequencies.

Oracles:

* the rotating uniform cantilever (hub radius 0, Euler-Bernoulli, spin rate Omega): exact
  flapwise (out-of-plane) frequencies of Hodges & Rutkowski, "Free-vibration analysis of
  rotating beams by a variable-order finite-element method", AIAA J. 19(11), 1459-1466 (1981),
  Table 1, the same as Wright, Smith, Thresher & Wang, "Vibration modes of centrifugally
  stiffened beams", J. Appl. Mech. 49, 197-202 (1982), Table 1 (Frobenius series), in units of
  sqrt(EI/(m L^4)). symgen's bars bend in the plane of the mechanism, which for a spinning crank
  is the plane of rotation: lead-lag (in-plane) bending, whose equation is the flapwise one
  plus the spin-softening term -m Omega^2 v, so omega_inplane^2 = omega_flap^2 - Omega^2 (same
  centrifugal tension, same mode shapes). With mu = 1 the crank's rate is the nondimensional
  spin rate and the frequencies come out in the table's units. The bar is made nearly
  inextensible (lambda = 1e7) as the classical theory assumes; the axial basis (6 functions)
  carries the centrifugal tension N = Omega^2 (1 - xi^2)/2;
* the pinned-pinned bar at rest: (n pi)^2 sqrt(mu), and Kelvin-Voigt modal damping c omega/2.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from symgen.api import mechanism
from symgen.cli import main
from symgen.numerics.modes import modes
from tests.oracles import write_scene

# Hodges & Rutkowski (1981) Table 1 / Wright et al. (1982) Table 1: uniform cantilever, hub
# radius 0, flapwise frequencies of the first two modes for nondimensional spin rate Omega
FLAPWISE = {
    0: (3.5160, 22.0345),
    1: (3.6816, 22.1810),
    2: (4.1373, 22.6149),
    3: (4.7973, 23.3203),
    5: (6.4495, 25.4461),
    8: (9.2568, 29.9954),
    10: (11.2023, 33.6404),
}

SPINNING = """
[scene]
name = "spinning_cantilever"
[[bodies]]
name = "crank"
length = 1.0
lambda = 1.0e7
mu = 1.0
frame = "cantilever"
axial_modes = 6
transverse_modes = 6
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "crank"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "angle"
body = "crank"
initial = 0.0
rate = 1.0
[outputs]
tip = { kind = "deflection", body = "crank", at = 1.0 }
[simulation]
cycles = 1
output_step = 0.1
"""


@pytest.fixture(scope="module")
def spinning(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("spin") / "spin.toml", SPINNING)


@pytest.mark.parametrize("spin", sorted(FLAPWISE))
def test_spinning_cantilever_in_plane_frequencies(spinning, spin):
    res = modes(mechanism(spinning, [f"driver.rate={spin}"]), tau=0.7, shapes=False)
    measured = res.frequencies("transverse", "crank")[:2]
    expected = [math.sqrt(w**2 - spin**2) for w in FLAPWISE[spin]]
    assert measured == pytest.approx(expected, rel=5e-3)
    assert res.stable
    # spin stiffens the bar: the axial (centrifugal) tension of the quasi-static state is in it
    # (without it the first mode would be sqrt(3.516^2 - Omega^2), imaginary beyond Omega = 3.5)
    if spin:
        assert measured[0] ** 2 + spin**2 > 1.01 * 3.5160**2


def test_spin_stiffening_needs_geometric_stiffening(spinning):
    """Without the axial-force coupling only spin softening is left: omega^2 = omega_0^2 - Omega^2
    in the first mode (Rayleigh quotient of the non-rotating mode, to 1e-3)."""
    res = modes(mechanism(spinning, ["driver.rate=2", "effects.geometric_stiffening=false"]), shapes=False)
    assert res.frequencies("transverse")[0] == pytest.approx(math.sqrt(3.5160**2 - 4), rel=1e-3)


PINNED = """
[scene]
name = "pinned_bar"
[[bodies]]
name = "beam"
length = 1.0
lambda = 1.0e4
mu = 0.5
frame = "pinned-pinned"
axial_modes = 2
transverse_modes = 4
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "beam"]
at = [[0.0, 0.0], 0.0]
[[joints]]
name = "B"
kind = "slider"
bodies = ["beam", "ground"]
at = [1.0, [1.0, 0.0]]
direction = [1.0, 0.0]
[outputs]
w = { kind = "deflection", body = "beam", at = 0.25 }
[simulation]
t_end = 1.0
output_step = 0.1
"""


@pytest.mark.parametrize("damping", [0.0, 0.002])
def test_pinned_pinned_bar_frequencies_and_damping(tmp_path, damping):
    path = write_scene(tmp_path / "bar.toml", PINNED)
    res = modes(mechanism(path, [f"effects.damping={damping}"]))
    tr = [m for m in res.modes if m.dominant == "beam transverse"]
    expected = [(n * math.pi) ** 2 * math.sqrt(0.5) for n in (1, 2, 3, 4)]
    assert [m.natural_frequency for m in tr] == pytest.approx(expected, rel=1e-9)
    assert [m.damping_ratio for m in tr] == pytest.approx([damping * w / 2 for w in expected], abs=1e-12)
    # the shape of mode n is sin(n pi xi)
    for n, m in enumerate(tr, start=1):
        xi = np.array(m.shape["beam"]["xi"])
        eta = np.array(m.shape["beam"]["eta"])
        ref = np.sin(n * math.pi * xi)
        ref *= np.dot(eta, ref) / np.dot(ref, ref)
        assert np.abs(eta - ref).max() < 1e-9 * np.abs(eta).max()


def test_cli_modes_json(tmp_path, capsys):
    out = tmp_path / "modes.json"
    assert main(["modes", "examples/four_bar.toml", "--at", "1.0", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "coupler transverse" in text and "Hz" in text
    doc = json.loads(out.read_text())
    assert doc["tau"] == 1.0 and doc["quasi_static"]["residual"] < 1e-9
    freqs = [m["natural_frequency"] for m in doc["modes"]]
    assert freqs == sorted(freqs) and len(freqs) >= 12
    first = doc["modes"][0]
    assert first["natural_frequency_hz"] == pytest.approx(first["natural_frequency"] * 230.0 / (2 * math.pi))
    assert set(first["shape"]) == {"crank", "coupler", "rocker"}
    # the coupler (mu = 0.50) rings lowest, near its pinned-pinned pi^2 sqrt(mu) = 7.0 (the
    # joints are not rigid supports and its axial load shifts it)
    assert first["dominant"] == "coupler transverse" and 5.0 < first["natural_frequency"] < 8.0
    # undamped moving loop: the console says it is unstable in the frozen sense and why, as the JSON
    assert doc["stable"] is False and doc["stability"]["kind"] == "growth"
    assert "UNSTABLE" in text and "no damping" in text and "zeta*" in text
    from symgen.numerics.modes import ZETA_NEUTRAL

    grows = [m for m in doc["modes"] if m["eigenvalue"][0] > 0 and m["damping_ratio"] < -ZETA_NEUTRAL]
    assert grows and f"{len(grows)} vibration mode(s) grow" in text


def test_console_verdicts_stable_and_damped(spinning, tmp_path, capsys):
    """A bar spinning without a loop is stable (said on the console); a damped pinned bar prints
    plain zeta without the undamped footnote."""
    assert main(["modes", str(spinning), "--at", "0.7"]) == 0
    text = capsys.readouterr().out
    assert "stable: every eigenvalue" in text and "UNSTABLE" not in text
    path = write_scene(tmp_path / "bar.toml", PINNED)
    assert main(["modes", str(path), "--set", "effects.damping=0.002"]) == 0
    text = capsys.readouterr().out
    assert "zeta*" not in text and "no damping" not in text and "stable:" in text


def test_divergence_verdict_names_buckling():
    """A real positive eigenvalue is a divergence (beyond buckling), whatever the damping."""
    from symgen.numerics.modes import ModesResult

    res = ModesResult(
        tau=0.0,
        modes=[],
        real_eigenvalues=[-0.5, 0.312],
        state={},
        independent=[],
        dependent=[],
        quasi_static={"method": "newton"},
    )
    v = res.stability(0.01)
    assert (v["stable"], v["kind"]) == (False, "divergence") and "buckling" in v["reason"] and "0.312" in v["reason"]


def test_a_mode_growing_slower_than_neutral_is_not_called_unstable():
    """An undamped moving loop gives vibration modes with growth rates of 1e-6 (zeta -2.5e-7):
    `modes` called them "UNSTABLE"; they double over millions of periods. Growth beyond
    zeta = -1e-5 is still unstable."""
    from symgen.numerics.modes import ZETA_NEUTRAL, Mode, ModesResult

    def result(zeta: float) -> ModesResult:
        wn = 12.0
        s = complex(-zeta * wn, wn * (1 - zeta**2) ** 0.5)
        mode = Mode(
            index=1,
            eigenvalue=s,
            natural_frequency=wn,
            frequency=s.imag,
            damping_ratio=zeta,
            dominant="rod transverse",
            energy_fractions={},
            amplitudes={},
            complexity=0.0,
        )
        return ModesResult(
            tau=0.0, modes=[mode], real_eigenvalues=[], state={}, independent=[], dependent=[], quasi_static={}
        )

    neutral = result(-2.5e-7)
    assert neutral.stable and neutral.stability()["stable"] and "neutral" in neutral.stability()["reason"]
    growing = result(-10 * ZETA_NEUTRAL)
    assert not growing.stable and growing.stability()["kind"] == "growth"
    assert result(0.01).stability()["reason"] == "every eigenvalue has a non-positive real part"
