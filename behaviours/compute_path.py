"""ComputePathToSubgoal: keep a global plan from the robot to the subgoal on the costmap (Nav2's ComputePathToPose).

Semantics:

- RUNNING: while a plan reaches the subgoal. It plans (``semexp_bt.nav.global_planner.GlobalPlanner``)
  on its first tick and again when the subgoal changes, when the costmap changed (its revision moved: an
  obstacle appeared or vanished) and ``replan_period_s`` has passed since the last plan, or when the plan
  is ``max_plan_age_s`` old; each plan is written to ``global_plan``. It stays RUNNING because it serves
  FollowPath, which runs beside it.
- FAILURE, at once, with ``nav_failure`` set to ``no_path`` (no passable cell near the subgoal is
  connected to the robot: the subgoal is walled in or inside obstacles) or ``start_blocked``, and an
  event of that kind: an unreachable subgoal is handed back to the decision layer, never chased.
- FAILURE when there is no ``subgoal`` or no costmap (``local_map``).
- On start it clears ``nav_failure``; halting it changes nothing else.

Reads ``subgoal`` and ``local_map``; writes ``global_plan`` and ``nav_failure``.

Example:
    - type: RateLimiter
      name: Plan4Hz
      params: {rate_hz: 4.0}
      children:
        - type: ComputePathToSubgoal
          name: ComputePath
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.nav.global_planner import GlobalPlan, GlobalPlanner, GlobalPlannerConfig


class ComputePathToSubgoal(SemExpBehaviour):
    READS = ("subgoal", "local_map")
    WRITES = ("global_plan", "nav_failure")

    replan_period_s: float = param(
        "float", doc="replan at most this often when the costmap changed, s", default=1.0, gt=0.0
    )
    max_plan_age_s: float = param("float", doc="replan anyway after this long, s", default=4.0, gt=0.0)
    goal_tolerance_m: float = param(
        "float",
        doc="passable cells this close to the subgoal are goals, m (0.8: with FollowPath's 0.15 m at the "
        "path's end, the robot stops within r_s = 1 m of a subgoal on an object)",
        default=0.8,
        gt=0.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.planner = GlobalPlanner(GlobalPlannerConfig(goal_tolerance_m=self.goal_tolerance_m))
        self._plan: GlobalPlan | None = None
        self._for: tuple[float, float] | None = None

    def initialise(self) -> None:
        self._plan = None
        self._for = None
        self.write("nav_failure", None)

    def _due(self, goal_xy: tuple[float, float], revision: int) -> bool:
        plan, now = self._plan, self.now_s()
        if plan is None or goal_xy != self._for:
            return True
        if has_elapsed(since_s=plan.stamp_s, now_s=now, duration_s=self.max_plan_age_s):
            return True
        return revision != plan.revision and has_elapsed(
            since_s=plan.stamp_s, now_s=now, duration_s=self.replan_period_s
        )

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        costmap = self.read("local_map")
        if subgoal is None or costmap is None:
            self.feedback_message = "no subgoal" if subgoal is None else "no costmap"
            return py_trees.common.Status.FAILURE
        goal_xy = (float(subgoal.position_m[0]), float(subgoal.position_m[1]))
        if self._due(goal_xy, costmap.revision):
            pose = self.services.robot.base_pose()
            with self.timed("global_path"):
                plan = self.planner.plan(
                    costmap, start_xy=(pose.x_m, pose.y_m), goal_xy=goal_xy, stamp_s=self.now_s()
                )
            self._plan, self._for = plan, goal_xy
            self.write("global_plan", plan)
            if not plan.ok:
                self.write("nav_failure", plan.status)
                self.services.log_event(plan.status, node_id=subgoal.node_id)
                self.feedback_message = f"{plan.status}: no plan reaches node {subgoal.node_id}"
                return py_trees.common.Status.FAILURE
        assert self._plan is not None
        self.feedback_message = f"plan {self._plan.length_m:.1f} m (revision {self._plan.revision})"
        return (
            py_trees.common.Status.RUNNING
            if math.isfinite(self._plan.length_m)
            else py_trees.common.Status.FAILURE
        )
