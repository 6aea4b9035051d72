"""Faults as data: what goes wrong, when, for how long, and how badly.

A fault list is a YAML list, given as a mission file's top-level ``faults:`` section or as a file of its
own (``semexp-bt run ... --faults FILE``, a mapping with the one key ``faults``)::

    faults:
      - class: camera_drop          # one of FAULT_CLASSES
        start_s: 20                 # robot-clock seconds after the mission starts
        duration_s: 5               # leave out (or null) for a fault that lasts to the end
        params: {drop_probability: 1.0}

Each entry becomes a :class:`FaultSpec` whose ``params`` is the class's own frozen dataclass (defaults for
what the entry leaves out), validated by :func:`semexp_bt.core.config.config_from_dict`: an unknown
class or key, a wrong type or an out-of-range value raises :class:`FaultSpecError` naming the file and
the key (``faults[1].params.drop_probability``). The wrappers that inject them are
:class:`sims.faults.robot.FaultyRobot` and :class:`sims.faults.perception.FaultyPerception`; what the
executive is expected to do about each class is in ``docs/reliability.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from semexp_bt.core.bounds import field_range
from semexp_bt.core.config import ConfigError, config_from_dict
from semexp_bt.files.yaml_source import YamlSourceError, load_yaml_file

PerceptionSourceName = Literal["vlm", "detector", "both"]


class FaultSpecError(ConfigError):
    """A fault list that cannot be used; the message names the file and the key."""


# ---------------------------------------------------------------------------------------------------
# Parameters, one dataclass per class
# ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CameraDropParams:
    """Frames the camera never delivers: readers get the newest frame that did arrive (an old stamp)."""

    drop_probability: float = field(default=1.0, metadata=field_range(0.0, 1.0))
    """Probability that each frame slot is lost (1: the camera is silent for the whole fault)."""
    frame_rate_hz: float = field(default=30.0, metadata=field_range(1.0, 1000.0))
    """The camera's frame rate: frame slots fall every 1 / rate seconds."""


@dataclass(frozen=True)
class NoParams:
    """A class without parameters."""


@dataclass(frozen=True)
class DepthCorruptParams:
    """Rectangular patches of every delivered depth frame read as holes (0) or as not-a-number."""

    value: Literal["zero", "nan"] = "nan"
    """``zero``: no return (how a RealSense reports a hole); ``nan``: garbage the driver let through."""
    patches: int = field(default=4, metadata=field_range(1, 100))
    """Patches per frame, placed anew on each frame."""
    patch_size_frac: float = field(default=0.3, metadata=field_range(0.01, 1.0))
    """Each patch's width and height as a fraction of the image's."""


@dataclass(frozen=True)
class OdometryJumpParams:
    """The odometry frame jumps once, at the fault's start, and keeps the offset (nothing corrects it)."""

    dx_m: float = field(default=0.5, metadata=field_range(-100.0, 100.0))
    """Jump along the map's x axis (m)."""
    dy_m: float = field(default=0.0, metadata=field_range(-100.0, 100.0))
    """Jump along the map's y axis (m)."""
    dyaw_deg: float = field(default=0.0, metadata=field_range(-180.0, 180.0))
    """Heading jump, about where the robot stood (degrees)."""


@dataclass(frozen=True)
class OdometryDriftParams:
    """The odometry frame drifts for the fault's duration and keeps the accumulated offset afterwards."""

    vx_mps: float = field(default=0.05, metadata=field_range(-10.0, 10.0))
    """Drift rate along the map's x axis (m/s)."""
    vy_mps: float = field(default=0.0, metadata=field_range(-10.0, 10.0))
    """Drift rate along the map's y axis (m/s)."""
    yaw_degps: float = field(default=2.0, metadata=field_range(-360.0, 360.0))
    """Heading drift rate, about where the robot stood when the drift began (degrees per second)."""


@dataclass(frozen=True)
class ImuSpikeParams:
    """Single IMU readings with a large spurious rate and acceleration (a loose connector, EMI)."""

    probability: float = field(default=0.2, metadata=field_range(0.0, 1.0))
    """Probability that each reading carries a spike."""
    gyro_radps: float = field(default=30.0, metadata=field_range(0.0, 1e4))
    """Magnitude added to the angular velocity, in a random direction (rad/s)."""
    accel_mps2: float = field(default=100.0, metadata=field_range(0.0, 1e4))
    """Magnitude added to the linear acceleration, in a random direction (m/s^2)."""


