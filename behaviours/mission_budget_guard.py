"""MissionBudgetGuard: fail the mission when its time budget (backend clock) is spent.

Semantics: RUNNING while ``now - start < budget_s`` (by default the mission's ``budget_s`` setting); then writes ``budget_exceeded`` to
``mission_outcome``, stops the robot and returns FAILURE. It sits in the mission's root parallel, so
its failure ends the mission safely.

Example:
    - type: MissionBudgetGuard
      name: Budget
      params: {budget_s: 240}   # or leave out: the mission's budget_s
"""

from __future__ import annotations

from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec


class MissionBudgetGuard(SemExpBehaviour):
    WRITES = ("mission_outcome",)
    PARAMS = {
        "budget_s": ParamSpec(
            "float",
            doc="mission time budget on the backend clock, s (0: the mission's budget_s setting)",
            default=0.0,
            ge=0.0,
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        budget_s: float = 0.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.budget_s = budget_s if budget_s > 0.0 else self.services.budget_s
        self._start_s: float | None = None

    def initialise(self) -> None:
        if self._start_s is None:
            self._start_s = self.now_s()

    def update(self) -> py_trees.common.Status:
        assert self._start_s is not None
        elapsed = self.now_s() - self._start_s
        self.feedback_message = f"{elapsed:.0f}/{self.budget_s:.0f} s"
        if elapsed < self.budget_s:
            return py_trees.common.Status.RUNNING
        self.services.robot.stop()
        self.write("mission_outcome", "budget_exceeded")
        self.services.log_event("budget_exceeded", elapsed_s=round(elapsed, 2))
        return py_trees.common.Status.FAILURE
