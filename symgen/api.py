"""Python entry points: the same stages as the command line, for scripts and tests.

>>> from symgen.api import simulate_scene
>>> result = simulate_scene("examples/slider_crank.toml", ["simulation.cycles=0.5"])  # doctest: +SKIP
>>> result.column("eta_mid").max()                                                   # doctest: +SKIP

With ``out=`` a run writes the files ``symgen simulate`` / ``symgen quasistatic`` write (the
CSV, its JSON sidecar, the plot), through the same writer (``symgen.numerics.results.write_run``):

>>> simulate_scene("examples/slider_crank.toml", ["simulation.cycles=0.5"],
...                out="out/sc.csv", plot="out/sc.png")                             # doctest: +SKIP
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from symgen.numerics.mechanism import Mechanism, load_mechanism
from symgen.numerics.run_result import SimResult
from symgen.scene import scene_of
from symgen.scene.model import Scene


def mechanism(
    scene: Scene | str | os.PathLike, overrides: Sequence[str] = (), use_cache: bool = True, lazy: bool = False
) -> Mechanism:
    """The compiled model of a scene with its parameter values, ready to run
    (:func:`symgen.numerics.mechanism.load_mechanism`; ``lazy``: its CasADi Functions read on
    first use)."""
    return load_mechanism(scene, overrides, use_cache, lazy)


def _emit_inputs(scene: Scene):
    """(derived model, its ModelInfo, StartPlan) of the C emitter: the scene derived once; the
    start planned on the CasADi Functions of that model (from the model cache when it holds
    this structure, else built from the model and stored), with the partition chosen once."""
    from symgen.backends.casadi.pipeline import compile_model
    from symgen.ir.info import ModelInfo
    from symgen.model.derive import derive
    from symgen.numerics.start import start_plan

    model = derive(scene)
    compiled = compile_model(model)
    info = ModelInfo.of(model)
    return model, info, start_plan(Mechanism(compiled, scene))


def write_c(scene: Scene | str | os.PathLike, out_dir: str | os.PathLike, overrides: Sequence[str] = ()):
    """``symgen emit-c``: the scene's standalone C (model, solver, driver, CMakeLists.txt) written
    into ``out_dir`` all or nothing; its folder. A bad scene name fails before any work."""
    from symgen.backends.c import c_prefix, write_c as emit

    scene = scene_of(scene, overrides)
    c_prefix(scene)
    model, info, plan = _emit_inputs(scene)
    return emit(scene, out_dir, model, plan, info)


def write_fmu(
    scene: Scene | str | os.PathLike, path: str | os.PathLike, overrides: Sequence[str] = (), cc: str | None = None
):
    """``symgen emit-fmu``: the scene's FMI 2.0 Co-Simulation FMU at ``path``; its path."""
    from pathlib import Path

    from symgen.backends.c import c_prefix, write_fmu as emit
    from symgen.backends.fmu import check_fmu_path

    scene = scene_of(scene, overrides)
    check_fmu_path(Path(path))
    c_prefix(scene)
    model, info, plan = _emit_inputs(scene)
    return emit(scene, path, model, plan, info, cc=cc)


