"""RotateInPlace alone: RUNNING while turning by odometry, SUCCESS at the angle, FAILURE when blocked."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.rotate_in_place import RotateInPlace
from semexp_bt.core.types import Pose2D, Twist
from tests.behaviours.rig import FakeRobot, Rig, compact


@pytest.mark.parametrize("angle_deg", [90.0, -45.0, 360.0])
def test_it_turns_by_the_angle_either_way_then_stops(rig: Rig, angle_deg: float) -> None:
    turn = rig.build(RotateInPlace, angle_deg=angle_deg, yaw_rate_radps=0.8)
    first = rig.tick(turn)
    assert math.copysign(1.0, rig.get("cmd_twist").angular_z_radps) == math.copysign(1.0, angle_deg)
    statuses = first + rig.tick_until_done(turn)
    rig.show(turn)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    turned = math.degrees(math.remainder(rig.robot.base_pose().yaw_rad - math.radians(angle_deg), math.tau))
    assert abs(turned) <= 2.0
    assert rig.get("cmd_twist") == Twist.zero()
    assert rig.written_by(turn) == ["cmd_twist", "cmd_stamp_s"]


def test_it_fails_after_the_timeout_when_the_base_cannot_turn(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0), blocked=True))
    turn = rig.build(RotateInPlace, angle_deg=45.0, timeout_s=0.5)
    statuses = rig.tick_until_done(turn, limit_s=3.0)
    rig.show(turn)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert rig.robot.now_s() == pytest.approx(0.54, abs=0.021)
    assert rig.get("cmd_twist") == Twist.zero()


def test_halting_it_commands_a_zero_twist_and_a_restart_turns_the_whole_angle_again(rig: Rig) -> None:
    turn = rig.build(RotateInPlace, angle_deg=90.0)
    rig.tick(turn, ticks=10)
    rig.halt(turn)
    assert rig.get("cmd_twist") == Twist.zero()
    yaw_at_halt = rig.robot.base_pose().yaw_rad
    statuses = rig.tick_until_done(turn)
    rig.show(turn)
    assert statuses[-1] == Status.SUCCESS
    turned = math.remainder(rig.robot.base_pose().yaw_rad - yaw_at_halt, math.tau)
    assert math.degrees(turned) == pytest.approx(90.0, abs=2.0)
