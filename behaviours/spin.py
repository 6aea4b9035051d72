"""Spin: turn in place by an angle, checking the footprint against the costmap first (Nav2's Spin recovery).

Semantics: RUNNING while the accumulated yaw (odometry) is short of ``angle_deg``, commanding
``yaw_rate_radps`` as long as the next ``lookahead_s`` of the turn keeps the oriented footprint clear of
lethal cells (the corners of the Go1's body sweep a circle of 0.41 m); SUCCESS once turned; FAILURE
when the turn would sweep into an obstacle (it stops first) or after ``timeout_s``. The camera sees
around while it turns, so the costmap learns what lies beside and behind the robot. Commands zero when
it ends or is preempted. ``RotateInPlace`` (panoramic init, looking around) turns without the check.

Example:
    - type: Spin
      name: Spin
      params: {angle_deg: 180.0}
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.follow_path import turn_is_admissible
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import Twist


class Spin(SemExpBehaviour):
    READS = ("local_map",)
    WRITES = ("cmd_twist", "cmd_stamp_s")
    PARAMS = {
        "angle_deg": ParamSpec(
            "float",
            doc="angle to turn, degrees (positive: counter-clockwise)",
            default=180.0,
            ge=-720.0,
            le=720.0,
        ),
        "yaw_rate_radps": ParamSpec("float", doc="turning rate, rad/s", default=0.8, gt=0.0, le=1.0),
        "lookahead_s": ParamSpec("float", doc="the turn is checked this far ahead, s", default=0.5, gt=0.0),
        "timeout_s": ParamSpec("float", doc="FAILURE after this long, s", default=15.0, gt=0.0),
    }

    def __init__(
        self,
        name: str,
        *,
        angle_deg: float = 180.0,
        yaw_rate_radps: float = 0.8,
        lookahead_s: float = 0.5,
        timeout_s: float = 15.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.angle_rad = math.radians(angle_deg)
        self.yaw_rate_radps = yaw_rate_radps
        self.lookahead_s = lookahead_s
        self.timeout_s = timeout_s
        self._turned = 0.0
        self._last_yaw = 0.0
        self._started_s = 0.0

    def initialise(self) -> None:
        self._turned = 0.0
        self._last_yaw = self.services.robot.base_pose().yaw_rad
        self._started_s = self.now_s()

    def update(self) -> py_trees.common.Status:
        pose = self.services.robot.base_pose()
        self._turned += wrap_angle(pose.yaw_rad - self._last_yaw)
        self._last_yaw = pose.yaw_rad
        remaining = self.angle_rad - self._turned
        self.feedback_message = (
            f"turned {math.degrees(self._turned):.0f}/{math.degrees(self.angle_rad):.0f} deg"
        )
        if abs(remaining) < math.radians(3.0):
            self.command(Twist.zero())
            return py_trees.common.Status.SUCCESS
        if self.now_s() - self._started_s > self.timeout_s:
            self.command(Twist.zero())
            return py_trees.common.Status.FAILURE
        rate = math.copysign(min(self.yaw_rate_radps, max(0.25, 2.0 * abs(remaining))), remaining)
        costmap = self.read("local_map")
        if costmap is not None and not turn_is_admissible(costmap, pose, rate, duration_s=self.lookahead_s):
            self.command(Twist.zero())
            self.feedback_message += "; the turn would sweep into an obstacle"
            return py_trees.common.Status.FAILURE
        self.command(Twist(angular_z_radps=rate))
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID:
            self.command(Twist.zero())
