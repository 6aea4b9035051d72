"""BackUp: reverse a short distance, the first step of a Nav2-style recovery.

Semantics: RUNNING while commanding ``-speed_mps`` until the base has moved ``distance_m``; SUCCESS
then; also SUCCESS (with a note) after ``timeout_s`` so recovery never hangs on a wall behind the
robot. Reversing is blind (the camera looks forward), so the distance is kept short.

Example:
    - type: BackUp
      name: BackUp
      params: {distance_m: 0.3, speed_mps: 0.2}
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.types import Twist


class BackUp(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s")
    PARAMS = {
        "distance_m": ParamSpec("float", doc="distance to reverse, m", default=0.3, gt=0.0, le=2.0),
        "speed_mps": ParamSpec("float", doc="reversing speed, m/s", default=0.2, gt=0.0, le=0.5),
        "timeout_s": ParamSpec("float", doc="SUCCESS anyway after this long, s", default=4.0, gt=0.0),
    }

    def __init__(
        self,
        name: str,
        *,
        distance_m: float = 0.3,
        speed_mps: float = 0.2,
        timeout_s: float = 4.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.distance_m = distance_m
        self.speed_mps = abs(speed_mps)
        self.timeout_s = timeout_s
        self._start = (0.0, 0.0, 0.0)

    def initialise(self) -> None:
        pose = self.services.robot.base_pose()
        self._start = (self.now_s(), pose.x_m, pose.y_m)

    def update(self) -> py_trees.common.Status:
        t0, x0, y0 = self._start
        pose = self.services.robot.base_pose()
        moved = math.hypot(pose.x_m - x0, pose.y_m - y0)
        if moved >= self.distance_m or self.now_s() - t0 > self.timeout_s:
            self.command(Twist.zero())
            self.feedback_message = f"backed up {moved:.2f} m"
            return py_trees.common.Status.SUCCESS
        self.command(Twist(linear_x_mps=-self.speed_mps))
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID:
            self.command(Twist.zero())
