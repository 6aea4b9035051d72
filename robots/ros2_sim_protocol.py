"""The simulation-only side of the ROS 2 link: ``/sim/...`` topics between the MuJoCo bridge and the executive.

The driver's and the camera's topics (the robot profile's) carry what a real Go1 carries. What only a
simulation has travels here, never on those:

| topic | type | from -> to | what |
| --- | --- | --- | --- |
| ``/sim/scene`` | std_msgs/String (JSON), transient local | bridge -> executive | the scene's catalogue for the perception emulator: object ids, labels, categories, roles, sizes; no positions |
| ``/sim/step`` | geometry_msgs/TwistStamped, best effort | executive -> bridge | lockstep: step the world to ``header.stamp`` applying ``twist``; a step for a stamp already reached is answered with the state again (how a lost step or reply is made good) |
| ``/sim/camera/request`` | std_msgs/String (JSON) | executive -> bridge | lockstep: render the camera now (``full``, or ``depth`` at pixel grids), or measure the flank cameras (``side``, at pixel grids), at the executive's instant (``at_ns``) |
| ``/sim/camera/segmentation`` | sensor_msgs/Image 16UC1 (id + 1) | bridge -> executive | the segmentation of each full frame, stamped as the colour frame |
| ``/sim/camera/depth_grid`` | sensor_msgs/Image 16UC1 (mm) | bridge -> executive | lockstep: the answer to a ``depth`` request at pixel grids, the depth of the grids' rows and columns only (robots/ros2_messages.py, ``fill_depth_grid_image``), beside the camera info |
| ``/sim/outcome`` | std_msgs/String (JSON), transient local | executive -> bridge | the mission's declared outcome and confirmed targets, and the instant it ended at, for the bridge's scoring |
| ``/sim/time`` | std_msgs/Float64 | bridge -> executive | the simulator's clock in float seconds (``/clock`` is its nanosecond rounding); the lockstep executive's clock, so that its time comparisons are the in-process run's to the bit |
| ``/sim/state`` | std_msgs/Float64MultiArray (:data:`STATE_FIELDS`), best effort | bridge -> executive | lockstep: after each step, the one reply: the step's stamp, the float clock, the odometry, the IMU and the joints (the values ``/odom``, ``/sim/time``, ``/imu`` and ``/joint_states`` carry), and the twist the steps were made with and the instant they started from, so that a step costs one message and one wake-up; also the states of the steps the bridge takes ahead (``SPECULATION_DEPTH``), sent at once (the executive takes one without a wait when it asks for that step under that twist: sims/ros2_bridge.py, ``Speculation``) |
| ``/sim/heartbeat`` | std_msgs/Header | bridge -> executive | every 0.1 s from a thread of its own: the bridge is alive, if busy (a lockstep wait halts only after the deadline passes without it) |

Every other ``/sim/...`` topic is reliable. The bridge keeps the ground truth (where things are, which object is reached, collisions) to itself and
scores the episode; the executive's emulator needs only what a detector "knows" about the classes.

This module is plain data (no rclpy): the names and the JSON payloads, encoded and decoded in one place.
"""

from __future__ import annotations

import array
import json
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import ImuReading, InvalidInputError, JointState, PixelGrid, Twist

SCENE_TOPIC = "/sim/scene"
STEP_TOPIC = "/sim/step"
CAMERA_REQUEST_TOPIC = "/sim/camera/request"
SEGMENTATION_TOPIC = "/sim/camera/segmentation"
#: Lockstep renders asked at pixel grids: the depth on the grids' rows and columns only (the driver's depth
#: topic carries whole frames).
DEPTH_GRID_TOPIC = "/sim/camera/depth_grid"
OUTCOME_TOPIC = "/sim/outcome"
HEARTBEAT_TOPIC = "/sim/heartbeat"
TIME_TOPIC = "/sim/time"
STATE_TOPIC = "/sim/state"
#: The bridge's heartbeat period (s, wall clock).
HEARTBEAT_PERIOD_S = 0.1

