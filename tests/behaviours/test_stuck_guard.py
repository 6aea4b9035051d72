"""StuckGuard alone: RUNNING while the base moves or turns and nears the subgoal; FAILURE otherwise."""

from __future__ import annotations

from collections.abc import Callable

from py_trees.common import Status

from behaviours.stuck_guard import StuckGuard
from semexp_bt.core.types import Pose2D, Subgoal, Twist
from tests.behaviours.rig import FakeRobot, Rig, compact


def test_a_base_that_does_not_move_fails_after_the_window(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), blocked=True))
    rig.robot.command_twist(Twist(linear_x_mps=0.5))  # commanded, but blocked
    guard = rig.build(StuckGuard, window_s=1.0)
    statuses = rig.tick_until_done(guard, limit_s=5.0)
    rig.show(guard)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert 1.0 < rig.robot.now_s() <= 1.1
    assert guard.feedback_message.startswith("stuck")
    assert [e["kind"] for e in rig.services.events] == ["stuck"]
    assert rig.written_by(guard) == ["nav_failure"] and rig.get("nav_failure") == "stuck"


def test_moving_or_turning_keeps_it_running(rig: Rig) -> None:
    guard = rig.build(StuckGuard, window_s=1.0)
    rig.robot.command_twist(Twist(linear_x_mps=0.5))
    moving = rig.tick(guard, ticks=100, drive=False)  # 2 s, 1 m
    rig.robot.command_twist(Twist(angular_z_radps=1.5))
    turning = rig.tick(guard, ticks=100, drive=False)  # 2 s, 86 degrees a second
    rig.show(guard)
    assert moving + turning == [Status.RUNNING] * 200


def test_turning_on_the_spot_without_nearing_the_subgoal_fails_after_the_approach_window(rig: Rig) -> None:
    rig.set("subgoal", Subgoal(node_id=1, position_m=(5.0, 0.0, 0.0), label="door", utility=1.0))
    guard = rig.build(StuckGuard, window_s=1.0, approach_window_s=2.0)
    rig.robot.command_twist(Twist(angular_z_radps=1.5))  # dithering: turns, never closer
    statuses = rig.tick_until_done(guard, limit_s=10.0)
    rig.show(guard)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert 2.0 < rig.robot.now_s() <= 2.1
    assert guard.feedback_message.startswith("no progress")
    assert [e["kind"] for e in rig.services.events] == ["no_progress"]
    assert rig.get("nav_failure") == "stuck"


def test_nearing_the_subgoal_keeps_it_running(rig: Rig) -> None:
    rig.set("subgoal", Subgoal(node_id=1, position_m=(5.0, 0.0, 0.0), label="door", utility=1.0))
    guard = rig.build(StuckGuard, approach_window_s=2.0)
    rig.robot.command_twist(Twist(linear_x_mps=0.3))
    assert rig.tick(guard, ticks=250, drive=False) == [Status.RUNNING] * 250  # 5 s, 1.5 m closer
    rig.show(guard)


def test_a_restart_after_a_halt_restarts_both_windows(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), blocked=True))
    guard = rig.build(StuckGuard, window_s=1.0)
    rig.tick(guard, ticks=40)  # 0.8 s without moving
    rig.halt(guard)
    statuses = rig.tick(guard, ticks=50)  # 1.0 s more: the window starts again at the restart
    rig.show(guard)
    assert statuses == [Status.RUNNING] * 50
