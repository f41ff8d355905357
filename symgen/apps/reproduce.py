"""``symgen reproduce``: the analogues of the seed paper's figures G.1-G.12 as PNGs.

The paper (section 6) shows, for each of its three examples, the dynamic response over the
first two crank turns, the second turn, and the quasi-static ("static") response of section 5:

* 6.1 slider-crank: the connecting rod's transverse deflection (D.T., G.1-G.3) and its
  dimensionless elongation (A.A., G.4-G.6);
* 6.2 four-bar: the horizontal elastic deflection of the crank tip (D.H., G.7-G.8) and the
  elastic rotation there (D.A., G.9-G.10), dynamic against static;
* 6.3 inverted slider-crank: the crank tip's elastic deflection along and across the output
  bar (G.11-G.12), dynamic against static.

Each example runs from its scene file in ``examples/``; the outputs a figure needs are set here
(whatever the file's [outputs] are). The slider-crank is shown both as the paper modelled it
(``examples/slider_crank.toml``: linear strain, stress-free axial function, one mode each) and
with the accurate default model (von Karman strain, complete axial basis, 3 axial + 4
transverse functions). G.11-G.12 are drawn when ``examples/inverted_slider_crank.toml`` exists.
``DIR/README.md`` says what each figure shows, with the numbers measured in this run.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from collections.abc import Callable

import numpy as np

from symgen.outputs import atomic_path, atomic_write, remove
from symgen.scene import load_scene
from symgen.scene.model import GROUND, Output, Scene

ACCURATE_SC = [
    "effects.strain=von_karman",
    "bodies.rod.axial_shapes=complete",
    "bodies.rod.axial_modes=3",
    "bodies.rod.transverse_modes=4",
]
DEG = 180.0 / math.pi

# (output step in degrees of crank angle) normal / quick
STEP_DEG = {"normal": 1.0, "quick": 6.0}
AXIAL_STEP_DEG = {"normal": 0.09, "quick": 6.0}  # the rod's axial ringing: ~212 periods per turn


@dataclass
class Run:
    label: str
    tau: np.ndarray
    values: dict
    seconds: float
    info: dict = field(default_factory=dict)

    def angle_deg(self, rate: float = 1.0) -> np.ndarray:
        return self.tau * rate * DEG


def default_examples() -> Path:
    here = Path(__file__).resolve().parents[2] / "examples"
    return here if here.is_dir() else Path.cwd() / "examples"


def _with_outputs(scene: Scene, outputs: list[Output]) -> Scene:
    return replace(scene, outputs=tuple(outputs))


def _dynamic(scene: Scene, t_end: float, step: float, label: str) -> Run:
    from symgen.numerics.mechanism import load_mechanism
    from symgen.numerics.simulate import simulate

    mech = load_mechanism(scene)
    tic = time.perf_counter()
    res = simulate(mech, t_end=t_end, output_step=step)
    values = {n: res.column(n) for n in res.output_names}
    return Run(label, res.tau, values, time.perf_counter() - tic, {"steps": res.steps, "closure_max": res.closure_max})


def _static(scene: Scene, step: float, label: str) -> Run:
    from symgen.numerics.mechanism import load_mechanism
    from symgen.numerics.quasistatic import quasi_static

    mech = load_mechanism(scene)
    tic = time.perf_counter()
    res = quasi_static(mech, output_step=step)
    info = res.solver_info()
    info.pop("per_position")
    values = {n: res.column(n) for n in res.output_names}
    return Run(label, res.tau, values, time.perf_counter() - tic, info)


# --------------------------------------------------------------------------- plotting
class Figures:
    """Consistent report-style figures: one file (PNG, SVG or PDF) per paper figure."""

    def __init__(self, out: Path, fmt: str = "png") -> None:
        self.fmt = fmt
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.plt = plt
        self.out = out
        self.written: list[Path] = []

    def plot(
        self,
        name: str,
        title: str,
        ylabel: str,
        curves: list,
        xmax: float = 720.0,
        xmin: float = 0.0,
        note: str = "",
        xlabel: str = r"crank angle $\theta$ (deg)",
    ) -> Path:
        """``curves``: (x_deg, y, label, style dict); the legend and the note go below the axes,
        the y values are scaled by a power of ten named in the axis label."""
        import textwrap

        plt = self.plt
        peak = max((float(np.nanmax(np.abs(y))) for _, y, _, _ in curves if len(y)), default=0.0)
        expo = int(math.floor(math.log10(peak))) if peak > 0 else 0
        scale = 1.0
        if expo < -2 or expo > 3:
            scale = 10.0 ** (-expo)
            ylabel = f"{ylabel}  ($\\times 10^{{{expo}}}$)"
        ncol = 2 if len(curves) > 2 else len(curves)
        legend_rows = int(math.ceil(len(curves) / max(ncol, 1)))
        note_lines = textwrap.wrap(note, 150) if note else []
        bottom_in = 0.24 * legend_rows + 0.17 * len(note_lines) + 0.12
        height = 4.2 + bottom_in
        fig, ax = plt.subplots(figsize=(8.4, height))
        for x, y, label, style in curves:
            ax.plot(x, np.asarray(y) * scale, label=label, **style)
        ax.set_xlim(xmin, xmax)
        ax.set_xticks(np.arange(xmin, xmax + 1e-9, 90 if xmax - xmin > 400 else 45))
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.axhline(0.0, color="0.3", lw=0.6)
        if xmax - xmin > 400:
            ax.axvline(360.0, color="0.5", lw=0.8, ls=":")
        ax.ticklabel_format(axis="y", style="plain", useOffset=False)
        ax.set_title(title, fontsize=10.5)
        handles, labels = ax.get_legend_handles_labels()
        frac = bottom_in / height
        fig.tight_layout(rect=(0, frac, 1, 1))
        fig.legend(
            handles,
            labels,
            loc="upper center",
            ncol=ncol,
            fontsize=8.5,
            frameon=False,
            bbox_to_anchor=(0.5, frac + 0.02 / height),
        )
        for k, line in enumerate(note_lines):
            fig.text(
                0.012,
                (0.05 + 0.17 * (len(note_lines) - 1 - k)) / height,
                line,
                fontsize=7.5,
                color="0.3",
                ha="left",
                va="bottom",
            )
        path = self.out / f"{name}.{self.fmt}"
        try:
            with atomic_path(path) as tmp:
                fig.savefig(tmp, dpi=140, format=self.fmt)
        finally:
            plt.close(fig)
        self.written.append(path)
        return path


def _running_mean(tau: np.ndarray, y: np.ndarray, window: float) -> np.ndarray | None:
    """Mean of y over a sliding window of ``window`` in tau (None if the sampling is too coarse)."""
    if len(tau) < 3:
        return None
    h = float(tau[1] - tau[0])
    k = int(round(window / h))
    if k < 5:
        return None
    kern = np.ones(k) / k
    pad = np.concatenate([np.full(k // 2, y[0]), y, np.full(k - 1 - k // 2, y[-1])])
    return np.convolve(pad, kern, mode="valid")


SEED_STYLE = {"color": "C0", "lw": 1.0}
ACC_STYLE = {"color": "C3", "lw": 1.0}
DYN_STYLE = {"color": "C0", "lw": 1.0}
QS_STYLE = {"color": "k", "lw": 1.4, "ls": "--"}
SEED_QS = {"color": "#08306b", "lw": 1.5, "ls": "--"}
ACC_QS = {"color": "#67000d", "lw": 1.5, "ls": (0, (5, 2, 1, 2))}


def _periodic(run: Run, cycles: float = 2.0) -> tuple[np.ndarray, dict]:
    """A one-turn quasi-static run repeated over ``cycles`` turns (it is periodic)."""
    x = run.angle_deg()
    n = len(x) - 1  # last point = first point + 360
    reps = int(math.ceil(cycles))
    xs = np.concatenate([x[:n] + 360.0 * k for k in range(reps)] + [x[n:] + 360.0 * (reps - 1)])
    vals = {k: np.concatenate([v[:n]] * reps + [v[n:]]) for k, v in run.values.items()}
    return xs, vals


def _second_turn(run: Run, key: str) -> tuple[np.ndarray, np.ndarray]:
    x = run.angle_deg()
    sel = (x >= 360.0 - 1e-9) & (x <= 720.0 + 1e-9)
    return x[sel] - 360.0, run.values[key][sel]


def _lowest_mode(scene: Scene, tau: float = 0.0) -> tuple[float, str]:
    """Lowest natural frequency (units of the crank speed) about the quasi-static state."""
    from symgen.numerics.mechanism import load_mechanism
    from symgen.numerics.modes import modes

    md = modes(load_mechanism(scene), tau, shapes=False).modes[0]
    return md.natural_frequency, md.dominant


def _functions(scene: Scene) -> str:
    """The shape-function counts of the scene's elastic bars, as the README states them."""
    parts = [
        f"{b.name} {b.axial_modes} axial + {b.transverse_modes} transverse"
        for b in scene.bodies
        if not b.rigid and (b.axial_modes or b.transverse_modes)
    ]
    return ", ".join(parts) + " functions" if parts else "no elastic bars"


