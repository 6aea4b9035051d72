"""RateLimiter alone: the child is ticked on a grid of robot-clock time and its status held in between."""

from __future__ import annotations

import math

import py_trees
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import Status

from behaviours.rate_limiter import RateLimiter
from behaviours.spec import BuildContext
from robots.null_robot import NullRobot
from semexp_bt.core.types import Pose2D


def limiter_over(child: py_trees.behaviour.Behaviour, rate_hz: float) -> tuple[RateLimiter, NullRobot]:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    return RateLimiter(name="R", child=child, rate_hz=rate_hz, context=BuildContext(clock=robot.now_s)), robot


def test_it_ticks_the_child_on_a_grid_and_holds_its_status() -> None:
    queue = [Status.RUNNING, Status.SUCCESS, Status.FAILURE]
    child = py_trees.behaviours.StatusQueue(name="Q", queue=queue, eventually=None)  # cycles the queue
    limiter, robot = limiter_over(child, 12.0)
    seen = []
    for _ in range(26):  # 50 Hz for 0.5 s
        limiter.tick_once()
        seen.append((limiter.child_ticks, limiter.status))
        robot.advance(0.02)
    print(py_trees.display.unicode_tree(limiter, show_status=True))
    # Due at 0, 1/12, 2/12, ... s: the first tick at or after each: t = 0, .1, .18, .26, .34, .42, .5.
    ticked_at = [i for i in range(26) if i == 0 or seen[i][0] != seen[i - 1][0]]
    assert ticked_at == [0, 5, 9, 13, 17, 21, 25]
    # The child's status is held until its next tick: R until tick 5, S until 9, F until 13, then R.
    statuses = [status for _, status in seen]
    assert statuses[:14] == [Status.RUNNING] * 5 + [Status.SUCCESS] * 4 + [Status.FAILURE] * 4 + [
        Status.RUNNING
    ]


def test_a_halt_drops_the_held_status_and_the_next_tick_reaches_the_child() -> None:
    child = py_trees.behaviours.Running(name="Run")
    limiter, robot = limiter_over(child, 1.0)
    limiter.tick_once()
    limiter.stop(Status.INVALID)  # a higher-priority branch took over
    assert child.status == Status.INVALID
    robot.advance(0.1)
    limiter.tick_once()
    print(py_trees.display.unicode_tree(limiter, show_status=True))
    assert limiter.child_ticks == 2 and limiter.status == Status.RUNNING


def test_a_rate_that_is_not_positive_is_refused() -> None:
    with pytest.raises(ValueError, match="rate_hz must be > 0"):
        limiter_over(py_trees.behaviours.Success(name="S"), 0.0)


@settings(max_examples=60, deadline=None)
@given(
    rate_hz=st.floats(0.5, 60.0),
    steps=st.lists(st.floats(0.001, 0.3), min_size=1, max_size=120),
)
def test_it_never_exceeds_its_rate_and_never_starves_the_child(rate_hz: float, steps: list[float]) -> None:
    limiter, robot = limiter_over(py_trees.behaviours.Running(name="Run"), rate_hz)
    tick_times = []
    for dt in [0.0, *steps]:
        if dt > 0.0:
            robot.advance(dt)
        before = limiter.child_ticks
        limiter.tick_once()
        if limiter.child_ticks != before:
            tick_times.append(robot.now_s())
    elapsed = robot.now_s()
    assert tick_times[0] == 0.0
    assert len(tick_times) <= math.floor(elapsed * rate_hz + 1e-6) + 1
    # Consecutive child ticks are at most one period plus one tree step apart.
    gaps = [b - a for a, b in zip(tick_times, tick_times[1:], strict=False)]
    assert all(gap <= 1.0 / rate_hz + max(steps) + 1e-9 for gap in gaps)
