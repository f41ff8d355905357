"""Dynamic simulation with SUNDIALS IDAS (through CasADi) of the index-1 DAE of ``Mechanism``.

Integration runs in chunks of growing length (128 outputs, doubling up to 2048) with one
integrator object per chunk length, reused (time enters through an offset parameter), so that
a failure can be located within one output step, the partial result kept, and the rigid
mechanism's distance to a singular position checked at every output. The model's functions
run compiled (a cached shared library, :mod:`symgen.numerics.compiled`) or in CasADi's virtual
machine, with the same numbers.
At each output the algebraic variables are polished by Newton on the algebraic equations
(position closure to ~1e-14), then the outputs are evaluated.

A run with no differential state (every rigid coordinate driven, every elastic amplitude
quasi-static: ``bodies.<name>.quasi_static_transverse`` with the axial ones quasi-static or
constrained) has nothing to integrate: each output is the solution of the algebraic equations at
its time, by Newton continued from the previous outputs (:class:`AlgebraicSweep`, one CasADi call
per block of outputs); IDAS is not run.
"""

from __future__ import annotations

import math
import re
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from symgen.errors import BudgetExceeded, Interrupted, SceneError, SimulationError
from symgen.progress import progress_bar
from symgen.ir.records import CoordKind
from symgen.policy import POLICY
from symgen.numerics import compiled, interrupt
from symgen.numerics import checks
from symgen.numerics.index1 import Index1, Partition, index1
from symgen.numerics.mechanism import Mechanism
from symgen.numerics.run_result import SimResult as SimResult  # its home; imported from here too
from symgen.numerics.start import State, continuum_start_outputs

CHUNK = 128  # output steps of the first integrator call; each next one covers twice as
CHUNK_MAX = 2048  # many, up to CHUNK_MAX, or all the rest when that is at most twice as many
# (the same chunks whatever the backend: the same steps, the same numbers)
CALC_IC = False  # z0 is always consistent (our own Newton); IDACalcIC only fails on it
#: IDAS's Newton linear solver: CSparse's sparse LU (CasADi's "csparse"), not CasADi's default
#: dense QR: 3x cheaper per step on a 12-bar chain, about N^0.96 per step against N^1.26, and
#: no dearer on a 2-bar model (benchmarks/RESULTS.md "perstep"). The two move the results only
#: within the integration's error (tests/test_rotor_inertia.py and tests/test_spinup.py
#: measured it: at rtol 1e-10 they differed by 1e-8 relative; at rtol 1e-12 by 1e-10).
LINEAR_SOLVER: str | None = "csparse"
#: The progress watchdog: IDAS may take at most this many steps per degree of the driver's
#: motion (per 0.01745 tau without a driven rate) within one output step. Real runs take tens
#: to hundreds (steel bars at 0.1 %: about 80); a run beyond it has stalled, its steps shrunk to
#: nothing at a near-singular position or a load singular there, and stops in seconds naming
#: where, instead of grinding for minutes (IDAS_TOO_MUCH_WORK, reported by ``_lost``).
MAX_STEPS_PER_DEGREE = 100_000
#: A run with no differential state (:class:`AlgebraicSweep`): Newton at each output stops at this
#: |residual|_inf (the rows are O(1) positions and rates, and forces in the model's units; 10x the
#: polish's tolerance: from an extrapolated guess, not from the integrator's value) ...
ALGEBRAIC_TOL = 1e-12
#: ... or after this many iterations (it converges in 2 to 4 from the extrapolated guess; the rest
#: is room for a fast driver between outputs) ...
ALGEBRAIC_MAXIT = 30
#: ... and the output is accepted when its position closure (the first m rows) is within this: the
#: dynamic rows are linear in (a, lam) and carry force units (1e6 masses: round-off above any
#: absolute 1e-9); beyond it the closure has no solution near the last one (a singular position)
ALGEBRAIC_CLOSURE = 1e-9


