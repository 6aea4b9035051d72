"""BackUp ticked alone: steps onto known free cells only."""

import math

import py_trees

from behaviours.back_up import BackUp
from semexp_bt.core.types import Pose2D
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


def test_it_steps_back_onto_the_cells_it_has_seen() -> None:
    """The robot walked 0.6 m forward: its own trail (footprint clearing) is known free behind it."""
    rig = make_rig()
    rig.map_around()
    costmap = rig.get("local_map")
    for x in (0.2, 0.4, 0.6):
        rig.robot._pose = Pose2D(x, 0.0, 0.0)  # noqa: SLF001
        costmap.integrate(rig.robot.observe_depth(pixel_grids=[costmap.sampled_pixels]))
    node = rig.build(BackUp, distance_m=0.3)
    statuses = rig.tick_until_done(node, limit_s=10.0)
    rig.show(node)
    assert statuses[-1] == S.SUCCESS
    pose = rig.robot.base_pose()
    assert math.hypot(pose.x_m - 0.6, pose.y_m) >= 0.29 and pose.x_m < 0.6  # back (or back-sideways)


def test_it_refuses_to_step_onto_cells_never_seen() -> None:
    rig = make_rig(start=Pose2D(0.0, 0.0, 0.0))
    rig.map_around(turns=1)  # only the view ahead: nothing behind or beside is known
    node = rig.build(BackUp, distance_m=0.5)
    assert rig.tick(node) == [S.FAILURE]
    rig.show(node)
    assert rig.robot.base_pose() == Pose2D(0.0, 0.0, 0.0)