def simulate_scene(
    scene: Scene | str | os.PathLike,
    overrides: Sequence[str] = (),
    *,
    out: str | os.PathLike | None = None,
    plot: str | os.PathLike | None = None,
    states: bool = False,
    units: str | None = None,
    estimate: str = "rerun",
    solver: str = "idas",
    **kwargs,
) -> SimResult:
    """Load (if needed), derive or load from cache, and simulate; kwargs go to ``simulate``
    (``solver="c"``: to ``symgen.numerics.csolver.simulate_c``, the emitted C Radau IIA solver
    run in this process: t_end, output_step, rtol, atol, use_cache).

    ``out``: write the run as ``symgen simulate -o OUT`` does (``out`` a .csv; its JSON sidecar
    beside it; ``plot``: a .png/.svg/.pdf of the outputs; ``states``: the coordinates as
    ``q.NAME`` columns; ``units``: "SI" or "dimensionless", default SI for an SI scene;
    ``estimate``: the sidecar's error estimate, as ``symgen simulate --estimate``). A run
    that stops early writes the ``.partial`` files, then raises as without ``out``. The sidecar
    records the scene's own times and tolerances, so with ``out`` the kwargs are those of the
    command line only (``backend``, ``use_cache``): give the others as overrides."""
    from symgen.numerics.csolver import run
    from symgen.numerics.solvers import check_solver

    check_solver(solver, "solver")
    if out is None:
        from symgen.numerics.results import attempt
        from symgen.numerics.strain_choice import resolved, run_with_strain_choice

        _no_files(plot, states, units)
        use_cache = kwargs.get("use_cache", True)
        _, result, failure = run_with_strain_choice(
            mechanism(resolved(scene_of(scene, overrides)), use_cache=use_cache, lazy=solver == "c"),
            lambda sc: mechanism(sc, use_cache=use_cache),
            lambda mech: attempt(lambda: run(mech, solver, **kwargs)),
        )
        if failure is not None:
            raise failure
        assert result is not None  # attempt gives a result or the failure
        return result
    allowed = ("backend", "use_cache") if solver == "idas" else ("use_cache",)
    _only(kwargs, allowed, "simulation.t_end=..., simulation.rtol=...")
    return _written_run(
        scene,
        overrides,
        out,
        plot,
        states,
        units,
        kwargs.get("use_cache", True),
        solver,
        lambda mech: run(mech, solver, **kwargs),
        estimate,
    )


def quasi_static_scene(
    scene: Scene | str | os.PathLike,
    overrides: Sequence[str] = (),
    *,
    out: str | os.PathLike | None = None,
    plot: str | os.PathLike | None = None,
    states: bool = False,
    units: str | None = None,
    use_cache: bool = True,
    **kwargs,
):
    """The quasi-static response (18)-(20) over a cycle (a mechanism with free rigid coordinates:
    its static equilibrium at each position, ``symgen.numerics.equilibrium``); kwargs go to
    ``symgen.numerics.quasistatic.quasi_static`` (kinematics, cycles, output_step, taus, say).

    ``out``, ``plot``, ``states``, ``units``: write the run as ``symgen quasistatic -o OUT`` does
    (see :func:`simulate_scene`); the kwargs are then those of the command line only
    (``kinematics``, ``cycles``, ``say``)."""
    from symgen.numerics.quasistatic import quasi_static

    if out is None:
        _no_files(plot, states, units)
        return quasi_static(mechanism(scene, overrides, use_cache=use_cache), **kwargs)
    _only(kwargs, ("kinematics", "cycles", "say"), "simulation.output_step=...")
    return _written_run(
        scene, overrides, out, plot, states, units, use_cache, "quasi-static", lambda mech: quasi_static(mech, **kwargs)
    )


def _no_files(plot, states: bool, units: str | None) -> None:
    if plot is not None or states or units is not None:
        raise ValueError(
            "plot, states and units describe the files of a run: give out=... (a .csv) too, "
            "or use results_table(result, scene, units) for the columns"
        )


def _only(kwargs: dict, allowed: tuple, hint: str) -> None:
    """With ``out``, the sidecar records the scene's times and tolerances: other kwargs would
    make it wrong."""
    other = sorted(set(kwargs) - set(allowed))
    if other:
        raise ValueError(
            f"with out=..., {', '.join(other)} would not be recorded in the sidecar: give them "
            f"as scene overrides ({hint}); the kwargs here are {', '.join(allowed)}"
        )


