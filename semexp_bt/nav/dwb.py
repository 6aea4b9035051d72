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
   - ``smooth``: the change of yaw rate from the last command (a soft preference for steady turns);
   - ``stall``: standing still while the path is not done;

   and, as Nav2's OscillationCritic does, refuses outright a turn (or drive) direction that would flip back
   a direction change made since the robot last turned ``oscillation_reset_angle_rad`` or moved
   ``oscillation_reset_dist_m`` (:class:`OscillationGuard`): a left turn refused, a right turn taken, then
   the left turn admissible again is a dither the scores alone cannot break;

4. commands the best one's first twist, regulated by its clearance.

With nothing admissible (or nothing better than standing still) it reports ``blocked`` and commands zero:
the behaviour tree's recovery takes over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import FloatArray, Pose2D, Twist
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
    oscillation_reset_dist_m: float = 0.05
    """A flipped direction may flip back once the base has moved this far (Nav2's value)."""
    oscillation_reset_angle_rad: float = 0.2
    """... or turned this far (Nav2's value)."""


class OscillationGuard:
    """Nav2's oscillation critic: once a command's turn (or drive) direction flips, the direction it flipped
    from is forbidden until the base has moved ``reset_dist_m`` or turned ``reset_angle_rad`` since the flip.

    Example: a left turn (+w) commanded, then a right turn (-w): left turns are refused until the base has
    turned 0.2 rad (or moved 0.05 m); then either direction is open again.
    """

    def __init__(self, reset_dist_m: float, reset_angle_rad: float) -> None:
        self.reset_dist_m = reset_dist_m
        self.reset_angle_rad = reset_angle_rad
        self.reset()

    def reset(self) -> None:
        self._last_sign = np.zeros(2)  # the last non-zero sign of (v, w)
        self._forbidden = np.zeros(2)  # the sign of (v, w) that may not come back yet, 0 for none
        self._flip_pose: Pose2D | None = None

    def forbidden(self, pose: Pose2D, targets: FloatArray) -> npt.NDArray[np.bool_]:
        """A ``(K,)`` mask of the ``(K, 2)`` (v, w) targets that would flip a direction back too soon (a
        guard the base has moved or turned past at ``pose`` is forgotten first)."""
        if self._flip_pose is not None:
            moved = math.hypot(pose.x_m - self._flip_pose.x_m, pose.y_m - self._flip_pose.y_m)
            turned = abs(math.remainder(pose.yaw_rad - self._flip_pose.yaw_rad, math.tau))
            if moved >= self.reset_dist_m or turned >= self.reset_angle_rad:
                self._forbidden[:] = 0.0
                self._flip_pose = None
        signs = np.where(np.abs(targets) > _MOTION_EPS, np.sign(targets), 0.0)
        return ((signs == self._forbidden) & (self._forbidden != 0.0)).any(axis=1)

    def commanded(self, pose: Pose2D, twist: Twist) -> None:
        """Note the command sent at ``pose``: a direction that flipped starts a guard."""
        for axis, value in enumerate((twist.linear_x_mps, twist.angular_z_radps)):
            if abs(value) <= _MOTION_EPS:
                continue
            sign = math.copysign(1.0, value)
            if self._last_sign[axis] == -sign:
                self._forbidden[axis] = -sign
                self._flip_pose = pose
            self._last_sign[axis] = sign


_MOTION_EPS = 1e-6


class DwbController:
    """DWB-style trajectory sampling (see the module docstring)."""

    name = "dwb"

    def __init__(self, config: DwbConfig | None = None) -> None:
        self.config = config or DwbConfig()
        self._last = Twist.zero()
        self._progress = 0
        self._path_id: int | None = None
        self.oscillation = OscillationGuard(
            self.config.oscillation_reset_dist_m, self.config.oscillation_reset_angle_rad
        )

    def reset(self) -> None:
        self._last = Twist.zero()
        self._progress = 0
        self._path_id = None
        self.oscillation.reset()

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
        ok = np.logical_and(ok, ~self.oscillation.forbidden(pose, targets))
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
        self.oscillation.commanded(pose, twist)
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
