"""Wait ticked alone: zero twist for the duration, then SUCCESS."""

import py_trees

from behaviours.wait import Wait
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


def test_it_stands_still_for_the_duration() -> None:
    rig = make_rig()
    node = rig.build(Wait, duration_s=0.1)
    statuses = rig.tick(node, 6)
    rig.show(node)
    assert statuses[:5] == [S.RUNNING] * 5 and statuses[5] == S.SUCCESS
    assert rig.get("cmd_twist").linear_x_mps == 0.0
