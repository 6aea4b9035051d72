"""Tests for semexp_bt.core.bounds (the one range check) and the three declarations that use it: the method's
configuration, the planner's configuration and a behaviour's parameters."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import pytest
from hypothesis import given
from hypothesis import strategies as st

from behaviours.spec import ParamSpec
from semexp_bt.core.bounds import Interval, field_interval, field_range
from semexp_bt.core.config import ConfigError, check_value, config_from_dict, field_problem
from semexp_bt.core.types import InvalidInputError
from semexp_bt.nav.costmap import CostmapConfig


def test_interval_notation_writes_each_end_as_declared() -> None:
    assert Interval.between(0.0, 1.0).notation() == "[0.0, 1.0]"
    assert Interval.between(0.0, 1.0, low_open=True).notation() == "(0.0, 1.0]"
    assert Interval.between(1, 64, high_open=True).notation() == "[1, 64)"
    assert Interval(gt=0.0).notation() == "(0.0, inf)"
    assert Interval(le=2.5).notation() == "(-inf, 2.5]"


def test_broken_bound_names_the_first_bound_broken() -> None:
    unit = Interval.between(0.0, 1.0, high_open=True)
    assert unit.broken_bound(-0.1) == (">=", 0.0)
    assert unit.broken_bound(1.0) == ("<", 1.0)
    assert unit.broken_bound(0.0) is None
    assert Interval(gt=0.0).broken_bound(0.0) == (">", 0.0)
    assert Interval(le=5).broken_bound(6) == ("<=", 5)
    assert Interval().broken_bound(-math.inf) is None


@given(st.floats(-10, 10), st.floats(-10, 10), st.booleans(), st.booleans(), st.floats(-20, 20))
def test_contains_is_the_textbook_interval(
    low: float, high: float, low_open: bool, high_open: bool, value: float
) -> None:
    interval = Interval.between(low, high, low_open=low_open, high_open=high_open)
    above_low = value > low if low_open else value >= low
    below_high = value < high if high_open else value <= high
    assert interval.contains(value) == (above_low and below_high)


def test_an_interval_takes_one_bound_per_side() -> None:
    with pytest.raises(ValueError, match="one lower bound"):
        Interval(gt=0.0, ge=1.0)
    with pytest.raises(ValueError, match="one upper bound"):
        Interval(lt=0.0, le=1.0)


@dataclass(frozen=True)
class _Gate:
    rho: float = field(default=0.3, metadata=field_range(0.0, 1.0, low_open=True))
    count: int = field(default=3, metadata=field_range(1, 64))
    enabled: bool = True
    free: float = 1.0


def test_field_range_round_trips_through_the_field_metadata() -> None:
    rho, count, enabled, free = dataclasses.fields(_Gate)
    assert field_interval(rho) == Interval(gt=0.0, le=1.0)
    assert field_interval(count) == Interval(ge=1, le=64)
    assert field_interval(enabled) is None and field_interval(free) is None


def test_check_value_says_what_was_expected_and_what_came() -> None:
    unit = Interval.between(0.0, 1.0, low_open=True)
    assert check_value(1, float, unit) == (1.0, None)  # an int is widened for a float
    assert check_value(0.0, float, unit) == (0.0, "must lie in (0.0, 1.0], got 0.0")
    assert check_value("x", float, unit)[1] == "must be a number, got 'x'"
    assert check_value(math.nan, float, None)[1] == "must be finite, got nan"
    assert check_value(1.5, int, None)[1] == "must be an integer, got 1.5"
    assert check_value(True, int, None)[1] == "must be an integer, got True"
    assert check_value(1, bool, None)[1] == "must be a boolean, got 1"


def test_field_problem_names_the_first_bad_field() -> None:
    assert field_problem(_Gate()) is None
    assert field_problem(_Gate(rho=0.0)) == "rho must lie in (0.0, 1.0], got 0.0"
    assert field_problem(_Gate(count=2.0)) == "count must be an integer, got 2.0"  # type: ignore[arg-type]


def test_the_three_declarations_give_one_verdict_on_the_same_bound() -> None:
    # rho in (0, 1] for the config loader; resolution_m in [0.005, 1.0] for the costmap; > 0 for a node.
    with pytest.raises(ConfigError, match=r"x\.yaml: key 'rho' must lie in \(0\.0, 1\.0\], got 0\.0"):
        config_from_dict({"rho": 0.0}, cls=_Gate, where="x.yaml")
    assert config_from_dict({"rho": 1}, cls=_Gate, where="x.yaml").rho == 1.0
    with pytest.raises(InvalidInputError, match=r"CostmapConfig\.resolution_m must lie in \[0\.005, 1\.0\]"):
        CostmapConfig(resolution_m=2.5)
    spec = ParamSpec("float", doc="a speed, m/s", default=0.2, gt=0.0, le=0.5)
    assert spec.check(0.0) == (0.0, "value 0.0 out of range: must be > 0")
    assert spec.check(0.6) == (0.6, "value 0.6 out of range: must be <= 0.5")
    assert spec.check(0.5) == (0.5, None)
