"""The ROS 2 backend of :class:`robots.interface.Robot`: a Go1 (or the MuJoCo bridge) over rclpy.

What it speaks is the robot profile's (``robots/ros2_profile.py``, ``robots/go1/ros2.yaml``): the Go1
driver's ``/cmd_vel``, ``/odom``, ``/imu``, ``/joint_states`` and realsense-ros' colour, aligned depth and
camera info. rclpy is imported when a :class:`Ros2Robot` is built, never at import time of anything the
default (MuJoCo) path loads.

How it runs:

- One executor thread spins the node. Subscription callbacks only store the latest messages (a short
  history for odometry and camera frames) with their arrival time; the tree's ticks read those buffers and
  convert them (``robots.ros2_messages``). A tick never waits for ROS, except :meth:`Ros2Robot.advance`,
  which waits until ROS time has moved by ``dt`` (with a deadline), and, in lockstep simulation only,
  the camera render it asks the bridge for (the world is paused meanwhile; see below).
- The commanded twist is republished by a steady-clock timer at ``command.rate_hz`` (>= 20 Hz): the
  driver zeroes the motion ``command.driver_timeout_s`` after the last command.
- Watchdog: a sensor stream silent past its profile deadline zeroes the twist at once (the timer keeps
  sending zero) and halts the robot: the next ``advance``/``observe`` raises :class:`RobotHalted` naming
  the topic. A malformed message halts it the same way, naming the topic and what is wrong.
- Time: the ROS clock: ``/clock`` with ``use_sim_time`` (and always with the bridge), the system clock
  otherwise; ``now_s()`` and frame stamps count from the instant the backend became ready, as a mission's
  clock does in-process (the lockstep bridge's clock starts at 0, so there the two are the same).
- Camera: colour and aligned depth are paired by stamp (within ``camera.pair_tolerance_s``); the
  camera-to-world transform is the odometry pose nearest the frame's stamp times the profile's static
  mount (tf2 has no PyPI wheel, so no TF lookup). ``map`` is ``odom``: no localisation runs.
- Safety: ``fallen`` from the IMU's tilt (the Go1 spec's threshold); a real robot reports no contact
  events (the bridge scores collisions against the ground truth itself).

Simulation (``simulation=True``, the bridge ``sims/ros2_bridge.py``): the backend also reads
``/sim/scene`` (the catalogue for the perception emulator and the bridge's mode) and the segmentation on
``/sim/camera/segmentation``. In ``lockstep`` mode ``advance(dt)`` sends ``/sim/step`` with the command
and waits for the bridge's reply, ``/sim/state`` (the new time's odometry and float clock in one message);
``observe``/``observe_depth`` ask for a render of the current instant on ``/sim/camera/request`` and wait
for it, as the in-process backend renders inside the tick. The deadlines then bound each wait instead of a
periodic check (the world is paused between steps, so silence between them is not a fault). In lockstep
the tick thread takes the replies itself: the state, IMU, joint and camera subscriptions belong to a
:class:`robots.ros2_pump.SubscriptionPump` that the executor leaves alone, and each wait pumps them, so a
reply costs one wake-up instead of the executor thread's and then the tick thread's (the executor thread
keeps the scene, the heartbeat and the command timer). Which is which is known only once ``/sim/scene``
has said the mode, so in simulation the sensor subscriptions are made then.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

import numpy as np
import numpy.typing as npt

from robots.go1 import load_go1_spec
from robots.interface import Fidelity, Robot
from robots.mount import FLANK_SIDES
from robots.ros2_messages import (
    MessageError,
    camera_info_to_intrinsics,
    depth_grid_image_to_depth_m,
    fill_stamp,
    fill_twist,
    image_to_depth_m,
    image_to_rgb,
    image_to_segmentation,
    imu_to_reading,
    joint_state_from_msg,
    odometry_to_transform,
    odometry_to_twist,
    pose2d_of,
    pose_to_transform,
    stamp_to_ns,
)
from robots.ros2_profile import (
    SENSOR_STREAMS,
    SIDE_DEPTH_STREAMS,
    Ros2Profile,
    TopicQos,
    load_ros2_profile,
)
from robots.ros2_sim_protocol import (
    CAMERA_REQUEST_TOPIC,
    DEPTH_GRID_TOPIC,
    HEARTBEAT_TOPIC,
    OUTCOME_TOPIC,
    SCENE_TOPIC,
    SEGMENTATION_TOPIC,
    STATE_TOPIC,
    STEP_TOPIC,
    TIME_TOPIC,
    CameraRequest,
    Outcome,
    SimState,
    SimulationInfo,
    decode_simulation_info,
    decode_state,
    encode_camera_request,
    encode_outcome,
    same_twist_bits,
)
from semexp_bt.core.types import (
    FloatArray,
    ImuReading,
    InvalidInputError,
    JointState,
    Observation,
    PixelGrid,
    Pose2D,
    SafetyState,
    Twist,
    require_finite,
)

#: Odometry kept for pairing camera frames with the pose they were taken at (about 1 s at 50 Hz).
ODOM_HISTORY = 64
#: Camera frames kept per stream for pairing colour with depth by stamp.
FRAME_HISTORY = 8
#: Completed camera pairs remembered for :meth:`Ros2Robot.camera_pair_arrivals`.
PAIR_LOG = 4096
#: How often (s, steady clock) the watchdog looks at the streams' ages.
WATCHDOG_PERIOD_S = 0.05
#: Zero twists sent on close, so that the driver has one even if a datagram is lost.
CLOSING_ZERO_COMMANDS = 3
#: How long (s) :meth:`Ros2Robot.close` waits, in all, for the executor to shut down and its thread to
#: stop: a clean stop takes well under 0.1 s.
CLOSE_WAIT_S = 2.0
#: The same after a halt. The peer may be gone, and Fast DDS can then hold the executor thread for seconds
#: (a CI run: a 2 s join ran out whole), while a dead bridge must see the executive exit within 2 s
#: (tests/test_ros2_mission.py); the zero twists are out before this wait, so a shorter one loses nothing.
HALTED_CLOSE_WAIT_S = 0.2
#: Lockstep: the most states sent ahead that the executive keeps at once (the bridge sends at most
#: ``SPECULATION_DEPTH`` beyond the ask; stale ones are dropped at each ask).
MAX_STATES_AHEAD = 8
#: Least wall time (s) the lockstep executive waits for the bridge to answer a step or a render. The
#: profile's sensor deadlines are the real robot's rates; a simulated step on a loaded 2-core machine
#: answered later than odometry's 0.5 s once (CI), which is a slow simulation, not a lost robot. 1 s keeps
#: a dead bridge's halt within the 2 s the executive has to exit.
LOCKSTEP_REPLY_MIN_S = 1.0
#: The streams that come on the bridge's ``/sim/...`` topics rather than the robot profile's.
SIMULATION_STREAM_TOPICS = {"segmentation": SEGMENTATION_TOPIC, "depth_grid": DEPTH_GRID_TOPIC}
#: How long (s) a lockstep wait first polls for the bridge's reply before it blocks
#: (robots/ros2_pump.py): a step's reply comes within a few hundred microseconds, sooner than the two
#: thread wake-ups of a blocking wait. Also the bridge's poll for the executive's next request.
LOCKSTEP_SPIN_S = 300e-6
#: Lockstep: a step not answered within this wall time (s) is sent again (its best-effort message or the
#: reply may have been dropped); the bridge answers a step it has already made with the state again.
LOCKSTEP_RESEND_S = 0.1
#: Longest single wait (s) inside a wait for the robot: between two, the waiting thread looks for a halt and
#: (lockstep) at the bridge's silence.
WAIT_SLICE_S = 0.05


class Ros2Error(RuntimeError):
    """The ROS 2 link failed (rclpy missing, a peer never appeared)."""


class RobotHalted(Ros2Error):
    """The backend stopped the robot: a sensor stream went silent or sent garbage, or the bridge vanished.

    Attributes:
        topic: the topic at fault.
        reason: what happened, for the mission's outcome.
    """

    def __init__(self, topic: str, reason: str) -> None:
        super().__init__(f"{topic}: {reason}")
        self.topic = topic
        self.reason = reason


def import_rclpy() -> Any:
    """rclpy, or a clear error saying how to get it."""
    try:
        import rclpy
    except ImportError as error:
        raise Ros2Error(
            "rclpy is not importable in this Python: run the ROS 2 commands with the ROS 2 environment "
            "(`make ros2-env`, then .venv-ros2/bin/semexp-bt ...; docs/ros2.md), or source a ROS 2 Jazzy "
            f"installation ({error})"
        ) from None
    return rclpy


def qos_profile(qos: TopicQos) -> Any:
    """An rclpy ``QoSProfile`` from a profile's topic QoS (keep last ``depth``)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE
        if qos.reliability == "reliable"
        else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL
        if qos.durability == "transient_local"
        else DurabilityPolicy.VOLATILE,
    )


