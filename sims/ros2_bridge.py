"""The MuJoCo world on ROS 2: a node that publishes what the Go1 driver and realsense-ros publish.

``semexp-bt sim-bridge --scene S --seed N`` runs one simulated episode's world (the scene, the sampled
start, :class:`robots.mujoco_backend.MujocoRobot`) and speaks the robot profile's topics
(``robots/go1/ros2.yaml``): it obeys ``/cmd_vel`` with the driver's 0.4 s timeout and publishes
``/odom``, ``/imu``, ``/joint_states``, the colour and aligned depth images with their camera info, and
``/clock``. What only a simulation has travels on ``/sim/...`` (``robots/ros2_sim_protocol.py``): the
scene's catalogue for the executive's perception emulator, the segmentation, and in lockstep the step and
render requests. The ground truth stays here: when the executive reports the mission's end on
``/sim/outcome`` (or on SIGINT/SIGTERM) the bridge scores the episode (``sims.episode_scoring``, the
in-process definitions) and writes it to ``--json``.

Two modes:

- ``lockstep`` (default; the end-to-end tests): the world moves only when the executive sends
  ``/sim/step`` (one 20 ms control period per tick, carrying the tick's twist), and renders the camera when
  the executive asks on ``/sim/camera/request`` (a full frame for perception, depth at the planner's and
  the map's pixel grids otherwise), exactly as the in-process backend renders inside a tick. The mission
  therefore sees the same world at the same instants as in-process, whatever the load on the machine.
  Each step's reply is one ``/sim/state`` message (odometry, the float clock, the IMU and the joints, these
  two read every PROPRIOCEPTION_EVERY steps as in realtime); ``/odom``, ``/sim/time``, ``/clock``, ``/imu``
  and ``/joint_states`` go out only while something subscribes to them (ROS tools; the lockstep executive
  does not). The main loop waits on its subscriptions itself (``robots/ros2_pump.py``), no executor: one
  wake-up per request. A kinematic bridge takes the next step ahead while the executive ticks and keeps it
  only if the executive asks for that very step (:class:`Speculation`).
- ``realtime``: the world runs on the wall clock at the control rate like a robot, applies the latest
  ``/cmd_vel`` (zeroed 0.4 s after the last one), and publishes camera frames at ``camera_hz``. Rendering
  costs tens of milliseconds on a software rasteriser, so simulated time may run slower than the wall;
  ``/clock`` is the authority either way.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robots.camera import CameraConfig
from robots.go1 import load_go1_spec
from robots.interface import Fidelity, Robot
from robots.mount import FLANK_SIDES
from robots.mujoco_backend import KinematicSnapshot, MujocoRobot
from robots.ros2_backend import (
    LOCKSTEP_SPIN_S,
    SIM_LATCHED_QOS,
    SIM_QOS,
    SIM_STEP_QOS,
    import_rclpy,
    qos_profile,
    ros_context,
)
from robots.ros2_messages import (
    MessageError,
    fill_camera_info,
    fill_depth_grid_image,
    fill_depth_image,
    fill_imu,
    fill_joint_state,
    fill_odometry,
    fill_rgb_image,
    fill_segmentation_image,
    fill_stamp,
    stamp_to_ns,
    twist_from_msg,
)
from robots.ros2_profile import SIDE_DEPTH_STREAMS, Ros2Profile, load_ros2_profile
from robots.ros2_sim_protocol import (
    CAMERA_REQUEST_TOPIC,
    DEPTH_GRID_TOPIC,
    HEARTBEAT_PERIOD_S,
    HEARTBEAT_TOPIC,
    OUTCOME_TOPIC,
    SCENE_TOPIC,
    SEGMENTATION_TOPIC,
    STATE_TOPIC,
    STEP_TOPIC,
    TIME_TOPIC,
    BridgeMode,
    CameraRequest,
    Outcome,
    SimState,
    decode_camera_request,
    decode_outcome,
    encode_simulation_info,
    encode_state,
    same_twist_bits,
)
from robots.side_depth import SideDepthConfig
from semexp_bt.core.metrics import DEFAULT_CLEARANCE_M, DEFAULT_SUCCESS_RADIUS_M
from semexp_bt.core.types import ImuReading, InvalidInputError, JointState, Observation, Twist
from sims.catalogue import build_scene
from sims.episode_scoring import score_episode
from sims.episodes import sample_episode
from sims.geodesic import GeodesicOracle

#: The world's control period (s): one step, the executive's tick.
CONTROL_PERIOD_S = 0.02
#: Lockstep: with no step for this long (s, wall), the bridge republishes the current state (so a late
#: executive finds it, and a lost best-effort /clock is made good).
HEARTBEAT_S = 0.25
#: IMU and joint states are read (and in realtime go out) every this many control steps (10 Hz): nothing in
#: the tree reads them faster, and each message costs both processes more than a kinematic step does
#: (docs/ros2.md).
PROPRIOCEPTION_EVERY = 5
#: Lockstep, kinematic: how many steps the bridge takes ahead of the executive's ask (:class:`Speculation`).
#: One hides the MuJoCo step; the second hides the round trip too, when the executive's tick is shorter
#: than the time its ask takes to reach the bridge and the next state to come back (most ticks are).
SPECULATION_DEPTH = 2
#: The streams that in lockstep travel inside ``/sim/state`` (not silenceable there on their own).
RIDE_ON_STATE: tuple[str, ...] = ("imu", "joint_states")
#: The streams a test may silence (``--silence STREAM=T``): the profile's sensor topics.
SILENCEABLE: tuple[str, ...] = (
    "odom",
    "imu",
    "joint_states",
    "color_image",
    "color_info",
    "depth_image",
    "clock",
    *SIDE_DEPTH_STREAMS,
)


@dataclass
class BridgeOptions:
    """One bridged episode.

    Attributes:
        scene: scene name (``semexp-bt scene list``).
        seed: seeds the layout, the start pose and the IMU noise (as ``semexp-bt run --seed``).
        fidelity: ``kinematic`` or ``dynamic`` (the shipped gait policy realises ``/cmd_vel`` then, as the
            Go1's own controller does).
        mode: ``lockstep`` or ``realtime`` (module docstring).
        profile_path: the robot profile (topics, frames, QoS, camera mount); the Go1's when None.
        result_path: where the episode's scoring goes (JSON).
        camera_hz: realtime mode: camera frames per simulated second.
        silence: fault injection for tests: stream key -> simulated time (s) after which it is no longer
            published.
        drop_step_replies: fault injection for tests (lockstep): leave every this many-th step unanswered,
            as if its best-effort reply were lost (0: never); the executive asks again.
        speculate: lockstep, kinematic: take the next step ahead with the last twist while the executive
            ticks, and keep it if the executive asks for that step (:class:`Speculation`); off: step only
            when asked. Either way the executive gets the same states.
        success_radius_m: r_s.
        clearance_m: the clearance threshold for OASR.
        max_sim_s: the bridge ends the episode at this simulated time.
        max_wall_s: the bridge ends after this much wall time (None: never).
    """

    scene: str
    seed: int
    fidelity: Fidelity = "kinematic"
    mode: BridgeMode = "lockstep"
    profile_path: Path | None = None
    result_path: Path | None = None
    camera_hz: float = 15.0
    silence: Mapping[str, float] = field(default_factory=dict)
    drop_step_replies: int = 0
    speculate: bool = True
    success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M
    clearance_m: float = DEFAULT_CLEARANCE_M
    max_sim_s: float = 900.0
    max_wall_s: float | None = None

    def __post_init__(self) -> None:
        unknown = sorted(set(self.silence) - set(SILENCEABLE))
        if unknown:
            raise InvalidInputError(f"cannot silence {unknown}; streams: {', '.join(SILENCEABLE)}")
        riding = sorted(set(self.silence) & set(RIDE_ON_STATE))
        if self.mode == "lockstep" and riding:
            raise InvalidInputError(
                f"cannot silence {riding} in lockstep: they ride on {STATE_TOPIC} there (silence 'odom' to "
                "stop it, or use realtime mode)"
            )
        if self.drop_step_replies < 0 or (self.drop_step_replies and self.mode != "lockstep"):
            raise InvalidInputError(
                f"drop_step_replies must be >= 0, and 0 outside lockstep; got {self.drop_step_replies} "
                f"in {self.mode}"
            )
        if not (math.isfinite(self.camera_hz) and 0.0 < self.camera_hz <= 1.0 / CONTROL_PERIOD_S):
            raise InvalidInputError(
                f"camera_hz must lie in (0, {1.0 / CONTROL_PERIOD_S:g}], got {self.camera_hz}"
            )


@dataclass(frozen=True)
class Speculation:
    """A lockstep step taken before the executive asked for it, and what it takes to take it back.

    A tick's step waits on the bridge's MuJoCo step and on a round trip over DDS, while between two steps
    the bridge waits on the executive's tree: on two cores they can overlap. After answering a step, the
    bridge steps once more with the same twist (most ticks repeat the last command: the controllers run
    slower than the tick) and sends that state ahead at once, tagged with the twist it was made with. When
    the executive then asks for exactly that step (the next control period, the same twist, bit for bit),
    it already holds the state and goes on without waiting: its ask only tells the bridge to keep the step,
    which needs no reply. Anything else (another twist, a resend, a render or the mission's end, which must
    see the instant the executive has) restores the snapshot first, and a state sent ahead under another
    twist is not the one the executive asked for (it compares the tag). The step is a pure function of the
    state and the twist, so both paths give the same bits; the end-to-end tests compare the whole mission
    with the in-process run tick for tick.

    Attributes:
        from_ns: the instant the step started from.
        twist: the twist it was taken with.
        robot: the robot before it.
        positions: how many path positions the bridge had recorded before it.
        proprioception: the IMU and joint reading the bridge last sent, before it.
    """

    from_ns: int
    twist: Twist
    robot: KinematicSnapshot
    positions: int
    proprioception: tuple[ImuReading, JointState] | None


def camera_config_for(profile: Ros2Profile) -> CameraConfig:
    """The simulated head camera mounted where the profile says (the simulated camera pitches only)."""
    mount = profile.camera.mount
    if mount.roll_rad != 0.0 or mount.yaw_rad != 0.0:
        raise InvalidInputError(
            f"{profile.source}: the simulated camera can pitch only; 'camera.mount.roll_rad' and "
            "'camera.mount.yaw_rad' must be 0"
        )
    return CameraConfig(
        mount_position_m=(mount.x_m, mount.y_m, mount.z_m), mount_pitch_down_deg=math.degrees(mount.pitch_rad)
    )


def side_depth_config_for(profile: Ros2Profile) -> SideDepthConfig:
    """The simulated flank cameras mounted where the profile's ``side_depth`` says: mirror images of each
    other on the trunk's flanks, looking straight out to the side and pitched only (as simulated)."""
    left, right = profile.side_depth.left.mount, profile.side_depth.right.mount
    mirrored = (
        left.x_m == right.x_m == 0.0
        and left.roll_rad == right.roll_rad == 0.0
        and left.y_m == -right.y_m > 0.0
        and left.z_m == right.z_m
        and left.pitch_rad == right.pitch_rad
        and left.yaw_rad == -right.yaw_rad == math.pi / 2
    )
    if not mirrored:
        raise InvalidInputError(
            f"{profile.source}: the simulated flank cameras are a mirrored pair at x 0, looking 90 deg "
            "sideways and pitched only: 'side_depth.left.mount' and 'side_depth.right.mount' must mirror "
            "each other (y_m opposite, yaw_rad +-pi/2, roll_rad 0)"
        )
    return SideDepthConfig(
        mount_lateral_m=left.y_m, mount_height_m=left.z_m, mount_pitch_down_deg=math.degrees(left.pitch_rad)
    )


class SimBridge:
    """The bridged world (see the module docstring). Build it, :meth:`run` it, read the result."""

    def __init__(self, options: BridgeOptions) -> None:
        self.options = options
        self.profile = load_ros2_profile(options.profile_path)
        self.scene = build_scene(options.scene, seed=options.seed)
        self.oracle = GeodesicOracle(self.scene)
        self.episode = sample_episode(self.scene, seed=options.seed, oracle=self.oracle)
        self.robot = MujocoRobot(
            scene=self.scene,
            fidelity=options.fidelity,
            start_pose=self.episode.start,
            seed=options.seed,
            camera=camera_config_for(self.profile),
            control_dt_s=CONTROL_PERIOD_S,
            side_depth=side_depth_config_for(self.profile),
        )
        self._gait: Callable[[Robot, Twist], None] | None = None
        if options.fidelity == "dynamic":
            from robots.gait_policy import make_gait_controller

            self._gait = make_gait_controller()
        self._joint_names = load_go1_spec().joint_names
        self._period_ns = int(round(CONTROL_PERIOD_S * 1e9))
        self._steps = 0
        # Lockstep: steps answered, replies left out on purpose (drop_step_replies), and steps asked again
        # for a stamp already reached (the executive's resends, answered with the state again).
        self._step_replies = {"sent": 0, "dropped": 0, "repeated": 0}
        # The step count whose state was last left out (drop_step_replies): a step taken back and taken
        # again is one step, its state left out once.
        self._dropped_at = 0
        # Lockstep: the instant the executive last asked for (speculative steps go past it), the twist of
        # that ask and the instant it started from (the tags of its state: SimState.step_twist, from_ns),
        # and the renders asked for at an instant the world has not reached yet (_catch_up).
        self._asked_ns = 0
        self._asked_twist = Twist.zero()
        self._asked_from_ns = 0
        self._pending_renders: list[CameraRequest] = []
        # The steps taken ahead of the ask, earliest first (all under one twist).
        self._speculations: list[Speculation] = []
        # Speculative steps the executive then asked for (kept) and those taken back (Speculation).
        self._speculated = {"kept": 0, "taken_back": 0}
        self._positions = [self.robot.base_pose().position()]
        self._proprioception: tuple[ImuReading, JointState] | None = None
        self._cmd_twist = Twist.zero()
        self._cmd_arrived_s: float | None = None
        self._cmd_arrived_ns = 0
        self._cmd_count = 0
        self._timeouts: list[dict[str, float]] = []
        self._timed_out = False
        self._last_step_wall_s = time.monotonic()
        self._outcome: Outcome | None = None
        self._stop_reason: str | None = None
        self._errors: list[str] = []
        self._frames_published = 0
        self._frame_log: list[tuple[int, float]] = []
        self._setup_ros()

    # ------------------------------------------------------------------ ROS

    def _setup_ros(self) -> None:
        rclpy = import_rclpy()
        from geometry_msgs.msg import Twist as TwistMsg
        from geometry_msgs.msg import TwistStamped
        from nav_msgs.msg import Odometry
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import CameraInfo, Image, Imu, JointState
        from std_msgs.msg import Float64, Float64MultiArray, Header, String

        self._types = {
            "odom": Odometry,
            "imu": Imu,
            "joint_states": JointState,
            "clock": Clock,
            "color_image": Image,
            "depth_image": Image,
            "color_info": CameraInfo,
            "segmentation": Image,
        }
        self._rclpy = rclpy
        self._context = ros_context(rclpy)
        self.node = rclpy.create_node(
            "semexp_sim_bridge", context=self._context, start_parameter_services=False
        )
        from robots.ros2_pump import SubscriptionPump

        self._pump = SubscriptionPump(self.node)
        #: Lockstep: the executive's request subscriptions (step, render), polled before each wait.
        self._requests: tuple[Any, ...] = ()
        topics, qos = self.profile.topics, self.profile.qos
        self._pubs: dict[str, Any] = {
            stream: self.node.create_publisher(
                self._types[stream], getattr(topics, stream), qos_profile(getattr(qos, stream))
            )
            for stream in ("odom", "imu", "joint_states", "clock", "color_image", "depth_image", "color_info")
        }
        self._pubs["segmentation"] = self.node.create_publisher(
            Image, SEGMENTATION_TOPIC, qos_profile(SIM_QOS)
        )
        self._pubs["depth_grid"] = self.node.create_publisher(Image, DEPTH_GRID_TOPIC, qos_profile(SIM_QOS))
        for side in FLANK_SIDES:
            camera = self.profile.side_depth.camera(side)
            self._pubs[f"{side}_depth_image"] = self.node.create_publisher(
                Image, camera.image, qos_profile(qos.side_depth)
            )
            self._pubs[f"{side}_depth_info"] = self.node.create_publisher(
                CameraInfo, camera.info, qos_profile(qos.side_depth)
            )
        self._pubs["sim_time"] = self.node.create_publisher(Float64, TIME_TOPIC, qos_profile(SIM_QOS))
        self._types["sim_time"] = Float64
        self._pubs["state"] = self.node.create_publisher(
            Float64MultiArray, STATE_TOPIC, qos_profile(SIM_STEP_QOS)
        )
        self._types["state"] = Float64MultiArray
        # The per-step messages are built once and refilled (publish copies them): building an Odometry
        # in Python costs more than a kinematic step.
        self._reused = {name: self._types[name]() for name in ("odom", "sim_time", "clock", "state")}
        scene_pub = self.node.create_publisher(String, SCENE_TOPIC, qos_profile(SIM_LATCHED_QOS))
        lockstep = self.options.mode == "lockstep"
        # Lockstep: the main loop waits on the subscriptions itself and runs their callbacks (one wake-up
        # per request; robots/ros2_pump.py); realtime: the executor, spun between steps.
        subscribe = self._pump.subscribe if lockstep else self.node.create_subscription
        subscribe(TwistMsg, topics.cmd_vel, self._on_cmd_vel, qos_profile(qos.cmd_vel))
        subscribe(String, OUTCOME_TOPIC, self._on_outcome, qos_profile(SIM_LATCHED_QOS))
        if lockstep:
            self._requests = (
                subscribe(TwistStamped, STEP_TOPIC, self._on_step, qos_profile(SIM_STEP_QOS)),
                subscribe(String, CAMERA_REQUEST_TOPIC, self._on_camera_request, qos_profile(SIM_QOS)),
            )
        announcement = String()
        announcement.data = encode_simulation_info(
            self.scene,
            mode=self.options.mode,
            control_period_s=CONTROL_PERIOD_S,
            seed=self.options.seed,
            side_depth=True,
        )
        scene_pub.publish(announcement)
        self._scene_pub = scene_pub  # latched: keep the publisher alive
        self._heartbeat_pub = self.node.create_publisher(Header, HEARTBEAT_TOPIC, qos_profile(SIM_QOS))
        self._heartbeat_stop = threading.Event()
        self._heartbeat = threading.Thread(
            target=self._beat, args=(Header,), name="sim-heartbeat", daemon=True
        )
        from rclpy.executors import SingleThreadedExecutor

        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)

    def _beat(self, header_type: type) -> None:
        """Say "alive" every HEARTBEAT_PERIOD_S from a thread of its own, busy main loop or not."""
        beat = header_type()
        while not self._heartbeat_stop.wait(HEARTBEAT_PERIOD_S):
            self._heartbeat_pub.publish(beat)

    def _now_ns(self) -> int:
        return self._steps * self._period_ns

    def _silenced(self, stream: str) -> bool:
        after = self.options.silence.get(stream)
        return after is not None and self._now_ns() * 1e-9 >= after

    def _publish(self, stream: str, msg: Any) -> None:
        if not self._silenced(stream):
            self._pubs[stream].publish(msg)

    def _wanted(self, stream: str) -> bool:
        """Whether to publish ``stream``'s message: always in realtime; in lockstep, where ``/sim/state``
        carries the step's reply, only while something subscribes to it (ROS tools, a test's listener; the
        lockstep executive does not)."""
        return self.options.mode == "realtime" or self._pubs[stream].get_subscription_count() > 0

    def publish_state(self, *, heartbeat: bool = False) -> None:
        """The current instant's clock and odometry (and every PROPRIOCEPTION_EVERY steps, or on a
        heartbeat, IMU and joint states), all stamped with it. In lockstep ``/sim/state`` carries them all
        and goes first: it is the reply the executive waits for, and what follows (the streams ROS tools
        listen to) then goes out while the executive ticks its tree, on the other core."""
        if self.options.mode == "lockstep":
            self._take_back_speculation()  # the instant the executive asked for
            self._send_state(from_ns=self._asked_from_ns, twist=self._asked_twist, heartbeat=heartbeat)
        self._publish_streams(heartbeat=heartbeat)

    def _proprioception_now(self, *, heartbeat: bool) -> tuple[ImuReading, JointState, bool]:
        """The IMU and joint reading to send, and whether it was read now: every PROPRIOCEPTION_EVERY
        steps or on a heartbeat, else the last one read is sent again."""
        proprioception = self._proprioception
        if proprioception is None or heartbeat or self._steps % PROPRIOCEPTION_EVERY == 0:
            proprioception = self._proprioception = (self.robot.imu(), self.robot.joint_state())
            return (*proprioception, True)
        return (*proprioception, False)

    def _send_state(
        self, *, from_ns: int, twist: Twist, heartbeat: bool = False, droppable: bool = False
    ) -> None:
        """Lockstep: the current instant on ``/sim/state`` (one message: :class:`SimState`), tagged with
        the twist of the steps that made it and the instant they started from (the executive's, then).
        ``droppable``: a step's state, which ``drop_step_replies`` may leave out (as a lost datagram
        would)."""
        if self._silenced("odom"):  # it carries the odometry
            return
        drop_every = self.options.drop_step_replies
        if droppable and drop_every and self._steps % drop_every == 0 and self._steps != self._dropped_at:
            self._dropped_at = self._steps
            self._step_replies["dropped"] += 1
            return
        robot = self.robot
        # The simulator's own pose values (float64 on the wire): the executive derives its pose and the
        # camera's from them exactly as the in-process backend does (MujocoRobot.base_odometry).
        position, orientation = robot.base_odometry()
        imu, joints, _ = self._proprioception_now(heartbeat=heartbeat)
        state = self._reused["state"]
        state.data = encode_state(
            SimState(
                stamp_ns=self._now_ns(),
                sim_time_s=robot.now_s(),
                position_m=position,
                orientation_xyzw=orientation,
                twist=robot.base_twist(),
                step_twist=twist,
                from_ns=from_ns,
                imu=(*imu.orientation_wxyz, *imu.angular_velocity_radps, *imu.linear_acceleration_mps2),
                joint_position_rad=tuple(joints.position_rad),
                joint_velocity_radps=tuple(joints.velocity_radps),
            )
        )
        self._pubs["state"].publish(state)
        self._step_replies["sent"] += 1

    def _publish_streams(self, *, heartbeat: bool = False) -> None:
        """The current instant on the driver's and the clock's topics (``/odom``, ``/imu``,
        ``/joint_states``, ``/sim/time``, ``/clock``): always in realtime; in lockstep only to those that
        subscribe (:meth:`_wanted`), and only for instants the executive has asked for."""
        wanted = {
            stream: self._wanted(stream) for stream in ("odom", "imu", "joint_states", "sim_time", "clock")
        }
        if not any(wanted.values()):
            return
        self._take_back_speculation()  # the instant the executive asked for, not the steps ahead
        now_ns = self._now_ns()
        stamp_s = now_ns * 1e-9
        frames = self.profile.frames
        robot = self.robot
        imu, joints, fresh = self._proprioception_now(heartbeat=heartbeat)
        if wanted["odom"]:
            position, orientation = robot.base_odometry()
            odom = self._reused["odom"]
            fill_odometry(
                odom,
                position,
                orientation,
                robot.base_twist(),
                stamp_s=stamp_s,
                odom_frame=frames.odom,
                base_frame=frames.base,
            )
            self._publish("odom", odom)
        if fresh and wanted["imu"]:
            imu_msg = self._types["imu"]()
            fill_imu(imu_msg, imu, stamp_s=stamp_s, frame_id=frames.base)
            self._publish("imu", imu_msg)
        if fresh and wanted["joint_states"]:
            joints_msg = self._types["joint_states"]()
            fill_joint_state(joints_msg, self._joint_names, joints, stamp_s=stamp_s)
            self._publish("joint_states", joints_msg)
        if wanted["sim_time"]:
            sim_time = self._reused["sim_time"]
            sim_time.data = robot.now_s()
            self._publish("sim_time", sim_time)
        if wanted["clock"]:
            clock = self._reused["clock"]
            fill_stamp(clock.clock, stamp_s)
            self._publish("clock", clock)

    def publish_side_depth(self, request: CameraRequest) -> None:
        """Measure the flank cameras now (at the request's pixel grids) and publish each one's camera info
        and depth image."""
        stamp_s = self._now_ns() * 1e-9
        frames = self.robot.observe_side_depth(pixel_grids=request.grids)
        for side, frame in zip(FLANK_SIDES, frames, strict=True):
            optical = self.profile.side_depth.camera(side).frame
            info = self._types["color_info"]()
            fill_camera_info(info, frame.intrinsics, stamp_s=stamp_s, frame_id=optical)
            self._publish(f"{side}_depth_info", info)
            depth = self._types["depth_image"]()
            fill_depth_image(depth, frame.depth_m, stamp_s=stamp_s, frame_id=optical)
            self._publish(f"{side}_depth_image", depth)

    def publish_frame(self, request: CameraRequest) -> None:
        """Render the camera now and publish camera info, depth and (full frames) colour and segmentation;
        a ``side`` request measures the flank cameras instead. A depth request at pixel grids is answered
        with the grids' rows and columns only, on ``DEPTH_GRID_TOPIC``: the executive reads no other
        pixel, and a whole 320x240 frame costs both sides far more to fill, send and convert."""
        if request.kind == "side":
            self.publish_side_depth(request)
            return
        stamp_s = self._now_ns() * 1e-9
        optical = self.profile.frames.camera_optical
        observation: Observation
        if request.kind == "full":
            observation = self.robot.observe()
        else:
            observation = self.robot.observe_depth(pixel_grids=request.grids)
        self._frame_log.append((self._now_ns(), time.monotonic()))  # rendered: the messages start here
        info = self._types["color_info"]()
        fill_camera_info(info, observation.intrinsics, stamp_s=stamp_s, frame_id=optical)
        self._publish("color_info", info)
        if request.kind == "full":
            color = self._types["color_image"]()
            fill_rgb_image(color, observation.rgb, stamp_s=stamp_s, frame_id=optical)
            self._publish("color_image", color)
            assert observation.segmentation is not None  # observe() always renders it
            segmentation = self._types["segmentation"]()
            fill_segmentation_image(segmentation, observation.segmentation, stamp_s=stamp_s, frame_id=optical)
            self._publish("segmentation", segmentation)
        depth = self._types["depth_image"]()
        if request.kind == "depth" and request.grids is not None:
            fill_depth_grid_image(
                depth, observation.depth_m, request.grids, stamp_s=stamp_s, frame_id=optical
            )
            self._publish("depth_grid", depth)
        else:
            fill_depth_image(depth, observation.depth_m, stamp_s=stamp_s, frame_id=optical)
            self._publish("depth_image", depth)
        self._frames_published += 1

    # ------------------------------------------------------------------ world

    def step(self, twist: Twist) -> None:
        """One control period under ``twist`` (the gait realises it in dynamic fidelity)."""
        if self._gait is not None:
            self._gait(self.robot, twist)
        else:
            self.robot.command_twist(twist)
        self.robot.advance(CONTROL_PERIOD_S)
        self._steps += 1
        self._positions.append(self.robot.base_pose().position())
        if self._now_ns() * 1e-9 >= self.options.max_sim_s:
            self._stop("max_sim_s")

    def _stop(self, reason: str) -> None:
        if self._stop_reason is None:
            self._stop_reason = reason

    # ------------------------------------------------------------------ callbacks

    def _on_cmd_vel(self, msg: Any) -> None:
        try:
            twist = twist_from_msg(msg)
        except MessageError as error:
            self._errors.append(f"{self.profile.topics.cmd_vel}: {error}; robot stopped")
            twist = Twist.zero()
        self._cmd_twist = twist
        self._cmd_arrived_s = time.monotonic()
        self._cmd_arrived_ns = self._now_ns()
        self._cmd_count += 1
        self._timed_out = False

    def _on_step(self, msg: Any) -> None:
        target_ns = stamp_to_ns(msg.header.stamp)
        try:
            twist = twist_from_msg(msg.twist)
        except MessageError as error:
            self._errors.append(f"{STEP_TOPIC}: {error}; stepping with a zero twist")
            twist = Twist.zero()
        # The executive's target time, in whole control periods (normally one). A step for a stamp already
        # reached is a resend (its reply was lost, or late): it is answered with the state again.
        kept = self._keep_speculation(target_ns, twist)
        stepped = False
        if not kept or self._asked_ns + self._period_ns // 2 < target_ns:
            self._take_back_speculation()
            from_ns = self._asked_ns
            while self._now_ns() + self._period_ns // 2 < target_ns and self._stop_reason is None:
                self.step(twist)
                stepped = True
            if stepped:
                self._asked_from_ns, self._asked_twist = from_ns, twist
            self._asked_ns = self._now_ns()
        self._last_step_wall_s = time.monotonic()
        if not (kept or stepped):
            self._step_replies["repeated"] += 1
        if not kept or stepped:  # a kept step's state went ahead (Speculation): no reply
            self._send_state(from_ns=self._asked_from_ns, twist=self._asked_twist, droppable=stepped)
        self._publish_streams()
        waiting, self._pending_renders = self._pending_renders, []
        for request in waiting:
            if not self._catch_up(request.at_ns, take_waiting=False, take_back=False):
                self._pending_renders.append(request)
            else:
                self._publish_frame_at_asked(request)
        self._speculate(twist)

    def _catch_up(self, at_ns: int | None, *, take_waiting: bool = True, take_back: bool = True) -> bool:
        """Lockstep: whether the world is at the executive's instant ``at_ns`` (None: whatever it is at),
        with the speculative steps kept up to it and the rest taken back (``take_back``; else left ahead,
        for a render of the instant asked, :meth:`_publish_frame_at_asked`).

        The executive takes a state sent ahead without waiting for the bridge to take its ask, so a render
        request or the outcome (other topics, which DDS does not order with ``/sim/step``) may come first.
        Then the asks already waiting are taken now, in order; if an ask is still on its way, the
        executive can only be at ``at_ns`` by having taken the speculative steps' states up to it (their
        tags matched its asks), so those steps are kept. False only if neither brings the world there (a
        step not sent yet). ``take_waiting``: False from the step handler, which must not run inside itself.
        """
        if take_waiting and at_ns is not None and self._asked_ns < at_ns:
            self._pump.drain(self._requests[:1])
        while at_ns is not None and self._asked_ns < at_ns and self._speculations:
            self._keep_first_speculation()
        if at_ns is not None and self._asked_ns < at_ns:
            return False
        if take_back:
            self._take_back_speculation()  # at the instant the executive has
        return True

    def _publish_frame_at_asked(self, request: CameraRequest) -> None:
        """Render the instant the executive asked for last, leaving the steps ahead of it in place: the
        cameras see the snapshot the first step ahead started from (``MujocoRobot.viewed_at``), and the
        world is back where it was after the render. The steps' states went out already and stay right (a
        render changes nothing a step reads), so the executive's next ask keeps them; taking them back
        and stepping them again cost each render two more steps and two more state messages."""
        if not self._speculations:
            self.publish_frame(request)
            return
        ahead = len(self._speculations)
        self._steps -= ahead  # the bridge's clock (_now_ns): the frame's stamp
        try:
            with self.robot.viewed_at(self._speculations[0].robot):
                self.publish_frame(request)
        finally:
            self._steps += ahead

    def _speculate(self, twist: Twist) -> None:
        """Take steps ahead with ``twist`` up to :data:`SPECULATION_DEPTH` and send each one's state at once
        (:class:`Speculation`), where they can be taken back (lockstep: after a step's answer or a
        render)."""
        if self._speculations and not same_twist_bits(self._speculations[-1].twist, twist):
            self._take_back_speculation()  # one twist per chain
        while (
            len(self._speculations) < SPECULATION_DEPTH
            # Not before the executive's first step (a render's resend of its empty ask included): until it
            # has asked for one, every state it gets is its start.
            and self._steps > 0
            and self.options.speculate
            and self._gait is None  # kinematic: MujocoRobot.snapshot
            and self._stop_reason is None
            # A step that would end the episode (max_sim_s) ends it when asked for, not ahead of the ask.
            and (self._now_ns() + self._period_ns) * 1e-9 < self.options.max_sim_s
        ):
            speculation = Speculation(
                from_ns=self._now_ns(),
                twist=twist,
                robot=self.robot.snapshot(),
                positions=len(self._positions),
                proprioception=self._proprioception,
            )
            self.step(twist)
            self._speculations.append(speculation)
            # Its chain starts at the instant the executive asked for last, under this twist.
            self._send_state(from_ns=self._asked_ns, twist=twist, droppable=True)

    def _keep_speculation(self, target_ns: int, twist: Twist) -> bool:
        """Whether the step asked for (to ``target_ns`` under ``twist``) begins with the first speculative
        one, which is then kept (True); otherwise every speculative step is taken back (False)."""
        if not self._speculations:
            return False
        first = self._speculations[0]
        if same_twist_bits(first.twist, twist) and first.from_ns + self._period_ns // 2 < target_ns:
            self._keep_first_speculation()
            return True
        self._take_back_speculation()
        return False

    def _keep_first_speculation(self) -> None:
        """The first speculative step becomes the executive's: its end is the instant asked for."""
        first = self._speculations.pop(0)
        self._asked_from_ns, self._asked_twist = self._asked_ns, first.twist
        self._asked_ns = first.from_ns + self._period_ns
        self._speculated["kept"] += 1

    def _take_back_speculation(self) -> None:
        """Back to the instant the executive last asked for (idempotent)."""
        if not self._speculations:
            return
        first = self._speculations[0]
        self.robot.restore(first.robot)
        self._steps -= len(self._speculations)
        self._proprioception = first.proprioception
        del self._positions[first.positions :]
        self._speculated["taken_back"] += len(self._speculations)
        self._speculations.clear()

    def _on_camera_request(self, msg: Any) -> None:
        try:
            request = decode_camera_request(msg.data)
        except InvalidInputError as error:
            self._take_back_speculation()
            self._errors.append(str(error))
            return
        if not self._catch_up(request.at_ns, take_back=False):  # rendered when its step comes (_on_step)
            self._pending_renders.append(request)
            return
        self._publish_frame_at_asked(request)  # of the instant the executive has
        # Ahead again while the executive reads the frames, so that its next step needs no wait either.
        self._speculate(self._asked_twist)

    def _on_outcome(self, msg: Any) -> None:
        at_ns = None
        try:
            self._outcome = decode_outcome(msg.data)
            at_ns = self._outcome.at_ns
        except InvalidInputError as error:
            self._errors.append(str(error))
        if not self._catch_up(at_ns):  # the episode ends where the executive ended it, or as near as known
            self._errors.append(
                f"{OUTCOME_TOPIC}: the executive ended at {at_ns} ns, the world is at {self._asked_ns} ns"
            )
        self._stop("mission_end")

    # ------------------------------------------------------------------ loops

    def request_stop(self, reason: str) -> None:
        """End :meth:`run` at the next turn of its loop (signal handlers call this)."""
        self._stop(reason)

    def _driver_command(self) -> Twist:
        """The latest /cmd_vel, or zero once the driver's timeout has passed since it arrived."""
        if self._cmd_arrived_s is None:
            return Twist.zero()
        silent_s = time.monotonic() - self._cmd_arrived_s
        if silent_s > self.profile.command.driver_timeout_s:
            if not self._timed_out:
                self._timed_out = True
                # Wall and simulated silence: on a loaded machine the control loop (and the world) may lag
                # the wall clock; the robot moves only in simulated time.
                self._timeouts.append(
                    {
                        "sim_time_s": self._now_ns() * 1e-9,
                        "silent_s": round(silent_s, 4),
                        "sim_silent_s": round((self._now_ns() - self._cmd_arrived_ns) * 1e-9, 4),
                    }
                )
            return Twist.zero()
        return self._cmd_twist

    def run(self) -> dict[str, Any]:
        """Serve until the mission ends, a signal, ``max_sim_s`` or ``max_wall_s``; return the result."""
        wall_start = time.monotonic()
        self.publish_state(heartbeat=True)
        self._heartbeat.start()
        try:
            if self.options.mode == "lockstep":
                self._run_lockstep(wall_start)
            else:
                self._run_realtime(wall_start)
        finally:
            self._take_back_speculation()
            self._heartbeat_stop.set()
            self._heartbeat.join(timeout=1.0)
            self.robot.stop()
        result = self.result(wall_s=time.monotonic() - wall_start)
        if self.options.result_path is not None:
            import json

            self.options.result_path.parent.mkdir(parents=True, exist_ok=True)
            self.options.result_path.write_text(json.dumps(result, indent=1))
        return result

    def _wall_exceeded(self, wall_start: float) -> bool:
        limit = self.options.max_wall_s
        if limit is not None and time.monotonic() - wall_start > limit:
            self._stop("max_wall_s")
        return self._stop_reason is not None

    def _run_lockstep(self, wall_start: float) -> None:
        while not self._wall_exceeded(wall_start):
            self._pump.pump(HEARTBEAT_S / 5, spin_on=self._requests, spin_s=LOCKSTEP_SPIN_S)
            if time.monotonic() - self._last_step_wall_s > HEARTBEAT_S:
                self.publish_state(heartbeat=True)  # the state the executive was sent, again
                self._last_step_wall_s = time.monotonic()

    def _run_realtime(self, wall_start: float) -> None:
        frame_every = max(1, int(round(1.0 / (self.options.camera_hz * CONTROL_PERIOD_S))))
        next_step = time.monotonic()
        while not self._wall_exceeded(wall_start):
            now = time.monotonic()
            if now < next_step:
                self._executor.spin_once(timeout_sec=next_step - now)
                continue
            self.step(self._driver_command())
            self.publish_state()
            if self._steps % frame_every == 0:
                self.publish_frame(CameraRequest(kind="full"))
                self.publish_side_depth(CameraRequest(kind="side"))
            # Behind schedule (a slow render), simulated time runs slower than the wall: no catch-up burst.
            next_step = max(next_step + CONTROL_PERIOD_S, time.monotonic() - CONTROL_PERIOD_S)

    # ------------------------------------------------------------------ result

    def result(self, *, wall_s: float) -> dict[str, Any]:
        """The episode's scoring plus what the bridge saw of the link."""
        self._take_back_speculation()
        outcome, found = (
            (self._outcome.outcome, self._outcome.found_objects)
            if self._outcome is not None
            else ("interrupted", [])
        )
        score = score_episode(
            scene=self.scene,
            episode=self.episode,
            outcome=outcome,
            found_objects=found,
            positions=self._positions,
            final_pose=self.robot.base_pose(),
            safety=self.robot.safety(),
            success_radius_m=self.options.success_radius_m,
            clearance_m=self.options.clearance_m,
        )
        return {
            "scene": self.scene.name,
            "seed": self.options.seed,
            "fidelity": self.options.fidelity,
            "mode": self.options.mode,
            "instruction": self.scene.instruction,
            **score,
            "found_objects": found,
            "ended_by": self._stop_reason,
            "steps": self._steps,
            "sim_time_s": self._now_ns() * 1e-9,
            "wall_time_s": wall_s,
            "frames_published": self._frames_published,
            "step_replies": dict(self._step_replies),
            "speculative_steps": dict(self._speculated),
            # (stamp ns, steady time the frame was rendered) per frame: the latency benchmark's send side.
            "frame_log": self._frame_log[-4096:],
            "cmd_vel": {
                "received": self._cmd_count,
                "last": [
                    self._cmd_twist.linear_x_mps,
                    self._cmd_twist.linear_y_mps,
                    self._cmd_twist.angular_z_radps,
                ],
                "timeouts": self._timeouts,
            },
            "errors": self._errors,
        }

    def close(self) -> None:
        """Release the renderer and the ROS context (idempotent)."""
        self.robot.close()
        self._pump.close()
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self._context.try_shutdown()


__all__ = [
    "BridgeOptions",
    "CONTROL_PERIOD_S",
    "SILENCEABLE",
    "SimBridge",
    "Speculation",
    "camera_config_for",
]
