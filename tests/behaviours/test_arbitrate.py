"""Arbitrate alone: Eq. 1-4 over the perception on the board; always SUCCESS, target or None."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.arbitrate import Arbitrate
from tests.behaviours.rig import Rig, robot_among
from tests.test_executive import Post


def rig_seeing(make_rig: Callable[..., Rig], post: Post | None, *, directions: bool = False) -> Rig:
    """A robot facing ``post`` 2 m ahead, with what perception said about its view already on the board."""
    rig = make_rig(robot=robot_among() if post is None else robot_among(post))
    rig.stage_view([] if post is None else [post], directions=directions, arbitrate=False)
    return rig


EXTINGUISHER = Post(1, 2.0, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")
RED_BOX = Post(1, 2.0, 0.0, vlm_label="red box", detector_label="red box")


def test_both_sources_naming_the_target_make_it_t_star(make_rig: Callable[..., Rig]) -> None:
    rig = rig_seeing(make_rig, EXTINGUISHER)
    arbitrate = rig.build(Arbitrate)
    assert rig.tick(arbitrate) == [Status.SUCCESS]
    rig.show(arbitrate)
    target = rig.get("target")
    assert target is not None and target.label == "fire extinguisher" and target.kind == "object"
    assert 0.0 < target.fused_confidence <= 1.0
    assert rig.get("arbitration").target == target
    assert rig.written_by(arbitrate) == ["arbitration", "target"]
    assert "arbitration" in rig.services.timings.samples


def test_nothing_seen_is_a_success_with_no_target(make_rig: Callable[..., Rig]) -> None:
    rig = rig_seeing(make_rig, None)
    arbitrate = rig.build(Arbitrate)
    assert rig.tick(arbitrate) == [Status.SUCCESS]
    rig.show(arbitrate)
    assert rig.get("target") is None and rig.get("arbitration").candidates == ()
    assert arbitrate.feedback_message.startswith("no target")


@pytest.mark.parametrize(("align_threshold", "target_label"), [(0.6, None), (0.0, "red box")])
def test_only_labels_aligned_with_the_instruction_compete(
    make_rig: Callable[..., Rig], align_threshold: float, target_label: str | None
) -> None:
    """A red box is not what 'find the fire extinguisher' asks for, unless every label counts as aligned."""
    rig = rig_seeing(make_rig, RED_BOX)
    arbitrate = rig.build(Arbitrate, align_threshold=align_threshold)
    assert rig.tick(arbitrate) == [Status.SUCCESS]
    rig.show(arbitrate)
    target = rig.get("target")
    assert (None if target is None else target.label) == target_label


def test_an_unexplored_direction_is_a_target_when_no_object_is(make_rig: Callable[..., Rig]) -> None:
    rig = rig_seeing(make_rig, None, directions=True)
    arbitrate = rig.build(Arbitrate)
    assert rig.tick(arbitrate) == [Status.SUCCESS]
    rig.show(arbitrate)
    assert rig.get("target").kind == "direction"
