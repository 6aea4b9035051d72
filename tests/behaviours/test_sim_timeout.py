"""SimTimeout alone: the child runs until duration_s of robot-clock time, then it is halted and FAILURE."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.common import Status

from behaviours.sim_timeout import SimTimeout
from behaviours.spec import BuildContext
from robots.null_robot import NullRobot
from semexp_bt.core.types import Pose2D


def timeout_over(child: py_trees.behaviour.Behaviour, duration_s: float) -> tuple[SimTimeout, NullRobot]:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    robot.advance(10.0)
    return SimTimeout(
        name="T", child=child, duration_s=duration_s, context=BuildContext(clock=robot.now_s)
    ), robot


def test_a_child_still_running_at_the_deadline_is_halted_and_fails() -> None:
    child = py_trees.behaviours.TickCounter(name="Long", duration=100, completion_status=Status.SUCCESS)
    timeout, robot = timeout_over(child, 1.0)
    statuses = []
    for dt in (0.0, 0.3, 0.3, 0.3, 0.1):  # t = 10.0, 10.3, 10.6, 10.9, 11.0
        if dt > 0.0:
            robot.advance(dt)
        timeout.tick_once()
        statuses.append(timeout.status)
    print(py_trees.display.unicode_tree(timeout, show_status=True))
    assert statuses == [Status.RUNNING] * 4 + [Status.FAILURE]
    assert child.counter == 4  # not ticked past its deadline
    assert child.status == Status.INVALID
    assert timeout.feedback_message == "timed out after 1 s"
    # Re-entering re-arms the deadline from the new time.
    robot.advance(40.0)
    timeout.tick_once()
    assert timeout.status == Status.RUNNING


def test_an_early_result_passes_through_however_long_the_wall_clock_takes() -> None:
    child = py_trees.behaviours.TickCounter(name="Short", duration=2, completion_status=Status.FAILURE)
    timeout, _ = timeout_over(child, 0.5)
    statuses = []
    for _ in range(3):
        timeout.tick_once()  # the robot clock stands still: no timeout however long this takes
        statuses.append(timeout.status)
    print(py_trees.display.unicode_tree(timeout, show_status=True))
    assert statuses == [Status.RUNNING, Status.RUNNING, Status.FAILURE]


def test_halting_it_halts_the_child_and_a_restart_re_arms_the_deadline() -> None:
    child = py_trees.behaviours.Running(name="Run")
    timeout, robot = timeout_over(child, 1.0)
    timeout.tick_once()
    robot.advance(0.9)
    timeout.stop(Status.INVALID)
    assert child.status == Status.INVALID
    robot.advance(0.5)  # past the first deadline
    timeout.tick_once()
    print(py_trees.display.unicode_tree(timeout, show_status=True))
    assert timeout.status == Status.RUNNING


def test_a_duration_that_is_not_positive_is_refused() -> None:
    with pytest.raises(ValueError, match="duration_s must be > 0"):
        timeout_over(py_trees.behaviours.Running(name="Run"), 0.0)
