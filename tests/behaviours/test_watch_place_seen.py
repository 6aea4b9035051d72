"""WatchPlaceSeen alone: a place subgoal whose surroundings the costmap comes to see on the way is handed
back once per node; objects, places seen before the trip and places close by are walked to."""

from __future__ import annotations

from collections.abc import Callable

from py_trees.common import Status

from behaviours.update_memory import FRONTIER_LABEL
from behaviours.watch_place_seen import HAND_BACK_WHEN_SEEN, PLACES_SWITCH, WatchPlaceSeen
from semexp_bt.core.types import Pose2D, Subgoal
from tests.behaviours.rig import Rig, compact

#: Where the place (or object) subgoal lies: 4 m ahead of the robot, which faces +x from the origin.
AHEAD_M = (4.0, 0.0)


def subgoal_node(
    rig: Rig, label: str = FRONTIER_LABEL, at: tuple[float, float] = AHEAD_M, *, switched_on: bool = True
) -> Subgoal:
    """A memory node labelled ``label`` at ``at``, made the subgoal; a frontier's label counts as a place.
    With ``switched_on``, the strategy turns the hand-back on (it is off by default)."""
    if switched_on:
        rig.services.strategy = {PLACES_SWITCH: HAND_BACK_WHEN_SEEN}
    rig.services.place_labels.add(FRONTIER_LABEL)
    update = rig.get("memory").update(
        position_m=(at[0], at[1], 0.3), label=label, confidence=0.6, stamp_s=rig.robot.now_s()
    )
    assert update.node_id is not None
    subgoal = Subgoal(node_id=update.node_id, position_m=(at[0], at[1], 0.3), label=label, utility=0.1)
    rig.set("subgoal", subgoal)
    return subgoal


def walked_past(rig: Rig, watch: WatchPlaceSeen) -> list[Status]:
    """The statuses once the cameras have seen the place: one tick as the trip starts (the place unseen
    then), a full turn of depth frames into the costmap, ten ticks more; the tree printed."""
    rig.tick(watch, ticks=1)
    rig.map_around()
    statuses = rig.tick(watch, ticks=10)
    rig.show(watch)
    return statuses


def test_a_place_seen_on_the_way_hands_the_subgoal_back(rig: Rig) -> None:
    subgoal = subgoal_node(rig)
    watch = rig.build(WatchPlaceSeen)
    unseen = rig.tick(watch, ticks=10)
    rig.map_around()  # the cameras see the place's surroundings from 4 m
    statuses = unseen + rig.tick(watch, ticks=1)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert rig.get("nav_failure") == "explored"
    [event] = rig.services.events
    assert event["kind"] == "place_seen" and event["node_id"] == subgoal.node_id
    assert event["distance_m"] == 4.0
    assert rig.written_by(watch) == ["nav_failure"]


def test_a_node_hands_a_subgoal_back_only_once(rig: Rig) -> None:
    subgoal_node(rig)
    watch = rig.build(WatchPlaceSeen)
    rig.tick(watch, ticks=1)
    rig.map_around()
    assert rig.tick(watch, ticks=1) == [Status.FAILURE]
    rig.get("local_map").clear_around((4.0, 0.0), radius_m=2.0)  # unseen again, chosen again
    statuses = rig.tick(watch, ticks=1)  # restarted: the next execute to the same place
    rig.map_around()
    statuses += rig.tick(watch, ticks=10)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]


def test_a_place_seen_before_the_trip_began_is_walked_to(rig: Rig) -> None:
    subgoal_node(rig)
    rig.map_around()
    watch = rig.build(WatchPlaceSeen)
    statuses = rig.tick(watch, ticks=10)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert rig.get("nav_failure") is None


def test_an_object_subgoal_is_walked_to_however_well_it_is_seen(rig: Rig) -> None:
    subgoal_node(rig, label="fire extinguisher")
    watch = rig.build(WatchPlaceSeen)
    assert compact(walked_past(rig, watch)) == ["RUNNING"]
    assert rig.get("nav_failure") is None


def test_close_to_the_place_the_robot_walks_on_to_it(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig()
    subgoal_node(rig, at=(1.2, 0.0))
    watch = rig.build(WatchPlaceSeen, finish_within_m=1.5)
    assert compact(walked_past(rig, watch)) == ["RUNNING"]
    assert watch.feedback_message.endswith("1.2 m away")


def test_a_place_taken_over_by_the_object_on_the_way_is_walked_to(rig: Rig) -> None:
    subgoal = subgoal_node(rig)
    watch = rig.build(WatchPlaceSeen)
    rig.tick(watch, ticks=1)  # the trip starts for a place
    rig.get("memory").update(  # the detector boxed the instructed object there: it takes the place over
        position_m=subgoal.position_m,
        label="fire extinguisher",
        confidence=0.9,
        stamp_s=rig.robot.now_s(),
        takes_over=frozenset({FRONTIER_LABEL}),
    )
    assert compact(walked_past(rig, watch)) == ["RUNNING"]
    assert rig.get("memory").node(subgoal.node_id).label == "fire extinguisher"


def test_without_a_subgoal_it_runs(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig()
    rig.robot.place(Pose2D(1.0, 1.0, 0.0))
    watch = rig.build(WatchPlaceSeen)
    statuses = rig.tick(watch, ticks=5)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert watch.feedback_message == "no unseen place to watch"


def test_off_by_default_a_place_seen_on_the_way_is_walked_to(rig: Rig) -> None:
    subgoal_node(rig, switched_on=False)
    watch = rig.build(WatchPlaceSeen)
    assert compact(walked_past(rig, watch)) == ["RUNNING"]
    assert rig.get("nav_failure") is None
