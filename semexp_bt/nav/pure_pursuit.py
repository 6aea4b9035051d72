"""Regulated pure pursuit (Macenski et al., 2023; Nav2's ``nav2_regulated_pure_pursuit_controller``).

Per cycle:

1. the lookahead point: the path point ``lookahead_time_s`` x the current speed ahead of the robot's
   nearest path point, between ``min_lookahead_m`` and ``max_lookahead_m``;
2. if it lies more than ``rotate_to_heading_rad`` off the heading, rotate in place toward it (Nav2's
   ``use_rotate_to_heading``) when the rotation is admissible;
3. else the pure-pursuit curvature ``2 y / L^2`` toward it, at ``max_speed_mps`` regulated down by the
   curvature (radius below ``regulated_min_radius_m``), by the approach to the path's end and by the
   clearance (:func:`~semexp_bt.nav.controller.regulate`);
4. the arc of that twist is rolled out for ``collision_horizon_s`` and checked by the safety rules; when
   it is refused, at half and at a quarter of the speed.

Where Nav2's controller stops (every pursuit motion refused, typically a turn in place that would sweep
a corner of the long Go1 body into a wall), this one hands the cycle to the DWB sampler
(:class:`~semexp_bt.nav.dwb.DwbController`), which searches every admissible arc, backward ones onto
known free cells included: a three-point turn out of a tight spot instead of a stop. ``blocked`` only
when that search finds nothing either. The search keeps its own oscillation guard
(:class:`~semexp_bt.nav.dwb.OscillationGuard`); pursuit's commands do not go through it (sharing it
was measured and not kept: docs/planner.md, fifth round).

"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.control_result import ControlResult, ControlStatus
from semexp_bt.nav.controller import (
    MotionLimits,
    SafetyRules,
    admissible,
    path_progress_index,
    regulate,
    rollout,
)
from semexp_bt.nav.costmap import Costmap
from semexp_bt.nav.dwb import DwbConfig, DwbController, _remaining_length
from semexp_bt.nav.global_planner import GlobalPlan


@dataclass(frozen=True)
class PurePursuitConfig:
    """Every constant of :class:`RegulatedPurePursuit` (Nav2's parameter names where there is one)."""

    limits: MotionLimits = field(default_factory=MotionLimits)
    rules: SafetyRules = field(default_factory=SafetyRules)
    lookahead_time_s: float = 1.5
    min_lookahead_m: float = 0.5
    max_lookahead_m: float = 1.2
    rotate_to_heading_rad: float = 0.8
    rotate_gain: float = 1.5
    min_rotate_rate_radps: float = 0.4
    regulated_min_radius_m: float = 0.9
    approach_gain: float = 0.8
    min_approach_speed_mps: float = 0.15
    collision_horizon_s: float = 1.5
    dt_s: float = 0.1


class RegulatedPurePursuit:
    """Regulated pure pursuit (see the module docstring)."""

    name = "rpp"

    def __init__(self, config: PurePursuitConfig | None = None) -> None:
        self.config = config or PurePursuitConfig()
        self._progress = 0
        self._path_id: int | None = None
        self._fallback = DwbController(DwbConfig(limits=self.config.limits, rules=self.config.rules))

    def reset(self) -> None:
        self._progress = 0
        self._path_id = None
        self._fallback.reset()

    def compute(
        self, *, plan: GlobalPlan, costmap: Costmap, pose: Pose2D, velocity: Twist, stamp_s: float
    ) -> ControlResult:
        cfg = self.config
        path = plan.path_xy
        if not plan.ok or len(path) == 0:
            return ControlResult(Twist.zero(), "blocked")
        if self._path_id != id(plan):
            self._path_id, self._progress = id(plan), 0
        here = np.array([pose.x_m, pose.y_m])
        self._progress = path_progress_index(path, here, self._progress)
        remaining = _remaining_length(path, self._progress, here)
        lookahead = float(
            np.clip(
                abs(velocity.linear_x_mps) * cfg.lookahead_time_s, cfg.min_lookahead_m, cfg.max_lookahead_m
            )
        )
        target = _point_along(path, self._progress, lookahead)
        c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
        dx, dy = target - here
        fwd, left = c * dx + s * dy, -s * dx + c * dy
        bearing = math.atan2(left, fwd)
        distance = math.hypot(fwd, left)
        if abs(bearing) > cfg.rotate_to_heading_rad or distance < 1e-3:
            rate = math.copysign(
                min(
                    cfg.limits.max_yaw_rate_radps,
                    max(cfg.min_rotate_rate_radps, cfg.rotate_gain * abs(bearing)),
                ),
                bearing,
            )
            result = self._checked(costmap, pose, velocity, [(0.0, rate)], "rotating")
            return (
                result if result.status != "blocked" else self._search(plan, costmap, pose, velocity, stamp_s)
            )
        curvature = 2.0 * left / max(distance * distance, 1e-6)
        speed = cfg.limits.max_speed_mps
        radius = 1.0 / max(abs(curvature), 1e-9)
        if radius < cfg.regulated_min_radius_m:
            speed *= radius / cfg.regulated_min_radius_m
        speed = min(speed, max(cfg.min_approach_speed_mps, cfg.approach_gain * remaining))
        rate = speed * curvature
        if abs(rate) > cfg.limits.max_yaw_rate_radps:
            speed *= cfg.limits.max_yaw_rate_radps / abs(rate)
            rate = math.copysign(cfg.limits.max_yaw_rate_radps, rate)
        options = [(speed * f, rate * f) for f in (1.0, 0.5, 0.25)]
        result = self._checked(costmap, pose, velocity, options, "tracking")
        return result if result.status != "blocked" else self._search(plan, costmap, pose, velocity, stamp_s)

    def _search(
        self, plan: GlobalPlan, costmap: Costmap, pose: Pose2D, velocity: Twist, stamp_s: float
    ) -> ControlResult:
        """When pursuit's own motions are all refused: search every admissible arc (the DWB sampler)."""
        return self._fallback.compute(
            plan=plan, costmap=costmap, pose=pose, velocity=velocity, stamp_s=stamp_s
        )

    def _checked(
        self,
        costmap: Costmap,
        pose: Pose2D,
        velocity: Twist,
        options: list[tuple[float, float]],
        status: ControlStatus,
    ) -> ControlResult:
        """The first admissible option, regulated by its clearance; ``blocked`` when none is."""
        cfg = self.config
        targets = np.asarray(options, dtype=float)
        states, commands = rollout(
            pose, velocity, targets, limits=cfg.limits, horizon_s=cfg.collision_horizon_s, dt_s=cfg.dt_s
        )
        ok, least = admissible(costmap, pose, states, commands, rules=cfg.rules)
        for k in range(len(options)):
            if ok[k]:
                v, w = regulate(float(targets[k, 0]), float(targets[k, 1]), float(least[k]), rules=cfg.rules)
                return ControlResult(Twist(linear_x_mps=v, angular_z_radps=w), status, float(least[k]), states[k],
                                     {"option": float(k)}, (len(options), int(ok.sum())))  # fmt: skip
        return ControlResult(Twist.zero(), "blocked", candidates=(len(options), 0))


def _point_along(path: np.ndarray, index: int, distance_m: float) -> np.ndarray:
    """The point ``distance_m`` along the path from the point ``index`` (its end when shorter)."""
    tail = path[index:]
    if len(tail) < 2:
        return path[-1]
    seg = np.hypot(*np.diff(tail, axis=0).T)
    along = np.concatenate([[0.0], np.cumsum(seg)])
    if along[-1] <= distance_m:
        return tail[-1]
    i = int(np.searchsorted(along, distance_m) - 1)
    t = (distance_m - along[i]) / max(seg[i], 1e-9)
    return tail[i] + t * (tail[i + 1] - tail[i])
