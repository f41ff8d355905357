"""The emitted C under AddressSanitizer and UndefinedBehaviorSanitizer (with float-cast-overflow,
every report fatal): every example runs a short simulation clean, and the driver rejects bad
arguments by name (exit 2, nothing on stdout) without undefined behaviour; the solver API and
``_parameter_valid`` reject what the Python policy rejects (symgen.ir.parameters.parameter_records,
symgen.scene.model limits), probed from a sanitized C harness.

The slider-crank runs in the default suite; the other examples (larger C, slower to compile
with sanitizers) are marked slow.
"""

from __future__ import annotations

import functools
import math
import os
import shutil
import subprocess

import numpy as np
import pytest

from c_support import ALL_EXAMPLES, WORK, mechanism, sources

SANITIZE = (
    "-fsanitize=address,undefined,float-cast-overflow",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
    "-g",
    "-O1",
)
STRICT = ("-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")
# a sanitizer report exits with these (the driver's own statuses are 0, 1 and 2)
ENV = {**os.environ, "ASAN_OPTIONS": "exitcode=86:detect_leaks=1", "UBSAN_OPTIONS": "exitcode=87:print_stacktrace=1"}
REPORTS = ("runtime error", "Sanitizer", "ERROR:")
DEFAULT = "slider_crank"
NAMES = [pytest.param(n, marks=() if n == DEFAULT else pytest.mark.slow) for n in ALL_EXAMPLES]


@functools.cache
def _unavailable() -> str | None:
    """Why sanitized programs cannot be built and run here, or None."""
    cc = shutil.which("gcc")
    if cc is None:
        return "gcc is not installed"
    folder = WORK / "sanitizer_probe"
    folder.mkdir(exist_ok=True)
    (folder / "probe.c").write_text('#include <stdio.h>\nint main(void) { puts("ok"); return 0; }\n')
    proc = subprocess.run(
        [cc, *SANITIZE, str(folder / "probe.c"), "-o", str(folder / "probe")], capture_output=True, text=True
    )
    if proc.returncode != 0:
        return f"gcc cannot build with -fsanitize=address,undefined (sanitizer runtime missing?): {proc.stderr[:300]}"
    run = subprocess.run([str(folder / "probe")], capture_output=True, text=True, env=ENV, timeout=60)
    if run.returncode != 0 or run.stdout.strip() != "ok":
        return f"sanitized programs do not run here (e.g. ptrace restrictions): {run.stderr[:300]}"
    return None


def _need_sanitizers():
    reason = _unavailable()
    if reason:
        pytest.skip(reason)


def _compile(args: list, output) -> None:
    proc = subprocess.run(
        ["gcc", *STRICT, *SANITIZE, *map(str, args), "-o", str(output)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr


@functools.cache
def _objects(name: str) -> tuple:
    """The model and solver of an example compiled with the sanitizers (once per session)."""
    src = sources(name)
    out = WORK / f"san_{name}"
    out.mkdir(exist_ok=True)
    objs = []
    for unit in (name, f"{name}_jac", f"{name}_solver"):
        _compile(["-c", src / f"{unit}.c", f"-I{src}"], out / f"{unit}.o")
        objs.append(out / f"{unit}.o")
    return tuple(objs)


@functools.cache
def _simulator(name: str):
    src = sources(name)
    exe = WORK / f"san_{name}" / f"{name}_sim"
    _compile([*_objects(name), src / f"{name}_sim.c", f"-I{src}", "-lm"], exe)
    return exe


def _run(exe, *args: str) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(exe), *args], capture_output=True, text=True, env=ENV, timeout=120)
    for word in REPORTS:
        assert word not in proc.stderr, proc.stderr
    assert proc.returncode in (0, 1, 2), proc.stderr
    return proc


def _rows(t_end: float, step: float) -> int:
    """Output rows of a run, the formula of symgen.numerics.simulate."""
    return int(math.floor(t_end / step + 1e-9)) + 1


def _positive_parameter(name: str) -> str:
    """A parameter that must be > 0 (a stiffness group)."""
    return next(p for p in mechanism(name).info.params if p.startswith(("lambda_", "mu_")))


