"""Spin: turn in place by an angle, checking the footprint against the costmap first (Nav2's Spin recovery).

Semantics:

- RUNNING: while the accumulated yaw (odometry) is short of ``angle_deg``, commanding up to
  ``yaw_rate_radps`` (``cmd_twist``, ``cmd_stamp_s``) as long as the next ``lookahead_s`` of the turn
  keeps the oriented footprint clear of lethal cells of ``local_map`` and sweeps only observed cells
  (the corners of the Go1's body sweep a circle of 0.41 m; the camera never sees the floor that close, so
  what lies there is known from having looked at it earlier, from the footprint's own trail, or, at the
  start pose, assumed free: ``semexp_bt.nav.controller``'s safety rules).
- SUCCESS: once turned (within 3 degrees); it commands a zero twist.
- FAILURE: the turn would sweep into an obstacle or over never-observed floor (it stops first), or
  ``timeout_s`` has passed.
- Halted while RUNNING: it commands a zero twist.

The camera sees around while it turns, so the costmap learns what lies beside and behind the robot.
It is the product's only turn in place (the panoramic init, looking around, recovery): an unchecked
turn swung the long body's corners into obstacles the camera had not seen.

Example:
    - type: Spin
      name: Spin
      params: {angle_deg: 180.0}
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.follow_path import turn_is_admissible
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import Twist


def turn_rate_toward(angle_rad: float, *, max_radps: float) -> float:
    """The yaw rate of a turn in place with ``angle_rad`` still to go: twice the angle per second, at least
    0.25 rad/s (the gait turns no slower cleanly) and at most ``max_radps``, with the angle's sign."""
    return math.copysign(min(max_radps, max(0.25, 2.0 * abs(angle_rad))), angle_rad)


class Spin(SemExpBehaviour):
    READS = ("local_map",)
    WRITES = ("cmd_twist", "cmd_stamp_s")

    angle_deg: float = param(
        "float",
        doc="angle to turn, degrees (positive: counter-clockwise)",
        default=180.0,
        ge=-720.0,
        le=720.0,
    )
    yaw_rate_radps: float = param("float", doc="turning rate, rad/s", default=0.8, gt=0.0, le=1.0)
    lookahead_s: float = param("float", doc="the turn is checked this far ahead, s", default=0.5, gt=0.0)
    timeout_s: float = param("float", doc="FAILURE after this long, s", default=15.0, gt=0.0)

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
        if has_elapsed(since_s=self._started_s, now_s=self.now_s(), duration_s=self.timeout_s):
            self.command(Twist.zero())
            return py_trees.common.Status.FAILURE
        rate = turn_rate_toward(remaining, max_radps=self.yaw_rate_radps)
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
