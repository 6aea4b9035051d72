"""Evaluation metrics (paper Sec. IV-A), hand-worked."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.metrics import (
    DEFAULT_CLEARANCE_M,
    DEFAULT_SUCCESS_RADIUS_M,
    DecisionStep,
    EpisodeRecord,
    bootstrap_interval,
    gnsa,
    goal_distance_m,
    oasr,
    oracle_node,
    sa,
    spl,
    spl_value,
    sr,
    success,
    summarize,
    wilson_interval,
)
from semexp_bt.core.types import InvalidInputError


def record(**overrides) -> EpisodeRecord:
    base = {
        "scene": "office",
        "seed": 0,
        "strategy": "ours",
        "success_declared": True,
        "final_position_m": (0.0, 0.0),
        "goal_position_m": (0.6, 0.8),  # 1.0 m away
        "goal_category": "extinguisher",
        "reached_category": "extinguisher",
        "path_length_m": 10.0,
        "geodesic_length_m": 8.0,
        "collision": False,
        "decisions": (),
    }
    return EpisodeRecord(**(base | overrides))


# Four hand-worked episodes (r_s = 1.0 m):
#  A: declared, 0.5 m from the goal, L = 10, L* = 8, no collision, reached extinguisher -> success, SPL 0.8
#  B: declared, exactly 1.0 m from the goal (not < r_s), collision, reached extinguisher -> failure
#  C: not declared, at the goal, reached nothing -> failure
#  D: declared, at the goal, L = 4 < L* = 5 (odometry short), collision, reached "sofa" -> success, SPL 1
EPISODES = [
    record(final_position_m=(0.3, 0.4), decisions=[DecisionStep(1, 1), DecisionStep(2, 3)]),
    record(collision=True, decisions=[DecisionStep(4, 4)]),
    record(success_declared=False, final_position_m=(0.6, 0.8), reached_category=None),
    record(final_position_m=(0.6, 0.8), path_length_m=4.0, geodesic_length_m=5.0, collision=True,
           reached_category="Sofa", decisions=[DecisionStep(5, 6), DecisionStep(7, 7), DecisionStep(8, 8)]),
]  # fmt: skip


def test_constants() -> None:
    assert DEFAULT_SUCCESS_RADIUS_M == 1.0
    assert DEFAULT_CLEARANCE_M == 0.1


def test_success_needs_distance_and_declaration() -> None:
    a, b, c, d = EPISODES
    assert goal_distance_m(a) == pytest.approx(0.5)
    assert goal_distance_m(b) == pytest.approx(1.0)
    assert [success(r) for r in EPISODES] == [True, False, False, True]
    assert success(b, success_radius_m=1.01)  # strictly within r_s
    with pytest.raises(ValueError, match="success_radius_m"):
        success(a, success_radius_m=0.0)


def test_sr_spl_oasr_sa_gnsa_hand_worked() -> None:
    assert sr(EPISODES) == pytest.approx(2 / 4)
    assert [spl_value(r) for r in EPISODES] == pytest.approx([0.8, 0.0, 0.0, 1.0])
    assert spl(EPISODES) == pytest.approx((0.8 + 1.0) / 4)
    assert oasr(EPISODES) == pytest.approx(1 - 2 / 4)
    assert sa(EPISODES) == pytest.approx(2 / 4)  # A, B match; C reached nothing; D reached a sofa
    assert gnsa(EPISODES) == pytest.approx(4 / 6)  # steps: A 1/2, B 1/1, D 2/3
    # r_s matters: at 1.01 m, B also succeeds (SPL 8 / 10).
    assert sr(EPISODES, success_radius_m=1.01) == pytest.approx(3 / 4)
    assert spl(EPISODES, success_radius_m=1.01) == pytest.approx((0.8 + 0.8 + 1.0) / 4)


def test_sa_ignores_case_and_spacing_only() -> None:
    assert sa([record(reached_category="  Extinguisher ")]) == 1.0
    assert sa([record(reached_category="fire extinguisher")]) == 0.0


def test_spl_zero_length_success() -> None:
    at_goal = record(final_position_m=(0.6, 0.8), path_length_m=0.0, geodesic_length_m=0.0)
    assert spl_value(at_goal) == 1.0


@pytest.mark.parametrize("metric", [sr, spl, oasr, sa, gnsa, summarize])
def test_empty_records_raise(metric) -> None:
    with pytest.raises(ValueError, match="at least one episode record"):
        metric([])


def test_gnsa_without_decisions_raises_and_summary_reports_none() -> None:
    records = [record(), record(seed=1)]
    with pytest.raises(ValueError, match="no decision step"):
        gnsa(records)
    summary = summarize(records)
    assert summary["gnsa"] is None and summary["gnsa_ci95"] is None and summary["decision_steps"] == 0


def test_oracle_node() -> None:
    assert oracle_node({4: (1.0, 5.0), 2: (3.0, 2.0), 9: (0.5, 7.0)}) == 2
    assert oracle_node({4: (1.0, 2.0), 2: (2.0, 1.0)}) == 2  # tie -> lowest id
    assert oracle_node({4: (math.inf, 1.0), 5: (2.0, math.inf), 6: (10.0, 10.0)}) == 6
    assert oracle_node({4: (math.inf, 1.0)}) is None
    with pytest.raises(ValueError, match="at least one candidate"):
        oracle_node({})
    with pytest.raises(InvalidInputError, match="node 3"):
        oracle_node({3: (math.nan, 1.0)})
    with pytest.raises(InvalidInputError, match="node 3"):
        oracle_node({3: (-1.0, 1.0)})


def test_wilson_interval_hand_worked() -> None:
    # n = 20, 10 successes, z = 1.959964: centre 0.5, half = z * sqrt(0.0125 + z^2/1600) / (1 + z^2/20)
    z = 1.959963984540054
    half = z * math.sqrt(0.25 / 20 + z * z / 1600) / (1 + z * z / 20)
    lo, hi = wilson_interval(10, 20)
    assert (lo, hi) == pytest.approx((0.5 - half, 0.5 + half))
    assert (lo, hi) == pytest.approx((0.2993, 0.7007), abs=1e-4)
    lo0, hi0 = wilson_interval(0, 20)
    assert lo0 == 0.0 and hi0 == pytest.approx(z * z / 20 / (1 + z * z / 20))  # 0.1611
    assert wilson_interval(20, 20)[1] == 1.0
    with pytest.raises(ValueError, match="n must be >= 1"):
        wilson_interval(0, 0)
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(21, 20)


@settings(max_examples=100, deadline=None)
@given(n=st.integers(1, 500), data=st.data())
def test_wilson_contains_the_estimate(n: int, data) -> None:
    k = data.draw(st.integers(0, n))
    lo, hi = wilson_interval(k, n)
    assert 0.0 <= lo <= k / n <= hi <= 1.0


def test_bootstrap_interval() -> None:
    values = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0] * 5
    lo, hi = bootstrap_interval(values, seed=3)
    assert lo < 0.5 < hi and 0.3 < lo and hi < 0.7
    assert bootstrap_interval(values, seed=3) == (lo, hi)  # seeded: reproducible
    assert bootstrap_interval([0.7], seed=0) == pytest.approx((0.7, 0.7))
    # Weighted: one episode with 3/3 right, one with 0/1 -> pooled 3/4 lies inside.
    wlo, whi = bootstrap_interval([1.0, 0.0], weights=[3, 1], seed=0)
    assert wlo <= 0.75 <= whi
    with pytest.raises(ValueError, match="non-empty"):
        bootstrap_interval([], seed=0)
    with pytest.raises(ValueError, match="weights"):
        bootstrap_interval([1.0, 0.0], weights=[1.0], seed=0)


def test_summarize_hand_worked_and_json_ready() -> None:
    summary = summarize(EPISODES)
    assert summary["n_episodes"] == 4
    assert summary["success_radius_m"] == DEFAULT_SUCCESS_RADIUS_M
    assert summary["sr"] == pytest.approx(0.5)
    assert summary["spl"] == pytest.approx(0.45)
    assert summary["oasr"] == pytest.approx(0.5)
    assert summary["sa"] == pytest.approx(0.5)
    assert summary["gnsa"] == pytest.approx(4 / 6)
    assert summary["decision_steps"] == 6
    assert summary["mean_path_length_m"] == pytest.approx(34.0 / 4)
    assert summary["sr_ci95"] == pytest.approx(list(wilson_interval(2, 4)))
    for key in ("sr", "spl", "oasr", "sa", "gnsa"):
        lo, hi = summary[f"{key}_ci95"]
        assert lo <= summary[key] <= hi
    assert json.loads(json.dumps(summary)) == summary


def test_record_round_trip_and_validation() -> None:
    rec = EPISODES[0]
    data = json.loads(json.dumps(rec.to_dict()))
    assert EpisodeRecord.from_dict(data) == rec
    assert isinstance(rec.decisions, tuple)
    with pytest.raises(InvalidInputError, match="unknown keys"):
        EpisodeRecord.from_dict(data | {"colour": "red"})
    with pytest.raises(InvalidInputError, match="final_position_m"):
        replace(rec, final_position_m=(math.nan, 0.0))
    with pytest.raises(InvalidInputError, match="geodesic_length_m"):
        replace(rec, geodesic_length_m=-1.0)
    with pytest.raises(InvalidInputError, match="success_declared"):
        replace(rec, success_declared="yes")