BridgeMode = Literal["lockstep", "realtime"]
#: ``lockstep``: the world steps one control period per executive tick and renders on request (the
#: in-process run's semantics, over DDS); ``realtime``: it runs on the wall clock like a robot.
BRIDGE_MODES: tuple[str, ...] = ("lockstep", "realtime")

FrameKind = Literal["full", "depth", "side"]
FRAME_KINDS: tuple[str, ...] = ("full", "depth", "side")


class SimProtocolError(InvalidInputError):
    """A ``/sim/...`` payload that does not parse (names the topic and the field)."""


@dataclass(frozen=True)
class SimulationInfo:
    """What the bridge announces on ``/sim/scene``.

    Attributes:
        mode: ``lockstep`` or ``realtime``.
        control_period_s: the world's control period (one step).
        seed: the episode's seed (the emulator's noise is seeded with it in-process too).
        scene: the catalogue (positions withheld).
        side_depth: the bridge publishes the flank depth cameras on the profile's ``side_depth`` topics.
    """

    mode: BridgeMode
    control_period_s: float
    seed: int
    scene: SceneSpec
    side_depth: bool = False


def _object_entry(obj: SceneObject) -> dict[str, Any]:
    return {
        "object_id": obj.object_id,
        "name": obj.name,
        "label": obj.label,
        "category": obj.category,
        "shape": obj.shape,
        "size_m": list(obj.size_m),
        "is_obstacle": obj.is_obstacle,
        "role": obj.role,
        "aliases": list(obj.aliases),
        "colour": obj.colour,
        "size": obj.size,
    }


def encode_simulation_info(
    scene: SceneSpec, *, mode: BridgeMode, control_period_s: float, seed: int, side_depth: bool
) -> str:
    """The ``/sim/scene`` payload: the scene's catalogue without positions, yaws, bounds or parts."""
    return json.dumps(
        {
            "mode": mode,
            "control_period_s": control_period_s,
            "seed": seed,
            "side_depth": side_depth,
            "scene": {
                "name": scene.name,
                "title": scene.title,
                "seed": scene.seed,
                "instruction": scene.instruction,
                "goal_object_id": scene.goal_object_id,
                "outdoor": scene.outdoor,
                "objects": [_object_entry(obj) for obj in scene.objects],
            },
        }
    )


def _field(data: dict[str, Any], key: str, kind: type | tuple[type, ...], topic: str) -> Any:
    if key not in data:
        raise SimProtocolError(f"{topic}: missing field '{key}'")
    value = data[key]
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise SimProtocolError(f"{topic}: field '{key}' has the wrong type ({type(value).__name__})")
    return value


def _load(text: str, topic: str) -> dict[str, Any]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise SimProtocolError(f"{topic}: not JSON ({error})") from None
    if not isinstance(data, dict):
        raise SimProtocolError(f"{topic}: expected a JSON object")
    return data


def decode_simulation_info(text: str) -> SimulationInfo:
    """Parse a ``/sim/scene`` payload (positions come back as zeros: the executive never has them)."""
    topic = SCENE_TOPIC
    data = _load(text, topic)
    mode = _field(data, "mode", str, topic)
    if mode not in BRIDGE_MODES:
        raise SimProtocolError(f"{topic}: field 'mode' must be one of {list(BRIDGE_MODES)}, got {mode!r}")
    period = float(_field(data, "control_period_s", (int, float), topic))
    scene_data = _field(data, "scene", dict, topic)
    objects = []
    for entry in _field(scene_data, "objects", list, topic):
        if not isinstance(entry, dict):
            raise SimProtocolError(f"{topic}: field 'scene.objects' must hold objects")
        size = [float(v) for v in _field(entry, "size_m", list, topic)]
        if len(size) != 3:
            raise SimProtocolError(f"{topic}: field 'size_m' must hold 3 numbers")
        objects.append(
            SceneObject(
                object_id=int(_field(entry, "object_id", int, topic)),
                name=str(_field(entry, "name", str, topic)),
                label=str(_field(entry, "label", str, topic)),
                category=str(_field(entry, "category", str, topic)),
                shape=_field(entry, "shape", str, topic),
                position_m=(0.0, 0.0, 0.0),
                size_m=(size[0], size[1], size[2]),
                is_obstacle=bool(_field(entry, "is_obstacle", bool, topic)),
                role=_field(entry, "role", str, topic),
                aliases=tuple(str(a) for a in _field(entry, "aliases", list, topic)),
                colour=str(_field(entry, "colour", str, topic)),
                size=str(_field(entry, "size", str, topic)),
            )
        )
    goal_id = int(_field(scene_data, "goal_object_id", int, topic))
    if goal_id not in {obj.object_id for obj in objects}:
        raise SimProtocolError(f"{topic}: 'goal_object_id' {goal_id} names no object")
    scene = SceneSpec(
        name=str(_field(scene_data, "name", str, topic)),
        title=str(_field(scene_data, "title", str, topic)),
        seed=int(_field(scene_data, "seed", int, topic)),
        bounds_m=(0.0, 0.0, 0.0, 0.0),
        objects=tuple(objects),
        goal_object_id=goal_id,
        instruction=str(_field(scene_data, "instruction", str, topic)),
        outdoor=bool(_field(scene_data, "outdoor", bool, topic)),
    )
    return SimulationInfo(
        mode=mode,
        control_period_s=period,
        seed=int(_field(data, "seed", int, topic)),
        scene=scene,
        side_depth=bool(_field(data, "side_depth", bool, topic)),
    )


