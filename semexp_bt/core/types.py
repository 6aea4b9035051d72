"""Shared data types that flow through semexp-bt.

The pipeline is ``Observation -> SceneEvidence + Detection -> Target -> TopologicalMemory -> Subgoal ->
Twist -> joint targets``. Every type here is a plain dataclass with units in the field names. Frames
follow ROS REP-103/105: x forward, y left, z up; the world frame is ``map``; the camera frame follows the
optical convention (x right, y down, z forward) as in ``sensor_msgs/CameraInfo``.

This is a core module: it imports only the standard library and numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: Segmentation value of pixels that belong to no scene object (floor, sky, the robot itself).
BACKGROUND_OBJECT_ID = -1


class InvalidInputError(ValueError):
    """Raised when an input to the core is malformed (NaN, inf, wrong shape, out of range).

    The message always names the offending field, so that a bad sensor frame or a garbled model reply
    is reported, never propagated into a NaN subgoal.
    """


def require_finite(name: str, value: float | npt.ArrayLike) -> None:
    """Raise :class:`InvalidInputError` unless every element of ``value`` is finite.

    Args:
        name: the field name to report.
        value: a scalar or array.
    """
    # Scalars (poses and twists, several per tick) take the fast path: numpy costs microseconds per call.
    if isinstance(value, (float, int)) and not isinstance(value, bool):
        if math.isfinite(value):
            return
        raise InvalidInputError(f"{name} must be finite, got {value!r}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise InvalidInputError(f"{name} must be finite numbers, got {value!r}") from error
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{name} must be finite, got {value!r}")


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics of a camera, in pixels (as in ``sensor_msgs/CameraInfo`` K).

    Attributes:
        fx_px: focal length along image x (columns).
        fy_px: focal length along image y (rows).
        cx_px: principal point column.
        cy_px: principal point row.
        width_px: image width.
        height_px: image height.
    """

    fx_px: float
    fy_px: float
    cx_px: float
    cy_px: float
    width_px: int
    height_px: int

    def matrix(self) -> FloatArray:
        """The 3x3 matrix K."""
        return np.array([[self.fx_px, 0.0, self.cx_px], [0.0, self.fy_px, self.cy_px], [0.0, 0.0, 1.0]])

    @classmethod
    def from_fov(cls, *, width_px: int, height_px: int, vertical_fov_deg: float) -> CameraIntrinsics:
        """Square-pixel intrinsics with the principal point at the image centre."""
        fy = 0.5 * height_px / math.tan(math.radians(vertical_fov_deg) / 2.0)
        return cls(
            fx_px=fy,
            fy_px=fy,
            cx_px=(width_px - 1) / 2.0,
            cy_px=(height_px - 1) / 2.0,
            width_px=width_px,
            height_px=height_px,
        )


@dataclass(frozen=True)
class Pose2D:
    """A planar pose in the world frame: position in metres and heading (yaw about +z) in radians."""

    x_m: float
    y_m: float
    yaw_rad: float

    def position(self) -> FloatArray:
        return np.array([self.x_m, self.y_m])


@dataclass(frozen=True)
class Twist:
    """A base velocity command in the robot's body frame (``geometry_msgs/Twist`` subset).

    Attributes:
        linear_x_mps: forward speed.
        linear_y_mps: leftward speed.
        angular_z_radps: yaw rate, counter-clockwise positive.
    """

    linear_x_mps: float = 0.0
    linear_y_mps: float = 0.0
    angular_z_radps: float = 0.0

    @classmethod
    def zero(cls) -> Twist:
        return cls()