#: QoS of the ``/sim/...`` topics: reliable (a lost render request or frame would stall the lockstep).
SIM_QOS = TopicQos(reliability="reliable", durability="volatile", depth=10)
#: QoS of the lockstep's per-tick pair, ``/sim/step`` and ``/sim/state``: best effort. A reliable writer
#: restarts its NACK-suppression timer (a wake-up of Fast DDS's event thread) and answers heartbeats for
#: every message, which cost a lockstep tick more than the step itself; a step is idempotent (it steps to
#: a stamp), so a lost step or reply is made good by sending the step again (:data:`LOCKSTEP_RESEND_S`).
SIM_STEP_QOS = TopicQos(reliability="best_effort", durability="volatile", depth=10)
#: QoS of the latched ``/sim/scene`` and ``/sim/outcome``.
SIM_LATCHED_QOS = TopicQos(reliability="reliable", durability="transient_local", depth=1)


def ros_context(rclpy: Any) -> Any:
    """A fresh initialised rclpy context without signal handlers (the caller owns SIGINT/SIGTERM)."""
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    return context


@dataclasses.dataclass
class _Stamped:
    """A message with its stamp (ns), the steady time it arrived, and what it converted to once read
    (a tick reads the IMU twice, the guard and ``safety``; a message does not change after it arrived)."""

    stamp_ns: int
    msg: Any
    arrived_s: float
    converted: Any = None


def _read_only(reading: Any) -> Any:
    """``reading`` (a dataclass of arrays) with its arrays made read-only: every caller shares it."""
    for value in vars(reading).values():
        if isinstance(value, np.ndarray):
            value.setflags(write=False)
    return reading


