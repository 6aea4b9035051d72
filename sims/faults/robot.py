"""``FaultyRobot``: a :class:`~robots.interface.Robot` decorator that injects the robot-side faults.

It sits between the executive and a backend and changes only what the executive reads and what reaches
the backend, as a failing sensor, driver or link would; the executive gets no other sign of a fault.
Times are robot-clock seconds since the wrapper was built (the mission's start), read from the backend's
own clock, so a clock-jump fault does not move the schedule.

- ``camera_drop``: frame slots fall at the camera's frame rate and each is lost with the given
  probability; a reader gets the newest frame that arrived (its old stamp and pose), and
  :meth:`sensor_stamps` reports that frame's stamp. A frame is captured from the backend when a slot
  arrived since the last one handed out (the backend renders on demand, so "arrived" means "captured
  at the next read").
- ``camera_freeze``: the frame handed out last is handed out again, with its own (old) stamp and pose,
  while :meth:`sensor_stamps` says frames keep arriving (a hung image pipeline re-publishing its last
  buffer): only the frame's own stamp shows that it is stale.
- ``depth_corrupt``: rectangular patches of each frame's depth read 0 or NaN (the flank cameras' too;
  the camera faults above are the head camera's only).
- ``odometry_drop`` / ``imu_drop``: the pose and twist / the IMU reading stop updating, and their stamps
  stay at the fault's start.
- ``odometry_jump``: the odometry frame moves once against the world (a rigid offset about where the
  robot stood when the fault began) and keeps the offset; frames carry poses in the same frame.
- ``odometry_drift``: dead reckoning goes wrong: the true motion is integrated turned by a growing heading
  error, plus a slip, for the fault's duration; the error stays after it (nothing corrects odometry).
- ``imu_spike``: readings carry large spurious rates and accelerations.
- ``commands_ignored``: twists, joint targets and stops are dropped; the robot's own watchdog stops the
  base ``robot_watchdog_s`` after the fault began.
- ``clock_jump``: the clock and every stamp jump by ``jump_s`` and jump back when the fault ends.

For benchmarks the wrapper keeps what the robot was told (:attr:`FaultyRobot.last_twist_received`) and
the backend it wraps (:attr:`FaultyRobot.inner`, the ground truth).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from robots.interface import Fidelity, Robot, SensorStamps
from semexp_bt.core.types import ImuReading, JointState, Observation, PixelGrid, Pose2D, SafetyState, Twist
from sims.faults.spec import (
    CameraDropParams,
    ClockJumpParams,
    CommandsIgnoredParams,
    DepthCorruptParams,
    FaultSpec,
    ImuSpikeParams,
    OdometryDriftParams,
    OdometryJumpParams,
)

_STAMP_EPS_S = 1e-9


def _planar(dx_m: float, dy_m: float, dyaw_rad: float, pivot: Pose2D) -> npt.NDArray[np.float64]:
    """3x3 transform: rotate by ``dyaw_rad`` about the pivot's position, then translate by (dx, dy)."""
    c, s = math.cos(dyaw_rad), math.sin(dyaw_rad)
    px, py = pivot.x_m, pivot.y_m
    return np.array(
        [[c, -s, px - c * px + s * py + dx_m], [s, c, py - s * px - c * py + dy_m], [0.0, 0.0, 1.0]]
    )