#: The ``/sim/state`` payload's fixed values, in order (float64 each; the stamp is exact below 2**53 ns,
#: 104 days). The joints follow: every joint's position, then every joint's velocity, in the robot's
#: actuator order.
STATE_FIELDS: tuple[str, ...] = (
    "stamp_ns",
    "sim_time_s",
    "position_x_m",
    "position_y_m",
    "position_z_m",
    "orientation_x",
    "orientation_y",
    "orientation_z",
    "orientation_w",
    "linear_x_mps",
    "linear_y_mps",
    "angular_z_radps",
    "step_linear_x_mps",
    "step_linear_y_mps",
    "step_angular_z_radps",
    "step_from_ns",
    "imu_orientation_w",
    "imu_orientation_x",
    "imu_orientation_y",
    "imu_orientation_z",
    "imu_angular_velocity_x_radps",
    "imu_angular_velocity_y_radps",
    "imu_angular_velocity_z_radps",
    "imu_linear_acceleration_x_mps2",
    "imu_linear_acceleration_y_mps2",
    "imu_linear_acceleration_z_mps2",
)
#: The largest stamp (ns) a float64 holds exactly.
_EXACT_NS = 2**53
_IMU_AT = STATE_FIELDS.index("imu_orientation_w")


@dataclass(frozen=True)
class SimState:
    """A lockstep step's reply (``/sim/state``): what ``/odom``, ``/sim/time``, ``/imu`` and
    ``/joint_states`` carry, in one message.

    Attributes:
        stamp_ns: the instant (ns), as ``/odom``'s header stamp.
        sim_time_s: the simulator's float clock (``/sim/time``).
        position_m: the base's position in ``odom`` (x, y, z).
        orientation_xyzw: its orientation (a quaternion x, y, z, w, as the simulator has it).
        twist: its body twist.
        step_twist: the command the steps that made this state were taken with.
        from_ns: the instant those steps started from: the executive's instant then (a state sent ahead
            continues the executive's steps only if every step it asked for since then had this twist;
            sims/ros2_bridge.py, ``Speculation``).
        imu: the latest IMU reading: orientation (w, x, y, z), angular velocity, linear acceleration.
        joint_position_rad: the latest joint positions, in the actuator order.
        joint_velocity_radps: the latest joint velocities (as many as the positions).
    """

    stamp_ns: int
    sim_time_s: float
    position_m: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float]
    twist: Twist
    step_twist: Twist
    from_ns: int
    imu: tuple[float, ...]
    joint_position_rad: tuple[float, ...]
    joint_velocity_radps: tuple[float, ...]

    def imu_reading(self) -> ImuReading:
        """The IMU values as the backends' reading (what ``imu_to_reading`` makes of an ``/imu`` message)."""
        return ImuReading(
            angular_velocity_radps=np.array(self.imu[4:7]),
            linear_acceleration_mps2=np.array(self.imu[7:10]),
            orientation_wxyz=np.array(self.imu[0:4]),
        )

    def joint_state(self) -> JointState:
        """The joint values as the backends' reading."""
        return JointState(
            position_rad=np.array(self.joint_position_rad), velocity_radps=np.array(self.joint_velocity_radps)
        )


