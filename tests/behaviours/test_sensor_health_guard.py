"""SensorHealthGuard on its own: a NullRobot driven forward by a stand-in planner, with faults injected
between it and the executive by ``sims.faults.FaultyRobot``.

The little tree is the mission's root parallel in miniature: the guard, then the gait, then a planner
that asks for 0.5 m/s every tick. Each test prints the tree it asserts on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import py_trees
import pytest

from behaviours.base import SemExpBehaviour
from behaviours.gait import Gait
from behaviours.sensor_health_guard import SensorHealthGuard
from behaviours.services import SERVICES_KEY, MissionServices
from behaviours.spec import BuildContext
from blackboard.schema import fresh_board
from robots.interface import Robot
from robots.null_robot import NullRobot
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.planner import DepthArcPlanner
from sims.faults import FaultyRobot, parse_faults

TICK_S = 0.02
FORWARD = Twist(linear_x_mps=0.5)


class NoPerception:
    """The guard never perceives."""

    def submit(self, **request: Any) -> Any:
        raise AssertionError("the guard must not call perception")


class DriveForward(SemExpBehaviour):
    """The planner's stand-in: commands FORWARD every tick, after the gait (as the search branch does)."""

    WRITES = ("cmd_twist", "cmd_stamp_s")

    def update(self) -> py_trees.common.Status:
        self.command(FORWARD)
        return py_trees.common.Status.RUNNING


def make_tree(robot: Robot, *, gait: Callable[[Robot, Any], None] | None = None, **params: Any):
    fresh_board()
    services = MissionServices(
        robot=robot,
        perception=NoPerception(),
        relevance=CachedRelevance(LexicalRelevance()),
        config=SemExpConfig(),
        planner=DepthArcPlanner(),
        gait=gait,
        rng=np.random.default_rng(0),
    )
    context = BuildContext(clock=robot.now_s, robot=robot, services={SERVICES_KEY: services})
    guard = SensorHealthGuard("SensorHealth", context=context, **params)
    root = py_trees.composites.Parallel(
        "Mission",
        policy=py_trees.common.ParallelPolicy.SuccessOnAll(),
        children=[guard, Gait("Gait50Hz", context=context), DriveForward("Plan", context=context)],
    )
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup()
    board = py_trees.blackboard.Client(name="test")
    board.register_key("mission_outcome", access=py_trees.common.Access.READ, remap_to="/mission_outcome")
    return tree, guard, services, board


def run_until(tree: py_trees.trees.BehaviourTree, robot: Robot, stop_s: float) -> list[tuple[float, float]]:
    """Tick and advance until ``stop_s`` or the root ends; ``(time, true forward speed)`` after each tick."""
    truth = robot.inner if isinstance(robot, FaultyRobot) else robot
    speeds = []
    while robot.now_s() < stop_s - 1e-9:
        tree.tick()
        speeds.append((robot.now_s(), truth.base_twist().linear_x_mps))
        if tree.root.status != py_trees.common.Status.RUNNING:
            break
        robot.advance(TICK_S)
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    return speeds


def faulty(*faults: dict[str, Any], seed: int = 0) -> FaultyRobot:
    return FaultyRobot(
        NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0)), parse_faults(list(faults), where="test"), seed=seed
    )


def kinds(services: MissionServices) -> list[tuple[str, str | None]]:
    return [(e["kind"], e.get("sensor")) for e in services.events]


def test_healthy_sensors_leave_the_command_alone() -> None:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    tree, guard, services, _ = make_tree(robot)
    speeds = run_until(tree, robot, 5.0)
    assert guard.status == py_trees.common.Status.RUNNING
    assert all(v == pytest.approx(0.5) for _, v in speeds[1:])  # the first tick has no command yet
    assert services.events == []
    assert guard.feedback_message == "sensors healthy"


def test_a_silent_camera_stops_the_base_at_once_and_it_drives_on_after_the_camera_returns() -> None:
    robot = faulty({"class": "camera_drop", "start_s": 1.0, "duration_s": 1.0})
    tree, guard, services, _ = make_tree(robot, recover_after_s=0.5)
    speeds = dict(run_until(tree, robot, 4.0))
    stopped = [t for t, v in speeds.items() if 1.0 < t < 2.0 and v == 0.0]
    assert stopped and stopped[0] <= 1.0 + 0.1 + 2 * TICK_S  # the deadline, then the next tick
    assert all(v == 0.0 for t, v in speeds.items() if stopped[0] <= t < 2.0 + 0.5)
    assert all(v == pytest.approx(0.5) for t, v in speeds.items() if t > 2.0 + 0.5 + 2 * TICK_S)
    assert kinds(services) == [("sensor_unhealthy", "camera"), ("sensor_recovered", "camera")]
    assert guard.status == py_trees.common.Status.RUNNING


