"""``symgen animate``: the mechanism moving, every bar drawn with its deformation magnified.

The states come from a fresh run (``simulate``) or from a run's CSV written with ``--states``
(coordinates as extra columns ``q.<name>``, described in the JSON sidecar's ``states`` block).
Positions are ``geometry.Geometry``'s (the package's bar kinematics and shape functions); the
deformation is the elastic displacement field relative to the rigid mechanism at the same input,
drawn ``factor`` times larger (``geometry`` explains why the bars stay joined).
GIF through matplotlib's PillowWriter, MP4 through ffmpeg; written to a temporary file and
renamed, so a failed or interrupted rendering leaves no file that looks complete.
"""

from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from symgen.errors import SceneError
from symgen.ir.info import ModelInfo
from symgen.numerics.geometry import Geometry, auto_factor, magnified, rigid_reference
from symgen.numerics.results import states_block
from symgen.outputs import printable

TARGET = 0.1  # default factor: peak displacement drawn at 10 % of the reference length
MAX_FRAMES = 150  # default: every output row up to this many frames, else evenly spaced


def _same(a, b, tol: float = 1e-12) -> bool:
    """Equal plain data, floats to a relative tolerance (JSON round trip of the sidecar)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k], tol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return abs(a - b) <= tol * max(1.0, abs(a), abs(b))
    return a == b


@dataclass
class Motion:
    tau: np.ndarray  # (N,)
    q: np.ndarray  # (N, n)
    source: str


def fresh_run(mech, t_end: float | None) -> Motion:
    from symgen.numerics.simulate import simulate

    res = simulate(mech, t_end=t_end)
    return Motion(res.tau, res.q, "fresh run")


def read_states(path: str | os.PathLike, scene, model: ModelInfo) -> Motion:
    """States of a run's CSV (``simulate --states``), checked against the scene and model."""
    path = Path(path)
    hint = (
        f"write the run with its states: symgen simulate {Path(scene.path).name} -o RUN.csv --states "
        f"(same scene and --set values as here)"
    )
    if path.suffix.lower() != ".csv" or not path.is_file():
        raise SceneError(str(path), "--from", "not a readable .csv file", hint)
    side = path.with_suffix(".json")
    try:
        info = json.loads(side.read_text())
    except (OSError, ValueError) as err:
        raise SceneError(str(side), "--from", f"the run's JSON sidecar cannot be read ({err})", hint) from None
    st = info.get("states") if isinstance(info, dict) else None
    if not isinstance(st, dict) or not isinstance(st.get("columns"), list):
        raise SceneError(
            str(path),
            "--from",
            "this CSV has no state columns (coordinates), only the scene's "
            "outputs: the geometry cannot be rebuilt from it",
            hint,
        )
    if st.get("model_key") != model.key or st.get("coordinates") != list(model.coordinate_names):
        raise SceneError(
            str(path),
            "--from",
            f"the run was made with another model (key {st.get('model_key')!r}, "
            f"here {model.key!r}): its coordinates do not fit this scene",
            hint,
        )
    here = states_block(scene, st["coordinates"], model.key)
    for key, what in (("bars", "bar lengths or shape functions"), ("ground", "ground points or slider lines")):
        if not _same(st.get(key), here[key]):
            raise SceneError(
                str(path),
                "--from",
                f"the run was made from another scene ({info.get('scene')!r}): its {what} differ from this scene's",
                hint,
            )
    try:
        with path.open(newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as err:
        raise SceneError(str(path), "--from", f"cannot read the CSV ({err})", hint) from None
    if len(rows) < 2:
        raise SceneError(str(path), "--from", "the CSV has no data rows", hint)
    head = rows[0]
    # the time column: tau, or t in seconds for SI results (the sidecar's units give the factor)
    time_unit = (info.get("units") or {}).get("time") or {"name": "tau", "factor": 1.0}
    try:
        time_name, time_factor = str(time_unit["name"]), float(time_unit["factor"])
    except (KeyError, TypeError, ValueError):
        raise SceneError(str(side), "--from", "the sidecar's units.time is malformed", hint) from None
    if not (np.isfinite(time_factor) and time_factor > 0):
        raise SceneError(str(side), "--from", "the sidecar's time factor is not a positive number", hint)
    want = [time_name, *st["columns"]]
    absent = [c for c in want if c not in head]
    if absent:
        raise SceneError(str(path), "--from", f"column {absent[0]!r} named in the sidecar is not in the CSV", hint)
    idx = [head.index(c) for c in want]
    try:
        data = np.array([[float(r[i]) for i in idx] for r in rows[1:] if r], dtype=float)
    except (ValueError, IndexError):
        raise SceneError(
            str(path), "--from", "a state row is not a list of numbers (truncated or edited file?)", hint
        ) from None
    if not np.all(np.isfinite(data)):
        raise SceneError(str(path), "--from", "the states hold NaN or infinite values", hint)
    return Motion(data[:, 0] / time_factor, data[:, 1:], f"{path.name}")


def frame_indices(n: int, frames: int | None, stride: int | None) -> np.ndarray:
    if stride is not None:
        return np.arange(0, n, stride)
    count = min(n, MAX_FRAMES) if frames is None else min(n, frames)
    return np.unique(np.round(np.linspace(0, n - 1, count)).astype(int))


class Animator:
    """One matplotlib figure whose artists ``draw(k)`` moves to frame k."""

    def __init__(
        self,
        scene,
        geom: Geometry,
        tau: np.ndarray,
        P: np.ndarray,
        P_rigid: np.ndarray,
        factor: float,
        title: str,
        turn: float | None = None,
        rigid_ghost: bool = True,
    ) -> None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.scene, self.geom, self.tau, self.factor, self.turn = scene, geom, tau, factor, turn
        # an SI scene is drawn in metres (the model's lengths are per l0), a dimensionless one per l0
        self.si = scene.units == "SI"
        scale = scene.l0 if self.si else 1.0
        self.D = magnified(P, P_rigid, factor) * scale
        self.P_rigid = P_rigid = P_rigid * scale
        grounds = {m.joint: (m.ground[0] * scale, m.ground[1] * scale) for m in geom.markers if m.ground is not None}
        self.fig, ax = plt.subplots(figsize=(6.4, 4.8), layout="constrained")
        self.ax = ax
        allx = np.concatenate([self.D[:, 0, :].ravel(), P_rigid[:, 0, :].ravel()])
        ally = np.concatenate([self.D[:, 1, :].ravel(), P_rigid[:, 1, :].ravel()])
        span = max(np.ptp(allx), np.ptp(ally), 1e-9)
        for gx, gy in grounds.values():  # room for the ground triangles below the pins
            allx = np.append(allx, gx)
            ally = np.append(ally, [gy, gy - 0.06 * span])
        pad = 0.08 * span
        x0, x1, y0, y1 = allx.min() - pad, allx.max() + pad, ally.min() - pad, ally.max() + pad
        ax.set_xlim(x0, x1), ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        if self.si:
            ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]")
        else:
            ax.set_xlabel(r"$x / l_0$"), ax.set_ylabel(r"$y / l_0$")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.set_title(printable(title), fontsize=10, parse_math=False)  # a file name is text, never mathtext
        size = 0.035 * span
        for m in geom.markers:  # ground: pins as hatched triangles, slider guides as lines
            if m.joint not in grounds:
                continue
            gx, gy = grounds[m.joint]
            if m.kind == "slider" and m.direction is not None:
                dx, dy = m.direction
                L = 4 * span
                ax.plot(
                    [gx - L * dx, gx + L * dx],
                    [gy - L * dy, gy + L * dy],
                    color="0.45",
                    lw=2.2,
                    zorder=1,
                    solid_capstyle="butt",
                )
                ax.plot(
                    [gx - L * dx, gx + L * dx],
                    [gy - L * dy - 0.25 * size, gy + L * dy - 0.25 * size],
                    color="0.45",
                    lw=0.6,
                    ls=(0, (1, 2)),
                    zorder=1,
                )
            else:
                tri = plt.Polygon(
                    [[gx, gy], [gx - size, gy - 1.6 * size], [gx + size, gy - 1.6 * size]],
                    closed=True,
                    fc="0.85",
                    ec="0.3",
                    hatch="///",
                    lw=0.8,
                    zorder=2,
                )
                ax.add_patch(tri)
        self.ghosts = {}
        if rigid_ghost and factor != 0:
            for name in geom.bars:
                (ln,) = ax.plot([], [], color="0.6", lw=0.8, ls="--", zorder=3, animated=True)
                self.ghosts[name] = ln
        self.lines = {}
        for k, name in enumerate(geom.bars):
            (ln,) = ax.plot([], [], color=f"C{k}", lw=2.4, zorder=4, label=name, solid_capstyle="round", animated=True)
            self.lines[name] = ln
        (self.joints,) = ax.plot([], [], "o", ms=5, mfc="white", mec="k", mew=1.0, zorder=5, animated=True)
        # lumped masses at joints and [[masses]] at their centres: filled disks, the area growing
        # with the mass; a rigid attachment's arm from its bar point to its centre
        masses = {j.name: j.mass for j in scene.joints if j.mass > 0}
        carried = [(pm, at, centre) for pm, (at, centre) in zip(scene.masses, geom.point_masses)]
        self.mass_index = [m.index for m in geom.markers if m.joint in masses] + [c for _, _, c in carried]
        heaviest = max([*masses.values(), *(pm.mass for pm, _, _ in carried)], default=1.0) or 1.0
        sizes = [36 + 180 * masses[m.joint] / heaviest for m in geom.markers if m.joint in masses]
        sizes += [36 + 180 * pm.mass / heaviest for pm, _, _ in carried]
        self.arms = []
        for pm, at, centre in carried:
            if pm.offset is not None:
                (ln,) = ax.plot([], [], color="k", lw=1.2, zorder=5, animated=True)
                self.arms.append((ln, at, centre))
        self.masses = ax.scatter(
            np.zeros(len(sizes)),
            np.zeros(len(sizes)),
            s=sizes,
            c="k",
            zorder=6,
            animated=True,
            label="lumped mass" if sizes else None,
        )
        ax.legend(loc="upper right", fontsize=7, framealpha=0.8, markerscale=0.5)
        self.clock = ax.text(
            0.02,
            0.97,
            "",
            transform=ax.transAxes,
            va="top",
            fontsize=8,
            bbox={"fc": "white", "ec": "0.7", "alpha": 0.85, "pad": 2},
            animated=True,
        )
        fac = f"deformation x {factor:g}" if factor != 1 else "deformation to scale (x 1)"
        ax.text(
            0.02,
            0.03,
            fac + ("  (dashed: rigid mechanism)" if self.ghosts else ""),
            transform=ax.transAxes,
            fontsize=8,
            color="0.2",
            bbox={"fc": "white", "ec": "0.7", "alpha": 0.85, "pad": 2},
        )

    def draw(self, k: int) -> list:
        D, geom = self.D[k], self.geom
        for name, rg in geom.bars.items():
            self.lines[name].set_data(D[0, rg.start : rg.stop], D[1, rg.start : rg.stop])
            if name in self.ghosts:
                R = self.P_rigid[k]
                self.ghosts[name].set_data(R[0, rg.start : rg.stop], R[1, rg.start : rg.stop])
        idx = [m.index for m in geom.markers]
        self.joints.set_data(D[0, idx], D[1, idx])
        self.masses.set_offsets(np.column_stack([D[0, self.mass_index], D[1, self.mass_index]]))
        for ln, at, centre in self.arms:
            ln.set_data(D[0, [at, centre]], D[1, [at, centre]])
        t = self.tau[k]
        text = rf"$\tau$ = {t:.4g}"
        if self.turn:
            text += f"  ({t / self.turn:.3f} turns)"
        if self.scene.units == "SI" and self.scene.omega:
            text += f"\nt = {t / self.scene.omega:.5g} s"
        self.clock.set_text(text)
        arms = [ln for ln, _, _ in self.arms]
        return [*self.lines.values(), *self.ghosts.values(), *arms, self.joints, self.masses, self.clock]

    def close(self) -> None:
        import matplotlib.pyplot as plt

        plt.close(self.fig)


