"""Obstacle-aware local planning from depth: a subgoal in the base frame becomes a ``(v, omega)`` command.

The paper (Sec. III-F) projects the 3D subgoal into the current view and runs ViPlanner on the depth
image to get ``[v_p, omega_p]``. ViPlanner's released weights need a semantic input and are not
available offline, so this module implements a depth-only, geometric planner behind the same narrow
interface (:class:`LocalPlanner`) that a learned planner can fill later (see ``docs/planner.md``).

:class:`DepthArcPlanner`, per call (12 Hz, about 1 ms at 320x240):

1. back-projects a subsampled set of valid depth pixels into ``base_link``, keeps points inside the
   robot's height band (the floor and overhangs are dropped) and thins them on a 2D grid;
2. merges them with a short memory of recent obstacle points, carried by odometry between calls and
   cleared where the current frame sees through them, so that an obstacle that has just left the
   ~70 degree field of view while turning is still avoided;
3. picks a guide point: the goal if the way to it is free, else the waypoint of the cheapest two-leg
   path around the known points (a local detour; choosing where to go is the memory's job);
4. rotates in place while the guide lies outside the camera's view (status ``goal_behind``, or
   ``blocked`` when the guide is a detour because the direct way is obstructed);
5. otherwise samples constant-curvature arcs (curvatures x speeds over a short horizon), rejects every
   arc whose swept disc comes closer than the safety margin to an obstacle point or whose centre line
   leaves the camera's view beyond a small allowance, scores the rest on progress and heading toward
   the guide, clearance and smoothness, and commands the best one, slowed near obstacles and near the
   goal along the same curvature (so the slowed motion is a prefix of the checked arc);
6. rotates in place toward the most open direction when no arc is safe (``blocked``), and stops within
   the arrival radius (``arrived``).

Frames follow REP-103: ``base_link`` x forward, y left, z up; the camera frame is optical (x right,
y down, z forward). Invalid depth (0, NaN, inf, outside the valid range) is free-but-unknown, never an
obstacle.

This is a core module: it imports only the standard library and numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from semexp_bt.core.bounds import field_range
from semexp_bt.core.config import field_problem
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import (
    CameraIntrinsics,
    FloatArray,
    InvalidInputError,
    PixelGrid,
    Pose2D,
    Twist,
    require_finite,
)

PlanStatus = Literal["tracking", "arrived", "blocked", "goal_behind"]
"""What the planner is doing: ``tracking`` an arc toward the goal (or a detour around an obstacle);
``arrived`` within the arrival radius (zero twist); ``blocked``: rotating in place because no arc is
safe, or toward a detour that lies outside the view because the direct way is obstructed;
``goal_behind``: rotating in place toward a goal outside the view."""

#: Numerical floor for divisions by small distances and curvatures.
_EPS = 1e-9


@dataclass(frozen=True)
class PlannerConfig:
    """Every constant of :class:`DepthArcPlanner`, named once (units in the names).

    The defaults suit a Unitree Go1 with a head RGB-D camera at about 0.34 m, planning at 12 Hz.
    Build from YAML with ``semexp_bt.core.config.config_from_dict(data, cls=PlannerConfig)``.
    """

    # --- robot and command limits -------------------------------------------------------------------
    robot_radius_m: float = field(default=0.30, metadata=field_range(0.05, 2.0))
    """Radius of the disc that covers the Go1's feet in any heading (as ``sims.robot_footprint``)."""
    safety_margin_m: float = field(default=0.10, metadata=field_range(0.0, 2.0))
    """Hard limit: an arc whose disc comes closer than this to an obstacle point is rejected."""
    max_speed_mps: float = field(default=0.6, metadata=field_range(0.05, 1.0))
    """Fastest forward speed commanded (the gait allows 1.0 m/s; 0.6 is kept near obstacles)."""
    min_speed_mps: float = field(default=0.1, metadata=field_range(0.01, 1.0))
    """Slowest sampled arc speed."""
    n_speeds: int = field(default=6, metadata=field_range(1, 50))
    """Number of sampled speeds, evenly spaced in [min_speed_mps, max_speed_mps]."""
    max_yaw_rate_radps: float = field(default=1.0, metadata=field_range(0.05, 1.0))
    """Largest commanded yaw rate, either sign (the gait's limit is 1.0 rad/s)."""
    max_curvature_1pm: float = field(default=4.0, metadata=field_range(0.1, 20.0))
    """Sharpest sampled arc curvature (1/m); arcs need |curvature * speed| <= max_yaw_rate_radps."""
    n_curvatures: int = field(default=33, metadata=field_range(3, 201))
    """Number of sampled curvatures, evenly spaced in [-max, max] (odd keeps the straight arc)."""
    horizon_s: float = field(default=2.0, metadata=field_range(0.1, 10.0))
    """Arc duration: an arc at speed v is checked over length v * horizon_s."""
    arc_step_m: float = field(default=0.05, metadata=field_range(0.005, 0.5))
    """Spacing of the clearance samples along each arc; the chord error is below step^2 / (8 r)."""

    # --- depth to obstacle points -------------------------------------------------------------------
    pixel_stride: int = field(default=4, metadata=field_range(1, 64))
    """Use every stride-th pixel in both directions (320x240 at 4 gives 4800 rays)."""
    depth_min_m: float = field(default=0.1, metadata=field_range(0.0, 10.0))
    """Depth below this is invalid (closer than the sensor's minimum range): unknown, not obstacle."""
    depth_max_m: float = field(default=5.0, metadata=field_range(0.1, 100.0))
    """Depth beyond this is invalid: unknown, not obstacle."""
    floor_z_in_base_m: float = field(default=0.0, metadata=field_range(-2.0, 2.0))
    """Height of the floor in ``base_link`` (0 when base_link sits on the floor, as base_footprint
    does; -0.29 when it is the Go1 trunk frame)."""
    obstacle_min_height_m: float = field(default=0.05, metadata=field_range(0.0, 2.0))
    """Points lower than this above the floor are floor (or steps the gait walks over)."""
    obstacle_max_height_m: float = field(default=0.60, metadata=field_range(0.05, 5.0))
    """Points higher than this above the floor are overhangs the robot walks under."""
    grid_cell_m: float = field(default=0.05, metadata=field_range(0.005, 0.5))
    """Obstacle points are thinned to one per 2D cell of this side; the robot disc is inflated by the
    half diagonal so that the thinning never hides an obstacle."""

    # --- visibility and memory ----------------------------------------------------------------------
    unseen_allowance_m: float = field(default=0.30, metadata=field_range(0.0, 2.0))
    """An arc may leave the camera's view only within this distance travelled."""
    memory_horizon_s: float = field(default=15.0, metadata=field_range(0.0, 600.0))
    """Obstacle points are remembered this long (0 disables the memory)."""
    memory_radius_m: float = field(default=5.0, metadata=field_range(0.1, 50.0))
    """Remembered points farther than this from the robot are forgotten."""
    memory_clear_tolerance_m: float = field(default=0.10, metadata=field_range(0.0, 2.0))
    """A remembered point in view is cleared when the measured depth at its pixel reaches at least
    its own depth minus this tolerance (the ray passes through it: it is gone or seen again)."""
    max_memory_points: int = field(default=4000, metadata=field_range(1, 1_000_000))
    """Hard cap on remembered points (the oldest go first)."""

    # --- goal handling ------------------------------------------------------------------------------
    arrival_radius_m: float = field(default=0.5, metadata=field_range(0.0, 10.0))
    """Within this distance of the goal the planner stops and reports ``arrived``."""
    standoff_arrival_radius_m: float = field(default=0.9, metadata=field_range(0.0, 10.0))
    """A goal on or against an obstacle (a memory node back-projected onto an object's surface, a place
    next to a wall) cannot be reached within ``arrival_radius_m`` by a disc that keeps the safety margin.
    Within this distance of such a goal, when the robot cannot slide more than
    ``standoff_slide_tolerance_m`` further toward it, it stands at the nearest safe standoff: ``arrived``.
    0 disables the rule. Keep it at or below the success radius r_s (1.0 m) so a standoff next to the
    goal object still counts as reaching it."""
    standoff_slide_tolerance_m: float = field(default=0.15, metadata=field_range(0.0, 2.0))
    """How much free straight-line travel toward the goal still counts as 'cannot get closer'."""
    turn_in_place_margin_rad: float = field(default=0.1, metadata=field_range(0.0, 2.0 * math.pi))
    """Rotate in place when the way to the goal lies more than this outside the camera's horizontal
    half field of view (a large value disables rotating in place for goals to the side) ..."""
    turn_in_place_exit_rad: float = field(default=0.3, metadata=field_range(0.0, math.pi))
    """... until it is within this of the camera's heading (hysteresis keeps the mode from chattering)."""
    turn_gain_per_s: float = field(default=1.5, metadata=field_range(0.0, 20.0))
    """Yaw rate per radian of goal bearing when rotating toward the goal."""
    min_turn_rate_radps: float = field(default=0.3, metadata=field_range(0.0, 1.0))
    """Smallest yaw rate of a rotation in place (below it the gait barely turns)."""
    blocked_turn_rate_radps: float = field(default=0.6, metadata=field_range(0.05, 1.0))
    """Yaw rate of the rotation in place when no arc is safe."""
    open_direction_range_m: float = field(default=1.5, metadata=field_range(0.1, 20.0))
    """Range of the polar histogram that picks the most open direction when blocked."""
    n_direction_bins: int = field(default=72, metadata=field_range(8, 720))
    """Bins of that polar histogram over the full circle."""

    # --- slowdown -----------------------------------------------------------------------------------
    goal_slowdown_distance_m: float = field(default=1.2, metadata=field_range(0.01, 20.0))
    """Speed scales down linearly with goal distance below this."""
    obstacle_slowdown_clearance_m: float = field(default=0.3, metadata=field_range(0.01, 10.0))
    """Speed scales down linearly with arc clearance above the margin below this."""
    creep_speed_mps: float = field(default=0.08, metadata=field_range(0.0, 1.0))
    """The slowdowns never bring a chosen arc below this speed."""

    # --- arc scores (higher is better; each term lies in [0, 1] or [-1, 1]) -----------------------
    weight_progress: float = field(default=1.0, metadata=field_range(0.0, 100.0))
    """Distance to the guide point gained over the arc, per longest arc length, in [-1, 1]."""
    weight_heading: float = field(default=0.3, metadata=field_range(0.0, 100.0))
    """1 - |guide-point bearing at the arc end| / pi."""
    weight_clearance: float = field(default=0.4, metadata=field_range(0.0, 100.0))
    """Arc clearance above the margin, saturated at clearance_saturation_m."""
    weight_smoothness: float = field(default=0.15, metadata=field_range(0.0, 100.0))
    """1 - normalised change of (v, omega) from the previous command."""
    clearance_saturation_m: float = field(default=0.6, metadata=field_range(0.01, 10.0))
    """Clearance beyond the margin stops scoring above this."""
    guide_lookahead_m: float = field(default=3.0, metadata=field_range(0.1, 50.0))
    """Longest first leg of the two-leg guide path (see ``_guide_point``)."""
    guide_leg_lengths: int = field(default=6, metadata=field_range(1, 20))
    """First legs are tried at this many lengths, evenly spaced up to guide_lookahead_m."""
    guide_check_range_m: float = field(default=3.0, metadata=field_range(0.1, 50.0))
    """The second leg (waypoint to goal) is checked against known points this far."""
    guide_clearance_m: float = field(default=0.3, metadata=field_range(0.0, 5.0))
    """Clearance the guide path prefers to keep from known points (more than the hard margin, so the
    robot passes obstacles with room to spare and does not creep along them at the margin)."""
    guide_tight_penalty_m: float = field(default=1.0, metadata=field_range(0.0, 100.0))
    """Added per leg of a guide path that passes closer than guide_clearance_m to a known point."""
    guide_blocked_penalty_m: float = field(default=4.0, metadata=field_range(0.0, 100.0))
    """Added to the length of a guide path whose second leg is blocked."""
    detour_side_penalty_m: float = field(default=1.0, metadata=field_range(0.0, 100.0))
    """Added to guide paths that pass the obstacle on the other side than the previous detour
    (keeps the robot from dithering between going left and right of an obstacle)."""
    slowdown_lookahead_m: float = field(default=0.6, metadata=field_range(0.0, 10.0))
    """The obstacle slowdown reads the chosen arc's clearance over this first stretch of it."""

    def __post_init__(self) -> None:
        problem = field_problem(self)
        if problem is not None:
            raise InvalidInputError(f"PlannerConfig.{problem}")
        if self.min_speed_mps > self.max_speed_mps:
            raise InvalidInputError("PlannerConfig.min_speed_mps must not exceed max_speed_mps")
        if self.depth_min_m >= self.depth_max_m:
            raise InvalidInputError("PlannerConfig.depth_min_m must be below depth_max_m")
        if self.obstacle_min_height_m >= self.obstacle_max_height_m:
            raise InvalidInputError("PlannerConfig.obstacle_min_height_m must be below obstacle_max_height_m")

    @property
    def inflated_radius_m(self) -> float:
        """Robot radius plus the half diagonal of a thinning cell (the radius every check uses)."""
        return self.robot_radius_m + self.grid_cell_m * math.sqrt(0.5)


