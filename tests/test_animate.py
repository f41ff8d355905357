"""``symgen animate`` and the plot formats.

Oracle of the drawn bars: for one driven cantilever (no loop: the rigid reference is the bar at
the same angle, straight) the drawn point at xi is alpha R(theta) [xi + F zeta(xi), F eta(xi)],
with zeta, eta evaluated here from the amplitudes in the run's state columns and the shape
functions of ``symgen.model.shapes`` (the cantilever's clamped-free eigenfunctions), independently of
the animation's own geometry (CasADi function of the tree kinematics).
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from PIL import Image, ImageChops

from symgen.cli import main
from symgen.model.shapes import axial_basis, transverse_basis

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent

BEAM = """
[scene]
name = "spinning_beam"
[[bodies]]
name = "beam"
length = 1.0
lambda = 1.0e3
mu = 0.8
frame = "cantilever"
axial_modes = 1
transverse_modes = 2
[[joints]]
name = "O"
kind = "pin"
bodies = ["ground", "beam"]
at = [[0.0, 0.0], 0.0]
[driver]
kind = "angle"
body = "beam"
initial = 0.3
rate = 1.0
[initial]
deformation = { beam = { g = [0.04, 0.005] } }
[outputs]
tip = { kind = "deflection", body = "beam", at = 1.0 }
[simulation]
t_end = 1.2
output_step = 0.1
rtol = 1e-8
atol = 1e-10
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("anim")
    scene = d / "beam.toml"
    scene.write_text(BEAM)
    assert main(["simulate", str(scene), "-o", str(d / "run.csv"), "--states", "--plot", str(d / "run.svg")]) == 0
    assert main(["simulate", str(scene), "-o", str(d / "plain.csv"), "--plot", str(d / "plain.pdf")]) == 0
    return d, scene


def frames(path) -> list:
    im = Image.open(path)
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append(im.convert("RGB").copy())
    return out


def test_gif_frames_move_and_show_the_magnified_deformation(run):
    d, scene = run
    for f in ("0", "30"):
        assert main(["animate", str(scene), "-o", str(d / f"m{f}.gif"), "--frames", "5", "--magnify", f]) == 0
    rigid, big = frames(d / "m0.gif"), frames(d / "m30.gif")
    assert len(rigid) == len(big) == 5
    # the mechanism moves: consecutive frames differ
    for a, b in zip(big, big[1:]):
        assert ImageChops.difference(a, b).getbbox() is not None
    # the deformation is drawn: same instant, factor 0 vs 30 -> the bar's pixels differ
    for a, b in zip(rigid, big):
        diff = np.asarray(ImageChops.difference(a, b).convert("L")) > 40
        assert diff.sum() > 200


def test_drawn_bar_is_rigid_line_plus_factor_times_shape_functions(run):
    from symgen.backends.casadi.pipeline import compile_scene
    from symgen.apps.animate import Animator, read_states
    from symgen.numerics.geometry import Geometry, rigid_reference
    from symgen.numerics.mechanism import Mechanism
    from symgen.scene import load_scene

    d, scene_path = run
    scene = load_scene(scene_path, [])
    compiled = compile_scene(scene)
    mech = Mechanism(compiled, scene)
    motion = read_states(d / "run.csv", scene, compiled.info)
    names = list(compiled.info.coordinate_names)
    geom = Geometry(scene, compiled.info)
    P = geom.points(motion.q)
    Pr = geom.points(rigid_reference(mech, motion.tau, motion.q))
    F = 25.0
    anim = Animator(scene, geom, motion.tau, P, Pr, F, "test")
    ba, bt = axial_basis("complete", 1), transverse_basis("cantilever", "modes", 2)
    xi = np.linspace(0, 1, 41)
    try:
        for k in (0, 5, len(motion.tau) - 1):
            anim.draw(k)
            x, y = (np.asarray(a) for a in anim.lines["beam"].get_data())
            q = dict(zip(names, motion.q[k]))
            zeta = np.array([ba.values(s) @ [q["f_beam_1"]] for s in xi])
            eta = np.array([bt.values(s) @ [q["g_beam_1"], q["g_beam_2"]] for s in xi])
            th = q["theta_beam"]
            assert th == pytest.approx(0.3 + motion.tau[k], abs=1e-9)  # the driver
            lx, ly = xi + F * zeta, F * eta
            ex, ey = np.cos(th) * lx - np.sin(th) * ly, np.sin(th) * lx + np.cos(th) * ly
            assert np.abs(eta).max() > 1e-3  # something to magnify
            np.testing.assert_allclose(x, ex, atol=1e-12)
            np.testing.assert_allclose(y, ey, atol=1e-12)
    finally:
        anim.close()


