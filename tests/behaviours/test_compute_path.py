"""ComputePathToSubgoal ticked alone: a plan on the board, replanning on change, no_path at once."""

import numpy as np
import py_trees

from behaviours.compute_path import ComputePathToSubgoal
from semexp_bt.core.types import Pose2D
from tests.behaviours.nav_rig import make_rig, subgoal_at
from tests.test_nav_stack import walled_costmap

S = py_trees.common.Status


def test_a_plan_is_written_and_kept_while_nothing_changes() -> None:
    rig = make_rig()
    rig.set("subgoal", subgoal_at(4.0, 0.0))
    node = rig.build(ComputePathToSubgoal)
    assert rig.tick(node, 5) == [S.RUNNING] * 5
    rig.show(node)
    plan = rig.get("global_plan")
    assert plan.ok and np.hypot(*(plan.path_xy[-1] - (4.0, 0.0))) <= 0.9
    assert rig.get("nav_failure") is None
    rig.tick(node, 5)
    assert rig.get("global_plan") is plan  # no replan: same subgoal, same costmap, young plan
    rig.set("subgoal", subgoal_at(0.0, 3.0, node_id=8))
    rig.tick(node)
    assert rig.get("global_plan") is not plan and rig.get("global_plan").goal_xy == (0.0, 3.0)


def test_a_walled_in_subgoal_fails_at_once_with_no_path() -> None:
    rig = make_rig(start=Pose2D(-2.0, 2.5, 0.0))
    rig.set("local_map", walled_costmap(door=False))
    rig.set("subgoal", subgoal_at(2.0, 2.5))
    node = rig.build(ComputePathToSubgoal)
    assert rig.tick(node) == [S.FAILURE]
    rig.show(node)
    assert rig.get("nav_failure") == "no_path"
    assert rig.services.events[-1]["kind"] == "no_path"