@dataclass(frozen=True)
class PlanResult:
    """One planning step's output.

    Attributes:
        twist: the command for the gait (body frame; ``linear_y_mps`` is always 0).
        status: see :data:`PlanStatus`.
        min_clearance_m: clearance of the commanded motion: the smallest distance between the robot
            disc and an obstacle point along the chosen arc (for a rotation in place, where the robot
            stands now); ``inf`` when no obstacle point is known. Conservative: it uses the inflated
            radius.
        arc_curvature_1pm: curvature of the chosen arc (0 when rotating in place or stopped).
        arc_speed_mps: speed of the chosen arc before the slowdowns (0 when rotating in place).
        arc_length_m: length of the checked arc (0 when rotating in place or stopped).
        goal_distance_m: distance from the base to the goal.
        goal_bearing_rad: bearing of the goal in the base frame, counter-clockwise positive.
        scores: debug figures: the chosen arc's score terms and total, and counts of arcs and points.
        obstacle_points_xy: ``(N, 2)`` obstacle points (current view and memory) in the base frame,
            after thinning, for visualisation.
    """

    twist: Twist
    status: PlanStatus
    min_clearance_m: float
    arc_curvature_1pm: float
    arc_speed_mps: float
    arc_length_m: float
    goal_distance_m: float
    goal_bearing_rad: float
    scores: dict[str, float] = field(default_factory=dict)
    obstacle_points_xy: FloatArray = field(
        default_factory=lambda: np.zeros((0, 2)), compare=False, repr=False
    )