def _peak(y) -> float:
    return float(np.abs(np.asarray(y)).max())


# --------------------------------------------------------------------------- 6.1 slider-crank
def _slider_crank(path: Path, figs: Figures, quick: bool, notes: list, progress) -> None:
    mode = "quick" if quick else "normal"
    h = STEP_DEG[mode] / DEG
    h_ax = AXIAL_STEP_DEG[mode] / DEG
    outs = [Output("eta_mid", "chord_deflection", body="rod", xi=0.5), Output("eps_ax", "chord_elongation", body="rod")]
    seed = _with_outputs(load_scene(str(path)), outs)
    acc = _with_outputs(load_scene(str(path), ACCURATE_SC), outs)
    lam, mu = seed.body("rod").lam, seed.body("rod").mu
    two = 4 * math.pi
    progress and progress("slider-crank: dynamic runs (seed model, accurate model)")
    d_seed = _dynamic(seed, two, h_ax, "seed model (paper): linear strain, 1+1 functions")
    d_acc = _dynamic(acc, two, h_ax, "accurate model: von Karman, 3+4 functions")
    progress and progress("slider-crank: quasi-static runs")
    s_seed = _static(seed, h, "seed model, quasi-static")
    s_acc = _static(acc, h, "accurate model, quasi-static")
    xs_seed, ps_seed = _periodic(s_seed)
    xs_acc, ps_acc = _periodic(s_acc)
    params = rf"$\lambda$ = {lam:g}, $\mu$ = {mu:g}, crank/rod $\alpha$ = {seed.body('crank').alpha:g}, crank at constant speed, no damping"
    dt_label = r"midspan deflection from the chord $\eta(\frac{1}{2})$ / $l$"
    aa_label = r"chord elongation $(|c| - l)/l$"

    figs.plot(
        "G01_slider_crank_deflection_two_cycles",
        "G.1  Slider-crank: transverse deflection of the rod (D.T.), first two crank turns",
        dt_label,
        [
            (d_seed.angle_deg(), d_seed.values["eta_mid"], d_seed.label, SEED_STYLE),
            (d_acc.angle_deg(), d_acc.values["eta_mid"], d_acc.label, ACC_STYLE),
            (xs_acc, ps_acc["eta_mid"], "quasi-static response (accurate model)", QS_STYLE),
        ],
        note=params + "; start from rest, undeformed",
    )
    x2s, y2s = _second_turn(d_seed, "eta_mid")
    x2a, y2a = _second_turn(d_acc, "eta_mid")
    figs.plot(
        "G02_slider_crank_deflection_second_cycle",
        "G.2  Slider-crank: second turn of the transverse deflection (D.T.)",
        dt_label,
        [
            (x2s, y2s, "dynamic, seed model", SEED_STYLE),
            (x2a, y2a, "dynamic, accurate model", ACC_STYLE),
            (s_seed.angle_deg(), s_seed.values["eta_mid"], "quasi-static, seed model", SEED_QS),
            (s_acc.angle_deg(), s_acc.values["eta_mid"], "quasi-static, accurate model", ACC_QS),
        ],
        xmax=360.0,
        note=params + r"; $\theta$ from the start of the second turn",
    )
    figs.plot(
        "G03_slider_crank_deflection_static",
        'G.3  Slider-crank: quasi-static ("static") response of the transverse deflection (D.T.)',
        dt_label,
        [
            (
                s_seed.angle_deg(),
                s_seed.values["eta_mid"],
                "seed model (paper)",
                {**SEED_STYLE, "lw": 3.0, "alpha": 0.55},
            ),
            (s_acc.angle_deg(), s_acc.values["eta_mid"], "accurate model", {**ACC_STYLE, "lw": 1.2}),
        ],
        xmax=360.0,
        note=params + "; (18)-(20) at each crank angle",
    )
    # the rod's axial ringing: drawn as a light band, with its mean over one axial period (none
    # when the rod's axial response is quasi-static, effects.axial = "auto" on a stiff rod)
    w_ax = {}
    for key, sc in (("seed", seed), ("acc", acc)):
        from symgen.numerics.mechanism import load_mechanism
        from symgen.numerics.modes import modes

        fr = modes(load_mechanism(sc), 0.0, shapes=False)
        axial = fr.frequencies("axial", "rod")
        w_ax[key] = (float(axial[0]) if len(axial) else None, fr.frequencies("transverse", "rod")[0])

    def band(run: Run, key: str, style: dict, label: str, which: str, x0: float = 0.0) -> list:
        x, y = run.angle_deg(), run.values[key]
        sel = x >= x0 - 1e-9
        w = w_ax[which][0]
        if w is None:  # a quasi-static rod does not ring: the curve itself
            return [(x[sel] - x0, y[sel], label, {**style, "lw": 1.4})]
        out = [(x[sel] - x0, y[sel], label, {**style, "lw": 0.4, "alpha": 0.45})]
        mean = _running_mean(run.tau, y, 2 * math.pi / w)
        if mean is not None:
            out.append((x[sel] - x0, mean[sel], label + ", mean over an axial period", {**style, "lw": 1.4}))
        return out

    ring = (
        "axial ringing at "
        + " / ".join(
            f"{w:.0f} ({name})" if w is not None else f"none ({name}: quasi-static rod)"
            for name, w in (("seed", w_ax["seed"][0]), ("accurate", w_ax["acc"][0]))
        )
        + " per unit $\\tau$, rung by the start from rest"
    )
    figs.plot(
        "G04_slider_crank_elongation_two_cycles",
        "G.4  Slider-crank: dimensionless elongation of the rod (A.A.), first two crank turns",
        aa_label,
        band(d_seed, "eps_ax", SEED_STYLE, "dynamic, seed model", "seed")
        + band(d_acc, "eps_ax", ACC_STYLE, "dynamic, accurate model", "acc")
        + [(xs_acc, ps_acc["eps_ax"], "quasi-static, accurate model", QS_STYLE)],
        note=params + "; " + ring,
    )
    figs.plot(
        "G05_slider_crank_elongation_second_cycle",
        "G.5  Slider-crank: second turn of the elongation (A.A.)",
        aa_label,
        band(d_seed, "eps_ax", SEED_STYLE, "dynamic, seed model", "seed", 360.0)
        + band(d_acc, "eps_ax", ACC_STYLE, "dynamic, accurate model", "acc", 360.0)
        + [
            (s_seed.angle_deg(), s_seed.values["eps_ax"], "quasi-static, seed model", SEED_QS),
            (s_acc.angle_deg(), s_acc.values["eps_ax"], "quasi-static, accurate model", ACC_QS),
        ],
        xmax=360.0,
        note=params + "; " + ring,
    )
    figs.plot(
        "G06_slider_crank_elongation_static",
        'G.6  Slider-crank: quasi-static ("static") response of the elongation (A.A.)',
        aa_label,
        [
            (
                s_seed.angle_deg(),
                s_seed.values["eps_ax"],
                "seed model (paper)",
                {**SEED_STYLE, "lw": 3.0, "alpha": 0.55},
            ),
            (s_acc.angle_deg(), s_acc.values["eps_ax"], "accurate model", {**ACC_STYLE, "lw": 1.2}),
        ],
        xmax=360.0,
        note=params + "; (18)-(20) at each crank angle",
    )

    def diff2(run: Run, st: Run, key: str) -> float:
        x2, y2 = _second_turn(run, key)
        ys = np.interp(x2, st.angle_deg(), st.values[key])
        return float(np.abs(y2 - ys).max() / _peak(st.values[key]))

    notes.append(
        {
            "example": "slider_crank",
            "functions": _functions(acc),
            "lines": [
                f"Seed model (the paper's): peak |eta_mid| {_peak(d_seed.values['eta_mid']):.4g} dynamic over two turns, "
                f"{_peak(s_seed.values['eta_mid']):.4g} quasi-static; second turn differs from the quasi-static curve by up to "
                f"{100 * diff2(d_seed, s_seed, 'eta_mid'):.0f} % of its peak.",
                f"Accurate model: peak |eta_mid| {_peak(d_acc.values['eta_mid']):.4g} dynamic, "
                f"{_peak(s_acc.values['eta_mid']):.4g} quasi-static (seed/accurate quasi-static peaks differ by "
                f"{100 * (_peak(s_seed.values['eta_mid']) / _peak(s_acc.values['eta_mid']) - 1):+.1f} %).",
                f"Elongation: quasi-static peak {_peak(s_seed.values['eps_ax']):.3g} (seed) and "
                f"{_peak(s_acc.values['eps_ax']):.3g} (accurate); the dynamic curves carry the axial ringing "
                f"of amplitude up to {_peak(d_acc.values['eps_ax'] - np.interp(d_acc.angle_deg() % 360, s_acc.angle_deg(), s_acc.values['eps_ax'])):.2g} (accurate model).",
                f"Quasi-static solves: seed {s_seed.info['iterations_mean']:.1f} fixed-point iterations per position on "
                f"average (Newton at {s_seed.info['newton_positions']} positions), accurate "
                f"{s_acc.info['iterations_mean']:.1f} (Newton at {s_acc.info['newton_positions']} of "
                f"{s_acc.info['positions']}: with von Karman strain the axial-bending coupling goes both ways and the "
                "fixed-point iteration of (20) diverges where the rod bends most; with the seed's one-way linear "
                "coupling it contracts everywhere).",
                f"Linearised about the quasi-static state at tau = 0 (`symgen modes`): first bending frequency of the rod "
                f"{w_ax['seed'][1]:.3f} (seed) / {w_ax['acc'][1]:.3f} (accurate), first axial "
                + " / ".join(
                    f"{w:.1f}" if w is not None else "none (quasi-static rod)"
                    for w in (w_ax["seed"][0], w_ax["acc"][0])
                )
                + ", in units of the crank speed.",
                f"Run times: dynamic {d_seed.seconds:.1f} s + {d_acc.seconds:.1f} s, quasi-static "
                f"{s_seed.seconds:.1f} s + {s_acc.seconds:.1f} s.",
            ],
        }
    )


