"""The emitted C (symgen emit-c): strict C99 / C++ compiles, values and Jacobians against the
CasADi Functions, consistent start and driver runs against the Python path (IDAS), two models
in one program, CMake add_subdirectory, odd scene names, the CLI."""

from __future__ import annotations

import ctypes
import dataclasses
import subprocess
import textwrap

import numpy as np
import pytest

from symgen.backends.c.render import RUNTIME_FILES, runtime_files

from c_support import (
    EXAMPLES,
    ROOT,
    WORK,
    closure_columns,
    idas_reference,
    library,
    mechanism,
    needs_cc,
    needs_cxx,
    parameter_names,
    run_sim,
    simulator,
    sources,
)

NAMES = sorted(EXAMPLES)
DP = ctypes.POINTER(ctypes.c_double)
VALUE_FUNCTIONS = ("phi", "phid", "phidd", "res", "out", "energy", "closure")
JACOBIANS = ("phi", "phid", "phidd", "res")


def _ptr(x: np.ndarray):
    return x.ctypes.data_as(DP)


# ---------------------------------------------------------------------------- generation
def test_radau_constants():
    """The Radau IIA constants baked into the solver satisfy their defining identities."""
    from symgen.backends.c import radau

    A = np.array(radau.A, dtype=float)
    c = np.array(radau.C, dtype=float)
    T, TI = np.array(radau.T, dtype=float), np.array(radau.TI, dtype=float)
    g, al, be = float(radau.GAMMA), float(radau.ALPHA), float(radau.BETA)
    np.testing.assert_allclose(A.sum(axis=1), c, atol=1e-15)  # row sums = nodes
    np.testing.assert_allclose(c, [(4 - 6**0.5) / 10, (4 + 6**0.5) / 10, 1.0], atol=1e-16)
    np.testing.assert_allclose(T @ TI, np.eye(3), atol=1e-14)
    block = np.array([[g, 0, 0], [0, al, -be], [0, be, al]])
    np.testing.assert_allclose(TI @ np.linalg.inv(A) @ T, block, atol=1e-12)
    dd = np.array(radau.DD, dtype=float)
    np.testing.assert_allclose([dd @ c, dd @ c**2, dd @ c**3], [-1, 0, 0], atol=1e-13)
    # order conditions of the collocation method: A c^(k-1) = c^k / k, k = 1..3
    for k in (1, 2, 3):
        np.testing.assert_allclose(A @ c ** (k - 1), c**k / k, atol=1e-15)


@pytest.mark.parametrize("name", NAMES)
def test_preamble_and_symbols(name):
    scene_hash = mechanism(name).scene.hash
    folder = sources(name)
    files = sorted(p.name for p in folder.iterdir())
    generated = ["CMakeLists.txt", f"{name}.h", f"{name}.c", f"{name}_jac.c", f"{name}_solver.h", f"{name}_solver.c"]
    generated.append(f"{name}_sim.c")
    assert files == sorted(generated + list(RUNTIME_FILES))
    for runtime_file, text in runtime_files().items():  # the runtime: copied, not rendered
        assert (folder / runtime_file).read_text() == text
    for path in (folder / f for f in generated):
        text = path.read_text()
        head = text[:3000]
        assert "DO NOT EDIT" in head and scene_hash in head and "symgen" in head, path.name
        for fn in ("phi", "res", "res_jac", "out"):
            assert f"{name}_{fn}: " in head, (path.name, fn)  # operation count of each function
    header = (folder / f"{name}.h").read_text()
    assert f"#ifndef SYMGEN_{name}_H" in header and 'extern "C"' in header
    # every external symbol of the library carries the prefix
    lib = ctypes.CDLL  # noqa: F841  (the library is loaded by the numeric tests)
    so = WORK / f"lib{name}.so"
    library(name)
    nm = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True)
    if nm.returncode == 0:
        syms = [line.split()[-1] for line in nm.stdout.splitlines() if line.split()[1] in "TDRB"]
        assert syms and all(s.startswith(name + "_") for s in syms if not s.startswith("_")), syms


