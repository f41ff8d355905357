"""Errors that reach the user as one clear message and exit code 2."""

from __future__ import annotations

from typing import Any


class SymgenError(Exception):
    """Base class of every error symgen reports to a user (no traceback, exit code 2)."""

    exit_code = 2


class SceneError(SymgenError):
    """A scene file (or a ``--set`` override) is malformed or inconsistent.

    Parameters
    ----------
    file : path of the scene file
    key : dotted key where the problem is (``bodies.rod.lambda``), or "" for the whole file
    message : what is wrong
    hint : what to do about it
    """

    def __init__(self, file: str, key: str, message: str, hint: str = "") -> None:
        self.file, self.key, self.message, self.hint = str(file), key, message, hint
        where = f"{self.file}: {key}" if key else self.file
        text = f"{where}: {message}"
        if hint:
            text += f" ({hint})"
        super().__init__(text)


class SimulationError(SymgenError):
    """A run failed at a known tau (solver failure, singular position, ...)."""

    def __init__(self, tau: float | None, cause: str, hint: str = "") -> None:
        self.tau, self.cause, self.hint = tau, cause, hint
        self.partial: Any = None  # the run's result up to tau, when the run keeps one
        text = cause if tau is None else f"at tau = {tau:.6g}: {cause}"
        if hint:
            text += f" ({hint})"
        super().__init__(text)


class BudgetExceeded(SimulationError):
    """A check run (the error estimate's reruns, which also decide the chosen counts) took more
    integrator steps than its budget (``symgen.policy.RERUN_BUDGET`` times the run it checks):
    stopped there, with what it computed before in ``partial``; the part it served is then
    reported not estimated, with this text as its reason."""

    def __init__(self, tau: float | None, steps: int, budget: int, what: str = "") -> None:
        self.steps, self.budget = steps, budget
        super().__init__(tau, f"budget: {what}stopped after {steps} steps, beyond its budget of {budget}")


class Interrupted(KeyboardInterrupt):
    """The run was stopped by SIGINT (Ctrl-C) or SIGTERM: exit code 130 or 143.

    A ``KeyboardInterrupt`` (not a ``SymgenError``), so that no ``except SymgenError`` or
    ``except Exception`` of a loop that tolerates failed items swallows it. Raised by the
    handlers of ``symgen.numerics.interrupt.handling``; a run that stops keeps what it computed
    in ``partial`` (as ``SimulationError`` does), to be written marked ``"interrupted"``.
    ``detail`` completes the message where no tau says where the run stood ("before the first
    input position was solved (nothing to keep)").
    """

    def __init__(self, signum: int | None = None, tau: float | None = None, detail: str = "") -> None:
        import signal

        self.signum = signal.SIGINT if signum is None else signum
        try:
            self.signal_name = signal.Signals(self.signum).name
        except ValueError:
            self.signal_name = f"signal {self.signum}"
        self.exit_code = 128 + int(self.signum)
        self.tau = tau
        self.detail = detail
        # what the stopped command had done (a SimResult, a Study, an EffectsReport...: each
        # command's own result, of a higher layer), read back by the CLI; None: nothing
        self.partial: Any = None
        text = f"interrupted by {self.signal_name}"
        if tau is not None:
            text += f" at tau = {tau:.6g}"
        if detail:
            text += f" {detail}"
        super().__init__(text)

    def __reduce__(self):  # picklable (worker processes), without the partial result
        return (type(self), (self.signum, self.tau, self.detail))
