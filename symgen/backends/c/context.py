"""The plain-data context the C templates are rendered from (the contract between the
symbolic stages and the templates: strings, numbers and lists only).

Its inputs are data: the scene, the derived model (``DerivedModel``: the program lowered to C),
the model's ``ModelInfo`` (names, sizes, the angle drivers' rows) and the ``StartPlan`` the numerics
made (``symgen.numerics.start.start_plan``), so that the Python runner and the C solver
handle the closure the same way: the partition of the coordinates into independent and
dependent ones (chosen at the start and baked in) and the quasi-static amplitudes (algebraic:
q_h in the slot of a_h in y, no v_h; ``StartPlan.quasi``), the dependent coordinates of the assembly,
the raw initial guess the assembly Newton starts from (the scene's ``[initial]`` guess and
deformation, the driver's angle and rate), which coordinates are elastic / rigid for the
quasi-static start, the rows and columns of the closure Jacobian that decide a singular
position, and the amplitudes of each bar for the range check.

The valid range of every parameter (``symgen.ir.parameters.parameter_records``) and the limits of
the run settings (``symgen.scene.model``: output rows, rtol) are rendered from Python, never
retyped in the templates.
"""

from __future__ import annotations

from pathlib import Path

from symgen import __version__
from symgen.policy import POLICY, range_message
from symgen.backends.c import radau
from symgen.backends.c.codegen import model_functions
from symgen.backends.c.names import c_comment, c_prefix, c_string
from symgen.backends.c.printer import c_double
from symgen.ir.info import ModelInfo
from symgen.ir.parameters import parameter_values
from symgen.ir.plan import StartPlan
from symgen.ir.records import CoordKind


def _ops_table(prefix: str, funcs) -> list[str]:
    return [
        f"{prefix}_{f.name}: {f.ops} operations, {f.temporaries} temporaries"
        + (f", {f.nnz} nonzeros of {f.rows}x{f.cols}" if f.kind == "jacobian" else "")
        for f in funcs
    ]


def _c_bound(x: float) -> str:
    """A range bound as C: a double literal, or +-HUGE_VAL for no bound."""
    if x == float("inf"):
        return "HUGE_VAL"
    if x == float("-inf"):
        return "-HUGE_VAL"
    return c_double(x)


def _parameter_ranges(scene, params: list[str]) -> list[dict]:
    from symgen.ir.parameters import parameter_records

    return [
        {
            "lower": _c_bound(r.valid.lower),
            "upper": _c_bound(r.valid.upper),
            "lower_open": int(r.valid.lower_open),
            "upper_open": int(r.valid.upper_open),
            "text": c_string(r.valid.text()),
            "key": c_comment(r.key),
        }
        for r in parameter_records(scene, params)
    ]


def _physical(scene, params: list[str]) -> dict:
    """An SI scene's physical inputs (``--set bodies.rod.E=...``) and, per model parameter that
    depends on them, its C expression of x[j] (the inputs): the loader's formulas printed, not
    retyped (symgen.ir.physical); ``deps``: the inputs it depends on."""
    from symgen.backends.c.printer import CPrinter
    from symgen.ir.physical import physical_map

    pm = physical_map(scene, params)
    keys = [k for k, _ in pm.inputs]
    names = {pm.symbols[k]: f"x[{j}]" for j, k in enumerate(keys)}
    printer = CPrinter(names)
    formulas = []
    for k, name in enumerate(params):
        expr = pm.expressions.get(name)
        if expr is None:
            continue
        deps = sorted(keys.index(s.name) for s in expr.free_symbols)
        formulas.append({"index": k, "code": printer.doprint(expr), "deps": deps, "name": c_comment(name)})
    from symgen.ir.physical import INPUT_UNITS, output_unit

    return {
        "si": scene.units == "SI",
        "omega": printer.doprint(pm.omega) if pm.output_factors else c_double(scene.omega),
        "output_factors": [printer.doprint(f) for f in pm.output_factors],
        "output_units": [output_unit(o.kind) for o in scene.outputs],
        "units": [INPUT_UNITS[k.rsplit(".", 1)[1]] for k in keys],
        "n": len(keys),
        "names": [c_string(k) for k in keys],
        "comments": [c_comment(k) for k in keys],
        "defaults": [c_double(v) for _, v in pm.inputs],
        "frozen": [c_comment(k) for k in pm.frozen],
        "formulas": formulas,
    }


