"""NullRobot: a Robot with no physics and no rendering, for measuring the tree alone and for fast tests.

The base is a unicycle that follows the commanded twist exactly; the camera ray-casts an analytic world
(a flat floor plus optional vertical cylinders, "posts", each with an object id for the segmentation)
and returns a blank colour image. Nothing collides and nothing falls. It exists so that the executive's own cost (py_trees ticks,
blackboard, the paper's maths) can be measured without MuJoCo, and so that behaviours can be tested
against a backend that does exactly what it is told.

Example:
    >>> robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    >>> robot.command_twist(Twist(linear_x_mps=1.0)); robot.advance(0.5); round(robot.base_pose().x_m, 3)
    0.5
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from robots.interface import Fidelity, Robot
from robots.mount import OPTICAL_IN_LINK
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import (
    CameraIntrinsics,
    ImuReading,
    JointState,
    Observation,
    PixelGrid,
    Pose2D,
    SafetyState,
    Twist,
    require_finite,
)

#: Camera height above the floor and image size of the synthetic camera (the Go1 head at 320x240).
CAMERA_HEIGHT_M = 0.30
IMAGE_WIDTH_PX = 320
IMAGE_HEIGHT_PX = 240
VERTICAL_FOV_DEG = 42.5


class NullRobot(Robot):
    """A perfect unicycle with a synthetic depth camera (see module docstring)."""

    def __init__(
        self,
        *,
        start_pose: Pose2D,
        posts: tuple[tuple[int, float, float, float, float], ...] = (),
        max_depth_m: float = 10.0,
        render_once: bool = False,
    ) -> None:
        """Args:
        start_pose: the initial base pose.
        posts: ``(object_id, x_m, y_m, radius_m, height_m)`` vertical cylinders standing on the floor.
        max_depth_m: farther returns read 0 (no return), as on a D435i.
        render_once: ray-cast the first frame only and return it ever after (to time the executive
            without any rendering cost; the images then ignore the pose).
        """
        self._pose = start_pose
        self._twist = Twist.zero()
        self._time_s = 0.0
        self.intrinsics = CameraIntrinsics.from_fov(
            width_px=IMAGE_WIDTH_PX, height_px=IMAGE_HEIGHT_PX, vertical_fov_deg=VERTICAL_FOV_DEG
        )
        self.posts = tuple(posts)
        self.render_once = render_once
        self._frame: tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]] | None = None
        self.max_depth_m = max_depth_m
        self.joint_targets = np.zeros(12)
        self.stopped = 0
        u, v = np.meshgrid(np.arange(IMAGE_WIDTH_PX, dtype=float), np.arange(IMAGE_HEIGHT_PX, dtype=float))
        # Optical-frame ray directions with unit z (so the ray parameter is the depth along the axis).
        self._rays = np.stack(
            [
                (u - self.intrinsics.cx_px) / self.intrinsics.fx_px,
                (v - self.intrinsics.cy_px) / self.intrinsics.fy_px,
                np.ones_like(u),
            ],
            axis=-1,
        )

    def render(self) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]:
        """Depth (m along the optical axis, 0 = no return) and segmentation of the analytic world."""
        return self._cast(self._rays)

    def _cast(self, rays: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]:
        """Depth and segmentation along optical-frame rays of unit z (any leading shape)."""
        t = self._camera_to_world()
        dirs = rays @ t[:3, :3].T  # world-frame ray per pixel, scaled so that depth = parameter
        origin = t[:3, 3]
        depth = np.full(dirs.shape[:-1], np.inf)
        seg = np.full(dirs.shape[:-1], -1, dtype=np.int32)
        down = dirs[..., 2] < -1e-9
        depth[down] = -origin[2] / dirs[..., 2][down]
        for object_id, px, py, radius, height in self.posts:
            ox, oy = origin[0] - px, origin[1] - py
            a = dirs[..., 0] ** 2 + dirs[..., 1] ** 2
            b = 2.0 * (ox * dirs[..., 0] + oy * dirs[..., 1])
            c = ox * ox + oy * oy - radius * radius
            disc = b * b - 4.0 * a * c
            hit = (disc >= 0.0) & (a > 1e-12)
            root = np.where(
                hit, (-b - np.sqrt(np.where(hit, disc, 0.0))) / (2.0 * np.where(hit, a, 1.0)), np.inf
            )
            z = origin[2] + root * dirs[..., 2]
            hit &= (root > 0.0) & (z >= 0.0) & (z <= height) & (root < depth)
            depth[hit] = root[hit]
            seg[hit] = object_id
        depth[~np.isfinite(depth) | (depth > self.max_depth_m)] = 0.0
        return depth.astype(np.float32), seg

    # --- clock -----------------------------------------------------------------------------------------
    def now_s(self) -> float:
        return self._time_s

    def advance(self, duration_s: float) -> None:
        require_finite("duration_s", duration_s)
        x, y, yaw = self._pose.x_m, self._pose.y_m, self._pose.yaw_rad
        mid = yaw + 0.5 * self._twist.angular_z_radps * duration_s
        vx, vy = self._twist.linear_x_mps, self._twist.linear_y_mps
        x += (math.cos(mid) * vx - math.sin(mid) * vy) * duration_s
        y += (math.sin(mid) * vx + math.cos(mid) * vy) * duration_s
        yaw = wrap_angle(yaw + self._twist.angular_z_radps * duration_s)
        self._pose = Pose2D(x, y, yaw)
        self._time_s += duration_s

    # --- sensing ---------------------------------------------------------------------------------------
    def _camera_to_world(self) -> npt.NDArray[np.float64]:
        c, s = math.cos(self._pose.yaw_rad), math.sin(self._pose.yaw_rad)
        # optical frame (x right, y down, z forward) -> base (x forward, y left, z up) -> world
        base_to_world = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        out = np.eye(4)
        out[:3, :3] = base_to_world @ OPTICAL_IN_LINK
        out[:3, 3] = [self._pose.x_m, self._pose.y_m, CAMERA_HEIGHT_M]
        return out

    def observe(self) -> Observation:
        if self._frame is None or not self.render_once:
            self._frame = self.render()
        depth, seg = self._frame
        return Observation(
            rgb=np.zeros((IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, 3), dtype=np.uint8),
            depth_m=depth,
            intrinsics=self.intrinsics,
            camera_to_world=self._camera_to_world(),
            base_pose=self._pose,
            stamp_s=self._time_s,
            segmentation=seg,
        )

    def observe_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> Observation:
        """Depth only; with ``pixel_grids``, only those pixels are ray-cast and the others are NaN.

        With ``render_once`` the first full frame is returned ever after, as :meth:`observe` does.
        """
        if pixel_grids is None or self.render_once:
            return self.observe()
        mask = np.zeros((IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX), dtype=bool)
        for grid in pixel_grids:
            mask |= grid.mask(height_px=IMAGE_HEIGHT_PX, width_px=IMAGE_WIDTH_PX)
        depth = np.full((IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX), np.nan, dtype=np.float32)
        depth[mask], _ = self._cast(self._rays[mask])
        return Observation(
            rgb=np.empty((0, 0, 3), dtype=np.uint8),
            depth_m=depth,
            intrinsics=self.intrinsics,
            camera_to_world=self._camera_to_world(),
            base_pose=self._pose,
            stamp_s=self._time_s,
        )

    def base_pose(self) -> Pose2D:
        return self._pose

    def base_twist(self) -> Twist:
        return self._twist

    def joint_state(self) -> JointState:
        return JointState(position_rad=np.zeros(12), velocity_radps=np.zeros(12))

    def imu(self) -> ImuReading:
        return ImuReading(
            angular_velocity_radps=np.array([0.0, 0.0, self._twist.angular_z_radps]),
            linear_acceleration_mps2=np.array([0.0, 0.0, 9.81]),
            orientation_wxyz=np.array(
                [math.cos(self._pose.yaw_rad / 2), 0.0, 0.0, math.sin(self._pose.yaw_rad / 2)]
            ),
        )

    # --- commands --------------------------------------------------------------------------------------
    def command_twist(self, twist: Twist) -> None:
        require_finite("twist", [twist.linear_x_mps, twist.linear_y_mps, twist.angular_z_radps])
        self._twist = twist

    def command_joint_targets(self, targets_rad: npt.NDArray[np.float64]) -> None:
        require_finite("targets_rad", targets_rad)
        self.joint_targets = np.asarray(targets_rad, dtype=float).copy()

    def stop(self) -> None:
        self._twist = Twist.zero()
        self.stopped += 1

    def safety(self) -> SafetyState:
        return SafetyState()

    @property
    def fidelity(self) -> Fidelity:
        return "kinematic"
