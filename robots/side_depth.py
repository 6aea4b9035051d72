"""The Go1's flank depth cameras: short-range depth beside the body, where the head camera is blind.

The head camera (``robots.camera``) sees the floor from 0.8 m ahead of the base only, so the floor beside
the body, which a turn in place sweeps with the trunk's corners, is unobserved unless the robot walked
over it (docs/planner.md, eighth round: in tight rooms the controller's sweep rule then refuses five in
six of the motions that keep clearance, and the robot stands still). The Go1 carries a stereo pair on each
flank of its trunk for exactly this band (Unitree's five "body" camera pairs: face, chin, left, right,
belly); on a real robot their depth comes from Unitree's camera SDK, not from the RealSense.

Simulated here as two pinhole depth images measured by ray casting (``mj_multiRay``, no rasteriser), only
at the pixels the costmap reads, with the head camera's validity rules: outside the depth range or no hit
reads 0, and so does a ray that hits the robot's own legs (a real stereo camera's self-mask). Only the
costmap reads them; perception never does.

Example: with the defaults each camera looks 90 deg sideways, 40 deg down, from the trunk's flank
(0.085 m off the centre line, trunk height). It sees the floor from 0.1 m off the centre line (just
outside the flank) to about 2 m out, 53 deg fore and aft, which covers the Go1's turning circle (0.36 m
circumscribed radius).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from robots.camera import cast_depth, pixel_rays
from robots.mount import FLANK_SIDES, optical_to_base
from semexp_bt.core.types import CameraIntrinsics, FloatArray, InvalidInputError, PixelGrid


@dataclass(frozen=True)
class SideDepthConfig:
    """The two flank depth cameras (mirror images of each other).

    Attributes:
        width_px: image width; the costmap reads every ``pixel_stride``-th pixel of it.
        height_px: image height.
        vertical_fov_deg: vertical field of view (the horizontal follows from the aspect ratio: 106 deg).
        min_depth_m: depth below this reads 0.
        max_depth_m: depth beyond this reads 0 (Go1 body stereo is short range).
        mount_lateral_m: distance of each camera from the trunk's centre line (the flank is at 0.08 m).
        mount_height_m: height above the trunk centre.
        mount_pitch_down_deg: downward pitch of each optical axis.
    """

    width_px: int = 128
    height_px: int = 96
    vertical_fov_deg: float = 90.0
    min_depth_m: float = 0.05
    max_depth_m: float = 2.0
    mount_lateral_m: float = 0.085
    mount_height_m: float = 0.0
    mount_pitch_down_deg: float = 40.0

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if not isinstance(value, int) or value <= 0:
                raise InvalidInputError(f"SideDepthConfig.{name} must be a positive int, got {value!r}")
        if not 1.0 < self.vertical_fov_deg < 170.0:
            raise InvalidInputError(
                f"SideDepthConfig.vertical_fov_deg must lie in (1, 170), got {self.vertical_fov_deg}"
            )
        if not 0.0 < self.min_depth_m < self.max_depth_m:
            raise InvalidInputError(
                f"SideDepthConfig depth range must satisfy 0 < min_depth_m < max_depth_m, "
                f"got {self.min_depth_m}..{self.max_depth_m}"
            )
        if not -90.0 < self.mount_pitch_down_deg < 90.0:
            raise InvalidInputError(
                f"SideDepthConfig.mount_pitch_down_deg must lie in (-90, 90), got {self.mount_pitch_down_deg}"
            )

    def intrinsics(self) -> CameraIntrinsics:
        return CameraIntrinsics.from_fov(
            width_px=self.width_px, height_px=self.height_px, vertical_fov_deg=self.vertical_fov_deg
        )

    def optical_to_base(self, side: str) -> FloatArray:
        """T_trunk<-optical of the ``side`` camera (``"left"``: +y and yaw +90 deg, or ``"right"``)."""
        sign = 1.0 if side == "left" else -1.0
        return optical_to_base(
            (0.0, sign * self.mount_lateral_m, self.mount_height_m),
            0.0,
            math.radians(self.mount_pitch_down_deg),
            sign * math.pi / 2.0,
        )


#: The Go1's flank cameras as simulated by default.
GO1_SIDE_DEPTH = SideDepthConfig()


class SideDepthCameras:
    """Both flank cameras of one MuJoCo robot, measured by ray casting.

    Args:
        model: the compiled scene with the robot.
        config: the cameras.
        exclude_body_id: the trunk, which houses the cameras (rays start inside its box).
        robot_geoms: the robot's geoms: a ray that hits one reads 0.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        config: SideDepthConfig,
        exclude_body_id: int,
        robot_geoms: npt.NDArray[np.int32],
    ) -> None:
        self._model = model
        self.config = config
        self._exclude_body_id = exclude_body_id
        self._robot_geoms = robot_geoms
        self._geomgroup = mujoco.MjvOption().geomgroup
        self.mounts = {side: config.optical_to_base(side) for side in FLANK_SIDES}
        self.intrinsics = config.intrinsics()

    def measure(
        self, data: mujoco.MjData, base_to_world: FloatArray, *, pixel_grids: Sequence[PixelGrid]
    ) -> dict[str, tuple[npt.NDArray[np.float32], FloatArray]]:
        """Per side (:data:`~robots.mount.FLANK_SIDES` order), the depth image at the grids' pixels (NaN
        elsewhere) and its T_world<-optical.

        ``base_to_world`` is the trunk's pose as odometry reports it; ``data`` must have had forward
        kinematics.
        """
        rays = pixel_rays(
            self.intrinsics,
            height_px=self.config.height_px,
            width_px=self.config.width_px,
            pixel_grids=tuple(pixel_grids),
            max_depth_m=self.config.max_depth_m,
        )
        frames = {}
        for side, mount in self.mounts.items():
            camera_to_world = base_to_world @ mount
            depth = cast_depth(
                self._model,
                data,
                rays,
                origin_m=camera_to_world[:3, 3],
                optical_to_world=camera_to_world[:3, :3],
                geomgroup=self._geomgroup,
                exclude_body_id=self._exclude_body_id,
                depth_range_m=(self.config.min_depth_m, self.config.max_depth_m),
                shape=(self.config.height_px, self.config.width_px),
                invalid_geoms=self._robot_geoms,
            )
            frames[side] = (depth, camera_to_world)
        return frames