def _run_limits() -> dict:
    """The run limits of the Python loader (symgen.scene.limits), rendered into the C: the
    default row limit (the C driver lifts it with --max-rows, Python with SYMGEN_MAX_ROWS), the
    rtol and atol bounds and the rtol above which both warn: one source for both."""
    from symgen.scene.limits import ATOL_MAX, ATOL_MIN, LIMITS, RTOL_MAX, RTOL_MIN, RTOL_WARN

    return {
        "max_rows": f"{int(LIMITS['rows'].default)}L",
        "rtol_max": c_double(RTOL_MAX),
        "rtol_min": c_double(RTOL_MIN),
        "atol_min": c_double(ATOL_MIN),
        "atol_max": c_double(ATOL_MAX),
        "loose_rtol": c_double(RTOL_WARN),
        "max_t_end": c_double(float(LIMITS["t_end"].default)),
    }


def c_context(scene, model, plan: StartPlan, info: ModelInfo | None = None) -> dict:
    """Everything the templates under ``templates/c/`` need, as plain data.
    ``info`` defaults to the description of ``model`` (``ModelInfo.of``)."""
    import sympy

    prefix = c_prefix(scene)
    info = ModelInfo.of(model) if info is None else info
    if info.key != model.key or info.coords != tuple(model.coords):
        raise ValueError(f"the model information (key {info.key}) is not that of the model {model.key}")
    n, m = info.n, info.m
    if plan.n != n:
        raise ValueError(f"a start plan of {plan.n} coordinates for a model of {n}")
    funcs = model_functions(model.program)
    ind, dep = list(plan.independent), list(plan.dependent)
    nI, nD = len(ind), len(dep)
    nx, nz = 2 * nI, 2 * nD + n + m
    ny = nx + nz
    ypos_q, ypos_v = [0] * n, [0] * n
    for k, i in enumerate(ind):
        ypos_q[i], ypos_v[i] = k, nI + k
    for k, i in enumerate(dep):
        ypos_q[i], ypos_v[i] = nx + k, nx + nD + k
    a0 = nx + 2 * nD
    # a quasi-static amplitude h (symgen.numerics.index1): q_h in the slot of a_h, no v_h, no a_h
    # (-1: the Jacobian's columns of v_h and a_h are dropped)
    quasi = list(plan.quasi)
    for i in quasi:
        ypos_q[i], ypos_v[i] = a0 + i, -1
    acol = [-1 if i in quasi else a0 + i for i in range(n)]
    ycol = ypos_q + ypos_v + acol + [a0 + n + j for j in range(m)]
    params = list(info.params)
    p = parameter_values(scene, params)
    # every angle driver (the scene's order): its angle's coordinate and its row of phi
    rows = info.driver_rows
    driver = {
        "angle_coords": [info.coordinate(CoordKind.THETA, body) for body in rows],
        "angle_rows": list(rows.values()),
    }
    sim = scene.simulation
    by_name = {f.name: f for f in funcs}
    amplitude_checks = _amplitude_checks(plan, info)
    return {
        "prefix": prefix,
        "guard": f"SYMGEN_{prefix}_H",
        "version": __version__,
        "sympy_version": sympy.__version__,
        "scene_name": c_comment(scene.name),
        "scene_file": c_comment(Path(str(scene.path)).name),
        "scene_hash": scene.hash,
        "ops": _ops_table(prefix, funcs),
        "n": n,
        "m": m,
        "np": len(params),
        "nout": len(info.outputs),
        "nclosure": info.n_loop_rows,
        "nw": 3 * n + m,
        "ni": nI,
        "nd": nD,
        "nx": nx,
        "nz": nz,
        "ny": ny,
        "nalg": 3 * m + n,
        "coordinate_names": [c_string(c.name) for c in info.coords],
        "coordinate_comments": [c_comment(c.name) for c in info.coords],
        "parameter_names": [c_string(x) for x in params],
        "parameter_comments": [c_comment(x) for x in params],
        "parameter_defaults": [c_double(x) for x in p],
        "parameter_plain": params,
        "parameter_values": [float(x) for x in p],
        "parameter_ranges": _parameter_ranges(scene, params),
        "physical": _physical(scene, params),
        "limits": _run_limits(),
        "output_names": [c_string(x) for x in info.outputs],
        "csv_header": c_string(",".join(["tau", *info.outputs])),
        "functions": [
            {
                "name": f.name,
                "kind": f.kind,
                "rows": f.rows,
                "cols": f.cols,
                "body": list(f.body),
                "unused": [x for x in ("t", "q", "v", "a", "lam", "p") if x not in f.used],
                "ops": f.ops,
                "nnz": f.nnz,
                "temporaries": f.temporaries,
                "loop": f.kind == "jacobian" and f.nnz < f.rows * f.cols,
            }
            for f in funcs
        ],
        "jac_rows": {k: by_name[k].rows for k in ("phi", "phid", "phidd", "res")},
        "independent": ind,
        "dependent": dep,
        "quasi": quasi,
        "follow": list(plan.follow),
        "moving": list(plan.moving),
        "assembly_dependent": list(plan.assembly_dependent),
        "ypos_q": ypos_q,
        "ypos_v": ypos_v,
        "ycol": ycol,
        "elastic": list(plan.elastic),
        "accel": list(plan.accel),
        "sing_rows": list(plan.singular_rows),
        "sing_cols": list(plan.singular_cols),
        "q_guess": [c_double(x) for x in plan.q_guess],
        "v_guess": [c_double(x) for x in plan.v_guess],
        "driver": driver,
        "quasi_static": bool(scene.initial.quasi_static),
        "t_end": c_double(sim.t_end),
        "output_step": c_double(sim.output_step),
        # the C solver's own tolerances: the scene's, or from its accuracy by the C rule
        "rtol": c_double(sim.tolerances("c")[0]),
        "atol": c_double(sim.tolerances("c")[1]),
        "policy": _policy(),
        "amplitude_checks": amplitude_checks,
        "free_inertia": list(plan.free_inertia),
        "start_forces": list(plan.start_forces),
        "radau": radau.constants(),
    }


