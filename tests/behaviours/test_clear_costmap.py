"""ClearCostmapAroundRobot ticked alone: the ring around the robot is forgotten, the inside kept."""

import py_trees

from behaviours.clear_costmap import ClearCostmapAroundRobot
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


def test_the_ring_is_forgotten_and_the_cells_under_the_robot_kept() -> None:
    rig = make_rig(posts=((1, 2.0, 0.0, 0.2, 0.6),))
    rig.map_around()
    costmap = rig.get("local_map")
    assert costmap.state_at((1.82, 0.0)) == "lethal"
    node = rig.build(ClearCostmapAroundRobot, radius_m=3.0, keep_radius_m=0.8)
    assert rig.tick(node) == [S.SUCCESS]
    rig.show(node)
    assert costmap.state_at((1.82, 0.0)) == "unknown" and costmap.state_at((0.0, 0.0)) == "free"
    assert rig.services.events[-1]["kind"] == "costmap_cleared"
