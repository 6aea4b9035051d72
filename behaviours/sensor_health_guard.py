"""SensorHealthGuard: hold the robot still while a needed sensor is silent or insane; end the mission when
one stays lost or lies.

Semantics: every tick, on the robot clock, it checks

- the clock: it must not run backwards, nor leap more than ``max_clock_step_s`` in one tick;
- odometry: its stamp (``Robot.sensor_stamps``) no older than ``odometry_deadline_s``, a finite pose, and
  a pose that moves as the measured twist says (a step more than ``max_jump_m`` / ``max_jump_deg`` off the
  twist in one tick is a jump, more than ``max_drift_m`` / ``max_drift_deg`` over ``drift_window_s`` a
  drift);
- the IMU, only when a gait policy walks the robot (nothing else reads it): its stamp no older than
  ``imu_deadline_s``, finite readings within ``max_gyro_radps`` and ``max_accel_mps2``;
- the camera: its stamp no older than ``camera_deadline_s`` and, every ``camera_check_period_s`` while the
  robot moves or is told to, a coarse depth sample (:data:`CHECK_GRID`) whose own stamp is no older than
  that (a frozen driver re-sends old frames while its topic looks alive) and whose measured pixels are
  numbers (at most ``max_nonfinite_fraction`` NaN or inf).

- RUNNING, "sensors healthy": every needed sensor (camera and odometry; the IMU with a gait policy) passes.
- RUNNING, "holding still": a needed sensor fails a check, or passed again less than ``recover_after_s``
  ago. The guard overwrites ``cmd_twist`` with zero before the gait reads it (the stamp is left alone, so
  the gait's watchdog still sees the command's age): the robot stands still and the rest of the tree
  carries on. A ``sensor_unhealthy`` event (with the reason) and a ``sensor_recovered`` event are logged
  as a sensor's health changes.
- FAILURE, ``sensor_lost: <sensor>`` in ``mission_outcome``: a needed sensor failed for ``lost_after_s``.
- FAILURE, ``sensor_fault: odometry`` / ``sensor_fault: clock``: an odometry jump or drift, or a clock
  jump, at once. The memory and the map are kept in the odometry frame and the timers on the clock, and
  nothing can tell which part of them is still right.
- In both failures the robot is stopped and a ``sensor_stop`` event logged.
- Halted: nothing to undo.

Reads ``cmd_twist`` (whether the robot is told to move); writes ``cmd_twist`` (zero, while holding) and
``mission_outcome``.

Example:
    - type: SensorHealthGuard
      name: SensorHealth
      params: {lost_after_s: 5.0, camera_deadline_s: 0.1}
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.types import PixelGrid, Pose2D, Twist

#: The depth pixels the guard samples: every 40th row and column (8 x 6 on the Go1's 320 x 240 camera), which
#: a patch of a tenth of the image covers at least once.
CHECK_GRID = PixelGrid.centred(40)
#: The robot counts as still (no camera sample needed) below these commanded and measured speeds.
STILL_SPEED_MPS = 0.01
STILL_YAW_RATE_RADPS = 0.01
#: A clock step this far below zero is a clock running backwards (s; float round-off is below it).
BACKWARD_TOLERANCE_S = 1e-6
SENSORS = ("camera", "odometry", "imu")


@dataclass
class _Health:
    """One sensor's state: why it is unhealthy (None: healthy), since when, and when it became healthy."""

    problem: str | None = None
    unhealthy_since_s: float = 0.0
    healthy_since_s: float = -math.inf


def _seconds(doc: str, default: float) -> Any:
    return param("float", doc=doc, default=default, gt=0.0)


