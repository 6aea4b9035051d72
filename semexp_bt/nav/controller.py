"""What every path-following controller shares: the protocol, the oriented-footprint check, rollouts.

A controller turns the global plan, the costmap and the robot's pose and velocity into one twist per
cycle (12 Hz). Two are implemented and were compared by measurement (``docs/planner.md``):
:class:`~semexp_bt.nav.dwb.DwbController` (Nav2 DWB-style trajectory sampling) and
:class:`~semexp_bt.nav.pure_pursuit.RegulatedPurePursuit` (Nav2's regulated pure pursuit). Both obey the
same safety rules, stated and checked here:

- **The oriented footprint, at every sampled state.** A state's clearance is the distance from the
  Go1's rectangle to the nearest lethal cell, from the costmap's distance field at points along its
  outline and centre line (:attr:`Footprint.clearance_points`; the disc cover of the first round
  overshot the sides by 2.5 cm, so the narrowest drivable passage was 0.62 m instead of 0.56 m). A motion
  whose states come closer than ``min_clearance_m`` is never commanded; a robot that already stands
  closer (it was pushed, or the map just learnt of an obstacle) may only move so that its clearance
  does not shrink.
- **Unseen space only within an allowance**: a forward motion may carry the base centre through at most
  ``unknown_allowance_m`` of never-observed cells (the camera cannot see the floor right in front of the
  head; after a turn that band is unknown).
- **Backing up only onto known free cells**: every disc of every state of a backward motion must lie on
  observed cells (the camera does not look back; the footprint's own trail is known free).
- **Turning only through observed space**: every point of the footprint's outline, at every state, that
  leaves the *forward corridor* of the current pose (the band the body would cover walking straight on)
  must lie on observed cells. A turn in place or a tight arc swings the long body's corners sideways, over
  floor beside the robot that the narrow camera (54 degrees across, blind to the floor within 0.8 m of
  the base) may never have seen: an obstacle there is absent from the costmap, not lethal, so the
  clearance rule alone lets a corner sweep into it (the remaining contacts of ``ours`` in the first
  round). The flank depth cameras (``robots/side_depth.py``), where the robot has them, observe that
  floor, so the rule then refuses only what nothing has seen. Straight ahead the unknown band in front
  of the head is what the unseen-space allowance governs; the start pose's turning circle is assumed
  free (:meth:`Costmap.assume_free_around`).
- **Speed regulated by clearance**: below ``slow_clearance_m`` the speed is scaled down linearly to
  ``creep_fraction`` at ``min_clearance_m``, with the yaw rate, so the motion stays on the checked arc.
- **Within what the gait tracks**: |v| <= 1 m/s forward, 0.5 m/s back, |omega| <= 1 rad/s (docs/gait.md),
  and accelerations within the kinematic base's limits, so the rollouts are what the base will do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import FloatArray, Pose2D, Twist
from semexp_bt.nav.control_result import ControlResult
from semexp_bt.nav.costmap import Costmap
from semexp_bt.nav.footprint import transform_points
from semexp_bt.nav.global_planner import GlobalPlan

#: The covering discs overshoot the Go1's rectangle by at most this much (3.4 cm at the ends), so their
#: clearance is within it of the rectangle's own.
DISC_OVERSHOOT_BOUND_M = 0.04
#: Below this disc clearance (m) the exact outline clearance is computed: the slow-down band
#: (``SafetyRules.slow_clearance_m``, 0.45 m) plus the overshoot bound.
EXACT_CLEARANCE_BELOW_M = 0.49


@dataclass(frozen=True)
class MotionLimits:
    """Command and acceleration limits (the Go1 gait's tracking envelope and the base's acceleration)."""

    max_speed_mps: float = 0.8
    max_reverse_mps: float = 0.3
    max_yaw_rate_radps: float = 1.0
    accel_mps2: float = 2.0
    yaw_accel_radps2: float = 4.0


@dataclass(frozen=True)
class SafetyRules:
    """The rules every controller obeys (see the module docstring)."""

    min_clearance_m: float = 0.13
    """Least clearance of the footprint to a lethal cell: OASR's 0.1 m plus the cell quantisation."""
    slow_clearance_m: float = 0.45
    """Full speed needs this much clearance; slower below it."""
    creep_fraction: float = 0.35
    """Speed fraction at ``min_clearance_m``."""
    unknown_allowance_m: float = 0.6
    """Travel of the base centre through never-observed cells allowed per trajectory."""
    sweep_observed_only: bool = True
    """Refuse motions whose footprint outline leaves the forward corridor over never-observed cells."""
    outline_spacing_m: float = 0.1
    """Spacing of the outline points that rule checks (two cells)."""