# ------------------------------------------------------------------------------------ driver
@pytest.mark.parametrize("name", NAMES)
def test_short_run_is_clean_under_sanitizers(name):
    """Half a unit of tau at the scene's settings: exit 0, every row finite, no report."""
    _need_sanitizers()
    proc = _run(_simulator(name), "--t-end", "0.5", "--stats")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].split(",") == ["tau", *mechanism(name).info.outputs]
    data = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    step = mechanism(name).scene.simulation.output_step
    assert data.shape[0] == _rows(0.5, step)
    assert np.all(np.isfinite(data))
    np.testing.assert_allclose(data[:, 0], step * np.arange(data.shape[0]), rtol=0, atol=1e-12)


def _bad_arguments(name: str) -> list:
    """(arguments, text the message must contain) of usages the driver rejects."""
    from symgen.ir.parameters import POSITIVE
    from symgen.scene.limits import LIMITS

    MAX_OUTPUT_ROWS = LIMITS["rows"].default
    par = _positive_parameter(name)
    rows = f"more than the limit of {MAX_OUTPUT_ROWS}"
    return [
        (["--bogus"], "unknown option '--bogus'"),
        (["--t-end", "1", "-x"], "unknown option '-x'"),
        (["stray"], "unexpected argument 'stray'"),
        (["--t-end"], "option '--t-end' is missing its value"),
        (["--step", "0.1", "--set"], "option '--set' is missing its value"),
        (["--t-end", "inf"], "--t-end: 'inf' is not a finite number"),
        (["--t-end", "-Infinity"], "--t-end: '-Infinity' is not a finite number"),
        (["--t-end", "nan"], "--t-end: 'nan' is not a finite number"),
        (["--t-end", "1e400"], "--t-end: '1e400' is out of the range of a double"),
        (["--atol", "1e-400"], "--atol: '1e-400' is out of the range of a double"),
        (["--t-end", "1e300"], "longer than the limit of 1e+06"),  # was: (long) of 6e301, undefined
        (["--t-end", "1e300", "--step", "1e300"], "longer than the limit"),  # two rows, 1e300 of tau
        (["--t-end", "1e300", "--max-t-end", "1e301"], rows),
        (["--max-t-end", "0"], "the limit must be > 0"),
        (["--t-end", "1.7976931348623157e308", "--step", "1e-300"], "longer than the limit"),
        (["--t-end", "1.7976931348623157e308", "--step", "1e-300", "--max-t-end", "1.7976931348623157e308"], rows),
        (["--t-end", "1000", "--step", "1e-6"], rows),
        (["--t-end", "2x"], "--t-end: '2x' is not a number"),
        (["--t-end", ""], "--t-end: '' is not a number"),
        (["--t-end", "0"], "--t-end 0: the end time must be > 0"),
        (["--t-end", "-1"], "the end time must be > 0"),
        (["--step", "0"], "--step 0: the output step must be > 0"),
        (["--step", "-0.1"], "the output step must be > 0"),
        (["--t-end", "0.5", "--step", "2"], "--step 2 is longer than the run"),
        (["--rtol", "0"], "--rtol 0: the relative tolerance must be in [1e-14, 1)"),
        (["--rtol", "1"], "the relative tolerance must be in [1e-14, 1)"),
        (["--rtol", "1e300"], "the relative tolerance must be in [1e-14, 1)"),
        (["--rtol", "-1e-8"], "the relative tolerance must be in [1e-14, 1)"),
        (["--atol", "0"], "--atol 0: the absolute tolerance must be in [1e-20, 1)"),
        (["--atol", "nan"], "--atol: 'nan' is not a finite number"),
        (["--max-rows", "0"], "--max-rows 0: give a whole number"),
        (["--max-rows", "2.5"], "--max-rows 2.5: give a whole number"),
        (["--max-rows", "1e300"], "give a whole number"),
        (["--set", "nope=1"], "--set: no parameter named 'nope'; the parameters are: "),
        (["--set", "x" * 300 + "=1"], "no parameter named 'xxx"),
        (["--set", "=1"], "--set '=1': expected NAME=VALUE"),
        (["--set", par], f"--set '{par}': expected NAME=VALUE"),
        (["--set", f"{par}=nan"], f"--set {par}: 'nan' is not a finite number"),
        (["--set", f"{par}=inf"], f"--set {par}: 'inf' is not a finite number"),
        (["--set", f"{par}=1e999"], "out of the range of a double"),
        (["--set", f"{par}=12abc"], f"--set {par}: '12abc' is not a number"),
        (["--set", f"{par}=-1"], f"--set {par}=-1: {par} must be {POSITIVE.text()}"),
        (["--set", f"{par}=0"], f"{par} must be > 0"),
    ]


