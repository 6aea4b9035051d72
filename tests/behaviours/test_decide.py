"""Decide alone: the greedy Eq. 9 argmax becomes the subgoal (SUCCESS); nothing to choose is FAILURE."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from py_trees.common import Status

from behaviours.decide import Decide
from robots.go1 import go1_footprint
from semexp_bt.nav.costmap import Costmap, CostmapConfig
from tests.behaviours.rig import Rig


def test_the_most_useful_node_becomes_the_subgoal(rig: Rig) -> None:
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    target = memory.update(position_m=(4.0, 1.0, 0.5), label="fire extinguisher", confidence=0.8, stamp_s=0.0)
    memory.update(position_m=(2.0, -1.0, 0.3), label="unexplored area", confidence=0.6, stamp_s=0.0)
    decide = rig.build(Decide)
    assert rig.tick(decide) == [Status.SUCCESS]
    rig.show(decide)
    subgoal = rig.get("subgoal")
    assert subgoal.node_id == target.node_id and subgoal.label == "fire extinguisher"
    decision = rig.get("decision")
    assert decision.subgoal == subgoal and len(decision.candidates) == 2
    assert max(c.utility for c in decision.candidates) == subgoal.utility
    assert rig.written_by(decide) == ["decision", "subgoal"]
    (entry,) = rig.services.decision_log
    assert entry["selected_node_id"] == target.node_id and len(entry["candidates"]) == 2


def test_an_empty_candidate_set_fails_and_clears_the_subgoal(rig: Rig) -> None:
    rig.get("memory").add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)  # the master is no candidate
    decide = rig.build(Decide, relax_when_exhausted=False)
    assert rig.tick(decide) == [Status.FAILURE]
    rig.show(decide)
    assert rig.get("subgoal") is None and rig.get("decision").subgoal is None
    assert decide.feedback_message == "no subgoal: empty candidate set"
    assert rig.written_by(decide) == ["decision", "subgoal"]


@pytest.mark.parametrize(("relax", "status"), [(True, Status.SUCCESS), (False, Status.FAILURE)])
def test_when_every_potential_decayed_a_never_reached_node_may_be_chosen_once(
    rig: Rig, relax: bool, status: Status
) -> None:
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    glimpsed = memory.update(position_m=(3.0, 1.0, 0.3), label="unexplored area", confidence=0.6, stamp_s=0.0)
    memory.scale_potential(node_id=glimpsed.node_id, factor=0.1)  # under tau_p
    decide = rig.build(Decide, relax_when_exhausted=relax)
    statuses = rig.tick(decide, ticks=2)
    rig.show(decide)
    assert statuses[0] == status
    assert statuses[1] == Status.FAILURE  # never the same relaxed choice twice
    if relax:
        assert rig.services.decision_log[0]["reason"].startswith("relaxed: ")
        assert rig.services.decision_log[0]["selected_node_id"] == glimpsed.node_id


@pytest.mark.parametrize(("travel_cost", "chosen"), [("graph", "behind the wall"), ("costmap", "this side")])
def test_the_travel_cost_on_the_costmap_goes_round_the_wall(rig: Rig, travel_cost: str, chosen: str) -> None:
    """Two equal nodes: one 2 m away behind a wall whose gap is 4 m off, one 3 m away on the robot's side."""
    occupied = np.zeros((200, 200), dtype=bool)  # 10 m x 10 m, known, centred on the robot
    occupied[0:180, 118:120] = True  # a wall at x = 0.9-1.0 m, open only beyond y = 4 m
    costmap = Costmap(CostmapConfig(), footprint=go1_footprint(), origin_xy=(0.0, 0.0))
    costmap.set_known(occupied, lower_left_xy=(-5.0, -5.0), resolution_m=0.05)
    rig.set("local_map", costmap)
    config = rig.services.config
    rig.services.config = dataclasses.replace(
        config, decision=dataclasses.replace(config.decision, travel_cost=travel_cost)
    )
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    nodes = {
        "behind the wall": memory.update(position_m=(2.0, 0.0, 0.5), label="fire extinguisher", confidence=0.8, stamp_s=0.0),
        "this side": memory.update(position_m=(-3.0, 0.0, 0.5), label="fire extinguisher", confidence=0.8, stamp_s=0.0),
    }  # fmt: skip
    decide = rig.build(Decide)
    assert rig.tick(decide) == [Status.SUCCESS]
    rig.show(decide)
    assert rig.get("subgoal").node_id == nodes[chosen].node_id
    costs = {c["node_id"]: c["travel_cost_m"] for c in rig.services.decision_log[0]["candidates"]}
    if travel_cost == "costmap":
        assert costs[nodes["behind the wall"].node_id] > 2 * 4.0 - 1.0  # up past the wall's end and back