@runtime_checkable
class PathController(Protocol):
    """A controller: (plan, costmap, pose, velocity) -> twist."""

    name: str

    def reset(self) -> None:
        """Forget per-path state (a new subgoal)."""

    def compute(
        self, *, plan: GlobalPlan, costmap: Costmap, pose: Pose2D, velocity: Twist, stamp_s: float
    ) -> ControlResult:
        """The command for this cycle."""
        ...


def footprint_clearance(costmap: Costmap, x: FloatArray, y: FloatArray, yaw: FloatArray) -> FloatArray:
    """Clearance (m) of the oriented footprint to the nearest lethal cell at every pose (arrays of one shape):
    the least distance at its :attr:`~semexp_bt.nav.footprint.Footprint.clearance_points`.

    Ten covering discs give a lower bound cheaply (they overshoot the rectangle by at most
    :data:`DISC_OVERSHOOT_BOUND_M`); the outline points are read only for the poses where that bound is
    below :data:`EXACT_CLEARANCE_BELOW_M`, where the exact value decides admissibility, speed and the
    critics. Farther from everything the bound stands for the value (full speed either way).
    """
    shape = np.shape(x)
    bound = _disc_clearance(costmap, np.ravel(x), np.ravel(y), np.ravel(yaw))
    near = np.flatnonzero(bound < EXACT_CLEARANCE_BELOW_M)
    if near.size:
        points = costmap.footprint.clearance_points
        xs, ys, yaws = np.ravel(x)[near], np.ravel(y)[near], np.ravel(yaw)[near]
        c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
        px = xs[:, None] + c * points[:, 0] - s * points[:, 1]
        py = ys[:, None] + s * points[:, 0] + c * points[:, 1]
        bound[near] = costmap.distance_at(np.stack([px, py], axis=-1)).min(axis=-1)
    return bound.reshape(shape)


def _disc_clearance(costmap: Costmap, x: FloatArray, y: FloatArray, yaw: FloatArray) -> FloatArray:
    """A lower bound of the footprint's clearance from its covering discs, at poses ``(N,)``."""
    centres, radius = costmap.footprint.covering_discs
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    px = x[:, None] + c * centres[:, 0] - s * centres[:, 1]
    py = y[:, None] + s * centres[:, 0] + c * centres[:, 1]
    return np.asarray(costmap.distance_at(np.stack([px, py], axis=-1)).min(axis=-1) - radius)


def discs_known(costmap: Costmap, x: FloatArray, y: FloatArray, yaw: FloatArray) -> npt.NDArray[np.bool_]:
    """Whether every covering disc centre of the footprint lies on observed cells, at every pose."""
    centres, _ = costmap.footprint.covering_discs
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    px = x[..., None] + c * centres[:, 0] - s * centres[:, 1]
    py = y[..., None] + s * centres[:, 0] + c * centres[:, 1]
    return np.asarray(costmap.known_at(np.stack([px, py], axis=-1)).all(axis=-1))


