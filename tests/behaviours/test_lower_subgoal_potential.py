"""LowerSubgoalPotential ticked alone: demote, or mark unreachable when no plan reached the subgoal."""

import py_trees
import pytest

from behaviours.lower_subgoal_potential import LowerSubgoalPotential
from semexp_bt.core.types import Subgoal
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


@pytest.mark.parametrize(("failure", "expected", "kind"), [("blocked", 0.2, "subgoal_demoted"),
                                                          ("no_path", 0.0, "subgoal_unreachable")])  # fmt: skip
def test_the_node_loses_its_pull_and_the_subgoal_is_cleared(failure: str, expected: float, kind: str) -> None:
    rig = make_rig()
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    update = memory.update(position_m=(3.0, 0.0, 0.3), label="unexplored area", confidence=0.8, stamp_s=0.0)
    rig.set("subgoal", Subgoal(update.node_id, (3.0, 0.0, 0.3), "unexplored area", 1.0))
    rig.set("nav_failure", failure)
    node = rig.build(LowerSubgoalPotential, factor=0.25)
    assert rig.tick(node) == [S.SUCCESS]
    rig.show(node)
    assert memory.node(update.node_id).potential == pytest.approx(0.8 * (0.25 if expected else 0.0))
    assert rig.get("subgoal") is None
    assert rig.services.events[-1]["kind"] == kind
