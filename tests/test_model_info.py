"""The typed records after the cache (issue 23): ``ir.info.ModelInfo`` round-trips through
``model.json``'s data with the same records the derivation made, and ``ir.plan.StartPlan``
holds the partition the Python start chose."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from symgen.api import mechanism
from symgen.ir.info import InvalidModelInfo, ModelInfo
from symgen.ir.plan import StartPlan
from symgen.ir.records import Coordinate, CoordKind, RowKind, find_coordinate
from symgen.numerics.start import start_plan

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def six_bar():
    return mechanism(ROOT / "examples" / "six_bar.toml")


def test_model_info_round_trips_through_json(six_bar):
    info = six_bar.info
    data = json.loads(json.dumps(info.to_json()))
    again = ModelInfo.from_json(data)
    assert again == info
    assert all(type(c) is Coordinate and isinstance(c.kind, CoordKind) for c in again.coords)
    assert all(isinstance(r.kind, RowKind) and isinstance(r.loop, tuple) for r in again.lam_rows)


def test_model_info_helpers_agree_with_the_records(six_bar):
    info = six_bar.info
    assert info.elastic == tuple(i for i, c in enumerate(info.coords) if c.kind in (CoordKind.F, CoordKind.G))
    assert set(info.elastic) | set(info.rigid) == set(range(info.n)) and not set(info.elastic) & set(info.rigid)
    for body, (f, g) in info.amplitudes.items():
        assert all(info.coords[i].body == body and info.coords[i].kind is CoordKind.F for i in f)
        assert all(info.coords[i].body == body and info.coords[i].kind is CoordKind.G for i in g)
        assert (len(f), len(g)) == (info.modes[body].axial, info.modes[body].transverse)
    drv = six_bar.scene.driver
    assert info.coordinate(CoordKind.THETA, drv.body) == find_coordinate(info.coords, CoordKind.THETA, drv.body)
    assert info.lam_rows[info.driver_row].kind is RowKind.DRIVER
    assert info.rows(RowKind.DRIVER) == (info.driver_row,)


def test_records_take_only_known_kinds():
    assert Coordinate("f_rod_1", "f", "rod").kind is CoordKind.F
    with pytest.raises(ValueError):
        Coordinate("x_rod", "x", "rod")
    with pytest.raises(InvalidModelInfo, match="is not an object"):
        ModelInfo.from_json([])


def test_start_plan_is_the_python_start(six_bar):
    plan = start_plan(six_bar)
    *_, part = six_bar.initial_state(0.0)
    assert (plan.independent, plan.dependent) == (tuple(part.ind), tuple(part.dep))
    q0, v0 = six_bar.initial_guess(0.0)
    assert plan.q_guess == tuple(q0) and plan.v_guess == tuple(v0)
    assert plan.assembly_dependent == six_bar.choose_partition(0.0, q0).dep
    assert set(plan.elastic) == set(six_bar.info.elastic) - set(part.dep)
    assert [(g.body, g.axial, g.transverse) for g in plan.amplitudes] == [
        (b, f, g) for b, (f, g) in six_bar.info.amplitudes.items()
    ]


def test_start_plan_refuses_a_partition_that_does_not_split_the_coordinates():
    with pytest.raises(ValueError, match="does not split"):
        StartPlan(
            independent=(0, 1),
            dependent=(1,),
            assembly_dependent=(1,),
            q_guess=(0.0, 0.0),
            v_guess=(0.0, 0.0),
            elastic=(),
            accel=(1,),
            inextensible_rows=(),
            inextensible_axial=(),
            singular_rows=(0,),
            singular_cols=(1,),
            amplitudes=(),
        )


def test_start_plan_round_trips_through_json_and_refuses_what_is_not_one(six_bar):
    """The plan a cached ``--solver c`` run recalls (symgen.numerics.csolver._plan) is the plan
    itself: every field back, its numbers to the bit; data that is not a plan is refused."""
    plan = start_plan(six_bar)
    data = plan.to_json()
    again = StartPlan.from_json(json.loads(json.dumps(data)))
    assert again == plan and again.amplitudes and all(isinstance(x, float) for x in again.q_guess)
    bad = [
        {k: v for k, v in data.items() if k != "accel"},  # a field missing
        dict(data, extra=[]),  # a field more
        dict(data, independent=[0.5]),  # not indices
        dict(data, dependent=[True]),
        dict(data, q_guess=[0] * len(data["q_guess"])),  # not numbers as written (ints)
        dict(data, amplitudes=[{"body": "rod", "axial": []}]),  # a group without its transverse
        dict(data, independent=list(plan.independent) + list(plan.dependent)),  # no partition
        [],
    ]
    for d in bad:
        with pytest.raises(ValueError):
            StartPlan.from_json(d)
