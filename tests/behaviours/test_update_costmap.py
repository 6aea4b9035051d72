"""UpdateCostmap alone: one depth frame per tick into the costmap on the board (SUCCESS); FAILURE without
a costmap."""

from __future__ import annotations

from collections.abc import Callable

from py_trees.common import Status

from behaviours.update_costmap import UpdateCostmap
from tests.behaviours.rig import Rig, robot_among
from tests.test_executive import Post


def test_each_tick_adds_one_frame_and_marks_what_the_camera_sees(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=robot_among(Post(1, 2.0, 0.0, "chair", None)))
    update = rig.build(UpdateCostmap)
    assert rig.tick(update, 3) == [Status.SUCCESS] * 3
    rig.show(update)
    costmap = rig.get("local_map")
    assert costmap.frames == 3
    assert costmap.state_at((1.82, 0.0)) == "lethal" and costmap.state_at((1.0, 0.0)) == "free"
    assert "marked" in update.feedback_message


def test_no_costmap_is_a_failure(rig: Rig) -> None:
    rig.set("local_map", None)
    update = rig.build(UpdateCostmap)
    assert rig.tick(update) == [Status.FAILURE]
    rig.show(update)
    assert update.feedback_message == "no costmap on the board"