# --------------------------------------------------------------------------- 6.2 four-bar
def _four_bar(path: Path, figs: Figures, quick: bool, notes: list, progress) -> None:
    mode = "quick" if quick else "normal"
    h = STEP_DEG[mode] / DEG
    base = load_scene(str(path))
    if len(base.drivers) != 1:
        raise ValueError(f"{path}: not one driver: not the four-bar of section 6.2")
    crank = base.drivers[0].body
    outs = [
        Output("dx", "elastic_displacement", body=crank, xi=1.0, component="x"),
        Output("slope", "slope", body=crank, xi=1.0),
    ]
    sc = _with_outputs(base, outs)
    l0_mm = base.l0 * 1000.0 if base.units == "SI" else None
    progress and progress("four-bar: dynamic and quasi-static runs")
    dyn = _dynamic(sc, 4 * math.pi, h, "dynamic (start on the quasi-static state)")
    st = _static(sc, h, "quasi-static")
    w1, dom1 = _lowest_mode(sc)
    xs, ps = _periodic(st)
    k_dx = l0_mm if l0_mm else 1.0
    dx_label = (
        "horizontal elastic deflection of the crank tip (mm)"
        if l0_mm
        else r"horizontal elastic deflection of the crank tip / $l_0$"
    )
    sl_label = r"elastic rotation of the crank tip $\eta'(1)$ (mrad)"
    g = base.groups
    rpm = base.omega * 60 / (2 * math.pi) if base.units == "SI" else None
    params = (
        (f"crank {g[crank]['alpha'] * base.l0 * 1000:.0f} mm, {rpm:.0f} rpm; " if rpm else "")
        + ", ".join(f"{b.name}: $\\mu$ = {b.mu:.3g}" for b in base.bodies if b.mu is not None)
        + "; no damping"
    )
    figs.plot(
        "G07_four_bar_crank_tip_horizontal_deflection",
        "G.7  Four-bar: horizontal deflection of the crank tip (D.H.), dynamic and static",
        dx_label,
        [
            (dyn.angle_deg(), dyn.values["dx"] * k_dx, "dynamic", DYN_STYLE),
            (xs, ps["dx"] * k_dx, "quasi-static (static)", QS_STYLE),
        ],
        note=params,
    )
    figs.plot(
        "G08_four_bar_crank_tip_horizontal_deflection_static",
        'G.8  Four-bar: quasi-static ("static") regime of the crank-tip horizontal deflection (D.H.)',
        dx_label,
        [(st.angle_deg(), st.values["dx"] * k_dx, "quasi-static (18)-(20)", {**QS_STYLE, "ls": "-"})],
        xmax=360.0,
        note=params,
    )
    figs.plot(
        "G09_four_bar_crank_tip_angle",
        "G.9  Four-bar: elastic rotation at the crank tip (D.A.), dynamic and static",
        sl_label,
        [
            (dyn.angle_deg(), dyn.values["slope"] * 1e3, "dynamic", DYN_STYLE),
            (xs, ps["slope"] * 1e3, "quasi-static (static)", QS_STYLE),
        ],
        note=params,
    )
    figs.plot(
        "G10_four_bar_crank_tip_angle_static",
        'G.10  Four-bar: quasi-static ("static") response of the crank-tip rotation (D.A.)',
        sl_label,
        [(st.angle_deg(), st.values["slope"] * 1e3, "quasi-static (18)-(20)", {**QS_STYLE, "ls": "-"})],
        xmax=360.0,
        note=params,
    )
    unit = "mm" if l0_mm else "l0"
    notes.append(
        {
            "example": "four_bar",
            "functions": _functions(base),
            "lines": [
                f"Crank-tip horizontal deflection: peak {_peak(dyn.values['dx']) * k_dx:.3g} {unit} dynamic, "
                f"{_peak(st.values['dx']) * k_dx:.3g} {unit} quasi-static; rotation: peak "
                f"{_peak(dyn.values['slope']) * 1e3:.3g} mrad dynamic, {_peak(st.values['slope']) * 1e3:.3g} mrad quasi-static.",
                f"The lowest natural frequency about the quasi-static state at tau = 0 (`symgen modes`) is "
                f"{w1:.2f} times the crank speed ({w1 * base.omega / (2 * math.pi):.0f} Hz, {dom1}): the bars ring "
                "within the first harmonics of the motion, so the dynamic response is dominated by their vibration and "
                "is far from the quasi-static one.",
                f"Quasi-static solve: {st.info['iterations_mean']:.1f} fixed-point iterations per position on average; "
                f"Newton took over at {st.info['newton_positions']} of {st.info['positions']} positions (the iteration did "
                "not contract there).",
                f"Run times: dynamic {dyn.seconds:.1f} s ({dyn.info['steps']} IDAS steps), quasi-static {st.seconds:.1f} s.",
            ],
        }
    )


