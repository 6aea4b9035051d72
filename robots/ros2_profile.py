"""The robot profile of the ROS 2 backend: topic names, frames, QoS, deadlines and the camera mount.

A profile is a YAML file the user edits for their robot; ``robots/go1/ros2.yaml`` is the Go1 with the
snt-arg/unitree_ros driver and realsense-ros 4.55+ (``align_depth.enable:=true``). It is read once into a
typed :class:`Ros2Profile`; every key is validated (unknown keys, wrong types and out-of-range values
raise :class:`ProfileError` naming the file and the dotted key), and every key has the default of the
shipped Go1 profile, so a user's file only states what differs.

No ROS import happens here: the profile is plain data, readable and testable without rclpy.

Example:
    >>> profile = load_ros2_profile()
    >>> profile.topics.depth_image
    '/camera/camera/aligned_depth_to_color/image_raw'
    >>> profile.deadline_of("odom")
    0.5
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from robots.mount import FLANK_SIDES, link_to_base, optical_to_base
from semexp_bt.core.bounds import field_range
from semexp_bt.core.config import ConfigError, config_from_dict
from semexp_bt.core.types import FloatArray
from semexp_bt.files.yaml_source import YamlSourceError, load_yaml_file

#: The shipped Go1 profile.
GO1_PROFILE_PATH = Path(__file__).resolve().parent / "go1" / "ros2.yaml"

#: The sensor streams the backend watches, by their key in ``topics``.
SENSOR_STREAMS: tuple[str, ...] = ("odom", "imu", "joint_states", "color_image", "color_info", "depth_image")
#: The flank depth cameras' streams (``side_depth``): ``<side>_depth_image`` and ``<side>_depth_info``.
SIDE_DEPTH_STREAMS: tuple[str, ...] = tuple(
    f"{side}_depth_{kind}" for side in FLANK_SIDES for kind in ("image", "info")
)


class ProfileError(ConfigError):
    """A robot profile key is unknown, missing, of the wrong type or out of range (names file and key)."""


@dataclass(frozen=True)
class Topics:
    """Topic names (absolute)."""

    cmd_vel: str = "/cmd_vel"
    """geometry_msgs/Twist the driver walks by."""
    odom: str = "/odom"
    """nav_msgs/Odometry of ``base_link`` in ``odom``."""
    imu: str = "/imu"
    """sensor_msgs/Imu of the trunk."""
    joint_states: str = "/joint_states"
    """sensor_msgs/JointState of the 12 leg joints."""
    color_image: str = "/camera/camera/color/image_raw"
    """sensor_msgs/Image, rgb8."""
    color_info: str = "/camera/camera/color/camera_info"
    """sensor_msgs/CameraInfo of the colour stream (the aligned depth shares it)."""
    depth_image: str = "/camera/camera/aligned_depth_to_color/image_raw"
    """sensor_msgs/Image, 16UC1 millimetres aligned to colour, 0 = no depth."""
    clock: str = "/clock"
    """rosgraph_msgs/Clock, in simulation (``use_sim_time``)."""


@dataclass(frozen=True)
class Frames:
    """REP-105 frame ids."""

    odom: str = "odom"
    base: str = "base_link"
    camera_link: str = "camera_link"
    camera_optical: str = "camera_color_optical_frame"


Reliability = Literal["reliable", "best_effort"]
Durability = Literal["volatile", "transient_local"]


@dataclass(frozen=True)
class TopicQos:
    """The QoS of one topic. A subscriber asking ``reliable`` does not match a ``best_effort`` publisher."""

    reliability: Reliability = "reliable"
    durability: Durability = "volatile"
    depth: int = field(default=5, metadata=field_range(1, 1000))
    """History depth (keep last)."""


def _qos(reliability: Reliability, depth: int) -> Any:
    return field(default_factory=lambda: TopicQos(reliability=reliability, depth=depth))


@dataclass(frozen=True)
class QosTable:
    """QoS per topic, as the Go1 driver and realsense-ros offer them."""

    cmd_vel: TopicQos = _qos("best_effort", 1)
    odom: TopicQos = _qos("reliable", 10)
    imu: TopicQos = _qos("reliable", 10)
    joint_states: TopicQos = _qos("reliable", 1)
    color_image: TopicQos = _qos("reliable", 5)
    color_info: TopicQos = _qos("reliable", 5)
    depth_image: TopicQos = _qos("reliable", 5)
    clock: TopicQos = _qos("best_effort", 1)
    side_depth: TopicQos = _qos("reliable", 5)
    """Both flank cameras' images and camera infos."""


def _deadline(seconds: float) -> Any:
    return field(default=seconds, metadata=field_range(0.0, 60.0, low_open=True))


