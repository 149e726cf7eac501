"""The scenario framework: criteria as data (one evaluator), one run-record writer, one min-jerk profile."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.profiles import min_jerk, min_jerk_ramp
from wbc.scenarios.framework import Criterion, RunRecord, evaluate


def test_criterion_number_and_missing_entry():
    c = Criterion("slip ≤ 1 mm", "slip", "<=", 1e-3)
    assert c.holds({"slip": 1e-3}) and not c.holds({"slip": 1.0001e-3})
    assert not c.holds({})  # an entry the run did not measure fails
    assert evaluate({"slip": 2e-3}, [c]) == (False, ["slip ≤ 1 mm: measured 0.002 (required <= 0.001)"])
    assert evaluate({}, [c]) == (False, ["slip ≤ 1 mm: not measured (no summary entry 'slip')"])


def test_failed_criterion_prints_the_measurement_beside_the_requirement():
    speed = Criterion("no joint above its URDF velocity limit", "n", "==", 0,
                      detail="worst {joint} at {ratio:.5g}× its limit")
    summary = {"n": 1, "joint": "arm_left_5_joint", "ratio": 1.000812}
    assert evaluate(summary, [speed])[1] == [
        "no joint above its URDF velocity limit: measured 1, worst arm_left_5_joint at 1.0008× its limit "
        "(required == 0)"]
    margin = Criterion("ZMP inside", "margin", ">=", 0.0)
    assert margin.report({"margin": -1.3877787807814457e-17}) == "ZMP inside: measured -1.388e-17 (required >= 0)"
    scaled = Criterion("distance", "walked", "<=", 0.05, minus="planned", scale_by="planned", floor=0.01)
    assert scaled.report({"walked": 0.07, "planned": 1.05}) == "distance: measured 0.98 (required <= 0.0525)"
    assert str(scaled) == "distance (|walked − planned| <= 0.05 × |planned|)"


def test_criterion_relative_difference_with_floor():
    # |walked − planned| ≤ max(5 % · planned, 1 cm)
    c = Criterion("distance", "walked", "<=", 0.05, minus="planned", scale_by="planned", floor=0.01)
    assert c.holds({"walked": 1.049, "planned": 1.0}) and not c.holds({"walked": 1.051, "planned": 1.0})
    assert c.holds({"walked": 0.109, "planned": 0.1}) and not c.holds({"walked": 0.111, "planned": 0.1})


def test_criterion_wrapped_angle():
    c = Criterion("heading", "got", "<=", math.radians(5), minus="want", period=2 * math.pi)
    assert c.holds({"got": math.pi - 0.01, "want": -math.pi + 0.01})  # 0.02 rad apart across ±π
    assert not c.holds({"got": 0.1, "want": 0.0})


def test_criterion_reduce_nested_elementwise_and_either():
    assert Criterion("max", "e", "<=", 0.1, reduce="max").holds({"e": {"a": 0.05, "b": 0.1}})
    assert not Criterion("max", "e", "<=", 0.1, reduce="max").holds({"e": {"a": 0.05, "b": 0.2}})
    assert Criterion("n", "d", "==", 3, reduce="len").holds({"d": [1, 2, 3]})
    assert Criterion("each", "d", "<=", 0.01, minus=0.15, reduce="max").holds({"d": [0.149, 0.158]})
    assert not Criterion("each", "d", "<=", 0.01, minus=0.15, reduce="max").holds({"d": [0.149, 0.161]})
    assert Criterion("nested", "err.arms", "<=", 0.05).holds({"err": {"arms": 0.04}})
    sweep = Criterion("swept", "swept", ">=", threshold_key="amp")
    assert sweep.holds({"swept": [0.5, 0.31], "amp": [-0.5, 0.3]})
    assert not sweep.holds({"swept": [0.5, 0.29], "amp": [-0.5, 0.3]})
    alt = Criterion("reached or limited", "residual", "<=", 0.01,
                    either=(Criterion("limited", "limited_by", ">", 0, reduce="len"),))
    assert alt.holds({"residual": 0.5, "limited_by": ["balance"]})
    assert not alt.holds({"residual": 0.5, "limited_by": []})


def test_criterion_rejects_unknown_operator():
    with pytest.raises(InvalidInputError, match="op"):
        Criterion("bad", "x", "=<", 1.0)
    with pytest.raises(InvalidInputError, match="reduce"):
        Criterion("bad", "x", "<=", 1.0, reduce="mean")


@dataclass
class _Run(RunRecord):
    robot: str
    dt: float
    t: np.ndarray
    names: list[str]
    wall_time: float = 0.0
    extra: dict | None = None

    not_logged = ("wall_time",)


def test_run_record_writes_fields_and_extra_arrays():
    run = _Run("talos", 0.002, np.arange(3) * 0.002, ["a", "b"], 1.5, {"dcm": np.ones((3, 2)), "obj": object()})
    buf = io.BytesIO()
    run.save(buf)
    buf.seek(0)
    with np.load(buf, allow_pickle=False) as z:
        assert sorted(z.files) == ["dcm", "dt", "names", "robot", "t"]
        assert str(z["robot"]) == "talos" and float(z["dt"]) == 0.002
        np.testing.assert_array_equal(z["t"], run.t)
        assert z["names"].tolist() == ["a", "b"]


def test_min_jerk_closed_form_and_finite_differences():
    s = np.linspace(-0.5, 1.5, 41)
    b, db, ddb = min_jerk(s)
    assert b[0] == 0.0 and b[-1] == 1.0 and db[0] == 0.0 and ddb[-1] == 0.0
    assert min_jerk(0.5) == pytest.approx((0.5, 1.875, 0.0))  # closed form: 10/8 − 15/16 + 6/32
    h = 1e-6
    for x in (0.1, 0.37, 0.8):
        assert min_jerk(x)[1] == pytest.approx((min_jerk(x + h)[0] - min_jerk(x - h)[0]) / (2 * h), rel=1e-6)
        assert min_jerk(x)[2] == pytest.approx((min_jerk(x + h)[1] - min_jerk(x - h)[1]) / (2 * h), rel=1e-5)
    assert min_jerk_ramp(1.0, 0.0, 2.0) == pytest.approx((0.5, 1.875 / 2.0))
    assert min_jerk_ramp(-1.0, 0.0, 2.0) == (0.0, 0.0) and min_jerk_ramp(0.0, 0.0, 0.0) == (1.0, 0.0)
