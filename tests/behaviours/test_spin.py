"""Spin ticked alone: turns by the angle when the footprint can, stops before sweeping into a post."""

import math

import py_trees

from behaviours.spin import Spin
from semexp_bt.core.types import Pose2D
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


def test_it_turns_half_a_circle_in_the_open() -> None:
    rig = make_rig()
    rig.map_around()
    node = rig.build(Spin, angle_deg=180.0)
    statuses = rig.tick_until_done(node, limit_s=20.0)
    rig.show(node)
    assert statuses[-1] == S.SUCCESS
    assert abs(abs(rig.robot.base_pose().yaw_rad) - math.pi) < math.radians(4.0)


def test_it_fails_rather_than_sweep_the_rear_into_a_post() -> None:
    # A post 0.45 m to the robot's right-rear: the rear corners (0.41 m from the centre) would hit it.
    rig = make_rig(start=Pose2D(0.0, 0.0, 0.0), posts=((1, -0.2, -0.5, 0.1, 0.6),))
    rig.map_around(turns=16)
    assert rig.get("local_map").state_at((-0.2, -0.42)) == "lethal"
    node = rig.build(Spin, angle_deg=-180.0)
    statuses = rig.tick_until_done(node, limit_s=20.0)
    rig.show(node)
    assert statuses[-1] == S.FAILURE
    assert "sweep" in node.feedback_message