@dataclass(frozen=True)
class Deadlines:
    """How long (s, wall clock) a sensor topic may stay silent before the backend zeroes the twist and
    halts the mission naming it."""

    odom: float = _deadline(0.5)
    imu: float = _deadline(0.5)
    joint_states: float = _deadline(1.0)
    color_image: float = _deadline(1.0)
    color_info: float = _deadline(1.0)
    depth_image: float = _deadline(1.0)
    side_depth: float = _deadline(1.0)
    """Each flank camera's image and camera info, where they are used."""
    startup_s: float = _deadline(15.0)
    """How long the backend waits for every sensor's first message (and, in simulation, the bridge)."""


@dataclass(frozen=True)
class Command:
    """The velocity command stream."""

    rate_hz: float = field(default=25.0, metadata=field_range(20.0, 1000.0))
    """The last twist is republished this often: the driver zeroes the motion ``driver_timeout_s`` after
    the last command, so a mission that holds a command must keep sending it."""
    driver_timeout_s: float = field(default=0.4, metadata=field_range(0.0, 10.0, low_open=True))
    """The driver's command timeout (the simulation bridge obeys the same)."""


@dataclass(frozen=True)
class CameraMount:
    """``base_link`` -> ``camera_link`` (x forward, y left, z up); the optical frame follows REP-103.

    Defaults: the Go1 head camera of the simulation (``robots.camera.CameraConfig``: 0.28 m ahead of and
    0.05 m above the trunk centre, pitched 10 deg down). Measure your robot's mount and write it here.
    """

    x_m: float = field(default=0.28, metadata=field_range(-5.0, 5.0))
    y_m: float = field(default=0.0, metadata=field_range(-5.0, 5.0))
    z_m: float = field(default=0.05, metadata=field_range(-5.0, 5.0))
    roll_rad: float = field(default=0.0, metadata=field_range(-math.pi, math.pi))
    pitch_rad: float = field(default=math.radians(10.0), metadata=field_range(-math.pi / 2, math.pi / 2))
    """Positive pitches the camera down (REP-103: rotation about +y)."""
    yaw_rad: float = field(default=0.0, metadata=field_range(-math.pi, math.pi))


@dataclass(frozen=True)
class Camera:
    """The RGB-D pair."""

    mount: CameraMount = field(default_factory=CameraMount)
    pair_tolerance_s: float = field(default=0.005, metadata=field_range(0.0, 1.0))
    """Colour and aligned depth frames are a pair when their stamps differ by at most this (realsense-ros
    stamps both with the colour frame's time)."""


#: The simulated flank cameras' mount (``robots.side_depth.SideDepthConfig``'s defaults; a test checks
#: that they agree): on the trunk's flank, 0.085 m off the centre line, pitched 40 deg down.
_SIDE_LATERAL_M = 0.085
_SIDE_PITCH_RAD = math.radians(40.0)


def _side_mount(sign: float) -> Any:
    return field(
        default_factory=lambda: CameraMount(
            x_m=0.0,
            y_m=sign * _SIDE_LATERAL_M,
            z_m=0.0,
            pitch_rad=_SIDE_PITCH_RAD,
            yaw_rad=sign * math.pi / 2,
        )
    )


@dataclass(frozen=True)
class LeftCamera:
    """The left flank depth camera: its depth image (16UC1 millimetres, 0 = no depth), camera info, optical
    frame id and mount (base_link -> its camera link, as :class:`CameraMount`)."""

    image: str = "/body_camera/left/depth/image_raw"
    info: str = "/body_camera/left/depth/camera_info"
    frame: str = "body_camera_left_optical_frame"
    mount: CameraMount = _side_mount(1.0)


@dataclass(frozen=True)
class RightCamera:
    """The right flank depth camera (as :class:`LeftCamera`, mirrored)."""

    image: str = "/body_camera/right/depth/image_raw"
    info: str = "/body_camera/right/depth/camera_info"
    frame: str = "body_camera_right_optical_frame"
    mount: CameraMount = _side_mount(-1.0)


@dataclass(frozen=True)
class SideDepth:
    """The flank depth cameras (``robots/side_depth.py``): the floor beside the body, for the costmap.

    On a real robot they are used when ``enabled``; the snt-arg/unitree_ros driver does not publish the
    Go1's body cameras, so the shipped profile leaves them off (docs/ros2.md says what to run). The
    simulation bridge always simulates and publishes them on these topics and says so on ``/sim/scene``;
    its executive then uses them whatever ``enabled`` says, as the in-process run does.
    """

    enabled: bool = False
    left: LeftCamera = field(default_factory=LeftCamera)
    right: RightCamera = field(default_factory=RightCamera)

    def camera(self, side: str) -> LeftCamera | RightCamera:
        return self.left if side == "left" else self.right


