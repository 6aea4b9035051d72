"""The Unitree Go1 description: the MJCF (``go1.xml``) and the facts code reads (``go1.yaml``).

Joint and actuator order everywhere is FR, FL, RR, RL x (hip, thigh, calf), as in
:class:`semexp_bt.core.types.JointState`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from semexp_bt.core.types import FloatArray

GO1_DIR = Path(__file__).resolve().parent
GO1_XML_PATH = GO1_DIR / "go1.xml"
GO1_YAML_PATH = GO1_DIR / "go1.yaml"

LEG_NAMES: tuple[str, ...] = ("FR", "FL", "RR", "RL")
LEG_JOINT_TYPES: tuple[str, ...] = ("hip", "thigh", "calf")
NUM_JOINTS = len(LEG_NAMES) * len(LEG_JOINT_TYPES)

#: Names of the trunk-mounted camera, IMU site and trunk body in go1.xml.
CAMERA_NAME = "head_camera"
IMU_SITE_NAME = "imu"
TRUNK_BODY_NAME = "trunk"
IMU_GYRO_SENSOR = "imu_gyro"
IMU_ACCELEROMETER_SENSOR = "imu_acc"
IMU_ORIENTATION_SENSOR = "imu_quat"


@dataclass(frozen=True)
class Go1Spec:
    """The Go1 facts from ``go1.yaml``, expanded to per-joint arrays in actuator order.

    Attributes:
        joint_names: the 12 joint names.
        standing_pose_rad: ``(12,)`` standing joint targets.
        home_trunk_height_m: trunk height of the "home" keyframe (legs at the standing targets, no sag).
        standing_trunk_height_m: trunk height once the PD has settled under gravity holding the targets.
        joint_lower_rad: ``(12,)`` lower joint limits.
        joint_upper_rad: ``(12,)`` upper joint limits.
        torque_limit_nm: ``(12,)`` peak motor torques.
        kp_nm_per_rad: position gain of every actuator.
        kd_nm_s_per_rad: velocity gain of every actuator.
        hip_offset_m: |x|, |y|, z of the hip joints from the trunk centre.
        thigh_offset_y_m: lateral offset of the thigh joint from the hip joint.
        thigh_length_m: hip-to-knee length.
        calf_length_m: knee-to-foot length.
        foot_radius_m: radius of the foot sphere.
        fall_tilt_rad: roll or pitch beyond which the robot counts as fallen.
        fall_trunk_height_m: trunk height below which the robot counts as fallen.
    """

    joint_names: tuple[str, ...]
    standing_pose_rad: FloatArray
    home_trunk_height_m: float
    standing_trunk_height_m: float
    joint_lower_rad: FloatArray
    joint_upper_rad: FloatArray
    torque_limit_nm: FloatArray
    kp_nm_per_rad: float
    kd_nm_s_per_rad: float
    hip_offset_m: tuple[float, float, float]
    thigh_offset_y_m: float
    thigh_length_m: float
    calf_length_m: float
    foot_radius_m: float
    fall_tilt_rad: float
    fall_trunk_height_m: float


def _per_joint(table: dict[str, Any], key: str) -> list[Any]:
    try:
        return [table[joint_type] for _ in LEG_NAMES for joint_type in LEG_JOINT_TYPES]
    except KeyError as err:
        raise KeyError(f"{GO1_YAML_PATH}: '{key}' lacks joint type {err}") from None


@cache
def load_go1_spec(path: Path = GO1_YAML_PATH) -> Go1Spec:
    """Read ``go1.yaml`` (cached).

    Raises:
        KeyError: naming the file and key when a key is missing.
    """
    raw = yaml.safe_load(Path(path).read_text())

    def get(key: str) -> Any:
        if key not in raw:
            raise KeyError(f"{path}: missing key '{key}'")
        return raw[key]

    joint_names = tuple(str(name) for name in get("joint_names"))
    if len(joint_names) != NUM_JOINTS:
        raise ValueError(f"{path}: 'joint_names' must list {NUM_JOINTS} joints, got {len(joint_names)}")
    ranges = np.array(_per_joint(get("joint_range_rad"), "joint_range_rad"), dtype=float)
    standing_leg = np.asarray(get("standing_pose_rad"), dtype=float)
    if standing_leg.shape != (len(LEG_JOINT_TYPES),):
        raise ValueError(f"{path}: 'standing_pose_rad' must hold (hip, thigh, calf), got {standing_leg}")
    return Go1Spec(
        joint_names=joint_names,
        standing_pose_rad=np.tile(standing_leg, len(LEG_NAMES)),
        home_trunk_height_m=float(get("home_trunk_height_m")),
        standing_trunk_height_m=float(get("standing_trunk_height_m")),
        joint_lower_rad=ranges[:, 0].copy(),
        joint_upper_rad=ranges[:, 1].copy(),
        torque_limit_nm=np.array(_per_joint(get("torque_limit_nm"), "torque_limit_nm"), dtype=float),
        kp_nm_per_rad=float(get("kp_nm_per_rad")),
        kd_nm_s_per_rad=float(get("kd_nm_s_per_rad")),
        hip_offset_m=tuple(float(v) for v in get("hip_offset_m")),  # type: ignore[arg-type]
        thigh_offset_y_m=float(get("thigh_offset_y_m")),
        thigh_length_m=float(get("thigh_length_m")),
        calf_length_m=float(get("calf_length_m")),
        foot_radius_m=float(get("foot_radius_m")),
        fall_tilt_rad=float(get("fall_tilt_rad")),
        fall_trunk_height_m=float(get("fall_trunk_height_m")),
    )