@dataclass(frozen=True)
class CommandsIgnoredParams:
    """The robot drops every command (twist, joint targets, stop): the command link is down."""

    robot_watchdog_s: float = field(default=0.5, metadata=field_range(0.0, 60.0))
    """The robot's own controller stops the base this long after the last command it accepted (the
    command watchdog of the Go1's controller and of ROS 2 drivers)."""


@dataclass(frozen=True)
class PerceptionGarbageParams:
    """Model replies that are not evidence: numbers out of range, or confident nonsense."""

    source: PerceptionSourceName = "both"
    """Which model's replies are garbled."""
    malformed: bool = True
    """True: not-a-number points, inverted boxes, confidences outside [0, 1] (a reply no validator
    should pass); False: well-formed replies naming things that are not there."""


@dataclass(frozen=True)
class PerceptionLateParams:
    """Model replies that arrive late (an overloaded server, a slow network)."""

    source: PerceptionSourceName = "both"
    """Which model answers late."""
    delay_s: float = field(default=30.0, metadata=field_range(0.0, 1e5))
    """Added to the reply's latency (robot-clock seconds)."""


@dataclass(frozen=True)
class PerceptionErrorParams:
    """Model requests that fail (the endpoint returns an error, the process died)."""

    source: PerceptionSourceName = "both"
    """Which model fails."""


@dataclass(frozen=True)
class ClockJumpParams:
    """The robot clock jumps (a time source resynchronised); sensor stamps jump with it."""

    jump_s: float = field(default=30.0, metadata=field_range(-1e6, 1e6))
    """The jump (s); negative jumps go back in time. The clock jumps back when the fault ends."""


@dataclass(frozen=True)
class FaultClass:
    """One kind of fault.

    Attributes:
        name: what ``class:`` says.
        params: its parameter dataclass.
        target: ``robot`` (injected by the Robot decorator) or ``perception`` (by the PerceptionSource
            decorator).
        sensor: the sensor it damages (``camera``, ``odometry``, ``imu``, ``clock``), or None.
        summary: one line for listings.
    """

    name: str
    params: type
    target: Literal["robot", "perception"]
    sensor: str | None
    summary: str


#: Every fault class, by name.
FAULT_CLASSES: dict[str, FaultClass] = {
    c.name: c
    for c in (
        FaultClass("camera_drop", CameraDropParams, "robot", "camera", "camera frames dropped"),
        FaultClass(
            "camera_freeze", NoParams, "robot", "camera", "the same old frame again and again, topic alive"
        ),
        FaultClass("depth_corrupt", DepthCorruptParams, "robot", "camera", "depth holes or NaN patches"),
        FaultClass("odometry_drop", NoParams, "robot", "odometry", "odometry stops updating"),
        FaultClass("odometry_jump", OdometryJumpParams, "robot", "odometry", "odometry jumps once"),
        FaultClass("odometry_drift", OdometryDriftParams, "robot", "odometry", "odometry drifts"),
        FaultClass("imu_drop", NoParams, "robot", "imu", "the IMU stops updating"),
        FaultClass("imu_spike", ImuSpikeParams, "robot", "imu", "IMU readings with spikes"),
        FaultClass("commands_ignored", CommandsIgnoredParams, "robot", None, "the robot ignores commands"),
        FaultClass("clock_jump", ClockJumpParams, "robot", "clock", "the robot clock jumps"),
        FaultClass(
            "perception_garbage", PerceptionGarbageParams, "perception", None, "garbage model replies"
        ),
        FaultClass("perception_late", PerceptionLateParams, "perception", None, "late model replies"),
        FaultClass("perception_error", PerceptionErrorParams, "perception", None, "failed model requests"),
    )
}

#: Keys of one entry of a fault list.
FAULT_KEYS: tuple[str, ...] = ("class", "start_s", "duration_s", "params")


@dataclass(frozen=True)
class FaultSpec:
    """One fault: its class, when it starts, how long it lasts, and its parameters.

    Attributes:
        fault_class: a key of :data:`FAULT_CLASSES`.
        start_s: robot-clock seconds after the mission started.
        duration_s: how long it lasts (s); None: to the end of the mission.
        params: the class's parameter dataclass.
    """

    fault_class: str
    start_s: float
    duration_s: float | None
    params: Any

    @property
    def kind(self) -> FaultClass:
        return FAULT_CLASSES[self.fault_class]

    @property
    def end_s(self) -> float:
        """When it ends (``inf`` for a fault that lasts)."""
        return math.inf if self.duration_s is None else self.start_s + self.duration_s

    def active(self, elapsed_s: float) -> bool:
        """Whether it acts ``elapsed_s`` after the mission started."""
        return self.start_s <= elapsed_s < self.end_s

    def to_dict(self) -> dict[str, Any]:
        """The entry as a fault file writes it."""
        from dataclasses import asdict

        return {
            "class": self.fault_class,
            "start_s": self.start_s,
            "duration_s": self.duration_s,
            "params": asdict(self.params),
        }


