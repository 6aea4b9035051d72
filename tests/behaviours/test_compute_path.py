"""ComputePathToSubgoal alone: a plan on the board, kept while nothing changes, replanned when the subgoal
changes; FAILURE with ``no_path`` at once for a walled-in subgoal."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from py_trees.common import Status

from behaviours.compute_path import ComputePathToSubgoal
from semexp_bt.core.types import Pose2D
from tests.behaviours.rig import FakeRobot, Rig, subgoal_at
from tests.test_nav_stack import walled_costmap


def test_a_plan_is_written_and_kept_while_nothing_changes(rig: Rig) -> None:
    rig.set("subgoal", subgoal_at(4.0, 0.0))
    compute = rig.build(ComputePathToSubgoal)
    assert rig.tick(compute, 5) == [Status.RUNNING] * 5
    rig.show(compute)
    plan = rig.get("global_plan")
    assert plan.ok and np.hypot(*(plan.path_xy[-1] - (4.0, 0.0))) <= 0.9
    assert rig.get("nav_failure") is None
    rig.tick(compute, 5)
    assert rig.get("global_plan") is plan  # no replan: same subgoal, same costmap, young plan
    rig.set("subgoal", subgoal_at(0.0, 3.0, node_id=8))
    rig.tick(compute)
    assert rig.get("global_plan") is not plan and rig.get("global_plan").goal_xy == (0.0, 3.0)
    assert rig.written_by(compute) == ["nav_failure", "global_plan"]


def test_a_walled_in_subgoal_fails_at_once_with_no_path(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=FakeRobot(start_pose=Pose2D(-2.0, 2.5, 0.0)))
    rig.set("local_map", walled_costmap(door=False))
    rig.set("subgoal", subgoal_at(2.0, 2.5))
    compute = rig.build(ComputePathToSubgoal)
    assert rig.tick(compute) == [Status.FAILURE]
    rig.show(compute)
    assert rig.get("nav_failure") == "no_path"
    assert rig.services.events[-1]["kind"] == "no_path"


def test_no_subgoal_is_a_failure(rig: Rig) -> None:
    compute = rig.build(ComputePathToSubgoal)
    assert rig.tick(compute) == [Status.FAILURE]
    rig.show(compute)
    assert compute.feedback_message == "no subgoal"
