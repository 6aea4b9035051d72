"""FallGuard: stop the mission safely when the robot has fallen.

Semantics (stateless, so halting it changes nothing):

- RUNNING: while the backend's ``robot.safety().fallen`` is false.
- FAILURE: on a fall, after stopping the robot (``robot.stop()``), writing ``fallen`` to
  ``mission_outcome`` and the safety state to ``safety``, and logging a ``fallen`` event.

Reads nothing from the board; writes ``mission_outcome`` and ``safety``.

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
