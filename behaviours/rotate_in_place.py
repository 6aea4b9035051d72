"""RotateInPlace: turn the base by a fixed angle, measured by odometry.

Semantics: RUNNING while the accumulated yaw is short of ``angle_deg`` (commanding a pure yaw rate on
``cmd_twist``), SUCCESS once it is reached, FAILURE if it takes longer than ``timeout_s`` of backend
time (the base is blocked). Commands a zero twist when it ends or is preempted.

Example (the panoramic init turns in 8 steps of 45 degrees):
    - type: RotateInPlace
      name: Turn45
      params: {angle_deg: 45, yaw_rate_radps: 0.8}
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import Twist


class RotateInPlace(SemExpBehaviour):
    WRITES = ("cmd_twist", "cmd_stamp_s")
    PARAMS = {
        "angle_deg": ParamSpec(
            "float",
            doc="angle to turn, degrees (positive: counter-clockwise)",
            default=45.0,
            ge=-720.0,
            le=720.0,
        ),
        "yaw_rate_radps": ParamSpec("float", doc="turning rate, rad/s", default=0.8, gt=0.0, le=1.5),
        "timeout_s": ParamSpec(
            "float", doc="give up (FAILURE) after this much backend time, s", default=15.0, gt=0.0
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        angle_deg: float = 45.0,
        yaw_rate_radps: float = 0.8,
        timeout_s: float = 15.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.angle_rad = math.radians(angle_deg)
        self.yaw_rate_radps = abs(yaw_rate_radps)
        self.timeout_s = timeout_s
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
        if self.now_s() - self._started_s > self.timeout_s:
            self.command(Twist.zero())
            return py_trees.common.Status.FAILURE
        # Slow down over the last 20 degrees so the gait does not overshoot.
        rate = min(self.yaw_rate_radps, max(0.25, abs(remaining) * 2.0))
        self.command(Twist(angular_z_radps=math.copysign(rate, remaining)))
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID:
            self.command(Twist.zero())