# --------------------------------------------------------------------------- 6.3 inverted slider-crank
def _slot_parts(scene: Scene) -> tuple[str, float, str]:
    """(crank, xi of its sliding point, guide bar) of the inverted slider-crank."""
    for j in scene.joints:
        if j.kind == "slot":
            guide = next(e for e in j.ends if e.variable)
            slider = next(e for e in j.ends if not e.variable and e.body != GROUND)
            assert slider.xi is not None, "the sliding bar's end has its xi"
            return slider.body, float(slider.xi), guide.body
    raise ValueError(f"{scene.path}: no slot joint: not an inverted slider-crank")


def _inverted(path: Path, figs: Figures, quick: bool, notes: list, progress) -> None:
    mode = "quick" if quick else "normal"
    h = STEP_DEG[mode] / DEG
    base = load_scene(str(path))
    crank, xi, guide = _slot_parts(base)
    outs = [
        Output("dx", "elastic_displacement", body=crank, xi=xi, component="x"),
        Output("dy", "elastic_displacement", body=crank, xi=xi, component="y"),
        Output("guide_angle", "angle", body=guide),
    ]
    sc = _with_outputs(base, outs)
    progress and progress("inverted slider-crank: dynamic and quasi-static runs")
    dyn = _dynamic(sc, 4 * math.pi, h, "dynamic")
    st = _static(sc, h, "quasi-static")
    w1, dom1 = _lowest_mode(sc)

    def split(values):
        c, s = np.cos(values["guide_angle"]), np.sin(values["guide_angle"])
        return values["dx"] * c + values["dy"] * s, -values["dx"] * s + values["dy"] * c

    d_al, d_pe = split(dyn.values)
    xs, ps = _periodic(st)
    s_al, s_pe = split(ps)
    mass = next(j.mass for j in base.joints if j.kind == "slot")
    params = (
        f"crank $\\mu$ = {base.body(crank).mu:g}, output bar $\\mu$ = {base.body(guide).mu:g}, "
        f"slider mass {mass:g} $m\\,l_0$, no damping"
    )
    figs.plot(
        "G11_inverted_slider_crank_deflection_along_output_bar",
        "G.11  Inverted slider-crank: crank-tip deflection along the output bar",
        r"elastic deflection along the output bar / $l_0$",
        [(dyn.angle_deg(), d_al, "dynamic", DYN_STYLE), (xs, s_al, "quasi-static (static)", QS_STYLE)],
        note=params,
    )
    figs.plot(
        "G12_inverted_slider_crank_deflection_across_output_bar",
        "G.12  Inverted slider-crank: crank-tip deflection perpendicular to the output bar",
        r"elastic deflection across the output bar / $l_0$",
        [(dyn.angle_deg(), d_pe, "dynamic", DYN_STYLE), (xs, s_pe, "quasi-static (static)", QS_STYLE)],
        note=params,
    )
    st_al, st_pe = split(st.values)
    notes.append(
        {
            "example": "inverted_slider_crank",
            "functions": _functions(base),
            "lines": [
                f"Crank-tip deflection along the output bar: peak {_peak(d_al):.3g} dynamic, {_peak(st_al):.3g} "
                f"quasi-static; across it: {_peak(d_pe):.3g} dynamic, {_peak(st_pe):.3g} quasi-static (units of l0).",
                f"The paper reports no visible difference between its static and dynamic responses (for data it does not "
                f"give); with this example's data the lowest natural frequency at tau = 0 is {w1:.1f} times the crank "
                f"speed ({dom1}); the dynamic response overshoots the quasi-static one near theta = 180 deg, where the "
                "slider passes closest to the guide's pivot and the guide swings fastest.",
                f"Quasi-static solve: {st.info['iterations_mean']:.1f} fixed-point iterations per position on average; "
                f"Newton at {st.info['newton_positions']} positions.",
                f"Run times: dynamic {dyn.seconds:.1f} s, quasi-static {st.seconds:.1f} s.",
            ],
        }
    )


