"""MissionBudgetGuard: fail the mission when its time budget (backend clock) is spent.

Semantics:

- RUNNING: while less than ``budget_s`` of backend time has passed since its first tick (``budget_s`` 0,
  the default: the mission's ``budget_s`` setting, ``services.budget_s``).
- FAILURE: once the budget is spent, after stopping the robot, writing ``budget_exceeded`` to
  ``mission_outcome`` and logging a ``budget_exceeded`` event. It sits in the mission's root parallel,
  so its failure ends the mission safely.
- Halted: the clock keeps running; the budget is counted from the first tick of the mission, never
  restarted.

Reads nothing from the board; writes ``mission_outcome``.

Example:
    - type: MissionBudgetGuard
      name: Budget
      params: {budget_s: 240}   # or leave out: the mission's budget_s
"""

from __future__ import annotations

from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed


class MissionBudgetGuard(SemExpBehaviour):
    WRITES = ("mission_outcome",)

    budget_s: float = param(
        "float",
        doc="mission time budget on the backend clock, s (0: the mission's budget_s setting)",
        default=0.0,
        ge=0.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        if self.budget_s <= 0.0:
            self.budget_s = self.services.budget_s
        self._start_s: float | None = None

    def initialise(self) -> None:
        if self._start_s is None:
            self._start_s = self.now_s()

    def update(self) -> py_trees.common.Status:
        assert self._start_s is not None
        now = self.now_s()
        elapsed = now - self._start_s
        self.feedback_message = f"{elapsed:.0f}/{self.budget_s:.0f} s"
        if not has_elapsed(since_s=self._start_s, now_s=now, duration_s=self.budget_s):
            return py_trees.common.Status.RUNNING
        self.services.robot.stop()
        self.write("mission_outcome", "budget_exceeded")
        self.services.log_event("budget_exceeded", elapsed_s=round(elapsed, 2))
        return py_trees.common.Status.FAILURE
