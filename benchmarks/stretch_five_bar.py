"""The stretch's share of the curvature (model_form.STRETCH_CURVATURE) on the five-bar, measured
against the exact bar's run at the same bases (docs/exact-bars.md, "The five-bar's over-estimate with
the stretch's curvature, located").

    python benchmarks/stretch_five_bar.py

benchmarks/validation/five_bar_elastic.toml with von Karman and with the exact bar, 3 + 4 on both
links, every function dynamic, dynamic axial amplitudes, IDAS rtol 1e-9, atol 1e-12. Prints, as
fractions of each output's peak, with the term off and on: the model-form part against von Karman
vs exact; its static change against the difference's content below ``STATIC_BAND`` (fitted scale
true / estimate and correlation); the links' two coupled modes' shifts against the exact model's
own frequencies at von Karman's states; link_b_mid's drift over three spans of the run against the
difference's content above ``STATIC_BAND``, with each mode's shift as estimated and held at its mean.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from symgen.api import mechanism
from symgen.numerics import model_form as mf
from symgen.numerics.simulate import simulate
from symgen.scene import load_scene

SCENE = Path(__file__).resolve().parent / "validation" / "five_bar_elastic.toml"
SAME_BASES = ["effects.axial=dynamic"] + [
    f"bodies.{b}.{k}"
    for b in ("link_a", "link_b")
    for k in ("axial_modes=3", "transverse_modes=4", "quasi_static_transverse=0")
]
#: below the links' first coupled modes (26.1, 27.1 per unit tau; their bands from 19.6)
STATIC_BAND = 15.0
SPANS = ((0.0, 3.0), (3.0, 2 * np.pi), (2 * np.pi, 4 * np.pi + 1e-9))


def band(tau: np.ndarray, y: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``y``'s content between ``lo`` and ``hi`` (rad per unit tau), by the FFT of the mirrored signal."""
    yy = np.concatenate([y, y[::-1]])
    F = np.fft.rfft(yy)
    w = 2 * np.pi * np.fft.rfftfreq(len(yy), tau[1] - tau[0])
    F[(w < lo) | (w >= hi)] = 0
    return np.fft.irfft(F, len(yy))[: len(y)]


def main() -> None:
    mechs = {s: mechanism(load_scene(SCENE, [*SAME_BASES, f"effects.strain={s}"])) for s in ("von_karman", "exact")}
    runs = {s: simulate(m, rtol=1e-9, atol=1e-12) for s, m in mechs.items()}
    vk_mech, ex_mech, vk = mechs["von_karman"], mechs["exact"], runs["von_karman"]
    tau = np.asarray(vk.tau)
    names = list(vk.output_names)
    out_vk, out_ex = np.asarray(vk.outputs), np.asarray(runs["exact"].outputs)
    pk = np.abs(out_ex).max(axis=0)
    truth = out_ex - out_vk
    true = np.abs(truth).max(axis=0) / pk
    rows = np.unique(np.linspace(0, len(tau) - 1, min(400, len(tau))).astype(int))
    Q, V, Lam = (np.asarray(x, dtype=float)[rows] for x in (vk.q, vk.v, vk.lam))
    at = np.unique(np.linspace(0, len(rows) - 1, min(mf.MODE_SAMPLES, len(rows))).astype(int))
    w_vk = mf._modes_along(vk_mech, tau[rows][at], Q[at], V[at], mf._modal_function(vk_mech))[0]
    w_ex = mf._modes_along(ex_mech, tau[rows][at], Q[at], V[at], mf._modal_function(ex_mech))[0]
    shift_true = np.array([w_ex[s][:2] / w_vk[s][:2] - 1.0 for s in range(len(at))])
    bodies = {b["name"]: b for b in vk_mech.info.structure["bodies"]}
    bars = [
        mf._Bar(vk_mech, n, mf._samples(bodies[n]), f, g, 0, 1, False) for n, (f, g) in vk_mech.amplitudes.items() if g
    ]
    damping = float(vk_mech.scene.effects.damping or 0.0)
    high = band(tau, truth[:, 1], STATIC_BAND, np.inf)
    print("link_b_mid, exact - von Karman above 15 per unit tau, over tau spans:", end=" ")
    print(" ".join(f"{np.abs(high[(tau >= a) & (tau < b)]).max() / pk[1]:.2e}" for a, b in SPANS))
    combined = mf.combined
    for flag in (False, True):
        mf.STRETCH_CURVATURE = flag
        seen: list[tuple[np.ndarray, np.ndarray]] = []

        def spy(t, at_, change, drifts, seen=seen):
            seen.append((np.array(at_), np.array(change)))
            return combined(t, at_, change, drifts)

        mf.combined = spy
        try:
            est = mf.model_form_estimate(vk_mech, vk)
        finally:
            mf.combined = combined
        print(f"\nSTRETCH_CURVATURE = {flag}")
        for j, n in enumerate(names):
            e = est.outputs.get(n, 0.0)
            print(f"  {n:11s} von Karman vs exact {true[j]:.2e}  model-form part {e:.2e} ({e / true[j]:.2f}x)")
        for j in range(2):
            at_, change = seen[j]
            low = band(tau, truth[:, j], 0.0, STATIC_BAND)
            ch = np.interp(tau, at_, change)
            print(
                f"  static change of {names[j]}: scale true/estimate {ch @ low / (ch @ ch):.2f}, "
                f"correlation {ch @ low / np.sqrt((ch @ ch) * (low @ low)):+.2f}"
            )
        ring = mf._coupled_modes(vk_mech, bars, vk, rows, Q, V, Lam)
        for k in range(2):
            s = ring[k][1][at]
            print(
                f"  mode {ring[k][0]:.1f}: shift mean {s.mean():+.1e} (exact model's {shift_true[:, k].mean():+.1e}), "
                f"correlation {np.corrcoef(s, shift_true[:, k])[0, 1]:+.2f}"
            )
        for label, held in (("as estimated", False), ("held at its mean", True)):
            tot = np.zeros(len(tau), dtype=complex)
            for k in range(2):
                _, s_k, band_k, W, (vel, share) = ring[k]
                s_k = np.full_like(s_k, s_k.mean()) if held else s_k
                x = mf._perturbed(tau, vel, (tau[rows], W, s_k), damping, band_k) / np.interp(tau, tau[rows], W)
                tot += share[:, 1] * x
            spans = " ".join(f"{np.abs(tot[(tau >= a) & (tau < b)]).max() / pk[1]:.2e}" for a, b in SPANS)
            print(f"  link_b_mid's drift, shift {label}: {spans}")


if __name__ == "__main__":
    main()