def test_a_camera_that_stays_silent_ends_the_mission_naming_it() -> None:
    robot = faulty({"class": "camera_drop", "start_s": 1.0})
    tree, guard, services, board = make_tree(robot, lost_after_s=2.0)
    run_until(tree, robot, 10.0)
    assert guard.status == py_trees.common.Status.FAILURE
    assert board.mission_outcome == "sensor_lost: camera"
    assert 3.0 <= robot.now_s() <= 3.0 + 0.1 + 3 * TICK_S
    assert kinds(services)[-1] == ("sensor_stop", "camera")


def test_a_frozen_frame_is_caught_by_its_own_stamp_though_frames_keep_arriving() -> None:
    robot = faulty({"class": "camera_freeze", "start_s": 1.0, "duration_s": 1.0})
    tree, guard, services, _ = make_tree(robot)
    speeds = dict(run_until(tree, robot, 1.5))
    assert robot.sensor_stamps().camera_s == pytest.approx(robot.now_s())
    assert speeds[max(speeds)] == 0.0
    assert services.events[0]["reason"].startswith("frame")


def test_depth_that_is_not_a_number_holds_the_robot() -> None:
    robot = faulty({"class": "depth_corrupt", "start_s": 1.0, "duration_s": 1.0, "params": {"value": "nan"}})
    tree, guard, services, _ = make_tree(robot)
    speeds = dict(run_until(tree, robot, 1.5))
    assert speeds[max(speeds)] == 0.0
    assert "not a number" in services.events[0]["reason"]


def test_an_odometry_jump_ends_the_mission_at_once() -> None:
    robot = faulty({"class": "odometry_jump", "start_s": 1.0, "params": {"dx_m": 0.5}})
    tree, guard, services, board = make_tree(robot)
    run_until(tree, robot, 5.0)
    assert board.mission_outcome == "sensor_fault: odometry"
    assert robot.now_s() == pytest.approx(1.0, abs=TICK_S + 1e-9)
    assert "jumped" in services.events[-1]["reason"]


def test_slow_odometry_drift_is_tolerated_and_fast_drift_ends_the_mission() -> None:
    slow = faulty({"class": "odometry_drift", "start_s": 1.0, "params": {"vx_mps": 0.02, "yaw_degps": 1.0}})
    tree, guard, _, _ = make_tree(slow)
    run_until(tree, slow, 12.0)
    assert guard.status == py_trees.common.Status.RUNNING
    fast = faulty({"class": "odometry_drift", "start_s": 1.0, "params": {"vx_mps": 0.3, "yaw_degps": 0.0}})
    tree, guard, services, board = make_tree(fast)
    run_until(tree, fast, 12.0)
    assert board.mission_outcome == "sensor_fault: odometry"
    assert "drifted" in services.events[-1]["reason"]
    assert fast.now_s() < 1.0 + 2 * 2.0 + TICK_S  # within two drift windows


def test_silent_odometry_holds_then_ends_the_mission() -> None:
    robot = faulty({"class": "odometry_drop", "start_s": 1.0})
    tree, guard, _, board = make_tree(robot, lost_after_s=1.0)
    speeds = dict(run_until(tree, robot, 5.0))
    assert all(v == 0.0 for t, v in speeds.items() if 1.0 + 0.1 + 2 * TICK_S <= t)
    assert board.mission_outcome == "sensor_lost: odometry"


def test_a_clock_that_jumps_ends_the_mission() -> None:
    for jump_s in (30.0, -5.0):
        robot = faulty({"class": "clock_jump", "start_s": 1.0, "params": {"jump_s": jump_s}})
        tree, guard, services, board = make_tree(robot)
        run_until(tree, robot, 5.0 + max(jump_s, 0.0))
        assert board.mission_outcome == "sensor_fault: clock"
        step = float(services.events[-1]["reason"].split()[2])
        assert step == pytest.approx(jump_s + TICK_S)


def test_imu_spikes_hold_the_robot_only_when_a_gait_policy_reads_the_imu() -> None:
    spikes = {"class": "imu_spike", "start_s": 1.0, "duration_s": 1.0, "params": {"probability": 1.0}}
    robot = faulty(spikes)
    tree, guard, services, _ = make_tree(robot)
    speeds = dict(run_until(tree, robot, 3.0))
    assert all(v == pytest.approx(0.5) for t, v in speeds.items() if t > 0.0)
    assert services.events == []  # nothing reads the IMU, so the guard does not either

    def walking_gait(robot: Robot, twist: Twist) -> None:
        robot.imu()  # a gait policy reads the IMU (and joints), then walks
        robot.command_twist(twist)

    robot = faulty(spikes)
    tree, guard, services, _ = make_tree(robot, gait=walking_gait)
    speeds = dict(run_until(tree, robot, 1.5))
    assert speeds[max(speeds)] == 0.0
    assert services.events[0]["needed"] is True
