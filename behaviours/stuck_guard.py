"""StuckGuard: detect a robot that does not make progress while it should be moving.

Semantics:

- RUNNING: while the base has moved at least ``min_progress_m`` (or turned ``min_turn_deg``) within the
  last ``window_s`` of backend time, and has come ``min_approach_m`` closer to the ``subgoal`` within the
  last ``approach_window_s`` (no subgoal: only the first rule applies).
- FAILURE, "stuck": the base has neither moved nor turned enough for ``window_s``; a ``stuck`` event is
  logged.
- FAILURE, "no progress": the robot has not come ``min_approach_m`` closer to the subgoal for
  ``approach_window_s``; a ``no_progress`` event is logged. A robot that dithers, turning back and forth
  in front of an obstacle it cannot pass, moves and turns but gets nowhere; without this rule it would
  spend the whole execute timeout there.
- Halted: nothing to undo; the next start restarts both windows.

Reads ``subgoal``; writes ``nav_failure`` (``stuck``) when it fails, so that recovery knows why (the
execute branch's failure hands over to recovery). It lives beside the planner in the execute branch,
and restarts its windows each time the branch starts.

Example:
    - type: StuckGuard
      name: Stuck
      params: {window_s: 8, min_progress_m: 0.25}
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.geometry import wrap_angle


class StuckGuard(SemExpBehaviour):
    READS = ("subgoal",)
    WRITES = ("nav_failure",)

    window_s: float = param("float", doc="progress is judged over this window, s", default=8.0, gt=0.0)
    min_progress_m: float = param("float", doc="least travel within the window, m", default=0.25, gt=0.0)
    min_turn_deg: float = param("float", doc="or least turn within the window, degrees", default=60.0, gt=0.0)
    approach_window_s: float = param(
        "float", doc="the subgoal must come min_approach_m closer within this window, s", default=15.0, gt=0.0
    )
    min_approach_m: float = param(
        "float",
        doc="least reduction of the distance to the subgoal within the approach window, m",
        default=0.3,
        gt=0.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.min_turn_rad = math.radians(self.min_turn_deg)
        self._anchor = (0.0, 0.0, 0.0, 0.0)
        self._approach: tuple[float, float] | None = None  # (stamp of the last approach, best distance)

    def _reset(self) -> None:
        pose = self.services.robot.base_pose()
        self._anchor = (self.now_s(), pose.x_m, pose.y_m, pose.yaw_rad)

    def initialise(self) -> None:
        self._reset()
        self._approach = None

    def _no_approach(self) -> bool:
        """Track the closest distance to the subgoal; True when it stalled for the approach window."""
        subgoal = self.read("subgoal")
        if subgoal is None:
            return False
        pose = self.services.robot.base_pose()
        distance = math.hypot(subgoal.position_m[0] - pose.x_m, subgoal.position_m[1] - pose.y_m)
        if self._approach is None or distance <= self._approach[1] - self.min_approach_m:
            self._approach = (self.now_s(), distance)
            return False
        return has_elapsed(since_s=self._approach[0], now_s=self.now_s(), duration_s=self.approach_window_s)

    def update(self) -> py_trees.common.Status:
        if self._no_approach():
            self.feedback_message = (
                f"no progress: not {self.min_approach_m:.2f} m closer in {self.approach_window_s:.0f} s"
            )
            best_distance_m = self._approach[1] if self._approach is not None else float("nan")
            self.services.log_event("no_progress", distance_m=round(best_distance_m, 3))
            self.write("nav_failure", "stuck")
            return py_trees.common.Status.FAILURE
        t0, x0, y0, yaw0 = self._anchor
        pose = self.services.robot.base_pose()
        moved = math.hypot(pose.x_m - x0, pose.y_m - y0)
        turned = abs(wrap_angle(pose.yaw_rad - yaw0))
        if moved >= self.min_progress_m or turned >= self.min_turn_rad:
            self._reset()
            return py_trees.common.Status.RUNNING
        if has_elapsed(since_s=t0, now_s=self.now_s(), duration_s=self.window_s):
            self.feedback_message = f"stuck: {moved:.2f} m in {self.window_s:.0f} s"
            self.services.log_event("stuck", moved_m=round(moved, 3))
            self.write("nav_failure", "stuck")
            return py_trees.common.Status.FAILURE
        return py_trees.common.Status.RUNNING
