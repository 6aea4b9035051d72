"""FallGuard alone: RUNNING until the robot falls, then a safe stop, the outcome 'fallen' and FAILURE."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.fall_guard import FallGuard
from semexp_bt.core.types import SafetyState
from tests.behaviours.rig import Rig


def test_running_until_the_fall_then_stop_record_and_fail(rig: Rig) -> None:
    guard = rig.build(FallGuard)
    statuses = rig.tick(guard, ticks=3)
    assert rig.written_by(guard) == [] and rig.get("mission_outcome") == "running"
    rig.robot.safety_state = SafetyState(fallen=True)
    statuses += rig.tick(guard)
    rig.show(guard)
    assert statuses == [Status.RUNNING] * 3 + [Status.FAILURE]
    assert rig.robot.stopped == 1
    assert rig.get("mission_outcome") == "fallen"
    assert rig.get("safety").fallen
    assert rig.written_by(guard) == ["safety", "mission_outcome"]
    assert [e["kind"] for e in rig.services.events] == ["fallen"]


def test_halting_changes_nothing(rig: Rig) -> None:
    guard = rig.build(FallGuard)
    rig.tick(guard)
    rig.halt(guard)
    assert rig.tick(guard) == [Status.RUNNING]
    rig.show(guard)
    assert rig.robot.stopped == 0 and rig.written_by(guard) == []
