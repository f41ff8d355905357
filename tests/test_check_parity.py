"""The Python runners and the emitted C solver give the same verdicts at the same tau on the
run checks: a singular position met on the way and at the start, a mechanism that cannot be
assembled, a bar beyond the range of its model (also in the quasi-static start), a quasi-static
start beyond a buckling load (an unstable equilibrium: the same growth rate along the same
amplitude). Both read their limits from ``symgen.policy`` and measure singularity the same way
(smallest / largest singular value of the closure Jacobian in the dependent rigid coordinates)."""

from __future__ import annotations

import math
import shutil
import subprocess

import pytest

from symgen.api import mechanism, write_c
from symgen.backends.c.build import compile_executable
from symgen.errors import SimulationError
from symgen.numerics.csolver import simulate_c
from symgen.numerics import checks
from symgen.numerics.simulate import simulate
from test_cli import FOUR_BAR_TOGGLE
from tests.test_hard_cases import MU, P_CR, write_column

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")

SINGULAR = "the rigid mechanism reached a singular position"  # not "may have reached"
TOGGLE = math.acos(0.375)  # the crank angle where coupler and rocker align (tests/test_cli.py)
ELASTIC = FOUR_BAR_TOGGLE.replace(
    'name = "coupler"\nlength = 1.0\nrigid = true',
    'name = "coupler"\nlength = 1.0\nlambda = 1e4\nmu = 2.0\n'
    'frame = "pinned-pinned"\naxial_modes = 2\ntransverse_modes = 2',
)
SCENES = {
    "rigid": (FOUR_BAR_TOGGLE, []),
    "elastic": (ELASTIC, ["effects.axial=inextensible", "initial.deformation=quasi-static"]),
}


def _executable(path, over, folder):
    """The emitted C simulator (``symgen emit-c``: ``PREFIX_sim``) of a scene, compiled."""
    src = write_c(path, folder / "c", over)
    name = mechanism(path, over).scene.name
    return compile_executable(
        [src / f"{name}.c", src / f"{name}_jac.c", src / f"{name}_solver.c", src / f"{name}_sim.c"],
        folder / f"{name}_sim",
        include=[src],
    )


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """{name: (scene path, overrides, the C executable)} of the toggle four-bars."""
    d = tmp_path_factory.mktemp("parity")
    out = {}
    for name, (text, over) in SCENES.items():
        path = d / f"{name}.toml"
        path.write_text(text)
        exe = _executable(path, over, d / name)
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
    # and the C solver in process (simulate --solver c): the same verdict after the same output
    with pytest.raises(SimulationError, match="singular position") as stop:
        simulate_c(mechanism(path, over))
    assert stop.value.partial.tau[-1] == pytest.approx(last_py, abs=1e-9) and not stop.value.partial.complete


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


# ---------------------------------------------------------------------------- beyond buckling
# The column of tests/test_hard_cases.py (pinned, its far end on a slider along its axis, mu =
# 0.01, a small lateral load as imperfection) under an axial end load ratio * pi^2 mu, with its
# axial amplitudes free (7 functions: their stiff axial rows are in the eigenvalue problem) or
# held by inextensibility (dependent coordinates). One C build per case, from the stable scene;
# the load is changed with --set (the parameter load1_axial).
COLUMNS = {"true": 7, "inextensible": 3}
PROBE = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "column_solver.h"
static column_solver s;
/* probe NAME VALUE: the solver's start with one parameter changed; prints the return code, the
   divergence rate (all digits) and the message */
