"""The one rule for time comparisons (semexp_bt.core.clock), and a mission that does not care whether its
clock is a float sum of 20 ms steps or whole nanoseconds (what ROS 2's ``/clock`` carries)."""

from __future__ import annotations

import math

import py_trees
import pytest

from robots.null_robot import NullRobot
from semexp_bt.core.clock import CLOCK_TOLERANCE_S, has_elapsed, is_due, next_due_s
from semexp_bt.core.types import Pose2D
from tests.test_executive import Post, make_services, run, seeing


class NanosecondClockRobot(NullRobot):
    """A NullRobot whose clock reads as whole nanoseconds, as a ROS 2 ``/clock`` subscriber sees it."""

    def now_s(self) -> float:
        return round(super().now_s() * 1e9) * 1e-9


def test_a_period_of_float_steps_is_reached_as_it_is_in_whole_nanoseconds() -> None:
    float_clock = sum([0.02] * 400)  # 8 s of ticks (StuckGuard's window)
    assert float_clock < 8.0  # a comparison without a tolerance misses the deadline by one tick
    assert has_elapsed(since_s=0.0, now_s=float_clock, duration_s=8.0)
    assert has_elapsed(since_s=0.0, now_s=round(float_clock * 1e9) * 1e-9, duration_s=8.0)
    assert not has_elapsed(since_s=0.0, now_s=7.98, duration_s=8.0)
    assert is_due(now_s=1.0 - 0.5 * CLOCK_TOLERANCE_S, due_s=1.0) and not is_due(now_s=0.999, due_s=1.0)
    assert CLOCK_TOLERANCE_S < 0.001 * 0.02  # far below a tick


@pytest.mark.parametrize("now_s", [0.26, sum([0.02] * 13), 0.26 + 1e-9])
def test_a_rate_stays_on_its_grid_whatever_the_clock_rounding(now_s: float) -> None:
    assert next_due_s(due_s=0.25, now_s=now_s, period_s=0.25) == pytest.approx(0.5)
    # A stall of exactly one period restarts the grid from now, on either clock.
    assert next_due_s(due_s=0.25, now_s=sum([0.02] * 25), period_s=0.25) == pytest.approx(0.75)
    assert next_due_s(due_s=0.25, now_s=0.5 - 1e-10, period_s=0.25) == pytest.approx(0.75)


def _mission(robot_type: type[NullRobot]) -> tuple[str, int, list[tuple[float, str]], int, Pose2D]:
    distractor = Post(
        2, 2.5, -0.5, vlm_label="red trash can", detector_label="fire extinguisher", detector_confidence=0.45
    )
    target = Post(1, -3.0, 2.5, vlm_label="fire extinguisher", detector_label="fire extinguisher")
    robot = robot_type(
        start_pose=Pose2D(0.0, 0.0, 0.0), posts=((2, 2.5, -0.5, 0.2, 0.6), (1, -3.0, 2.5, 0.2, 0.6))
    )
    services = make_services(robot, seeing([distractor, target]))
    tree, board = run("object_search.yaml", services, ["find the fire extinguisher"])
    ticks = round(robot.now_s() / 0.02)
    events = [(round(e["stamp_s"], 3), e["kind"]) for e in services.events]
    return str(board.mission_outcome), ticks, events, len(services.decision_log), robot.base_pose()


def test_a_mission_on_a_nanosecond_clock_runs_as_on_the_float_clock() -> None:
    """Every deadline, period and timeout of the tree goes through the one rule, so the clock's last bits
    change nothing: the same ticks, events, decisions and path."""
    on_floats = _mission(NullRobot)
    on_nanoseconds = _mission(NanosecondClockRobot)
    print(on_floats[:4], on_nanoseconds[:4], sep="\n")
    assert on_floats[0] == "success"
    assert on_nanoseconds[:4] == on_floats[:4]
    a, b = on_floats[4], on_nanoseconds[4]
    assert math.hypot(a.x_m - b.x_m, a.y_m - b.y_m) < 1e-6 and abs(a.yaw_rad - b.yaw_rad) < 1e-6
    assert py_trees.blackboard.Blackboard.storage is not None
