"""ConfirmTarget alone: from the step's own arbitration, further views vote; k of n from close by succeed.

The first view is staged on the board as Perceive and Arbitrate would leave it; the further views come
from the rig's scripted perception, one script entry per view.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.confirm_target import ConfirmTarget
from tests.behaviours.rig import INSTRUCTION, Rig, compact, robot_among
from tests.test_executive import Post, seeing

TARGET = Post(1, 0.8, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")
SEES, BLIND = seeing([TARGET], directions=False), seeing([], directions=False)


def rig_before_the_target(make_rig: Callable[..., Rig], further_views: list[Callable[..., object]]) -> Rig:
    """The robot 0.8 m from the target (front surface 0.6 m away); its first view is on the board."""
    rig = make_rig(robot=robot_among(TARGET), script=further_views, latency_s=1.0)
    rig.get("memory").add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    rig.stage_view([TARGET])
    return rig


def test_three_further_votes_confirm_the_target(make_rig: Callable[..., Rig]) -> None:
    rig = rig_before_the_target(make_rig, [SEES])
    confirm = rig.build(ConfirmTarget)
    statuses = rig.tick_until_done(confirm)
    rig.show(confirm)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert len(rig.perception.requests) == 3
    (found,) = rig.get("found_objects")
    assert found["label"] == "fire extinguisher" and found["instruction"] == INSTRUCTION
    assert found["position_m"][0] == pytest.approx(0.6, abs=0.1)
    assert rig.written_by(confirm) == ["found_objects"]
    assert [e["kind"] for e in rig.services.events] == ["target_confirmed"]


def test_too_few_votes_fail_as_soon_as_three_cannot_be_reached(make_rig: Callable[..., Rig]) -> None:
    rig = rig_before_the_target(make_rig, [BLIND])
    confirm = rig.build(ConfirmTarget, extra_views=3, max_extra_views=4)
    statuses = rig.tick_until_done(confirm)
    rig.show(confirm)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert len(rig.perception.requests) == 2  # after two misses, two views cannot give three votes
    assert rig.get("found_objects") == []
    assert [e["kind"] for e in rig.services.events] == ["confirmation_rejected"]


def test_a_first_view_that_does_not_vote_fails_at_once_and_lowers_the_node_in_view(
    make_rig: Callable[..., Rig],
) -> None:
    rig = make_rig(robot=robot_among(TARGET))
    memory = rig.get("memory")
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    node = memory.update(position_m=(0.7, 0.0, 0.3), label="fire extinguisher", confidence=0.8, stamp_s=0.0)
    before = memory.node(node.node_id).potential
    rig.stage_view([])  # the target is there, but this view did not report it
    confirm = rig.build(ConfirmTarget, reject_potential_factor=0.5)
    assert rig.tick(confirm) == [Status.FAILURE]
    rig.show(confirm)
    assert confirm.feedback_message == "no confirmable target here"
    assert memory.node(node.node_id).potential == pytest.approx(0.5 * before)
    assert rig.perception.requests == []


def test_with_no_further_views_required_the_first_vote_confirms(make_rig: Callable[..., Rig]) -> None:
    rig = rig_before_the_target(make_rig, [BLIND])
    confirm = rig.build(ConfirmTarget, extra_views=0, max_extra_views=0)
    assert rig.tick(confirm) == [Status.SUCCESS]
    rig.show(confirm)
    assert len(rig.get("found_objects")) == 1


def test_more_views_required_than_allowed_is_refused_at_build_time(rig: Rig) -> None:
    with pytest.raises(ValueError, match=r"max_extra_views \(2\) must be at least extra_views \(3\)"):
        rig.build(ConfirmTarget, extra_views=3, max_extra_views=2)


def test_halting_it_cancels_the_pending_view(make_rig: Callable[..., Rig]) -> None:
    rig = rig_before_the_target(make_rig, [SEES])
    jobs = rig.record_jobs()
    confirm = rig.build(ConfirmTarget)
    assert rig.tick(confirm, ticks=3) == [Status.RUNNING] * 3
    rig.halt(confirm)
    assert len(jobs) == 1 and jobs[0].cancelled
    assert rig.get("found_objects") == []