def sweeps_unseen(
    costmap: Costmap, pose: Pose2D, states: FloatArray, *, spacing_m: float
) -> npt.NDArray[np.bool_]:
    """Whether each rollout ``(K, T, 3)`` carries a point of the footprint's outline, outside the forward
    corridor of ``pose``, over a never-observed cell: ``(K,)``.

    The forward corridor is the band the footprint covers moving straight on from ``pose`` (within a cell
    of its sides, from its rear edge forward); inside it, the unseen-space allowance rules.
    """
    fp = costmap.footprint
    outline = fp.outline(spacing_m)
    world = transform_points(outline, states[..., 0], states[..., 1], states[..., 2])  # (K, T, P, 2)
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    dx, dy = world[..., 0] - pose.x_m, world[..., 1] - pose.y_m
    ahead, left = c * dx + s * dy, -s * dx + c * dy
    margin = costmap.resolution_m
    outside = (np.abs(left) > fp.half_width_m + margin) | (ahead < fp.x_min_m - margin)
    if not outside.any():
        return np.zeros(len(states), dtype=bool)
    unseen = outside & ~costmap.known_at(world)
    return np.asarray(unseen.reshape(len(states), -1).any(axis=1))


def rollout(
    pose: Pose2D, velocity: Twist, targets: FloatArray, *, limits: MotionLimits, horizon_s: float, dt_s: float
) -> tuple[FloatArray, FloatArray]:
    """States of ``K`` constant target twists ``(K, 2)`` (v, omega) from the current velocity, ramped at the
    acceleration limits: ``(K, T, 3)`` (x, y, yaw) after each ``dt_s`` up to ``horizon_s``, and the
    commanded (v, omega) at each step ``(K, T, 2)``."""
    steps = max(1, int(round(horizon_s / dt_s)))
    t = dt_s * np.arange(1, steps + 1)
    v0, w0 = velocity.linear_x_mps, velocity.angular_z_radps
    dv = targets[:, 0:1] - v0
    dw = targets[:, 1:2] - w0
    v = v0 + np.sign(dv) * np.minimum(np.abs(dv), limits.accel_mps2 * t)
    w = w0 + np.sign(dw) * np.minimum(np.abs(dw), limits.yaw_accel_radps2 * t)
    yaw = pose.yaw_rad + np.cumsum(w * dt_s, axis=1)
    mid = yaw - 0.5 * w * dt_s
    x = pose.x_m + np.cumsum(v * np.cos(mid) * dt_s, axis=1)
    y = pose.y_m + np.cumsum(v * np.sin(mid) * dt_s, axis=1)
    return np.stack([x, y, yaw], axis=-1), np.stack([v, w], axis=-1)


#: The rules of :func:`admissible`, in the order it applies them (the names :func:`rule_masks` reports).
RULE_NAMES = (
    "keeps clearance",
    "unseen travel within allowance",
    "backs up onto known cells",
    "sweeps observed cells only",
)


def _keeps_clearance(clearance: FloatArray, now_m: float, *, rules: SafetyRules) -> npt.NDArray[np.bool_]:
    """Rollouts ``(K, T)`` of clearances that keep ``min_clearance_m``, or, from inside the margin already
    (``now_m`` below it), never come closer than now, step by step."""
    least = clearance.min(axis=1)
    if now_m >= rules.min_clearance_m:
        return np.asarray(least >= rules.min_clearance_m)
    running = np.minimum.accumulate(
        np.concatenate([np.full((len(clearance), 1), now_m), clearance], axis=1), axis=1
    )
    return np.asarray((clearance >= running[:, :-1] - 1e-4).all(axis=1) | (least >= rules.min_clearance_m))


def _within_unseen_allowance(
    costmap: Costmap, pose: Pose2D, states: FloatArray, *, rules: SafetyRules
) -> npt.NDArray[np.bool_]:
    """Rollouts whose base centre travels at most ``unknown_allowance_m`` through never-observed cells."""
    x, y = states[..., 0], states[..., 1]
    step = np.hypot(np.diff(np.concatenate([np.full((len(states), 1), pose.x_m), x], axis=1), axis=1),
                    np.diff(np.concatenate([np.full((len(states), 1), pose.y_m), y], axis=1), axis=1))  # fmt: skip
    unknown = ~costmap.known_at(np.stack([x, y], axis=-1))
    return np.asarray((step * unknown).sum(axis=1) <= rules.unknown_allowance_m)


