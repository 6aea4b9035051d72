"""Spin alone: turns by the angle when the footprint can, stops before sweeping into a post (FAILURE)."""

from __future__ import annotations

import math
from collections.abc import Callable

from py_trees.common import Status

from behaviours.spin import Spin
from semexp_bt.core.types import Pose2D, Twist
from tests.behaviours.rig import Rig, compact, robot_among
from tests.test_executive import Post


def test_it_turns_half_a_circle_in_the_open(rig: Rig) -> None:
    rig.map_around()
    spin = rig.build(Spin, angle_deg=180.0)
    statuses = rig.tick_until_done(spin, limit_s=20.0)
    rig.show(spin)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert abs(abs(rig.robot.base_pose().yaw_rad) - math.pi) < math.radians(4.0)
    assert rig.get("cmd_twist") == Twist.zero()


def test_it_fails_rather_than_sweep_the_rear_into_a_post(make_rig: Callable[..., Rig]) -> None:
    # A post 0.45 m to the robot's right-rear: the rear corners (0.41 m from the centre) would hit it.
    rig = make_rig(robot=robot_among(Post(1, -0.2, -0.5, "bin", None, radius_m=0.1)))
    rig.map_around(turns=16)
    assert rig.get("local_map").state_at((-0.2, -0.42)) == "lethal"
    spin = rig.build(Spin, angle_deg=-180.0)
    statuses = rig.tick_until_done(spin, limit_s=20.0)
    rig.show(spin)
    assert statuses[-1] == Status.FAILURE
    assert "sweep" in spin.feedback_message
    assert rig.get("cmd_twist") == Twist.zero()


def test_halting_it_commands_a_zero_twist(rig: Rig) -> None:
    rig.map_around()
    spin = rig.build(Spin)
    assert rig.tick(spin, ticks=3) == [Status.RUNNING] * 3
    assert rig.get("cmd_twist") != Twist.zero()
    rig.halt(spin)
    assert rig.get("cmd_twist") == Twist.zero()


def test_it_fails_rather_than_sweep_floor_it_has_never_seen(rig: Rig) -> None:
    # Away from the start (whose turning circle counts as free), having looked only straight ahead: the
    # floor beside the body was never observed, so the rear corners may not swing over it.
    rig.robot.place(Pose2D(3.0, 0.0, 0.0))
    rig.map_from(rig.robot.base_pose(), turns=1)
    spin = rig.build(Spin, angle_deg=90.0)
    statuses = rig.tick_until_done(spin, limit_s=20.0)
    rig.show(spin)
    assert statuses[-1] == Status.FAILURE
    assert "sweep" in spin.feedback_message
    assert rig.get("cmd_twist") == Twist.zero()
