"""UpdateCostmap alone: one depth frame per tick into the costmap on the board (SUCCESS); FAILURE without
a costmap."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np
from py_trees.common import Status

from behaviours.update_costmap import UpdateCostmap
from robots.mount import rotation_from_rpy
from semexp_bt.core.types import Observation, PixelGrid, Pose2D
from tests.behaviours.rig import FakeRobot, Rig, robot_among
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


class LeftLookingTwin(FakeRobot):
    """A robot with one side camera: the head camera's frame again, taken looking 90 degrees left."""

    def observe_side_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> list[Observation]:
        head = self.observe_depth(pixel_grids=pixel_grids)
        to_left = np.eye(4)
        to_left[:3, :3] = rotation_from_rpy(0.0, 0.0, np.pi / 2)
        camera_to_world = head.camera_to_world.copy()
        camera_to_world[:3, :3] = to_left[:3, :3] @ head.camera_to_world[:3, :3]
        return [dataclasses.replace(head, camera_to_world=camera_to_world)]


def test_the_side_cameras_frames_are_integrated_too(make_rig: Callable[..., Rig]) -> None:
    twin = LeftLookingTwin(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 2.0, 0.0, 0.2, 0.6),))
    rig = make_rig(robot=twin)
    update = rig.build(UpdateCostmap)
    assert rig.tick(update) == [Status.SUCCESS]
    rig.show(update)
    costmap = rig.get("local_map")
    assert costmap.frames == 1, "the head's and the side camera's frames are one update"
    # The post ahead, and its image in the frame that claims to look left, both marked.
    assert costmap.state_at((1.82, 0.0)) == "lethal" and costmap.state_at((0.0, 1.82)) == "lethal"
    assert "from 2 cameras" in update.feedback_message
