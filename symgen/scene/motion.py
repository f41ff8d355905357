"""The prescribed angle of an angle driver, theta(tau), as one SymPy expression.

Three forms, all ``theta = theta0 + ...``:

* constant speed (the contract): ``theta0 + rate * tau``;
* ``law = "..."``: ``theta0 + law(tau)``, the user's expression of tau (parsed by
  :func:`symgen.scene.expressions.parse_tau_expression`, never evaluated as Python);
* ``ramp = T`` with ``rate``: the smooth spin-up of Kane, Ryan & Banerjee (1987, eq. 58),
  built here (not from user text) as a Piecewise,

      theta - theta0 = (Omega / T) [tau^2 / 2 + (T / 2 pi)^2 (cos(2 pi tau / T) - 1)],  tau < T
                     = Omega (tau - T / 2),                                              tau >= T

  whose rate rises from 0 to Omega with zero acceleration at both ends (continuous up to the
  second derivative).

The derivation (``symgen.model.derive``) differentiates the expression exactly (``sympy.diff``) for the
velocity- and acceleration-level driver rows; the loader evaluates it to check that the law is
finite over the run. Kept in ``symgen.scene`` because both use it; it imports SymPy lazily.
"""

from __future__ import annotations

from typing import Any


def ramp_law(tau: Any, rate: Any, ramp: Any) -> Any:
    """theta - theta0 of the Kane-Ryan-Banerjee spin-up to ``rate`` over ``ramp`` (tau units).

    Examples
    --------
    >>> import sympy
    >>> t = sympy.Symbol("tau")
    >>> float(ramp_law(t, 6, 15).subs(t, 20))       # 6 (20 - 7.5)
    75.0
    """
    import sympy as sp

    first = rate / ramp * (tau**2 / 2 + (ramp / (2 * sp.pi)) ** 2 * (sp.cos(2 * sp.pi * tau / ramp) - 1))
    return sp.Piecewise((first, tau < ramp), (rate * (tau - ramp / 2), True))


def user_law(text: str, tau: Any) -> Any:
    """The scene's ``law`` text as an expression of the given ``tau`` symbol."""
    from symgen.scene.expressions import parse_tau_expression

    expr = parse_tau_expression(text)
    return expr.xreplace({s: tau for s in expr.free_symbols if getattr(s, "name", "") == "tau"})


def driver_angle(driver: Any, tau: Any, theta0: Any, rate: Any, ramp: Any = None) -> Any:
    """theta(tau) of an angle driver; ``theta0``, ``rate``, ``ramp`` are symbols or numbers.

    ``driver`` is a :class:`symgen.scene.model.Driver` of kind ``"angle"``.
    """
    if driver.law is not None:
        return theta0 + user_law(driver.law, tau)
    if driver.ramp is not None:
        return theta0 + ramp_law(tau, rate, ramp)
    return theta0 + rate * tau


def driver_record(driver: Any) -> dict | None:
    """The driver as plain data for a run's JSON sidecar (the law as written; angles in rad,
    times in tau)."""
    if driver is None:
        return None
    out = {"kind": driver.kind, "body": driver.body, "initial": driver.initial}
    if getattr(driver, "rotor_inertia", 0.0):
        out["rotor_inertia"] = driver.rotor_inertia  # / (m_ref l0^3)
    if driver.kind == "torque":
        out["torque"] = driver.torque
        return out
    if driver.law is not None:
        out["law"] = driver.law
        out["theta"] = f"initial + ({driver.law})"
    else:
        out["rate"] = driver.rate
        if driver.ramp is not None:
            out["ramp"] = driver.ramp
            out["theta"] = (
                "initial + (rate/ramp) (tau^2/2 + (ramp/(2 pi))^2 (cos(2 pi tau/ramp) - 1)) "
                "for tau < ramp, else initial + rate (tau - ramp/2)"
            )
        else:
            out["theta"] = "initial + rate tau"
    return out


def check_finite(driver: Any, t_end: float, samples: int = 64) -> tuple[float, str] | None:
    """First (tau, what) in [0, t_end] where theta, theta' or theta'' is not a finite real
    number, else None (:func:`symgen.scene.expressions.first_non_finite` of each: a pole counts
    even between the samples). ``driver`` has numeric ``initial``, ``rate``, ``ramp``."""
    from symgen.scene.expressions import derivative, first_non_finite, tau_symbol

    tau = tau_symbol()
    theta = driver_angle(driver, tau, driver.initial or 0.0, driver.rate, driver.ramp)
    exprs = (
        ("theta", theta),
        ("d theta/d tau", derivative(theta, tau)),
        ("d2 theta/d tau2", derivative(theta, tau, 2)),
    )
    bad = [(t, k, what) for k, (what, e) in enumerate(exprs) if (t := first_non_finite(e, t_end, samples)) is not None]
    return (min(bad)[0], min(bad)[2]) if bad else None
