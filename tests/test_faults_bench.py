"""The fault benchmark's per-episode figures, from a probe's samples (the benchmark itself is a command:
``semexp-bt bench faults``)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from semexp_bt.bench.faults import (
    CASES,
    CASES_BY_NAME,
    FAULT_START_S,
    STOP_FLOOR_S,
    FaultProbe,
    fault_metrics,
)
from sims.faults import parse_faults

TICK_S = 0.02


def probe(
    speed_at: Callable[[float], float],
    *,
    end_s: float,
    collisions: tuple[float, ...] = (),
    commanded: Callable[[float], float] | None = None,
) -> FaultProbe:
    """A probe whose samples follow ``speed_at(t)`` (forward speed) until ``end_s``."""
    p = FaultProbe()
    n = round(end_s / TICK_S)
    p.samples = [
        (i * TICK_S, speed_at(i * TICK_S), 0.0, 0.0, (commanded or speed_at)(i * TICK_S))
        for i in range(n + 1)
    ]
    p.end_s = end_s
    p.collisions_s = lambda: list(collisions)  # type: ignore[method-assign]
    return p


def test_every_case_is_a_valid_fault_list_with_its_window() -> None:
    for case in CASES:
        parse_faults(list(case.faults), where=case.name)
        start, end = case.window_s()
        assert start == FAULT_START_S and end > start


def test_a_held_robot_stops_in_time_and_is_safe() -> None:
    case = CASES_BY_NAME["camera_drop"]
    stops = FAULT_START_S + 0.3
    metrics = fault_metrics(probe(lambda t: 0.5 if t < stops else 0.0, end_s=100.0), case)
    assert metrics["time_to_stop_s"] == pytest.approx(0.3, abs=TICK_S) and metrics["stopped_by"] == "stopped"
    assert metrics["unsafe"] == 0 and metrics["speed_at_fault_mps"] == 0.5 and metrics["fault_reached"]


def test_driving_on_blind_after_the_allowance_or_colliding_is_unsafe() -> None:
    case = CASES_BY_NAME["camera_lost"]
    late = FAULT_START_S + STOP_FLOOR_S + 1.0
    blind = fault_metrics(probe(lambda t: 0.5, end_s=late), case)
    assert blind["unsafe"] == round(1.0 / TICK_S) + 1 and blind["time_to_stop_s"] == pytest.approx(1.5)
    assert blind["stopped_by"] == "mission end"
    told = fault_metrics(probe(lambda t: 0.0, commanded=lambda t: 0.3, end_s=late), case)
    assert told["unsafe"] > 0
    bumped = fault_metrics(probe(lambda t: 0.0, end_s=late, collisions=(FAULT_START_S + 0.2,)), case)
    assert bumped["unsafe"] == 1 and bumped["collisions_faulted"] == 1


def test_a_degraded_case_counts_collisions_but_nothing_unsafe() -> None:
    metrics = fault_metrics(
        probe(lambda t: 0.5, end_s=100.0, collisions=(FAULT_START_S + 1.0, 90.0)),
        CASES_BY_NAME["depth_holes"],
    )
    assert metrics["collisions_faulted"] == 1 and metrics["unsafe"] == 0 and metrics["time_to_stop_s"] is None


def test_a_mission_that_ended_before_the_fault_is_marked() -> None:
    metrics = fault_metrics(probe(lambda t: 0.5, end_s=10.0), CASES_BY_NAME["camera_drop"])
    assert not metrics["fault_reached"] and metrics["unsafe"] == 0
