"""SeedMasterNode alone: the master node v_m at the robot's position, SUCCESS."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.seed_master_node import SeedMasterNode
from semexp_bt.core.types import InvalidInputError, Pose2D
from tests.behaviours.rig import FakeRobot, Rig


def test_it_puts_the_master_node_where_the_robot_stands(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(1.5, -2.0, math.pi / 2)))
    seed = rig.build(SeedMasterNode)
    assert rig.tick(seed) == [Status.SUCCESS]
    rig.show(seed)
    memory = rig.get("memory")
    (master,) = memory.nodes()
    assert master.is_master and master.position_m == (1.5, -2.0, 0.0)
    assert memory.master_id == master.node_id
    assert rig.written_by(seed) == []  # the memory on the board is changed in place


def test_a_second_master_is_refused_by_the_memory(rig: Rig) -> None:
    seed = rig.build(SeedMasterNode)
    rig.tick(seed)
    with pytest.raises(InvalidInputError, match="already has a master"):
        rig.tick(seed)
    rig.show(seed)