class Ros2Robot(Robot):
    """A Go1 over ROS 2 (see the module docstring).

    Args:
        profile: the robot profile (the shipped Go1 profile when None).
        simulation: also read the bridge's ``/sim/...`` topics (scene catalogue, segmentation, lockstep).
        node_name: the ROS node name.

    Raises:
        Ros2Error: rclpy is not importable.
    """

    def __init__(
        self,
        profile: Ros2Profile | None = None,
        *,
        simulation: bool = False,
        node_name: str = "semexp_bt_executive",
    ) -> None:
        rclpy = import_rclpy()
        from geometry_msgs.msg import Twist as TwistMsg
        from geometry_msgs.msg import TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.clock import Clock, ClockType
        from rclpy.executors import SingleThreadedExecutor
        from rosgraph_msgs.msg import Clock as ClockMsg
        from sensor_msgs.msg import CameraInfo, Image, Imu
        from sensor_msgs.msg import JointState as JointStateMsg
        from std_msgs.msg import Float64, Float64MultiArray, Header, String

        self.profile = profile or load_ros2_profile()
        self.simulation = simulation
        self._use_sim_time = self.profile.use_sim_time or simulation
        # The flank depth cameras: on a robot where the profile enables them; in simulation where the
        # bridge announces them (``_on_scene``).
        self._side_depth = self.profile.side_depth.enabled and not simulation
        self._spec = load_go1_spec()
        self._optical_to_base = self.profile.optical_to_base()
        self._side_optical_to_base = {side: self.profile.side_optical_to_base(side) for side in FLANK_SIDES}
        self._twist_msg_type = TwistMsg
        # Built once and refilled per step (publish copies it): building a TwistStamped costs as much as
        # filling it.
        self._step_msg = TwistStamped()
        self._string_msg_type = String

        self._lock = threading.Condition()
        self._odom: collections.deque[tuple[int, npt.NDArray[np.float64], Twist]] = collections.deque(
            maxlen=ODOM_HISTORY
        )
        self._latest: dict[str, _Stamped] = {}
        self._frames: dict[str, collections.deque[_Stamped]] = {
            stream: collections.deque(maxlen=FRAME_HISTORY)
            for stream in ("color_image", "depth_image", "segmentation")
        }
        self._arrivals: dict[str, int] = collections.defaultdict(int)
        self._pairs_completed: collections.deque[tuple[int, float]] = collections.deque(maxlen=PAIR_LOG)
        # The newest colour + depth pair, kept past FRAME_HISTORY: a colour stream that pauses for less
        # than its deadline must not halt the mission once its last partner leaves the depth history.
        self._last_pair: tuple[_Stamped, _Stamped, _Stamped | None] | None = (
            None  # colour, depth, segmentation
        )
        self._clock_ns: int | None = None
        self._sim_time_s: float | None = None
        self._halt: RobotHalted | None = None
        self._command = Twist.zero()
        self._target_ns: int | None = None
        # Lockstep: the step last asked for (its stamp and twist), and the instant since which every step
        # asked for had that twist: a state is the ask's reply only if it was made under that twist from an
        # instant no earlier (SimState.step_twist, from_ns). States for later instants are the bridge's
        # steps ahead, kept aside by stamp until asked for.
        self._asked: tuple[int, Twist] | None = None
        self._same_twist_since_ns = 0
        self._ahead: dict[int, tuple[SimState, npt.NDArray[np.float64], Any]] = {}
        self._silent_wait_s = 0.0
        self._epoch_ns = 0
        self._bridge_heard_s = time.monotonic()
        self._simulation_info: SimulationInfo | None = None
        self._ready = False
        self._closed = False

        self._rclpy = rclpy
        self._context = ros_context(rclpy)
        # No parameter services: every entity costs each executor wake-up (rclpy rebuilds its wait set).
        self.node = rclpy.create_node(node_name, context=self._context, start_parameter_services=False)
        topics, qos = self.profile.topics, self.profile.qos
        self._cmd_pub = self.node.create_publisher(TwistMsg, topics.cmd_vel, qos_profile(qos.cmd_vel))
        self._msg_types = {
            "odom": Odometry,
            "imu": Imu,
            "joint_states": JointStateMsg,
            "color_info": CameraInfo,
            "color_image": Image,
            "depth_image": Image,
            "sim_time": Float64,
            "state": Float64MultiArray,
        }
        # Lockstep: the tick thread takes the bridge's replies itself (robots/ros2_pump.py).
        self._pump: Any = None
        self._state_subscription: Any = None
        #: Lockstep: steps sent again for want of an answer (LOCKSTEP_RESEND_S).
        self.steps_resent = 0
        #: Lockstep: steps whose state the bridge had sent ahead, taken without a wait.
        self.steps_taken_ahead = 0
        subscribe = self.node.create_subscription
        if not simulation:
            self._subscribe_sensors(subscribe, lockstep=False)
            if self._use_sim_time:
                subscribe(ClockMsg, topics.clock, self._on_clock, qos_profile(qos.clock))
        self._step_pub: Any = None
        self._request_pub: Any = None
        self._outcome_pub: Any = None
        if simulation:
            # The sensor subscriptions follow the bridge's mode (_on_scene): which thread takes them.
            subscribe(String, SCENE_TOPIC, self._on_scene, qos_profile(SIM_LATCHED_QOS))
            subscribe(Header, HEARTBEAT_TOPIC, self._on_heartbeat, qos_profile(SIM_QOS))
            self._step_pub = self.node.create_publisher(TwistStamped, STEP_TOPIC, qos_profile(SIM_STEP_QOS))
            self._request_pub = self.node.create_publisher(String, CAMERA_REQUEST_TOPIC, qos_profile(SIM_QOS))
            self._outcome_pub = self.node.create_publisher(
                String, OUTCOME_TOPIC, qos_profile(SIM_LATCHED_QOS)
            )
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.node.create_timer(1.0 / self.profile.command.rate_hz, self._send_command, clock=steady)
        self._watchdog_timer = self.node.create_timer(WATCHDOG_PERIOD_S, self._watchdog, clock=steady)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        self._spinner = threading.Thread(target=self._spin, name="ros2-robot-spin", daemon=True)
        self._spinner.start()

    def _subscribe_sensors(self, subscribe: Callable[..., Any], *, lockstep: bool) -> None:
        """The profile's sensor streams (and the bridge's segmentation and clock in simulation).

        ``subscribe``: the node's (the executor thread runs the callbacks) or, in lockstep, the pump's
        (the tick thread does, in its waits). In lockstep ``/sim/state`` carries odometry and the float
        clock of each step in one message, instead of ``/odom`` and ``/sim/time``.
        """
        topics, qos, types = self.profile.topics, self.profile.qos, self._msg_types
        if lockstep:
            self._state_subscription = subscribe(
                types["state"], STATE_TOPIC, self._on_state, qos_profile(SIM_STEP_QOS)
            )
        else:
            subscribe(types["odom"], topics.odom, self._on_odom, qos_profile(qos.odom))
            subscribe(types["imu"], topics.imu, self._store("imu"), qos_profile(qos.imu))
            subscribe(
                types["joint_states"],
                topics.joint_states,
                self._store("joint_states"),
                qos_profile(qos.joint_states),
            )
        subscribe(
            types["color_info"], topics.color_info, self._store("color_info"), qos_profile(qos.color_info)
        )
        if self._side_depth:
            for stream in SIDE_DEPTH_STREAMS:
                kind = types["color_info"] if stream.endswith("info") else types["depth_image"]
                subscribe(
                    kind, self.profile.topic_of(stream), self._store(stream), qos_profile(qos.side_depth)
                )
        for stream in ("color_image", "depth_image"):
            subscribe(
                types[stream],
                getattr(topics, stream),
                self._store_frame(stream),
                qos_profile(getattr(qos, stream)),
            )
        if self.simulation:
            subscribe(
                types["color_image"],
                SEGMENTATION_TOPIC,
                self._store_frame("segmentation"),
                qos_profile(SIM_QOS),
            )
            if lockstep:
                subscribe(
                    types["depth_image"], DEPTH_GRID_TOPIC, self._store("depth_grid"), qos_profile(SIM_QOS)
                )
            else:
                subscribe(types["sim_time"], TIME_TOPIC, self._on_sim_time, qos_profile(SIM_QOS))

    # ------------------------------------------------------------------ executor thread

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except Exception as error:
            if not self._closed:
                self._halt_now("rclpy executor", f"the ROS executor stopped ({error!r})")

    def _halt_now(self, topic: str, reason: str) -> None:
        """Zero the command at once and make the next tick-side call raise (first fault wins)."""
        with self._lock:
            if self._halt is None:
                self._halt = RobotHalted(topic, reason)
            self._command = Twist.zero()
            self._lock.notify_all()
        self._publish_twist(Twist.zero())

    def _publish_twist(self, twist: Twist) -> None:
        if self._closed:
            return
        msg = self._twist_msg_type()
        fill_twist(msg, twist)
        self._cmd_pub.publish(msg)

    def _send_command(self) -> None:
        with self._lock:
            command = self._command
        self._publish_twist(command)

    def _watchdog(self) -> None:
        if not self._ready or self.lockstep:
            return
        now = time.monotonic()
        with self._lock:
            if self._halt is not None:
                return
            for stream in self._watched_streams():
                last = self._latest.get(stream)
                deadline = self.profile.deadline_of(stream)
                if last is not None and now - last.arrived_s > deadline:
                    silent_s = now - last.arrived_s
                    break
            else:
                return
        self._halt_now(
            self.profile.topic_of(stream),
            f"silent for {silent_s:.2f} s (deadline {deadline:.2f} s): robot stopped",
        )

    def _record(self, stream: str, stamp_ns: int, msg: Any) -> _Stamped:
        entry = _Stamped(stamp_ns, msg, time.monotonic())
        self._bridge_heard_s = entry.arrived_s
        self._latest[stream] = entry
        self._arrivals[stream] += 1
        return entry

    def _store(self, stream: str) -> Callable[[Any], None]:
        def callback(msg: Any) -> None:
            with self._lock:
                self._record(stream, stamp_to_ns(msg.header.stamp), msg)
                self._lock.notify_all()

        return callback

    def _store_frame(self, stream: str) -> Callable[[Any], None]:
        other = {"color_image": "depth_image", "depth_image": "color_image"}.get(stream)

        def callback(msg: Any) -> None:
            with self._lock:
                entry = self._record(stream, stamp_to_ns(msg.header.stamp), msg)
                self._frames[stream].append(entry)
                partner = None
                if other is not None:
                    partner = next((f for f in self._frames[other] if f.stamp_ns == entry.stamp_ns), None)
                if partner is not None:
                    self._pairs_completed.append((entry.stamp_ns, entry.arrived_s))
                    color, depth = (entry, partner) if stream == "color_image" else (partner, entry)
                    segmentation = next(
                        (f for f in self._frames["segmentation"] if f.stamp_ns == color.stamp_ns), None
                    )
                    self._last_pair = (color, depth, segmentation)
                elif (
                    stream == "segmentation"
                    and self._last_pair is not None
                    and self._last_pair[0].stamp_ns == entry.stamp_ns
                ):
                    self._last_pair = (self._last_pair[0], self._last_pair[1], entry)
                self._lock.notify_all()

        return callback

    def camera_pair_arrivals(self) -> list[tuple[int, float]]:
        """``(stamp_ns, steady time)`` at which each recent colour + depth pair became complete (for the
        latency benchmark: ``time.monotonic`` is the same clock in every process of the machine)."""
        with self._lock:
            return list(self._pairs_completed)

    def _on_odom(self, msg: Any) -> None:
        try:
            transform, twist = odometry_to_transform(msg), odometry_to_twist(msg)
        except MessageError as error:
            self._halt_now(self.profile.topics.odom, f"malformed odometry ({error})")
            return
        stamp = stamp_to_ns(msg.header.stamp)
        with self._lock:
            self._odom.append((stamp, transform, twist))
            self._record("odom", stamp, msg)
            self._lock.notify_all()

    def _on_state(self, msg: Any) -> None:
        """Lockstep: a step's reply (``/sim/state``), converted as ``/odom``, ``/sim/time``, ``/imu`` and
        ``/joint_states`` would be (the IMU and joints when read: :meth:`imu`, :meth:`joint_state`)."""
        try:
            state = decode_state(msg.data, joints=len(self._spec.joint_names))
            transform = pose_to_transform(state.position_m, state.orientation_xyzw)
        except InvalidInputError as error:  # MessageError and SimProtocolError
            self._halt_now(STATE_TOPIC, f"malformed state ({error})")
            return
        with self._lock:
            asked = self._asked
            if asked is None or self._answers_ask(state):
                self._take_state_locked(state, transform, msg)
            else:  # the bridge spoke, if not this step's answer
                self._bridge_heard_s = time.monotonic()
                if state.stamp_ns > asked[0] and len(self._ahead) < MAX_STATES_AHEAD:
                    self._ahead[state.stamp_ns] = (state, transform, msg)
                # else: a state for an instant already passed, or sent ahead under another twist.

    def _answers_ask(self, state: SimState) -> bool:
        """Lockstep: ``state`` is the state of the step last asked for (call with the lock held)."""
        asked = self._asked
        return (
            asked is not None
            and state.stamp_ns == asked[0]
            and same_twist_bits(state.step_twist, asked[1])
            and state.from_ns >= self._same_twist_since_ns
        )

    def _take_state_locked(self, state: SimState, transform: npt.NDArray[np.float64], msg: Any) -> None:
        """Lockstep: ``state`` is the instant the executive is at (call with the lock held)."""
        if not (self._odom and self._odom[-1][0] == state.stamp_ns):  # a resend's answer, once
            self._odom.append((state.stamp_ns, transform, state.twist))
        self._sim_time_s = state.sim_time_s
        self._record("odom", state.stamp_ns, msg)
        self._record("imu", state.stamp_ns, state)
        self._record("joint_states", state.stamp_ns, state)
        self._lock.notify_all()

    def _on_clock(self, msg: Any) -> None:
        with self._lock:
            self._clock_ns = stamp_to_ns(msg.clock)
            self._arrivals["clock"] += 1
            self._bridge_heard_s = time.monotonic()
            self._lock.notify_all()

    def _on_sim_time(self, msg: Any) -> None:
        with self._lock:
            self._sim_time_s = float(msg.data)
            self._bridge_heard_s = time.monotonic()
            self._lock.notify_all()

    def _on_heartbeat(self, msg: Any) -> None:
        del msg
        with self._lock:
            self._bridge_heard_s = time.monotonic()

    def _on_scene(self, msg: Any) -> None:
        try:
            info = decode_simulation_info(msg.data)
        except InvalidInputError as error:
            self._halt_now(SCENE_TOPIC, str(error))
            return
        lockstep = info.mode == "lockstep"
        if self._simulation_info is None:  # latched: once per subscription, but never subscribe twice
            self._side_depth = info.side_depth
            if lockstep:
                from robots.ros2_pump import SubscriptionPump

                self._pump = SubscriptionPump(self.node)
                self._subscribe_sensors(self._pump.subscribe, lockstep=True)
            else:
                self._subscribe_sensors(self.node.create_subscription, lockstep=False)
        with self._lock:
            self._simulation_info = info
            self._lock.notify_all()
        if lockstep:  # deadlines bound the waits instead; one entity less per wake-up
            self._watchdog_timer.cancel()

    # ------------------------------------------------------------------ readiness

    @property
    def lockstep(self) -> bool:
        """Whether the bridge steps the world per tick (known once ``/sim/scene`` has arrived)."""
        info = self._simulation_info
        return info is not None and info.mode == "lockstep"

    @property
    def simulation_info(self) -> SimulationInfo | None:
        """The bridge's announcement (None on a real robot)."""
        return self._simulation_info

    def _watched_streams(self) -> tuple[str, ...]:
        if self.lockstep:  # camera frames come on request only
            return ("odom", "imu", "joint_states")
        return SENSOR_STREAMS + (SIDE_DEPTH_STREAMS if self._side_depth else ())

    def _topic_of(self, stream: str) -> str:
        """The topic a stream arrives on (in lockstep, odometry, IMU and joints come on ``/sim/state``)."""
        if self.lockstep and stream in ("odom", "imu", "joint_states"):
            return STATE_TOPIC
        return SIMULATION_STREAM_TOPICS.get(stream) or self.profile.topic_of(stream)

    def _missing(self) -> list[str]:
        missing = [] if not self.simulation or self._simulation_info is not None else [SCENE_TOPIC]
        if self.simulation and self._simulation_info is None:
            return missing  # which streams to expect depends on the bridge's mode
        missing += [self._topic_of(s) for s in self._watched_streams() if s not in self._latest]
        if self.simulation and self._sim_time_s is None and not self.lockstep:  # else /sim/state's
            missing.append(TIME_TOPIC)
        elif self._use_sim_time and not self.simulation and self._clock_ns is None:
            missing.append(self.profile.topics.clock)
        return missing

    def wait_until_ready(self, timeout_s: float | None = None) -> None:
        """Wait for every stream's first message (and the bridge's scene in simulation).

        Raises:
            Ros2Error: naming the topics still silent after ``timeout_s`` (the profile's startup deadline).
            RobotHalted: a stream sent garbage meanwhile.
        """
        timeout = self.profile.deadlines_s.startup_s if timeout_s is None else timeout_s
        with self._lock:
            self._wait_locked(lambda: not self._missing() or self._halt is not None, timeout)
            self._raise_if_halted()
            missing = self._missing()
            if missing:
                hint = " (is `semexp-bt sim-bridge` running?)" if self.simulation else ""
                raise Ros2Error(f"no message within {timeout:.1f} s on {', '.join(missing)}{hint}")
            self._target_ns = self._epoch_ns = self._now_ns()
            self._ready = True

    def _raise_if_halted(self) -> None:
        if self._halt is not None:
            raise self._halt

    # ------------------------------------------------------------------ clock

    def _now_ns(self) -> int:
        if self.simulation:
            return int(round((self._sim_time_s or 0.0) * 1e9))
        if self._use_sim_time:
            return int(self._clock_ns or 0)
        return time.time_ns()

    def now_s(self) -> float:
        """Seconds of ROS time since the backend became ready; in lockstep, the simulator's own float clock
        (``/sim/time``, of which ``/clock`` is the nanosecond rounding; the lockstep clock starts at 0)."""
        with self._lock:
            return self._now_s_locked()

    def _now_s_locked(self) -> float:
        if self.lockstep:
            return self._sim_time_s or 0.0
        return (self._now_ns() - self._epoch_ns) * 1e-9

    @property
    def epoch_s(self) -> float:
        """The ROS time (s) at which the backend became ready: ``now_s()`` counts from here."""
        return self._epoch_ns * 1e-9

    def _sim_time_reached(self, target_ns: int) -> bool:
        """Lockstep: the float clock has reached ``target_ns`` (to the nanosecond)."""
        return self._sim_time_s is not None and int(round(self._sim_time_s * 1e9)) >= target_ns

    def advance(self, duration_s: float) -> None:
        """Wait until ROS time has moved by ``duration_s`` since the last target (lockstep: step the bridge).

        Raises:
            RobotHalted: the robot was halted, or ROS time did not move within the deadline (the bridge
                or the clock is gone).
        """
        require_finite("duration_s", duration_s)
        if duration_s < 0.0:
            raise InvalidInputError(f"duration_s must be >= 0, got {duration_s}")
        with self._lock:
            self._raise_if_halted()
            if self._target_ns is None:
                self._target_ns = self._now_ns()
            target = self._target_ns + int(round(duration_s * 1e9))
            command = self._command
        if self.lockstep:
            self._step_to(target, command)
        else:
            self._wait_for_time(target)

    def _step_to(self, target_ns: int, command: Twist) -> None:
        """Lockstep: step the bridge to ``target_ns`` under ``command``. If the bridge already sent that
        step's state ahead (sims/ros2_bridge.py, ``Speculation``), take it and go on: the ask only tells
        the bridge to keep the step. Else wait for the reply."""
        self._pump.drain((self._state_subscription,))  # what came while the tree ticked
        msg = self._step_msg
        fill_stamp(msg.header.stamp, target_ns * 1e-9)
        fill_twist(msg.twist, command)
        with self._lock:
            self._raise_if_halted()
            previous = self._asked
            if previous is None or not same_twist_bits(previous[1], command):
                self._same_twist_since_ns = self._target_ns if self._target_ns is not None else 0
            self._asked = (target_ns, command)
            ahead = self._ahead.pop(target_ns, None)
            for stamp in [stamp for stamp in self._ahead if stamp <= target_ns]:
                del self._ahead[stamp]
            taken = ahead is not None and self._answers_ask(ahead[0])
            if taken:
                assert ahead is not None
                self._take_state_locked(*ahead)
                self.steps_taken_ahead += 1
                self._target_ns = target_ns
        self._step_pub.publish(msg)
        if taken:
            return
        deadline = max(self.profile.deadline_of("odom"), LOCKSTEP_REPLY_MIN_S)
        with self._lock:
            arrived = self._await_bridge(
                lambda: (
                    self._sim_time_reached(target_ns) and bool(self._odom) and self._odom[-1][0] >= target_ns
                ),
                deadline,
                spin_on=(self._state_subscription,),
                resend=self._resend_step,
            )
            if not arrived:
                self._halt_locked(
                    STATE_TOPIC,
                    f"the simulation bridge fell silent for {deadline:.2f} s during a step "
                    f"(waited {self._silent_wait_s:.2f} s)",
                )
            self._target_ns = target_ns

    def _resend_step(self) -> None:
        self.steps_resent += 1
        self._step_pub.publish(self._step_msg)

    def _await_bridge(
        self,
        done: Callable[[], bool],
        deadline_s: float,
        *,
        spin_on: tuple[Any, ...] = (),
        resend: Callable[[], None] | None = None,
    ) -> bool:
        """Lockstep: wait (lock held) until ``done()``, while the bridge keeps talking; False once it has
        sent nothing (not even its heartbeat) for ``deadline_s``. Raises if the robot was halted meanwhile.
        ``spin_on``: the subscriptions the reply comes on, polled first (:data:`LOCKSTEP_SPIN_S`);
        ``resend``: sends the request again, every :data:`LOCKSTEP_RESEND_S` without an answer.

        A busy bridge (a render on a loaded machine) is slow, not gone: the world is paused meanwhile.
        The wait's own length is kept for the halt's message (:attr:`_silent_wait_s`): a wait shorter than
        the silence means the tick came to it late.
        """
        began = time.monotonic()
        while True:
            silent_s = time.monotonic() - self._bridge_heard_s
            if self._wait_locked(
                lambda: self._halt is not None or done(),
                max(deadline_s - silent_s, 0.0),
                spin_on=spin_on,
                resend=resend,
            ):
                self._raise_if_halted()
                return True
            if time.monotonic() - self._bridge_heard_s >= deadline_s:
                self._silent_wait_s = time.monotonic() - began
                return False

    def _wait_locked(
        self,
        done: Callable[[], bool],
        timeout_s: float,
        *,
        spin_on: tuple[Any, ...] = (),
        resend: Callable[[], None] | None = None,
    ) -> bool:
        """Wait (lock held) until ``done()``, at most ``timeout_s``; whether it came true.

        Before the bridge's mode is known, and live, the executor thread's callbacks notify the lock. In
        lockstep the waiting thread takes the bridge's replies itself (the pump runs their callbacks here),
        with the lock released meanwhile so that the executor thread's callbacks (the heartbeat) go on;
        ``resend`` (lockstep) runs there too, each :data:`LOCKSTEP_RESEND_S` without ``done()``.
        """
        sent_s = time.monotonic()
        deadline = sent_s + timeout_s
        while not done():
            now = time.monotonic()
            left = deadline - now
            if left <= 0.0:
                return False
            pump = self._pump
            if pump is None:
                self._lock.wait(timeout=min(left, WAIT_SLICE_S))
                continue
            self._lock.release()
            try:
                if resend is not None and now - sent_s >= LOCKSTEP_RESEND_S:
                    resend()
                    sent_s = now
                pump.pump(min(left, WAIT_SLICE_S, LOCKSTEP_RESEND_S), spin_on=spin_on, spin_s=LOCKSTEP_SPIN_S)
            finally:
                self._lock.acquire()
        return True

    def _halt_locked(self, topic: str, reason: str) -> NoReturn:
        """:meth:`_halt_now` from a thread that holds the lock; raises."""
        if self._halt is None:
            self._halt = RobotHalted(topic, reason)
        self._command = Twist.zero()
        self._lock.notify_all()
        halt = self._halt
        self._lock.release()
        try:
            self._publish_twist(Twist.zero())
        finally:
            self._lock.acquire()
        raise halt

    def _wait_for_time(self, target_ns: int) -> None:
        """Live: wait until ROS time reaches ``target_ns`` (the system clock, or /clock and /sim/time)."""
        with self._lock:
            period_ns = target_ns - (self._target_ns or target_ns)
            if not self._use_sim_time:
                wait_s = max(0.0, (target_ns - time.time_ns()) * 1e-9)
                self._lock.wait_for(lambda: self._halt is not None, timeout=wait_s)
            else:
                deadline = self.profile.deadline_of("odom") + (target_ns - self._now_ns()) * 1e-9
                moved = self._lock.wait_for(
                    lambda: self._halt is not None or self._now_ns() >= target_ns, timeout=max(deadline, 0.0)
                )
                self._raise_if_halted()
                if not moved:
                    topic = TIME_TOPIC if self.simulation else self.profile.topics.clock
                    self._halt_locked(topic, f"ROS time did not reach the next tick within {deadline:.2f} s")
            self._raise_if_halted()
            now = self._now_ns()
            # A tick that overran by a whole period does not make the next ones rush to catch up.
            self._target_ns = target_ns if now - target_ns < period_ns else now

    # ------------------------------------------------------------------ camera

    def _pose_at(self, stamp_ns: int) -> npt.NDArray[np.float64]:
        """T_odom<-base of the odometry sample nearest ``stamp_ns`` (call with the lock held)."""
        if not self._odom:
            raise RobotHalted(self.profile.topics.odom, "no odometry to place the camera frame")
        best = min(self._odom, key=lambda sample: abs(sample[0] - stamp_ns))
        return best[1]

    def _latest_pair(self, *, need_color: bool) -> tuple[_Stamped | None, _Stamped, _Stamped | None]:
        """The newest (colour, depth, segmentation) with matching stamps (call with the lock held)."""
        tolerance_ns = int(self.profile.camera.pair_tolerance_s * 1e9)
        depths = list(self._frames["depth_image"])
        if not depths:
            raise RobotHalted(self.profile.topics.depth_image, "no depth frame yet")
        for depth in reversed(depths):
            color = None
            if need_color:
                color = next(
                    (
                        c
                        for c in reversed(self._frames["color_image"])
                        if abs(c.stamp_ns - depth.stamp_ns) <= tolerance_ns
                    ),
                    None,
                )
                if color is None:
                    continue
            segmentation = None
            if self.simulation and need_color:
                segmentation = next(
                    (s for s in reversed(self._frames["segmentation"]) if s.stamp_ns == color.stamp_ns),  # type: ignore[union-attr]
                    None,
                )
                if segmentation is None:
                    continue
            return color, depth, segmentation
        topic = self.profile.topics.color_image if need_color else self.profile.topics.depth_image
        if need_color and not self.lockstep:
            last_color = self._latest.get("color_image")
            silent_s = math.inf if last_color is None else time.monotonic() - last_color.arrived_s
            deadline = self.profile.deadline_of("color_image")
            if silent_s > deadline:
                self._halt_locked(
                    topic, f"silent for {silent_s:.2f} s (deadline {deadline:.2f} s): robot stopped"
                )
            if self._last_pair is not None and (self._last_pair[2] is not None or not self.simulation):
                return self._last_pair
        raise RobotHalted(topic, "no colour frame pairs with a depth frame by stamp")

    def _request_frame(self, request: CameraRequest) -> None:
        """Lockstep: ask the bridge to render now and wait for the frames (call with the lock held)."""
        now = self._now_ns()
        if request.kind == "side":
            wanted = list(SIDE_DEPTH_STREAMS)
        elif request.kind == "depth" and request.grids is not None:
            wanted = ["color_info", "depth_grid"]
        else:
            wanted = ["color_info", "depth_image"] + (
                ["color_image", "segmentation"] if request.kind == "full" else []
            )
        seen = {stream: self._arrivals[stream] for stream in wanted}
        msg = self._string_msg_type()
        msg.data = encode_camera_request(dataclasses.replace(request, at_ns=now))
        self._request_pub.publish(msg)
        # The wait is bounded by the camera's deadline (the grid reply has none of its own).
        image = SIDE_DEPTH_STREAMS[0] if request.kind == "side" else "depth_image"
        deadline = max(self.profile.deadline_of(image), LOCKSTEP_REPLY_MIN_S)

        def arrived() -> bool:
            return all(self._arrivals[s] > seen[s] and self._latest[s].stamp_ns == now for s in wanted)

        # The step ask is sent again meanwhile: a render of an instant the bridge has not reached waits for
        # it there (the executive may have taken that step's state ahead of a lost ask). Before the first
        # step there is no ask to send.
        resend = None if self._asked is None else self._resend_step
        if not self._await_bridge(arrived, deadline, resend=resend):
            missing = [s for s in wanted if not (self._arrivals[s] > seen[s])]
            stream = missing[0] if missing else "depth_image"
            topic = self._topic_of(stream)
            self._halt_locked(
                topic,
                f"the simulation bridge fell silent for {deadline:.2f} s during a render "
                f"(waited {self._silent_wait_s:.2f} s)",
            )
        self._raise_if_halted()

    def _observation(
        self,
        color: _Stamped | None,
        depth: _Stamped,
        segmentation: _Stamped | None,
        *,
        info_stream: str = "color_info",
        depth_stream: str = "depth_image",
        optical_to_base: FloatArray | None = None,
        grids: Sequence[PixelGrid] | None = None,
    ) -> Observation:
        """Convert a paired frame (call with the lock held): the head camera's, or with ``info_stream``,
        ``depth_stream`` and ``optical_to_base`` another depth camera's. With ``grids``, ``depth`` is a
        lockstep grid image (``DEPTH_GRID_TOPIC``), put back into a whole frame."""
        info = self._latest.get(info_stream)
        if info is None:
            raise RobotHalted(self.profile.topic_of(info_stream), "no camera info yet")
        topics = self.profile.topics
        try:
            intrinsics = camera_info_to_intrinsics(info.msg)
        except MessageError as error:
            self._halt_locked(self.profile.topic_of(info_stream), str(error))
        try:
            if grids is None:
                depth_m = image_to_depth_m(depth.msg)
            else:
                depth_m = depth_grid_image_to_depth_m(
                    depth.msg, grids, height_px=intrinsics.height_px, width_px=intrinsics.width_px
                )
        except MessageError as error:
            self._halt_locked(self._topic_of(depth_stream), str(error))
        rgb = np.empty((0, 0, 3), dtype=np.uint8)
        if color is not None:
            try:
                rgb = image_to_rgb(color.msg)
            except MessageError as error:
                self._halt_locked(topics.color_image, str(error))
        seg = None
        if segmentation is not None:
            try:
                seg = image_to_segmentation(segmentation.msg)
            except MessageError as error:
                self._halt_locked(SEGMENTATION_TOPIC, str(error))
        if depth_m.shape != (intrinsics.height_px, intrinsics.width_px) or (
            color is not None and rgb.shape[:2] != depth_m.shape
        ):
            self._halt_locked(
                self.profile.topic_of(depth_stream),
                f"frame sizes disagree: depth {depth_m.shape}, colour {rgb.shape[:2]}, "
                f"camera info {intrinsics.height_px}x{intrinsics.width_px}",
            )
        base_to_odom = self._pose_at(depth.stamp_ns)
        mount = self._optical_to_base if optical_to_base is None else optical_to_base
        return Observation(
            rgb=rgb,
            depth_m=depth_m,
            intrinsics=intrinsics,
            camera_to_world=base_to_odom @ mount,
            base_pose=pose2d_of(base_to_odom),
            # Lockstep frames are rendered at the current instant: stamp them with the float clock.
            stamp_s=self._now_s_locked() if self.lockstep else (depth.stamp_ns - self._epoch_ns) * 1e-9,
            segmentation=seg,
        )

    def observe(self) -> Observation:
        """The latest colour + aligned depth pair (lockstep: rendered now), with the pose it was taken at."""
        with self._lock:
            self._raise_if_halted()
            if self.lockstep:
                self._request_frame(CameraRequest(kind="full"))
            return self._observation(*self._latest_pair(need_color=True))

    def observe_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> Observation:
        """The latest depth frame; ``rgb`` is empty. Lockstep: depth rendered now at ``pixel_grids``."""
        with self._lock:
            self._raise_if_halted()
            if self.lockstep:
                grids = None if pixel_grids is None else tuple(pixel_grids)
                self._request_frame(CameraRequest(kind="depth", grids=grids))
                if grids is not None:
                    return self._observation(
                        None, self._latest["depth_grid"], None, depth_stream="depth_grid", grids=grids
                    )
            _, depth, _ = self._latest_pair(need_color=False)
            return self._observation(None, depth, None)

    def observe_side_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> list[Observation]:
        """The flank cameras' latest depth, each with the pose at its stamp (lockstep: measured now at
        ``pixel_grids``); none where they are not used (``side_depth`` in the profile, or the bridge's
        announcement)."""
        if not self._side_depth:
            return []
        with self._lock:
            self._raise_if_halted()
            if self.lockstep:
                grids = None if pixel_grids is None else tuple(pixel_grids)
                self._request_frame(CameraRequest(kind="side", grids=grids))
            return [self._side_observation(side) for side in FLANK_SIDES]

    def _side_observation(self, side: str) -> Observation:
        """Convert one flank camera's latest depth image (call with the lock held)."""
        stream = f"{side}_depth_image"
        image = self._latest.get(stream)
        if image is None:
            raise RobotHalted(self.profile.topic_of(stream), "no message yet")
        return self._observation(
            None,
            image,
            None,
            info_stream=f"{side}_depth_info",
            depth_stream=stream,
            optical_to_base=self._side_optical_to_base[side],
        )

    # ------------------------------------------------------------------ state

    def base_pose(self) -> Pose2D:
        with self._lock:
            if not self._odom:
                raise RobotHalted(self.profile.topics.odom, "no odometry yet")
            return pose2d_of(self._odom[-1][1])

    def base_twist(self) -> Twist:
        with self._lock:
            if not self._odom:
                raise RobotHalted(self.profile.topics.odom, "no odometry yet")
            return self._odom[-1][2]

    def _convert_latest(self, stream: str, convert: Callable[[Any], Any]) -> Any:
        with self._lock:
            entry = self._latest.get(stream)
            if entry is None:
                raise RobotHalted(self._topic_of(stream), "no message yet")
            if entry.converted is None:
                try:
                    entry.converted = _read_only(convert(entry.msg))
                except MessageError as error:
                    self._halt_locked(self._topic_of(stream), str(error))
            return entry.converted

    def joint_state(self) -> JointState:
        if self.lockstep:
            state: JointState = self._convert_latest("joint_states", SimState.joint_state)
            return state
        names = self._spec.joint_names
        state = self._convert_latest("joint_states", lambda msg: joint_state_from_msg(msg, names))
        return state

    def imu(self) -> ImuReading:
        convert = SimState.imu_reading if self.lockstep else imu_to_reading
        reading: ImuReading = self._convert_latest("imu", convert)
        return reading

    def safety(self) -> SafetyState:
        """``fallen`` when the IMU's tilt exceeds the Go1 spec's; no contact events on a real robot."""
        w, x, y, z = (float(v) for v in self.imu().orientation_wxyz)
        # The angle between the body's z axis and the world's: cos(tilt) = R[2, 2].
        cos_tilt = 1.0 - 2.0 * (x * x + y * y) / max(w * w + x * x + y * y + z * z, 1e-12)
        tilt = math.acos(max(-1.0, min(1.0, cos_tilt)))
        return SafetyState(fallen=tilt > self._spec.fall_tilt_rad)

    @property
    def fidelity(self) -> Fidelity:
        """``kinematic``: the robot walks by itself; the executive commands twists (no gait runs here)."""
        return "kinematic"

    # ------------------------------------------------------------------ commands

    def command_twist(self, twist: Twist) -> None:
        require_finite("twist", [twist.linear_x_mps, twist.linear_y_mps, twist.angular_z_radps])
        with self._lock:
            if self._halt is not None:
                return  # a halted robot stays stopped; the next advance() raises
            self._command = twist
        if not self.lockstep:
            self._publish_twist(twist)

    def command_joint_targets(self, targets_rad: npt.NDArray[np.float64]) -> None:
        raise InvalidInputError(
            "the ROS 2 backend drives the Go1 through its driver's /cmd_vel; joint targets are not available"
        )

    def stop(self) -> None:
        with self._lock:
            self._command = Twist.zero()
        self._publish_twist(Twist.zero())

    def report_outcome(
        self, outcome: str, found_objects: Sequence[dict[str, Any]], *, timeout_s: float = 2.0
    ) -> bool:
        """Simulation: publish the mission's outcome on ``/sim/outcome`` (with the instant the executive
        ended at) and wait until the bridge has it."""
        if self._outcome_pub is None:
            return False
        from rclpy.duration import Duration

        with self._lock:
            at_ns = self._now_ns()
        msg = self._string_msg_type()
        msg.data = encode_outcome(Outcome(outcome, list(found_objects), at_ns))
        self._outcome_pub.publish(msg)
        return bool(self._outcome_pub.wait_for_all_acked(Duration(seconds=timeout_s)))

    def close(self) -> None:
        """Send zero twists, then stop the executor and the ROS context (idempotent).

        The executor's shutdown and its thread's end share one deadline, :data:`CLOSE_WAIT_S`, or after a
        halt :data:`HALTED_CLOSE_WAIT_S`: a node the executor thread still holds is left to the process's
        end rather than destroyed. After a halt the node's and the context's teardown run on a thread of
        their own, waited for until that deadline only: with a peer gone, Fast DDS can hold them too.
        """
        if self._closed:
            return
        with self._lock:
            self._command = Twist.zero()
            halted = self._halt is not None
        wait_s = HALTED_CLOSE_WAIT_S if halted else CLOSE_WAIT_S
        for _ in range(CLOSING_ZERO_COMMANDS):
            self._publish_twist(Twist.zero())
        self._closed = True
        if self._pump is not None:
            self._pump.close()
        deadline = time.monotonic() + wait_s
        self._executor.shutdown(timeout_sec=wait_s / 2.0)
        self._spinner.join(timeout=max(0.0, deadline - time.monotonic()))
        # A node still in the executor's hands would block destroy_node.
        node_free = not self._spinner.is_alive()

        def end_ros() -> None:
            if node_free:
                self.node.destroy_node()
            self._context.try_shutdown()

        if not halted:
            end_ros()
            return
        ender = threading.Thread(target=end_ros, name="ros2-robot-end", daemon=True)
        ender.start()
        ender.join(timeout=max(0.0, deadline - time.monotonic()))


__all__ = ["Ros2Error", "Ros2Robot", "RobotHalted", "import_rclpy", "qos_profile", "ros_context"]