def _policy() -> dict:
    """The solver policy (``symgen.policy``) as C literals: the emitted solver's tolerances and
    limits are the Python runners' (doubles to the last bit, integers as written)."""
    return {k: (str(v) if isinstance(v, int) else c_double(v)) for k, v in POLICY.as_dict().items()}


def _amplitude_checks(plan: StartPlan, info: ModelInfo) -> list[dict]:
    """The range of the bar models (``symgen.numerics.checks.beyond_range``), one check per bar
    (in the model's order, ``checks.range_tables``'): at the points of the shape samples'
    ``range_rows``, its largest slope |eta'| (``slope_table``: ``psi_a'`` there, row-major points
    x amplitudes) may not exceed ``POLICY.slope_limit``, its largest stretch ||r'| - 1|, r' =
    (1 + zeta', eta') (``stretch_table``: ``phi_k'`` there; the linear strain's (1 + zeta', 0):
    ``ModelInfo.linear_strain``), not ``POLICY.stretch_limit``. A slot guide's functions move with
    the contact: its slopes are beta^a (1 - beta)^b times fixed numbers at the points of its span
    and its overhang (``GuideSamples.slope_rows``: ``guide``, its contact's coordinate ``beta``, ``span_points``,
    ``powers`` a, b on the span and a, b on the overhang per function), read with q's beta."""

    from symgen.model.shape_samples import guide_samples, shape_samples

    bodies = {b["name"]: b for b in info.structure.get("bodies", [])}
    slots = info.slot_joints
    checks = []
    for group in plan.amplitudes:
        body = group.body
        guide: dict = {"guide": 0, "beta": -1, "span_points": 0, "powers": []}
        if body in slots and group.transverse:
            # its functions move with the contact: the slopes beta^a (1 - beta)^b F_k at the span's and
            # the overhang's points (GuideSamples, checks.guide_tables), no axial amplitudes
            g = guide_samples(bodies[body], slots[body])
            span_rows, over_rows = g.slope_rows()
            span_powers, over_powers = g.powers(1)
            slopes: tuple[tuple[float, ...], ...] = span_rows + over_rows
            stretches: tuple[tuple[float, ...], ...] = ()
            guide = {
                "guide": 1,
                "beta": info.coordinate(CoordKind.BETA, body),
                "span_points": len(span_rows),
                "powers": [v for k in range(g.nt) for v in (*span_powers[k], *over_powers[k])],
            }
            points = len(slopes)
        else:
            samples = shape_samples(bodies[body])
            slopes = samples.slope_table() if group.transverse else ()
            stretches = samples.stretch_table() if group.axial else ()
            points = len(samples.range_rows())
        for table, width in ((slopes, len(group.transverse)), (stretches, len(group.axial))):
            if any(len(row) != width for row in table):
                raise ValueError(f"bar {body!r}: the shape samples hold other functions than its amplitudes")
        checks.append(
            {
                "indices": list(group.transverse),
                "axial": list(group.axial),
                "points": points,
                "linear": 1 if info.linear_strain else 0,
                "slopes": [c_double(v) for row in slopes for v in row],
                "stretches": [c_double(v) for row in stretches for v in row],
                "slope_message": c_string(range_message(body, "slope", POLICY.slope_limit, "this")),
                "stretch_message": c_string(range_message(body, "stretch", POLICY.stretch_limit, "this")),
                **guide,
            }
        )
    return checks
