"""FollowPath alone (a plan staged on the board): drives the plan, faces the subgoal, SUCCESS; FAILURE
with ``blocked`` when nothing is admissible for the timeout, or without a subgoal."""

from __future__ import annotations

import math
from collections.abc import Callable

from py_trees.common import Status

from behaviours.follow_path import FollowPath
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.global_planner import GlobalPlanner
from tests.behaviours.rig import FakeRobot, Rig, subgoal_at
from tests.test_nav_stack import walled_costmap


def _staged(make_rig: Callable[..., Rig], start: Pose2D) -> Rig:
    rig = make_rig(robot=FakeRobot(start_pose=start))
    costmap = walled_costmap(door=True)
    rig.set("local_map", costmap)
    rig.set("subgoal", subgoal_at(2.0, 2.5))
    rig.set("global_plan", GlobalPlanner().plan(costmap, start_xy=(-2.0, 2.5), goal_xy=(2.0, 2.5)))
    return rig


def test_it_follows_the_plan_through_the_door_and_faces_the_subgoal(make_rig: Callable[..., Rig]) -> None:
    rig = _staged(make_rig, Pose2D(-2.0, 2.5, 0.0))
    follow = rig.build(FollowPath)
    statuses = rig.tick_until_done(follow, limit_s=60.0)
    rig.show(follow)
    assert statuses[-1] == Status.SUCCESS and set(statuses[:-1]) == {Status.RUNNING}
    pose = rig.robot.base_pose()
    assert math.hypot(pose.x_m - 2.0, pose.y_m - 2.5) <= 0.7 + 0.05
    bearing = wrap_angle(math.atan2(2.5 - pose.y_m, 2.0 - pose.x_m) - pose.yaw_rad)
    assert abs(bearing) <= math.radians(17.0) or math.hypot(pose.x_m - 2.0, pose.y_m - 2.5) < 0.1
    assert rig.get("cmd_twist") == Twist.zero()  # stopped on arrival
    assert rig.get("plan") is not None
    assert rig.written_by(follow) == ["plan", "cmd_twist", "cmd_stamp_s"]


def test_blocked_for_longer_than_the_timeout_fails_with_the_reason(make_rig: Callable[..., Rig]) -> None:
    rig = _staged(make_rig, Pose2D(-3.75, -3.75, 0.8))  # jammed into a corner: nothing is admissible
    follow = rig.build(FollowPath, blocked_timeout_s=0.5)
    statuses = rig.tick_until_done(follow, limit_s=5.0)
    rig.show(follow)
    assert statuses[-1] == Status.FAILURE
    assert rig.get("nav_failure") == "blocked"
    assert rig.get("cmd_twist") == Twist.zero()


def test_no_subgoal_is_a_failure(rig: Rig) -> None:
    follow = rig.build(FollowPath)
    assert rig.tick(follow) == [Status.FAILURE]
    rig.show(follow)
    assert follow.feedback_message == "no subgoal"
