"""FollowPath: follow the global plan with the controller, to the subgoal (Nav2's FollowPath).

Semantics (every tick it receives, 12 Hz behind a RateLimiter, it hands the latest ``global_plan``, the
costmap ``local_map`` and the robot's pose and velocity to the path-following controller,
``services.planner``, a ``semexp_bt.nav.controller.PathController``: DWB-style sampling or regulated
pure pursuit, which checks the oriented footprint at every state it considers; it writes the
controller's result to ``plan`` and its twist to ``cmd_twist`` and ``cmd_stamp_s``):

- SUCCESS on arrival: within ``arrival_radius_m`` of the ``subgoal`` or ``path_end_tolerance_m`` of the
  plan's end (for a subgoal on an object's surface the plan ends at the nearest place to stand), after
  turning in place to face the subgoal so that the perception that follows looks at it (a turn the
  footprint cannot make is skipped).
- FAILURE, with ``nav_failure`` = ``blocked`` and a ``blocked`` event, when the controller has found no
  admissible motion for ``blocked_timeout_s``; FAILURE when there is no subgoal.
- RUNNING otherwise (also while no plan has been written yet: it then commands zero).
- When it ends, and when it is halted, it commands a zero twist.

Example:
    - type: RateLimiter
      name: Follow12Hz
      params: {rate_hz: 12.0}
      children:
        - type: FollowPath
          name: FollowPath
          params: {arrival_radius_m: 0.7}
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.controller import MotionLimits, SafetyRules, admissible, rollout
from semexp_bt.nav.costmap import Costmap


def motion_is_admissible(costmap: Costmap, pose: Pose2D, twist: Twist, *, duration_s: float = 0.6) -> bool:
    """Whether ``twist`` (forward speed and yaw rate) held for ``duration_s`` from a standstill passes the
    controller's safety rules: the footprint's clearance, unseen space, the sweep of the body's corners."""
    wanted = np.array([[twist.linear_x_mps, twist.angular_z_radps]])
    states, commands = rollout(
        pose, Twist.zero(), wanted, limits=MotionLimits(), horizon_s=duration_s, dt_s=0.1
    )
    ok, _ = admissible(costmap, pose, states, commands, rules=SafetyRules())
    return bool(ok[0])


def turn_is_admissible(costmap: Costmap, pose: Pose2D, rate_radps: float, *, duration_s: float = 0.6) -> bool:
    """Whether a turn in place at ``rate_radps`` for ``duration_s`` keeps the footprint's clearance."""
    return motion_is_admissible(costmap, pose, Twist(angular_z_radps=rate_radps), duration_s=duration_s)


class FollowPath(SemExpBehaviour):
    READS = ("subgoal", "global_plan", "local_map")
    WRITES = ("plan", "cmd_twist", "cmd_stamp_s", "nav_failure")

    arrival_radius_m: float = param(
        "float", doc="SUCCESS within this distance of the subgoal, m", default=0.7, gt=0.0
    )
    path_end_tolerance_m: float = param(
        "float", doc="or within this distance of the plan's end, m", default=0.15, gt=0.0
    )
    blocked_timeout_s: float = param(
        "float", doc="FAILURE after no admissible motion for this long, s", default=3.0, gt=0.0
    )
    facing_tolerance_deg: float = param(
        "float",
        doc="on arrival, turn until the subgoal is this close to straight ahead, degrees",
        default=6.0,
        gt=0.0,
        le=180.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.facing_tolerance_rad = math.radians(self.facing_tolerance_deg)
        self._blocked_since: float | None = None
        self._arrived = False

    def initialise(self) -> None:
        self._blocked_since = None
        self._arrived = False
        self.services.planner.reset()

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        if subgoal is None:
            self.feedback_message = "no subgoal"
            return py_trees.common.Status.FAILURE
        plan = self.read("global_plan")
        costmap = self.read("local_map")
        robot = self.services.robot
        pose = robot.base_pose()
        goal_xy = (subgoal.position_m[0], subgoal.position_m[1])
        at_goal = math.hypot(goal_xy[0] - pose.x_m, goal_xy[1] - pose.y_m) <= self.arrival_radius_m
        at_end = (
            plan is not None
            and plan.ok
            and math.hypot(plan.path_xy[-1, 0] - pose.x_m, plan.path_xy[-1, 1] - pose.y_m)
            <= self.path_end_tolerance_m
        )
        if self._arrived or at_goal or at_end:
            self._arrived = True
            return self._face(pose, goal_xy, costmap)
        if plan is None or not plan.ok or costmap is None:
            self.command(Twist.zero())
            self.feedback_message = "waiting for a plan"
            return py_trees.common.Status.RUNNING
        with self.timed("planner"):
            result = self.services.planner.compute(
                plan=plan, costmap=costmap, pose=pose, velocity=robot.base_twist(), stamp_s=self.now_s()
            )
        self.write("plan", result)
        self.command(result.twist)
        self.feedback_message = (
            f"{result.status} v={result.twist.linear_x_mps:.2f} w={result.twist.angular_z_radps:.2f} "
            f"clearance {result.clearance_m:.2f} m"
        )
        if result.status == "blocked":
            if self._blocked_since is None:
                self._blocked_since = self.now_s()
            elif has_elapsed(
                since_s=self._blocked_since, now_s=self.now_s(), duration_s=self.blocked_timeout_s
            ):
                self.write("nav_failure", "blocked")
                self.services.log_event("blocked", node_id=subgoal.node_id)
                return py_trees.common.Status.FAILURE
        else:
            self._blocked_since = None
        return py_trees.common.Status.RUNNING

    def _face(
        self, pose: Pose2D, goal_xy: tuple[float, float], costmap: Costmap | None
    ) -> py_trees.common.Status:
        """Arrival: turn in place toward the subgoal (when the footprint can), then SUCCESS."""
        bearing = math.remainder(
            math.atan2(goal_xy[1] - pose.y_m, goal_xy[0] - pose.x_m) - pose.yaw_rad, math.tau
        )
        distance = math.hypot(goal_xy[0] - pose.x_m, goal_xy[1] - pose.y_m)
        if abs(bearing) > self.facing_tolerance_rad and distance > 0.1:
            rate = math.copysign(max(0.3, min(0.8, 1.5 * abs(bearing))), bearing)
            if costmap is None or turn_is_admissible(costmap, pose, rate):
                self.command(Twist(angular_z_radps=rate))
                self.feedback_message = (
                    f"arrived; turning to face the subgoal ({math.degrees(bearing):.0f} deg)"
                )
                return py_trees.common.Status.RUNNING
        self.command(Twist.zero())
        self.feedback_message = f"arrived, {distance:.2f} m from the subgoal"
        return py_trees.common.Status.SUCCESS

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status != py_trees.common.Status.RUNNING:
            self.command(Twist.zero())
