"""The integration paths measured in benchmarks/bench_faster.py.

* The batched output path (a chunk's outputs polished and recorded with mapped CasADi calls)
  gives the values of the one-output-at-a-time path it replaced (``DaeRunner.polish`` and the
  CasADi functions of the model evaluated at each output).
* ``simulate(axial_atol=...)`` (no error control on the axial amplitudes) takes far fewer IDAS
  steps on the seed's slider-crank at rtol 1e-4 and keeps the midspan deflection within 1 %.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from symgen.api import mechanism
from symgen.numerics.simulate import DaeRunner, simulate

ROOT = Path(__file__).resolve().parent.parent
ACCURATE = [
    "effects.axial=true",
    "effects.strain=von_karman",
    "bodies.rod.axial_shapes=complete",
    "bodies.rod.axial_modes=3",
    "bodies.rod.transverse_modes=2",
    "simulation.cycles=0.25",
]


def test_batched_outputs_match_one_at_a_time():
    mech = mechanism(ROOT / "examples/slider_crank.toml", ACCURATE)
    res = simulate(mech, t_end=0.5)
    run = DaeRunner(mech, res.partition, 1e-8, 1e-10)
    for i in (1, len(res.tau) // 2, len(res.tau) - 1):
        t, q, v, lam = res.tau[i], res.q[i], res.v[i], res.lam[i]
        # the recorded state satisfies the algebraic equations to the polish tolerance
        a = mech.accelerations(t, q, v)[0]
        x, z = run.pack(q, v, a, lam)
        p = np.concatenate([mech.p, [0.0]])
        g = np.array(run.g(t, x, z, p)[0]).ravel()
        assert np.abs(g).max() < 1e-10
        # and its outputs are those the model's own function gives at that state
        out = mech.call("out", t, q, v, a, lam)
        assert np.allclose(out, res.outputs[i], rtol=1e-9, atol=1e-12)
    # a batched polish of perturbed columns lands where polish of each column does
    X = np.stack(
        [
            run.pack(res.q[i], res.v[i], mech.accelerations(res.tau[i], res.q[i], res.v[i])[0], res.lam[i])[0]
            for i in (1, 2, 3)
        ],
        axis=1,
    )
    Z0 = np.stack(
        [
            run.pack(res.q[i], res.v[i], mech.accelerations(res.tau[i], res.q[i], res.v[i])[0], res.lam[i])[1]
            for i in (1, 2, 3)
        ],
        axis=1,
    ) * (1 + 1e-6)
    p = np.concatenate([mech.p, [0.0]])
    ts = res.tau[[1, 2, 3]]
    Zb = run.polish_many(ts, X, Z0, p)
    for k in range(3):
        zk = run.polish(ts[k], X[:, k], Z0[:, k], p)
        assert np.allclose(Zb[:, k], zk, rtol=0, atol=1e-12)


def test_axial_error_control_off_is_cheaper_and_close():
    mech = mechanism(ROOT / "examples/slider_crank.toml", [*ACCURATE, "simulation.rtol=1e-4", "simulation.atol=1e-6"])
    ref = simulate(mech, rtol=1e-8, atol=1e-10)
    full = simulate(mech)
    loose = simulate(mech, axial_atol=1e3)
    assert loose.steps < full.steps / 3
    peak = np.abs(ref.column("eta_mid")).max()
    assert np.abs(loose.column("eta_mid") - ref.column("eta_mid")).max() / peak < 0.01
    assert loose.closure_max < 1e-12
