"""LocalPlan alone: drive to the subgoal and face it (SUCCESS); no subgoal, blocked or no path is FAILURE."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.local_plan import LocalPlan
from semexp_bt.core.types import Pose2D, Subgoal, Twist
from tests.behaviours.rig import FakeRobot, Rig, compact


def subgoal_at(x_m: float, y_m: float) -> Subgoal:
    return Subgoal(node_id=1, position_m=(x_m, y_m, 0.0), label="doorway", utility=1.0)


def test_without_a_subgoal_it_fails_and_commands_a_stop(rig: Rig) -> None:
    plan = rig.build(LocalPlan)
    assert rig.tick(plan) == [Status.FAILURE]
    rig.show(plan)
    assert plan.feedback_message == "no subgoal"
    assert rig.get("cmd_twist") == Twist.zero()


def test_it_drives_to_the_subgoal_and_succeeds_within_the_arrival_radius(rig: Rig) -> None:
    rig.set("subgoal", subgoal_at(2.0, 0.5))
    plan = rig.build(LocalPlan, arrival_radius_m=0.7)
    first = rig.tick(plan)
    assert rig.get("cmd_twist").linear_x_mps > 0.0
    statuses = first + rig.tick_until_done(plan, limit_s=30.0)
    rig.show(plan)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    pose = rig.robot.base_pose()
    assert math.hypot(2.0 - pose.x_m, 0.5 - pose.y_m) <= 0.7
    assert rig.get("cmd_twist") == Twist.zero()
    assert rig.get("plan") is not None and rig.get("local_map").frames > 0
    assert rig.written_by(plan) == ["plan", "cmd_twist", "cmd_stamp_s"]


def test_on_arrival_it_first_turns_to_face_the_subgoal(rig: Rig) -> None:
    rig.set("subgoal", subgoal_at(-0.5, 0.0))  # within the arrival radius, behind the robot
    plan = rig.build(LocalPlan, arrival_radius_m=0.7)
    statuses = rig.tick_until_done(plan)
    rig.show(plan)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert len(statuses) > 10
    assert abs(math.remainder(rig.robot.base_pose().yaw_rad - math.pi, math.tau)) <= 0.3
    assert rig.robot.base_pose().x_m == pytest.approx(0.0, abs=1e-9)  # turned on the spot


def test_a_subgoal_with_no_path_on_the_map_fails_after_the_no_path_timeout(rig: Rig) -> None:
    rig.set("subgoal", subgoal_at(30.0, 0.0))  # beyond the mapped square
    plan = rig.build(LocalPlan, no_path_timeout_s=1.0)
    statuses = rig.tick_until_done(plan, limit_s=10.0)
    rig.show(plan)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert 1.0 < rig.robot.now_s() <= 1.1
    assert [e["kind"] for e in rig.services.events] == ["no_path"]
    assert rig.get("cmd_twist") == Twist.zero()


def test_blocked_for_longer_than_the_timeout_is_a_failure(make_rig: Callable[..., Rig]) -> None:
    """Without a map the planner sees only the post in front; it reports 'blocked' until the timeout."""
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 0.6, 0.0, 0.3, 0.6),)))
    rig.set("local_map", None)
    rig.set("subgoal", subgoal_at(3.0, 0.0))
    plan = rig.build(LocalPlan, blocked_timeout_s=1.0)
    statuses = rig.tick_until_done(plan, limit_s=10.0)
    rig.show(plan)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert rig.get("plan").status == "blocked"
    assert rig.robot.base_pose().x_m == pytest.approx(0.0, abs=1e-9)  # it never drove into the post
    assert rig.get("cmd_twist") == Twist.zero()


def test_halting_it_commands_a_zero_twist(rig: Rig) -> None:
    rig.set("subgoal", subgoal_at(5.0, 0.0))
    plan = rig.build(LocalPlan)
    assert rig.tick(plan, ticks=5) == [Status.RUNNING] * 5
    assert rig.get("cmd_twist") != Twist.zero()
    rig.halt(plan)
    assert rig.get("cmd_twist") == Twist.zero()
