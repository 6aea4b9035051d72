"""StuckGuard: detect a robot that is commanded to move but does not make progress.

Semantics: RUNNING while the base has moved at least ``min_progress_m`` (or turned ``min_turn_deg``)
within the last ``window_s`` of backend time; FAILURE (with ``stuck`` in the feedback and the event
log) otherwise, so that the execute branch fails over to recovery. It lives beside the planner in the
execute branch, and restarts its window each time the branch starts.

Example:
    - type: StuckGuard
      name: Stuck
      params: {window_s: 8, min_progress_m: 0.25}
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec


class StuckGuard(SemExpBehaviour):
    PARAMS = {
        "window_s": ParamSpec("float", doc="progress is judged over this window, s", default=8.0, gt=0.0),
        "min_progress_m": ParamSpec("float", doc="least travel within the window, m", default=0.25, gt=0.0),
        "min_turn_deg": ParamSpec(
            "float", doc="or least turn within the window, degrees", default=60.0, gt=0.0
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        window_s: float = 8.0,
        min_progress_m: float = 0.25,
        min_turn_deg: float = 60.0,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.window_s = window_s
        self.min_progress_m = min_progress_m
        self.min_turn_rad = math.radians(min_turn_deg)
        self._anchor = (0.0, 0.0, 0.0, 0.0)

    def _reset(self) -> None:
        pose = self.services.robot.base_pose()
        self._anchor = (self.now_s(), pose.x_m, pose.y_m, pose.yaw_rad)

    def initialise(self) -> None:
        self._reset()

    def update(self) -> py_trees.common.Status:
        t0, x0, y0, yaw0 = self._anchor
        pose = self.services.robot.base_pose()
        moved = math.hypot(pose.x_m - x0, pose.y_m - y0)
        turned = abs(math.remainder(pose.yaw_rad - yaw0, math.tau))
        if moved >= self.min_progress_m or turned >= self.min_turn_rad:
            self._reset()
            return py_trees.common.Status.RUNNING
        if self.now_s() - t0 > self.window_s:
            self.feedback_message = f"stuck: {moved:.2f} m in {self.window_s:.0f} s"
            self.services.log_event("stuck", moved_m=round(moved, 3))
            return py_trees.common.Status.FAILURE
        return py_trees.common.Status.RUNNING