def same_twist_bits(a: Twist, b: Twist) -> bool:
    """Equal to the bit (``==`` holds for 0.0 and -0.0, which a step may carry on to different results)."""
    return struct.pack("<3d", a.linear_x_mps, a.linear_y_mps, a.angular_z_radps) == struct.pack(
        "<3d", b.linear_x_mps, b.linear_y_mps, b.angular_z_radps
    )


def encode_state(state: SimState) -> array.array[float]:
    """The ``/sim/state`` values (:data:`STATE_FIELDS`, then the joints), float64 each: the receiver gets
    these bits. An ``array('d')``: rclpy's setter takes it as it is, where a list is checked value by value."""
    for stamp in (state.stamp_ns, state.from_ns):
        if not 0 <= stamp < _EXACT_NS:
            raise SimProtocolError(f"{STATE_TOPIC}: stamp {stamp} ns is not exact in a float64")
    if len(state.imu) != len(STATE_FIELDS) - _IMU_AT:
        raise SimProtocolError(f"{STATE_TOPIC}: the IMU takes {len(STATE_FIELDS) - _IMU_AT} values")
    if len(state.joint_position_rad) != len(state.joint_velocity_radps):
        raise SimProtocolError(f"{STATE_TOPIC}: as many joint velocities as positions")
    twist = state.twist
    return array.array(
        "d",
        [
            state.stamp_ns,
            state.sim_time_s,
            *state.position_m,
            *state.orientation_xyzw,
            twist.linear_x_mps,
            twist.linear_y_mps,
            twist.angular_z_radps,
            state.step_twist.linear_x_mps,
            state.step_twist.linear_y_mps,
            state.step_twist.angular_z_radps,
            state.from_ns,
            *state.imu,
            *state.joint_position_rad,
            *state.joint_velocity_radps,
        ],
    )


def decode_state(values: Sequence[float], *, joints: int) -> SimState:
    """Parse ``/sim/state`` values of a robot with ``joints`` joints; a wrong length or a non-finite value
    raises (names the field)."""
    expected = len(STATE_FIELDS) + 2 * joints
    if len(values) != expected:
        raise SimProtocolError(
            f"{STATE_TOPIC}: expected {expected} values ({len(STATE_FIELDS)} and {joints} joints' position "
            f"and velocity), got {len(values)}"
        )
    floats = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(floats)
    if not finite.all():
        at = int(np.argmin(finite))
        name = STATE_FIELDS[at] if at < len(STATE_FIELDS) else f"joint value {at - len(STATE_FIELDS)}"
        raise SimProtocolError(f"{STATE_TOPIC}: field '{name}' must be finite, got {floats[at]}")
    listed = floats.tolist()
    stamp, sim_time, px, py, pz, qx, qy, qz, qw, vx, vy, wz, step_vx, step_vy, step_wz, from_ns = listed[
        :_IMU_AT
    ]
    joint_at = len(STATE_FIELDS)
    return SimState(
        stamp_ns=int(stamp),
        sim_time_s=sim_time,
        position_m=(px, py, pz),
        orientation_xyzw=(qx, qy, qz, qw),
        twist=Twist(vx, vy, wz),
        step_twist=Twist(step_vx, step_vy, step_wz),
        from_ns=int(from_ns),
        imu=tuple(listed[_IMU_AT:joint_at]),
        joint_position_rad=tuple(listed[joint_at : joint_at + joints]),
        joint_velocity_radps=tuple(listed[joint_at + joints :]),
    )