def test_from_csv_uses_the_state_columns(run, capsys):
    d, scene = run
    side = json.loads((d / "run.json").read_text())
    assert side["states"]["coordinates"] == ["theta_beam", "f_beam_1", "g_beam_1", "g_beam_2"]
    assert main(["animate", str(scene), "--from", str(d / "run.csv"), "-o", str(d / "from.gif"), "--stride", "3"]) == 0
    assert len(frames(d / "from.gif")) == 5  # rows 0, 3, 6, 9, 12 of 13
    assert "deformation x" in capsys.readouterr().out


def test_from_csv_without_states_or_of_another_scene_is_refused(run, capsys, tmp_path):
    d, scene = run
    assert main(["animate", str(scene), "--from", str(d / "plain.csv"), "-o", str(tmp_path / "x.gif")]) == 2
    assert "no state columns" in capsys.readouterr().err
    other = tmp_path / "other.toml"
    other.write_text(BEAM.replace("at = [[0.0, 0.0], 0.0]", "at = [[0.2, 0.0], 0.0]"))
    assert main(["animate", str(other), "--from", str(d / "run.csv"), "-o", str(tmp_path / "x.gif")]) == 2
    assert "another scene" in capsys.readouterr().err
    other.write_text(BEAM.replace("axial_modes = 1", "axial_modes = 2"))
    assert main(["animate", str(other), "--from", str(d / "run.csv"), "-o", str(tmp_path / "x.gif")]) == 2
    assert "another model" in capsys.readouterr().err
    other.unlink()
    assert not list(tmp_path.glob("*.gif")) and not list(tmp_path.glob(".x*"))


def test_bad_targets_exit_2(run, capsys, tmp_path, monkeypatch):
    from matplotlib.animation import FFMpegWriter

    d, scene = run
    assert main(["animate", str(scene), "-o", str(tmp_path / "x.avi")]) == 2
    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    assert main(["animate", str(scene), "-o", str(tmp_path / "x.mp4")]) == 2
    assert "ffmpeg" in capsys.readouterr().err
    assert main(["simulate", str(scene), "-o", str(tmp_path / "r.csv"), "--plot", str(tmp_path / "r.jpg")]) == 2
    assert not list(tmp_path.iterdir())


def test_plots_as_svg_and_pdf(run):
    d, _ = run
    root = ET.parse(d / "run.svg").getroot()
    assert root.tag.endswith("svg")
    assert (d / "plain.pdf").read_bytes().startswith(b"%PDF")
    header = (d / "run.csv").read_text().splitlines()[0].split(",")
    assert header == ["tau", "tip", "q.theta_beam", "q.f_beam_1", "q.g_beam_1", "q.g_beam_2"]


TIP = (
    BEAM.replace(
        "[driver]",
        """[[joints]]
name = "B"
kind = "slider"
bodies = ["beam", "ground"]
at = [1.0, [1.0, 0.0]]
direction = [0.0, 1.0]
[driver]""",
    )
    .replace("transverse_modes = 2", "transverse_modes = 3")
    .replace("g = [0.04, 0.005]", "g = [0.0, 0.0, 0.0]")
)


