"""The whole estimate adds its parts as sizes at the same instant where their sizes along the run
are known (symgen.numerics.error_estimate.same_instant): to first order an output's error is the sum
of the parts' signed differences at each instant, so its largest is at most the largest of the sum
of their sizes, which is at most the sum of each part's largest (estimator versions up to 10)."""

from __future__ import annotations

import numpy as np

from symgen.numerics.error_estimate import same_instant


def test_parts_largest_at_different_instants_are_not_added_at_their_largest():
    """Two errors that are largest at different instants (a start's ringing decaying, a drift
    growing): the error of the output, their sum, is largest nowhere near the sum of their
    largest values, and the estimate from their sizes bounds it from above without reaching that sum."""
    t = np.linspace(0.0, 10.0, 2001)
    ringing = 1e-3 * np.exp(-t) * np.sin(20 * t)  # the truncation part's difference
    drift = 1e-3 * (t / 10.0) * np.sin(20 * t + 1.0)  # the model-form part's
    peak = 2.0
    error = np.abs(ringing + drift).max() / peak  # the output's error, both present
    values = {"truncation": np.abs(ringing).max() / peak, "model_form": np.abs(drift).max() / peak, "axial": None}
    sizes = {"truncation": np.abs(ringing) / peak, "model_form": np.abs(drift) / peak}
    got = same_instant(values, sizes)
    assert got is not None
    assert error <= got <= 1.05 * error  # the bound holds and is tight where one part dominates each instant
    assert sum(v for v in values.values() if v) > 1.7 * error  # the largest values added: nearly twice


def test_parts_without_sizes_are_added_at_their_largest():
    t = np.linspace(0.0, 1.0, 11)
    a, b = np.abs(np.sin(3 * t)), np.abs(np.cos(3 * t))
    # time integration's size not known: its largest added to the others' same-instant sum
    got = same_instant(
        {"truncation": a.max(), "model_form": b.max(), "time_integration": 0.25}, {"truncation": a, "model_form": b}
    )
    assert np.isclose(got, (a + b).max() + 0.25)
    # one part's size alone: nothing to add at the same instant
    assert np.isclose(
        same_instant({"truncation": a.max(), "model_form": b.max()}, {"truncation": a}), a.max() + b.max()
    )
    # sizes on different grids (a rerun that stopped early): the largest values added
    assert np.isclose(
        same_instant({"truncation": a.max(), "model_form": b.max()}, {"truncation": a, "model_form": b[:5]}),
        a.max() + b.max(),
    )
    assert same_instant({"truncation": None, "model_form": None}, {}) is None
    # never below any part's largest
    assert same_instant({"truncation": a.max(), "model_form": b.max()}, {"truncation": a, "model_form": b}) >= max(
        a.max(), b.max()
    )
