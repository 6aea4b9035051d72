"""Where a camera sits on the base: one definition of the mount and of REP-103's optical frame.

Every backend reports a frame's pose the way a robot's own software does: the base's odometry pose times
the camera's static mount on the base. The ROS 2 backend takes the mount from the robot profile
(``robots/ros2_profile.py``), the MuJoCo backend from its :class:`robots.camera.CameraConfig`; both
build the transform here, so equal mounts give equal bits.
"""

from __future__ import annotations

import math

import numpy as np

from semexp_bt.core.types import FloatArray

#: The flank cameras' sides, in the order every backend returns their frames (left = +y on the base).
FLANK_SIDES: tuple[str, ...] = ("left", "right")

#: REP-103: the optical frame (x right, y down, z forward) in its camera link frame (x forward, y left,
#: z up). Columns are the optical axes written in the link frame.
OPTICAL_IN_LINK = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def rotation_from_rpy(roll_rad: float, pitch_rad: float, yaw_rad: float) -> FloatArray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), the URDF / tf2 convention."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def link_to_base(
    position_m: tuple[float, float, float], roll_rad: float, pitch_rad: float, yaw_rad: float
) -> FloatArray:
    """T_base<-camera_link (4x4): the mount as x, y, z (m) and roll, pitch, yaw (rad) on the base."""
    out = np.eye(4)
    out[:3, :3] = rotation_from_rpy(roll_rad, pitch_rad, yaw_rad)
    out[:3, 3] = position_m
    return out


def optical_to_base(
    position_m: tuple[float, float, float], roll_rad: float, pitch_rad: float, yaw_rad: float
) -> FloatArray:
    """T_base<-optical (4x4): the mount (:func:`link_to_base`), then REP-103's optical rotation."""
    out = link_to_base(position_m, roll_rad, pitch_rad, yaw_rad)
    out[:3, :3] = out[:3, :3] @ OPTICAL_IN_LINK
    return out


__all__ = ["OPTICAL_IN_LINK", "link_to_base", "optical_to_base", "rotation_from_rpy"]