int main(int argc, char **argv)
{
    double p[column_N_P];
    int rc;
    memcpy(p, column_parameter_defaults, sizeof p);
    if (argc != 3 || column_parameter_index(argv[1]) < 0) return 2;
    p[column_parameter_index(argv[1])] = strtod(argv[2], NULL);
    rc = column_solver_init(&s, p, 0.0, -1.0, -1.0);
    printf("%d %.17g\n%s\n", rc, s.divergence_rate, s.message);
    return 0;
}
"""


@pytest.fixture(scope="module", params=sorted(COLUMNS))
def column(request, tmp_path_factory):
    """{folder, axial, C simulator, C sources} of the column with effects.axial = param."""
    axial = request.param
    d = tmp_path_factory.mktemp(f"column_{axial}")
    over = [f"effects.axial={axial}"]
    path = write_column(d, 0.9, COLUMNS[axial])  # the C is emitted from a stable start
    exe = _executable(path, over, d / "sim")
    return {"folder": d, "axial": axial, "exe": exe, "src": write_c(path, d / "c", over)}


def _python_divergence(monkeypatch, column, ratio):
    """(tau of the failure, message, (rate, coordinate) of the divergence check) of the Python run."""
    seen = []
    check = checks.divergent_deformation

    def spy(mech, *args):
        seen.append(check(mech, *args))
        return seen[-1]

    monkeypatch.setattr(checks, "divergent_deformation", spy)
    axial = column["axial"]
    tau, msg, _ = _python(write_column(column["folder"], ratio, COLUMNS[axial]), [f"effects.axial={axial}"])
    monkeypatch.undo()
    assert len(seen) == 1, "the Python start ran no divergence check"
    return tau, msg, seen[0]


def _load(ratio):
    return f"load1_axial={-ratio * P_CR!r}"


def _c_probe(column, ratio):
    """(return code, divergence rate, message) of the C solver's start (the probe, built once)."""
    if "probe" not in column:
        d, src = column["folder"], column["src"]
        (d / "probe.c").write_text(PROBE)
        column["probe"] = compile_executable(
            [src / "column.c", src / "column_jac.c", src / "column_solver.c", d / "probe.c"], d / "probe", include=[src]
        )
    out = subprocess.run(
        [str(column["probe"]), *_load(ratio).split("=")], capture_output=True, text=True, timeout=60
    ).stdout
    head, message = out.split("\n", 1)
    rc, rate = head.split()
    return int(rc), float(rate), message.strip()


@pytest.mark.parametrize("ratio", [0.9, 0.99])
def test_quasi_static_start_below_buckling(column, monkeypatch, ratio):
    """Below the Euler load pi^2 mu the quasi-static state is stable: both start and run."""
    tau, msg, (rate, coord) = _python_divergence(monkeypatch, column, ratio)
    assert (tau, msg, rate, coord) == (None, "complete", 0.0, "")
    code, err, _ = _c(column["exe"], "--set", _load(ratio))
    assert code == 0 and err == "", err
    assert _c_probe(column, ratio)[:2] == (0, 0.0)


@pytest.mark.parametrize("ratio, amplitude", [(1.01, "g_col_1"), (1.1, "g_col_1"), (5.0, "g_col_2")])
def test_quasi_static_start_beyond_buckling(column, monkeypatch, ratio, amplitude):
    """Beyond it the quasi-static state is an unstable equilibrium: both refuse to start at tau = 0
    with the same growth rate (pi^2 sqrt(mu) sqrt(ratio - 1) for the first mode; measured to agree
    to 8e-11 with free axial amplitudes and 2e-14 inextensible) along the same amplitude (the
    second sine beyond four times the load, where the second mode diverges faster)."""
    tau, msg, (rate, coord) = _python_divergence(monkeypatch, column, ratio)
    assert tau == 0.0 and "quasi-static state is unstable" in msg
    assert coord == amplitude
    if ratio < 4:
        assert rate == pytest.approx(math.pi**2 * math.sqrt(MU) * math.sqrt(ratio - 1), rel=2e-3)
    code, err, _ = _c(column["exe"], "--set", _load(ratio))
    assert code == 1 and "at tau = 0:" in err, err
    same = (
        f"the quasi-static state is unstable: the deformation grows at rate {rate:.3g} (per unit tau) along {coord}, "
        f"a load beyond a buckling load"
    )
    assert same in msg and same in err, (msg, err)
    rc, c_rate, c_msg = _c_probe(column, ratio)
    assert rc == 1 and c_msg in err
    assert c_rate == pytest.approx(rate, rel=1e-8)


# ---------------------------------------------------------------------------- run settings
@pytest.mark.parametrize(
    "rtol, atol",
    [
        (1e-15, 1e-10),
        (1e-14, 1e-10),
        (0.5, 1e-10),
        (1.0, 1e-10),
        (1e-8, 1e-21),
        (1e-8, 1e-20),
        (1e-8, 0.5),
        (1e-8, 1.0),
    ],
)
def test_the_c_driver_takes_the_tolerances_python_takes(built, rtol, atol):
    """One source of the run-setting bounds (symgen.scene.limits), rendered into the C driver:
    the same tolerances are refused (exit 2, naming the option) or accepted by both."""
    from symgen.errors import SceneError
    from symgen.scene import load_scene

    path, over, exe = built["rigid"]
    try:
        load_scene(path, [*over, f"simulation.rtol={rtol!r}", f"simulation.atol={atol!r}"])
        python_ok = True
    except SceneError as err:
        python_ok = False
        assert ("rtol" if "rtol" in err.key else "atol") in err.key
    code, err, _ = _c(exe, "--rtol", repr(rtol), "--atol", repr(atol), "--t-end", "0.1", "--step", "0.05")
    assert (code != 2) == python_ok, (rtol, atol, code, err)
    if not python_ok:
        assert "--rtol" in err or "--atol" in err, err
