"""BackUp alone: step away by distance_m in the roomiest direction, SUCCESS when done or timed out."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.back_up import BackUp
from robots.null_robot import NullRobot
from semexp_bt.core.types import Pose2D, Twist
from tests.behaviours.rig import FakeRobot, Rig, compact


def test_without_anything_mapped_it_steps_straight_back(rig: Rig) -> None:
    back = rig.build(BackUp, distance_m=0.3, speed_mps=0.2)
    statuses = rig.tick(back)
    assert rig.get("cmd_twist") == Twist(linear_x_mps=-0.2, linear_y_mps=0.2 * math.sin(math.pi))
    statuses += rig.tick_until_done(back)
    rig.show(back)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert 70 <= len(statuses) <= 80  # 0.3 m at 0.2 m/s: 1.5 s of 20 ms ticks
    pose = rig.robot.base_pose()
    assert math.hypot(pose.x_m, pose.y_m) >= 0.3 and pose.x_m < -0.29
    assert rig.get("cmd_twist") == Twist.zero()
    assert rig.written_by(back) == ["cmd_twist", "cmd_stamp_s"]


def test_it_steps_away_from_an_obstacle_the_map_knows_behind_it(make_rig: Callable[..., Rig]) -> None:
    post = (1, -0.6, 0.0, 0.2, 0.6)
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=(post,)))
    # The map saw the post when the robot faced it (the camera now looks the other way).
    rig.get("local_map").integrate(NullRobot(start_pose=Pose2D(0.0, 0.0, math.pi), posts=(post,)).observe())
    back = rig.build(BackUp, distance_m=0.3)
    statuses = rig.tick_until_done(back)
    rig.show(back)
    assert statuses[-1] == Status.SUCCESS
    pose = rig.robot.base_pose()
    assert pose.x_m > -0.1, "it must not back into the post"
    assert math.hypot(pose.x_m, pose.y_m) >= 0.3


def test_a_blocked_base_succeeds_after_the_timeout_instead_of_hanging(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), blocked=True))
    back = rig.build(BackUp, timeout_s=1.0)
    statuses = rig.tick_until_done(back, limit_s=5.0)
    rig.show(back)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert rig.robot.now_s() == pytest.approx(1.04, abs=0.021)  # the first tick after 1 s
    assert back.feedback_message == "backed up 0.00 m"


def test_halting_it_commands_a_zero_twist(rig: Rig) -> None:
    back = rig.build(BackUp)
    assert rig.tick(back, ticks=3) == [Status.RUNNING] * 3
    assert rig.get("cmd_twist") != Twist.zero()
    rig.halt(back)
    assert rig.get("cmd_twist") == Twist.zero()