def _backs_onto_known(costmap: Costmap, states: FloatArray, commands: FloatArray) -> npt.NDArray[np.bool_]:
    """Rollouts that either never back up or keep every covering disc on observed cells."""
    ok = np.ones(len(states), dtype=bool)
    backward = np.flatnonzero((commands[..., 0] < -1e-3).any(axis=1))
    if backward.size:
        back = states[backward]
        ok[backward] = discs_known(costmap, back[..., 0], back[..., 1], back[..., 2]).all(axis=1)
    return ok


def _clearances(costmap: Costmap, pose: Pose2D, states: FloatArray) -> tuple[FloatArray, float]:
    """The footprint clearance at every state ``(K, T)``, and at ``pose`` now."""
    clearance = footprint_clearance(costmap, states[..., 0], states[..., 1], states[..., 2])
    now = footprint_clearance(costmap, np.array([pose.x_m]), np.array([pose.y_m]), np.array([pose.yaw_rad]))
    return clearance, float(now[0])


def admissible(
    costmap: Costmap, pose: Pose2D, states: FloatArray, commands: FloatArray, *, rules: SafetyRules
) -> tuple[npt.NDArray[np.bool_], FloatArray]:
    """The safety rules on rollouts ``(K, T, 3)``: a ``(K,)`` mask of admissible trajectories and their least
    clearance ``(K,)``. The sweep rule, the dearest, is checked on the survivors of the others only."""
    clearance, now = _clearances(costmap, pose, states)
    ok = _keeps_clearance(clearance, now, rules=rules)
    ok &= _within_unseen_allowance(costmap, pose, states, rules=rules)
    ok &= _backs_onto_known(costmap, states, commands)
    if rules.sweep_observed_only and ok.any():
        candidates = np.flatnonzero(ok)
        unseen = sweeps_unseen(costmap, pose, states[candidates], spacing_m=rules.outline_spacing_m)
        ok[candidates[unseen]] = False
    return ok, clearance.min(axis=1)


def rule_masks(
    costmap: Costmap, pose: Pose2D, states: FloatArray, commands: FloatArray, *, rules: SafetyRules
) -> tuple[dict[str, npt.NDArray[np.bool_]], float]:
    """Each rule of :func:`admissible` alone, over every rollout (``RULE_NAMES`` order; for diagnosis, not
    the control loop: the sweep rule is checked on all rollouts), and the footprint's clearance now."""
    clearance, now = _clearances(costmap, pose, states)
    if rules.sweep_observed_only:
        sweeps_seen = ~sweeps_unseen(costmap, pose, states, spacing_m=rules.outline_spacing_m)
    else:
        sweeps_seen = np.ones(len(states), dtype=bool)
    masks = (
        _keeps_clearance(clearance, now, rules=rules),
        _within_unseen_allowance(costmap, pose, states, rules=rules),
        _backs_onto_known(costmap, states, commands),
        sweeps_seen,
    )
    return dict(zip(RULE_NAMES, masks, strict=True)), now


def regulate(v: float, w: float, clearance_m: float, *, rules: SafetyRules) -> tuple[float, float]:
    """Scale (v, omega) together by the clearance (the motion stays on the checked arc)."""
    if not math.isfinite(clearance_m) or clearance_m >= rules.slow_clearance_m or abs(v) < 1e-6:
        return v, w
    span = max(rules.slow_clearance_m - rules.min_clearance_m, 1e-6)
    fraction = (
        rules.creep_fraction
        + (1.0 - rules.creep_fraction) * max(0.0, clearance_m - rules.min_clearance_m) / span
    )
    fraction = min(1.0, fraction)
    return v * fraction, w * fraction


def path_progress_index(path: FloatArray, xy: FloatArray, previous: int, window: int = 40) -> int:
    """Index of the path point nearest ``xy``, searched from ``previous`` a little way on (never back)."""
    hi = min(len(path), previous + window)
    seg = path[previous:hi]
    if len(seg) == 0:
        return max(0, len(path) - 1)
    return previous + int(np.argmin(np.hypot(seg[:, 0] - xy[0], seg[:, 1] - xy[1])))
