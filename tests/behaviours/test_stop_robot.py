"""StopRobot alone: zero twist, robot.stop(), the outcome recorded; always SUCCESS."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from behaviours.stop_robot import StopRobot
from semexp_bt.core.types import Twist
from tests.behaviours.rig import Rig


@pytest.mark.parametrize("outcome", ["success", "failed", "returned"])
def test_it_stops_the_robot_and_records_the_outcome(rig: Rig, outcome: str) -> None:
    rig.robot.command_twist(Twist(linear_x_mps=0.4))
    stop = rig.build(StopRobot, outcome=outcome)
    assert rig.tick(stop, drive=False) == [Status.SUCCESS]
    rig.show(stop)
    assert rig.robot.stopped == 1 and rig.robot.base_twist() == Twist.zero()
    assert rig.get("cmd_twist") == Twist.zero()
    assert rig.get("cmd_stamp_s") == pytest.approx(0.0)
    assert rig.get("mission_outcome") == outcome
    assert rig.written_by(stop) == ["cmd_twist", "cmd_stamp_s", "mission_outcome"]


def test_the_default_outcome_is_success(rig: Rig) -> None:
    stop = rig.build(StopRobot)
    rig.tick(stop)
    rig.show(stop)
    assert rig.get("mission_outcome") == "success"