@pytest.mark.parametrize("name", NAMES)
def test_bad_arguments_are_rejected_by_name_without_undefined_behaviour(name):
    _need_sanitizers()
    exe = _simulator(name)
    for args, text in _bad_arguments(name):
        proc = _run(exe, *args)
        assert proc.returncode == 2, (args, proc.returncode, proc.stderr)
        assert text in proc.stderr, (args, proc.stderr)
        assert "usage:" in proc.stderr and proc.stdout == "", args


def test_row_limit_is_exact_and_can_be_raised():
    """--max-rows N admits a run of exactly N rows and rejects one of N + 1; the loose-rtol
    warning (symgen.scene.limits.RTOL_WARN) does not stop the run."""
    _need_sanitizers()
    from symgen.scene.limits import RTOL_WARN as LOOSE_RTOL

    exe = _simulator(DEFAULT)
    step = mechanism(DEFAULT).scene.simulation.output_step
    n = _rows(0.3, step)
    proc = _run(exe, "--t-end", "0.3", "--max-rows", str(n - 1))
    assert proc.returncode == 2 and f"gives {n} output rows, more than the limit of {n - 1}" in proc.stderr
    proc = _run(exe, "--t-end", "0.3", "--max-rows", str(n))
    assert proc.returncode == 0 and len(proc.stdout.splitlines()) == n + 1
    assert "warning" not in proc.stderr
    proc = _run(exe, "--t-end", "0.1", "--rtol", repr(LOOSE_RTOL * 10))
    assert proc.returncode == 0 and f"warning: --rtol {LOOSE_RTOL * 10:g} is above {LOOSE_RTOL:g}" in proc.stderr


def test_failed_run_is_clean_under_sanitizers():
    """A valid parameter the mechanism cannot assemble with: exit 1, the header only."""
    _need_sanitizers()
    proc = _run(_simulator(DEFAULT), "--set", "py_B=5")
    assert proc.returncode == 1 and "cannot be assembled" in proc.stderr
    assert proc.stdout.strip() == "tau,eta_mid,eps_ax,torque,closure"


# ------------------------------------------------------------------------------------ library
def _c_double(x: float) -> str:
    if math.isnan(x):
        return "NAN"
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    return x.hex()


def _probes(rec) -> list[float]:
    """Values around every bound of a parameter's range, and some that never are valid."""
    xs = [rec.value, 0.0, 1.0, -1.0, 1e300, -1e300, math.nan, math.inf, -math.inf]
    for b in (rec.valid.lower, rec.valid.upper):
        if math.isfinite(b):
            xs += [b, math.nextafter(b, -math.inf), math.nextafter(b, math.inf)]
    return xs


