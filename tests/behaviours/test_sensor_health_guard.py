"""SensorHealthGuard alone: a robot told to drive forward every tick, with faults injected between it and
the executive by ``sims.faults.FaultyRobot``.

Each tick the test writes the planner's command (0.5 m/s forward), ticks the guard, and the rig drives the
robot with whatever ``cmd_twist`` the guard left on the board (the gait's part), so a hold shows as the true
robot standing still. Each test prints the behaviour it asserts on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from py_trees.common import Status

from behaviours.sensor_health_guard import SensorHealthGuard
from robots.interface import Robot
from semexp_bt.core.types import Pose2D, Twist
from sims.faults import FaultyRobot, parse_faults
from tests.behaviours.rig import TICK_S, FakeRobot, Rig

FORWARD = Twist(linear_x_mps=0.5)


def drive(rig: Rig, guard: SensorHealthGuard, until_s: float, twist: Twist = FORWARD) -> dict[float, float]:
    """Command ``twist`` and tick until ``until_s`` or the guard ends; the true forward speed (the yaw rate
    for a turn in place) by time."""
    robot = rig.robot
    truth = robot.inner if isinstance(robot, FaultyRobot) else robot
    speeds: dict[float, float] = {}
    while robot.now_s() < until_s - 1e-9:
        rig.set("cmd_twist", twist)
        rig.set("cmd_stamp_s", robot.now_s())
        status = rig.tick(guard)[0]
        measured = truth.base_twist()
        speeds[round(truth.now_s(), 6)] = (
            measured.linear_x_mps if twist.linear_x_mps else measured.angular_z_radps
        )
        if status != Status.RUNNING:
            break
    rig.show(guard)
    return speeds


def guarded(
    make_rig: Callable[..., Rig], *faults: dict[str, Any], **params: Any
) -> tuple[Rig, SensorHealthGuard]:
    """A rig whose robot has ``faults`` injected, and the guard built with ``params``."""
    robot = FaultyRobot(
        FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0)), parse_faults(list(faults), where="test"), seed=0
    )
    rig = make_rig(robot=robot)
    return rig, rig.build(SensorHealthGuard, **params)


def kinds(rig: Rig) -> list[tuple[str, str | None]]:
    return [(e["kind"], e.get("sensor")) for e in rig.services.events]


def test_healthy_sensors_leave_the_command_alone(rig: Rig) -> None:
    guard = rig.build(SensorHealthGuard)
    speeds = drive(rig, guard, 5.0)
    assert guard.status == Status.RUNNING and guard.feedback_message == "sensors healthy"
    assert all(v == pytest.approx(0.5) for v in speeds.values())
    assert rig.services.events == [] and rig.written_by(guard) == []


def test_a_silent_camera_stops_the_base_at_once_and_it_drives_on_after_the_camera_returns(
    make_rig: Callable[..., Rig],
) -> None:
    rig, guard = guarded(make_rig, {"class": "camera_drop", "start_s": 1.0, "duration_s": 1.0})
    speeds = drive(rig, guard, 4.0)
    stopped = [t for t, v in speeds.items() if 1.0 < t < 2.0 and v == 0.0]
    assert stopped and stopped[0] <= 1.0 + 0.1 + 2 * TICK_S  # the deadline, then the next tick
    assert all(v == 0.0 for t, v in speeds.items() if stopped[0] <= t <= 2.0 + 0.5)  # recover_after_s
    assert all(v == pytest.approx(0.5) for t, v in speeds.items() if t > 2.0 + 0.5 + 2 * TICK_S)
    assert kinds(rig) == [("sensor_unhealthy", "camera"), ("sensor_recovered", "camera")]
    assert guard.status == Status.RUNNING and rig.written_by(guard) == ["cmd_twist"]


def test_a_camera_that_stays_silent_ends_the_mission_naming_it(make_rig: Callable[..., Rig]) -> None:
    rig, guard = guarded(make_rig, {"class": "camera_drop", "start_s": 1.0}, lost_after_s=2.0)
    drive(rig, guard, 10.0)
    assert guard.status == Status.FAILURE and rig.get("mission_outcome") == "sensor_lost: camera"
    assert 3.0 <= rig.robot.now_s() <= 3.0 + 0.1 + 3 * TICK_S
    assert kinds(rig)[-1] == ("sensor_stop", "camera")
    assert rig.written_by(guard) == ["cmd_twist", "mission_outcome"]


def test_a_frozen_frame_is_caught_by_its_own_stamp_though_frames_keep_arriving(
    make_rig: Callable[..., Rig],
) -> None:
    rig, guard = guarded(make_rig, {"class": "camera_freeze", "start_s": 1.0, "duration_s": 1.0})
    speeds = drive(rig, guard, 1.5)
    assert rig.robot.sensor_stamps().camera_s == pytest.approx(rig.robot.now_s())
    assert speeds[max(speeds)] == 0.0
    assert rig.services.events[0]["reason"].startswith("frame")


def test_depth_that_is_not_a_number_holds_the_robot(make_rig: Callable[..., Rig]) -> None:
    rig, guard = guarded(
        make_rig, {"class": "depth_corrupt", "start_s": 1.0, "duration_s": 1.0, "params": {"value": "nan"}}
    )
    speeds = drive(rig, guard, 1.5)
    assert speeds[max(speeds)] == 0.0
    assert "not a number" in rig.services.events[0]["reason"]


def test_a_robot_that_stands_still_is_not_sampled_and_a_new_command_is_checked_first(
    make_rig: Callable[..., Rig],
) -> None:
    rig, guard = guarded(
        make_rig, {"class": "depth_corrupt", "start_s": 1.0, "duration_s": 5.0, "params": {"value": "nan"}}
    )
    rig.tick(guard, ticks=100)  # standing, told nothing: nothing to check
    assert rig.services.events == []
    speeds = drive(rig, guard, 3.0)
    assert all(v == 0.0 for v in speeds.values())  # the first forward command is checked before it is driven


def test_a_robot_turning_in_place_on_a_frozen_camera_is_stopped_too(make_rig: Callable[..., Rig]) -> None:
    rig, guard = guarded(make_rig, {"class": "camera_freeze", "start_s": 1.0, "duration_s": 2.0})
    turns = drive(rig, guard, 2.0, twist=Twist(angular_z_radps=0.8))
    assert turns[0.02] == pytest.approx(0.8)
    assert all(w == 0.0 for t, w in turns.items() if t >= 1.0 + 0.1 + 2 * TICK_S)


def test_an_odometry_jump_ends_the_mission_at_once(make_rig: Callable[..., Rig]) -> None:
    rig, guard = guarded(make_rig, {"class": "odometry_jump", "start_s": 1.0, "params": {"dx_m": 0.5}})
    drive(rig, guard, 5.0)
    assert rig.get("mission_outcome") == "sensor_fault: odometry"
    assert rig.robot.now_s() == pytest.approx(1.0 + TICK_S, abs=TICK_S + 1e-9)
    assert "jumped" in rig.services.events[-1]["reason"]


def test_slow_odometry_drift_is_tolerated_and_fast_drift_ends_the_mission(
    make_rig: Callable[..., Rig],
) -> None:
    slow = {"class": "odometry_drift", "start_s": 1.0, "params": {"vx_mps": 0.02, "yaw_degps": 1.0}}
    rig, guard = guarded(make_rig, slow)
    drive(rig, guard, 12.0)
    assert guard.status == Status.RUNNING
    fast = {"class": "odometry_drift", "start_s": 1.0, "params": {"vx_mps": 0.3, "yaw_degps": 0.0}}
    rig, guard = guarded(make_rig, fast)
    drive(rig, guard, 12.0)
    assert rig.get("mission_outcome") == "sensor_fault: odometry"
    assert "drifted" in rig.services.events[-1]["reason"]
    assert rig.robot.now_s() < 1.0 + 2 * 2.0 + TICK_S  # within two drift windows


def test_silent_odometry_holds_then_ends_the_mission(make_rig: Callable[..., Rig]) -> None:
    rig, guard = guarded(make_rig, {"class": "odometry_drop", "start_s": 1.0}, lost_after_s=1.0)
    speeds = drive(rig, guard, 5.0)
    assert all(v == 0.0 for t, v in speeds.items() if 1.0 + 0.1 + 2 * TICK_S <= t)
    assert rig.get("mission_outcome") == "sensor_lost: odometry"


def test_a_clock_that_jumps_ends_the_mission(make_rig: Callable[..., Rig]) -> None:
    for jump_s in (30.0, -5.0):
        rig, guard = guarded(make_rig, {"class": "clock_jump", "start_s": 1.0, "params": {"jump_s": jump_s}})
        drive(rig, guard, 5.0 + max(jump_s, 0.0))
        assert rig.get("mission_outcome") == "sensor_fault: clock"
        step = float(rig.services.events[-1]["reason"].split()[2])
        assert step == pytest.approx(jump_s + TICK_S)


def test_imu_spikes_hold_the_robot_only_when_a_gait_policy_reads_the_imu(
    make_rig: Callable[..., Rig],
) -> None:
    spikes = {"class": "imu_spike", "start_s": 1.0, "duration_s": 1.0, "params": {"probability": 1.0}}
    rig, guard = guarded(make_rig, spikes)
    speeds = drive(rig, guard, 3.0)
    assert all(v == pytest.approx(0.5) for v in speeds.values())
    assert rig.services.events == []  # nothing reads the IMU, so the guard does not either

    def walking_gait(robot: Robot, twist: Twist) -> None:
        robot.imu()  # a gait policy reads the IMU (and the joints), then walks

    rig, _ = guarded(make_rig, spikes)
    rig.services.gait = walking_gait
    guard = rig.build(SensorHealthGuard)
    speeds = drive(rig, guard, 1.5)
    assert speeds[max(speeds)] == 0.0
    assert rig.services.events[0]["sensor"] == "imu" and rig.services.events[0]["needed"] is True


def test_halting_changes_nothing(make_rig: Callable[..., Rig]) -> None:
    rig, guard = guarded(make_rig, {"class": "camera_drop", "start_s": 0.5})
    drive(rig, guard, 1.0)
    rig.halt(guard)
    assert rig.get("mission_outcome") == "running"