def _lift(planar: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The 4x4 homogeneous transform of a 3x3 planar one (about the z axis)."""
    out = np.eye(4)
    out[:2, :2] = planar[:2, :2]
    out[:2, 3] = planar[:2, 2]
    return out


class FaultyRobot(Robot):
    """A robot whose sensors, commands and clock fail as a list of faults says.

    Args:
        inner: the backend.
        faults: the faults (only the robot-side ones are used).
        seed: seeds dropped frame slots, patch positions and spikes.
    """

    def __init__(self, inner: Robot, faults: Sequence[FaultSpec], *, seed: int) -> None:
        self.inner = inner
        self.faults = tuple(f for f in faults if f.kind.target == "robot")
        self._seed = int(seed)
        self._t0 = inner.now_s()
        self._rng = np.random.default_rng([self._seed, 1])
        self._frames: dict[str, Observation] = {}  # "full" / "depth" -> the raw frame last handed out
        self._pivots: dict[int, Pose2D] = {}  # odometry jump index -> true pose when it began
        self._drift: dict[int, tuple[float, Pose2D, Pose2D]] = {}  # drift index -> (elapsed, true, reported)
        self._last_pose: Pose2D | None = None
        self._last_twist: Twist | None = None
        self._last_imu: ImuReading | None = None
        self._watchdog_fired: set[int] = set()
        #: The last twist the executive sent, accepted or not (benchmarks read it).
        self.last_twist_received: Twist = Twist.zero()

    # ------------------------------------------------------------------ schedule

    def elapsed_s(self) -> float:
        """Robot-clock seconds since the mission started, on the backend's clock (no clock fault)."""
        return self.inner.now_s() - self._t0

    def _active(self, name: str) -> list[tuple[int, FaultSpec]]:
        elapsed = self.elapsed_s()
        return [(i, f) for i, f in enumerate(self.faults) if f.fault_class == name and f.active(elapsed)]

    def _clock_offset_s(self) -> float:
        return sum(
            float(f.params.jump_s)
            for _, f in self._active("clock_jump")
            if isinstance(f.params, ClockJumpParams)
        )

    # ------------------------------------------------------------------ time

    def now_s(self) -> float:
        return self.inner.now_s() + self._clock_offset_s()

    def advance(self, duration_s: float) -> None:
        self._run_watchdog()
        self.inner.advance(duration_s)
        self._run_watchdog()

    def _run_watchdog(self) -> None:
        for index, fault in self._active("commands_ignored"):
            params = fault.params
            assert isinstance(params, CommandsIgnoredParams)
            if (
                index not in self._watchdog_fired
                and self.elapsed_s() >= fault.start_s + params.robot_watchdog_s
            ):
                self._watchdog_fired.add(index)
                self.inner.stop()

    # ------------------------------------------------------------------ odometry

    def _odometry_offset(self) -> npt.NDArray[np.float64] | None:
        """The odometry frame's offset against the world now (3x3), or None when no odometry fault began."""
        elapsed = self.elapsed_s()
        offset: npt.NDArray[np.float64] | None = None
        true = None
        for index, fault in enumerate(self.faults):
            if fault.fault_class not in ("odometry_jump", "odometry_drift") or elapsed < fault.start_s:
                continue
            true = true or self.inner.base_pose()
            params = fault.params
            if isinstance(params, OdometryJumpParams):
                pivot = self._pivots.setdefault(index, true)
                step = _planar(params.dx_m, params.dy_m, math.radians(params.dyaw_deg), pivot)
            else:
                assert isinstance(params, OdometryDriftParams)
                step = self._drift_offset(index, fault, params, true, elapsed)
            offset = step if offset is None else step @ offset
        return offset

    def _drift_offset(
        self, index: int, fault: FaultSpec, params: OdometryDriftParams, true: Pose2D, elapsed: float
    ) -> npt.NDArray[np.float64]:
        """Dead reckoning with a drifting heading and a slip: the odometry integrates the true motion turned
        by the heading error, plus the slip, so the pose still agrees with the measured twist up to the
        slip (as a gyro bias would leave it)."""
        start, end = fault.start_s, fault.end_s
        t_prev, true_prev, reported = self._drift.get(index, (start, true, true))
        tau_prev, tau = min(t_prev, end) - start, min(elapsed, end) - start
        heading = math.radians(params.yaw_degps) * tau
        c, s = math.cos(heading), math.sin(heading)
        dx, dy = true.x_m - true_prev.x_m, true.y_m - true_prev.y_m
        reported = Pose2D(
            reported.x_m + c * dx - s * dy + params.vx_mps * (tau - tau_prev),
            reported.y_m + s * dx + c * dy + params.vy_mps * (tau - tau_prev),
            math.remainder(true.yaw_rad + heading, math.tau),
        )
        self._drift[index] = (elapsed, true, reported)
        origin = Pose2D(0.0, 0.0, 0.0)
        as_true = _planar(true.x_m, true.y_m, true.yaw_rad, origin)
        return _planar(reported.x_m, reported.y_m, reported.yaw_rad, origin) @ np.linalg.inv(as_true)

    def _offset_pose(self, pose: Pose2D, offset: npt.NDArray[np.float64] | None) -> Pose2D:
        if offset is None:
            return pose
        x, y, _ = offset @ np.array([pose.x_m, pose.y_m, 1.0])
        yaw = math.remainder(pose.yaw_rad + math.atan2(offset[1, 0], offset[0, 0]), math.tau)
        return Pose2D(float(x), float(y), yaw)

    def base_pose(self) -> Pose2D:
        if self._active("odometry_drop") and self._last_pose is not None:
            return self._last_pose
        pose = self._offset_pose(self.inner.base_pose(), self._odometry_offset())
        self._last_pose = pose
        return pose

    def base_twist(self) -> Twist:
        if self._active("odometry_drop") and self._last_twist is not None:
            return self._last_twist
        self._last_twist = self.inner.base_twist()
        return self._last_twist

    # ------------------------------------------------------------------ IMU and joints

    def imu(self) -> ImuReading:
        if self._active("imu_drop") and self._last_imu is not None:
            return self._last_imu
        reading = self.inner.imu()
        for _, fault in self._active("imu_spike"):
            params = fault.params
            assert isinstance(params, ImuSpikeParams)
            if self._rng.random() < params.probability:
                gyro_dir, accel_dir = self._rng.normal(size=3), self._rng.normal(size=3)
                reading = ImuReading(
                    angular_velocity_radps=reading.angular_velocity_radps
                    + params.gyro_radps * gyro_dir / max(float(np.linalg.norm(gyro_dir)), 1e-9),
                    linear_acceleration_mps2=reading.linear_acceleration_mps2
                    + params.accel_mps2 * accel_dir / max(float(np.linalg.norm(accel_dir)), 1e-9),
                    orientation_wxyz=reading.orientation_wxyz,
                )
        self._last_imu = reading
        return reading

    def joint_state(self) -> JointState:
        return self.inner.joint_state()

    # ------------------------------------------------------------------ camera

    def _newest_slot_true_s(self) -> float:
        """When (backend clock) the newest frame the camera delivered was taken."""
        now = self.inner.now_s()
        newest = now
        for index, fault in self._active("camera_drop"):
            params = fault.params
            assert isinstance(params, CameraDropParams)
            start = self._t0 + fault.start_s
            rate = params.frame_rate_hz
            if params.drop_probability >= 1.0:
                newest = min(
                    newest, (math.ceil(start * rate - _STAMP_EPS_S) - 1) / rate
                )  # the last slot before it
                continue
            slot = math.floor(now * rate + _STAMP_EPS_S)
            while slot / rate >= start and self._slot_dropped(index, slot, params.drop_probability):
                slot -= 1
            newest = min(newest, slot / rate)
        return newest

    def _slot_dropped(self, index: int, slot: int, probability: float) -> bool:
        return bool(np.random.default_rng([self._seed, 2, index, slot]).random() < probability)

    def _deliver(self, kind: str, capture: Callable[[], Observation]) -> Observation:
        cached = self._frames.get(kind)
        if cached is not None and self._active("camera_freeze"):
            frame = cached  # the driver re-sends its last frame, stamp and all
        elif (
            cached is not None
            and self._active("camera_drop")
            and self._newest_slot_true_s() <= cached.stamp_s + _STAMP_EPS_S
        ):
            frame = cached  # no frame arrived since the one handed out last
        else:
            frame = capture()
            self._frames[kind] = frame
        return self._as_read(frame)

    def _as_read(self, frame: Observation) -> Observation:
        """A raw frame as the executive reads it: corrupted depth, offset poses, offset stamp."""
        offset = self._odometry_offset()
        corrupt = self._active("depth_corrupt")
        clock = self._clock_offset_s()
        if offset is None and not corrupt and clock == 0.0:
            return frame
        depth = frame.depth_m
        for index, fault in corrupt:
            depth = self._corrupted(depth, fault.params, key=(index, round(frame.stamp_s * 1e6)))
        return replace(
            frame,
            depth_m=depth,
            stamp_s=frame.stamp_s + clock,
            base_pose=self._offset_pose(frame.base_pose, offset),
            camera_to_world=frame.camera_to_world
            if offset is None
            else _lift(offset) @ frame.camera_to_world,
        )

    def _corrupted(
        self, depth: npt.NDArray[np.float32], params: DepthCorruptParams, *, key: tuple[int, int]
    ) -> npt.NDArray[np.float32]:
        # Seeded by the frame's stamp: every reader of one frame sees the same patches.
        rng = np.random.default_rng([self._seed, 3, key[0], key[1]])
        out = np.array(depth, dtype=np.float32, copy=True)
        height, width = out.shape
        patch_h = max(1, round(params.patch_size_frac * height))
        patch_w = max(1, round(params.patch_size_frac * width))
        fill = 0.0 if params.value == "zero" else np.nan
        for _ in range(params.patches):
            row = int(rng.integers(0, max(1, height - patch_h + 1)))
            col = int(rng.integers(0, max(1, width - patch_w + 1)))
            out[row : row + patch_h, col : col + patch_w] = fill
        return out

    def observe(self) -> Observation:
        return self._deliver("full", self.inner.observe)

    def observe_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> Observation:
        return self._deliver("depth", lambda: self.inner.observe_depth(pixel_grids=pixel_grids))

    def observe_side_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> list[Observation]:
        """The backend's flank frames as the executive reads them: the odometry, clock and depth faults
        apply (the camera faults are the head camera's)."""
        return [self._as_read(frame) for frame in self.inner.observe_side_depth(pixel_grids=pixel_grids)]

    def sensor_stamps(self) -> SensorStamps:
        stamps = self.inner.sensor_stamps()
        elapsed_at = self._t0
        camera_s = min(stamps.camera_s, self._newest_slot_true_s())
        odometry_s, imu_s = stamps.odometry_s, stamps.imu_s
        for _, fault in self._active("odometry_drop"):
            odometry_s = min(odometry_s, elapsed_at + fault.start_s)
        for _, fault in self._active("imu_drop"):
            imu_s = min(imu_s, elapsed_at + fault.start_s)
        clock = self._clock_offset_s()
        return SensorStamps(camera_s=camera_s + clock, odometry_s=odometry_s + clock, imu_s=imu_s + clock)

    # ------------------------------------------------------------------ commands

    def _commands_lost(self) -> bool:
        return bool(self._active("commands_ignored"))

    def command_twist(self, twist: Twist) -> None:
        self.last_twist_received = twist
        if not self._commands_lost():
            self.inner.command_twist(twist)

    def command_joint_targets(self, targets_rad: npt.NDArray[np.float64]) -> None:
        if not self._commands_lost():
            self.inner.command_joint_targets(targets_rad)

    def stop(self) -> None:
        self.last_twist_received = Twist.zero()
        if not self._commands_lost():
            self.inner.stop()

    # ------------------------------------------------------------------ the rest

    def safety(self) -> SafetyState:
        return self.inner.safety()

    @property
    def fidelity(self) -> Fidelity:
        return self.inner.fidelity

    def close(self) -> None:
        self.inner.close()