def _written_run(
    scene, overrides, out, plot, states: bool, units: str | None, use_cache: bool, solver: str, run, estimate="off"
):
    """``run(mechanism)`` written as the command line writes it (``symgen.cli``'s simulate and
    quasistatic): the files checked before any work, the CSV and its sidecar (partial when the
    run stopped early), the plot; no result of this name from an earlier run left looking
    complete when it fails. The result, or the run's failure raised (with ``.partial``)."""
    from symgen.numerics.results import attempt, run_files, write_run
    from symgen.numerics.units import choose_system

    files = run_files(out, plot, out_key="out", plot_key="plot")
    try:
        from symgen.numerics.strain_choice import resolved, run_with_strain_choice

        scene = resolved(scene_of(scene, overrides))  # effects.strain = "auto": a decision remembered
        choose_system(scene, units)
        mech = mechanism(scene, use_cache=use_cache, lazy=solver == "c")  # C: CasADi's Functions if used
        failure: BaseException | None
        if solver == "quasi-static":
            result, failure = attempt(lambda: run(mech))
        else:  # "auto": the von Karman run's model-form estimate may call for the exact bar
            mech, result, failure = run_with_strain_choice(
                mech,
                lambda sc: mechanism(sc, use_cache=use_cache),
                lambda m: attempt(lambda: run(m)),
                estimate=estimate,
            )
        scene = mech.scene
        written = write_run(
            files,
            scene,
            mech.compiled,
            mech.build_s,
            result,
            failure,
            solver=solver,
            units=units,
            states=states,
            estimate=estimate,
            mech=mech,
        )
        if written.plot is not None:
            from symgen.apps.plot import plot_run  # numpy and matplotlib: only to plot

            plot_run(written.plot)
        if failure is not None:
            raise failure
    except BaseException:
        files.discard()
        raise
    return result


def modes_scene(scene: Scene | str | os.PathLike, overrides: Sequence[str] = (), tau: float = 0.0, **kwargs):
    """Natural frequencies and mode shapes about the quasi-static state at input position tau (a
    mechanism with free rigid coordinates: about its static equilibrium at tau, with the
    pendulum modes; ``ModesResult.equilibrium`` says which equilibrium)."""
    from symgen.numerics.modes import modes

    return modes(mechanism(scene, overrides), tau=tau, **kwargs)


@dataclass(frozen=True)
class Equations:
    """The scene's equations of motion as SymPy objects, as sympy.physics.mechanics gives them:

        mass_matrix * a + multiplier_matrix * lam = forcing        (the weak-form residual, (8)-(17))
        constraints(q, t) = 0                                       (closure and angle-driver rows, (11))

    with ``constraint_jacobian`` = d constraints / d q. The multipliers ``lam`` are the joint
    forces of the cut joints (and each angle driver's moment; each in ``rows``); the model's own
    residual ``res`` is ``mass_matrix * a + multiplier_matrix * lam - forcing``. Everything is in
    the model's dimensionless units (``time`` is tau = omega t), with the scene's parameters as
    symbols (``parameters``) and their values for this scene in ``values``."""

    time: Any  # sympy Symbol tau
    coordinates: tuple[Any, ...]  # q (sympy Symbols), one per ``records`` entry
    records: tuple[Any, ...]  # symgen.ir.records.Coordinate of each q: kind, bar, index, joint
    speeds: tuple[Any, ...]  # v = dq/dtau
    accelerations: tuple[Any, ...]  # a = dv/dtau
    multipliers: tuple[Any, ...]  # lam
    rows: tuple[Any, ...]  # symgen.ir.records.ConstraintRow of each lam
    parameters: tuple[Any, ...]  # the parameter symbols
    values: dict[Any, float]  # parameter symbol -> its value for this scene
    mass_matrix: Any  # sympy Matrix n x n
    multiplier_matrix: Any  # sympy Matrix n x m
    forcing: Any  # sympy Matrix n x 1
    constraints: Any  # sympy Matrix m x 1 (position level)
    constraint_jacobian: Any  # sympy Matrix m x n


def equations(scene: Scene | str | os.PathLike, overrides: Sequence[str] = ()) -> Equations:
    """The derived equations of ``scene`` as SymPy matrices (see :class:`Equations`), every
    intermediate of the model inlined. For a large model the expressions are large: the
    emitted code keeps them shared (``symgen latex`` prints them with their intermediates).

    >>> eqs = equations("examples/slider_crank.toml")                          # doctest: +SKIP
    >>> eqs.mass_matrix.shape, eqs.constraint_jacobian.shape                   # doctest: +SKIP
    ((7, 7), (3, 7))
    """
    import sympy as sp

    from symgen.ir.parameters import parameter_values
    from symgen.model.derive import TAU, derive

    scene = scene_of(scene, overrides)
    model = derive(scene)
    prog = model.program
    inlined: dict[Any, Any] = {}
    for sym, expr in prog.assignments:
        inlined[sym] = sp.sympify(expr).xreplace(inlined)
    res = sp.Matrix([sp.sympify(e).xreplace(inlined) for e in prog.outputs["res"]])
    phi = sp.Matrix([sp.sympify(e).xreplace(inlined) for e in prog.outputs["phi"]])
    a, lam, q = sp.Matrix(model.a), sp.Matrix(model.lam), sp.Matrix(model.q)
    zero = {x: 0 for x in (*model.a, *model.lam)}
    params = tuple(model.params)
    return Equations(
        time=TAU,
        coordinates=tuple(model.q),
        records=tuple(model.coords),
        speeds=tuple(model.v),
        accelerations=tuple(model.a),
        multipliers=tuple(model.lam),
        rows=tuple(model.lam_rows),
        parameters=params,
        values=dict(zip(params, (float(x) for x in parameter_values(scene, model.param_names)))),
        mass_matrix=res.jacobian(a),
        multiplier_matrix=res.jacobian(lam) if len(model.lam) else sp.zeros(len(res), 0),
        forcing=-res.xreplace(zero),
        constraints=phi,
        constraint_jacobian=phi.jacobian(q) if len(model.lam) else sp.zeros(0, len(model.q)),
    )


