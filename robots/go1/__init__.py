"""The Unitree Go1 description: the MJCF (``go1.xml``) and the facts code reads (``go1.yaml``).

Joint and actuator order everywhere is FR, FL, RR, RL x (hip, thigh, calf), as in
:class:`semexp_bt.core.types.JointState`.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from semexp_bt.core.types import FloatArray
from semexp_bt.nav.footprint import Footprint

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
#: The trunk's collision boxes in go1.xml (the kinematic base carries these plus the leg envelope).
TRUNK_BOX_GEOM_NAMES: tuple[str, ...] = ("trunk", "head")

#: Gap (m) between the floor and the bottom of the kinematic leg envelope: low enough that a kerb or a
#: cable counts, high enough that the floor itself never does.
LEG_ENVELOPE_GROUND_GAP_M = 0.02


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


def leg_envelope(spec: Go1Spec, trunk_height_m: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Centre and half extents (trunk frame) of a box bounding the legs in the standing pose.

    With the standing targets the knees stick out behind each hip (thigh pitched back), the feet sit
    under the hips; the box spans hip, knee and foot of every leg, padded by the foot radius, from
    :data:`LEG_ENVELOPE_GROUND_GAP_M` above the floor to the trunk's underside. For the shipped figures it
    is 0.59 m x 0.30 m, centred 8 cm behind the trunk centre.
    """
    thigh_angle, calf_angle = spec.standing_pose_rad[1], spec.standing_pose_rad[2]
    knee_dx = -spec.thigh_length_m * math.sin(thigh_angle)
    foot_dx = knee_dx - spec.calf_length_m * math.sin(thigh_angle + calf_angle)
    hip_x, hip_y, _ = spec.hip_offset_m
    xs = [sign * hip_x + dx for sign in (1.0, -1.0) for dx in (0.0, knee_dx, foot_dx)]
    pad = spec.foot_radius_m
    x_min, x_max = min(xs) - pad, max(xs) + pad
    half_y = hip_y + spec.thigh_offset_y_m + pad
    z_min = LEG_ENVELOPE_GROUND_GAP_M - trunk_height_m
    z_max = -0.05
    centre = ((x_min + x_max) / 2.0, 0.0, (z_min + z_max) / 2.0)
    half = ((x_max - x_min) / 2.0, half_y, (z_max - z_min) / 2.0)
    return centre, half


def trunk_boxes(
    path: Path = GO1_XML_PATH,
) -> dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """``name -> (centre, half extents)`` in the trunk frame of the trunk's collision boxes in go1.xml.

    Raises:
        ValueError: naming the file when a box of :data:`TRUNK_BOX_GEOM_NAMES` is missing or not a box.
    """
    trunk = ET.parse(path).getroot().find(f".//body[@name='{TRUNK_BODY_NAME}']")
    if trunk is None:
        raise ValueError(f"{path}: no body named '{TRUNK_BODY_NAME}'")
    boxes = {}
    for name in TRUNK_BOX_GEOM_NAMES:
        geom = trunk.find(f"geom[@name='{name}']")
        if geom is None or geom.get("type") != "box":
            raise ValueError(f"{path}: trunk has no box geom named '{name}'")
        size = tuple(float(v) for v in geom.get("size", "").split())
        pos = tuple(float(v) for v in geom.get("pos", "0 0 0").split())
        if len(size) != 3 or len(pos) != 3:
            raise ValueError(f"{path}: geom '{name}' needs a 3-value size and pos")
        boxes[name] = (pos, size)
    return boxes


@cache
def go1_footprint() -> Footprint:
    """The Go1's planar footprint for navigation: the rectangle around its trunk, head and standing legs.

    It is the plan view of exactly the geoms the kinematic backend checks for collisions (the trunk and
    head boxes of go1.xml and :func:`leg_envelope`), so the navigation stack and the simulator's safety
    checks describe one body: x from -0.378 m (rear feet) to +0.29 m (head), 0.30 m wide.
    """
    spec = load_go1_spec()
    boxes = list(trunk_boxes().values()) + [leg_envelope(spec, spec.standing_trunk_height_m)]
    x_min = min(c[0] - h[0] for c, h in boxes)
    x_max = max(c[0] + h[0] for c, h in boxes)
    half_width = max(abs(c[1]) + h[1] for c, h in boxes)
    return Footprint(x_min_m=x_min, x_max_m=x_max, half_width_m=half_width)
