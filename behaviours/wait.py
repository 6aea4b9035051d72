"""Wait: stand still for a while (Nav2's Wait recovery: let the sensors and the map settle).

Semantics:

- RUNNING: until ``duration_s`` of robot time has passed since it started, commanding a zero twist
  (``cmd_twist``, ``cmd_stamp_s``) every tick.
- SUCCESS: once the time has passed. It never fails; halting it leaves the zero command in place.

Example:
    - type: Wait
      name: Wait
      params: {duration_s: 1.0}
"""

from __future__ import annotations

from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import is_due
from semexp_bt.core.types import Twist


class Wait(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s")

    duration_s: float = param("float", doc="how long to stand still, s", default=1.0, gt=0.0)

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._until = 0.0

    def initialise(self) -> None:
        self._until = self.now_s() + self.duration_s

    def update(self) -> py_trees.common.Status:
        self.command(Twist.zero())
        left = self._until - self.now_s()
        self.feedback_message = f"{max(left, 0.0):.2f} s left"
        done = is_due(now_s=self.now_s(), due_s=self._until)
        return py_trees.common.Status.SUCCESS if done else py_trees.common.Status.RUNNING