@runtime_checkable
class LocalPlanner(Protocol):
    """A local planner: one depth frame and a subgoal in the base frame give one velocity command.

    Implementations keep their own short-term state (previous command, obstacle memory) and must be
    safe to call at the planning rate; :meth:`reset` forgets that state (new episode, relocalisation).
    """

    @property
    def sampled_pixels(self) -> PixelGrid | None:
        """The only depth pixels :meth:`plan` reads, or None when it may read any pixel."""
        ...

    def plan(
        self,
        *,
        depth_m: npt.NDArray[np.floating[Any]],
        intrinsics: CameraIntrinsics,
        camera_to_base: FloatArray,
        goal_base_xy: tuple[float, float] | FloatArray,
        stamp_s: float,
        base_pose: Pose2D | None = None,
    ) -> PlanResult:
        """Plan one step.

        Args:
            depth_m: ``(H, W)`` depth along the optical axis in metres; 0, NaN, inf mean invalid.
            intrinsics: pinhole intrinsics of the depth image.
            camera_to_base: ``(4, 4)`` transform T_base<-camera (optical camera frame to base_link).
            goal_base_xy: the subgoal in base_link (x forward, y left), metres.
            stamp_s: capture time on the backend's clock.
            base_pose: the base pose in an odometry frame, if available (used to carry memory).

        Raises:
            InvalidInputError: on malformed input (wrong shapes, NaN goal or transform).
        """
        ...

    def reset(self) -> None:
        """Forget the previous command and any remembered obstacles."""
        ...


# --------------------------------------------------------------------------------------------------
# Geometry helpers (pure functions; tests and visualisation reuse them)
# --------------------------------------------------------------------------------------------------


def arc_points(*, curvature_1pm: npt.ArrayLike, arclength_m: npt.ArrayLike) -> FloatArray:
    """Positions on constant-curvature arcs that start at the origin heading along +x.

    Args:
        curvature_1pm: curvature (positive turns left), broadcastable against ``arclength_m``.
        arclength_m: distance travelled along the arc.

    Returns:
        ``(..., 2)`` array of ``(x, y)``; exact for zero curvature (no division by it).
    """
    kappa = np.asarray(curvature_1pm, dtype=float)
    s = np.asarray(arclength_m, dtype=float)
    half_turn = 0.5 * kappa * s
    # sin(k s)/k = s sinc(k s / pi) and (1 - cos(k s))/k = s sin(k s / 2) sinc(k s / (2 pi)):
    # both are well defined at k = 0, so straight and curved arcs share one expression.
    x = s * np.sinc(kappa * s / np.pi)
    y = s * np.sin(half_turn) * np.sinc(half_turn / np.pi)
    return np.stack(np.broadcast_arrays(x, y), axis=-1)


def _pairwise_min_distance(queries: FloatArray, points: FloatArray) -> FloatArray:
    """For each query point (Q, 2), the distance to the nearest of ``points`` (M, 2); inf if M = 0."""
    if points.shape[0] == 0:
        return np.full(queries.shape[0], np.inf)
    # |a - b|^2 = |a|^2 + |b|^2 - 2 a.b turns the Q x M problem into one small matrix product.
    sq = (
        np.einsum("ij,ij->i", queries, queries)[:, None]
        + np.einsum("ij,ij->i", points, points)[None, :]
        - 2.0 * queries @ points.T
    )
    return np.sqrt(np.maximum(sq.min(axis=1), 0.0))


def _validate_transform(name: str, transform: Any) -> FloatArray:
    arr = np.asarray(transform, dtype=float)
    if arr.shape != (4, 4):
        raise InvalidInputError(f"{name} must have shape (4, 4), got {arr.shape}")
    require_finite(name, arr)
    if not np.allclose(arr[3], [0.0, 0.0, 0.0, 1.0], atol=1e-6):
        raise InvalidInputError(f"{name} last row must be [0, 0, 0, 1], got {arr[3].tolist()}")
    rotation = arr[:3, :3]
    if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-4):
        raise InvalidInputError(f"{name} rotation block must be orthonormal")
    return arr


def _validate_depth(depth_m: Any, intrinsics: CameraIntrinsics) -> npt.NDArray[np.floating[Any]]:
    if not isinstance(intrinsics, CameraIntrinsics):
        raise InvalidInputError(f"intrinsics must be CameraIntrinsics, got {type(intrinsics).__name__}")
    require_finite("intrinsics", [intrinsics.fx_px, intrinsics.fy_px, intrinsics.cx_px, intrinsics.cy_px])
    if intrinsics.fx_px <= 0.0 or intrinsics.fy_px <= 0.0:
        raise InvalidInputError(f"intrinsics focal lengths must be positive, got {intrinsics!r}")
    depth = np.asarray(depth_m)
    if depth.ndim != 2:
        raise InvalidInputError(f"depth_m must be a 2D (H, W) array, got shape {depth.shape}")
    if depth.shape != (intrinsics.height_px, intrinsics.width_px):
        raise InvalidInputError(
            f"depth_m shape {depth.shape} does not match intrinsics (height_px, width_px) = "
            f"({intrinsics.height_px}, {intrinsics.width_px})"
        )
    if not np.issubdtype(depth.dtype, np.floating):
        raise InvalidInputError(f"depth_m must be a floating-point array in metres, got dtype {depth.dtype}")
    return depth


