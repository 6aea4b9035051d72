"""BackUp alone: step away onto observed free cells, SUCCESS when done or timed out, FAILURE when no
direction is known free."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.back_up import BackUp
from semexp_bt.core.types import Pose2D, Twist
from tests.behaviours.rig import FakeRobot, Rig, compact, robot_among
from tests.test_executive import Post


def test_without_a_costmap_it_steps_straight_back(rig: Rig) -> None:
    rig.set("local_map", None)
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


def test_it_steps_back_onto_the_cells_it_has_seen(rig: Rig) -> None:
    """The robot walked 0.6 m forward: its own trail (footprint clearing) is known free behind it."""
    rig.map_around()
    for x in (0.2, 0.4, 0.6):
        rig.map_from(Pose2D(x, 0.0, 0.0))
    rig.robot.place(Pose2D(0.6, 0.0, 0.0))
    back = rig.build(BackUp, distance_m=0.3)
    statuses = rig.tick_until_done(back, limit_s=10.0)
    rig.show(back)
    assert statuses[-1] == Status.SUCCESS
    pose = rig.robot.base_pose()
    assert math.hypot(pose.x_m - 0.6, pose.y_m) >= 0.29 and pose.x_m < 0.6  # back (or back-sideways)


def test_it_steps_away_from_an_obstacle_the_map_knows_behind_it(make_rig: Callable[..., Rig]) -> None:
    post = Post(1, -0.75, 0.0, "chair", None, radius_m=0.2)
    rig = make_rig(robot=robot_among(post))
    rig.map_around(turns=16)  # the costmap saw the post when the robot faced it; now it looks away
    for y in (0.6, 0.4, 0.2):  # the robot came in from its left: that strip is known free
        rig.map_from(Pose2D(0.0, y, 0.0))
    back = rig.build(BackUp, distance_m=0.3)
    statuses = rig.tick_until_done(back)
    rig.show(back)
    assert statuses[-1] == Status.SUCCESS
    pose = rig.robot.base_pose()
    assert pose.x_m > -0.1, "it must not back into the post"
    assert pose.y_m >= 0.29, "it steps left, onto the cells it came over"


def test_it_refuses_to_step_onto_cells_never_seen(rig: Rig) -> None:
    rig.map_around(turns=1)  # only the view ahead: nothing behind or beside is known
    back = rig.build(BackUp, distance_m=0.5)
    assert rig.tick(back) == [Status.FAILURE]
    rig.show(back)
    assert back.feedback_message == "no direction to step away onto known free cells"
    assert rig.robot.base_pose() == Pose2D(0.0, 0.0, 0.0)
    assert rig.get("cmd_twist") == Twist.zero()


def test_a_blocked_base_succeeds_after_the_timeout_instead_of_hanging(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), blocked=True))
    rig.set("local_map", None)
    back = rig.build(BackUp, timeout_s=1.0)
    statuses = rig.tick_until_done(back, limit_s=5.0)
    rig.show(back)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert rig.robot.now_s() == pytest.approx(1.04, abs=0.021)  # the first tick after 1 s
    assert back.feedback_message == "stepped 0.00 m at 180 deg"


def test_halting_it_commands_a_zero_twist(rig: Rig) -> None:
    rig.set("local_map", None)
    back = rig.build(BackUp)
    assert rig.tick(back, ticks=3) == [Status.RUNNING] * 3
    assert rig.get("cmd_twist") != Twist.zero()
    rig.halt(back)
    assert rig.get("cmd_twist") == Twist.zero()
