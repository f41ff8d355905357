"""The run checks of a mechanism, one home for Python (the emitted C runs the same checks
under the same policy, the C runtime's ``symgen/backends/c/runtime/symgen_solver.c``; ``tests/test_check_parity.py``):

* ``singular_ratio``: sigma_min / sigma_max of the closure Jacobian in the dependent rigid
  coordinates (a singular position: a toggle, a change point), compared with
  ``POLICY.singular_ratio`` / ``POLICY.near_singular_ratio`` by the runners;
* ``beyond_range``: a bar deformed beyond the range of the bar model (its largest slope beyond
  ``POLICY.slope_limit``, its largest stretch ||r'| - 1| beyond ``POLICY.stretch_limit``);
* ``range_record``: each bar's largest slope and stretch, and where an exact bar's slopes pass the
  accuracy's limit (``RANGE``): a warning, from the run's coordinates (IDAS) or from the maxima
  the C solver kept during its run over the same rows, the same for both solvers;
* ``divergent_deformation``: a quasi-static state beyond a buckling load (a real, positive
  eigenvalue of the linearised motion of the amplitudes, ``POLICY.divergence_rtol``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike
else:
    from symgen.lazy import numpy as np  # imported at its first use (symgen.lazy)

from symgen import cache
from symgen.ir.records import CoordKind, RowKind
from symgen.numerics.index1 import Partition, index1
from symgen.policy import POLICY, RANGE, range_message

if TYPE_CHECKING:
    from symgen.ir.info import ModelInfo
    from symgen.ir.shape_samples import GuideSamples
    from symgen.numerics.mechanism import Mechanism


def singular_ratio(mech: Mechanism, t: float, q: np.ndarray, part: Partition) -> tuple[float, int]:
    """Smallest / largest singular value of the loop and driver rows' Jacobian in the
    dependent rigid coordinates (inextensibility rows and their axial amplitudes, a
    regular block Ka, are left out: the rigid mechanism alone decides singularity)."""
    rows = [i for i in range(mech.m) if i not in mech.inext_rows]
    cols = [i for i in part.dep if i not in mech.inext_f]
    if not cols:
        return 1.0, 0
    Jd = mech.jac_q(t, q)[np.ix_(rows, cols)]
    u, s, _ = np.linalg.svd(Jd)
    weights = np.zeros(mech.m)
    weights[rows] = u[:, -1]
    return float(s[-1] / max(s[0], 1e-300)), loop_row(mech, weights)


def worst_row(mech: Mechanism, Jd: np.ndarray) -> int:
    if Jd.shape[1] == 0:
        return 0
    u, s, _ = np.linalg.svd(Jd)
    return loop_row(mech, u[:, -1])


def loop_row(mech: Mechanism, weights: ArrayLike) -> int:
    """The closure row (a loop, not the driver) that weighs most in a singular direction."""
    w = np.abs(np.asarray(weights, dtype=float))
    if len(w) > 1:
        w[list(mech.info.rows(RowKind.DRIVER, RowKind.INEXTENSIBLE))] = -1.0
    return int(np.argmax(w))


#: the range tables read in this process, by the model's structure key
_TABLES: dict[str, dict[str, tuple[np.ndarray | None, np.ndarray | None]]] = {}
_GUIDES: dict[str, dict[str, tuple[GuideSamples, int]]] = {}


def range_tables(info: ModelInfo) -> dict[str, tuple[np.ndarray | None, np.ndarray | None]]:
    """bar -> (P, A): P[j, a] = psi_a'(xi_j) over its transverse amplitudes g, A[j, k] =
    phi_k'(xi_j) over its axial amplitudes f (None: the bar has none), so that its slopes there
    are P @ g and its tangent r' = (1 + A @ f, P @ g), at the points of
    :meth:`symgen.ir.shape_samples.ShapeSamples.range_rows` (the model-form estimate's samples,
    from the signed cache). The emitted C solver's range check reads the same tables
    (``symgen.backends.c.context``). A slot guide's functions move with the contact: (None, None)
    here, its slopes from :func:`guide_tables`."""
    from symgen.numerics.model_form import _samples

    if info.key in _TABLES:
        return _TABLES[info.key]
    bodies = {b["name"]: b for b in info.structure.get("bodies", [])}
    tables: dict[str, tuple[np.ndarray | None, np.ndarray | None]] = {}
    for body, (fi, gi) in info.amplitudes.items():
        if body in info.slot_guides:  # its functions move with the contact: guide_tables
            tables[body] = (None, None)
            continue
        samples = _samples(bodies[body])
        P = np.asarray(samples.slope_table(), dtype=float).reshape(-1, len(gi)) if gi else None
        A = np.asarray(samples.stretch_table(), dtype=float).reshape(-1, len(fi)) if fi else None
        tables[body] = (P, A)
    _TABLES[info.key] = tables
    return tables


def guide_tables(info: ModelInfo) -> dict[str, tuple[GuideSamples, int]]:
    """slot guide (with transverse amplitudes) -> (its slopes at the range check's points of its
    span and its overhang, :class:`symgen.ir.shape_samples.GuideSamples`, taken when the model was
    derived and read from the signed cache; the index of its contact beta in q)."""
    if info.key in _GUIDES:
        return _GUIDES[info.key]
    bodies = {b["name"]: b for b in info.structure.get("bodies", [])}
    guides: dict[str, tuple[GuideSamples, int]] = {}
    for body, joint in info.slot_joints.items():
        if body not in info.amplitudes or not info.amplitudes[body][1]:
            continue
        slopes = read_guide(bodies[body], joint)
        if slopes.nt != len(info.amplitudes[body][1]):
            raise ValueError(f"bar {body!r}: the guide's samples hold other functions than its amplitudes")
        guides[body] = (slopes, info.coordinate(CoordKind.BETA, body))
    _GUIDES[info.key] = guides
    return guides


def read_guide(body: dict[str, Any], joint: dict[str, Any]) -> GuideSamples:
    """A slot guide's samples (its and its slot's structure records), taken when the model was
    derived and read from the signed cache; sampled now where the cache does not hold them (a
    model cache written before them)."""
    from symgen.ir.shape_samples import GuideSamples, InvalidShapeSamples, guide_question

    known, answer = cache.recall(guide_question(body, joint))
    if known:
        try:
            return GuideSamples.from_json(answer)
        except InvalidShapeSamples:
            pass
    from symgen.model.shape_samples import guide_samples

    return guide_samples(body, joint)


def guide_slopes(samples: GuideSamples, g: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """A guide's slopes eta' at its range check's nodes (rows, the span's first:
    :meth:`GuideSamples.slope_rows`) per column of its amplitudes ``g`` (functions x samples) at
    contacts ``beta`` (one per sample)."""
    span_rows, over_rows = samples.slope_rows()
    span, over = samples.scalings(beta, 1)
    return np.vstack([np.asarray(span_rows, dtype=float) @ (span * g), np.asarray(over_rows, dtype=float) @ (over * g)])


def slope_tables(info: ModelInfo) -> dict[str, np.ndarray]:
    """bar -> P of :func:`range_tables`, the bars with transverse amplitudes."""
    return {body: P for body, (P, _) in range_tables(info).items() if P is not None}


def slopes(info: ModelInfo, Q: ArrayLike) -> dict[str, np.ndarray]:
    """bar -> its largest |eta'| over the points of :func:`range_tables`, per column of Q
    (coordinates x samples)."""
    return {body: s for body, (s, _) in bar_ranges(info, Q).items() if s is not None}


def stretches(info: ModelInfo, Q: ArrayLike) -> dict[str, np.ndarray]:
    """bar -> its largest stretch ||r'| - 1| over the points of :func:`range_tables`, per column
    of Q (coordinates x samples), the bars with axial amplitudes."""
    return {body: e for body, (_, e) in bar_ranges(info, Q).items() if e is not None}


def stretch(axial: ArrayLike, slope: ArrayLike) -> np.ndarray:
    """|r'| - 1 of the tangent r' = (1 + axial, slope) (zeta', eta'), as (2 zeta' + zeta'^2 +
    eta'^2) / (1 + |r'|): no cancellation at small strains (the C runtime's symgen_bar_range_)."""
    a, s = np.asarray(axial, dtype=float), np.asarray(slope, dtype=float)
    e: np.ndarray = (2.0 * a + a * a + s * s) / (1.0 + np.sqrt((1.0 + a) * (1.0 + a) + s * s))
    return e


def bar_ranges(info: ModelInfo, Q: ArrayLike) -> dict[str, tuple[np.ndarray | None, np.ndarray | None]]:
    """bar -> (its largest |eta'|, its largest ||r'| - 1|) over the points of
    :func:`range_tables`, per column of Q (coordinates x samples); None where the bar has no
    transverse (axial) amplitudes. A bar without axial amplitudes (``axial = false``) has no
    stretch: its axis keeps its length by assumption, not by its amplitudes; the linear strain's
    is zeta' (``ModelInfo.linear_strain``)."""
    Q = np.asarray(Q, dtype=float).reshape(info.n, -1)
    linear = info.linear_strain
    out: dict[str, tuple[np.ndarray | None, np.ndarray | None]] = {}
    guides = guide_tables(info)
    for body, (P, A) in range_tables(info).items():
        fi, gi = info.amplitudes[body]
        if body in guides:  # its functions move with the contact (no axial amplitudes: axially rigid)
            slopes, beta = guides[body]
            out[body] = (np.abs(guide_slopes(slopes, Q[list(gi)], Q[beta])).max(axis=0), None)
            continue
        eta = P @ Q[list(gi)] if P is not None else None
        slope = np.abs(eta).max(axis=0) if eta is not None else None
        size = None
        if A is not None:
            zeta = A @ Q[list(fi)]
            size = np.abs(stretch(zeta, eta if eta is not None and not linear else 0.0)).max(axis=0)
        out[body] = (slope, size)
    return out


def beyond_range(mech: Mechanism, Q: ArrayLike) -> tuple[int, str] | None:
    """First column of Q (coordinates x outputs) where a bar is deformed beyond the range of the
    model (its largest slope beyond ``POLICY.slope_limit``, its largest stretch beyond
    ``POLICY.stretch_limit``), with the reason; None if none."""
    Q = np.asarray(Q, dtype=float).reshape(mech.n, -1)
    first = None
    for body, (slope, size) in bar_ranges(mech.info, Q).items():
        for sizes, limit, what in ((slope, POLICY.slope_limit, "slope"), (size, POLICY.stretch_limit, "stretch")):
            if sizes is None:
                continue
            bad = np.nonzero(~(sizes <= limit))[0]  # NaN counts as beyond
            if len(bad) and (first is None or bad[0] < first[0]):
                first = (int(bad[0]), body, what, float(sizes[bad[0]]), limit)
    if first is None:
        return None
    k, body, what, value, limit = first
    return k, range_message(body, what, limit, f"{value:.3g}")


#: the fields of one bar in the C solver's range record (``PREFIX_solver_range``), in its order
C_RANGE_FIELDS = ("slope", "slope_tau", "over_tau", "over_slope", "stretch", "stretch_tau")


def range_record(info: ModelInfo, tau: ArrayLike, Q: ArrayLike, accuracy: float, maxima: Any = None) -> dict[str, Any]:
    """The sidecar's ``range``: each bar's largest slope and stretch over the run and when; for
    the exact bar (``effects.strain = "exact"``), the first time each bar's slope passed the
    accuracy's limit (``RANGE.warning_limit``), a warning. The von Karman and linear bars' model
    form is the error estimate's (``symgen.numerics.model_form``): no warning here. Q: samples x
    coordinates. ``maxima``: the same kept by the emitted C solver during its run over the same
    rows (``symgen.numerics.csolver``: per bar in ``info.amplitudes``' order, the values of
    :data:`C_RANGE_FIELDS`, with the run's warning limit), used instead of tau and Q: no numpy."""
    exact = (info.structure.get("effects") or {}).get("strain") == "exact"
    limit = RANGE.warning_limit(accuracy)
    record: dict[str, Any] = {
        "slope_limit": POLICY.slope_limit,
        "stretch_limit": POLICY.stretch_limit,
        "warning_limit": limit if exact else None,
        "rule": (
            f"the exact bar's left-out terms cost about {RANGE.error_per_slope6:g} slope^6 of an output's peak: "
            f"a warning where a bar's largest slope passes (accuracy / {RANGE.error_per_slope6:g})^(1/6); "
            f"the run stops at slope {POLICY.slope_limit:g} or stretch {POLICY.stretch_limit:g}"
            if exact
            else "von Karman or linear bars: their model form is the error estimate's; the run stops at slope "
            f"{POLICY.slope_limit:g} or stretch {POLICY.stretch_limit:g}"
        ),
        "largest_slope": {},
        "largest_stretch": {},
        "warnings": [],
    }
    if exact and info.slot_guides & set(info.amplitudes):
        record["rule"] += (
            "; a slot guide's curvature is kept to fourth order whatever the strain (symgen.model.slot): its slope "
            "is recorded and checked, not warned"
        )
    per_bar: list[tuple[str, tuple[float, float] | None, tuple[float, float] | None, tuple[float, float] | None]] = []
    if maxima is not None:
        for body, values in zip(info.amplitudes, maxima):
            fi, gi = info.amplitudes[body]
            s, s_tau, o_tau, o_s, e, e_tau = (float(v) for v in values)
            per_bar.append(
                (
                    body,
                    (s, s_tau) if gi and s_tau == s_tau else None,  # NaN tau: no rows
                    (o_s, o_tau) if gi and o_tau == o_tau else None,
                    (e, e_tau) if fi and e_tau == e_tau else None,
                )
            )
    else:
        tau = np.asarray(tau, dtype=float).ravel()
        if len(tau) == 0:
            return record
        Q = np.asarray(Q, dtype=float).reshape(len(tau), info.n)
        for body, (sl, st) in bar_ranges(info, Q.T).items():
            largest = over = big = None
            if sl is not None:
                k = int(np.argmax(np.where(np.isfinite(sl), sl, -1.0)))
                largest = (float(sl[k]), float(tau[k]))
                beyond = np.nonzero(~(sl <= limit))[0]
                if len(beyond):
                    over = (float(sl[beyond[0]]), float(tau[beyond[0]]))
            if st is not None:
                k = int(np.argmax(np.where(np.isfinite(st), st, -1.0)))
                big = (float(st[k]), float(tau[k]))
            per_bar.append((body, largest, over, big))
    for body, largest, over, big in per_bar:
        if big is not None:
            record["largest_stretch"][body] = {"stretch": big[0], "tau": big[1]}
        if largest is None:
            continue
        record["largest_slope"][body] = {"slope": largest[0], "tau": largest[1]}
        if exact and over is not None and body not in info.slot_guides:
            record["warnings"].append(
                {
                    "bar": body,
                    "tau": over[1],
                    "slope": over[0],
                    "message": (
                        f"bar '{body}' passes slope {limit:.3g} at tau = {over[1]:.6g} (largest {largest[0]:.3g} at "
                        f"tau = {largest[1]:.6g}): the exact bar's left-out terms (about {RANGE.error_per_slope6:g} "
                        f"slope^6 of peak) exceed simulation.accuracy = {accuracy:g} from there on"
                    ),
                }
            )
    record["warnings"].sort(key=lambda w: w["tau"])
    return record


def divergent_deformation(
    mech: Mechanism, t: float, q: np.ndarray, v: np.ndarray, part: Partition
) -> tuple[float, str]:
    """Largest real, positive eigenvalue of the linearised motion of the independent
    deformation amplitudes about (q, v) (rigid independent coordinates held; dependent
    ones follow the closure), and the amplitude dominating its eigenvector. Positive:
    the state is statically unstable (beyond a buckling load). (0.0, "") if none."""
    E = [i for i in part.ind if mech.coords[i].elastic]
    if not E:
        return 0.0, ""
    import casadi as ca  # here: a cached run of the C solver never imports CasADi

    I, D = list(part.ind), list(part.dep)
    nI, nD = len(I), len(D)
    sys_ = index1(mech.n, mech.m, part)
    G = sys_.alg(mech.f, t, mech.p)
    jac = ca.Function("lin", [sys_.x, sys_.z], [ca.jacobian(G, sys_.x), ca.jacobian(G, sys_.z)])
    a, lam = mech.accelerations(t, q, v)
    Gx, Gz = (np.array(w) for w in jac(np.concatenate([q[I], v[I]]), np.concatenate([q[D], v[D], a, lam])))
    dzdx = -np.linalg.solve(Gz, Gx)
    e = [I.index(i) for i in E]
    cols = e + [nI + k for k in e]
    A = np.zeros((2 * len(E), 2 * len(E)))
    A[: len(E), len(E) :] = np.eye(len(E))
    A[len(E) :, :] = dzdx[[2 * nD + i for i in E]][:, cols]
    s, W = np.linalg.eig(A)
    scale = max(1.0, float(np.abs(s).max()))
    tol = POLICY.divergence_rtol * scale
    real = [k for k in range(len(s)) if abs(s[k].imag) <= tol and s[k].real > tol]
    if not real:
        return 0.0, ""
    k = max(real, key=lambda j: s[j].real)
    return float(s[k].real), mech.coords[E[int(np.argmax(np.abs(W[: len(E), k])))]].name
