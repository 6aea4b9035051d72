"""CloserStandpoint alone: a near miss becomes a subgoal at the voted point, once per spot; no near miss,
no subgoal."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.closer_standpoint import CloserStandpoint
from semexp_bt.core.types import CloserLook, Subgoal
from tests.behaviours.rig import Rig

SHELTER = CloserLook(label="bus shelter", position_m=(1.2, 0.0, 0.4), distance_m=1.2)


def rig_with_the_shelter_node(rig: Rig) -> int:
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    return memory.update(position_m=(1.5, 0.2, 0.5), label="bus shelter", confidence=0.8, stamp_s=1.0).node_id


def test_a_near_miss_becomes_a_subgoal_at_the_voted_point(rig: Rig) -> None:
    node = rig_with_the_shelter_node(rig)
    rig.set("closer_look", SHELTER)
    look = rig.build(CloserStandpoint)
    assert rig.tick(look) == [Status.SUCCESS]
    rig.show(look)
    assert rig.get("subgoal") == Subgoal(
        node_id=node, position_m=(1.2, 0.0, 0.4), label="bus shelter", utility=1.0
    )
    assert rig.get("closer_look") is None
    assert rig.written_by(look) == ["closer_look", "subgoal"]
    [event] = rig.services.events
    assert event["kind"] == "closer_look" and event["distance_m"] == 1.2


def test_without_a_near_miss_it_fails_and_writes_nothing(rig: Rig) -> None:
    rig_with_the_shelter_node(rig)
    look = rig.build(CloserStandpoint)
    assert rig.tick(look) == [Status.FAILURE]
    rig.show(look)
    assert rig.get("subgoal") is None and rig.written_by(look) == []


def test_a_spot_gets_one_closer_look_and_its_next_near_miss_is_dropped(rig: Rig) -> None:
    rig_with_the_shelter_node(rig)
    look = rig.build(CloserStandpoint)
    rig.set("closer_look", SHELTER)
    assert rig.tick(look) == [Status.SUCCESS]
    rig.set("subgoal", None)
    rig.set("closer_look", CloserLook(label="bus shelter", position_m=(1.5, 0.3, 0.4), distance_m=1.1))
    assert rig.tick(look) == [Status.FAILURE]  # 0.42 m from the first: the same spot
    rig.show(look)
    assert rig.get("subgoal") is None and rig.get("closer_look") is None
    elsewhere = CloserLook(label="bus shelter", position_m=(1.2, 0.0, 0.4), distance_m=1.2)
    two_looks = rig.build(CloserStandpoint, name="TwoLooks", looks_per_spot=2)
    rig.set("closer_look", elsewhere)
    assert rig.tick(two_looks) == [Status.SUCCESS]


def test_a_near_miss_far_from_every_node_fails(rig: Rig) -> None:
    rig_with_the_shelter_node(rig)
    rig.set("closer_look", CloserLook(label="bus shelter", position_m=(4.0, 3.0, 0.4), distance_m=1.2))
    look = rig.build(CloserStandpoint)
    assert rig.tick(look) == [Status.FAILURE]
    rig.show(look)
    assert rig.get("subgoal") is None and rig.get("closer_look") is None