HARNESS = r"""
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "PFX_solver.h"

static PFX_solver s;
static const int probe_k[] = { PROBE_K };
static const double probe_x[] = { PROBE_X };

static void show(const char *what, int rc) { printf("%s|%d|%d|%s\n", what, rc, s.status, s.message); }

int main(void)
{
    double p[PFX_N_P];
    size_t i;
    for (i = 0; i < sizeof(probe_k) / sizeof(probe_k[0]); ++i) {
        printf("valid|%d|%d\n", probe_k[i], PFX_parameter_valid(probe_k[i], probe_x[i]));
    }
    printf("valid|-1|%d\n", PFX_parameter_valid(-1, 1.0));
    printf("valid|%d|%d\n", PFX_N_P, PFX_parameter_valid(PFX_N_P, 1.0));
    printf("null|%d|%d\n", PFX_solver_init(NULL, NULL, 0.0, 0.0, 0.0), PFX_solver_advance(NULL, 1.0));
    show("t0 nan", PFX_solver_init(&s, NULL, NAN, 0.0, 0.0));
    show("rtol nan", PFX_solver_init(&s, NULL, 0.0, NAN, 0.0));
    show("rtol inf", PFX_solver_init(&s, NULL, 0.0, INFINITY, 0.0));
    show("rtol 1", PFX_solver_init(&s, NULL, 0.0, 1.0, 0.0));
    show("atol inf", PFX_solver_init(&s, NULL, 0.0, 0.0, INFINITY));
    memcpy(p, PFX_parameter_defaults, sizeof(p));
    p[PAR] = -1.0;
    show("parameter", PFX_solver_init(&s, p, 0.0, 0.0, 0.0));
    p[PAR] = NAN;
    show("parameter nan", PFX_solver_init(&s, p, 0.0, 0.0, 0.0));
    show("defaults", PFX_solver_init(&s, NULL, 0.0, 0.0, 0.0));
    show("advance inf", PFX_solver_advance(&s, INFINITY));
    show("advance nan", PFX_solver_advance(&s, NAN));
    show("advance 0.05", PFX_solver_advance(&s, 0.05));
    printf("t|%.17g\n", s.t);
    return 0;
}
"""


def test_library_rejects_what_the_python_policy_rejects(tmp_path):
    """_parameter_valid agrees with ParameterRange.contains at and around every bound of every
    parameter; _solver_init / _solver_advance return _SOLVER_BAD_ARGUMENT with a message for
    non-finite or out-of-range times, tolerances and parameters, and a NULL solver (a bad t_out
    leaves the run usable); all of it clean under the sanitizers."""
    _need_sanitizers()
    from symgen.ir.parameters import parameter_records

    name = DEFAULT
    mech = mechanism(name)
    params = list(mech.info.params)
    records = parameter_records(mech.scene, params)
    probes = [(k, x) for k, rec in enumerate(records) for x in _probes(rec)]
    par = params.index(_positive_parameter(name))
    code = (
        HARNESS.replace("PFX", name)
        .replace("PROBE_K", ", ".join(str(k) for k, _ in probes))
        .replace("PROBE_X", ", ".join(_c_double(x) for _, x in probes))
        .replace("PAR", str(par))
    )
    (tmp_path / "harness.c").write_text(code)
    exe = tmp_path / "harness"
    _compile([*_objects(name), tmp_path / "harness.c", f"-I{sources(name)}", "-lm"], exe)
    proc = _run(exe)
    assert proc.returncode == 0, proc.stderr
    lines = [line.split("|") for line in proc.stdout.splitlines()]
    valid = [(int(k), int(v)) for tag, k, v in (x for x in lines if x[0] == "valid")]
    expected = [(k, int(records[k].valid.contains(x))) for k, x in probes] + [(-1, 0), (len(params), 0)]
    assert valid == expected
    calls = {x[0]: (int(x[1]), int(x[2]), x[3]) for x in lines if len(x) == 4}
    bad = 2
    for what, text in (
        ("t0 nan", "t0 = nan is not valid: it must be finite"),
        ("rtol nan", "rtol = nan is not valid"),
        ("rtol inf", "rtol = inf is not valid"),
        ("rtol 1", "rtol = 1 is not valid: it must be in (0, 1.0)"),
        ("atol inf", "atol = inf is not valid"),
        ("parameter", f"{params[par]} = -1 is not valid: it must be > 0"),
        ("parameter nan", f"{params[par]} = nan is not valid"),
    ):
        rc, status, message = calls[what]
        assert (rc, status) == (bad, bad) and message.startswith(text), (what, message)
    assert next(x[1:] for x in lines if x[0] == "null") == [str(bad), str(bad)]
    assert calls["defaults"][:2] == (0, 0)
    for what, text in (("advance inf", "t_out = inf"), ("advance nan", "t_out = nan")):
        rc, status, message = calls[what]
        assert (rc, status) == (bad, 0) and message.startswith(text), (what, message)
    assert calls["advance 0.05"][:2] == (0, 0)
    assert float(next(x[1] for x in lines if x[0] == "t")) == 0.05