class DaeRunner:
    """The index-1 DAE of a partition as CasADi Functions, and IDAS over it.

    ``backend``: "compiled" (the Functions compiled to a cached shared library, see
    :mod:`symgen.numerics.compiled`), "vm" (CasADi's virtual machine) or "auto" (compiled when a C
    compiler is at hand, else the virtual machine, said in one line on stderr). Both evaluate
    the same operations in the same order: their results agree to the last bit."""

    def __init__(
        self,
        mech: Mechanism,
        part: Partition,
        rtol: float,
        atol: float,
        axial_atol: float | None = None,
        backend: str | None = None,
        use_cache: bool = True,
        background: bool = False,
    ) -> None:
        self.mech, self.part = mech, part
        I, D = list(part.ind), list(part.dep)
        self.nI, self.nD = len(I), len(D)
        self.n_sing = len([i for i in D if i not in mech.inext_f])
        self.backend: str = "vm"
        self.library: str | None = None  # compiled: "built" for this run, or "cached"
        self._built: dict[str, ca.Function] = {}
        self._pending: compiled.PendingLibrary | None = None
        self._store = use_cache
        self._maps: dict[tuple[str, int], ca.Function] = {}
        self._integrators: dict[tuple[float, int], ca.Function] = {}
        self._xdot0: dict[tuple[float, int], list[float]] = {}
        self.vm_until: float | None = None  # a run that switched to the compiled library: where
        choice = self.choice = compiled.backend_choice(backend)
        if choice == "compiled" or (choice == "auto" and not mech.provisional):
            self._use_compiled(choice, use_cache, background and choice == "auto")
        if self.backend == "vm":
            funcs = self._functions()
            self._bind(funcs["dae"], funcs["g"], funcs["split"], funcs["rec"])
        self.opts: dict[str, float | bool | str | list[float]] = {
            "abstol": atol,
            "reltol": rtol,
            "max_num_steps": 2_000_000,
            "suppress_algebraic": True,
            "disable_internal_warnings": True,
            "calc_ic": CALC_IC,
        }
        if LINEAR_SOLVER is not None:
            self.opts["linear_solver"] = LINEAR_SOLVER
        if axial_atol is not None:
            # a looser error control on the axial amplitudes and their rates (x = [q_I, v_I])
            ax = [axial_atol if mech.coords[i].kind is CoordKind.F else atol for i in I]
            self.opts["abstolv"] = ax + ax + [atol] * (2 * self.nD + mech.n + mech.m)

    def _bind(self, dae: ca.Function, g: ca.Function, split: ca.Function, rec: ca.Function) -> None:
        """Evaluate with these Functions (the virtual machine's or a compiled library's): the
        integrators and maps made of the others are dropped."""
        self.dae, self.g, self.split, self.rec = dae, g, split, rec
        # one Newton step of the output polish, solved inside CasADi: mapped over a chunk, only
        # the new Z and each column's residual norm cross into Python (not the k Jacobians);
        # gstep_checked also gives the residual after the step: one call per Newton step, the
        # test that ends it included (the outputs of IDAS take one step to the tolerance)
        tm, xm, zm, pm = (ca.MX.sym(nm, self.g.size1_in(i)) for i, nm in enumerate(("t", "x", "z", "p")))
        gm, jm = self.g(tm, xm, zm, pm)
        znew = zm - ca.solve(jm, gm)
        self.gstep = ca.Function("gstep", [tm, xm, zm, pm], [znew, ca.norm_inf(gm)])
        self.gstep_checked = ca.Function(
            "gstep_checked",
            [tm, xm, zm, pm],
            [znew, ca.norm_inf(gm), ca.norm_inf(self.g(tm, xm, znew, pm)[0])],
        )
        self._maps.clear()
        self._integrators.clear()

    def algebraic(self) -> AlgebraicSweep:
        """The Newton continuation of a partition without differential states on this runner's
        Functions: made once per mechanism, partition and backend (``Mechanism.algebraic_sweeps``;
        a later runner's Functions are the same operations: the virtual machine's from the same
        memo, a compiled library's from the same verified entry)."""
        key = (self.part, self.backend)
        memo = self.mech.algebraic_sweeps
        if key not in memo:
            memo[key] = AlgebraicSweep(self.g, self.mech.m)
        return memo[key]

    def switch_when_built(self, tau: float) -> None:
        """Between chunks of a run started in the virtual machine while its library compiles in
        the background: from now on the compiled Functions, once the library is there (the same
        operations in the same order: the same numbers to the last bit, so the switch does not
        change the run); stays in the virtual machine, said once, when the compile failed."""
        if self._pending is None or not self._pending.done():
            return
        ext = self._settle()
        if ext is not None:
            self._bind(ext["dae"], _library_g(ext), ext["split"], ext["rec"])
            self.backend, self.library, self.vm_until = "compiled", "built", tau

    def settle(self) -> None:
        """Wait for a background compile still running (its library is the next run's, from the
        cache; a signal meanwhile cancels it); without the cache (``use_cache=False``: a library
        for this run only) it is cancelled instead."""
        if self._pending is not None and not self._store:
            self.cancel()
        elif self._pending is not None:
            self._settle()

    def cancel(self) -> None:
        """Kill a background compile still running (nothing of it is left in the cache)."""
        if self._pending is not None:
            self._pending.cancel()
            self._pending = None

    def _settle(self) -> dict[str, ca.Function] | None:
        assert self._pending is not None
        pending, self._pending = self._pending, None
        try:
            return pending.result()
        except compiled.Unavailable as exc:
            _notice(
                f"{exc.reason}: running the model in CasADi's virtual machine (slower; "
                f"--backend vm or ${compiled.BACKEND_ENV}=vm chooses it quietly)"
            )
            return None

    def _functions(self) -> dict[str, ca.Function]:
        """The runner's SX Functions, made on first use: ``dae`` (the index-1 DAE for IDAS, time
        offset in the last parameter), ``jac_dae`` (its Jacobian as IDAS asks a compiled ``dae``
        for it), ``g`` (the algebraic equations and their Jacobian in z), ``split`` and ``rec``
        (everything recorded at an output, mapped over a chunk's outputs)."""
        if not self._built:
            memo = self.mech.runner_functions
            if self.part not in memo:
                memo[self.part] = _symbolic(self.mech, self.part)
            self._built = memo[self.part]
        return self._built

    def _compiled_functions(self) -> list[ca.Function]:
        """The Functions ``COMPILED`` (with ``jac_dae``, which only a compiled ``dae`` needs; without
        ``g`` where the model has calls, :func:`_library_names`), each with its repeated operations
        made once (``_shared``: the same numbers to the last bit)."""
        funcs = self._functions()
        if "jac_dae" not in funcs:
            dae = funcs["dae"]
            dae_in = dae.sx_in()
            funcs["jac_dae"] = _dae_jacobian(dae, dae_in, dae.call(dae_in))
        names = _library_names(self.mech)
        for name in names:
            if f"compiled:{name}" not in funcs:
                funcs[f"compiled:{name}"] = _shared(funcs[name])
        return [funcs[f"compiled:{name}"] for name in names]

    def _use_compiled(self, choice: str, use_cache: bool, background: bool = False) -> None:
        """Run the Functions from a compiled library (built once, cached; when cached, the
        symbolic Functions are not even made); when no C compiler works, stay in the virtual
        machine (said once on stderr) unless ``choice`` is "compiled". ``background``: a
        library not in the cache is compiled in a background thread while the run starts in the
        virtual machine (:meth:`switch_when_built`)."""
        mech, part = self.mech, self.part
        build = self._compiled_functions
        signatures = _signatures(mech, part)
        try:
            found = compiled.start_library(
                signatures,
                build,
                mech.info.key,
                f"ind={list(part.ind)} dep={list(part.dep)}"
                + (f" quasi={list(part.quasi)}" if part.quasi else "")
                + f" {JACOBIAN}"
                + (" bar calls" if _calls(mech) else ""),
                store=use_cache,
                cold=COLD,
                background=background,
            )
            if isinstance(found, compiled.PendingLibrary):
                self._pending = found
                return
            ext, built = found
        except compiled.Unavailable as exc:
            if choice == "compiled":
                raise SceneError(
                    "command line",
                    "--backend",
                    f"compiled: {exc.reason}",
                    f"install a C compiler or set ${compiled.CC_ENV} to one; or run with --backend vm",
                ) from None
            _notice(
                f"{exc.reason}: running the model in CasADi's virtual machine (slower; "
                f"--backend vm or ${compiled.BACKEND_ENV}=vm chooses it quietly)"
            )
        else:
            self._bind(ext["dae"], _library_g(ext), ext["split"], ext["rec"])
            self.backend, self.library = "compiled", "built" if built else "cached"

    def pack(self, q: np.ndarray, v: np.ndarray, a: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.part.pack(q, v, a, lam)

    def unpack(self, x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        q, v, a, lam = self.split(x, z)
        return (np.array(q).ravel(), np.array(v).ravel(), np.array(a).ravel(), np.array(lam).ravel())

    def quasi_start(self, t0: float, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        """z at t0 with the quasi-static amplitudes (and with them a, lam) solved from the
        algebraic equations by Newton from the full model's consistent start (converged as
        ``POLICY.quasi_start_tol`` and ``quasi_start_floor`` say); refused when it does not
        converge (a quasi-static function near buckling: keep it dynamic)."""
        p = np.concatenate([self.mech.p, [t0]])
        z = np.array(z, dtype=float)
        last = np.inf
        for _ in range(POLICY.quasi_start_maxit):
            g, J = self.g(0.0, x, z, p)
            try:
                dz = np.linalg.solve(np.array(J), np.array(g).ravel())
            except np.linalg.LinAlgError:
                break
            z = z - dz
            if not np.all(np.isfinite(z)):
                break
            step, size = np.abs(dz).max(), max(1.0, np.abs(z).max())
            if step <= POLICY.quasi_start_tol * size or (step <= POLICY.quasi_start_floor * size and step > 0.5 * last):
                return z
            last = step
        raise SimulationError(
            t0,
            "the quasi-static transverse amplitudes have no solution at the start (Newton does not converge)",
            "lower bodies.<name>.quasi_static_transverse (keep those functions dynamic)",
        )

    def integrator(self, h: float, k: int, x: np.ndarray, z: np.ndarray) -> ca.Function:
        """IDAS over k output steps of h (time offset in the last parameter), made once per k
        and reused. The state derivatives at the start are those at (x, z) of its first use
        (x' = [v_I, a_I], read from z): CasADi would otherwise start IDAS with x' = 0, and a
        nonzero initial acceleration then forces steps of order atol/|a|; at later starts they
        are close enough."""
        if (h, k) not in self._integrators:
            opts = dict(self.opts)
            # kept across a switch to the compiled Functions: the integrator remade for them
            # starts as the first one did
            opts["init_xdot"] = self._xdot0.setdefault((h, k), [float(w) for w in self.xdot(x, z)])
            opts["max_num_steps"] = self.max_steps(h)
            grid = [h * (i + 1) for i in range(k)]
            self._integrators[(h, k)] = ca.integrator("F", "idas", self.dae, 0.0, grid, opts)
        return self._integrators[(h, k)]

    def max_steps(self, h: float) -> int:
        """The watchdog's IDAS step budget of one output step h (``MAX_STEPS_PER_DEGREE``)."""
        rates = [abs(d.rate) for d in self.mech.scene.angle_drivers if d.rate]
        rate = max(rates) if rates else 1.0  # the fastest angle driver
        degree = math.pi / 180 / rate
        return int(MAX_STEPS_PER_DEGREE * max(1.0, h / degree))

    def xdot(self, x: ArrayLike, z: ArrayLike) -> np.ndarray:
        x = np.asarray(x, dtype=float).ravel()
        z = np.asarray(z, dtype=float).ravel()
        a = z[2 * self.nD : 2 * self.nD + self.mech.n]
        return np.concatenate([x[self.nI :], a[list(self.part.ind)]])

    def _map(self, name: str, k: int) -> ca.Function:
        key = (name, k)
        if key not in self._maps:
            fun: ca.Function = getattr(self, name)  # one of the Functions above, by name
            self._maps[key] = fun.map(k)
        return self._maps[key]

    def polish_many(
        self, t: np.ndarray, X: np.ndarray, Z: np.ndarray, p: np.ndarray, tol: float = POLICY.polish_tol
    ) -> np.ndarray:
        """``polish`` of every column of Z at once (one mapped Newton step per iteration, the
        same iteration per column: columns stop when their residual is below ``tol``; a column
        whose step is not finite (singular Jacobian) keeps its last value). Each call takes the
        step of the columns whose residual is at least ``tol`` and returns the residual after it
        (``gstep_checked``), so a column whose step reached ``tol`` needs no further call; the
        later calls evaluate only the columns still polished (a map of the next power of two of
        them, padded with the last one): each column gets the same numbers as alone (the
        iteration of ``gstep``: the same steps, the same tests)."""
        k = X.shape[1]
        t = np.asarray(t, dtype=float).ravel()
        Z = np.array(Z, dtype=float)
        cols = np.arange(k)  # the columns still polished
        for _ in range(POLICY.polish_maxit):
            width = k if len(cols) == k else 1 << (len(cols) - 1).bit_length()
            pick = np.concatenate([cols, np.full(width - len(cols), cols[-1])])
            Znew, before, after = self._map("gstep_checked", width)(t[pick].reshape(1, -1), X[:, pick], Z[:, pick], p)
            keep = np.array(before).ravel()[: len(cols)] >= tol  # these take the step
            if not keep.any():
                break
            Znew = np.array(Znew)[:, : len(cols)][:, keep]
            after = np.array(after).ravel()[: len(cols)][keep]
            cols = cols[keep]
            finite = np.isfinite(Znew).all(axis=0)
            cols = cols[finite]
            Z[:, cols] = Znew[:, finite]
            cols = cols[after[finite] >= tol]  # a step that reached tol ends its column
            if not len(cols):
                break
        return Z

    def polish(
        self, t: float, x: np.ndarray, z: np.ndarray, p: np.ndarray, tol: float = POLICY.polish_tol
    ) -> np.ndarray:
        z = np.array(z, dtype=float).ravel()
        for _ in range(POLICY.polish_maxit):
            g, J = self.g(t, x, z, p)
            g = np.array(g).ravel()
            if np.abs(g).max() < tol:
                break
            try:
                z = z - np.linalg.solve(np.array(J), g)
            except np.linalg.LinAlgError:
                break
        return z


@dataclass(frozen=True)
class RunSettings:
    """The times, tolerances and backend of one run: ``simulate``'s arguments, else the scene's."""

    t0: float
    t_end: float
    h: float  # output step
    rtol: float
    atol: float
    axial_atol: float | None
    backend: str | None
    use_cache: bool
    #: a check run's step budget (``symgen.policy.rerun_budget``): stopped past it (``BudgetExceeded``)
    max_steps: int | None = None

    @property
    def n_outputs(self) -> int:
        """Output steps after t0: the outputs are at t0 + i h, i = 0 .. n_outputs."""
        return int(np.floor((self.t_end - self.t0) / self.h + 1e-9))


def simulate(
    mech: Mechanism,
    t_end: float | None = None,
    output_step: float | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    t0: float = 0.0,
    initial: State | None = None,
    axial_atol: float | None = None,
    backend: str | None = None,
    use_cache: bool = True,
    progress: bool = False,
    max_steps: int | None = None,
) -> SimResult:
    """Integrate the scene's DAE from t0 to t_end, output every output_step (in tau).

    ``axial_atol``: absolute tolerance of the axial amplitudes and their rates instead of
    ``atol`` (e.g. 1e3: no error control on them, so IDAS's BDF steps over the start-up
    ringing of the stiff axial modes and damps it numerically; bending and rigid motion keep
    rtol/atol; see benchmarks/RESULTS.md for what it costs in accuracy).

    ``backend``: "auto" (default, or ``$SYMGEN_BACKEND``), "compiled" or "vm" (see ``DaeRunner``);
    ``use_cache=False``: a compiled library is built for this run only. ``progress``: a progress
    bar of tau on stderr while it runs, when stderr is a terminal (the command line's runs).
    ``max_steps``: a check run's budget of IDAS steps (the error estimate's reruns:
    ``symgen.policy.rerun_budget``): checked before each chunk of outputs (the chunks as any run's:
    it overshoots by at most one chunk, and its steps are a run's without a budget); past it the run stops with
    ``BudgetExceeded`` (a ``SimulationError``, its ``.partial`` the outputs before).

    A run that stops early (``SimulationError``: a solver failure, a singular position, a bar
    beyond its range; ``Interrupted``: SIGINT/SIGTERM) raises with ``.partial``, the
    ``SimResult`` of the outputs recorded before it (``complete=False``).

    A scene whose axial dynamics are kept only while a damped start ringing lasts
    (``Scene.axial_switch``, :mod:`symgen.numerics.axial_choice`) is run in two parts when the
    switch falls inside the run: with ``mech`` to the first output at or after it, then with
    the quasi-static model from the state reached (:func:`_switched`), one result."""
    sim = mech.scene.simulation
    settings = RunSettings(
        t0=t0,
        t_end=sim.t_end if t_end is None else t_end,
        h=sim.output_step if output_step is None else output_step,
        rtol=sim.rtol if rtol is None else rtol,
        atol=sim.atol if atol is None else atol,
        axial_atol=axial_atol,
        backend=backend,
        use_cache=use_cache,
        max_steps=max_steps,
    )
    switch = mech.scene.axial_switch
    if switch is not None:
        h = settings.h
        t_switch = t0 + math.ceil((switch.tau - t0) / h - 1e-9) * h  # on this run's output grid
        if t0 < t_switch < settings.t_end - 1e-9 * h:
            return _switched(mech, settings, t_switch, initial, progress)
        if t_switch <= t0 and initial is None:  # the run starts after the switch: the quasi-static model's own start
            return _run(after_switch(mech), settings, None, progress)
    return _run(mech, settings, initial, progress)


def after_switch(mech: Mechanism) -> Mechanism:
    """The model a run of ``mech`` continues with after its axial switch (``Scene.axial_switch``):
    the scene's bars kept dynamic for the start's ringing quasi-static, loaded once per mechanism."""
    from dataclasses import replace

    from symgen.numerics.mechanism import load_mechanism

    if mech.after_switch is None:
        mech.after_switch = load_mechanism(replace(mech.scene, axial_kept=(), axial_switch=None))
    return mech.after_switch


def switched_rows(before: Mechanism, after: Mechanism, bars: list[str]) -> list[int] | None:
    """The columns of ``after``'s multipliers that are ``before``'s, in ``before``'s order, where
    ``after`` is ``before`` with the axial dynamics of ``bars`` quasi-static (their inextensibility
    rows added); None where the two models' coordinates or other rows differ."""
    from symgen.ir.records import RowKind

    if [c.name for c in before.coords] != [c.name for c in after.coords]:
        return None
    keep = [i for i, r in enumerate(after.info.lam_rows) if not (r.kind is RowKind.INEXTENSIBLE and r.joint in bars)]
    mine = [(r.kind, r.joint) for r in before.info.lam_rows]
    if mine != [(after.info.lam_rows[i].kind, after.info.lam_rows[i].joint) for i in keep]:
        return None
    return keep


def _switched(
    mech: Mechanism, settings: RunSettings, t_switch: float, initial: State | None, progress: bool
) -> SimResult:
    """A run of ``mech`` to ``t_switch`` (an output), continued to the run's end with its
    quasi-static model (:func:`after_switch`) from the state reached (``start.continued_start``):
    one result on ``mech``'s coordinates and multipliers (those of the quasi-static bars'
    inextensibility rows left out), its stats saying where it switched. A stop in the second part
    keeps the first."""
    from dataclasses import replace

    from symgen.numerics.start import continued_start

    first = _run(mech, replace(settings, t_end=t_switch), initial, progress)
    after = after_switch(mech)
    bars = [b for b, _ in mech.scene.axial_kept]
    keep = switched_rows(mech, after, bars)
    if keep is None:  # axial_choice checks it before it decides a switch
        raise RuntimeError(f"the models before and after the axial switch of {', '.join(bars)} do not match")
    budget = None if settings.max_steps is None else max(settings.max_steps - first.steps, 0)
    try:
        state = continued_start(after, t_switch, first.q[-1], first.v[-1])
        second = _run(after, replace(settings, t0=t_switch, max_steps=budget), state, progress)
    except (SimulationError, Interrupted) as err:
        part = getattr(err, "partial", None)
        err.partial = _joined(first, part, after, keep, t_switch) if part is not None else first
        raise
    return _joined(first, second, after, keep, t_switch)


def _joined(first: SimResult, second: SimResult, after: Mechanism, keep: list[int], t_switch: float) -> SimResult:
    """The two parts of a switched run as one result (the second's first output is the first's
    last). The second part's states as the kept model reads them: a quasi-static bar's axial
    amplitudes f + N / lambda (the stretch its outputs add; ``axial_drift``'s stretched bar) and
    their rates with the stretch's rate along the outputs, so what reads the run's states after it
    with the kept model (the error estimate's model-form and truncation parts, the animation)
    sees the stretched bar."""
    from symgen.numerics.axial_drift import quasi_static_bars, stretched

    n2 = len(second.tau)
    lam_all = np.asarray(second.lam, dtype=float).reshape(n2, -1)
    q = np.asarray(second.q, dtype=float)
    q2 = stretched(after, q, lam_all, quasi_static_bars(after))
    v2 = np.array(second.v, dtype=float)
    if n2 > 1:
        v2 += np.gradient(q2 - q, np.asarray(second.tau, dtype=float), axis=0)
    stats = dict(second.stats)
    stats.update(axial_switch=t_switch, steps_before_switch=first.steps, steps_after_switch=second.steps)
    return SimResult(
        tau=np.concatenate([first.tau, second.tau[1:]]),
        outputs=np.vstack([first.outputs, second.outputs[1:]]),
        output_names=list(first.output_names),
        q=np.vstack([first.q, q2[1:]]),
        v=np.vstack([first.v, v2[1:]]),
        lam=np.vstack([np.asarray(first.lam, dtype=float).reshape(len(first.tau), -1), lam_all[1:, keep]]),
        closure_max=max(first.closure_max, second.closure_max),
        steps=first.steps + second.steps,
        simulate_s=first.simulate_s + second.simulate_s,
        partition=first.partition,
        complete=second.complete,
        failure=second.failure,
        stats=stats,
        start_forces=first.start_forces,
    )


def _run(mech: Mechanism, settings: RunSettings, initial: State | None, progress: bool) -> SimResult:
    """:func:`simulate` with one model."""
    t0 = settings.t0
    run, x, z, setup_s = _start(mech, settings, initial)
    traj = _Trajectory(run)
    tic = time.perf_counter()
    # no differential state: the algebraic solution at each output (IDAS has nothing to integrate)
    motion = _algebraic_motion if run.nI == 0 else _integrate
    try:
        traj.record(t0, x, z)
        traj.continuum_start(t0)
        if progress:  # tqdm, and only when stderr is a terminal
            with progress_bar(settings.n_outputs, "simulate", unit="output") as bar:
                motion(run, traj, settings, x, z, bar.update)
        else:
            motion(run, traj, settings, x, z)
    except BaseException as err:
        run.cancel()  # a background compile of the library: nothing of it is kept
        stop = _stopped(err, traj, t0)
        if stop is None:
            raise
    else:
        stop = None
    result = traj.result(time.perf_counter() - tic, setup_s, stop)
    if stop is not None:
        stop.partial = result  # symgen.errors does not declare the errors' partial
        raise stop
    tic = time.perf_counter()
    try:
        run.settle()  # the library compiled in the background, for the next run
    except BaseException as err:
        signal = interrupt.interrupted(err, float(result.tau[-1]))
        if signal is err:
            raise
        signal.partial = result  # type: ignore[attr-defined]  # symgen.errors does not declare it
        raise signal from None
    result.stats["library_wait_s"] = time.perf_counter() - tic
    if run.vm_until is not None:
        result.stats["vm_until"] = run.vm_until
    return result


def _start(
    mech: Mechanism, settings: RunSettings, initial: State | None
) -> tuple[DaeRunner, np.ndarray, np.ndarray, float]:
    """The consistent start (``initial``, else the mechanism's own at t0), the runner of its
    partition and the runner's set-up time: (runner, x, z, setup_s). A signal meanwhile (the
    assembly, the consistent state, a compiled library's build) stops the run at t0."""
    try:
        q, v, a, lam, part = mech.initial_state(settings.t0) if initial is None else initial
        part = mech.run_partition(part)
        run, setup_s = _runner(mech, part, settings)
        try:
            x, z = run.pack(q, v, a, lam)
            if part.quasi:  # the quasi-static amplitudes: the solution of their rows at the start
                z = run.quasi_start(settings.t0, x, z)
        except BaseException:
            run.cancel()
            raise
    except BaseException as err:
        stop = interrupt.interrupted(err, settings.t0)
        if stop is err:
            raise
        raise stop from None
    return run, x, z, setup_s


def _runner(mech: Mechanism, part: Partition, settings: RunSettings) -> tuple[DaeRunner, float]:
    """The runner of a partition with the run's tolerances and backend, and the seconds it took."""
    tic = time.perf_counter()
    run = DaeRunner(
        mech,
        part,
        settings.rtol,
        settings.atol,
        settings.axial_atol,
        settings.backend,
        settings.use_cache,
        background=True,
    )
    return run, time.perf_counter() - tic


class _Trajectory:
    """The outputs of a run recorded so far, each checked as it is recorded (a bar beyond the
    range of the model or a singular position of the rigid mechanism ends the run there), the
    IDAS steps taken, and the ``SimResult`` they make: what a run that stops early keeps."""

    def __init__(self, run: DaeRunner) -> None:
        self.run, self.mech, self.part = run, run.mech, run.part
        self.taus: list[float] = []
        self.outs: list[np.ndarray] = []
        self.qs: list[np.ndarray] = []
        self.vs: list[np.ndarray] = []
        self.lams: list[np.ndarray] = []
        self.closure_max = 0.0
        self.steps = 0
        self.newton = 0  # Newton iterations of a run without differential states (AlgebraicSweep)
        self.start_forces: list[str] = []  # the first output's columns that are the continuum's

    def whole(self) -> int:
        """The outputs recorded whole (an interrupt may land between the appends of one output)."""
        return min(len(self.taus), len(self.outs), len(self.qs), len(self.vs), len(self.lams))

    def _append(self, t: float, out: np.ndarray, q: np.ndarray, v: np.ndarray, lam: np.ndarray) -> None:
        self.taus.append(t)
        self.outs.append(out)
        self.qs.append(q)
        self.vs.append(v)
        self.lams.append(lam)

    def record(self, t: float, x_: np.ndarray, z_: np.ndarray, append: bool = True) -> None:
        """The output at t (``append=False``: only its checks), or the ``SimulationError`` of a
        check it fails."""
        run, mech = self.run, self.mech
        qq, vv, aa, ll = run.unpack(x_, z_)
        if append:
            out = mech.call("out", t, qq, vv, aa, ll)
            clo = mech.call("closure", t, qq)
            if clo.size:
                self.closure_max = max(self.closure_max, float(np.abs(clo).max()))
            self._append(t, out, qq, vv, ll)
        beyond = checks.beyond_range(mech, qq)
        if beyond is not None:
            raise SimulationError(t, beyond[1], "check the loads, lumped masses and stiffness (lambda, mu) of that bar")
        ratio, row = checks.singular_ratio(mech, t, qq, self.part)
        if ratio < POLICY.singular_ratio:
            raise SimulationError(
                t,
                f"the rigid mechanism reached a singular position: the closure Jacobian "
                f"of the {mech.loop_name(row)} loses rank (ratio {ratio:.2e})",
                "the mechanism cannot pass this position as driven; shorten t_end or change the geometry",
            )

    def continuum_start(self, t: float) -> None:
        """The first output's joint forces (driver torques, reactions) as the continuum gives them
        at an unstressed start (``symgen.numerics.start.continuum_start_outputs``; the emitted C
        solver's first row alike); the model's own where it does not apply, or where the KKT
        matrix with the bars' masses scaled is singular."""
        try:
            cont = continuum_start_outputs(self.mech, t, self.qs[0], self.vs[0])
        except np.linalg.LinAlgError:
            cont = None
        if not cont:
            return
        names = list(self.mech.info.outputs)
        out = np.array(self.outs[0], dtype=float)
        for name, value in cont.items():
            out[names.index(name)] = value
        self.outs[0] = out
        self.start_forces = list(cont)

    def record_many(self, ts: np.ndarray, rel: np.ndarray, X: np.ndarray, Z: np.ndarray, p: np.ndarray) -> None:
        """``record`` of a chunk's outputs with one mapped call (same values, same stop at the
        first singular position)."""
        run, mech = self.run, self.mech
        k = len(ts)
        Q, V, L, O, C, Jd = (np.array(w) for w in run._map("rec", k)(rel.reshape(1, -1), X, Z, p))
        L, O, C = (w.reshape(-1, k) for w in (L, O, C))  # no multipliers (an open chain): (0, k)
        stop = k
        if run.n_sing:
            bad = _singular_outputs(Jd.reshape(-1, k, run.n_sing).transpose(1, 0, 2))
            if len(bad):
                stop = int(bad[0]) + 1
        beyond = checks.beyond_range(mech, Q)
        if beyond is not None and beyond[0] < stop:
            stop = beyond[0] + 1
        if C.size:
            self.closure_max = max(self.closure_max, float(np.abs(C[:, :stop]).max()))
        for i in range(stop):
            self._append(ts[i], O[:, i], Q[:, i], V[:, i], L[:, i])
        if stop < k:
            self.record(ts[stop - 1], X[:, stop - 1], Z[:, stop - 1], append=False)  # raises, naming the loop

    def result(self, elapsed: float, setup_s: float, stop: BaseException | None) -> SimResult:
        """The outputs recorded whole as a ``SimResult`` (``stop``: what ended the run early)."""
        n = self.whole()
        return SimResult(
            tau=np.array(self.taus[:n]),
            outputs=np.array(self.outs[:n]),
            output_names=list(self.mech.info.outputs),
            q=np.array(self.qs[:n]),
            v=np.array(self.vs[:n]),
            lam=np.array(self.lams[:n]),
            closure_max=self.closure_max,
            steps=self.steps,
            simulate_s=elapsed,
            partition=self.part,
            complete=stop is None,
            failure="" if stop is None else str(stop),
            stats={
                "backend": self.run.backend,
                "library": self.run.library,
                "setup_s": setup_s,
                "backend_choice": self.run.choice,
                # x = [q_I, v_I]; none: the outputs are the algebraic solutions, by Newton
                "differential_states": 2 * self.run.nI,
                "newton_iterations": self.newton if self.run.nI == 0 else None,
            },
            start_forces=tuple(self.start_forces),
        )


def _singular_outputs(J: np.ndarray) -> np.ndarray:
    """The indices i where the closure Jacobian J[i] (loop rows x dependent rigid coordinates)
    is singular: smallest / largest singular value below ``POLICY.singular_ratio``. A square
    J[i] with |det| / ||J||_F^n above twice that is not, without its SVD: that quotient is a
    lower bound of the ratio (|det| = prod(sigma) <= sigma_min sigma_max^(n-1), sigma_max <=
    ||J||_F), and it settles nearly every output; the others (near singular, not finite, not
    square) are decided by the SVD as before."""
    check = np.ones(len(J), dtype=bool)
    rows, cols = J.shape[1:]
    if rows == cols:
        with np.errstate(all="ignore"):
            bound = np.abs(np.linalg.det(J)) / np.linalg.norm(J, axis=(1, 2)) ** cols
        check = ~(bound >= 2 * POLICY.singular_ratio)  # NaN: checked
    ratio = np.ones(len(J))
    if check.any():
        sv = np.linalg.svd(J[check], compute_uv=False)
        ratio[check] = sv[:, -1] / np.maximum(sv[:, 0], 1e-300)
    return np.nonzero(ratio < POLICY.singular_ratio)[0]


@dataclass
class _Chunk:
    """One chunk of a run's outputs (``_chunks``): k outputs after t_start; ``replayed`` when the
    runner went through it output by output (the next chunk is then not made longer)."""

    k: int
    t_start: float
    replayed: bool = False


def _chunks(
    run: DaeRunner,
    traj: _Trajectory,
    settings: RunSettings,
    pfull: np.ndarray,
    advanced: Callable[[int], object],
) -> Iterator[_Chunk]:
    """The chunks of outputs of a run, one policy for every runner (``_integrate``,
    ``_algebraic_motion``): ``CHUNK`` outputs first, each next chunk twice as many up to
    ``CHUNK_MAX``, or all the rest when that is at most twice as many. Before each: the time
    offset set in ``pfull[-1]``, the interrupt checked, the compiled library switched to when it
    is built; after each: ``advanced(k)`` (the progress line)."""
    t0, h, n_out = settings.t0, settings.h, settings.n_outputs
    done, size = 0, CHUNK
    while done < n_out:
        remaining = n_out - done
        k = remaining if remaining <= 2 * size else size
        t_start = t0 + done * h
        pfull[-1] = t_start
        interrupt.check(traj.taus[-1])
        run.switch_when_built(t_start)
        chunk = _Chunk(k, t_start)
        yield chunk
        done += k
        advanced(k)
        if not chunk.replayed:
            size = min(2 * size, CHUNK_MAX)


def _algebraic_motion(
    run: DaeRunner,
    traj: _Trajectory,
    settings: RunSettings,
    x: np.ndarray,
    z: np.ndarray,
    advanced: Callable[[int], object] = lambda k: None,
) -> None:
    """No differential state (every rigid coordinate driven, every elastic amplitude quasi-static):
    the motion is the algebraic solution at each output time, by Newton from the previous two
    solutions extrapolated (:class:`AlgebraicSweep`: one CasADi call per block of outputs), in the
    chunks of outputs of ``_integrate``, recorded per chunk with its checks (``record_many``). The first output
    whose closure has no solution near the last one ends the run there, the outputs before it kept."""
    h = settings.h
    mech = run.mech
    pfull = np.concatenate([mech.p, [settings.t0]])
    nz = len(z)
    zz = np.concatenate([z, z])  # the last two solutions: the first guess is z itself
    for chunk in _chunks(run, traj, settings, pfull, advanced):
        k, t_start = chunk.k, chunk.t_start
        rel = h * np.arange(1, k + 1)
        ZZ, good, its = run.algebraic().solve(zz, rel, x, pfull)
        stop = len(good) if good.all() else int(np.argmin(good))  # the first output without a solution
        traj.newton += int(its[:stop].sum())
        if stop:
            X = np.repeat(np.reshape(x, (-1, 1)), stop, axis=1)
            traj.record_many(t_start + rel[:stop], rel[:stop], X, ZZ[nz:, :stop], pfull)
        if stop < k:
            raise _lost(
                mech,
                run.part,
                t_start + rel[stop],
                traj.qs[-1],
                traj.taus[-1],
                "the closure has no solution near the last one",
                limit=True,
            )
        zz = ZZ[:, -1]


class AlgebraicSweep:
    """The Newton continuation of a run without differential states (``_algebraic_motion``), as
    CasADi Functions over a runner's ``g`` (the algebraic equations and their Jacobian in z).

    ``step`` takes one output: from the last two solutions (z_prev, z) the guess 2 z - z_prev,
    then Newton z <- z - J^-1 g until |g|_inf < ``ALGEBRAIC_TOL`` (g finite), at most
    ``ALGEBRAIC_MAXIT`` steps; a step that is not finite (a singular Jacobian) ends it at the last
    iterate. It returns (z, its solution), ok (converged, or a closure residual within
    ``ALGEBRAIC_CLOSURE`` and g finite at the last iterate) and the Newton steps taken. The
    iterations are nested conditionals (CasADi's ``conditional``, short-circuit): an output that
    converged in three steps evaluates three levels, not ``ALGEBRAIC_MAXIT``. ``solve`` maps
    ``step`` over outputs with the last two solutions carried, in blocks of at most ``BLOCK``
    outputs (CasADi's ``mapaccum``, unrolled: one call per block; a wider one costs more to make
    than it saves, 90 ms at 1024 against 0.9 ms at 64, and the same per output to run)."""

    BLOCK = 64

    def __init__(self, g: ca.Function, m: int) -> None:
        nx, nz, np_ = (g.size1_in(i) for i in (1, 2, 3))
        t, x, z, p = ca.MX.sym("t"), ca.MX.sym("x", nx), ca.MX.sym("z", nz), ca.MX.sym("p", np_)
        args = [z, t, x, p]

        def finite(e: ca.MX) -> ca.MX:
            s = ca.sum1(ca.fabs(e))  # NaN and inf carry into the sum (a max would drop a NaN)
            return ca.logic_and(s == s, s < ca.inf)

        gz, jz = g(t, x, z, p)
        # LAPACK's QR: a singular Jacobian gives a step that is not finite, not an error that
        # would end the whole block (CasADi's sparse "qr" and "csparse" raise on exact rank loss)
        znew = z - ca.solve(jz, gz, "lapackqr")
        # 1: converged at z; 0: the step taken (go on from znew); 2: the step is not finite: stop at z
        sel = ca.if_else(ca.logic_and(ca.norm_inf(gz) < ALGEBRAIC_TOL, finite(gz)), 1, ca.if_else(finite(znew), 0, 2))
        newton = ca.Function("algebraic_newton", args, [ca.if_else(sel == 0, znew, z), sel])
        g0 = g(t, x, z, p)[0]
        ok = ca.logic_and(ca.norm_inf(g0[:m]) <= ALGEBRAIC_CLOSURE, finite(g0))
        check = ca.Function("algebraic_check", args, [z, ok, ca.MX(0)])  # out of steps, or stopped
        converged = ca.Function("algebraic_converged", args, [z, ca.MX(1), ca.MX(0)])
        level = check  # the last level: no step left
        for k in range(1, ALGEBRAIC_MAXIT + 1):
            z1, sel = newton(*args)
            branch = ca.Function.conditional(f"algebraic_branch_{k}", [level, converged], check)
            z2, ok2, steps = branch(sel, z1, t, x, p)
            level = ca.Function(f"algebraic_newton_{k}", args, [z2, ok2, steps + (sel == 0)])
        zz = ca.MX.sym("zz", 2 * nz)
        zsol, ok, steps = level(2 * zz[nz:] - zz[:nz], t, x, p)
        self.step = ca.Function("algebraic_step", [zz, t, x, p], [ca.vertcat(zz[nz:], zsol), ok, steps])
        self._blocks: dict[int, ca.Function] = {}

    def block(self, k: int) -> ca.Function:
        """``step`` over k outputs: (the last two solutions stacked, the k times (1 x k), x, p) ->
        (the last two solutions after each output (2 nz x k), ok (1 x k), Newton steps (1 x k))."""
        if k not in self._blocks:
            self._blocks[k] = self.step.mapaccum("algebraic_sweep", k, 1, {"base": -1})
        return self._blocks[k]

    def solve(
        self, zz: np.ndarray, t: np.ndarray, x: np.ndarray, p: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The outputs at the times ``t`` (the offset in p[-1]) from the last two solutions ``zz``
        (stacked): (the last two solutions after each output (2 nz x n), ok (n booleans), the Newton
        steps of each (n)), in blocks of ``BLOCK``; after a block with an output that is not ok
        the later ones are not solved (n is then that block's end)."""
        blocks: list[list[np.ndarray]] = []
        for i in range(0, len(t), self.BLOCK):
            ti = t[i : i + self.BLOCK]
            ZZ, ok, its = (np.array(w) for w in self.block(len(ti))(zz, ti.reshape(1, -1), x, p))
            blocks.append([ZZ, ok.ravel() != 0, its.ravel()])
            if not blocks[-1][1].all():
                break
            zz = ZZ[:, -1]
        ZZs, oks, itss = (np.concatenate(parts, axis=-1) for parts in zip(*blocks))
        return ZZs, oks, itss


def _integrate(
    run: DaeRunner,
    traj: _Trajectory,
    settings: RunSettings,
    x: np.ndarray,
    z: np.ndarray,
    advanced: Callable[[int], object] = lambda k: None,
) -> None:
    """IDAS over the run in chunks of outputs (``CHUNK`` first, each next one twice as many up to
    ``CHUNK_MAX``, or all the rest when that is at most twice as many), the algebraic variables
    polished and the outputs recorded per chunk; a chunk that fails is replayed step by step
    (``_locate_failure``)."""
    h = settings.h
    pfull = np.concatenate([run.mech.p, [settings.t0]])
    for chunk in _chunks(run, traj, settings, pfull, advanced):
        k, t_start = chunk.k, chunk.t_start
        if settings.max_steps is not None and traj.steps > settings.max_steps:
            # a check run past its budget (a run that ends within its last chunk is kept)
            raise BudgetExceeded(float(traj.taus[-1]), traj.steps, settings.max_steps)
        try:
            F = run.integrator(h, k, x, z)
            sol = F(x0=x, z0=z, p=pfull)
            traj.steps += int(F.stats()["nsteps"])
        except RuntimeError as err:
            # SIGINT/SIGTERM inside IDAS comes back as a residual failure: it is the
            # interrupt, reported at once (no step-by-step retry)
            _raise_if_interrupted(err, traj.taus[-1])
            x, z = _locate_failure(run, traj, h, k, t_start, x, z, pfull, err)
            chunk.replayed = True
            continue
        X, Z = np.array(sol["xf"]), np.array(sol["zf"])
        rel = h * np.arange(1, k + 1)
        Z = run.polish_many(rel, X, Z, pfull)
        traj.record_many(t_start + rel, rel, X, Z, pfull)
        x, z = X[:, -1], Z[:, -1]


def _locate_failure(
    run: DaeRunner,
    traj: _Trajectory,
    h: float,
    k: int,
    t_start: float,
    x: np.ndarray,
    z: np.ndarray,
    pfull: np.ndarray,
    err: RuntimeError,
) -> tuple[np.ndarray, np.ndarray]:
    """A chunk of k outputs from t_start failed (``err``): replay it one output step at a time,
    recording each output, so that the error names the step that fails (its cause, or the
    singular position it met) and the run keeps everything before it. When every step goes
    through (IDAS restarted at each output), the run goes on from the chunk's end: (x, z)."""
    for i in range(k):
        pfull[-1] = t_start + i * h
        try:
            F1 = run.integrator(h, 1, x, z)
            sol = F1(x0=x, z0=z, p=pfull)
        except RuntimeError as err1:
            _raise_if_interrupted(err1, traj.taus[-1])
            cause = _idas_cause(err1)
            if cause.startswith("IDA_TOO_MUCH_WORK"):
                raise _stalled(run, t_start + i * h, h, traj) from None
            tau = t_start + i * h
            cause = f"IDAS failed: {cause}"
            if run.part.quasi:
                raise _singular(run.mech, run.part, tau, traj.qs[-1], traj.taus[-1], cause) or _quasi_failure(
                    run, tau, x, z, pfull, cause
                ) from None
            raise _lost(run.mech, run.part, tau, traj.qs[-1], traj.taus[-1], cause) from None
        traj.steps += int(F1.stats()["nsteps"])
        x = np.array(sol["xf"]).ravel()
        z = run.polish(h, x, np.array(sol["zf"]).ravel(), pfull)
        traj.record(t_start + (i + 1) * h, x, z)
        interrupt.check(traj.taus[-1])
    return x, z  # the chunk went through step by step (a fresh start of IDAS at each output)


def _raise_if_interrupted(err: BaseException, tau: float) -> None:
    """Raise ``Interrupted`` (at ``tau``) when ``err`` is really SIGINT/SIGTERM."""
    stop = interrupt.interrupted(err, tau)
    if isinstance(stop, Interrupted):
        raise stop from None


def _stopped(err: BaseException, traj: _Trajectory, t0: float) -> SimulationError | Interrupted | None:
    """What ended the run early, or None when ``err`` is neither a failure of the run nor an
    interrupt (the caller re-raises it). Any failure while SIGINT/SIGTERM is pending is the
    interrupt: inside IDAS a RuntimeError, between chunks (numpy converting CasADi's results)
    also the SystemError CPython makes of a C function that returned with the handler's
    exception set, or a bare KeyboardInterrupt."""
    n = traj.whole()
    exc = interrupt.interrupted(err, traj.taus[n - 1] if n else t0)
    return exc if isinstance(exc, (SimulationError, Interrupted)) else None


#: CasADi's ``ad_weight`` of the runner's ``dae``: 1 makes the Jacobian IDAS asks for (``jac:alg:x``,
#: ``jac:alg:z``; the same factory in the virtual machine and in ``jac_dae``) by reverse mode, one
#: adjoint sweep per residual row. Measured (``benchmarks/bench_exact_nodes.py``): the exact bar's
#: node form at 3 + 10 functions 287 k operations by CasADi's own choice (forward) against 179 k;
#: the examples' equal or smaller (inverted slider-crank 5.0 k -> 5.2 k).
AD_WEIGHT = 1.0
#: The inputs of the DAE whose Jacobian blocks IDAS asks for (``jac:ode:x``, ``jac:alg:z``, ...):
#: ``jac_dae`` computes only those; its blocks in t, p and u are structurally empty (IDAS never
#: asks for them, no sensitivities are run). Computed, they were 14-22 % of its operations (the
#: 4- and 12-bar von Karman chains of ``benchmarks/bench_compile.py``: 7348 -> 5728 and
#: 60279 -> 51623 operations, 174 -> 138 and 1495 -> 1279 kB of C; its -O0 compile 0.60 -> 0.49 s
#: and 4.14 -> 4.06 s CPU, medians of 3 on a loaded machine: the compile hardly changes).
JACOBIAN_INPUTS = ("x", "z")
#: What a library's Jacobian is made by (part of its key: ``compiled.start_library``'s variant).
JACOBIAN = f"jac=ad_weight {AD_WEIGHT}, cse, in {' '.join(JACOBIAN_INPUTS)}"

#: The Functions of a runner that a compiled library holds, in its order.
COMPILED = ("dae", "jac_dae", "g", "split", "rec")
#: Those evaluated rarely (once per IDAS Jacobian; once per polish iteration or chunk of outputs),
#: compiled with ``compiled.COLD_CFLAGS``: the residual ``dae`` is the run's hot loop.
COLD = ("jac_dae", "g", "split", "rec")


def _symbolic(mech: Mechanism, part: Partition) -> dict[str, ca.Function]:
    """The SX Functions of :meth:`DaeRunner._functions` for a partition of ``mech`` (all but
    ``jac_dae``)."""
    n, m = mech.n, mech.m
    I, D = list(part.ind), list(part.dep)
    nI = len(I)
    sys_ = index1(n, m, part)
    x, z, q, v, a, lam = sys_.x, sys_.z, sys_.q, sys_.v, sys_.a, sys_.lam
    p = ca.SX.sym("p", len(mech.p) + 1)
    t = ca.SX.sym("t")
    u = ca.SX.sym("u", 0)
    tt = t + p[-1]  # time offset: one integrator serves every chunk
    args = [tt, q, v, a, lam, p[:-1]]
    f = mech.f
    ode = ca.vertcat(x[nI:], a[I] if I else ca.SX(0, 1))
    dae_in = [t, x, z, p, u]
    calls = _calls(mech)
    if calls:
        alg, out, jac, alg_z = _chain_rule(f, sys_, args, dae_in, ode)
    else:
        alg, out = sys_.alg(f, tt, p[:-1]), f["out"](*args)
    dae = ca.Function(
        "dae", dae_in, [ode, alg, ca.SX(0, 1), ca.SX(0, 1)], ca.dyn_in(), ca.dyn_out(), {"ad_weight": AD_WEIGHT}
    )
    phi_q = ca.jacobian(f["phi"](*args), q)
    # singular-position check on the loop and driver rows and the dependent rigid
    # coordinates only, as checks.singular_ratio (inextensibility rows left out)
    rows = [i for i in range(m) if i not in mech.inext_rows]
    Ds = [i for i in D if i not in mech.inext_f]
    funcs = {
        "dae": dae,
        "g": ca.Function("g", [t, x, z, p], [alg, alg_z if calls else ca.jacobian(alg, z)]),
        "split": ca.Function("split", [x, z], [q, v, a, lam]),
        "rec": ca.Function(
            "rec",
            [t, x, z, p],
            [q, v, lam, out, f["closure"](*args), phi_q[rows, Ds] if Ds else ca.SX(len(rows), 0)],
        ),
    }
    if calls:
        funcs["jac_dae"] = jac
        _same_jacobian(funcs)
    return funcs


def _calls(mech: Mechanism) -> bool:
    """Whether the model's bar blocks are calls (its Functions hold ``store.CALL_NAMES``)."""
    from symgen.backends.casadi.store import CALL_NAMES

    return CALL_NAMES[0] in mech.f  # a cached entry's file names: nothing deserialized


def _chain_rule(
    f: Mapping[str, ca.Function], sys_: Index1, args: list[ca.SX], dae_in: list[ca.SX], ode: ca.SX
) -> tuple[ca.SX, ca.SX, ca.Function, ca.SX]:
    """(alg, out, jac_dae, jac_alg_z) of a model whose bar blocks are calls: E = bars(X), X =
    xin(args), res = res_E(args, E), and every Jacobian block of the DAE by the chain rule over the
    blocks' own Jacobians, alg_w + alg_E . jac_bars(X) . X_w (one call of each block's Function and
    of its Jacobian per bar; CasADi's AD through the call nodes would call the callee's adjoint
    once per row colour per bar: benchmarks/RESULTS.md, "One Function per bar structure")."""
    X = f["xin"](*args)
    Es = ca.SX.sym("E", f["bars"].size1_out(0))

    def res(*a: ca.SX) -> ca.SX:
        return f["res_E"](*a, Es)

    alg = ca.vertcat(*(({"res": res}.get(k) or f[k])(*args) for k in ("phi", "phid", "res", "phidd")))
    out = f["out_E"](*args, Es)
    JE = ca.mtimes(ca.jacobian(alg, Es), f["jac_bars"](X))
    dae_out = [ode, alg, ca.SX(0, 1), ca.SX(0, 1)]
    blocks, names = [], []
    for ko, e in zip(ca.dyn_out(), dae_out):
        for ki, w in zip(ca.dyn_in(), dae_in):
            if ki not in JACOBIAN_INPUTS:
                J = ca.SX(e.numel(), w.numel())  # never asked for: structurally empty
            else:
                J = ca.jacobian(e, w)
                if ko == "alg" and w.numel():
                    J = J + ca.mtimes(JE, ca.jacobian(X, w))
            blocks.append(J)
            names.append(f"jac_{ko}_{ki}")
    E = f["bars"](X)
    alg, out, *jb = ca.substitute([alg, out, *blocks], [Es], [E])
    nominal = [ca.SX.sym(f"out_{k}", e.shape) for k, e in zip(ca.dyn_out(), dae_out)]
    jac = ca.Function("jac_dae", dae_in + nominal, jb, ca.dyn_in() + [f"out_{k}" for k in ca.dyn_out()], names)
    return alg, out, jac, jb[names.index("jac_alg_z")]


def _library_names(mech: Mechanism) -> tuple[str, ...]:
    """The Functions of ``COMPILED`` a library of ``mech`` holds: all but ``g`` where the model's bar
    blocks are calls (there ``g`` is the DAE's algebraic rows and their ``jac_alg_z``, which ``dae``
    and ``jac_dae`` compute already: :func:`_library_g`). ``g`` is evaluated per output (the
    polish), not per step; its own C was a quarter of a 12-bar chain's library (benchmarks/RESULTS.md,
    "Callees compiled once")."""
    return tuple(n for n in COMPILED if n != "g") if _calls(mech) else COMPILED


def _library_g(ext: Mapping[str, ca.Function]) -> ca.Function:
    """The library's ``g`` (t, x, z, p) -> (alg, jac_alg_z): its own where it holds one, else made of
    the library's ``dae`` and its Jacobian ``jac_dae`` (:func:`_library_names`): the same operations
    on the same operands as the virtual machine's ``g`` (``_chain_rule``: alg and jac_alg_z are
    those of ``dae`` and ``jac_dae``), so the same numbers to the last bit."""
    if "g" in ext:
        return ext["g"]
    dae = ext["dae"]
    jac = dae.jacobian()  # the library's jac_dae (CasADi's external finds it by name)
    ins = [ca.MX.sym(n, dae.sparsity_in(i)) for i, n in enumerate(("t", "x", "z", "p"))]
    u = ca.MX(dae.sparsity_in(4))
    outs = dae(*ins, u)
    blocks = jac(*ins, u, *outs)
    return ca.Function("g", ins, [outs[1], blocks[jac.index_out("jac_alg_z")]], ["t", "x", "z", "p"], ["g", "jac_g_z"])


def _same_jacobian(funcs: dict[str, ca.Function]) -> None:
    """The virtual machine's IDAS given the library's Jacobian: ``dae`` an MX oracle calling the
    library's SX ``dae``, whose Jacobian is ``jac_dae`` (``custom_jacobian``; CasADi's factory of an
    SX oracle would differentiate it itself, through the calls). The library's Functions are made
    here (``compiled:<name>``): the virtual machine and the library evaluate the same operations."""
    for name in COMPILED:
        funcs[f"compiled:{name}"] = _shared(funcs[name])
    inner = funcs["compiled:dae"]
    opts: dict[str, Any] = {
        "custom_jacobian": funcs["compiled:jac_dae"],
        "jac_penalty": 0,
        "never_inline": True,
        "ad_weight": AD_WEIGHT,
    }
    inner = ca.Function("dae", inner.sx_in(), inner.call(inner.sx_in()), ca.dyn_in(), ca.dyn_out(), opts)
    mx = [ca.MX.sym(n, inner.sparsity_in(i)) for i, n in enumerate(ca.dyn_in())]
    funcs["dae"] = ca.Function("dae", mx, inner.call(mx), ca.dyn_in(), ca.dyn_out())


def _shared(f: ca.Function) -> ca.Function:
    """``f`` with each repeated operation made once (``casadi.cse``: the same operation on the same
    operands, hence the same value to the last bit): what a library compiles. CasADi's derivatives
    repeat many (``jac_dae`` of the exact bar at 3 + 10 functions: 179 k -> 151 k operations)."""
    ins = f.sx_in()
    return ca.Function(f.name(), ins, ca.cse(f.call(ins)), f.name_in(), f.name_out())


def _signatures(mech: Mechanism, part: Partition) -> list[compiled.Signature]:
    """The signatures (names and sizes) of the Functions of a partition's library (:func:`_library_names`) (one without
    independent coordinates too: x and the DAE's ode are then 0 x 1), from the sizes alone: what
    a cached library is found and checked by, without making the Functions
    (:func:`compiled.library_of` checks them against the Functions whenever it builds)."""
    n, m, nI, nD = mech.n, mech.m, len(part.ind), len(part.dep)
    nz = 2 * nD + n + m
    n_alg = sum(mech.f[k].size1_out(0) for k in ("phi", "phid", "res", "phidd"))
    rows = [i for i in range(m) if i not in mech.inext_rows]
    n_sing = len([i for i in part.dep if i not in mech.inext_f])

    def col(k: int) -> list[int]:
        return [k, 1]

    ins = [col(1), col(2 * nI), col(nz), col(len(mech.p) + 1), col(0)]
    outs = [col(2 * nI), col(n_alg), col(0), col(0)]
    jac_outs = [[o[0], i[0]] for o in outs for i in ins]
    sigs: list[compiled.Signature] = [
        ["dae", ins, outs],
        ["jac_dae", ins + outs, jac_outs],
        ["g", ins[:4], [col(n_alg), [n_alg, nz]]],
        ["split", ins[1:3], [col(n), col(n), col(n), col(m)]],
        [
            "rec",
            ins[:4],
            [
                col(n),
                col(n),
                col(m),
                col(mech.f["out"].size1_out(0)),
                col(mech.f["closure"].size1_out(0)),
                [len(rows), n_sing],
            ],
        ],
    ]
    names = _library_names(mech)
    return [sig for sig in sigs if sig[0] in names]


def _dae_jacobian(dae: ca.Function, dae_in: list[ca.SX], dae_out: list[ca.SX]) -> ca.Function:
    """``jac_dae``: the Jacobian CasADi's ``external`` gives IDAS for a compiled ``dae``. The
    blocks IDAS uses are built by the factory that builds them for the SX oracle of the virtual
    machine, so the compiled library computes them with the same operations in the same order
    (bit-identical Jacobians, hence the same Newton iterates and steps); the blocks in the inputs
    IDAS never differentiates by (t, p, u: not ``JACOBIAN_INPUTS``) are structurally empty."""
    fac = dae.factory("jac_blocks", ca.dyn_in(), ["jac:ode:x", "jac:alg:x", "jac:ode:z", "jac:alg:z"])
    blocks = dict(zip(("ode_x", "alg_x", "ode_z", "alg_z"), fac(*dae_in)))
    nominal = [ca.SX.sym(f"out_{k}", e.shape) for k, e in zip(ca.dyn_out(), dae_out)]
    jac: list[ca.SX] = []
    names: list[str] = []
    for ko, e in zip(ca.dyn_out(), dae_out):
        for ki, w in zip(ca.dyn_in(), dae_in):
            if ki not in JACOBIAN_INPUTS:
                jac.append(ca.SX(e.numel(), w.numel()))
            else:
                jac.append(blocks.get(f"{ko}_{ki}", ca.jacobian(e, w)))
            names.append(f"jac_{ko}_{ki}")
    return ca.Function("jac_dae", dae_in + nominal, jac, ca.dyn_in() + [f"out_{k}" for k in ca.dyn_out()], names)


_noticed: set[str] = set()


def _notice(text: str) -> None:
    """One line on stderr, once per process for the same text."""
    if text not in _noticed:
        _noticed.add(text)
        print(f"symgen: {text}", file=sys.stderr)


def _singular(
    mech: Mechanism, part: Partition, tau: float, q_last: np.ndarray, tau_last: float, cause: str, limit: bool = False
) -> SimulationError | None:
    """The error of a step that failed at a singular position of the rigid mechanism: the
    closure Jacobian was already near rank loss at the last good output (or, ``limit``, the
    driven closure itself lost its solution, which a smooth mechanism does only at a singular
    position); None when it was not."""
    ratio, row = checks.singular_ratio(mech, tau_last, q_last, part)
    if ratio >= POLICY.near_singular_ratio and not limit:
        return None
    return SimulationError(
        tau,
        f"the rigid mechanism reached a singular position (change point / toggle): "
        f"the closure Jacobian of the {mech.loop_name(row)} loses rank "
        f"(ratio {ratio:.1e} at tau = {tau_last:.6g}); {cause}",
        "the mechanism cannot be driven through this position; shorten the run or change the geometry or the driver",
    )


def _lost(
    mech: Mechanism, part: Partition, tau: float, q_last: np.ndarray, tau_last: float, cause: str, limit: bool = False
) -> SimulationError:
    """The error for a step that failed: a singular position (``_singular``), else the solver cause."""
    return _singular(mech, part, tau, q_last, tau_last, cause, limit) or SimulationError(
        tau, cause, "tighten or loosen simulation.rtol/atol, or check the scene near this tau"
    )


#: the quasi-static form's mass ratio (:func:`quasi_mass_ratio`) at the last output before a failed
#: step at or below which the failure is put down to the form's impasse (symgen's own quasi-static
#: choice is then run again dynamic: a cost, never a wrong number, so generous: the ratio falls
#: fast near the impasse, 0.31 / 0.084 / 0.013 at 0.02 / 0.01 / 0.005 before it on
#: tests/data/four_bar_torque_spinup.toml, and the last output may be a step before it)
IMPASSE_RATIO = 0.5


def quasi_mass_ratio(run: DaeRunner, x: np.ndarray, z: np.ndarray, p: np.ndarray) -> float:
    """The smallest eigenvalue of the quasi-static form's mass against the full model's on the
    motions the closure allows, at the state (x, z) (time offset in ``p[-1]``, t = 0).

    The rows of the dynamic coordinates d lose ``M_dh a_h`` but read ``q_h``, which the rows h
    set from the inertia loads ``M_hd a_d`` (docs/quasi-static-modes.md, "The equations"): the
    accelerations see the mass ``M_c = M_dd - R_dh R_hh^-1 M_hd`` (``R``: the residual's
    Jacobian in ``q_h``), not symmetric. On the null space ``N`` of the closure's rows this
    returns the smallest real part of the eigenvalues of ``(N^T M_dd N)^-1 N^T M_c N``: 1 where
    the loads through ``q_h`` do not feed back; at 0 the accelerations have no solution (an
    impasse of the DAE: its Jacobian in z is singular and BDF's corrector fails at any step),
    below 0 a motion of the closure has a negative mass. The blocks are those of the runner's
    ``g`` (rows [phi; phid; res; phidd], z = [q_D, v_D, a with q_h in the slots of a_h, lam])."""
    part, n, m = run.part, run.mech.n, run.mech.m
    J = np.array(run.g(0.0, x, z, p)[1])
    Q = list(part.quasi)
    d = [i for i in range(n) if i not in part.quasi]
    rows = [2 * m + i for i in d]
    cols = [2 * run.nD + i for i in d]
    hr, hc = [2 * m + i for i in Q], [2 * run.nD + i for i in Q]
    M = J[np.ix_(rows, cols)]
    Mc = M - J[np.ix_(rows, hc)] @ np.linalg.solve(J[np.ix_(hr, hc)], J[np.ix_(hr, cols)])
    phi_q = J[np.ix_([2 * m + n + r for r in range(m)], cols)]  # phidd's Jacobian in a_d
    _, s, vt = np.linalg.svd(phi_q)
    rank = int(np.sum(s > 1e-9 * s[0])) if len(s) and s[0] > 0 else 0
    N = vt[rank:].T
    ev = np.linalg.eigvals(np.linalg.solve(N.T @ M @ N, N.T @ Mc @ N))
    return float(ev.real.min())


def _quasi_failure(
    run: DaeRunner, tau: float, x: np.ndarray, z: np.ndarray, p: np.ndarray, cause: str
) -> SimulationError:
    """The error of a step that failed in a run with quasi-static amplitudes, at the last good
    output (x, z): the failure, the keys of those amplitudes and the mass of the quasi-static
    form there (``quasi_mass_ratio``: near 0 or below, the form itself has no solution)."""
    mech = run.mech
    bars, axial = [], []
    for name, (fi, gi) in mech.amplitudes.items():
        if any(i in run.part.quasi for i in gi):
            bars.append(name)
        if any(i in run.part.quasi for i in fi):
            axial.append(name)
    from symgen.numerics.quasi_fallback import chosen_quasi

    chosen = chosen_quasi(mech.scene)  # bar -> (transverse, axial) symgen's choice
    stated = [b for b in bars if not chosen.get(b, (False, False))[0]]
    keys = [f"bodies.{b}.quasi_static_transverse" for b in stated]
    keys += [f"the transverse functions of {b} symgen chose quasi-static" for b in bars if b not in stated]
    keys += [f"the axial functions of {b} symgen chose quasi-static" for b in axial]
    try:
        ratio = quasi_mass_ratio(run, x, z, p)
    except np.linalg.LinAlgError:
        ratio = float("nan")
    err = SimulationError(
        tau,
        f"{cause}; the run has quasi-static functions ({', '.join(keys)}): their rows take the inertia "
        f"loads of the dynamic amplitudes' accelerations and the dynamic rows do not take theirs, so "
        f"the mass of the quasi-static form is not the model's: at tau = {float(p[-1]):.6g} its "
        f"smallest eigenvalue was {ratio:.3g} of the full model's on the closure's motions (at 0 "
        f"the accelerations have no solution and neither IDAS nor the C solver steps on)",
        "lower "
        + (" and ".join(f"bodies.{b}.quasi_static_transverse" for b in stated) or "the quasi-static functions")
        + (f" (state bodies.{axial[0]}.axial_modes to keep symgen's axial choice out)" if axial else "")
        + " to keep those functions dynamic",
    )
    # the bars whose quasi-static functions this failure is about, where the form's mass is at (or
    # near, or cannot be measured at) its impasse: where symgen chose them, the run is made again
    # with them dynamic (symgen.numerics.quasi_fallback); a failure with the mass well away from
    # it has another cause, which a dynamic rerun would not cure
    if not ratio > IMPASSE_RATIO:  # NaN too
        err.quasi_bars = tuple(dict.fromkeys(bars + axial))  # type: ignore[attr-defined]
        err.quasi_ratio = ratio  # type: ignore[attr-defined]
    return err


def quasi_failure_at(
    mech: Mechanism, tau: float, q: np.ndarray, v: np.ndarray, lam: np.ndarray, cause: str
) -> SimulationError:
    """``_quasi_failure`` of a run that is not this module's (the emitted C solver's: the same
    DAE, its rows' states q, v, lam at the last output ``tau``): a runner of the mechanism's
    partition at tau (the virtual machine), z solved from the row's state; a singular position
    of the rigid mechanism there (``_singular``) keeps its own message."""
    part = mech.run_partition(mech.choose_partition(tau, np.asarray(q, dtype=float)))
    singular = _singular(mech, part, tau, np.asarray(q, dtype=float), tau, cause)
    if singular is not None:  # a singular position of the rigid mechanism: its own message
        return singular
    run = DaeRunner(mech, part, 1e-8, 1e-10, backend="vm")
    x, z = run.pack(np.asarray(q, dtype=float), np.asarray(v, dtype=float), np.zeros(mech.n), np.asarray(lam))
    p = np.concatenate([mech.p, [tau]])
    return _quasi_failure(run, tau, x, run.polish(0.0, x, z, p), p, cause)


def _stalled(run: DaeRunner, tau: float, h: float, traj: _Trajectory) -> SimulationError:
    """The watchdog's error: no progress within one output step from ``tau``; the likely cause
    measured at the last good output (a near-singular position, ``_singular``), else the others."""
    what = (
        f"no progress: IDAS took more than {run.max_steps(h)} steps within the output step from tau = "
        f"{tau:.6g} (its steps shrank to nothing)"
    )
    return _singular(run.mech, run.part, tau, traj.qs[-1], traj.taus[-1], what) or SimulationError(
        tau,
        f"{what}: a load, a torque or the driver law may be singular there, or the "
        f"model stiff beyond what the run can resolve",
        "check the scene's expressions near this tau, and the loads and stiffness of the bars",
    )


def _idas_cause(err: Exception) -> str:
    text = str(err)
    m = re.search(r"(IDA_[A-Z_]+)", text)
    flag = m.group(1) if m else "error"
    m2 = re.search(r"(At t=[^\n]*)", text)
    detail = m2.group(1).strip() if m2 else text.strip().splitlines()[-1][:200] if text.strip() else ""
    return f"{flag}: {detail}"
