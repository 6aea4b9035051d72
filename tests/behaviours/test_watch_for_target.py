"""WatchForTarget alone: views on the move every period; the instructed object sighted away from the subgoal
hands the subgoal back once per node; anything else goes on."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.decide import PRIVILEGED_GOAL_NODE_ID
from behaviours.watch_for_target import WatchForTarget
from semexp_bt.core.memory import MemoryUpdate, TopologicalMemory
from semexp_bt.core.types import Pose2D, Twist
from tests.behaviours.rig import Rig, compact, robot_among, subgoal_at
from tests.test_executive import Post, seeing

#: The instructed object, 3 m ahead of the robot (which faces +x from the origin).
EXTINGUISHER = Post(1, 3.0, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")
#: A box the detector does not box and the VLM calls a box.
BOX = Post(2, 3.0, 0.0, vlm_label="cardboard box", detector_label=None)


def walking_rig(make_rig: Callable[..., Rig], seen: Post, **kwargs: object) -> Rig:
    rig = make_rig(
        robot=robot_among(seen), script=[seeing([seen], directions=False)], latency_s=1.0, **kwargs
    )
    rig.robot.command_twist(Twist(linear_x_mps=0.1))  # on its way, slowly (the rig drives no cmd_twist here)
    return rig


def _nodes_labelled(rig: Rig, label: str) -> list[tuple[float, float]]:
    memory = rig.get("memory")
    return [
        (memory.node(n).position_m[0], memory.node(n).position_m[1])
        for n in memory.graph
        if memory.node(n).label == label
    ]


def test_the_instructed_object_seen_on_the_way_hands_the_subgoal_back(make_rig: Callable[..., Rig]) -> None:
    rig = walking_rig(make_rig, EXTINGUISHER)
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    statuses = rig.tick_until_done(watch, limit_s=10.0)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    # One view, 2 s after the start, answered 1 s later.
    assert [round(stamp, 2) for stamp, _ in rig.perception.requests] == [2.0]
    assert rig.robot.now_s() == pytest.approx(3.02, abs=0.021)
    assert rig.get("nav_failure") == "superseded"
    [(x, y)] = _nodes_labelled(rig, "fire extinguisher")
    assert math.hypot(x - 3.0, y) < 0.5  # on the object (its surface seen from 2.8 m away)
    [event] = [e for e in rig.services.events if e["kind"] == "target_sighted"]
    assert event["label"] == "fire extinguisher"
    assert rig.written_by(watch) == ["nav_failure"]  # the memory is changed in place


def test_a_node_hands_a_subgoal_back_only_once(make_rig: Callable[..., Rig]) -> None:
    rig = walking_rig(make_rig, EXTINGUISHER)
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    assert rig.tick_until_done(watch, limit_s=10.0)[-1] == Status.FAILURE
    statuses = rig.tick(watch, ticks=500)  # restarted (the next execute): 10 s, four more views of it
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert len(rig.perception.requests) == 1 + 4
    assert len(_nodes_labelled(rig, "fire extinguisher")) == 1  # the same node, merged into


def test_the_object_at_the_subgoal_itself_is_no_reason_to_stop(make_rig: Callable[..., Rig]) -> None:
    rig = walking_rig(make_rig, EXTINGUISHER)
    rig.set("subgoal", subgoal_at(3.2, 0.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    statuses = rig.tick(watch, ticks=250)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert rig.get("nav_failure") is None
    assert len(_nodes_labelled(rig, "fire extinguisher")) == 1  # still remembered


def test_a_privileged_subgoal_is_never_handed_back(make_rig: Callable[..., Rig]) -> None:
    # oracle_nav walks to the true goal; the same sighting that hands an exploration subgoal back
    # (the first test) leaves it alone, and still enters the memory.
    rig = walking_rig(make_rig, EXTINGUISHER)
    rig.set("subgoal", subgoal_at(0.0, 5.0, node_id=PRIVILEGED_GOAL_NODE_ID))
    watch = rig.build(WatchForTarget, period_s=2.0)
    statuses = rig.tick(watch, ticks=250)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert rig.get("nav_failure") is None
    assert len(_nodes_labelled(rig, "fire extinguisher")) == 1


def test_other_objects_leave_the_memory_and_the_subgoal_alone(make_rig: Callable[..., Rig]) -> None:
    rig = walking_rig(make_rig, BOX)
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    size = len(rig.get("memory"))
    statuses = rig.tick(watch, ticks=250)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert len(rig.perception.requests) == 2
    assert len(rig.get("memory")) == size
    assert rig.get("nav_failure") is None


def test_a_view_behind_the_robot_is_placed_by_its_own_camera_pose(make_rig: Callable[..., Rig]) -> None:
    """The reply arrives after the robot has turned away: the object is placed from the frame's pose."""
    rig = make_rig(
        robot=robot_among(EXTINGUISHER), script=[seeing([EXTINGUISHER], directions=False)], latency_s=1.0
    )
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    rig.tick(watch, ticks=101)  # the view is taken at 2.0 s
    rig.robot.place(Pose2D(0.0, 0.0, math.pi))  # then the robot faces away
    assert rig.tick_until_done(watch)[-1] == Status.FAILURE
    [(x, y)] = _nodes_labelled(rig, "fire extinguisher")
    assert math.hypot(x - 3.0, y) < 0.5


