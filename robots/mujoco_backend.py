"""The MuJoCo backend of :class:`robots.interface.Robot`, in two fidelities.

- ``kinematic``: a planar base (slide x, slide y, hinge yaw) carrying the Go1 trunk shape, a box bounding
  the standing legs and the head camera. Each control period it integrates the commanded twist under
  Go1-like speed and acceleration limits and sets qpos; a move that would make the robot penetrate an
  obstacle (signed distance < 0 by ``mj_geomDistance``) is not taken, the base stops and a collision
  event is recorded. No dynamics run: it is for fast mission and benchmark runs.
- ``dynamic``: the full Go1 on a free joint. ``mj_step`` runs at the physics rate, the 12 position
  actuators hold the last joint targets (the standing pose until the gait sends others). The commanded
  twist is stored for the gait (a later issue); until then the robot stands.

Safety (both fidelities, once per control period): signed distances between the robot's geoms and every
obstacle geom near it (``mj_geomDistance``, exact for boxes and cylinders). An object enters the
"collision" set when a distance is <= 0 and the "clearance" set when it is < ``clearance_m``; each time
an object enters a set a :class:`ContactEvent` is appended (edge-triggered with a 3 cm release
hysteresis: pushing into a wall for 5 s is one event, backing off and touching it again is a second). ``min_clearance_m`` is the smallest distance
at the last check, exact up to ``clearance_m + CLEARANCE_SENSE_MARGIN_M`` and ``inf`` beyond;
``least_clearance_m`` the smallest since the start (a refused kinematic move counts as a touch: its penetration, <= 0).

Rendering happens only in :meth:`MujocoRobot.observe` and :meth:`MujocoRobot.observe_depth`; the GL
context is created on the first call. ``observe_depth`` given the pixel grids its caller reads (the local
planner's and the occupancy map's) casts one ray per grid pixel instead of rasterising the frame
(``depth_sampling="rays"``, the default): on the software rasteriser this is the largest cost of a
kinematic episode. The rays agree with the rendered depth within 1 cm at all but a few pixels (53 of
321,000 sampled over the ten scenes: scripts/compare_ray_depth.py, docs/simulation.md).
``depth_sampling="raster"`` keeps the rendered frame.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np
import numpy.typing as npt

from robots.camera import CameraConfig, RgbdCamera
from robots.go1 import (
    CAMERA_NAME,
    IMU_ACCELEROMETER_SENSOR,
    IMU_GYRO_SENSOR,
    IMU_ORIENTATION_SENSOR,
    NUM_JOINTS,
    TRUNK_BODY_NAME,
    load_go1_spec,
)
from robots.interface import FIDELITIES, Fidelity, Robot
from robots.mjcf_scene import build_mjcf, geom_object_ids, robot_geom_ids
from robots.ros2_messages import pose2d_of, pose_to_transform
from robots.side_depth import GO1_SIDE_DEPTH, SideDepthCameras, SideDepthConfig
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import (
    ContactEvent,
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

#: Standard gravity (m/s^2), what an accelerometer at rest reads upwards.
GRAVITY_MPS2 = 9.81

#: Distances are computed up to ``clearance_m`` plus this (m); beyond it ``min_clearance_m`` is inf.
CLEARANCE_SENSE_MARGIN_M = 0.5

#: Hysteresis (m): an object leaves the collision (clearance) set only once the robot is this much beyond
#: contact (the clearance distance). A blocked kinematic base stops up to one control step (2 cm at
#: 1 m/s) short of the obstacle and creeps on; without hysteresis every creep would be a new event.
EVENT_RELEASE_MARGIN_M = 0.03

#: Physics time the dynamic robot stands before the clock starts, so that the PD sag is over (s).
SETTLE_S = 1.0

_TIME_EPS_S = 1e-9

DepthSampling = Literal["rays", "raster"]
#: How ``observe_depth`` measures the pixels its caller asks for: ray casting or a rendered frame.
DEPTH_SAMPLINGS: tuple[str, ...] = ("rays", "raster")


@dataclass(frozen=True)
class BaseMotionLimits:
    """Speed and acceleration limits of the base (the Go1's own walking controller's envelope).

    Attributes:
        max_forward_mps: |v_x| limit (Go1 normal walking mode: about 1 m/s).
        max_lateral_mps: |v_y| limit.
        max_yaw_radps: |w_z| limit.
        max_linear_accel_mps2: per-axis linear acceleration limit (the Go1 reaches 1 m/s in about 0.5 s).
        max_yaw_accel_radps2: yaw acceleration limit.
    """

    max_forward_mps: float = 1.0
    max_lateral_mps: float = 0.5
    max_yaw_radps: float = 1.5
    max_linear_accel_mps2: float = 2.0
    max_yaw_accel_radps2: float = 4.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not math.isfinite(value) or value <= 0.0:
                raise InvalidInputError(
                    f"BaseMotionLimits.{name} must be a positive finite number, got {value!r}"
                )

    def clamp(self, twist: Twist) -> FloatArray:
        """The twist as ``(vx, vy, wz)``, each clipped to its speed limit."""
        # Plain min/max: np.clip on three scalars costs more than the rest of a kinematic step.
        return np.array(
            [
                min(max(twist.linear_x_mps, -self.max_forward_mps), self.max_forward_mps),
                min(max(twist.linear_y_mps, -self.max_lateral_mps), self.max_lateral_mps),
                min(max(twist.angular_z_radps, -self.max_yaw_radps), self.max_yaw_radps),
            ]
        )

    def accel_limits(self) -> FloatArray:
        return np.array([self.max_linear_accel_mps2, self.max_linear_accel_mps2, self.max_yaw_accel_radps2])


@dataclass(frozen=True)
class ImuNoise:
    """White noise added to IMU readings (zero-mean Gaussian standard deviations).

    Defaults are a MEMS IMU of the Go1's class (BMI088-like noise densities over a ~500 Hz band).
    """

    gyro_std_radps: float = 0.005
    accel_std_mps2: float = 0.04

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not math.isfinite(value) or value < 0.0:
                raise InvalidInputError(
                    f"ImuNoise.{name} must be a non-negative finite number, got {value!r}"
                )


def _roll_pitch_from_quat(quat_wxyz: FloatArray) -> tuple[float, float]:
    w, x, y, z = quat_wxyz
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    return roll, pitch


def _yaw_quat(yaw_rad: float) -> FloatArray:
    return np.array([math.cos(yaw_rad / 2.0), 0.0, 0.0, math.sin(yaw_rad / 2.0)])


def _copy_imu(reading: ImuReading) -> ImuReading:
    return ImuReading(
        angular_velocity_radps=reading.angular_velocity_radps.copy(),
        linear_acceleration_mps2=reading.linear_acceleration_mps2.copy(),
        orientation_wxyz=reading.orientation_wxyz.copy(),
    )


#: Penetration depth the kinematic base treats as touching (distance-solver round-off at contact).
_CONTACT_TOLERANCE_M = 1e-4


@dataclass(frozen=True)
class KinematicSnapshot:
    """What a kinematic step changes in a :class:`MujocoRobot`, kept to take the step back
    (:meth:`MujocoRobot.snapshot`, :meth:`MujocoRobot.restore`). Opaque to callers."""

    qpos: FloatArray
    time_s: float
    clock_target_s: float
    command: Twist
    base_velocity: FloatArray
    base_accel: FloatArray
    min_clearance_m: float
    least_clearance_m: float
    events: int
    in_collision: frozenset[int]
    in_clearance: frozenset[int]
    imu_sample: tuple[float, ImuReading] | None
    transform_cache: tuple[bytes, FloatArray] | None


class MujocoRobot(Robot):
    """A Go1 with a head RGB-D camera in a MuJoCo scene.

    Args:
        scene: the scene to build.
        fidelity: ``"kinematic"`` or ``"dynamic"``.
        start_pose: the base pose at t = 0.
        seed: seeds the IMU noise generator.
        camera: the head camera; the default :class:`CameraConfig` (320x240 render) when None.
        clearance_m: distance below which an obstacle counts as a clearance breach.
        physics_dt_s: physics timestep; the model's (0.002 s) when None.
        control_dt_s: the command period (gait rate, 50 Hz): the kinematic integration step and the
            safety-check period. Must be a whole number of physics steps.
        motion_limits: speed/acceleration limits of the kinematic base.
        imu_noise: IMU noise; :class:`ImuNoise` defaults when None.
        depth_sampling: how :meth:`observe_depth` measures the pixels a caller asks for: ``"rays"``
            (one ray per pixel, no rasteriser) or ``"raster"`` (a rendered depth frame).
        side_depth: the flank depth cameras (``robots/side_depth.py``), for the costmap; None: none.

    Raises:
        InvalidInputError: a non-finite start pose, a bad clearance or timestep (naming the field).
        ValueError: an unknown fidelity or a malformed scene.
    """

    def __init__(
        self,
        *,
        scene: SceneSpec,
        fidelity: Fidelity,
        start_pose: Pose2D,
        seed: int,
        camera: CameraConfig | None = None,
        clearance_m: float = 0.1,
        physics_dt_s: float | None = None,
        control_dt_s: float = 0.02,
        motion_limits: BaseMotionLimits | None = None,
        imu_noise: ImuNoise | None = None,
        depth_sampling: DepthSampling = "rays",
        side_depth: SideDepthConfig | None = GO1_SIDE_DEPTH,
    ) -> None:
        if fidelity not in FIDELITIES:
            raise ValueError(f"fidelity must be one of {FIDELITIES}, got {fidelity!r}")
        if depth_sampling not in DEPTH_SAMPLINGS:
            raise ValueError(f"depth_sampling must be one of {DEPTH_SAMPLINGS}, got {depth_sampling!r}")
        self._depth_sampling: DepthSampling = depth_sampling
        require_finite("start_pose", [start_pose.x_m, start_pose.y_m, start_pose.yaw_rad])
        require_finite("clearance_m", clearance_m)
        if clearance_m < 0.0:
            raise InvalidInputError(f"clearance_m must be >= 0, got {clearance_m}")
        self._fidelity: Fidelity = fidelity
        self._scene = scene
        self._camera_config = camera or CameraConfig()
        self._clearance_m = float(clearance_m)
        self._limits = motion_limits or BaseMotionLimits()
        self._imu_noise = imu_noise or ImuNoise()
        self._rng = np.random.default_rng(seed)
        self._spec = load_go1_spec()

        self.model = mujoco.MjModel.from_xml_string(
            build_mjcf(scene, fidelity=fidelity, camera=self._camera_config)
        )
        if physics_dt_s is not None:
            require_finite("physics_dt_s", physics_dt_s)
            if physics_dt_s <= 0.0:
                raise InvalidInputError(f"physics_dt_s must be > 0, got {physics_dt_s}")
            self.model.opt.timestep = physics_dt_s
        self.physics_dt_s = float(self.model.opt.timestep)
        require_finite("control_dt_s", control_dt_s)
        substeps = control_dt_s / self.physics_dt_s
        if control_dt_s <= 0.0 or round(substeps) < 1 or abs(substeps - round(substeps)) > 1e-6:
            raise InvalidInputError(
                f"control_dt_s={control_dt_s} must be a positive whole multiple of physics_dt_s={self.physics_dt_s}"
            )
        self.control_dt_s = float(control_dt_s)
        self._substeps = int(round(substeps))
        self.data = mujoco.MjData(self.model)

        self._trunk_body = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, TRUNK_BODY_NAME)
        self._robot_geoms = robot_geom_ids(self.model)
        object_of_geom = geom_object_ids(self.model)
        obstacle_ids = {obj.object_id for obj in scene.objects if obj.is_obstacle}
        self._obstacle_geoms = np.array(
            [g for g in range(self.model.ngeom) if int(object_of_geom[g]) in obstacle_ids], dtype=np.int32
        )
        self._object_of_geom = object_of_geom
        self._camera: RgbdCamera | None = None
        self._side_depth = (
            None
            if side_depth is None
            else SideDepthCameras(
                self.model, config=side_depth, exclude_body_id=self._trunk_body, robot_geoms=self._robot_geoms
            )
        )
        self._optical_to_base = self._camera_config.optical_to_base()
        # Kinematic: x, y, yaw; dynamic: the free joint's position and quaternion.
        self._pose_coordinates = 3 if fidelity == "kinematic" else 7
        self._trunk_height_m = float(self.model.body_pos[self._trunk_body, 2])
        self._transform_cache: tuple[bytes, FloatArray] | None = None

        self._command = Twist.zero()
        self._base_velocity = np.zeros(3)  # kinematic (vx, vy, wz) in the body frame
        self._base_accel = np.zeros(3)  # kinematic (ax, ay, yaw accel) in the body frame
        self._joint_targets = self._spec.standing_pose_rad.copy()
        self._fallen = False
        self._events: list[ContactEvent] = []
        self._in_collision: set[int] = set()
        self._in_clearance: set[int] = set()
        self._min_clearance_m = math.inf
        self._least_clearance_m = math.inf
        self._clock_target_s = 0.0
        self._imu_sample: tuple[float, ImuReading] | None = None

        self._place_robot(start_pose)
        self._obstacle_aabb_min, self._obstacle_aabb_max = self._obstacle_world_aabbs()
        self._robot_radius_m = self._robot_bounding_radius()
        self._check_safety()

    # ------------------------------------------------------------------ setup

    def _place_robot(self, pose: Pose2D) -> None:
        if self._fidelity == "kinematic":
            self.data.qpos[:3] = [pose.x_m, pose.y_m, pose.yaw_rad]
            mujoco.mj_kinematics(self.model, self.data)
            return
        self.data.qpos[:3] = [pose.x_m, pose.y_m, self._spec.home_trunk_height_m]
        self.data.qpos[3:7] = _yaw_quat(pose.yaw_rad)
        self.data.qpos[7 : 7 + NUM_JOINTS] = self._spec.standing_pose_rad
        self.data.ctrl[:] = self._joint_targets
        # Let the PD sag settle, then put the base back where it was asked to start: the clock starts at
        # 0 with the robot standing still, not dropping onto its legs.
        for _ in range(int(round(SETTLE_S / self.physics_dt_s))):
            mujoco.mj_step(self.model, self.data)
        self.data.qpos[0] += pose.x_m - self.data.qpos[0]
        self.data.qpos[1] += pose.y_m - self.data.qpos[1]
        self.data.qvel[:] = 0.0
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)

    def _obstacle_world_aabbs(self) -> tuple[FloatArray, FloatArray]:
        """World AABBs of the static obstacle geoms (they never move, so once)."""
        geoms = self._obstacle_geoms
        if geoms.size == 0:
            return np.zeros((0, 3)), np.zeros((0, 3))
        local = self.model.geom_aabb[geoms]
        rotation = self.data.geom_xmat[geoms].reshape(-1, 3, 3)
        centre = self.data.geom_xpos[geoms] + np.einsum("nij,nj->ni", rotation, local[:, :3])
        half = np.einsum("nij,nj->ni", np.abs(rotation), local[:, 3:])
        return centre - half, centre + half

    def _robot_bounding_radius(self) -> float:
        trunk = self.data.xpos[self._trunk_body]
        reach = np.linalg.norm(self.data.geom_xpos[self._robot_geoms] - trunk, axis=1)
        return float(np.max(reach + self.model.geom_rbound[self._robot_geoms]))

    # ------------------------------------------------------------------ safety

    def _obstacle_distances(self) -> dict[int, float]:
        """Smallest signed distance robot -> each scene object within the sensing range, by object id."""
        sense_m = self._clearance_m + CLEARANCE_SENSE_MARGIN_M
        if self._obstacle_geoms.size == 0:
            return {}
        trunk = self.data.xpos[self._trunk_body]
        gap = np.maximum(self._obstacle_aabb_min - trunk, 0.0) + np.maximum(
            trunk - self._obstacle_aabb_max, 0.0
        )
        near = self._obstacle_geoms[np.linalg.norm(gap, axis=1) <= self._robot_radius_m + sense_m]
        distances: dict[int, float] = {}
        for obstacle in near:
            object_id = int(self._object_of_geom[obstacle])
            for robot_geom in self._robot_geoms:
                distance = mujoco.mj_geomDistance(
                    self.model, self.data, int(robot_geom), int(obstacle), sense_m, None
                )
                if distance < sense_m and distance < distances.get(object_id, math.inf):
                    distances[object_id] = float(distance)
        return distances

    def _record(self, distances: dict[int, float]) -> None:
        now = self.now_s()
        colliding = {
            oid
            for oid, dist in distances.items()
            if dist <= 0.0 or (oid in self._in_collision and dist < EVENT_RELEASE_MARGIN_M)
        }
        close = {
            oid
            for oid, dist in distances.items()
            if dist < self._clearance_m
            or (oid in self._in_clearance and dist < self._clearance_m + EVENT_RELEASE_MARGIN_M)
        }
        for object_id in sorted(close - self._in_clearance):
            self._events.append(ContactEvent(now, object_id, distances[object_id], "clearance"))
        for object_id in sorted(colliding - self._in_collision):
            self._events.append(ContactEvent(now, object_id, distances[object_id], "collision"))
        self._in_collision, self._in_clearance = colliding, close

    def _check_safety(
        self, blocked: dict[int, float] | None = None, *, distances: dict[int, float] | None = None
    ) -> None:
        """Record contact events; ``distances``: those of the current configuration, when already known."""
        if distances is None:
            distances = self._obstacle_distances()
        self._min_clearance_m = min(distances.values(), default=math.inf)
        if blocked:
            distances = dict(distances)  # the caller's stay as measured
            # The kinematic base stopped short of these objects: it touched them.
            for object_id, distance in blocked.items():
                distances[object_id] = min(distance, distances.get(object_id, math.inf))
        self._least_clearance_m = min(self._least_clearance_m, min(distances.values(), default=math.inf))
        self._record(distances)
        if self._fidelity == "dynamic":
            roll, pitch = _roll_pitch_from_quat(self.data.qpos[3:7])
            tipped = max(abs(roll), abs(pitch)) > self._spec.fall_tilt_rad
            low = self.data.qpos[2] < self._spec.fall_trunk_height_m
            self._fallen = bool(self._fallen or tipped or low)

    # ------------------------------------------------------------------ stepping

    def _kinematic_step(self, dt_s: float) -> None:
        target = self._limits.clamp(self._command)
        max_change = self._limits.accel_limits() * dt_s
        previous_velocity = self._base_velocity
        velocity = previous_velocity + np.clip(target - previous_velocity, -max_change, max_change)
        x, y, yaw = (float(v) for v in self.data.qpos[:3])
        mid_yaw = yaw + 0.5 * velocity[2] * dt_s
        cos_yaw, sin_yaw = math.cos(mid_yaw), math.sin(mid_yaw)
        proposed = np.array(
            [
                x + (cos_yaw * velocity[0] - sin_yaw * velocity[1]) * dt_s,
                y + (sin_yaw * velocity[0] + cos_yaw * velocity[1]) * dt_s,
                wrap_angle(yaw + velocity[2] * dt_s),
            ]
        )
        before = self._min_clearance_m
        # A move into penetration is refused, but the base slides: when the whole move is refused, its
        # translation alone and then its rotation alone are tried, so a base touching an obstacle can
        # still turn or back away from it (a legged robot side-steps; a refused move would otherwise
        # leave it pinned). A base that already penetrates (a bad start pose) may move as long as it does
        # not go deeper. The tolerance absorbs the distance solver's round-off at contact.
        attempts = (
            (proposed, velocity),
            (np.array([proposed[0], proposed[1], yaw]), np.array([velocity[0], velocity[1], 0.0])),
            (np.array([x, y, proposed[2]]), np.array([0.0, 0.0, velocity[2]])),
        )
        refused: dict[int, float] | None = None  # distances of the refused full move, for the event
        accepted = False
        for k, (pose, moved_velocity) in enumerate(attempts):
            if k > 0 and not np.any(moved_velocity):
                continue
            self.data.qpos[:3] = pose
            mujoco.mj_kinematics(self.model, self.data)
            distances = self._obstacle_distances()
            after = min(distances.values(), default=math.inf)
            if not (after < -_CONTACT_TOLERANCE_M and after < before - 1e-9):
                accepted = True
                velocity = moved_velocity
                break
            if refused is None:
                refused = distances
        if not accepted:
            self.data.qpos[:3] = [x, y, yaw]
            mujoco.mj_kinematics(self.model, self.data)
            distances = self._obstacle_distances()
            velocity = np.zeros(3)
        self._base_accel = (velocity - previous_velocity) / dt_s
        self._base_velocity = velocity
        self.data.time += dt_s
        self._check_safety(
            {oid: d for oid, d in refused.items() if d <= 0.0} if refused is not None else None,
            distances=distances,
        )

    def _dynamic_step(self, dt_s: float) -> None:
        self.data.ctrl[:] = self._joint_targets
        for _ in range(max(1, int(round(dt_s / self.physics_dt_s)))):
            mujoco.mj_step(self.model, self.data)
        self._check_safety()

    def snapshot(self) -> KinematicSnapshot:
        """The state a kinematic step changes (kinematic fidelity only), for :meth:`restore`.

        The ROS 2 bridge steps ahead speculatively while the executive ticks and takes the step back when
        the executive asks for another (sims/ros2_bridge.py). Reads only: no noise is drawn.

        Raises:
            InvalidInputError: in dynamic fidelity (the physics and the gait hold more state than this).
        """
        if self._fidelity != "kinematic":
            raise InvalidInputError(
                "snapshot() is kinematic-only: a dynamic step changes the whole physics state"
            )
        return KinematicSnapshot(
            qpos=self.data.qpos.copy(),
            time_s=float(self.data.time),
            clock_target_s=self._clock_target_s,
            command=self._command,
            base_velocity=self._base_velocity,  # replaced by each step, never written in place
            base_accel=self._base_accel,
            min_clearance_m=self._min_clearance_m,
            least_clearance_m=self._least_clearance_m,
            events=len(self._events),
            in_collision=frozenset(self._in_collision),
            in_clearance=frozenset(self._in_clearance),
            imu_sample=self._imu_sample,
            transform_cache=self._transform_cache,
        )

    def restore(self, snapshot: KinematicSnapshot) -> None:
        """Back to ``snapshot`` (taken by this robot since its last :meth:`teleport`): the pose, the clock,
        the velocities, the safety record (events after it dropped) and every body and geom pose derived
        from them, to the bit."""
        if self._fidelity != "kinematic":
            raise InvalidInputError("restore() is kinematic-only")
        if snapshot.events > len(self._events):
            raise InvalidInputError("restore(): the snapshot is newer than this robot's event log")
        self.data.qpos[:] = snapshot.qpos
        self.data.time = snapshot.time_s
        mujoco.mj_kinematics(self.model, self.data)
        self._clock_target_s = snapshot.clock_target_s
        self._command = snapshot.command
        self._base_velocity = snapshot.base_velocity
        self._base_accel = snapshot.base_accel
        self._min_clearance_m = snapshot.min_clearance_m
        self._least_clearance_m = snapshot.least_clearance_m
        del self._events[snapshot.events :]
        self._in_collision = set(snapshot.in_collision)
        self._in_clearance = set(snapshot.in_clearance)
        self._imu_sample = snapshot.imu_sample
        self._transform_cache = snapshot.transform_cache

    @contextlib.contextmanager
    def viewed_at(self, snapshot: KinematicSnapshot) -> Iterator[None]:
        """Inside: the cameras see the world of ``snapshot`` (its pose and clock); after: back to now, to
        the bit. Unlike :meth:`restore`, the safety record, the events and the velocities stay as they are
        now: the ROS 2 bridge renders the instant the executive asked for between the steps it has
        taken ahead of it, and keeps those steps (sims/ros2_bridge.py)."""
        if self._fidelity != "kinematic":
            raise InvalidInputError("viewed_at() is kinematic-only")
        qpos, time_s = self.data.qpos.copy(), float(self.data.time)
        self.data.qpos[:] = snapshot.qpos
        self.data.time = snapshot.time_s
        mujoco.mj_kinematics(self.model, self.data)
        try:
            yield
        finally:
            self.data.qpos[:] = qpos
            self.data.time = time_s
            mujoco.mj_kinematics(self.model, self.data)

    def advance(self, duration_s: float) -> None:
        """Step the simulation by ``duration_s`` (rounded to whole physics steps), one control period at a time."""
        require_finite("duration_s", duration_s)
        if duration_s < 0.0:
            raise InvalidInputError(f"duration_s must be >= 0, got {duration_s}")
        # A target clock that accumulates the requested durations keeps many short advances from drifting.
        self._clock_target_s += duration_s
        step = self._kinematic_step if self._fidelity == "kinematic" else self._dynamic_step
        while self._clock_target_s - self.data.time > 0.5 * self.physics_dt_s:
            remaining = self._clock_target_s - self.data.time
            period = min(self.control_dt_s, remaining)
            if self._fidelity == "dynamic":
                period = max(1, round(period / self.physics_dt_s)) * self.physics_dt_s
            step(period)

    # ------------------------------------------------------------------ Robot interface

    @property
    def fidelity(self) -> Fidelity:
        return self._fidelity

    @property
    def commanded_twist(self) -> Twist:
        """The last twist passed to :meth:`command_twist` (read by the gait in dynamic fidelity)."""
        return self._command

    def now_s(self) -> float:
        return float(self.data.time)

    def base_odometry(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """The trunk's pose in the world as a robot's odometry reports it: position (m) and unit
        quaternion (x, y, z, w), read from the simulator's state.

        :meth:`base_pose` and each observation's ``camera_to_world`` derive from it with the conversions
        the ROS 2 backend applies to ``/odom`` (``robots.ros2_messages.pose_to_transform``, then the
        camera's mount), and the simulation bridge publishes it as ``/odom``: a mission sees the same
        pose, to the bit, in process and over ROS 2.
        """
        qpos = self.data.qpos
        if self._fidelity == "kinematic":
            x, y, yaw = (float(v) for v in qpos[:3])
            half = 0.5 * yaw
            return (x, y, self._trunk_height_m), (0.0, 0.0, math.sin(half), math.cos(half))
        w, qx, qy, qz = (float(v) for v in qpos[3:7])
        return (float(qpos[0]), float(qpos[1]), float(qpos[2])), (qx, qy, qz, w)

    def _base_transform(self) -> FloatArray:
        # base_pose is read several times a tick: convert once per state (qpos bytes as the key).
        key = self.data.qpos[: self._pose_coordinates].tobytes()
        if self._transform_cache is None or self._transform_cache[0] != key:
            self._transform_cache = (key, pose_to_transform(*self.base_odometry()))
        return self._transform_cache[1]

    def base_pose(self) -> Pose2D:
        """The planar pose of :meth:`base_odometry` (x, y and the heading of its rotation)."""
        return pose2d_of(self._base_transform())

    def base_twist(self) -> Twist:
        if self._fidelity == "kinematic":
            vx, vy, wz = (float(v) for v in self._base_velocity)
            return Twist(vx, vy, wz)
        rotation = self.data.xmat[self._trunk_body].reshape(3, 3)
        linear_body = rotation.T @ self.data.qvel[:3]
        return Twist(float(linear_body[0]), float(linear_body[1]), float(self.data.qvel[5]))

    def joint_state(self) -> JointState:
        if self._fidelity == "kinematic":
            return JointState(position_rad=np.zeros(NUM_JOINTS), velocity_radps=np.zeros(NUM_JOINTS))
        return JointState(
            position_rad=self.data.qpos[7 : 7 + NUM_JOINTS].copy(),
            velocity_radps=self.data.qvel[6 : 6 + NUM_JOINTS].copy(),
        )

    def imu(self) -> ImuReading:
        """The trunk IMU with its noise; one sample per instant, so readers at the same time agree.

        A second read at the same simulated time (a sensor-health guard beside the gait) returns the same
        sample and draws no new noise, so the gait sees the readings it would see alone.
        """
        now = float(self.data.time)
        if self._imu_sample is not None and self._imu_sample[0] == now:
            return _copy_imu(self._imu_sample[1])
        reading = self._sample_imu()
        self._imu_sample = (now, reading)
        return _copy_imu(reading)

    def _sample_imu(self) -> ImuReading:
        if self._fidelity == "kinematic":
            vx, vy, wz = self._base_velocity
            ax, ay, _ = self._base_accel
            gyro = np.array([0.0, 0.0, wz])
            # Body-frame acceleration of a planar rigid body: dv/dt + w x v, plus the reaction to gravity.
            accel = np.array([ax - wz * vy, ay + wz * vx, GRAVITY_MPS2])
            orientation = _yaw_quat(float(self.data.qpos[2]))
        else:
            gyro = self._sensor(IMU_GYRO_SENSOR).copy()
            accel = self._sensor(IMU_ACCELEROMETER_SENSOR).copy()
            orientation = self._sensor(IMU_ORIENTATION_SENSOR).copy()
        gyro += self._rng.normal(0.0, self._imu_noise.gyro_std_radps, 3)
        accel += self._rng.normal(0.0, self._imu_noise.accel_std_mps2, 3)
        return ImuReading(
            angular_velocity_radps=gyro, linear_acceleration_mps2=accel, orientation_wxyz=orientation
        )

    def _sensor(self, name: str) -> FloatArray:
        return np.asarray(self.data.sensor(name).data, dtype=float)

    def command_twist(self, twist: Twist) -> None:
        require_finite("twist", [twist.linear_x_mps, twist.linear_y_mps, twist.angular_z_radps])
        self._command = twist

    def command_joint_targets(self, targets_rad: npt.NDArray[np.float64]) -> None:
        """Set the 12 actuator targets (clipped to the joint ranges).

        In kinematic fidelity the legs are not simulated: the targets are validated and kept, and the base
        keeps following :meth:`command_twist`.
        """
        targets = np.asarray(targets_rad, dtype=float)
        if targets.shape != (NUM_JOINTS,):
            raise InvalidInputError(f"targets_rad must have shape ({NUM_JOINTS},), got {targets.shape}")
        require_finite("targets_rad", targets)
        self._joint_targets = np.clip(targets, self._spec.joint_lower_rad, self._spec.joint_upper_rad)
        if self._fidelity == "dynamic":
            self.data.ctrl[:] = self._joint_targets

    def stop(self) -> None:
        """Zero the twist (the kinematic base decelerates at its limit) and hold the standing pose."""
        self._command = Twist.zero()
        self._joint_targets = self._spec.standing_pose_rad.copy()
        if self._fidelity == "dynamic":
            self.data.ctrl[:] = self._joint_targets

    def safety(self) -> SafetyState:
        return SafetyState(
            fallen=self._fallen,
            events=list(self._events),
            min_clearance_m=self._min_clearance_m,
            least_clearance_m=self._least_clearance_m,
        )

    def _ready_camera(self) -> RgbdCamera:
        if self._camera is None:
            self._camera = RgbdCamera(
                self.model,
                config=self._camera_config,
                camera_name=CAMERA_NAME,
                geom_object_ids=self._object_of_geom,
            )
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        return self._camera

    def _camera_to_world(self) -> FloatArray:
        """T_world<-optical as a robot reports it: odometry times the camera's mount (the render's own
        pose, MuJoCo's compiled camera, agrees to rounding: the MJCF carries the mount's every bit)."""
        return self._base_transform() @ self._optical_to_base

    def observe(self) -> Observation:
        """Render the head camera now (RGB, depth, segmentation) with the pose it was taken at."""
        camera = self._ready_camera()
        frame = camera.render(self.data)
        return Observation(
            rgb=frame.rgb,
            depth_m=frame.depth_m,
            intrinsics=camera.intrinsics,
            camera_to_world=self._camera_to_world(),
            base_pose=self.base_pose(),
            stamp_s=self.now_s(),
            segmentation=frame.segmentation,
        )

    def observe_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> Observation:
        """Depth only, no colour, no segmentation: ``rgb`` is ``(0, 0, 3)``.

        With ``pixel_grids`` and ``depth_sampling="rays"`` only those pixels are measured, by ray casting,
        and the others are NaN; otherwise one GL depth pass renders the whole frame.
        """
        camera = self._ready_camera()
        if pixel_grids is not None and self._depth_sampling == "rays":
            depth = camera.ray_depth(self.data, pixel_grids=pixel_grids, exclude_body_id=self._trunk_body)
        else:
            depth = camera.render_depth(self.data)
        return Observation(
            rgb=np.empty((0, 0, 3), dtype=np.uint8),
            depth_m=depth,
            intrinsics=camera.intrinsics,
            camera_to_world=self._camera_to_world(),
            base_pose=self.base_pose(),
            stamp_s=self.now_s(),
            segmentation=None,
        )

    def observe_side_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> list[Observation]:
        """The flank cameras' depth (``robots.side_depth``), ray cast at ``pixel_grids`` (all pixels when
        None); none when the robot was built with ``side_depth=None``."""
        if self._side_depth is None:
            return []
        mujoco.mj_kinematics(self.model, self.data)
        grids = pixel_grids if pixel_grids is not None else [PixelGrid(stride=1)]
        frames = self._side_depth.measure(self.data, self._base_transform(), pixel_grids=grids)
        pose, stamp = self.base_pose(), self.now_s()
        return [
            Observation(
                rgb=np.empty((0, 0, 3), dtype=np.uint8),
                depth_m=depth,
                intrinsics=self._side_depth.intrinsics,
                camera_to_world=camera_to_world,
                base_pose=pose,
                stamp_s=stamp,
                segmentation=None,
            )
            for depth, camera_to_world in frames.values()
        ]

    def teleport(self, pose: Pose2D) -> None:
        """Move the base to ``pose`` at once, at rest (for view sampling and tests; not part of ``Robot``).

        The clock and the event log are kept; safety is re-checked at the new pose. The dynamic robot is
        re-placed standing and settles again (``SETTLE_S`` of physics, clock restored).
        """
        require_finite("pose", [pose.x_m, pose.y_m, pose.yaw_rad])
        now = self.data.time
        self._imu_sample = None  # the base moved: a new sample, even at the same instant
        self._base_velocity = np.zeros(3)
        self._base_accel = np.zeros(3)
        if self._fidelity == "dynamic":
            self.data.qvel[:] = 0.0
            self._joint_targets = self._spec.standing_pose_rad.copy()
        self._place_robot(pose)
        self.data.time = now
        self._check_safety()

    @property
    def camera(self) -> RgbdCamera | None:
        """The head camera once :meth:`observe` has created it (for benchmarks)."""
        return self._camera

    def close(self) -> None:
        if self._camera is not None:
            self._camera.close()
            self._camera = None


__all__ = ["BaseMotionLimits", "ImuNoise", "KinematicSnapshot", "MujocoRobot"]