# --------------------------------------------------------------------------- README
FIGURE_TEXT = {
    "slider_crank": (
        "## 6.1 Slider-crank (G.1-G.6)\n\n"
        "`examples/slider_crank.toml`: rigid crank (alpha = 0.5), elastic connecting rod, massless slider, crank "
        "at constant speed, no damping, started from rest undeformed. Blue: the paper's model (linear strain, "
        "one axial function sin(pi xi/2), one transverse sin(pi xi)); red: the accurate default model "
        "(von Karman strain, complete axial basis, {functions}). Dashed: the quasi-static "
        "response (18)-(20) (`symgen quasistatic`), the state reached after many turns with internal damping "
        "if the bar's inertia were negligible.\n\n"
        "* G.1 midspan deflection of the rod from its chord over the first two turns; G.2 the second turn with "
        "both quasi-static curves; G.3 the quasi-static deflection alone.\n"
        "* G.4-G.6 the same for the rod's chord elongation (|c| - l)/l. The start from rest rings the axial "
        "mode (hundreds of periods per turn): the dynamic curves are a band around the quasi-static one.\n"
    ),
    "four_bar": (
        "## 6.2 Four-bar (G.7-G.10)\n\n"
        "`examples/four_bar.toml`: aluminium crank-rocker (crank 100 mm as a cantilever, coupler 300 mm and "
        "rocker 250 mm pinned-pinned; {functions}), 2196 rpm, started on the "
        "quasi-static state, no damping. G.7 / G.9: horizontal elastic deflection and elastic rotation eta'(1) "
        "of the crank tip A over two turns, dynamic (solid) against quasi-static (dashed); G.8 / G.10: the "
        "quasi-static response alone.\n"
    ),
    "inverted_slider_crank": (
        "## 6.3 Inverted slider-crank (G.11-G.12)\n\n"
        "`examples/inverted_slider_crank.toml`: elastic crank (cantilever) whose tip slider (lumped mass) runs "
        "along an elastic output bar with a variable support distance ({functions}). G.11 / G.12: the crank tip's elastic "
        "deflection resolved along and across the output bar, dynamic against quasi-static.\n"
    ),
}


