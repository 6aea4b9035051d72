"""FollowPath ticked alone (with a plan staged on the board): drives the plan, faces the subgoal, SUCCESS."""

import math

import py_trees

from behaviours.follow_path import FollowPath
from semexp_bt.core.types import Pose2D
from semexp_bt.nav.global_planner import GlobalPlanner
from tests.behaviours.nav_rig import make_rig, subgoal_at
from tests.test_nav_stack import walled_costmap

S = py_trees.common.Status


def test_it_follows_the_plan_through_the_door_and_faces_the_subgoal() -> None:
    rig = make_rig(start=Pose2D(-2.0, 2.5, 0.0))
    costmap = walled_costmap(door=True)
    rig.set("local_map", costmap)
    rig.set("subgoal", subgoal_at(2.0, 2.5))
    rig.set("global_plan", GlobalPlanner().plan(costmap, start_xy=(-2.0, 2.5), goal_xy=(2.0, 2.5)))
    node = rig.build(FollowPath)
    statuses = rig.tick_until_done(node, limit_s=60.0)
    rig.show(node)
    assert statuses[-1] == S.SUCCESS and set(statuses[:-1]) == {S.RUNNING}
    pose = rig.robot.base_pose()
    assert math.hypot(pose.x_m - 2.0, pose.y_m - 2.5) <= 0.7 + 0.05
    bearing = math.remainder(math.atan2(2.5 - pose.y_m, 2.0 - pose.x_m) - pose.yaw_rad, math.tau)
    assert abs(bearing) <= math.radians(17.0) or math.hypot(pose.x_m - 2.0, pose.y_m - 2.5) < 0.1
    assert rig.get("cmd_twist").linear_x_mps == 0.0  # stopped on arrival
    assert rig.get("plan") is not None


def test_blocked_for_longer_than_the_timeout_fails_with_the_reason() -> None:
    rig = make_rig(start=Pose2D(-2.0, 2.5, 0.0))
    costmap = walled_costmap(door=True)
    rig.set("local_map", costmap)
    rig.set("subgoal", subgoal_at(2.0, 2.5))
    plan = GlobalPlanner().plan(costmap, start_xy=(-2.0, 2.5), goal_xy=(2.0, 2.5))
    rig.set("global_plan", plan)
    rig.robot._pose = Pose2D(-3.75, -3.75, 0.8)  # noqa: SLF001 - jammed into a corner: nothing is admissible
    node = rig.build(FollowPath, blocked_timeout_s=0.5)
    statuses = rig.tick_until_done(node, limit_s=5.0)
    rig.show(node)
    assert statuses[-1] == S.FAILURE
    assert rig.get("nav_failure") == "blocked"


def test_no_subgoal_is_a_failure() -> None:
    rig = make_rig()
    node = rig.build(FollowPath)
    assert rig.tick(node) == [S.FAILURE]
