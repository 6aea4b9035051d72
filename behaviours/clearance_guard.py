"""ClearanceGuard: watch collisions and clearance breaches (the events OASR counts).

Semantics: RUNNING; every tick it copies the backend's safety state to ``safety`` and logs each new
collision or clearance event once. With ``fail_on_collision: true`` it returns FAILURE (after a
safe stop) on the first collision, for missions where touching anything is unacceptable.

Example:
    - type: ClearanceGuard
      name: Clearance
      params: {fail_on_collision: false}
"""

from __future__ import annotations

from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec


class ClearanceGuard(SemExpBehaviour):
    WRITES = ("safety",)
    PARAMS = {
        "fail_on_collision": ParamSpec(
            "bool", doc="FAILURE (after a safe stop) on the first collision", default=False
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        fail_on_collision: bool = False,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.fail_on_collision = fail_on_collision
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
