"""ClearanceGuard alone: RUNNING while it logs each new safety event once; FAILURE on a collision if asked."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from behaviours.clearance_guard import ClearanceGuard
from semexp_bt.core.types import ContactEvent, SafetyState
from tests.behaviours.rig import Rig

CLOSE = ContactEvent(stamp_s=0.1, object_id=7, distance_m=0.05, kind="clearance")
BUMP = ContactEvent(stamp_s=0.2, object_id=7, distance_m=-0.01, kind="collision")


def test_it_logs_each_event_once_and_keeps_running(rig: Rig) -> None:
    guard = rig.build(ClearanceGuard)
    assert rig.tick(guard) == [Status.RUNNING]
    assert rig.get("safety") is None and rig.written_by(guard) == []  # nothing new: nothing written
    rig.robot.safety_state = SafetyState(events=[CLOSE], min_clearance_m=0.05)
    rig.tick(guard, ticks=2)
    rig.robot.safety_state = SafetyState(events=[CLOSE, BUMP], min_clearance_m=0.0)
    statuses = rig.tick(guard, ticks=3)
    rig.show(guard)
    assert statuses == [Status.RUNNING] * 3  # a collision alone does not fail the default guard
    assert [(e["kind"], e["object_id"]) for e in rig.services.events] == [("clearance", 7), ("collision", 7)]
    assert rig.get("safety").events == [CLOSE, BUMP]
    assert rig.written_by(guard) == ["safety"]
    assert rig.robot.stopped == 0


@pytest.mark.parametrize(("event", "status"), [(CLOSE, Status.RUNNING), (BUMP, Status.FAILURE)])
def test_fail_on_collision_stops_the_robot_and_fails_on_a_collision_only(
    rig: Rig, event: ContactEvent, status: Status
) -> None:
    guard = rig.build(ClearanceGuard, fail_on_collision=True)
    rig.tick(guard)
    rig.robot.safety_state = SafetyState(events=[event])
    assert rig.tick(guard) == [status]
    rig.show(guard)
    assert rig.robot.stopped == (1 if status == Status.FAILURE else 0)


def test_events_seen_before_a_halt_are_not_logged_again(rig: Rig) -> None:
    guard = rig.build(ClearanceGuard)
    rig.robot.safety_state = SafetyState(events=[CLOSE])
    rig.tick(guard)
    rig.halt(guard)
    rig.tick(guard, ticks=2)
    rig.show(guard)
    assert len(rig.services.events) == 1