@dataclass(frozen=True)
class Ros2Profile:
    """A robot on ROS 2 (see the module docstring). ``source`` names the file it came from."""

    robot: str = "go1"
    use_sim_time: bool = False
    """Read time from ``/clock`` (the simulation bridge sets it for its executive regardless)."""
    topics: Topics = field(default_factory=Topics)
    frames: Frames = field(default_factory=Frames)
    qos: QosTable = field(default_factory=QosTable)
    deadlines_s: Deadlines = field(default_factory=Deadlines)
    command: Command = field(default_factory=Command)
    camera: Camera = field(default_factory=Camera)
    side_depth: SideDepth = field(default_factory=SideDepth)
    source: str = "<defaults>"

    def deadline_of(self, stream: str) -> float:
        """The silence deadline (s) of a sensor stream (a key of :data:`SENSOR_STREAMS` or
        :data:`SIDE_DEPTH_STREAMS`)."""
        if stream in SIDE_DEPTH_STREAMS:
            return float(self.deadlines_s.side_depth)
        return float(getattr(self.deadlines_s, stream))

    def topic_of(self, stream: str) -> str:
        """The topic name of a stream key."""
        if stream in SIDE_DEPTH_STREAMS:
            side, _, kind = stream.split("_")
            return str(getattr(self.side_depth.camera(side), kind))
        return str(getattr(self.topics, stream))

    def side_optical_to_base(self, side: str) -> FloatArray:
        """T_base<-optical (4x4) of a flank camera."""
        m = self.side_depth.camera(side).mount
        return optical_to_base((m.x_m, m.y_m, m.z_m), m.roll_rad, m.pitch_rad, m.yaw_rad)

    def camera_link_to_base(self) -> FloatArray:
        """T_base<-camera_link (4x4) from the mount."""
        m = self.camera.mount
        return link_to_base((m.x_m, m.y_m, m.z_m), m.roll_rad, m.pitch_rad, m.yaw_rad)

    def optical_to_base(self) -> FloatArray:
        """T_base<-optical (4x4): the mount, then REP-103's optical rotation (``robots.mount``)."""
        m = self.camera.mount
        return optical_to_base((m.x_m, m.y_m, m.z_m), m.roll_rad, m.pitch_rad, m.yaw_rad)


def read_profile_document(path: Path) -> Any:
    """The parsed YAML of a profile file, read by the product's one safe YAML reader
    (``semexp_bt.files.yaml_source``: not a regular file, too big, not UTF-8, tabs, deep nesting, alias
    bombs, duplicate keys and non-plain tags are refused).

    Raises:
        ProfileError: one line naming the file (and the line and column where there is one).
    """
    try:
        return load_yaml_file(path)
    except YamlSourceError as error:
        raise ProfileError(f"robot profile {error}") from None


def _check_strings(value: Any, where: str, prefix: str) -> None:
    """config_from_dict checks numbers, booleans and literals; names must be non-empty strings too."""
    for f in dataclasses.fields(value):
        key = f"{prefix}.{f.name}" if prefix else f.name
        item = getattr(value, f.name)
        if dataclasses.is_dataclass(item):
            _check_strings(item, where, key)
        elif f.type in ("str", str) and (not isinstance(item, str) or not item.strip()):
            raise ProfileError(f"{where}: key '{key}' must be a non-empty string, got {item!r}")
    if isinstance(value, Topics | LeftCamera | RightCamera):
        names = [f for f in dataclasses.fields(value) if f.name != "frame" and f.type in ("str", str)]
        for f in names:
            name = getattr(value, f.name)
            if not name.startswith("/") or " " in name:
                raise ProfileError(
                    f"{where}: key '{prefix}.{f.name}' must be an absolute topic name, got {name!r}"
                )


def profile_from_dict(data: Any, *, where: str) -> Ros2Profile:
    """Build and validate a profile from a parsed document (``where`` names its source in errors)."""
    if data is None:
        data = {}
    if isinstance(data, dict) and "source" in data:
        raise ProfileError(f"{where}: unknown key 'source'")
    try:
        profile: Ros2Profile = config_from_dict(data, cls=Ros2Profile, where=where)
    except ProfileError:
        raise
    except ConfigError as error:
        raise ProfileError(str(error)) from None
    _check_strings(profile, where, "")
    return dataclasses.replace(profile, source=where)


def load_ros2_profile(path: str | Path | None = None) -> Ros2Profile:
    """Read and validate a robot profile (the shipped Go1 profile when ``path`` is None).

    Raises:
        ProfileError: naming the file and the key (or line) that is wrong.
    """
    file = Path(path) if path is not None else GO1_PROFILE_PATH
    return profile_from_dict(read_profile_document(file), where=str(file))


__all__ = [
    "GO1_PROFILE_PATH",
    "SENSOR_STREAMS",
    "SIDE_DEPTH_STREAMS",
    "ProfileError",
    "Ros2Profile",
    "load_ros2_profile",
    "profile_from_dict",
    "read_profile_document",
]
