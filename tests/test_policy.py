"""One solver policy (``symgen.policy``) for the Python runners and the emitted C: every value
reaches the C solver through the context (no constant retyped in the template), and the Python
runners read it at call time."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from c_support import mechanism, model, plan
from symgen import policy
from symgen.backends.c import context as ctx_mod
from symgen.backends.c.printer import c_double
from symgen.backends.c.render import render_files
from symgen.errors import SimulationError
from symgen.numerics import checks, start
from symgen.numerics import mechanism as mech_mod


def _odd(value):
    """A value of the same type that no template could contain by chance."""
    return value + 7919 if isinstance(value, int) else value * 1.2345678901234567


def test_every_policy_value_reaches_the_emitted_solver(monkeypatch):
    """Render the slider-crank's C with every policy value changed: each new value appears in
    the emitted sources (the C solver would not see a value retyped in its template)."""
    mech = mechanism("slider_crank")
    base = render_files(ctx_mod.c_context(mech.scene, model("slider_crank"), plan("slider_crank"), mech.info))
    odd = policy.SolverPolicy(**{k: _odd(v) for k, v in policy.POLICY.as_dict().items()})
    monkeypatch.setattr(ctx_mod, "POLICY", odd)
    files = render_files(ctx_mod.c_context(mech.scene, model("slider_crank"), plan("slider_crank"), mech.info))
    missing = []
    for field in dataclasses.fields(odd):
        new = getattr(odd, field.name)
        literal = str(new) if isinstance(new, int) else c_double(new)
        if field.name in ("partition_ratio",):  # Python-only: the C solver gets the partition
            continue
        if not any(literal in text for text in files.values()):
            missing.append(f"{field.name} ({literal})")
    assert not missing, "policy values not in the emitted C: " + ", ".join(missing)
    assert files != base


def test_python_runners_read_the_policy_at_call_time(monkeypatch):
    """The range limit and the assembly's acceptance come from POLICY when the call is made."""
    mech = mechanism("slider_crank")
    q0, _ = mech.initial_guess()
    Q = np.tile(np.asarray(q0, dtype=float).reshape(-1, 1), (1, 3))
    body, (fi, gi) = next((b, ix) for b, ix in mech.amplitudes.items() if ix[1])
    # the first function at half the slope limit: its largest slope psi_1' times the amplitude
    Q[gi[0], 2] = 0.5 * policy.POLICY.slope_limit / np.abs(checks.slope_tables(mech.info)[body][:, 0]).max()
    assert checks.beyond_range(mech, Q) is None
    monkeypatch.setattr(
        checks, "POLICY", dataclasses.replace(policy.POLICY, slope_limit=0.25 * policy.POLICY.slope_limit)
    )
    column, reason = checks.beyond_range(mech, Q)
    assert column == 2 and body in reason
    part = mech.choose_partition(0.0, q0)
    monkeypatch.setattr(mech_mod, "POLICY", dataclasses.replace(policy.POLICY, assembly_maxit=0, assembly_accept=0.0))
    with pytest.raises(SimulationError, match="cannot be assembled"):
        mech.assemble(0.0, np.asarray(q0, dtype=float) + 0.05, part, maxit=0)


def test_divergence_check_reads_the_policy_at_call_time(tmp_path, monkeypatch):
    """The divergence check of the quasi-static start (beyond a buckling load) takes its
    tolerance, POLICY.divergence_rtol, when the call is made: the column of
    tests/test_hard_cases.py at 1.1 times its Euler load diverges at rate 0.312 = 3.75 % of its
    largest |eigenvalue|, so a tolerance of 5 % sees no divergence."""
    from symgen.api import mechanism as load_mechanism
    from tests.test_hard_cases import write_column

    mech = load_mechanism(write_column(tmp_path, 1.1, 3), ["effects.axial=inextensible"])
    q, v = mech.initial_guess(0.0)
    part = mech.choose_partition(0.0, q)
    q = mech.assemble(0.0, q, part)
    qs, vs, _ = start.quasi_static(mech, 0.0, q, v, part)
    rate, coord = checks.divergent_deformation(mech, 0.0, qs, vs, part)
    assert rate == pytest.approx(0.3121, rel=1e-3) and coord == "g_col_1"
    monkeypatch.setattr(checks, "POLICY", dataclasses.replace(policy.POLICY, divergence_rtol=0.05))
    assert checks.divergent_deformation(mech, 0.0, qs, vs, part) == (0.0, "")
    monkeypatch.setattr(checks, "POLICY", dataclasses.replace(policy.POLICY, divergence_rtol=0.02))
    assert checks.divergent_deformation(mech, 0.0, qs, vs, part)[0] == rate


def test_limits_state_their_source():
    """Every policy value is documented where it is defined (the source of the number)."""
    import inspect

    src = inspect.getsource(policy.SolverPolicy)
    for field in dataclasses.fields(policy.SolverPolicy):
        line = next(ln for ln in src.splitlines() if ln.strip().startswith(f"{field.name}:"))
        above = src[: src.index(line)].rstrip().splitlines()[-1].strip()
        assert above.startswith("#:") or "..." in above, f"{field.name} has no stated source"