def _number(value: Any, *, where: str, key: str, minimum: float, open_low: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise FaultSpecError(f"{where}: key '{key}' must be a finite number, got {value!r}")
    if value < minimum or (open_low and value == minimum):
        bound = f"> {minimum:g}" if open_low else f">= {minimum:g}"
        raise FaultSpecError(f"{where}: key '{key}' must be {bound}, got {value!r}")
    return float(value)


def parse_fault(entry: Any, *, where: str, key: str) -> FaultSpec:
    """One entry of a fault list.

    Args:
        entry: the entry as YAML gave it.
        where: the file (and line) to name in errors.
        key: the entry's key path, e.g. ``faults[2]``.

    Raises:
        FaultSpecError: naming ``where`` and the key.
    """
    if not isinstance(entry, Mapping):
        raise FaultSpecError(
            f"{where}: '{key}' must be a mapping with keys {list(FAULT_KEYS)}, got {type(entry).__name__}"
        )
    unknown = [k for k in entry if k not in FAULT_KEYS]
    if unknown:
        raise FaultSpecError(f"{where}: unknown key '{key}.{unknown[0]}'; expected one of {list(FAULT_KEYS)}")
    name = entry.get("class")
    if name not in FAULT_CLASSES:
        raise FaultSpecError(
            f"{where}: key '{key}.class' must be one of {sorted(FAULT_CLASSES)}, got {name!r}"
        )
    if "start_s" not in entry:
        raise FaultSpecError(f"{where}: missing key '{key}.start_s' (robot-clock seconds after the start)")
    start = _number(entry["start_s"], where=where, key=f"{key}.start_s", minimum=0.0, open_low=False)
    duration_value = entry.get("duration_s")
    duration = (
        None
        if duration_value is None
        else _number(duration_value, where=where, key=f"{key}.duration_s", minimum=0.0, open_low=True)
    )
    kind = FAULT_CLASSES[str(name)]
    try:
        params = config_from_dict(
            entry.get("params") or {}, cls=kind.params, where=where, prefix=f"{key}.params"
        )
    except ConfigError as exc:
        raise FaultSpecError(str(exc)) from None
    if isinstance(params, ClockJumpParams) and params.jump_s == 0.0:
        raise FaultSpecError(f"{where}: key '{key}.params.jump_s' must not be 0")
    return FaultSpec(fault_class=str(name), start_s=start, duration_s=duration, params=params)


def parse_faults(data: Any, *, where: str) -> tuple[FaultSpec, ...]:
    """A fault list (the value of a ``faults:`` section): None or a list of entries.

    Raises:
        FaultSpecError: naming ``where`` and the key of the first bad entry.
    """
    if data is None:
        return ()
    if not isinstance(data, Sequence) or isinstance(data, (str, bytes)):
        raise FaultSpecError(f"{where}: 'faults' must be a list of faults, got {type(data).__name__}")
    return tuple(parse_fault(entry, where=where, key=f"faults[{i}]") for i, entry in enumerate(data))


def load_faults_file(path: str | Path) -> tuple[FaultSpec, ...]:
    """Read a fault file: a mapping with the one key ``faults`` holding a fault list.

    The file is read by the product's one safe YAML reader (``trees.yaml_source``: a regular file, small,
    UTF-8, plain tags, bounded nesting and aliases, no duplicate keys).

    Raises:
        FaultSpecError: one line naming the file (and the line and column, for YAML problems) when it
            cannot be read, is refused by the reader, has another shape, or holds a bad entry.
    """
    where = str(path)
    try:
        data = load_yaml_file(path)
    except YamlSourceError as exc:
        raise FaultSpecError(f"fault file {exc}") from None
    if not isinstance(data, Mapping) or set(data) != {"faults"}:
        raise FaultSpecError(
            f"{where}: a fault file is a mapping with the one key 'faults' (a list of faults)"
        )
    return parse_faults(data["faults"], where=where)
