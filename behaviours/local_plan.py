"""LocalPlan: obstacle-aware local planning from the head camera's depth toward the subgoal.

Semantics:

- RUNNING: while driving toward the subgoal, or while turning in place to face it on arrival.
- SUCCESS: within ``arrival_radius_m`` of the subgoal, at the end of the mapped path, as close as the
  live depth lets it get to the path's end, or when the planner reports arrival on the last leg; in each
  case only once it faces the subgoal, so that the perception that follows looks at it.
- FAILURE: no subgoal is set; the planner has reported "blocked" for longer than ``blocked_timeout_s``;
  or the map has had no path to the subgoal for longer than ``no_path_timeout_s`` (a ``no_path`` event).
- When it ends, and when it is halted, it commands a zero twist.

Reads ``subgoal`` and ``local_map``; writes ``plan`` (the planner's last PlanResult), ``cmd_twist``,
``cmd_stamp_s`` and ``local_map`` (the frames added).

Every tick it receives (the tree runs it behind a 12 Hz RateLimiter), it reads the latest depth frame;
every ``map_period_s`` (4 Hz by default) it also adds that frame to the occupancy map (``local_map``).
Every ``replan_period_s`` it recomputes the shortest path on that map to the subgoal (or to the reachable
point nearest it, for a subgoal on an object's surface). It then asks the depth-only local planner for
(v, omega) toward the path point ``lookahead_m`` ahead, or toward the subgoal itself on the last leg, and
follows the mapped path by pure pursuit while that arc keeps clear of what the camera sees now. The map
knows the way round walls seen earlier; the local planner keeps the robot clear of what it sees now.

Why the map updates more slowly than the planner: the map only feeds the path, recomputed once a
second, and adding a frame costs about as much as a planning step. Nav2's costmaps are updated the same
way, below the controller's rate (by default 1 Hz for the global costmap, 5 Hz for the local one).

Example (in subtrees/execute.yaml it sits under a 12 Hz ``RateLimiter``):
    - type: LocalPlan
      name: LocalPlan
      params: {arrival_radius_m: 0.7, map_period_s: 0.25}
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.rate_limiter import CLOCK_TOLERANCE_S, next_due_s
from behaviours.spec import param
from semexp_bt.core.geometry import world_to_base
from semexp_bt.core.types import PixelGrid, Pose2D, Twist
from semexp_bt.nav.local_map import OccupancyMap, lookahead_point
from semexp_bt.nav.planner import LocalPlanner, arc_points


def base_footprint_to_world(pose: Pose2D) -> np.ndarray:
    """4x4 transform of the planar base frame (origin on the floor under the base) to ``map``."""
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    out[0, 3], out[1, 3] = pose.x_m, pose.y_m
    return out


def depth_pixel_grids(planner: LocalPlanner, local_map: OccupancyMap | None) -> list[PixelGrid] | None:
    """The depth pixels the planner and the map read, for ``Robot.observe_depth``; None: the whole frame.

    A simulated camera casts rays at only these pixels instead of rasterising the frame.
    """
    planner_pixels = planner.sampled_pixels
    if planner_pixels is None:
        return None
    return [planner_pixels] if local_map is None else [planner_pixels, local_map.sampled_pixels]


def pure_pursuit(goal_base: tuple[float, float], *, max_speed_mps: float) -> Twist:
    """Pure pursuit toward a point in the base frame: turn in place when it is far off the heading."""
    bearing = math.atan2(goal_base[1], goal_base[0])
    distance = math.hypot(*goal_base)
    if abs(bearing) > 0.7:
        return Twist(angular_z_radps=math.copysign(0.8, bearing))
    curvature = 2.0 * goal_base[1] / max(distance * distance, 1e-6)
    speed = max_speed_mps * max(0.3, math.cos(bearing) ** 2)
    yaw_rate = max(-1.0, min(1.0, curvature * speed))
    return Twist(linear_x_mps=speed, angular_z_radps=yaw_rate)


def arc_is_clear(
    twist: Twist, obstacles_xy: np.ndarray, *, clearance_m: float, max_length_m: float, horizon_s: float = 1.5
) -> bool:
    """Whether the arc the twist sweeps in ``horizon_s`` (but no farther than ``max_length_m``, the way
    left to the aim point) stays ``clearance_m`` from every obstacle point."""
    if obstacles_xy is None or len(obstacles_xy) == 0:
        return True
    if twist.linear_x_mps <= 0.0:
        return True  # turning in place sweeps no new ground
    length = max(min(twist.linear_x_mps * horizon_s, max_length_m), 0.05)
    curvature = twist.angular_z_radps / twist.linear_x_mps
    samples = arc_points(curvature_1pm=curvature, arclength_m=np.linspace(0.0, length, 16))
    gaps = np.linalg.norm(samples[:, None, :] - np.asarray(obstacles_xy)[None, :, :2], axis=2)
    return bool(gaps.min() >= clearance_m)


class LocalPlan(SemExpBehaviour):
    READS = ("subgoal", "local_map")
    WRITES = ("plan", "cmd_twist", "cmd_stamp_s", "local_map")
    arrival_radius_m: float = param(
        "float", doc="SUCCESS within this distance of the subgoal, m", default=0.7, gt=0.0
    )
    blocked_timeout_s: float = param(
        "float", doc="FAILURE after being blocked this long, s", default=6.0, gt=0.0
    )
    replan_period_s: float = param(
        "float", doc="recompute the path on the occupancy map this often, s", default=1.0, gt=0.0
    )
    map_period_s: float = param(
        "float",
        doc="add a depth frame to the occupancy map at most this often, s (0: every planning cycle)",
        default=0.25,
        ge=0.0,
    )
    lookahead_m: float = param(
        "float", doc="the local planner aims at the path point this far ahead, m", default=1.2, gt=0.0
    )
    no_path_timeout_s: float = param(
        "float",
        doc="FAILURE when the map has had no path to the subgoal for this long, s",
        default=4.0,
        gt=0.0,
    )

    #: Pure-pursuit speed along a mapped path, and the clearance its arc must keep from live depth points.
    pursuit_speed_mps = 0.6
    pursuit_clearance_m = 0.38
    #: On arrival the robot turns until the subgoal is within this bearing (the camera's half view is 0.48 rad).
    facing_tolerance_rad = 0.3
    #: A path this short whose pursuit arc is not clear counts as arrival (nothing closer is safe).
    close_enough_m = 0.6

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._blocked_since: float | None = None
        self._path: np.ndarray | None = None
        self._planned_at = -math.inf
        self._map_due_s: float | None = None
        self._planned_for: tuple[float, float, float] | None = None
        self._no_path_since: float | None = None

    def initialise(self) -> None:
        self._blocked_since = None
        self._path = None
        self._planned_at = -math.inf
        self._map_due_s = None
        self._no_path_since = None

    def _global_path(
        self, pose: Pose2D, goal_xy: tuple[float, float], subgoal_key: tuple
    ) -> np.ndarray | None:
        """The occupancy-map path to the subgoal, recomputed every ``replan_period_s`` or on a new subgoal."""
        local_map = self.read("local_map")
        if local_map is None:
            return None
        now = self.now_s()
        if subgoal_key != self._planned_for or now - self._planned_at >= self.replan_period_s:
            with self.timed("global_path"):
                self._path = local_map.path((pose.x_m, pose.y_m), goal_xy)
            self._planned_at, self._planned_for = now, subgoal_key
        return self._path

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        if subgoal is None:
            self.feedback_message = "no subgoal"
            return py_trees.common.Status.FAILURE
        robot = self.services.robot
        pose = robot.base_pose()
        goal_xy = (subgoal.position_m[0], subgoal.position_m[1])
        if math.hypot(goal_xy[0] - pose.x_m, goal_xy[1] - pose.y_m) <= self.arrival_radius_m:
            return self._arrive(pose, goal_xy, "arrived")
        with self.timed("planner"):
            local_map = self.read("local_map")
            now = self.now_s()
            map_due = self._map_due_s is None or now >= self._map_due_s - CLOCK_TOLERANCE_S
            mapping = local_map if map_due else None
            frame = robot.observe_depth(pixel_grids=depth_pixel_grids(self.services.planner, mapping))
            if mapping is not None:
                mapping.integrate(frame)
                self._map_due_s = next_due_s(due_s=self._map_due_s, now_s=now, period_s=self.map_period_s)
            path = self._global_path(pose, goal_xy, (subgoal.node_id, *subgoal.position_m[:2]))
            # Aim at a point a little way along the mapped path (the map knows the way round walls seen
            # earlier); with no map, or no path on it yet, aim straight at the subgoal.
            final_leg = True
            aim = np.asarray(goal_xy)
            if path is not None:
                self._no_path_since = None
                path_end = path[-1]
                remaining = (
                    float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) if len(path) > 1 else 0.0
                )
                if remaining <= 0.15:
                    return self._arrive(
                        pose,
                        goal_xy,
                        f"arrived at the nearest reachable point, {math.dist(path_end, goal_xy):.2f} m away",
                    )
                # The path ends at a cell the robot can stand on next to the subgoal: aim along it to the
                # very end, never at the subgoal itself (which may sit on an object's surface).
                aim = lookahead_point(path, distance_m=self.lookahead_m)
                final_leg = False
            elif local_map is not None:
                if self._no_path_since is None:
                    self._no_path_since = self.now_s()
                elif self.now_s() - self._no_path_since > self.no_path_timeout_s:
                    self.command(Twist.zero())
                    self.feedback_message = "no path to the subgoal on the map"
                    self.services.log_event("no_path", node_id=subgoal.node_id)
                    return py_trees.common.Status.FAILURE
            goal_base = world_to_base(aim, pose)
            camera_to_base = np.linalg.inv(base_footprint_to_world(frame.base_pose)) @ frame.camera_to_world
            result = self.services.planner.plan(
                depth_m=frame.depth_m,
                intrinsics=frame.intrinsics,
                camera_to_base=camera_to_base,
                goal_base_xy=goal_base,
                stamp_s=self.now_s(),
                base_pose=pose,
            )
            twist = result.twist
            if path is not None:
                # The mapped path already keeps the robot's radius from every obstacle seen so far:
                # follow it (pure pursuit), and let the local planner's command stand only when the
                # pursuit arc would pass closer than the robot's radius to what the camera sees now.
                pursuit = pure_pursuit(goal_base, max_speed_mps=self.pursuit_speed_mps)
                if arc_is_clear(
                    pursuit,
                    result.obstacle_points_xy,
                    clearance_m=self.pursuit_clearance_m,
                    max_length_m=math.hypot(*goal_base),
                ):
                    twist = pursuit
                elif remaining <= self.close_enough_m:
                    # The last few decimetres of the path would take the robot closer to what it sees now
                    # than its clearance allows: this is as close as it safely gets.
                    return self._arrive(
                        pose, goal_xy, f"as close as it is safe, {remaining:.2f} m short of the path end"
                    )
        self.write("plan", result)
        self.command(twist)
        self.feedback_message = (
            f"{result.status} d={math.dist(goal_xy, (pose.x_m, pose.y_m)):.2f} m v={twist.linear_x_mps:.2f}"
            + ("" if path is None else f" path {len(path)} cells")
        )
        if result.status == "arrived" and final_leg:
            return self._arrive(pose, goal_xy, "arrived")
        if result.status == "blocked":
            if self._blocked_since is None:
                self._blocked_since = self.now_s()
            elif self.now_s() - self._blocked_since > self.blocked_timeout_s:
                return py_trees.common.Status.FAILURE
        else:
            self._blocked_since = None
        return py_trees.common.Status.RUNNING

    def _arrive(self, pose: Pose2D, goal_xy: tuple[float, float], note: str) -> py_trees.common.Status:
        """Arrival: turn in place to face the subgoal first, so the next perception looks at it."""
        # math.remainder, not core wrap_angle: the two round differently, and the swap changes episodes.
        bearing = math.remainder(
            math.atan2(goal_xy[1] - pose.y_m, goal_xy[0] - pose.x_m) - pose.yaw_rad, math.tau
        )
        if abs(bearing) > self.facing_tolerance_rad:
            self.command(
                Twist(angular_z_radps=math.copysign(max(0.3, min(0.8, 1.5 * abs(bearing))), bearing))
            )
            self.feedback_message = f"{note}; turning to face the subgoal ({math.degrees(bearing):.0f} deg)"
            return py_trees.common.Status.RUNNING
        self.command(Twist.zero())
        self.feedback_message = note
        return py_trees.common.Status.SUCCESS

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status != py_trees.common.Status.RUNNING:
            self.command(Twist.zero())