def depth_to_points(
    *,
    depth_m: npt.NDArray[np.floating[Any]],
    intrinsics: CameraIntrinsics,
    camera_to_base: FloatArray,
    pixel_stride: int = 1,
    depth_min_m: float = 0.0,
    depth_max_m: float = math.inf,
) -> FloatArray:
    """Back-project valid depth pixels into the base frame.

    Args:
        depth_m: ``(H, W)`` depth along the optical axis.
        intrinsics: pinhole intrinsics.
        camera_to_base: ``(4, 4)`` T_base<-camera.
        pixel_stride: use every stride-th row and column, starting half a stride in.
        depth_min_m: smaller depths are invalid.
        depth_max_m: larger depths are invalid.

    Returns:
        ``(N, 3)`` points in the base frame; invalid pixels (non-finite, out of range) are skipped.
    """
    grid = PixelGrid.centred(pixel_stride)
    sub = np.asarray(depth_m, dtype=float)[grid.offset :: grid.stride, grid.offset :: grid.stride]
    rows = grid.indices(depth_m.shape[0]).astype(float)
    cols = grid.indices(depth_m.shape[1]).astype(float)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(sub) & (sub >= depth_min_m) & (sub <= depth_max_m)
    row_idx, col_idx = np.nonzero(valid)
    z = sub[row_idx, col_idx]
    x = (cols[col_idx] - intrinsics.cx_px) / intrinsics.fx_px * z
    y = (rows[row_idx] - intrinsics.cy_px) / intrinsics.fy_px * z
    cam = np.stack([x, y, z], axis=1)
    return cam @ camera_to_base[:3, :3].T + camera_to_base[:3, 3]


def _thin_on_grid(points_xy: FloatArray, cell_m: float) -> npt.NDArray[np.intp]:
    """Indices of one point per occupied 2D grid cell (the first in input order)."""
    if points_xy.shape[0] == 0:
        return np.zeros(0, dtype=np.intp)
    keys = np.floor(points_xy / cell_m).astype(np.int64)
    # Cells within +-2^20 of the robot: pack (i, j) into one int64 so np.unique sorts a flat array.
    packed = (keys[:, 0] + (1 << 20)) * (1 << 21) + (keys[:, 1] + (1 << 20))
    _, first = np.unique(packed, return_index=True)
    return np.sort(first)


def _camera_heading_and_half_fov(transform: FloatArray, intrinsics: CameraIntrinsics) -> tuple[float, float]:
    """Yaw of the optical axis projected on the ground (base frame) and the narrower horizontal half
    field of view; the half FOV is 0 when the camera looks straight up or down."""
    forward = transform[:2, 2]
    if float(np.hypot(forward[0], forward[1])) < 1e-3:
        return 0.0, 0.0
    half_fov = math.atan2(
        min(intrinsics.cx_px, intrinsics.width_px - 1 - intrinsics.cx_px) + 0.5, intrinsics.fx_px
    )
    return math.atan2(forward[1], forward[0]), half_fov


# --------------------------------------------------------------------------------------------------
# The planner
# --------------------------------------------------------------------------------------------------


@dataclass
class _ArcSet:
    """Precomputed arc geometry: one row of samples per curvature, shared by every speed."""

    curvatures_1pm: FloatArray  # (K,)
    speeds_mps: FloatArray  # (V,)
    sample_s_m: FloatArray  # (S,) arclength of the samples, excluding s = 0
    samples_xy: FloatArray  # (K, S, 2)
    end_index: npt.NDArray[np.intp]  # (V,) index of the last sample an arc at each speed covers
    feasible: npt.NDArray[np.bool_]  # (K, V): |curvature * speed| within the yaw-rate limit


def _build_arc_set(config: PlannerConfig) -> _ArcSet:
    curvatures = np.linspace(-config.max_curvature_1pm, config.max_curvature_1pm, config.n_curvatures)
    speeds = np.linspace(config.min_speed_mps, config.max_speed_mps, config.n_speeds)
    longest = config.max_speed_mps * config.horizon_s
    n_samples = max(1, math.ceil(longest / config.arc_step_m - 1e-9))
    sample_s = np.arange(1, n_samples + 1, dtype=float) * (longest / n_samples)
    samples = arc_points(curvature_1pm=curvatures[:, None], arclength_m=sample_s[None, :])
    step = longest / n_samples
    # Round the arc's length up to a whole sample: the check then covers at least the whole arc.
    end_index = np.clip(
        np.ceil(speeds * config.horizon_s / step - 1e-9).astype(np.intp) - 1, 0, n_samples - 1
    )
    feasible = np.abs(curvatures[:, None] * speeds[None, :]) <= config.max_yaw_rate_radps + 1e-9
    return _ArcSet(curvatures, speeds, sample_s, samples, end_index, feasible)