class SensorHealthGuard(SemExpBehaviour):
    READS = ("cmd_twist",)
    WRITES = ("cmd_twist", "mission_outcome")

    camera_deadline_s: float = _seconds("the newest camera frame may be this old, s", 0.1)
    odometry_deadline_s: float = _seconds("the newest odometry may be this old, s", 0.1)
    imu_deadline_s: float = _seconds("the newest IMU reading may be this old, s", 0.1)
    camera_check_period_s: float = _seconds(
        "a coarse depth sample is checked this often while moving, s", 0.1
    )
    recover_after_s: float = _seconds("a sensor must be healthy this long before the hold ends, s", 0.5)
    lost_after_s: float = _seconds("a needed sensor unhealthy this long ends the mission, s", 5.0)
    max_nonfinite_fraction: float = param(
        "float",
        doc="largest share of sampled depth pixels that may be NaN or inf",
        default=0.05,
        ge=0.0,
        le=1.0,
    )
    max_jump_m: float = _seconds("odometry may move this far from what the twist says in one tick, m", 0.1)
    max_jump_deg: float = _seconds("or turn this far from it, degrees", 5.0)
    drift_window_s: float = _seconds(
        "odometry is compared with the integrated twist over this window, s", 2.0
    )
    max_drift_m: float = _seconds("largest disagreement over the window, m", 0.25)
    max_drift_deg: float = _seconds("largest heading disagreement over the window, degrees", 10.0)
    max_gyro_radps: float = _seconds("largest plausible angular rate, rad/s", 15.0)
    max_accel_mps2: float = _seconds("largest plausible acceleration, m/s^2", 60.0)
    max_clock_step_s: float = _seconds("the clock may leap this far in one tick, s", 1.0)

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.deadline_s = {
            "camera": self.camera_deadline_s,
            "odometry": self.odometry_deadline_s,
            "imu": self.imu_deadline_s,
        }
        self.max_jump_rad = math.radians(self.max_jump_deg)
        self.max_drift_rad = math.radians(self.max_drift_deg)
        self.health = {sensor: _Health() for sensor in SENSORS}
        self._last_clock_s: float | None = None
        self._previous: tuple[float, Pose2D] | None = None  # (clock, pose) at the last tick
        self._window: tuple[float, Pose2D, float, float, float] | None = None  # start, pose, dx, dy, dyaw
        self._camera_due_s = -math.inf
        self._camera_problem: str | None = None
        #: The sensors this mission cannot move without (the IMU only when a gait policy reads it).
        self.needed = (
            ("camera", "odometry", "imu") if self.services.gait is not None else ("camera", "odometry")
        )

    def update(self) -> py_trees.common.Status:
        with self.timed("sensor_health"):
            return self._check()

    def _check(self) -> py_trees.common.Status:
        robot = self.services.robot
        now = self.now_s()
        clock_problem = self._clock_problem(now)
        if clock_problem is not None:
            return self._end("sensor_fault: clock", "clock", clock_problem)
        stamps = robot.sensor_stamps()
        needed = self.needed
        problems = {
            "odometry": self._stale("odometry", now - stamps.odometry_s),
            # The IMU is read only when something reads it (reading a simulated one draws noise).
            "imu": (self._stale("imu", now - stamps.imu_s) or self._imu_problem())
            if "imu" in needed
            else None,
            "camera": self._stale("camera", now - stamps.camera_s) or self._camera_sample_problem(now),
        }
        odometry_fault = None
        if problems["odometry"] is None:
            problems["odometry"], odometry_fault = self._odometry_problems(now)
        else:
            self._previous, self._window = None, None
        if odometry_fault is not None:
            return self._end("sensor_fault: odometry", "odometry", odometry_fault)
        for sensor, problem in problems.items():
            self._track(sensor, problem, now)
        lost = [
            s
            for s in self.needed
            if self.health[s].problem is not None
            and now - self.health[s].unhealthy_since_s >= self.lost_after_s
        ]
        if lost:
            return self._end(f"sensor_lost: {lost[0]}", lost[0], str(self.health[lost[0]].problem))
        holding = [s for s in self.needed if not self._settled(s, now)]
        if holding:
            self.write("cmd_twist", Twist.zero())
            self.feedback_message = "holding still: " + ", ".join(
                f"{s} {self.health[s].problem or 'recovering'}" for s in holding
            )
        else:
            self.feedback_message = "sensors healthy"
        return py_trees.common.Status.RUNNING

    # -- bookkeeping ----------------------------------------------------------------------------------

    def _track(self, sensor: str, problem: str | None, now: float) -> None:
        health = self.health[sensor]
        if problem is not None and health.problem is None:
            health.unhealthy_since_s = now
            self.services.log_event(
                "sensor_unhealthy", sensor=sensor, reason=problem, needed=sensor in self.needed
            )
        elif problem is None and health.problem is not None:
            health.healthy_since_s = now
            self.services.log_event(
                "sensor_recovered", sensor=sensor, after_s=round(now - health.unhealthy_since_s, 3)
            )
        health.problem = problem

    def _settled(self, sensor: str, now: float) -> bool:
        health = self.health[sensor]
        return health.problem is None and now - health.healthy_since_s >= self.recover_after_s

    def _end(self, outcome: str, sensor: str, reason: str) -> py_trees.common.Status:
        self.services.robot.stop()
        self.write("cmd_twist", Twist.zero())
        self.write("mission_outcome", outcome)
        self.services.log_event("sensor_stop", sensor=sensor, reason=reason, outcome=outcome)
        self.feedback_message = f"{outcome}: {reason}"
        return py_trees.common.Status.FAILURE

    def _stale(self, sensor: str, age_s: float) -> str | None:
        if not math.isfinite(age_s):
            return "no stamp"
        return f"nothing new for {age_s:.2f} s" if age_s > self.deadline_s[sensor] else None

    # -- the checks -----------------------------------------------------------------------------------

    def _clock_problem(self, now: float) -> str | None:
        if not math.isfinite(now):
            return f"clock reads {now!r}"
        last, self._last_clock_s = self._last_clock_s, now
        if last is not None:
            step = now - last
            if step < -BACKWARD_TOLERANCE_S or step > self.max_clock_step_s:
                return f"clock jumped {step:+.3f} s in one tick"
        return None

    def _imu_problem(self) -> str | None:
        reading = self.services.robot.imu()
        rate = math.hypot(*(float(v) for v in reading.angular_velocity_radps))
        acceleration = math.hypot(*(float(v) for v in reading.linear_acceleration_mps2))
        if not (math.isfinite(rate) and math.isfinite(acceleration)):
            return "reading is not a number"
        if rate > self.max_gyro_radps:
            return f"angular rate {rate:.1f} rad/s"
        if acceleration > self.max_accel_mps2:
            return f"acceleration {acceleration:.1f} m/s^2"
        return None

    def _still(self) -> bool:
        """Whether the robot neither moves nor is told to (then a stale camera cannot make it collide)."""
        command = self.read("cmd_twist", Twist.zero())
        twist = self.services.robot.base_twist()
        return (
            all(
                abs(v) < STILL_SPEED_MPS
                for v in (
                    command.linear_x_mps,
                    command.linear_y_mps,
                    twist.linear_x_mps,
                    twist.linear_y_mps,
                )
            )
            and max(abs(command.angular_z_radps), abs(twist.angular_z_radps)) < STILL_YAW_RATE_RADPS
        )

    def _camera_sample_problem(self, now: float) -> str | None:
        """Check a coarse depth sample every ``camera_check_period_s`` while the robot moves or is told to
        (the first tick of a new command is checked before the gait sees it); keep the last verdict
        between, and while the robot stands still."""
        if now < self._camera_due_s or (self._camera_problem is None and self._still()):
            return self._camera_problem
        self._camera_due_s = now + self.camera_check_period_s
        frame = self.services.robot.observe_depth(pixel_grids=[CHECK_GRID])
        problem = None
        age = now - frame.stamp_s
        if not math.isfinite(age) or age > self.deadline_s["camera"]:
            problem = f"frame {age:.2f} s old"
        else:
            depth = np.asarray(frame.depth_m)
            sample = depth[np.ix_(CHECK_GRID.indices(depth.shape[0]), CHECK_GRID.indices(depth.shape[1]))]
            share = float(np.count_nonzero(~np.isfinite(sample))) / max(sample.size, 1)
            if sample.size == 0 or share > self.max_nonfinite_fraction:
                problem = f"depth not a number at {100 * share:.0f} % of pixels"
        self._camera_problem = problem
        return problem

    def _odometry_problems(self, now: float) -> tuple[str | None, str | None]:
        """``(problem, fault)``: a pose that is not a number (problem), or one that jumped or drifted (fault)."""
        robot = self.services.robot
        pose = robot.base_pose()
        if not all(math.isfinite(v) for v in (pose.x_m, pose.y_m, pose.yaw_rad)):
            self._previous, self._window = None, None
            return "pose is not a number", None
        twist = robot.base_twist()
        previous, self._previous = self._previous, (now, pose)
        if previous is None:
            self._window = (now, pose, 0.0, 0.0, 0.0)
            return None, None
        dt = now - previous[0]
        last = previous[1]
        # The twist is the body-frame velocity over the last step; in the map frame at the last heading:
        c, s = math.cos(last.yaw_rad), math.sin(last.yaw_rad)
        dx = (c * twist.linear_x_mps - s * twist.linear_y_mps) * dt
        dy = (s * twist.linear_x_mps + c * twist.linear_y_mps) * dt
        dyaw = twist.angular_z_radps * dt
        off_m = math.hypot(pose.x_m - last.x_m - dx, pose.y_m - last.y_m - dy)
        off_rad = abs(math.remainder(pose.yaw_rad - last.yaw_rad - dyaw, math.tau))
        if off_m > self.max_jump_m or off_rad > self.max_jump_rad:
            return None, f"pose jumped {off_m:.2f} m, {math.degrees(off_rad):.1f} deg in one tick"
        assert self._window is not None
        start, anchor, sx, sy, syaw = self._window
        sx, sy, syaw = sx + dx, sy + dy, syaw + dyaw
        if now - start >= self.drift_window_s:
            drift_m = math.hypot(pose.x_m - anchor.x_m - sx, pose.y_m - anchor.y_m - sy)
            drift_rad = abs(math.remainder(pose.yaw_rad - anchor.yaw_rad - syaw, math.tau))
            self._window = (now, pose, 0.0, 0.0, 0.0)
            if drift_m > self.max_drift_m or drift_rad > self.max_drift_rad:
                return None, (
                    f"pose drifted {drift_m:.2f} m, {math.degrees(drift_rad):.1f} deg from the twist "
                    f"in {now - start:.1f} s"
                )
        else:
            self._window = (start, anchor, sx, sy, syaw)
        return None, None
