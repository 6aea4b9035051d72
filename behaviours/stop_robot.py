"""StopRobot: command a safe stop and record the mission outcome.

Semantics (it never returns RUNNING and holds no state, so halting it changes nothing):

- SUCCESS: always, after commanding a zero twist, stopping the robot (``robot.stop()``) and writing
  ``outcome`` to ``mission_outcome``.

Reads nothing from the board; writes ``cmd_twist``, ``cmd_stamp_s`` and ``mission_outcome``.

Example:
    - type: StopRobot
      name: Stop
      params: {outcome: success}
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.types import Twist


class StopRobot(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s", "mission_outcome")

    outcome: str = param(
        "enum",
        doc="the mission outcome to record",
        default="success",
        choices=("success", "failed", "returned"),
    )

    def update(self) -> py_trees.common.Status:
        self.command(Twist.zero())
        self.services.robot.stop()
        self.write("mission_outcome", self.outcome)
        self.feedback_message = f"stopped: {self.outcome}"
        return py_trees.common.Status.SUCCESS
