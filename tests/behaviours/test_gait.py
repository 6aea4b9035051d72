"""Gait alone: always RUNNING, realises cmd_twist, zero when the command is stale, stop() when halted."""

from __future__ import annotations

from typing import Any

from py_trees.common import Status

from behaviours.gait import Gait
from robots.interface import Robot
from semexp_bt.core.types import Twist
from tests.behaviours.rig import Rig

FORWARD = Twist(linear_x_mps=0.5, angular_z_radps=0.2)


def test_it_passes_a_fresh_command_to_the_robot_and_zero_once_it_is_stale(rig: Rig) -> None:
    gait = rig.build(Gait, command_timeout_s=0.1)
    assert rig.tick(gait, drive=False) == [Status.RUNNING]
    assert rig.robot.base_twist() == Twist.zero()  # never commanded: the watchdog's zero
    rig.set("cmd_twist", FORWARD)
    rig.set("cmd_stamp_s", rig.robot.now_s())
    fresh = rig.tick(gait, ticks=5, drive=False)  # 0.00 .. 0.08 s after the stamp
    assert rig.robot.base_twist() == FORWARD and rig.robot.base_pose().x_m > 0.0
    stale = rig.tick(gait, ticks=2, drive=False)  # 0.10, 0.12 s: older than the timeout
    rig.show(gait)
    assert fresh + stale == [Status.RUNNING] * 7
    assert rig.robot.base_twist() == Twist.zero()
    assert rig.written_by(gait) == []


def test_with_a_gait_policy_the_policy_gets_the_twist(rig: Rig) -> None:
    calls: list[Twist] = []

    def policy(robot: Robot, twist: Any) -> None:
        calls.append(twist)

    rig.services.gait = policy
    gait = rig.build(Gait)
    rig.set("cmd_twist", FORWARD)
    rig.set("cmd_stamp_s", rig.robot.now_s())
    assert rig.tick(gait, ticks=2, drive=False) == [Status.RUNNING] * 2
    rig.show(gait)
    assert calls == [FORWARD, FORWARD]
    assert rig.robot.base_twist() == Twist.zero()  # the policy, not the backend, moves the legs


def test_halting_stops_the_robot(rig: Rig) -> None:
    gait = rig.build(Gait)
    rig.set("cmd_twist", FORWARD)
    rig.set("cmd_stamp_s", rig.robot.now_s())
    rig.tick(gait, drive=False)
    rig.halt(gait)
    assert rig.robot.stopped == 1 and rig.robot.base_twist() == Twist.zero()
