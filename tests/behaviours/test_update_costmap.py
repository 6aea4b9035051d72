"""UpdateCostmap ticked alone: one depth frame per tick into the costmap on the board."""

import py_trees

from behaviours.update_costmap import UpdateCostmap
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


def test_each_tick_adds_one_frame_and_marks_what_the_camera_sees() -> None:
    rig = make_rig(posts=((1, 2.0, 0.0, 0.2, 0.6),))
    node = rig.build(UpdateCostmap)
    assert rig.tick(node, 3) == [S.SUCCESS] * 3
    rig.show(node)
    costmap = rig.get("local_map")
    assert costmap.frames == 3
    assert costmap.state_at((1.82, 0.0)) == "lethal" and costmap.state_at((1.0, 0.0)) == "free"
    assert "marked" in node.feedback_message


def test_no_costmap_is_a_failure() -> None:
    rig = make_rig()
    rig.set("local_map", None)
    node = rig.build(UpdateCostmap)
    assert rig.tick(node) == [S.FAILURE]
    rig.show(node)
