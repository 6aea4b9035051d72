"""StopRobot: command a safe stop and record the mission outcome.

Semantics: zero twist, ``robot.stop()``, writes ``outcome`` to ``mission_outcome``; SUCCESS.

Example:
    - type: StopRobot
      name: Stop
      params: {outcome: success}
"""

from __future__ import annotations

from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.core.types import Twist


class StopRobot(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s", "mission_outcome")
    PARAMS = {
        "outcome": ParamSpec(
            "enum",
            doc="the mission outcome to record",
            default="success",
            choices=("success", "failed", "returned"),
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        outcome: str = "success",
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.outcome = outcome

    def update(self) -> py_trees.common.Status:
        self.command(Twist.zero())
        self.services.robot.stop()
        self.write("mission_outcome", self.outcome)
        self.feedback_message = f"stopped: {self.outcome}"
        return py_trees.common.Status.SUCCESS
