"""Wait: stand still for a while (Nav2's Wait recovery: let the sensors and the map settle).

Semantics: commands a zero twist; RUNNING until ``duration_s`` of robot time has passed since it
started, then SUCCESS.

Example:
    - type: Wait
      name: Wait
      params: {duration_s: 1.0}
"""

from __future__ import annotations

from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.core.types import Twist


class Wait(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s")
    PARAMS = {"duration_s": ParamSpec("float", doc="how long to stand still, s", default=1.0, gt=0.0)}

    def __init__(
        self,
        name: str,
        *,
        duration_s: float = 1.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.duration_s = duration_s
        self._until = 0.0

    def initialise(self) -> None:
        self._until = self.now_s() + self.duration_s

    def update(self) -> py_trees.common.Status:
        self.command(Twist.zero())
        left = self._until - self.now_s()
        self.feedback_message = f"{max(left, 0.0):.2f} s left"
        return py_trees.common.Status.SUCCESS if left <= 1e-9 else py_trees.common.Status.RUNNING