def write_frames(anim: Animator, path: str | os.PathLike, fps: float, dpi: int) -> None:
    """Every frame through matplotlib's PillowWriter (.gif) or FFMpegWriter (.mp4). The still
    parts (axes, ticks, ground) are drawn once; each frame restores them and draws only the
    moving artists (blitting), then hands the canvas's pixels to the writer."""
    from matplotlib.animation import FFMpegWriter, PillowWriter
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    fig = anim.fig
    fig.set_dpi(dpi)
    canvas = fig.canvas
    assert isinstance(canvas, FigureCanvasAgg), "the Animator draws with Agg (blitting needs its pixel buffer)"
    canvas.draw()  # lay out once (constrained), then freeze the layout
    fig.set_layout_engine("none")
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)

    def pixels(k: int):
        canvas.restore_region(background)
        for artist in anim.draw(k):
            fig.draw_artist(artist)
        return canvas.buffer_rgba()

    # the frames go to the writers' own frame list and ffmpeg pipe (private: matplotlib's stubs
    # do not declare them), not through grab_frame, which would redraw the whole figure
    if Path(path).suffix.lower() == ".gif":
        gif = PillowWriter(fps=fps)  # type: ignore[arg-type]  # the stubs say int; a float fps works (1000/fps ms a frame)
        with gif.saving(fig, os.fspath(path), dpi):
            for k in range(len(anim.tau)):
                gif._frames.append(Image.fromarray(np.asarray(pixels(k))).convert("RGB"))  # type: ignore[attr-defined]
    else:
        mp4 = FFMpegWriter(fps=fps)  # type: ignore[arg-type]  # the stubs say int; ffmpeg takes a float frame rate
        mp4.frame_format = "rgba"
        with mp4.saving(fig, os.fspath(path), dpi):
            for k in range(len(anim.tau)):
                mp4._proc.stdin.write(bytes(pixels(k)))  # type: ignore[attr-defined]


