"""Wait alone: a zero twist for the duration (RUNNING), then SUCCESS."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.wait import Wait
from semexp_bt.core.types import Twist
from tests.behaviours.rig import Rig


def test_it_stands_still_for_the_duration(rig: Rig) -> None:
    wait = rig.build(Wait, duration_s=0.1)
    statuses = rig.tick(wait, 6)
    rig.show(wait)
    assert statuses[:5] == [Status.RUNNING] * 5 and statuses[5] == Status.SUCCESS
    assert rig.get("cmd_twist") == Twist.zero()
    assert rig.written_by(wait) == ["cmd_twist", "cmd_stamp_s"]