def results_table(result, scene: Scene, units: str | None = None) -> dict:
    """The columns of a run (``simulate_scene``/``quasi_static_scene``) as numpy arrays, time
    first, in the units of the command line: SI (``t`` in s, m, rad, N, N m, J) for an SI scene,
    the model's dimensionless units (``tau``) otherwise or with ``units="dimensionless"``. The
    units and factors are in ``symgen.numerics.units.result_units(scene, units)``.

    >>> scene = load_scene("examples/four_bar.toml")                           # doctest: +SKIP
    >>> cols = results_table(simulate_scene(scene), scene)                      # doctest: +SKIP
    >>> cols["t"][-1], cols["torque"].max()                                     # doctest: +SKIP
    """
    from symgen.numerics.units import result_units

    u = result_units(scene, units)
    time, values = u.convert(result.tau, result.outputs)
    table = {u.time.name: time}
    table.update({name: values[:, k] for k, name in enumerate(result.output_names)})
    return table


def results_frame(result, scene: Scene, units: str | None = None):
    """:func:`results_table` as a pandas DataFrame (pandas is optional: ``pip install pandas``)."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(
            "results_frame needs pandas (pip install pandas); results_table gives the same columns as numpy arrays"
        ) from None
    return pd.DataFrame(results_table(result, scene, units))


def sweep(scene: str | os.PathLike, vary: dict, overrides: Sequence[str] = (), *, frame: bool = False, **kwargs):
    """A parameter sweep: one row per point of the grid of ``vary``, as a dict of numpy arrays
    (a pandas DataFrame with ``frame=True``; pandas is optional).

    ``vary`` maps scene keys (as for ``--set``) to a grid spec string (``"0.5:3:20"``,
    ``"1e4:1e8:9:log"``, ``"1,2,4"``) or a sequence of numbers; several keys give the full grid.
    kwargs go to ``symgen.apps.sweep.sweep`` (workers, scheduler, window, campbell, campbell_at,
    progress, units; ``workers=1`` runs in this process). The table of an SI scene is in SI
    (peaks in their outputs' units, speed and frequencies in Hz, speed_rpm) unless
    ``units="dimensionless"``. Local worker processes are forked on Linux;
    where they are spawned instead (macOS, Windows, or a parent with threads) a script must guard
    its entry point with ``if __name__ == "__main__":``. Columns: the varied keys, status, steps, cpu_s, peak_<output>, and with
    ``campbell=True`` speed and f1..fk (natural frequencies from ``modes``).

    >>> table = sweep("examples/slider_crank.toml", {"driver.rate": "0.5:2:4"},
    ...               ["simulation.cycles=0.5"], workers=1)        # doctest: +SKIP
    >>> table["peak_eta_mid"]                                      # doctest: +SKIP
    """
    from symgen.apps.sweep import sweep as run_sweep, vary_from

    if frame:
        try:
            import pandas  # noqa: F401
        except ImportError:
            raise ImportError(
                "sweep(..., frame=True) needs pandas: pip install pandas "
                "(without it, sweep returns a dict of numpy arrays)"
            ) from None
    result = run_sweep(scene, [vary_from(k, v) for k, v in vary.items()], overrides, **kwargs)
    return result.frame() if frame else result.columns
