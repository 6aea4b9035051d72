"""ClearCostmapAroundRobot alone: the ring around the robot is forgotten, the inside kept; SUCCESS; FAILURE without a costmap."""

from __future__ import annotations

from collections.abc import Callable

from py_trees.common import Status

from behaviours.clear_costmap import ClearCostmapAroundRobot
from tests.behaviours.rig import Rig, robot_among
from tests.test_executive import Post


def test_the_ring_is_forgotten_and_the_cells_under_the_robot_kept(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(robot=robot_among(Post(1, 2.0, 0.0, "chair", None)))
    rig.map_around()
    costmap = rig.get("local_map")
    assert costmap.state_at((1.82, 0.0)) == "lethal"
    clear = rig.build(ClearCostmapAroundRobot, radius_m=3.0, keep_radius_m=0.8)
    assert rig.tick(clear) == [Status.SUCCESS]
    rig.show(clear)
    assert costmap.state_at((1.82, 0.0)) == "unknown" and costmap.state_at((0.0, 0.0)) == "free"
    assert rig.services.events[-1]["kind"] == "costmap_cleared"
    assert rig.written_by(clear) == []  # the costmap object changes in place


def test_without_a_costmap_it_fails(rig: Rig) -> None:
    rig.set("local_map", None)
    clear = rig.build(ClearCostmapAroundRobot)
    assert rig.tick(clear) == [Status.FAILURE]
    rig.show(clear)
    assert clear.feedback_message == "no costmap on the board" and rig.services.events == []