def test_tip_load_shape_printed_factored(tmp_path):
    """The cantilever's orthogonalised tip-load shape is printed as (P - sum c_k X_k)/t with
    its coefficients on their own lines (was one 800 pt line); the printed c_k, t agree with
    projections computed here by quadrature and rebuild psi_1."""
    import shutil
    import subprocess

    from symgen.model.shapes import tip_load_coefficients

    basis = transverse_basis("cantilever", "modes", 3, tip_joint=True)
    eig = list(basis.functions[1:])
    c, t = tip_load_coefficients(eig)
    xi = np.linspace(0, 1, 20001)
    P = xi**2 * (3 - xi) / 2
    X = [np.array([f.value(s) for s in xi[::20]]) for f in eig]  # 1001 points, Simpson
    Pc = P[::20]
    w = np.ones(1001)
    w[1:-1:2], w[2:-1:2] = 4, 2
    w /= 3 * 1000
    for ck, Xk in zip(c, X):
        assert ck == pytest.approx((w * Pc * Xk).sum() / (w * Xk * Xk).sum(), rel=1e-9)
    assert t == pytest.approx(1 - sum(c), rel=1e-9)
    for s in (0.25, 0.6, 1.0):
        rebuilt = (s * s * (3 - s) / 2 - sum(ck * f.value(s) for ck, f in zip(c, eig))) / t
        assert rebuilt == pytest.approx(basis.functions[0].value(s), abs=1e-9)

    scene = tmp_path / "tip.toml"
    scene.write_text(TIP)
    assert main(["latex", str(scene), "-o", str(tmp_path / "tip.tex")]) == 0
    tex = (tmp_path / "tip.tex").read_text()
    block = tex[tex.index(r"\psi_{1}(\xi)") : tex.index(r"\psi_{2}(\xi)")]
    assert r"\sum_{k=1}^{2} c_k X_k(\xi)" in block and "e^{" not in block
    assert f"c_{{1}} = {c[0]:.10g}" in block
    assert max(len(line) for line in block.splitlines()) < 200
    if shutil.which("pdflatex"):
        subprocess.run(
            ["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "tip.tex"],
            cwd=tmp_path,
            capture_output=True,
            timeout=120,
            check=True,
        )
        log = (tmp_path / "tip.log").read_text(errors="replace")
        assert "Overfull \\hbox" not in log


def test_magnified_slider_crank_stays_joined():
    """In a closed loop the drawn bars meet at every joint for any factor: the computed and the
    rigid positions both close the loop (crank tip = rod start; the rod's end on the slider line),
    while the rod's midpoint moves F times its elastic displacement off the rigid rod."""
    from symgen.backends.casadi.pipeline import compile_scene
    from symgen.numerics.geometry import Geometry, magnified, rigid_reference
    from symgen.numerics.mechanism import Mechanism
    from symgen.numerics.simulate import simulate
    from symgen.scene import load_scene

    scene = load_scene(ROOT / "examples" / "slider_crank.toml", ["simulation.cycles=0.25"])
    compiled = compile_scene(scene)
    mech = Mechanism(compiled, scene)
    res = simulate(mech)
    geom = Geometry(scene, compiled.info)
    P, Pr = geom.points(res.q), geom.points(rigid_reference(mech, res.tau, res.q))
    crank, rod = geom.bars["crank"], geom.bars["rod"]
    mid = rod.start + len(rod) // 2
    assert np.abs(P[:, :, mid] - Pr[:, :, mid]).max() > 1e-4  # the rod does bend
    for F in (1.0, 50.0, 500.0):
        D = magnified(P, Pr, F)
        np.testing.assert_allclose(D[:, :, crank.stop - 1], D[:, :, rod.start], atol=1e-10)
        np.testing.assert_allclose(D[:, 1, rod.stop - 1], 0.0, atol=1e-10)
        np.testing.assert_allclose(D[:, :, mid] - Pr[:, :, mid], F * (P[:, :, mid] - Pr[:, :, mid]), atol=1e-12)


@pytest.mark.parametrize(
    "example, overrides, si", [("slider_crank", ["joints.B.mass=0.3"], False), ("four_bar", [], True)]
)
def test_lumped_masses_are_drawn_and_si_scenes_in_metres(example, overrides, si):
    """The animation drew no lumped masses and SI scenes on x/l0 axes: a mass is a disk that
    follows its joint, and an SI mechanism is drawn in metres (its ground pins at their places)."""
    from symgen.api import mechanism
    from symgen.apps.animate import Animator
    from symgen.numerics.geometry import Geometry, rigid_reference
    from symgen.numerics.simulate import simulate

    mech = mechanism(ROOT / "examples" / f"{example}.toml", [*overrides, "simulation.cycles=0.1"])
    scene, res = mech.scene, simulate(mech, backend="vm")
    geom = Geometry(scene, mech.info)
    P, Pr = geom.points(res.q), geom.points(rigid_reference(mech, res.tau, res.q))
    anim = Animator(scene, geom, res.tau, P, Pr, 1.0, "test")
    try:
        anim.draw(3)
        assert anim.ax.get_xlabel() == ("x [m]" if si else "$x / l_0$")
        offsets = np.asarray(anim.masses.get_offsets())
        if overrides:
            (marker,) = [m for m in geom.markers if m.joint == "B"]
            np.testing.assert_allclose(offsets, P[3][:, marker.index][None, :], atol=1e-12)
        else:
            assert len(offsets) == 0
            x, _ = (np.asarray(a) for a in anim.lines["crank"].get_data())
            assert x[0] == pytest.approx(0.0, abs=1e-12) and abs(x[-1]) < 0.11  # a 100 mm crank, in m
    finally:
        anim.close()