def _readme(out: Path, notes: list, quick: bool, missing: list, total_s: float, fmt: str = "png") -> Path:
    lines = [
        "# Figures of the seed paper, reproduced by symgen",
        "",
        "Analogues of figures G.1-G.12 of Riesco, Garcia-Lomas & Dominguez (section 6), written by "
        "`symgen reproduce`"
        + (" --quick (coarse output step: a smoke run, not for reading)" if quick else "")
        + f" in {total_s:.0f} s. The x axis is the crank angle; all quantities are dimensionless "
        "(lengths / bar length or / l0, tau = omega t) unless a unit is given.",
        "",
    ]
    for note in notes:
        lines.append(FIGURE_TEXT[note["example"]].format(functions=note["functions"]))
        lines.append("Measured in this run:\n")
        lines.extend(f"* {x}" for x in note["lines"])
        lines.append("")
    for m in missing:
        lines.append(m)
        lines.append("")
    lines.append("Files: " + ", ".join(f"`{p.name}`" for p in sorted(out.glob(f"G*.{fmt}"))) + ".")
    path = out / "README.md"
    atomic_write(path, "\n".join(lines) + "\n")
    return path


def reproduce(
    out_dir, quick: bool = False, examples=None, progress: Callable[[str], object] | None = None, fmt: str = "png"
) -> list[Path]:
    """Write the figures (``fmt``: png, svg or pdf) and ``README.md`` to ``out_dir``; return the paths written."""
    tic = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ex = Path(examples) if examples else default_examples()
    figs = Figures(out, fmt)
    notes: list = []
    missing: list = []
    from symgen.progress import progress_bar

    inv = ex / "inverted_slider_crank.toml"
    try:
        with progress_bar(3 if inv.exists() else 2, "reproduce", unit="example") as bar:
            _slider_crank(ex / "slider_crank.toml", figs, quick, notes, progress)
            bar.update(1)
            _four_bar(ex / "four_bar.toml", figs, quick, notes, progress)
            bar.update(1)
            if inv.exists():
                _inverted(inv, figs, quick, notes, progress)
                bar.update(1)
    except BaseException as err:
        _stopped(out, figs, notes, err, time.perf_counter() - tic)
        raise
    if not inv.exists():
        missing.append(
            "G.11-G.12 (inverted slider-crank) are not drawn: `examples/inverted_slider_crank.toml` does not exist."
        )
    readme = _readme(out, notes, quick, missing, time.perf_counter() - tic, fmt)
    remove([out / PARTIAL_README])
    return figs.written + [readme]