def test_halting_it_cancels_the_pending_request(make_rig: Callable[..., Rig]) -> None:
    rig = walking_rig(make_rig, EXTINGUISHER)
    jobs = rig.record_jobs()
    watch = rig.build(WatchForTarget, period_s=2.0)
    rig.tick(watch, ticks=110)
    assert len(jobs) == 1
    rig.halt(watch)
    assert jobs[0].cancelled
    assert rig.get("nav_failure") is None


def test_the_papers_stop_and_perceive_takes_no_views(make_rig: Callable[..., Rig]) -> None:
    rig = walking_rig(make_rig, EXTINGUISHER)
    rig.services.strategy = {"perception": "stop_and_perceive"}
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    statuses = rig.tick(watch, ticks=250)
    rig.show(watch)
    assert compact(statuses) == ["RUNNING"]
    assert rig.perception.requests == []
    assert _nodes_labelled(rig, "fire extinguisher") == []


def _walking_past_a_place(
    make_rig: Callable[..., Rig], post: Post
) -> tuple[Rig, TopologicalMemory, MemoryUpdate]:
    """A rig walking past ``post``, and the memory's node for a frontier-like place the VLM named at full
    confidence where the object turns out to stand: (rig, memory, the place's update)."""
    rig = walking_rig(make_rig, post)
    memory = rig.get("memory")
    memory.add_master(position_m=(-3.0, 0.0, 0.0), stamp_s=0.0)
    rig.services.place_labels.add("unexplored area")
    place = memory.update(position_m=(2.6, 0.0, 0.3), label="unexplored area", confidence=1.0, stamp_s=0.0)
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    return rig, memory, place


def test_the_object_seen_on_a_place_takes_its_node_over(make_rig: Callable[..., Rig]) -> None:
    rig, memory, place = _walking_past_a_place(make_rig, EXTINGUISHER)
    watch = rig.build(WatchForTarget, period_s=2.0)
    assert rig.tick_until_done(watch, limit_s=10.0)[-1] == Status.FAILURE
    rig.show(watch)
    assert memory.node(place.node_id).label == "fire extinguisher"
    assert _nodes_labelled(rig, "unexplored area") == []
    [event] = [e for e in rig.services.events if e["kind"] == "target_sighted"]
    assert event["node_id"] == place.node_id


def test_the_vlm_alone_seen_on_a_place_does_not_take_it_over(make_rig: Callable[..., Rig]) -> None:
    named_only = Post(1, 3.0, 0.0, vlm_label="fire extinguisher", detector_label=None)
    rig, memory, place = _walking_past_a_place(make_rig, named_only)
    watch = rig.build(WatchForTarget, period_s=2.0, min_score=0.0)
    rig.tick(watch, ticks=200)
    rig.show(watch)
    assert memory.graph.nodes[place.node_id]["observations"] >= 2  # the VLM's evidence merged into it
    assert memory.node(place.node_id).label == "unexplored area"


def test_the_object_seen_under_another_name_enters_under_the_instructions_words(
    make_rig: Callable[..., Rig],
) -> None:
    robot_dog = Post(1, 3.0, 0.0, vlm_label="robot dog", detector_label="robot dog")
    rig = walking_rig(make_rig, robot_dog, instructions=("find the quadruped robot",))
    rig.set("subgoal", subgoal_at(0.0, 5.0))
    watch = rig.build(WatchForTarget, period_s=2.0)
    assert rig.tick_until_done(watch, limit_s=10.0)[-1] == Status.FAILURE
    rig.show(watch)
    assert _nodes_labelled(rig, "robot dog") == []
    [(x, y)] = _nodes_labelled(rig, "quadruped robot")
    assert math.hypot(x - 3.0, y) < 0.5
