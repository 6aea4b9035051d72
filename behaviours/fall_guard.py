"""FallGuard: stop the mission safely when the robot has fallen.

Semantics: RUNNING while ``robot.safety().fallen`` is false; on a fall it stops the robot, writes
``fallen`` to ``mission_outcome`` and ``safety``, and returns FAILURE.

Example:
    - type: FallGuard
      name: FallGuard
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour


class FallGuard(SemExpBehaviour):
    WRITES = ("mission_outcome", "safety")

    def update(self) -> py_trees.common.Status:
        safety = self.services.robot.safety()
        if not safety.fallen:
            return py_trees.common.Status.RUNNING
        self.services.robot.stop()
        self.write("safety", safety)
        self.write("mission_outcome", "fallen")
        self.services.log_event("fallen")
        self.feedback_message = "robot fell: mission stopped"
        return py_trees.common.Status.FAILURE