@needs_cc
@needs_cxx
@pytest.mark.parametrize("name", NAMES)
def test_compiles_strict_c99_and_cxx(name):
    folder = sources(name)
    for src in (f"{name}.c", f"{name}_jac.c", f"{name}_solver.c", f"{name}_sim.c"):
        for cmd in (
            ["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1"],
            ["g++", "-x", "c++", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1"],
        ):
            proc = subprocess.run(
                [*cmd, "-c", str(folder / src), "-o", str(WORK / f"{src}.{cmd[0]}.o")], capture_output=True, text=True
            )
            assert proc.returncode == 0, f"{cmd[0]} {src}:\n{proc.stderr}"


# ---------------------------------------------------------------------------- values vs CasADi
@needs_cc
@pytest.mark.parametrize("name", NAMES)
def test_values_and_jacobians_match_casadi(name):
    """Every function and Jacobian at 100 random states and parameter sets, to 1e-12 of the
    largest entry of the function's value (round-off of both codes)."""
    import casadi as ca

    mech = mechanism(name)
    lib = library(name)
    n, m, npar = mech.n, mech.m, len(mech.p)
    f = mech.f
    sx = [ca.SX.sym(k, s) for k, s in (("t", 1), ("q", n), ("v", n), ("a", n), ("lam", m), ("p", npar))]
    w = ca.vertcat(*sx[1:5])
    jac = {k: ca.Function(f"J{k}", sx, [ca.jacobian(f[k](*sx), w)]) for k in JACOBIANS}
    rng = np.random.default_rng(12)
    worst = {}
    for _ in range(100):
        t = rng.uniform(0, 4 * np.pi)
        q, v, a = (rng.uniform(-1, 1, n) for _ in range(3))
        lam = rng.uniform(-5, 5, m)
        p = mech.p * rng.uniform(0.7, 1.3, npar) + rng.uniform(-0.05, 0.05, npar)
        args = [ctypes.c_double(t), _ptr(q), _ptr(v), _ptr(a), _ptr(lam), _ptr(p)]
        for k in VALUE_FUNCTIONS:
            ref = np.array(f[k](t, q, v, a, lam, p)).ravel()
            out = np.full(max(ref.size, 1), np.nan)
            getattr(lib, f"{name}_{k}")(*args, _ptr(out))
            scale = max(np.abs(ref).max(initial=0.0), 1e-300)
            worst[k] = max(worst.get(k, 0.0), np.abs(out[: ref.size] - ref).max(initial=0.0) / scale)
        for k in JACOBIANS:
            ref = np.array(jac[k](t, q, v, a, lam, p))
            out = np.full(ref.size, np.nan)
            getattr(lib, f"{name}_{k}_jac")(*args, _ptr(out))
            scale = max(np.abs(ref).max(initial=0.0), 1e-300)
            worst[k + "_jac"] = max(worst.get(k + "_jac", 0.0), np.abs(out.reshape(ref.shape) - ref).max() / scale)
    assert max(worst.values()) < 1e-12, worst


# ---------------------------------------------------------------------------- solver
def _solver(name: str, p=None):
    lib = library(name)
    lib[f"{name}_solver_sizeof"].restype = ctypes.c_ulong
    buf = ctypes.create_string_buffer(int(lib[f"{name}_solver_sizeof"]()))
    pp = None if p is None else _ptr(np.ascontiguousarray(p, dtype=float))
    rc = lib[f"{name}_solver_init"](buf, pp, ctypes.c_double(0.0), ctypes.c_double(1e-8), ctypes.c_double(1e-10))
    return lib, buf, rc


@needs_cc
@pytest.mark.parametrize("name", NAMES)
def test_consistent_start_matches_python(name):
    """Assembly Newton from the baked guess, quasi-static start (four-bar), velocities,
    accelerations and multipliers: the same state as Mechanism.initial_state."""
    mech = mechanism(name)
    q0, v0, a0, lam0, _ = mech.initial_state(0.0)
    lib, buf, rc = _solver(name)
    assert rc == 0
    q, v, a = (np.zeros(mech.n) for _ in range(3))
    lam = np.zeros(max(mech.m, 1))
    lib[f"{name}_solver_state"](buf, _ptr(q), _ptr(v), _ptr(a), _ptr(lam))
    for got, ref in ((q, q0), (v, v0), (a, a0), (lam[: mech.m], lam0)):
        np.testing.assert_allclose(got, ref, rtol=1e-8, atol=1e-9 * max(1.0, np.abs(ref).max()))


@needs_cc
def test_changed_parameters_reassemble_in_c():
    """A parameter changed in C (crank start angle of the four-bar) gives the start the Python
    path computes for the scene with that value: re-assembly and quasi-static state in C."""
    from symgen.api import mechanism as python_mechanism

    name = "four_bar"
    names = parameter_names(name)
    p = mechanism(name).p.copy()
    p[names.index("theta0")] = 0.7
    lib, buf, rc = _solver(name, p)
    assert rc == 0
    ref = python_mechanism(EXAMPLES[name], ["driver.initial=0.7"])
    q0, v0, *_ = ref.initial_state(0.0)
    q, v = np.zeros(ref.n), np.zeros(ref.n)
    lib[f"{name}_solver_state"](buf, _ptr(q), _ptr(v), None, None)
    np.testing.assert_allclose(q, q0, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(v, v0, rtol=1e-7, atol=1e-9)


@needs_cc
def test_assembly_failure_is_reported():
    lib, buf, rc = _solver("slider_crank", p=_bad_slider_crank())
    assert rc != 0
    msg = ctypes.string_at(ctypes.addressof(buf) + _message_offset("slider_crank", lib, buf)).decode()
    assert "cannot be assembled" in msg


def _bad_slider_crank():
    names = parameter_names("slider_crank")
    p = mechanism("slider_crank").p.copy()
    p[names.index("py_B")] = 5.0  # the slider's line out of the rod's reach
    return p


def _message_offset(name, lib, buf) -> int:
    raw = bytes(buf)
    k = raw.find(b"at tau = ")
    assert k >= 0, "no message in the solver struct"
    return k


@needs_cc
@pytest.mark.parametrize("name,args", [("slider_crank", ("--rtol", "1e-10", "--atol", "1e-12")), ("four_bar", ())])
def test_driver_matches_idas_over_two_turns(name, args):
    """The C driver's CSV over the scene's two crank turns against IDAS at converged
    tolerances: every output within 1e-5 of its peak (closure columns: both at round-off).
    The slider-crank rings axially at ~212 rad per unit tau from rest: resolved with tight
    tolerances; the four-bar runs at the scene's own tolerances."""
    tau, ref = idas_reference(name)
    header, data, stats = run_sim(simulator(name), *args)
    assert header == ["tau", *mechanism(name).info.outputs]
    assert data.shape == (len(tau), 1 + ref.shape[1]), stats
    np.testing.assert_allclose(data[:, 0], tau, rtol=0, atol=1e-12)
    clo = closure_columns(name)
    for k in range(ref.shape[1]):
        if k in clo:
            assert np.abs(data[:, 1 + k]).max() < 1e-12 and np.abs(ref[:, k]).max() < 1e-12
            continue
        peak = np.abs(ref[:, k]).max()
        err = np.abs(data[:, 1 + k] - ref[:, k]).max() / peak
        assert err < 1e-5, f"{header[1 + k]}: {err:.2e} of peak ({stats})"


@needs_cc
def test_driver_set_and_bad_usage():
    exe = simulator("slider_crank")
    header, data, _ = run_sim(exe, "--t-end", "0.5", "--step", "0.25", "--set", "lambda_rod=20000")
    assert data.shape == (3, 5)
    proc = subprocess.run([str(exe), "--set", "nope=1"], capture_output=True, text=True)
    assert proc.returncode == 2 and "no parameter" in proc.stderr
    proc = subprocess.run([str(exe), "--set", "py_B=5"], capture_output=True, text=True)
    assert proc.returncode == 1 and "cannot be assembled" in proc.stderr
    assert proc.stdout.strip() == "tau,eta_mid,eps_ax,torque,closure"


@needs_cc
def test_bar_beyond_range_stops_like_python():
    """A rod too soft for its load buckles: C and Python stop at the same output, same reason."""
    from symgen.api import simulate_scene
    from symgen.errors import SimulationError

    with pytest.raises(SimulationError, match="beyond the range") as err:
        simulate_scene(EXAMPLES["slider_crank"], ["bodies.rod.mu=0.01"])
    partial = err.value.partial
    proc = subprocess.run([str(simulator("slider_crank")), "--set", "mu_rod=0.01"], capture_output=True, text=True)
    assert proc.returncode == 1 and "beyond the range of the model" in proc.stderr and "'rod'" in proc.stderr
    rows = proc.stdout.strip().splitlines()[1:]
    assert len(rows) == len(partial.tau)
    assert float(rows[-1].split(",")[0]) == pytest.approx(partial.tau[-1], abs=1e-12)


@needs_cc
def test_changed_stiffness_run_matches_python():
    """--set lambda_rod in the C driver = the scene overridden in Python (half a turn)."""
    from symgen.api import simulate_scene

    res = simulate_scene(EXAMPLES["slider_crank"], ["bodies.rod.lambda=9000"], t_end=1.5, rtol=1e-11, atol=1e-13)
    _, data, _ = run_sim(
        simulator("slider_crank"), "--t-end", "1.5", "--set", "lambda_rod=9000", "--rtol", "1e-10", "--atol", "1e-12"
    )
    assert data.shape[0] == len(res.tau)
    for k in (0, 1, 2):
        peak = np.abs(res.outputs[:, k]).max()
        assert np.abs(data[:, 1 + k] - res.outputs[:, k]).max() < 1e-5 * peak


def _rigid_slider_crank(tmp_path):
    text = EXAMPLES["slider_crank"].read_text()
    elastic = (
        'lambda = 18246.0\nmu = 0.495\nframe = "pinned-pinned"\naxial_modes = 1\ntransverse_modes = 1\n'
        'axial_shapes = "stress-free"\ntransverse_shapes = "modes"'
    )
    assert elastic in text
    text = text.replace(elastic, "rigid = true").replace('[effects]\nstrain = "linear"\n', "")
    text = text.replace(
        'eta_mid = { kind = "chord_deflection", body = "rod", at = 0.5 }\n'
        'eps_ax = { kind = "chord_elongation", body = "rod" }\n',
        'rod = { kind = "angle", body = "rod" }\n',
    )
    path = tmp_path / "rigid.toml"
    path.write_text(text)
    return path, ["simulation.cycles=0.25"]


def _pendulum(tmp_path):
    from test_energy import write_pendulum

    return write_pendulum(tmp_path, strain="linear", t_end=2.0, quasi_static=True, rtol=1e-8, atol=1e-10), []


@needs_cc
@needs_cxx
@pytest.mark.parametrize(
    "build", [_rigid_slider_crank, _pendulum], ids=["rigid-no-differential-state", "pendulum-no-closure-torque-driver"]
)
def test_edge_scenes_compile_and_match_python(build, tmp_path):
    """No differential state (a rigid driven slider-crank) and no closure at all (a free elastic
    pendulum under a torque driver, quasi-static start): zero-size arrays compile, runs agree."""
    from symgen.api import mechanism as python_mechanism
    from symgen.api import write_c
    from symgen.numerics.simulate import simulate
    from symgen.scene import load_scene

    path, overrides = build(tmp_path)
    scene = load_scene(path, overrides)
    out = write_c(scene, tmp_path / "c")
    n = scene.name
    files = [str(out / f) for f in (f"{n}.c", f"{n}_jac.c", f"{n}_solver.c", f"{n}_sim.c")]
    for cmd in (["gcc", "-std=c99"], ["g++", "-x", "c++"]):
        proc = subprocess.run(
            [
                *cmd,
                "-Wall",
                "-Wextra",
                "-pedantic",
                "-Werror",
                "-O1",
                f"-I{out}",
                *files,
                "-o",
                str(tmp_path / "sim"),
                "-lm",
            ],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 0, proc.stderr
    _, data, stats = run_sim(tmp_path / "sim", "--rtol", "1e-10", "--atol", "1e-12")
    res = simulate(python_mechanism(scene), rtol=1e-11, atol=1e-12)
    assert data.shape == (len(res.tau), 1 + res.outputs.shape[1])
    for k, o in enumerate(scene.outputs):
        if o.kind == "closure_residual":
            continue
        peak = max(np.abs(res.outputs[:, k]).max(), 1e-12)
        assert np.abs(data[:, 1 + k] - res.outputs[:, k]).max() < 1e-6 * peak, (o.name, stats)


# ---------------------------------------------------------------------------- linking, CMake
MAIN_BOTH = r"""
#include <stdio.h>
#include <math.h>
#include "slider_crank_solver.h"
#include "four_bar_solver.h"
static slider_crank_solver a;
static four_bar_solver b;
int main(void)
{
    double out1[slider_crank_N_OUT], out2[four_bar_N_OUT];
    if (slider_crank_solver_init(&a, NULL, 0.0, 0, 0) || four_bar_solver_init(&b, NULL, 0.0, 0, 0)) return 1;
    if (slider_crank_solver_advance(&a, 0.1) || four_bar_solver_advance(&b, 0.1)) return 2;
    slider_crank_solver_outputs(&a, out1);
    four_bar_solver_outputs(&b, out2);
    printf("%.17g %.17g\n", out1[0], out2[0]);
    return !(isfinite(out1[0]) && isfinite(out2[0]));
}
"""


@needs_cc
def test_both_examples_link_into_one_program():
    src = {n: sources(n) for n in NAMES}
    main = WORK / "both_main.c"
    main.write_text(MAIN_BOTH)
    files = [main] + [src[n] / f for n in NAMES for f in (f"{n}.c", f"{n}_jac.c", f"{n}_solver.c")]
    exe = WORK / "both"
    cmd = [
        "gcc",
        "-std=c99",
        "-Wall",
        "-Wextra",
        "-pedantic",
        "-Werror",
        "-O1",
        *[f"-I{src[n]}" for n in NAMES],
        *map(str, files),
        "-o",
        str(exe),
        "-lm",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    # the same first output as the single-model drivers at tau = 0.1
    for n, got in zip(("slider_crank", "four_bar"), map(float, run.stdout.split())):
        _, data, _ = run_sim(simulator(n), "--t-end", "0.1", "--step", "0.1")
        assert got == pytest.approx(data[-1, 1], rel=1e-12, abs=1e-300)


@needs_cc
@pytest.mark.skipif(subprocess.run(["which", "cmake"], capture_output=True).returncode != 0, reason="no cmake")
def test_cmake_add_subdirectory_of_both_models():
    proj = WORK / "cmake_parent"
    proj.mkdir(exist_ok=True)
    (proj / "main.c").write_text(MAIN_BOTH)
    (proj / "CMakeLists.txt").write_text(
        textwrap.dedent(f"""\
        cmake_minimum_required(VERSION 3.10...3.31)
        project(parent C)
        set(four_bar_BUILD_SIM OFF CACHE BOOL "" FORCE)
        add_subdirectory({sources("slider_crank")} slider_crank)
        add_subdirectory({sources("four_bar")} four_bar)
        add_executable(app main.c)
        target_link_libraries(app PRIVATE slider_crank four_bar)
        """)
    )
    build = proj / "build"
    for cmd in (
        ["cmake", "-S", str(proj), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release"],
        ["cmake", "--build", str(build), "-j", "2"],
    ):
        proc = subprocess.run(cmd, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert (build / "slider_crank" / "slider_crank_sim").exists()  # the driver target
    assert not (build / "four_bar" / "four_bar_sim").exists()  # switched off
    run = subprocess.run([str(build / "app")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr


# ---------------------------------------------------------------------------- names, CLI
ODD_NAMES = [
    "slider crank",
    "int",
    "class",
    "a;b",
    'x); system("rm"',
    "ünïcode",
    "crank\u00e9",
    "1st",
    "__reserved",
    "_Reserved",
    "",
    "a" * 64,
    "a\nb",
    "/*x*/",
]


@pytest.mark.parametrize("bad", ODD_NAMES)
def test_odd_scene_names_are_rejected(bad, tmp_path):
    from symgen.api import write_c
    from symgen.errors import SceneError

    scene = dataclasses.replace(mechanism("slider_crank").scene, name=bad)
    with pytest.raises(SceneError, match="scene.name"):
        write_c(scene, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_strings_are_escaped_in_c_and_xml():
    from symgen.backends.c.names import c_comment, c_string, xml_attr

    for text in ODD_NAMES + ['quote " back \\ ??= trigraph', "*/ end", "é\u2028"]:
        lit = c_string(text)
        assert lit.isascii() and "\n" not in lit and "??" not in lit[1:-1].replace("\\?", "")
        com = c_comment(text)
        assert com.isascii() and "*/" not in com and "/*" not in com and "\n" not in com
        assert "<" not in xml_attr(text) and '"' not in xml_attr(text)


@needs_cc
def test_escaped_strings_compile_and_round_trip(tmp_path):
    from symgen.backends.c.names import c_string

    texts = ["a;b", 'q"uote', "back\\slash", "ünï", "??=", "tab\there"]
    src = tmp_path / "s.c"
    src.write_text(
        "#include <stdio.h>\nint main(void)\n{\n"
        + "".join(f"    puts({c_string(t)});\n" for t in texts)
        + "    return 0;\n}\n"
    )
    exe = tmp_path / "s"
    proc = subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", str(src), "-o", str(exe)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    out = subprocess.run([str(exe)], capture_output=True).stdout.decode("utf-8").splitlines()
    assert out == texts


def test_cli_emit_c_and_errors(tmp_path, capsys):
    from symgen.cli import main

    out = tmp_path / "sc_c"
    assert main(["emit-c", str(EXAMPLES["slider_crank"]), "-o", str(out)]) == 0
    assert (out / "slider_crank_solver.c").read_text() == (
        sources("slider_crank") / "slider_crank_solver.c"
    ).read_text()
    # a scene with an odd name (a C keyword): exit 2, a message naming the key, no folder
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLES["slider_crank"].read_text().replace('name = "slider_crank"', 'name = "int"'))
    assert main(["emit-c", str(bad), "-o", str(tmp_path / "bad_c")]) == 2
    assert "scene.name" in capsys.readouterr().err
    assert not (tmp_path / "bad_c").exists()
    bad.write_text(EXAMPLES["slider_crank"].read_text().replace('name = "slider_crank"', 'name = "a;b c"'))
    assert main(["emit-fmu", str(bad), "-o", str(tmp_path / "bad.fmu")]) == 2
    assert not (tmp_path / "bad.fmu").exists()
    assert main(["emit-fmu", str(EXAMPLES["slider_crank"]), "-o", str(tmp_path / "x.zip")]) == 2
    assert not list(tmp_path.glob("x*")) and not list(tmp_path.glob(".*"))


def test_emitted_folder_has_the_mode_of_any_output(tmp_path):
    """write_tree renders into a temporary sibling and renames it: the folder gets the mode
    mkdir gives (0777 & ~umask), not mkdtemp's 0700."""
    import os
    from symgen.backends.c import write_tree

    old = os.umask(0o027)
    try:
        out = write_tree({"a.c": "int a;\n", "sub/b.h": "int b;\n"}, tmp_path / "out_c")
    finally:
        os.umask(old)
    assert os.stat(out).st_mode & 0o777 == 0o750
    assert os.stat(out / "a.c").st_mode & 0o777 == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out_c"]


def test_generated_c_is_what_emit_c_writes():
    """generated/<scene>/c/ is the output of emit-c (staleness itself: tests/test_generated.py)."""
    for name in NAMES:
        stored = ROOT / "generated" / name / "c"
        assert sorted(p.name for p in stored.iterdir()) == sorted(p.name for p in sources(name).iterdir())


@pytest.mark.parametrize("cached", [False, True], ids=["cold-cache", "warm-cache"])
def test_emit_c_derives_once_and_chooses_the_partition_once(cached, tmp_path, monkeypatch):
    """``symgen emit-c`` derives the SymPy model once (the start plan runs on the CasADi Functions
    of that model, or of the cache), and the C gets the partitions of the Python start: one
    choice at the guess, one at the assembled position, none made again for the emitter."""
    import symgen.model.derive as derive_mod
    from symgen.api import write_c
    from symgen.backends.casadi.pipeline import compile_scene
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene import load_scene

    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    scene = load_scene(EXAMPLES["slider_crank"])
    if cached:
        compile_scene(scene)
    calls = {"derive": 0, "choose_partition": 0}
    derive, choose = derive_mod.derive, Mechanism.choose_partition

    def counted_derive(sc):
        calls["derive"] += 1
        return derive(sc)

    def counted_choose(self, t, q):
        calls["choose_partition"] += 1
        return choose(self, t, q)

    monkeypatch.setattr(derive_mod, "derive", counted_derive)
    monkeypatch.setattr(Mechanism, "choose_partition", counted_choose)
    out = write_c(scene, tmp_path / "c")
    assert calls == {"derive": 1, "choose_partition": 2}
    assert (out / "slider_crank_solver.c").is_file()


def test_printer_writes_no_posix_math_macros():
    """SymPy's C printer writes pi/4, pi/2, sqrt(2), 1/pi as M_PI_4, M_PI_2, M_SQRT2, M_1_PI (POSIX,
    not C99: the emitted C of a slot guide's contact-slope inner products failed to compile with
    -std=c99). symgen's printer writes double literals and libm calls."""
    import sympy as sp

    from symgen.backends.c.printer import CPrinter

    x = sp.Symbol("x")
    pi = "3.141592653589793"
    for expr, text in (
        (sp.pi / 4 * x, f"(0.25)*{pi}*x"),
        (sp.pi / 2, f"(0.5)*{pi}"),
        (sp.sqrt(2) * x, "sqrt(2.0)*x"),
        (x / sp.pi, f"x/{pi}"),
        (2 / sp.sqrt(sp.pi), f"2.0/sqrt({pi})"),
    ):
        assert CPrinter({x: "x"}).doprint(expr) == text
