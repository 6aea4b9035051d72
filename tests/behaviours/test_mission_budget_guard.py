"""MissionBudgetGuard alone: RUNNING while the budget lasts, then a safe stop, 'budget_exceeded', FAILURE."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from behaviours.mission_budget_guard import MissionBudgetGuard
from tests.behaviours.rig import Rig, compact


@pytest.mark.parametrize(("budget_s", "mission_budget_s", "spent_s"), [(1.0, 240.0, 1.0), (0.0, 0.5, 0.5)])
def test_it_fails_the_mission_once_the_budget_is_spent(
    rig: Rig, budget_s: float, mission_budget_s: float, spent_s: float
) -> None:
    """Its own budget_s, or (0, the default) the mission's budget_s setting."""
    rig.services.budget_s = mission_budget_s
    guard = rig.build(MissionBudgetGuard, budget_s=budget_s)
    statuses = rig.tick_until_done(guard, limit_s=5.0)
    rig.show(guard)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert len(statuses) == round(spent_s / 0.02) + 1  # the first tick at or after the budget fails
    assert rig.get("mission_outcome") == "budget_exceeded"
    assert rig.robot.stopped == 1
    assert rig.written_by(guard) == ["mission_outcome"]
    assert [e["kind"] for e in rig.services.events] == ["budget_exceeded"]


def test_a_halt_does_not_restart_the_budget(rig: Rig) -> None:
    guard = rig.build(MissionBudgetGuard, budget_s=1.0)
    rig.tick(guard, ticks=30)  # 0.6 s
    rig.halt(guard)
    statuses = rig.tick(guard, ticks=21)
    rig.show(guard)
    assert statuses[-1] == Status.FAILURE and statuses[:-1] == [Status.RUNNING] * 20
