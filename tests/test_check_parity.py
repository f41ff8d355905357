"""The Python runners and the emitted C solver give the same verdicts at the same tau on the
run checks: a singular position met on the way and at the start, a mechanism that cannot be
assembled, a bar beyond the range of its model (also in the quasi-static start). Both read
their limits from ``symgen.policy`` and measure singularity the same way (smallest / largest
singular value of the closure Jacobian in the dependent rigid coordinates)."""
from __future__ import annotations

import math
import shutil
import subprocess

import pytest

from symgen.api import mechanism
from symgen.errors import SimulationError
from symgen.numerics.csolver import executable
from symgen.numerics.simulate import simulate
from test_cli import FOUR_BAR_TOGGLE

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")

SINGULAR = "the rigid mechanism reached a singular position"    # not "may have reached"
TOGGLE = math.acos(0.375)       # the crank angle where coupler and rocker align (tests/test_cli.py)
ELASTIC = FOUR_BAR_TOGGLE.replace('name = "coupler"\nlength = 1.0\nrigid = true',
                                  'name = "coupler"\nlength = 1.0\nlambda = 1e4\nmu = 2.0\n'
                                  'frame = "pinned-pinned"\naxial_modes = 2\ntransverse_modes = 2')
SCENES = {"rigid": (FOUR_BAR_TOGGLE, []),
          "elastic": (ELASTIC, ["effects.axial=inextensible", "initial.deformation=quasi-static"])}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """{name: (scene path, overrides, the C executable)} of the toggle four-bars."""
    d = tmp_path_factory.mktemp("parity")
    out = {}
    for name, (text, over) in SCENES.items():
        path = d / f"{name}.toml"
        path.write_text(text)
        exe = d / f"{name}_sim"
        exe.write_bytes(executable(mechanism(path, over))[0])
        exe.chmod(0o700)
        out[name] = (path, over, exe)
    return out


def _python(path, over, extra=()):
    """(tau of the failure, message, last output tau) of the Python run."""
    try:
        res = simulate(mechanism(path, [*over, *extra]))
    except SimulationError as err:
        partial = getattr(err, "partial", None)
        last = float(partial.tau[-1]) if partial is not None and len(partial.tau) else None
        return err.tau, str(err), last
    return None, "complete", float(res.tau[-1])


def _c(exe, *args):
    """(exit code, stderr, last output tau) of the C executable."""
    proc = subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=120)
    rows = proc.stdout.strip().splitlines()[1:]
    last = float(rows[-1].split(",")[0]) if rows else None
    return proc.returncode, proc.stderr, last


@pytest.mark.parametrize("name", sorted(SCENES))
def test_singular_position_on_the_way(built, name):
    """Driven into the toggle at tau = acos(0.375) - 0.5: both stop there as a singular
    position, after the same last output."""
    path, over, exe = built[name]
    tau, msg, last_py = _python(path, over)
    code, err, last_c = _c(exe)
    assert SINGULAR in msg and SINGULAR in err, (msg, err)
    assert code == 1
    assert last_py == pytest.approx(last_c, abs=1e-9)
    assert last_py == pytest.approx(TOGGLE - 0.5, abs=0.011)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_start_at_the_toggle(built, name):
    path, over, exe = built[name]
    tau, msg, _ = _python(path, over, [f"driver.initial={TOGGLE!r}"])
    code, err, _ = _c(exe, "--set", f"theta0={TOGGLE!r}")
    assert "singular position" in msg and "singular position" in err and "may have" not in err, (msg, err)
    assert tau == 0.0 and "at tau = 0:" in err and code == 1


@pytest.mark.parametrize("name", sorted(SCENES))
def test_cannot_be_assembled(built, name):
    """The crank started at 2 rad, beyond its toggle: no assembly, in both."""
    path, over, exe = built[name]
    tau, msg, _ = _python(path, over, ["driver.initial=2.0"])
    code, err, _ = _c(exe, "--set", "theta0=2.0")
    assert "cannot be assembled" in msg and "cannot be assembled" in err, (msg, err)
    assert tau == 0.0 and code == 1


def test_quasi_static_start_beyond_the_range(built):
    """A coupler so soft that its quasi-static start deflects beyond the model's range: both
    refuse to start (the C start checked no range before)."""
    path, over, exe = built["elastic"]
    mu = 2.0 * 1e-4
    tau, msg, _ = _python(path, over, [f"bodies.coupler.mu={mu!r}"])
    code, err, _ = _c(exe, "--set", f"mu_coupler={mu!r}")
    assert "beyond the range of the model" in msg and "beyond the range of the model" in err, (msg, err)
    assert tau == 0.0 and code == 1 and "at tau = 0:" in err and "'coupler'" in err