@dataclass(frozen=True)
class PixelGrid:
    """A regular grid of image pixels a depth consumer reads: rows and columns ``offset, offset + stride, ...``.

    A consumer that samples a depth image on such a grid (the local planner, the occupancy map) says so,
    and a backend that can measure depth per pixel (ray casting in simulation) may then measure only
    those pixels and leave the rest NaN ("not measured"). A camera that delivers whole frames ignores it.

    Example:
        ``PixelGrid(stride=4, offset=2)`` on a 320x240 image is 80x60 pixels: rows and columns 2, 6, 10, ...

    Attributes:
        stride: step between sampled rows and between sampled columns (>= 1).
        offset: first sampled row and column (0 <= offset < stride).
    """

    stride: int
    offset: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.stride, int) or self.stride < 1:
            raise InvalidInputError(f"PixelGrid.stride must be an integer >= 1, got {self.stride!r}")
        if not isinstance(self.offset, int) or not 0 <= self.offset < self.stride:
            raise InvalidInputError(
                f"PixelGrid.offset must be an integer in [0, stride), got {self.offset!r}"
            )

    @classmethod
    def centred(cls, stride: int) -> PixelGrid:
        """Every ``stride``-th row and column, starting half a stride in."""
        return cls(stride=stride, offset=stride // 2)

    def indices(self, length_px: int) -> npt.NDArray[np.int64]:
        """The grid's rows (or columns) in an image ``length_px`` high (or wide)."""
        return np.arange(self.offset, length_px, self.stride, dtype=np.int64)

    def nearest(self, coordinate_px: npt.NDArray[np.floating]) -> npt.NDArray[np.floating]:
        """The grid row (or column) nearest each coordinate, as floats; may lie off the image."""
        return self.offset + self.stride * np.round((coordinate_px - self.offset) / self.stride)

    def mask(self, *, height_px: int, width_px: int) -> npt.NDArray[np.bool_]:
        """``(height_px, width_px)`` True on the grid's pixels."""
        rows = np.zeros(height_px, dtype=bool)
        cols = np.zeros(width_px, dtype=bool)
        rows[self.indices(height_px)] = True
        cols[self.indices(width_px)] = True
        return rows[:, None] & cols[None, :]


@dataclass
class Observation:
    """One RGB-D frame with the robot state it was taken at.

    Attributes:
        rgb: ``(H, W, 3)`` uint8 colour image.
        depth_m: ``(H, W)`` float32 depth along the optical axis in metres; 0 where invalid (out of
            range, no return), NaN where not measured (a backend asked for :class:`PixelGrid` pixels only
            may leave the others NaN).
        intrinsics: the depth-aligned colour intrinsics.
        camera_to_world: ``(4, 4)`` homogeneous transform T_w<-c (optical camera frame to ``map``).
        base_pose: the robot base pose in ``map`` (from odometry).
        stamp_s: capture time on the backend's clock.
        segmentation: ``(H, W)`` int32 per-pixel scene object id, ``BACKGROUND_OBJECT_ID`` elsewhere.
            Simulation ground truth: only the perception emulator reads it; real cameras leave it None.
    """

    rgb: npt.NDArray[np.uint8]
    depth_m: npt.NDArray[np.float32]
    intrinsics: CameraIntrinsics
    camera_to_world: FloatArray
    base_pose: Pose2D
    stamp_s: float
    segmentation: npt.NDArray[np.int32] | None = None


@dataclass(frozen=True)
class SceneProposal:
    """A scene-level (VLM) proposal: an image point with a label.

    Attributes:
        point_px: ``(u, v)`` image point (column, row).
        label: free-text semantic label.
        kind: ``"object"`` if the proposal names an object in view, ``"direction"`` if it indicates an
            unexplored direction (a doorway, a corridor, the far side of an occluder).
        region_px: optional ``(u0, v0, u1, v1)`` region; when None the arbitration builds one around
            ``point_px`` (see ``semexp_bt.core.evidence.scene_region``).
    """

    point_px: tuple[float, float]
    label: str
    kind: Literal["object", "direction"] = "object"
    region_px: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class SceneEvidence:
    """The VLM's reply for one view: proposals plus one scene-level confidence C_s in [0, 1]."""

    proposals: tuple[SceneProposal, ...]
    scene_confidence: float
    stamp_s: float = 0.0


@dataclass(frozen=True)
class Detection:
    """An open-vocabulary detection.

    Attributes:
        box_xyxy_px: ``(u0, v0, u1, v1)`` with u0 <= u1 and v0 <= v1.
        label: the text-aligned label.
        confidence: detector confidence C_o in [0, 1].
    """

    box_xyxy_px: tuple[float, float, float, float]
    label: str
    confidence: float


@dataclass(frozen=True)
class Subgoal:
    """The decision's output: a memory node and its 3D position in ``map``.

    Attributes:
        node_id: id of the selected node in the topological memory.
        position_m: ``(3,)`` world position.
        label: the node's semantic label.
        utility: U(v*) of Eq. 9.
    """

    node_id: int
    position_m: tuple[float, float, float]
    label: str
    utility: float


@dataclass(frozen=True)
class JointState:
    """Joint positions (rad) and velocities (rad/s) in the Go1 actuator order FR, FL, RR, RL x (hip, thigh, calf)."""

    position_rad: FloatArray
    velocity_radps: FloatArray


@dataclass(frozen=True)
class ImuReading:
    """Body-frame angular velocity (rad/s), linear acceleration (m/s^2) and orientation (wxyz quaternion)."""

    angular_velocity_radps: FloatArray
    linear_acceleration_mps2: FloatArray
    orientation_wxyz: FloatArray


@dataclass(frozen=True)
class ContactEvent:
    """A collision or clearance breach between the robot and a scene object.

    Attributes:
        stamp_s: when it happened.
        object_id: the scene object's id.
        distance_m: signed distance (negative = penetration / contact).
        kind: ``"collision"`` (contact) or ``"clearance"`` (closer than the clearance threshold).
    """

    stamp_s: float
    object_id: int
    distance_m: float
    kind: Literal["collision", "clearance"]


@dataclass
class SafetyState:
    """Safety flags a guard reads.

    Attributes:
        fallen: the base has tipped beyond the fall threshold (roll/pitch) or the trunk touches ground.
        events: contact and clearance events since the episode started, oldest first.
        min_clearance_m: smallest robot-to-obstacle distance seen in the last step.
        least_clearance_m: smallest robot-to-obstacle distance since the episode started (what an episode
            is scored on; ``inf`` where the backend does not measure distances, as on a real robot).
    """

    fallen: bool = False
    events: list[ContactEvent] = field(default_factory=list)
    min_clearance_m: float = math.inf
    least_clearance_m: float = math.inf


@dataclass(frozen=True)
class NodeState:
    """A read-only view of one topological-memory node (paper Sec. III-D).

    Attributes:
        node_id: the node's id in the memory graph.
        position_m: ``(x, y, z)`` in ``map``.
        label: semantic label L_v.
        confidence: fused confidence C_f of the node, in [0, 1].
        potential: exploration potential P_explore, in [0, 1].
        visits: how many times the robot reached this node.
        is_master: the master node v_m (the initial viewpoint).
    """

    node_id: int
    position_m: tuple[float, float, float]
    label: str
    confidence: float
    potential: float
    visits: int = 0
    is_master: bool = False


@dataclass(frozen=True)
class Target:
    """The evidence arbitration's output (p_t, L_t, C_f) of paper Eq. 3-4 (see ``semexp_bt.core.evidence``).

    Attributes:
        pixel_px: ``(u, v)`` target location p_t in the image (fused by Eq. 4 when both sources exist).
        label: semantic label L_t (the detection's label for a fused or object candidate).
        fused_confidence: normalised fused confidence C_f in [0, 1] of Eq. 3.
        source: ``"fused"`` (detection + scene proposal), ``"object"`` (detection only) or ``"scene"``
            (scene proposal only).
        kind: ``"direction"`` when the winner is a scene proposal of an unexplored direction, else
            ``"object"``.
        depth_m: robust (median) depth at ``pixel_px`` when a depth image was given and it has valid
            pixels there, else None. It is reported as measured, even outside the feasible range (the
            feasibility term kappa already penalised that).
    """

    pixel_px: tuple[float, float]
    label: str
    fused_confidence: float
    source: Literal["fused", "object", "scene"]
    kind: Literal["object", "direction"]
    depth_m: float | None = None
