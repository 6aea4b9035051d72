"""UpdateMemory alone: the arbitrated evidence on the board grows the memory (Eq. 5-7); always SUCCESS."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.update_memory import FRONTIER_LABEL, UpdateMemory
from semexp_bt.core.types import Subgoal
from tests.behaviours.rig import Rig, robot_among
from tests.test_executive import Post

EXTINGUISHER = Post(1, 2.0, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")


def test_the_target_seen_becomes_a_node_on_its_surface(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=robot_among(EXTINGUISHER))
    rig.get("memory").add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    rig.stage_view([EXTINGUISHER])
    update = rig.build(UpdateMemory)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    memory = rig.get("memory")
    (node,) = [n for n in memory.nodes() if n.label == "fire extinguisher"]
    assert (
        node.position_m[0] == pytest.approx(1.8, abs=0.1) and abs(node.position_m[1]) < 0.1
    )  # front surface
    assert node.confidence == pytest.approx(rig.get("target").fused_confidence, abs=1e-6)
    assert FRONTIER_LABEL in rig.services.place_labels
    assert rig.written_by(update) == []  # the memory on the board is changed in place
    assert "memory_update" in rig.services.timings.samples


def test_the_target_seen_on_a_place_takes_its_node_over(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=robot_among(EXTINGUISHER))
    memory = rig.get("memory")
    memory.add_master(position_m=(-3.0, 0.0, 0.0), stamp_s=0.0)
    # An unexplored direction the VLM named, at full confidence, 0.4 m short of the extinguisher's surface.
    rig.services.place_labels.add("unexplored area ahead")
    place = memory.update(
        position_m=(1.4, 0.0, 0.3), label="unexplored area ahead", confidence=1.0, stamp_s=0.0
    )
    rig.stage_view([EXTINGUISHER])
    update = rig.build(UpdateMemory, offer_frontiers=False, map_frontier_confidence=0.0)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    node = memory.node(place.node_id)
    # The detection (a box and the VLM's proposal, fused) is weaker than the place, yet the node is now the
    # extinguisher's; it stepped towards the surface (1.8 m) as any merge does.
    assert rig.get("arbitration").winner.source == "fused"
    assert node.label == "fire extinguisher"
    assert node.confidence == pytest.approx(rig.get("target").fused_confidence, abs=1e-6)
    assert 1.4 < node.position_m[0] < 1.8
    assert not [n for n in memory.nodes() if n.label == "unexplored area ahead"]


def test_one_object_named_two_ways_is_one_node_under_the_instructions_words(
    make_rig: Callable[..., Rig],
) -> None:
    # The detector labels its box with the instruction's words, the VLM names the same object in its own.
    robot_dog = Post(1, 2.0, 0.0, vlm_label="quadruped robot", detector_label="robot dog")
    for wording in ("find the robot dog", "find the quadruped robot"):
        rig = make_rig(robot=robot_among(robot_dog), instructions=(wording,))
        rig.get("memory").add_master(position_m=(-3.0, 0.0, 0.0), stamp_s=0.0)
        rig.stage_view([robot_dog])
        update = rig.build(UpdateMemory, offer_frontiers=False, map_frontier_confidence=0.0)
        assert rig.tick(update) == [Status.SUCCESS]
        rig.show(update)
        objects = [n for n in rig.get("memory").nodes() if not n.is_master]
        assert [n.label for n in objects] == [rig.get("target_label")], wording


def test_the_vlm_alone_does_not_take_a_place_over(make_rig: Callable[..., Rig]) -> None:
    named_only = Post(1, 2.0, 0.0, vlm_label="fire extinguisher", detector_label=None)
    rig = make_rig(robot=robot_among(named_only))
    memory = rig.get("memory")
    memory.add_master(position_m=(-3.0, 0.0, 0.0), stamp_s=0.0)
    rig.services.place_labels.add("unexplored area ahead")
    place = memory.update(
        position_m=(1.4, 0.0, 0.3), label="unexplored area ahead", confidence=1.0, stamp_s=0.0
    )
    rig.stage_view([named_only])
    update = rig.build(UpdateMemory, offer_frontiers=False, map_frontier_confidence=0.0)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    assert rig.get("arbitration").winner.source == "scene"
    # It merged (the evidence reached the node) and left the place a place.
    assert memory.graph.nodes[place.node_id]["observations"] == 2
    assert memory.node(place.node_id).label == "unexplored area ahead"


def test_unexplored_directions_become_place_nodes_short_of_the_surface(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig()
    rig.get("memory").add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    rig.stage_view([], directions=True)
    update = rig.build(UpdateMemory, direction_range_m=3.0, offer_frontiers=False)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    places = [n for n in rig.get("memory").nodes() if n.label.startswith("open area")]
    assert places, update.feedback_message
    for place in places:
        assert 0.5 <= math.hypot(*place.position_m[:2]) <= 3.0 + 0.1
    assert {p.label for p in places} <= rig.services.place_labels


@pytest.mark.parametrize(("offer_frontiers", "grows"), [(True, True), (False, False)])
def test_open_depth_directions_are_offered_as_frontiers_only_when_asked(
    rig: Rig, offer_frontiers: bool, grows: bool
) -> None:
    rig.get("memory").add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    rig.stage_view([])  # an empty floor: open in every column
    update = rig.build(UpdateMemory, offer_frontiers=offer_frontiers, map_frontier_confidence=0.0)
    rig.tick(update)
    rig.show(update)
    frontiers = [n for n in rig.get("memory").nodes() if n.label == FRONTIER_LABEL]
    assert bool(frontiers) == grows


def test_without_an_observation_it_only_marks_the_subgoal_visited(rig: Rig) -> None:
    memory = rig.get("memory")
    memory.add_master(position_m=(-3.0, 0.0, 0.0), stamp_s=0.0)
    node = memory.update(position_m=(0.5, 0.0, 0.3), label="doorway", confidence=0.8, stamp_s=0.0).node_id
    rig.set("subgoal", Subgoal(node_id=node, position_m=(0.5, 0.0, 0.3), label="doorway", utility=0.5))
    update = rig.build(UpdateMemory)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    assert len(memory) == 2
    assert memory.node(node).visits == 1


@pytest.mark.parametrize(
    ("seen", "enters"),
    [
        (EXTINGUISHER, True),  # boxed by the detector and named: it enters
        (Post(1, 2.0, 0.0, vlm_label="fire extinguisher", detector_label=None), False),  # the VLM alone
    ],
)
def test_a_glance_aside_adds_only_the_boxed_instructed_object_and_leaves_the_rest(
    make_rig: Callable[..., Rig], seen: Post, enters: bool
) -> None:
    rig = make_rig(robot=robot_among(seen))
    memory = rig.get("memory")
    memory.add_master(position_m=(-3.0, 0.0, 0.0), stamp_s=0.0)
    near = memory.update(position_m=(0.5, 0.0, 0.3), label="doorway", confidence=0.8, stamp_s=0.0).node_id
    rig.set("subgoal", Subgoal(node_id=near, position_m=(0.5, 0.0, 0.3), label="doorway", utility=0.5))
    rig.stage_view([seen], directions=True)
    update = rig.build(UpdateMemory, instructed_only=True)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    labels = [n.label for n in memory.nodes()]
    assert ("fire extinguisher" in labels) == enters
    assert not [label for label in labels if label.startswith("open area") or label == FRONTIER_LABEL]
    # The step's own view already decayed the surroundings and counted the visit: a glance does neither.
    assert memory.node(near).potential == pytest.approx(0.8) and memory.node(near).visits == 0