PARTIAL_README = "README.partial.md"


def _stopped(out: Path, figs: Figures, notes: list, err: BaseException, total_s: float) -> Path:
    """A run that failed or was interrupted: the README of a complete run and figures of an
    earlier run that this one did not redraw go; ``README.partial.md`` says what was drawn."""
    from symgen.errors import Interrupted
    from symgen.numerics import interrupt

    stop = interrupt.interrupted(err)  # not None: err is not None
    err = err if stop is None else stop
    status = "interrupted" if isinstance(err, Interrupted) else "failed"
    written = {p.name for p in figs.written}
    remove(
        [
            out / "README.md",
            *(p for ext in ("png", "svg", "pdf") for p in out.glob(f"G[0-9][0-9]_*.{ext}") if p.name not in written),
        ]
    )
    lines = [
        "# Figures of the seed paper: PARTIAL run of `symgen reproduce`",
        "",
        f"status: {status}",
        f"cause: {err}",
        f"after: {total_s:.0f} s",
        "",
        "Only these figures were drawn by this run (the others are missing):",
        "",
    ]
    lines += [f"* `{name}`" for name in sorted(written)] or ["* none"]
    for note in notes:
        lines += ["", f"Measured ({note['example']}):", *(f"* {x}" for x in note["lines"])]
    path = out / PARTIAL_README
    atomic_write(path, "\n".join(lines) + "\n")
    return path
