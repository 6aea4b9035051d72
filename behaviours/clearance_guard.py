"""ClearanceGuard: watch collisions and clearance breaches (the events OASR counts).

Semantics:

- RUNNING: every tick, after logging each new collision or clearance event of the backend's safety state
  once (``services.events``) and, when there are new events, writing that state to ``safety``.
- FAILURE: only with ``fail_on_collision: true``, on the tick a collision is first seen, after a safe
  stop (``robot.stop()``), for missions where touching anything is unacceptable.
- Halted: nothing to undo; events already logged are not logged again.

Reads nothing from the board; writes ``safety``.

Example:
    - type: ClearanceGuard
      name: Clearance
      params: {fail_on_collision: false}
"""

from __future__ import annotations

from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param


class ClearanceGuard(SemExpBehaviour):
    WRITES = ("safety",)

    fail_on_collision: bool = param(
        "bool", doc="FAILURE (after a safe stop) on the first collision", default=False
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._seen = 0

    def update(self) -> py_trees.common.Status:
        safety = self.services.robot.safety()
        new_events = safety.events[self._seen :]
        self._seen = len(safety.events)
        if new_events:
            self.write("safety", safety)
            for event in new_events:
                self.services.log_event(
                    event.kind, object_id=event.object_id, distance_m=round(event.distance_m, 3)
                )
        self.feedback_message = f"min clearance {safety.min_clearance_m:.2f} m, {len(safety.events)} events"
        if self.fail_on_collision and any(e.kind == "collision" for e in new_events):
            self.services.robot.stop()
            return py_trees.common.Status.FAILURE
        return py_trees.common.Status.RUNNING