class DepthArcPlanner:
    """Depth-only arc-sampling local planner with a short odometry-carried obstacle memory.

    Example:
        >>> planner = DepthArcPlanner()
        >>> result = planner.plan(depth_m=depth, intrinsics=K, camera_to_base=T_base_cam,
        ...                       goal_base_xy=(3.0, 0.5), stamp_s=t)  # doctest: +SKIP
        >>> robot.command_twist(result.twist)  # doctest: +SKIP
    """

    def __init__(self, config: PlannerConfig | None = None) -> None:
        self.config = config if config is not None else PlannerConfig()
        self._arcs = _build_arc_set(self.config)
        bins = self.config.n_direction_bins
        self._bin_centres_rad = -np.pi + (np.arange(bins) + 0.5) * (2.0 * np.pi / bins)
        self.reset()

    # ---------------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the previous command, the obstacle memory, the odometry estimate and the modes."""
        self._previous_twist = Twist.zero()
        self._last_stamp_s: float | None = None
        self._odom_pose = np.zeros(3)  # x, y, yaw of the base in the memory's frame
        self._memory_xyz = np.zeros((0, 3))  # in the memory's frame
        self._memory_stamp_s = np.zeros(0)
        self._turn_in_place_sign = 0.0  # +1 / -1 while rotating in place toward the guide
        self._blocked_turn_sign = 0.0
        self._detour_side = 0.0

    @property
    def sampled_pixels(self) -> PixelGrid:
        """The only depth pixels :meth:`plan` reads: every ``pixel_stride``-th, half a stride in."""
        return PixelGrid.centred(self.config.pixel_stride)

    @property
    def memory_size(self) -> int:
        """Number of remembered obstacle points."""
        return int(self._memory_xyz.shape[0])

    # ---------------------------------------------------------------------------------------------
    def plan(
        self,
        *,
        depth_m: npt.NDArray[np.floating[Any]],
        intrinsics: CameraIntrinsics,
        camera_to_base: FloatArray,
        goal_base_xy: tuple[float, float] | FloatArray,
        stamp_s: float,
        base_pose: Pose2D | None = None,
    ) -> PlanResult:
        """Plan one step; see :meth:`LocalPlanner.plan`.

        Memory: with ``base_pose`` the remembered points are carried by that odometry; without it, by
        integrating the previous command over the time since the previous call (dead reckoning).
        A stamp that goes backwards clears the memory.
        """
        cfg = self.config
        depth = _validate_depth(depth_m, intrinsics)
        transform = _validate_transform("camera_to_base", camera_to_base)
        goal = np.asarray(goal_base_xy, dtype=float)
        if goal.shape != (2,):
            raise InvalidInputError(f"goal_base_xy must have shape (2,), got {goal.shape}")
        require_finite("goal_base_xy", goal)
        require_finite("stamp_s", stamp_s)
        if base_pose is not None:
            require_finite("base_pose", [base_pose.x_m, base_pose.y_m, base_pose.yaw_rad])

        self._update_odometry(stamp_s=float(stamp_s), base_pose=base_pose)
        seen = depth_to_points(
            depth_m=depth,
            intrinsics=intrinsics,
            camera_to_base=transform,
            pixel_stride=cfg.pixel_stride,
            depth_min_m=cfg.depth_min_m,
            depth_max_m=cfg.depth_max_m,
        )
        height = seen[:, 2] - cfg.floor_z_in_base_m
        seen = seen[(height >= cfg.obstacle_min_height_m) & (height <= cfg.obstacle_max_height_m)]
        remembered = self._recall(depth=depth, intrinsics=intrinsics, transform=transform, stamp_s=stamp_s)
        obstacles_xyz = self._remember(seen=seen, remembered=remembered, stamp_s=float(stamp_s))
        obstacles = obstacles_xyz[:, :2]

        goal_distance = float(np.hypot(goal[0], goal[1]))
        goal_bearing = float(math.atan2(goal[1], goal[0]))
        start_clearance = float(
            _pairwise_min_distance(np.zeros((1, 2)), obstacles)[0] - cfg.inflated_radius_m
        )
        counts = {
            "n_obstacle_points": float(obstacles.shape[0]),
            "n_memory_points": float(remembered.shape[0]),
        }

        def finish(twist: Twist, status: PlanStatus, **arc: Any) -> PlanResult:
            self._previous_twist = twist
            fields: dict[str, Any] = {
                "min_clearance_m": start_clearance,
                "arc_curvature_1pm": 0.0,
                "arc_speed_mps": 0.0,
                "arc_length_m": 0.0,
                "scores": {},
            }
            fields.update(arc)
            fields["scores"] = {**counts, **fields["scores"]}
            return PlanResult(
                twist=twist,
                status=status,
                goal_distance_m=goal_distance,
                goal_bearing_rad=goal_bearing,
                obstacle_points_xy=obstacles,
                **fields,
            )

        if goal_distance <= cfg.arrival_radius_m:
            self._turn_in_place_sign = 0.0
            self._blocked_turn_sign = 0.0
            return finish(Twist.zero(), "arrived")

        if goal_distance <= cfg.standoff_arrival_radius_m and self._at_standoff(
            obstacles, goal, goal_distance
        ):
            self._turn_in_place_sign = 0.0
            self._blocked_turn_sign = 0.0
            return finish(Twist.zero(), "arrived")

        guide = self._guide_point(obstacles=obstacles, goal=goal, goal_distance=goal_distance)
        guide_bearing = float(math.atan2(guide[1], guide[0]))
        counts["detour_rad"] = float(abs(wrap_angle(guide_bearing - goal_bearing)))
        counts["guide_x_m"], counts["guide_y_m"] = float(guide[0]), float(guide[1])

        # Rotate in place while the way to the goal (the guide direction) lies outside the view. The
        # direction of the rotation is kept until the guide is in view: what the camera discovers while
        # turning may move the guide to the other side, and reversing then would undo the turn.
        camera_yaw, half_fov = _camera_heading_and_half_fov(transform, intrinsics)
        offset = float(wrap_angle(guide_bearing - camera_yaw))
        enter = half_fov + cfg.turn_in_place_margin_rad
        threshold = min(cfg.turn_in_place_exit_rad, enter) if self._turn_in_place_sign else enter
        if abs(offset) <= threshold:
            self._turn_in_place_sign = 0.0
        else:
            self._turn_in_place_sign = self._turn_in_place_sign or math.copysign(1.0, offset)
            self._blocked_turn_sign = 0.0
            rate = self._turn_rate_toward(offset)
            if math.copysign(1.0, rate) != self._turn_in_place_sign:
                rate = self._turn_in_place_sign * cfg.max_yaw_rate_radps
            # Toward the goal itself: it is behind. Toward a detour: the direct way is blocked.
            status: PlanStatus = "blocked" if self._detour_side else "goal_behind"
            return finish(Twist(angular_z_radps=rate), status)

        choice = self._choose_arc(
            obstacles=obstacles,
            guide=guide,
            transform=transform,
            intrinsics=intrinsics,
        )
        if choice is None:
            sign = self._blocked_turn_sign or self._most_open_turn_sign(obstacles, guide_bearing)
            self._blocked_turn_sign = sign
            return finish(Twist(angular_z_radps=sign * cfg.blocked_turn_rate_radps), "blocked")

        self._blocked_turn_sign = 0.0
        curvature, speed, length, clearance, near_clearance, scores = choice
        scale = self._slowdown_scale(speed=speed, near_clearance=near_clearance, goal_distance=goal_distance)
        linear = speed * scale
        angular = float(np.clip(curvature * linear, -cfg.max_yaw_rate_radps, cfg.max_yaw_rate_radps))
        return finish(
            Twist(linear_x_mps=linear, angular_z_radps=angular),
            "tracking",
            min_clearance_m=clearance,
            arc_curvature_1pm=curvature,
            arc_speed_mps=speed,
            arc_length_m=length,
            scores=scores,
        )

    # ---------------------------------------------------------------------------------------------
    def _at_standoff(self, obstacles: FloatArray, goal: FloatArray, goal_distance: float) -> bool:
        """Whether the robot stands as close to an obstructed goal as the safety margin allows: the goal
        lies within the inflated disc plus margin of a known obstacle point (so no safe pose is closer
        to it), and the disc cannot slide more than the tolerance straight toward it."""
        cfg = self.config
        if obstacles.shape[0] == 0:
            return False
        reach = cfg.inflated_radius_m + cfg.safety_margin_m
        goal_gap = float(_pairwise_min_distance(goal[None, :], obstacles)[0])
        if goal_gap > reach:
            return False
        slide = float(
            self._free_range(
                obstacles, np.array([math.atan2(goal[1], goal[0])]), goal_distance, cfg.safety_margin_m
            )[0]
        )
        return slide <= cfg.standoff_slide_tolerance_m

    def _turn_rate_toward(self, bearing_rad: float) -> float:
        cfg = self.config
        rate = min(
            cfg.max_yaw_rate_radps, max(cfg.min_turn_rate_radps, cfg.turn_gain_per_s * abs(bearing_rad))
        )
        return math.copysign(rate, bearing_rad)

    def _slowdown_scale(self, *, speed: float, near_clearance: float, goal_distance: float) -> float:
        """Factor in (0, 1] applied to v and omega together, so the path keeps its curvature."""
        cfg = self.config
        near_obstacle = (near_clearance - cfg.safety_margin_m) / cfg.obstacle_slowdown_clearance_m
        near_goal = goal_distance / cfg.goal_slowdown_distance_m
        cap = cfg.max_speed_mps * min(1.0, max(0.0, near_obstacle), near_goal)
        cap = max(cap, min(cfg.creep_speed_mps, speed))
        return min(1.0, cap / speed)

    def _update_odometry(self, *, stamp_s: float, base_pose: Pose2D | None) -> None:
        last = self._last_stamp_s
        if last is not None and stamp_s < last:
            self._memory_xyz = np.zeros((0, 3))
            self._memory_stamp_s = np.zeros(0)
        if base_pose is not None:
            self._odom_pose = np.array([base_pose.x_m, base_pose.y_m, base_pose.yaw_rad])
        elif last is not None and stamp_s > last:
            # Dead reckoning on the previous command (exact for a constant-curvature arc).
            dt = min(stamp_s - last, self.config.memory_horizon_s)
            v = self._previous_twist.linear_x_mps
            w = self._previous_twist.angular_z_radps
            if abs(v) > _EPS:
                local = arc_points(curvature_1pm=w / v, arclength_m=v * dt)
            else:
                local = np.zeros(2)
            x, y, yaw = self._odom_pose
            c, s = math.cos(yaw), math.sin(yaw)
            self._odom_pose = np.array(
                [x + c * local[0] - s * local[1], y + s * local[0] + c * local[1], yaw + w * dt]
            )
        self._last_stamp_s = stamp_s

    def _recall(
        self,
        *,
        depth: npt.NDArray[np.floating[Any]],
        intrinsics: CameraIntrinsics,
        transform: FloatArray,
        stamp_s: float,
    ) -> FloatArray:
        """Remembered points in the base frame that are still young, near, and not seen through now."""
        cfg = self.config
        if self._memory_xyz.shape[0] == 0 or cfg.memory_horizon_s <= 0.0:
            return np.zeros((0, 3))
        x, y, yaw = self._odom_pose
        c, s = math.cos(yaw), math.sin(yaw)
        dx = self._memory_xyz[:, 0] - x
        dy = self._memory_xyz[:, 1] - y
        base = np.stack([c * dx + s * dy, -s * dx + c * dy, self._memory_xyz[:, 2]], axis=1)
        keep = (stamp_s - self._memory_stamp_s <= cfg.memory_horizon_s) & (
            np.hypot(base[:, 0], base[:, 1]) <= cfg.memory_radius_m
        )
        # Visibility clearing: a remembered point that projects into the image where the measured depth
        # reaches it (or beyond) is either gone or measured again this frame, so it is dropped. Points
        # behind an invalid pixel or an occluder stay: the camera has no evidence either way. The depth
        # is read at the nearest pixel of the planner's own sampling grid, so that the planner needs no
        # pixels beyond it (a ray-cast depth source measures only those).
        cam = (base - transform[:3, 3]) @ transform[:3, :3]
        grid = self.sampled_pixels
        with np.errstate(divide="ignore", invalid="ignore"):
            u = grid.nearest(intrinsics.fx_px * cam[:, 0] / cam[:, 2] + intrinsics.cx_px)
            v = grid.nearest(intrinsics.fy_px * cam[:, 1] / cam[:, 2] + intrinsics.cy_px)
        in_view = (
            (cam[:, 2] >= cfg.depth_min_m)
            & (cam[:, 2] <= cfg.depth_max_m)
            & (u >= 0)
            & (u < depth.shape[1])
            & (v >= 0)
            & (v < depth.shape[0])
        )
        idx = np.nonzero(in_view)[0]
        measured = depth[v[idx].astype(np.intp), u[idx].astype(np.intp)].astype(float)
        with np.errstate(invalid="ignore"):
            valid = np.isfinite(measured) & (measured >= cfg.depth_min_m) & (measured <= cfg.depth_max_m)
            seen_through = valid & (measured >= cam[idx, 2] - cfg.memory_clear_tolerance_m)
        keep[idx[seen_through]] = False
        self._memory_xyz = self._memory_xyz[keep]
        self._memory_stamp_s = self._memory_stamp_s[keep]
        return base[keep]

    def _remember(self, *, seen: FloatArray, remembered: FloatArray, stamp_s: float) -> FloatArray:
        """Thin current + remembered points on the grid (current first wins) and store the result."""
        cfg = self.config
        points = np.concatenate([seen, remembered], axis=0)
        stamps = np.concatenate([np.full(seen.shape[0], stamp_s), self._memory_stamp_s])
        keep = _thin_on_grid(points[:, :2], cfg.grid_cell_m)
        points, stamps = points[keep], stamps[keep]
        if cfg.memory_horizon_s > 0.0:
            near = np.nonzero(np.hypot(points[:, 0], points[:, 1]) <= cfg.memory_radius_m)[0]
            order = near[np.argsort(-stamps[near], kind="stable")[: cfg.max_memory_points]]
            x, y, yaw = self._odom_pose
            c, s = math.cos(yaw), math.sin(yaw)
            kept = points[order]
            self._memory_xyz = np.stack(
                [x + c * kept[:, 0] - s * kept[:, 1], y + s * kept[:, 0] + c * kept[:, 1], kept[:, 2]], axis=1
            )
            self._memory_stamp_s = stamps[order]
        return points

    def _visible(
        self, points_xy: FloatArray, transform: FloatArray, intrinsics: CameraIntrinsics
    ) -> npt.NDArray[np.bool_]:
        """Whether base-frame points lie inside the camera's horizontal field of view (ground projection)."""
        camera_yaw, half_fov = _camera_heading_and_half_fov(transform, intrinsics)
        if half_fov <= 0.0:
            return np.zeros(points_xy.shape[:-1], dtype=bool)
        forward = np.array([math.cos(camera_yaw), math.sin(camera_yaw)])
        rel = points_xy - transform[:2, 3]
        along = rel[..., 0] * forward[0] + rel[..., 1] * forward[1]
        across = -rel[..., 0] * forward[1] + rel[..., 1] * forward[0]
        return (along > 0.0) & (np.abs(across) <= along * math.tan(half_fov))

    def _choose_arc(
        self,
        *,
        obstacles: FloatArray,
        guide: FloatArray,
        transform: FloatArray,
        intrinsics: CameraIntrinsics,
    ) -> tuple[float, float, float, float, float, dict[str, float]] | None:
        """Best admissible arc as (curvature, speed, length, clearance, clearance over the slowdown
        lookahead, scores), or None when none is safe."""
        cfg = self.config
        arcs = self._arcs
        n_k, n_s = arcs.samples_xy.shape[:2]
        flat = arcs.samples_xy.reshape(-1, 2)
        reach = cfg.max_speed_mps * cfg.horizon_s + cfg.inflated_radius_m + cfg.safety_margin_m
        ranges = np.hypot(obstacles[:, 0], obstacles[:, 1])
        near = obstacles[ranges <= reach + cfg.clearance_saturation_m]
        # Points already inside the margin (the robot was pushed, or a point appeared next to it) may not
        # be approached any further; every other point must stay outside the margin. Without the first
        # rule a robot inside the margin could never move again; the second is the hard safety limit.
        start_gap = np.hypot(near[:, 0], near[:, 1]) - cfg.inflated_radius_m
        inside = start_gap < cfg.safety_margin_m
        clearance = _pairwise_min_distance(flat, near[~inside]) - cfg.inflated_radius_m
        admissible_sample = clearance >= cfg.safety_margin_m
        if inside.any():
            gaps = np.hypot(
                flat[:, None, 0] - near[None, inside, 0], flat[:, None, 1] - near[None, inside, 1]
            )
            gaps = gaps - cfg.inflated_radius_m
            admissible_sample &= (gaps >= start_gap[None, inside] - 1e-9).all(axis=1)
            clearance = np.minimum(clearance, gaps.min(axis=1))
        clearance = clearance.reshape(n_k, n_s)
        prefix_clearance = np.minimum.accumulate(clearance, axis=1)  # (K, S)
        arc_clearance = prefix_clearance[:, arcs.end_index]  # (K, V)
        prefix_safe = np.logical_and.accumulate(admissible_sample.reshape(n_k, n_s), axis=1)[
            :, arcs.end_index
        ]

        # Visibility: past the allowance, every sample up to the arc's end must be in view.
        hidden = ~self._visible(arcs.samples_xy, transform, intrinsics) & (
            arcs.sample_s_m > cfg.unseen_allowance_m
        )
        hidden_prefix = np.logical_or.accumulate(hidden, axis=1)[:, arcs.end_index]  # (K, V)

        admissible = arcs.feasible & ~hidden_prefix & prefix_safe
        if not admissible.any():
            return None

        lengths = arcs.speeds_mps * cfg.horizon_s
        ends = arc_points(curvature_1pm=arcs.curvatures_1pm[:, None], arclength_m=lengths[None, :])
        end_yaw = arcs.curvatures_1pm[:, None] * lengths[None, :]
        to_guide = guide - ends
        guide_distance = float(np.hypot(guide[0], guide[1]))
        end_distance = np.hypot(to_guide[..., 0], to_guide[..., 1])
        longest = cfg.max_speed_mps * cfg.horizon_s
        progress = np.clip((guide_distance - end_distance) / longest, -1.0, 1.0)
        heading = 1.0 - np.abs(wrap_angle(np.arctan2(to_guide[..., 1], to_guide[..., 0]) - end_yaw)) / np.pi
        clear_score = np.clip((arc_clearance - cfg.safety_margin_m) / cfg.clearance_saturation_m, 0.0, 1.0)
        prev = self._previous_twist
        omega = arcs.curvatures_1pm[:, None] * arcs.speeds_mps[None, :]
        change = 0.5 * (
            np.abs(arcs.speeds_mps[None, :] - prev.linear_x_mps) / cfg.max_speed_mps
            + np.abs(omega - prev.angular_z_radps) / (2.0 * cfg.max_yaw_rate_radps)
        )
        smooth = 1.0 - np.clip(change, 0.0, 1.0)
        total = (
            cfg.weight_progress * progress
            + cfg.weight_heading * heading
            + cfg.weight_clearance * clear_score
            + cfg.weight_smoothness * smooth
        )
        total = np.where(admissible, total, -np.inf)
        k, v = np.unravel_index(int(np.argmax(total)), total.shape)
        slowdown_index = max(0, int(np.searchsorted(arcs.sample_s_m, cfg.slowdown_lookahead_m)))
        slowdown_index = min(slowdown_index, n_s - 1)
        scores = {
            "progress": float(progress[k, v]),
            "heading": float(heading[k, v]),
            "clearance": float(clear_score[k, v]),
            "smoothness": float(smooth[k, v]),
            "total": float(total[k, v]),
            "n_arcs": float(arcs.feasible.sum()),
            "n_admissible_arcs": float(admissible.sum()),
        }
        return (
            float(arcs.curvatures_1pm[k]),
            float(arcs.speeds_mps[v]),
            float(lengths[v]),
            float(arc_clearance[k, v]),
            float(prefix_clearance[k, min(int(arcs.end_index[v]), slowdown_index)]),
            scores,
        )

    def _free_range(
        self, obstacles: FloatArray, directions_rad: npt.ArrayLike, max_range_m: float, clearance_m: float
    ) -> FloatArray:
        """How far the robot disc can slide straight along each direction before it comes within
        ``clearance_m`` of an obstacle point, capped at ``max_range_m`` (exact for a swept disc)."""
        cfg = self.config
        reach = cfg.inflated_radius_m + clearance_m
        close = np.hypot(obstacles[:, 0], obstacles[:, 1]) <= max_range_m + reach
        pts = obstacles[close]
        unit = np.stack([np.cos(directions_rad), np.sin(directions_rad)], axis=1)
        along = unit @ pts.T  # (D, M)
        across = unit[:, :1] * pts[None, :, 1] - unit[:, 1:] * pts[None, :, 0]
        # Points behind never block (sliding away only increases the distance to them).
        touching = (np.abs(across) < reach) & (along > 0.0)
        hit = along - np.sqrt(np.maximum(reach * reach - across * across, 0.0))
        hit = np.where(touching, np.maximum(hit, 0.0), max_range_m)
        return np.minimum(hit.min(axis=1, initial=max_range_m), max_range_m)

    def _segment_gaps(self, *, starts: FloatArray, goal: FloatArray, obstacles: FloatArray) -> FloatArray:
        """Clearance of the robot disc sliding from each start toward the goal (over at most
        guide_check_range_m): the smallest point-to-segment distance minus the inflated radius."""
        cfg = self.config
        if obstacles.shape[0] == 0:
            return np.full(starts.shape[0], np.inf)
        direction = goal - starts
        length = np.hypot(direction[:, 0], direction[:, 1])
        reach = np.minimum(length, cfg.guide_check_range_m)
        unit = direction / np.maximum(length, _EPS)[:, None]
        # Point-to-segment distances as (A x M) matrix products, without an (A, M, 2) temporary:
        # with rel = p - a, t = clip(rel.u, 0, L) and |rel - t u|^2 = |rel|^2 - 2 t (rel.u) + t^2.
        along = unit @ obstacles.T - np.einsum("ad,ad->a", unit, starts)[:, None]
        rel_sq = (
            np.einsum("md,md->m", obstacles, obstacles)[None, :]
            - 2.0 * starts @ obstacles.T
            + np.einsum("ad,ad->a", starts, starts)[:, None]
        )
        t = np.clip(along, 0.0, reach[:, None])
        gap_sq = (rel_sq - 2.0 * t * along + t * t).min(axis=1)
        return np.sqrt(np.maximum(gap_sq, 0.0)) - cfg.inflated_radius_m

    def _guide_point(self, *, obstacles: FloatArray, goal: FloatArray, goal_distance: float) -> FloatArray:
        """The point the arcs are scored toward: the goal if the way to it is free with room to spare,
        else the waypoint of the cheapest two-leg path robot -> waypoint -> goal.

        Waypoints lie along the polar directions (and the goal's) at a few distances up to the
        lookahead; the first leg must keep the hard margin. A path costs its length, plus
        guide_tight_penalty_m per leg that passes closer than guide_clearance_m, plus
        guide_blocked_penalty_m if the second leg breaks the margin, plus detour_side_penalty_m if it
        passes on the other side than the previous detour. This sees around a single obstacle (a box,
        a pillar, a wall end) with two small (D x M) and (D L x M) tables; it is not a global planner
        (the topological memory above it chooses where to go).
        """
        cfg = self.config
        goal_bearing = math.atan2(goal[1], goal[0])
        direct = min(goal_distance, cfg.guide_lookahead_m)
        roomy = self._free_range(obstacles, np.array([goal_bearing]), direct, cfg.guide_clearance_m)[0]
        if roomy >= direct - _EPS and (
            direct >= goal_distance - _EPS
            or self._segment_gaps(
                starts=goal[None, :] * (direct / goal_distance), goal=goal, obstacles=obstacles
            )[0]
            >= cfg.guide_clearance_m
        ):
            self._detour_side = 0.0
            return goal
        directions = np.append(self._bin_centres_rad, goal_bearing)
        free_hard = self._free_range(obstacles, directions, cfg.guide_lookahead_m, cfg.safety_margin_m)
        free_soft = self._free_range(obstacles, directions, cfg.guide_lookahead_m, cfg.guide_clearance_m)
        legs = np.linspace(
            cfg.guide_lookahead_m / cfg.guide_leg_lengths, cfg.guide_lookahead_m, cfg.guide_leg_lengths
        )
        usable = legs[None, :] <= free_hard[:, None] + _EPS  # (D, L)
        unit = np.stack([np.cos(directions), np.sin(directions)], axis=1)
        waypoints = unit[:, None, :] * legs[None, :, None]  # (D, L, 2)
        cost = legs[None, :] + np.hypot(goal[0] - waypoints[..., 0], goal[1] - waypoints[..., 1])
        cost = cost + cfg.guide_tight_penalty_m * (legs[None, :] > free_soft[:, None] + _EPS)
        gaps = np.full(usable.shape, -np.inf)
        gaps[usable] = self._segment_gaps(starts=waypoints[usable], goal=goal, obstacles=obstacles)
        cost = cost + np.where(gaps < cfg.safety_margin_m, cfg.guide_blocked_penalty_m, 0.0)
        cost = cost + np.where(gaps < cfg.guide_clearance_m, cfg.guide_tight_penalty_m, 0.0)
        side = np.sign(wrap_angle(directions - goal_bearing))
        if self._detour_side:
            cost = cost + cfg.detour_side_penalty_m * (side == -self._detour_side)[:, None]
        cost = np.where(usable, cost, np.inf)
        if not np.isfinite(cost).any():
            # Boxed in within the first leg: head for the freest direction, nearest the goal.
            best_d = int(np.argmax(free_hard - 1e-3 * np.abs(wrap_angle(directions - goal_bearing))))
            reach = max(float(free_hard[best_d]), cfg.robot_radius_m)
        else:
            flat_best = int(np.argmin(cost))
            best_d, best_l = divmod(flat_best, cost.shape[1])
            reach = float(legs[best_l])
        self._detour_side = float(side[best_d]) or self._detour_side or 1.0
        return reach * unit[best_d]

    def _most_open_turn_sign(self, obstacles: FloatArray, guide_bearing: float) -> float:
        """+1 (left) or -1 (right): the side of the most open direction, ties broken toward the guide."""
        cfg = self.config
        free = self._free_range(
            obstacles, self._bin_centres_rad, cfg.open_direction_range_m, cfg.safety_margin_m
        )
        closeness = 1.0 - np.abs(wrap_angle(self._bin_centres_rad - guide_bearing)) / np.pi
        best = int(np.argmax(free / cfg.open_direction_range_m + 0.1 * closeness))
        direction = float(self._bin_centres_rad[best])
        if abs(direction) < 2.0 * math.pi / cfg.n_direction_bins:
            # Straight ahead is open but no arc was admissible (view or margin): turn toward the guide.
            direction = guide_bearing
        return 1.0 if direction >= 0.0 else -1.0
