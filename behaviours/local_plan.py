"""LocalPlan: obstacle-aware local planning from the head camera's depth toward the subgoal.

Semantics: every tick it receives (the tree runs it behind a 12 Hz RateLimiter), it renders/reads the
latest depth frame, expresses the subgoal in the robot's ``base_footprint`` frame (x forward, y left,
z up from the floor) and asks the planner for (v, omega), which it writes to ``cmd_twist``. SUCCESS
when the planner reports arrival within ``arrival_radius_m``; FAILURE when no subgoal is set or the
planner has reported "blocked" for longer than ``blocked_timeout_s``; RUNNING otherwise. Commands a
zero twist when it ends or is preempted.

Example:
    - type: RateLimiter
      name: Plan12Hz
      params: {hz: 12}
      children:
        - type: LocalPlan
          name: LocalPlan
          params: {arrival_radius_m: 0.7}
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.types import Pose2D, Twist


def base_footprint_to_world(pose: Pose2D) -> np.ndarray:
    """4x4 transform of the planar base frame (origin on the floor under the base) to ``map``."""
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    out[0, 3], out[1, 3] = pose.x_m, pose.y_m
    return out


class LocalPlan(SemExpBehaviour):
    READS = ("subgoal",)
    WRITES = ("plan", "cmd_twist", "cmd_stamp_s")
    PARAMS = {
        "arrival_radius_m": ParamSpec(
            "float", doc="SUCCESS within this distance of the subgoal, m", default=0.7, gt=0.0
        ),
        "blocked_timeout_s": ParamSpec(
            "float", doc="FAILURE after being blocked this long, s", default=6.0, gt=0.0
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        arrival_radius_m: float = 0.7,
        blocked_timeout_s: float = 6.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.arrival_radius_m = arrival_radius_m
        self.blocked_timeout_s = blocked_timeout_s
        self._blocked_since: float | None = None

    def initialise(self) -> None:
        self._blocked_since = None

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        if subgoal is None:
            self.feedback_message = "no subgoal"
            return py_trees.common.Status.FAILURE
        robot = self.services.robot
        pose = robot.base_pose()
        gx, gy = subgoal.position_m[0] - pose.x_m, subgoal.position_m[1] - pose.y_m
        c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
        goal_base = (c * gx + s * gy, -s * gx + c * gy)
        if math.hypot(*goal_base) <= self.arrival_radius_m:
            self.command(Twist.zero())
            self.feedback_message = "arrived"
            return py_trees.common.Status.SUCCESS
        with self.timed("planner"):
            frame = robot.observe_depth()
            camera_to_base = np.linalg.inv(base_footprint_to_world(frame.base_pose)) @ frame.camera_to_world
            result = self.services.planner.plan(
                depth_m=frame.depth_m,
                intrinsics=frame.intrinsics,
                camera_to_base=camera_to_base,
                goal_base_xy=goal_base,
                stamp_s=self.now_s(),
                base_pose=pose,
            )
        self.write("plan", result)
        self.command(result.twist)
        self.feedback_message = (
            f"{result.status} d={math.hypot(*goal_base):.2f} m v={result.twist.linear_x_mps:.2f}"
        )
        if result.status == "arrived":
            return py_trees.common.Status.SUCCESS
        if result.status == "blocked":
            if self._blocked_since is None:
                self._blocked_since = self.now_s()
            elif self.now_s() - self._blocked_since > self.blocked_timeout_s:
                return py_trees.common.Status.FAILURE
        else:
            self._blocked_since = None
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status != py_trees.common.Status.RUNNING:
            self.command(Twist.zero())
