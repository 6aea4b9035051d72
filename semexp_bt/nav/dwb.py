"""A DWB-style controller: sample twists, roll them out, drop the unsafe, score the rest with critics.

Nav2's DWB samples velocities in the dynamic window, simulates each for a short horizon and sums
*critics* (obstacle cost, distance to the path, distance to the goal, alignment, oscillation). This one:

1. samples ``speeds`` x ``yaw_rates`` constant targets (pure rotations and, where what lies behind is
   known free, backward motions included) and rolls each out at the acceleration limits
   (:func:`~semexp_bt.nav.controller.rollout`), ``horizon_s`` ahead at ``dt_s``;
2. drops every trajectory the safety rules refuse (:func:`~semexp_bt.nav.controller.admissible`: the
   oriented footprint at every state, unseen space, backing up);
3. scores the others, lower is better:

   - ``progress``: the rise of the global plan's navigation function from now to the trajectory's end,
     per metre the fastest trajectory could cover (Nav2's GoalDist and PathDist in one: the navigation
     function is the distance to the goal *along the plan*, obstacles and unknown space priced in);
   - ``path``: mean distance of the states from the next stretch of the path (stay on it);
   - ``align``: the heading at the end against the path's direction ahead (look where it goes: the
     camera only sees forward);
   - ``obstacle``: mean of ``exp(-obstacle_decay (clearance - min_clearance))`` over the states;
   - ``smooth``: the change of yaw rate from the last command (no dithering, Nav2's oscillation critic);
   - ``stall``: standing still while the path is not done;

4. commands the best one's first twist, regulated by its clearance.

With nothing admissible (or nothing better than standing still) it reports ``blocked`` and commands zero:
the behaviour tree's recovery takes over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from semexp_bt.core.types import FloatArray, Pose2D, Twist
from semexp_bt.nav.controller import (
    ControlResult,
    ControlStatus,
    MotionLimits,
    SafetyRules,
    admissible,
    path_progress_index,
    regulate,
    rollout,
)
from semexp_bt.nav.costmap import Costmap
from semexp_bt.nav.global_planner import GlobalPlan


@dataclass(frozen=True)
class DwbConfig:
    """Every constant of :class:`DwbController`."""

    limits: MotionLimits = field(default_factory=MotionLimits)
    rules: SafetyRules = field(default_factory=SafetyRules)
    speeds: int = 9
    """Forward speed samples in [0, max] (0 gives pure rotations)."""
    reverse_speeds: int = 2
    """Backward speed samples in [-max_reverse, 0)."""
    yaw_rates: int = 17
    """Yaw-rate samples in [-max, max]."""
    horizon_s: float = 1.6
    dt_s: float = 0.1
    weight_progress: float = 10.0
    weight_path: float = 2.0
    weight_align: float = 1.5
    weight_obstacle: float = 1.0
    weight_smooth: float = 0.3
    weight_stall: float = 1.0
    """Cost of standing still (the path is not done: some motion must be better than none)."""
    obstacle_decay: float = 4.0
    """1/m: how fast the obstacle critic falls off with clearance."""
    path_lookahead_points: int = 30
    """The path critic looks at this many path points ahead of the robot (planning cells: 3 m)."""
    align_lookahead_m: float = 0.6
    """The path direction for the align critic: from the nearest path point to this far along."""
    approach_gain: float = 0.8
    """Near the end of the path the speed is capped at this x the distance left (m/s per m)."""
    min_approach_speed_mps: float = 0.15


class DwbController:
    """DWB-style trajectory sampling (see the module docstring)."""

    name = "dwb"

    def __init__(self, config: DwbConfig | None = None) -> None:
        self.config = config or DwbConfig()
        self._last = Twist.zero()
        self._progress = 0
        self._path_id: int | None = None

    def reset(self) -> None:
        self._last = Twist.zero()
        self._progress = 0
        self._path_id = None

    def _targets(self, max_forward: float) -> FloatArray:
        cfg, lim = self.config, self.config.limits
        forward = np.linspace(0.0, max_forward, cfg.speeds)
        backward = -np.linspace(lim.max_reverse_mps, 0.0, cfg.reverse_speeds, endpoint=False)
        speeds = np.concatenate([backward, forward])
        rates = np.linspace(-lim.max_yaw_rate_radps, lim.max_yaw_rate_radps, cfg.yaw_rates)
        v, w = np.meshgrid(speeds, rates, indexing="ij")
        return np.stack([v.ravel(), w.ravel()], axis=1)

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
        max_forward = min(
            cfg.limits.max_speed_mps, max(cfg.min_approach_speed_mps, cfg.approach_gain * remaining)
        )
        targets = self._targets(max_forward)
        states, commands = rollout(
            pose, velocity, targets, limits=cfg.limits, horizon_s=cfg.horizon_s, dt_s=cfg.dt_s
        )
        ok, least = admissible(costmap, pose, states, commands, rules=cfg.rules)
        if not ok.any():
            self._last = Twist.zero()
            return ControlResult(Twist.zero(), "blocked", candidates=(len(targets), 0))
        idx = np.flatnonzero(ok)
        st = states[idx]
        # progress along the navigation function
        ctg_now = float(plan.cost_to_go_at(here))
        ctg_end = plan.cost_to_go_at(st[:, -1, :2])
        fallback = np.hypot(st[:, -1, 0] - path[-1, 0], st[:, -1, 1] - path[-1, 1])
        if not math.isfinite(ctg_now):
            ctg_now = float(np.hypot(*(here - path[-1])))
        ctg_end = np.where(np.isfinite(ctg_end), ctg_end, ctg_now + fallback)
        reach = max(cfg.limits.max_speed_mps * cfg.horizon_s, 1e-6)
        progress = (ctg_end - ctg_now) / reach
        # distance from the path ahead
        ahead = path[self._progress : self._progress + cfg.path_lookahead_points]
        gaps = np.hypot(st[..., 0, None] - ahead[:, 0], st[..., 1, None] - ahead[:, 1]).min(axis=-1)
        path_cost = gaps.mean(axis=1)
        # heading at the end against the path direction ahead
        direction = _path_direction(path, self._progress, cfg.align_lookahead_m, here)
        align = np.abs(np.remainder(st[:, -1, 2] - direction + math.pi, math.tau) - math.pi) / math.pi
        clearance_states = least[idx]
        obstacle = np.exp(-cfg.obstacle_decay * np.maximum(clearance_states - cfg.rules.min_clearance_m, 0.0))
        smooth = np.abs(targets[idx, 1] - self._last.angular_z_radps) / max(
            cfg.limits.max_yaw_rate_radps, 1e-6
        )
        total = (
            cfg.weight_progress * progress
            + cfg.weight_path * path_cost
            + cfg.weight_align * align
            + cfg.weight_obstacle * obstacle
            + cfg.weight_smooth * smooth
            + cfg.weight_stall * ((np.abs(targets[idx, 0]) < 1e-6) & (np.abs(targets[idx, 1]) < 1e-6))
        )
        best = int(np.argmin(total))
        k = idx[best]
        v, w = regulate(float(targets[k, 0]), float(targets[k, 1]), float(least[k]), rules=cfg.rules)
        twist = Twist(linear_x_mps=v, angular_z_radps=w)
        self._last = twist
        status: ControlStatus
        if abs(v) < 1e-6 and abs(w) < 1e-6:
            status = "blocked"  # standing still is the best there is: no admissible motion helps
        else:
            status = "rotating" if abs(v) < 1e-6 else "tracking"
        scores = {
            "progress": float(progress[best]),
            "path": float(path_cost[best]),
            "align": float(align[best]),
            "obstacle": float(obstacle[best]),
            "smooth": float(smooth[best]),
            "remaining_m": float(remaining),
        }
        return ControlResult(twist, status, float(least[k]), states[k], scores, (len(targets), int(ok.sum())))


def _remaining_length(path: FloatArray, index: int, here: FloatArray) -> float:
    """Path length left from ``here`` (via the path point ``index``) to the end."""
    tail = path[index:]
    if len(tail) == 0:
        return 0.0
    return float(np.hypot(*(tail[0] - here)) + np.hypot(*np.diff(tail, axis=0).T).sum())


def _path_direction(path: FloatArray, index: int, lookahead_m: float, here: FloatArray) -> float:
    """Heading (rad) from ``here`` toward the path point ``lookahead_m`` along from ``index`` (the last point
    when the path is shorter)."""
    tail = path[index:]
    if len(tail) < 2:
        target = path[-1]
    else:
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(tail, axis=0).T))])
        target = tail[min(int(np.searchsorted(along, lookahead_m)), len(tail) - 1)]
    delta = target - here
    if float(np.hypot(*delta)) < 1e-6:
        delta = path[-1] - path[max(0, len(path) - 2)]
    return math.atan2(float(delta[1]), float(delta[0]))
