"""RotateInPlace: turn the base by a fixed angle, measured by odometry.

Semantics:

- RUNNING: while the yaw accumulated since it started is more than 2 degrees short of ``angle_deg``,
  commanding a pure yaw rate (``yaw_rate_radps``, slowing down over the last 20 degrees so the gait does
  not overshoot).
- SUCCESS: once the angle is reached (within 2 degrees), after commanding a zero twist.
- FAILURE: when it has taken longer than ``timeout_s`` of backend time (the base is blocked), after
  commanding a zero twist.
- Halted: it commands a zero twist.

Reads nothing from the board; writes ``cmd_twist`` and ``cmd_stamp_s``.

Example (the panoramic init turns in 8 steps of 45 degrees):
    - type: RotateInPlace
      name: Turn45
      params: {angle_deg: 45, yaw_rate_radps: 0.8}
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import Twist


class RotateInPlace(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s")

    angle_deg: float = param(
        "float", doc="angle to turn, degrees (positive: counter-clockwise)", default=45.0, ge=-720.0, le=720.0
    )
    yaw_rate_radps: float = param("float", doc="turning rate, rad/s", default=0.8, gt=0.0, le=1.5)
    timeout_s: float = param(
        "float", doc="give up (FAILURE) after this much backend time, s", default=15.0, gt=0.0
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.angle_rad = math.radians(self.angle_deg)
        self._turned = 0.0
        self._last_yaw = 0.0
        self._started_s = 0.0

    def initialise(self) -> None:
        self._turned = 0.0
        self._last_yaw = self.services.robot.base_pose().yaw_rad
        self._started_s = self.now_s()

    def update(self) -> py_trees.common.Status:
        yaw = self.services.robot.base_pose().yaw_rad
        self._turned += wrap_angle(yaw - self._last_yaw)
        self._last_yaw = yaw
        remaining = self.angle_rad - self._turned
        self.feedback_message = (
            f"turned {math.degrees(self._turned):.0f}/{math.degrees(self.angle_rad):.0f} deg"
        )
        if abs(remaining) < math.radians(2.0):
            self.command(Twist.zero())
            return py_trees.common.Status.SUCCESS
        if has_elapsed(since_s=self._started_s, now_s=self.now_s(), duration_s=self.timeout_s):
            self.command(Twist.zero())
            return py_trees.common.Status.FAILURE
        # Slow down over the last 20 degrees so the gait does not overshoot.
        rate = min(self.yaw_rate_radps, max(0.25, abs(remaining) * 2.0))
        self.command(Twist(angular_z_radps=math.copysign(rate, remaining)))
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID:
            self.command(Twist.zero())