def check_target(path: str | os.PathLike) -> Path:
    """The output path: .gif, or .mp4 when ffmpeg is installed (else exit 2 before any work)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise SceneError(
            "command line", "-o", f"{str(path)!r} should end in .gif or .mp4", "give a file name like out/four_bar.gif"
        )
    if suffix == ".mp4":
        from matplotlib.animation import FFMpegWriter

        if not FFMpegWriter.isAvailable():
            raise SceneError(
                "command line",
                "-o",
                "writing .mp4 needs ffmpeg, which is not installed",
                "install ffmpeg (e.g. apt-get install ffmpeg) or write a .gif",
            )
    return p


def animate(
    out: str | os.PathLike,
    scene,
    compiled,
    mech,
    motion: Motion,
    factor: float | None = None,
    fps: float = 20.0,
    frames: int | None = None,
    stride: int | None = None,
    dpi: int = 100,
) -> dict:
    """Render the motion to ``out`` (.gif / .mp4); return a summary (factor, frames, peak)."""
    out = check_target(out)
    geom = Geometry(scene, compiled.info)
    sel = frame_indices(len(motion.tau), frames, stride)
    tau, Q = motion.tau[sel], motion.q[sel]
    P = geom.points(Q)
    P_rigid = geom.points(rigid_reference(mech, tau, Q))
    auto, peak = auto_factor(P, P_rigid, TARGET)
    factor = auto if factor is None else factor
    drv = scene.turning_driver
    turn = 2 * math.pi / abs(drv.rate) if drv is not None else None
    title = f"{scene.name}: {Path(scene.path).name} ({motion.source})"
    anim = Animator(scene, geom, tau, P, P_rigid, factor, title, turn)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=out.suffix, dir=out.parent)
    os.close(fd)
    try:
        write_frames(anim, tmp, fps, dpi)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    finally:
        anim.close()
    return {
        "path": out,
        "frames": len(tau),
        "factor": factor,
        "auto_factor": auto,
        "peak": peak,
        "tau": (float(tau[0]), float(tau[-1])),
    }
