"""LowerSubgoalPotential alone: the subgoal's node loses potential (all of it when no plan reached it) and
the subgoal is cleared; SUCCESS."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from behaviours.lower_subgoal_potential import LowerSubgoalPotential
from semexp_bt.core.types import Subgoal
from tests.behaviours.rig import Rig


@pytest.mark.parametrize(
    ("failure", "scale", "kind"),
    [
        (None, 0.25, "subgoal_demoted"),
        ("blocked", 0.25, "subgoal_demoted"),
        ("no_path", 0.0, "subgoal_unreachable"),
    ],
)
def test_the_subgoal_node_is_demoted_and_the_subgoal_cleared(
    rig: Rig, failure: str | None, scale: float, kind: str
) -> None:
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    node = memory.update(position_m=(3.0, 0.0, 0.3), label="doorway", confidence=0.8, stamp_s=0.0).node_id
    before = memory.node(node).potential
    rig.set("subgoal", Subgoal(node_id=node, position_m=(3.0, 0.0, 0.3), label="doorway", utility=0.5))
    rig.set("nav_failure", failure)
    demote = rig.build(LowerSubgoalPotential, factor=0.25)
    assert rig.tick(demote) == [Status.SUCCESS]
    rig.show(demote)
    assert memory.node(node).potential == pytest.approx(scale * before)
    assert rig.get("subgoal") is None
    assert rig.written_by(demote) == ["subgoal"]
    assert [(e["kind"], e["node_id"]) for e in rig.services.events] == [(kind, node)]


@pytest.mark.parametrize("subgoal_node", [None, 99], ids=["no-subgoal", "node-gone"])
def test_with_nothing_to_demote_it_succeeds_and_changes_nothing(rig: Rig, subgoal_node: int | None) -> None:
    memory = rig.get("memory")
    master = memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    if subgoal_node is not None:
        rig.set("subgoal", Subgoal(node_id=subgoal_node, position_m=(1.0, 0.0, 0.0), label="x", utility=0.1))
    demote = rig.build(LowerSubgoalPotential)
    assert rig.tick(demote) == [Status.SUCCESS]
    rig.show(demote)
    assert demote.feedback_message == "no subgoal to demote"
    assert memory.node(master).potential == 0.0 and rig.services.events == []
    assert rig.written_by(demote) == []