@dataclass(frozen=True)
class CameraRequest:
    """A lockstep render request: ``full`` (colour, depth, segmentation), ``depth`` at ``grids`` only, or
    ``side``: the flank cameras' depth at ``grids``. ``at_ns``: the instant the executive is at (the
    render's stamp), which the bridge reaches first where the step's ask is still on its way (the
    executive takes a state sent ahead without waiting for the bridge to take its ask)."""

    kind: FrameKind
    grids: tuple[PixelGrid, ...] | None = None
    at_ns: int | None = None


def encode_camera_request(request: CameraRequest) -> str:
    grids = None if request.grids is None else [[g.stride, g.offset] for g in request.grids]
    return json.dumps({"kind": request.kind, "grids": grids, "at_ns": request.at_ns})


def decode_camera_request(text: str) -> CameraRequest:
    topic = CAMERA_REQUEST_TOPIC
    data = _load(text, topic)
    kind = _field(data, "kind", str, topic)
    if kind not in FRAME_KINDS:
        raise SimProtocolError(f"{topic}: field 'kind' must be one of {list(FRAME_KINDS)}, got {kind!r}")
    at_ns = _instant(data, topic)
    raw = data.get("grids")
    if raw is None:
        return CameraRequest(kind=kind, at_ns=at_ns)
    if not isinstance(raw, list):
        raise SimProtocolError(f"{topic}: field 'grids' must be a list of [stride, offset]")
    grids: list[PixelGrid] = []
    for pair in raw:
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(v, int) for v in pair)):
            raise SimProtocolError(f"{topic}: field 'grids' must hold [stride, offset] integer pairs")
        grids.append(PixelGrid(stride=pair[0], offset=pair[1]))
    return CameraRequest(kind=kind, grids=tuple(grids), at_ns=at_ns)


def _instant(data: dict[str, Any], topic: str) -> int | None:
    """The optional ``at_ns`` field: the executive's instant (ns), a non-negative integer."""
    at_ns = data.get("at_ns")
    if at_ns is not None and (not isinstance(at_ns, int) or isinstance(at_ns, bool) or at_ns < 0):
        raise SimProtocolError(f"{topic}: field 'at_ns' must be a non-negative integer, got {at_ns!r}")
    return at_ns


@dataclass(frozen=True)
class Outcome:
    """The mission's declared outcome (``/sim/outcome``), for the bridge's scoring.

    Attributes:
        outcome: the episode's outcome (``success``, ``budget_exceeded``, ...).
        found_objects: the targets the executive confirmed (each with its ``position_m``).
        at_ns: the instant the executive ended at (as :attr:`CameraRequest.at_ns`).
    """

    outcome: str
    found_objects: list[dict[str, Any]]
    at_ns: int | None = None


def encode_outcome(outcome: Outcome) -> str:
    """The ``/sim/outcome`` payload."""
    return json.dumps(
        {"outcome": outcome.outcome, "found_objects": list(outcome.found_objects), "at_ns": outcome.at_ns},
        default=float,
    )


def decode_outcome(text: str) -> Outcome:
    topic = OUTCOME_TOPIC
    data = _load(text, topic)
    found = _field(data, "found_objects", list, topic)
    for entry in found:
        if not isinstance(entry, dict) or "position_m" not in entry:
            raise SimProtocolError(f"{topic}: each found object needs 'position_m'")
    return Outcome(str(_field(data, "outcome", str, topic)), found, _instant(data, topic))


__all__ = [
    "BRIDGE_MODES",
    "FRAME_KINDS",
    "CAMERA_REQUEST_TOPIC",
    "DEPTH_GRID_TOPIC",
    "HEARTBEAT_PERIOD_S",
    "HEARTBEAT_TOPIC",
    "OUTCOME_TOPIC",
    "SCENE_TOPIC",
    "SEGMENTATION_TOPIC",
    "STATE_FIELDS",
    "STATE_TOPIC",
    "STEP_TOPIC",
    "TIME_TOPIC",
    "CameraRequest",
    "Outcome",
    "SimProtocolError",
    "SimState",
    "SimulationInfo",
    "decode_camera_request",
    "decode_outcome",
    "decode_simulation_info",
    "decode_state",
    "encode_camera_request",
    "encode_outcome",
    "encode_simulation_info",
    "encode_state",
    "same_twist_bits",
]
