"""Fault injection (``sims.faults``): fault lists as data, the decorators that inject them, and the way in
from a mission file or ``semexp-bt run --faults``.

The decorators are checked on the NullRobot (a perfect unicycle with an analytic camera), so each test can
say exactly what the executive must read; one short MuJoCo episode checks the whole path, and the
MuJoCo IMU's one-sample-per-instant rule that keeps a guard from changing what the gait reads.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robots.null_robot import NullRobot
from semexp_bt.core.types import Observation, PixelGrid, Pose2D, SceneEvidence, SceneProposal, Twist
from semexp_bt.perception.interface import PerceptionResult, ReadyJob
from semexp_bt.perception.validation import screen_result
from sims.faults import (
    FAULT_CLASSES,
    FaultSpecError,
    FaultyPerception,
    FaultyRobot,
    load_faults_file,
    parse_faults,
)
from trees.loader import MissionLoadError, parse_mission

REPO = Path(__file__).resolve().parents[1]
TICK_S = 0.02


def faulty(*entries: dict, seed: int = 0) -> FaultyRobot:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 3.0, 0.0, 0.3, 0.6),))
    return FaultyRobot(robot, parse_faults(list(entries), where="test.yaml"), seed=seed)


def advance_to(robot: FaultyRobot, t_s: float) -> None:
    while robot.inner.now_s() < t_s - 1e-9:
        robot.advance(TICK_S)


# --- the fault list ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"class": "camera_dro", "start_s": 1}, "test.yaml: key 'faults[0].class' must be one of"),
        ({"class": "camera_drop"}, "test.yaml: missing key 'faults[0].start_s'"),
        ({"class": "camera_drop", "start_s": -1}, "key 'faults[0].start_s' must be >= 0"),
        ({"class": "camera_drop", "start_s": 1, "duration_s": 0}, "key 'faults[0].duration_s' must be > 0"),
        ({"class": "camera_drop", "start_s": 1, "when": 2}, "unknown key 'faults[0].when'"),
        (
            {"class": "camera_drop", "start_s": 1, "params": {"drop_probability": 2}},
            "key 'faults[0].params.drop_probability' must lie in [0.0, 1.0], got 2",
        ),
        (
            {"class": "depth_corrupt", "start_s": 1, "params": {"value": "inf"}},
            "key 'faults[0].params.value' must be one of ['zero', 'nan']",
        ),
        ({"class": "imu_spike", "start_s": 1, "params": {"gyro": 1}}, "unknown key 'faults[0].params.gyro'"),
        (
            {"class": "clock_jump", "start_s": 1, "params": {"jump_s": 0}},
            "'faults[0].params.jump_s' must not be 0",
        ),
        ("camera_drop", "'faults[0]' must be a mapping"),
    ],
)
def test_a_bad_fault_entry_is_refused_naming_the_file_and_the_key(entry: object, message: str) -> None:
    with pytest.raises(FaultSpecError) as error:
        parse_faults([entry], where="test.yaml")
    assert message in str(error.value)


def test_every_class_parses_with_its_defaults_and_says_what_it_damages() -> None:
    faults = parse_faults([{"class": name, "start_s": 1.0} for name in FAULT_CLASSES], where="x")
    assert [f.fault_class for f in faults] == list(FAULT_CLASSES)
    assert all(f.duration_s is None and f.active(1e9) and not f.active(0.5) for f in faults)
    assert {c.target for c in FAULT_CLASSES.values()} == {"robot", "perception"}


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"faults: [", ":1:10: YAML syntax error"),
        (b"\xff\xfe", ":1:1: not UTF-8 text"),
        (b"- {class: camera_drop, start_s: 1}\n", ": a fault file is a mapping with the one key 'faults'"),
        (b"[" * 5000 + b"]" * 5000, ":1:65: nested deeper than 64 levels"),
        (b"faults:\n  - {class: nope, start_s: 1}\n", ": key 'faults[0].class'"),
    ],
)
def test_a_bad_fault_file_is_refused_naming_it(tmp_path: Path, content: bytes, message: str) -> None:
    path = tmp_path / "faults.yaml"
    path.write_bytes(content)
    with pytest.raises(FaultSpecError) as error:
        load_faults_file(path)
    assert f"{path}{message}" in str(error.value)


def test_a_fault_file_that_is_missing_or_a_folder_is_refused(tmp_path: Path) -> None:
    for path, problem in (
        (tmp_path / "missing.yaml", "not found"),
        (tmp_path, "not a regular file (a directory)"),
    ):
        with pytest.raises(FaultSpecError) as error:
            load_faults_file(path)
        assert str(error.value) == f"fault file {path}: {problem}"


def test_a_mission_file_may_carry_a_faults_section_and_a_subtree_may_not(tmp_path: Path) -> None:
    text = (REPO / "trees" / "object_search.yaml").read_text()
    text = text.replace("include: subtrees/", f"include: {REPO / 'trees' / 'subtrees'}/")
    mission = tmp_path / "mission.yaml"  # a mission anywhere may include the shipped subtrees
    mission.write_text(text + "faults:\n  - {class: camera_drop, start_s: 2, duration_s: 1}\n")
    settings = parse_mission(mission).settings
    faults = parse_faults(settings.faults, where=settings.faults_where)
    assert [(f.fault_class, f.start_s, f.duration_s) for f in faults] == [("camera_drop", 2.0, 1.0)]
    assert settings.faults_where.endswith(f"{mission.name}:{text.count(chr(10)) + 2}:3")

    subtree = tmp_path / "sub.yaml"
    subtree.write_text("faults: []\ntree: {type: Success, name: S}\n")
    parent = tmp_path / "parent.yaml"
    parent.write_text("tree:\n  include: sub.yaml\n  name: Sub\n")
    with pytest.raises(MissionLoadError, match="subtree file must not have a 'faults' section"):
        parse_mission(parent)


# --- the robot decorator ----------------------------------------------------------------------------


def test_without_an_active_fault_the_decorator_hands_out_what_the_robot_gives() -> None:
    robot = faulty({"class": "camera_drop", "start_s": 5.0})
    plain = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 3.0, 0.0, 0.3, 0.6),))
    for r in (robot, plain):
        r.command_twist(Twist(0.3, 0.0, 0.1))
        for _ in range(50):
            r.advance(TICK_S)
    assert robot.base_pose() == plain.base_pose()
    np.testing.assert_array_equal(robot.observe().depth_m, plain.observe().depth_m)
    assert robot.sensor_stamps().camera_s == robot.now_s() == plain.now_s()


def test_dropped_frames_leave_the_newest_delivered_frame_and_its_stamp() -> None:
    robot = faulty({"class": "camera_drop", "start_s": 1.0, "duration_s": 1.0})
    robot.command_twist(Twist(0.5, 0.0, 0.0))
    advance_to(robot, 0.98)
    before = robot.observe_depth(pixel_grids=[PixelGrid.centred(8)])
    advance_to(robot, 1.5)
    during = robot.observe_depth(pixel_grids=[PixelGrid.centred(8)])
    assert during.stamp_s == before.stamp_s == pytest.approx(0.98)
    assert robot.sensor_stamps().camera_s == pytest.approx(1.0 - 1.0 / 30.0, abs=1.0 / 30.0)
    advance_to(robot, 2.0)
    after = robot.observe_depth(pixel_grids=[PixelGrid.centred(8)])
    assert after.stamp_s == pytest.approx(2.0) and after.base_pose.x_m > during.base_pose.x_m + 0.4


def test_partly_dropped_frames_arrive_at_a_lower_rate() -> None:
    robot = faulty({"class": "camera_drop", "start_s": 0.0, "params": {"drop_probability": 0.5}}, seed=3)
    ages = []
    for _ in range(500):
        robot.advance(1.0 / 30.0)
        ages.append(robot.now_s() - robot.sensor_stamps().camera_s)
    assert 0.0 <= min(ages) < 1e-6 and max(ages) > 0.1
    assert 0.3 < np.mean(np.asarray(ages) < 1e-6) < 0.7


def test_a_frozen_camera_keeps_fresh_topic_stamps_but_hands_out_the_old_frame() -> None:
    robot = faulty({"class": "camera_freeze", "start_s": 1.0})
    advance_to(robot, 0.9)
    old = robot.observe()
    robot.command_twist(Twist(0.0, 0.0, 1.0))
    advance_to(robot, 2.0)
    frozen = robot.observe()
    assert robot.sensor_stamps().camera_s == pytest.approx(2.0)
    assert frozen.stamp_s == old.stamp_s and frozen is old


def test_corrupted_depth_has_patches_of_nan_or_zero_the_same_for_every_reader() -> None:
    for value, check in (("nan", np.isnan), ("zero", lambda d: d == 0.0)):
        robot = faulty({"class": "depth_corrupt", "start_s": 0.0, "params": {"value": value, "patches": 2}})
        clean = robot.inner.observe().depth_m
        a, b = robot.observe().depth_m, robot.observe().depth_m
        assert np.array_equal(np.isnan(a), np.isnan(b)) and np.array_equal(a == 0, b == 0)
        damaged = check(a) & ~check(clean)
        assert 0.05 < damaged.mean() < 0.2  # two patches of 0.3 x 0.3 of the image


def test_an_odometry_jump_moves_the_odometry_frame_once_and_the_frames_with_it() -> None:
    robot = faulty({"class": "odometry_jump", "start_s": 1.0, "params": {"dx_m": 0.5, "dyaw_deg": 90}})
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    advance_to(robot, 1.0)
    true_start = robot.inner.base_pose()
    jumped = robot.base_pose()
    assert (jumped.x_m, jumped.y_m, jumped.yaw_rad) == pytest.approx((true_start.x_m + 0.5, 0.0, math.pi / 2))
    advance_to(robot, 2.0)
    # One metre forward in truth is one metre along +y in the turned odometry frame.
    pose = robot.base_pose()
    assert (pose.x_m, pose.y_m) == pytest.approx((jumped.x_m, 1.0), abs=1e-6)
    frame = robot.observe()
    assert frame.base_pose == pose
    assert frame.camera_to_world[:2, 3] == pytest.approx([pose.x_m, pose.y_m])


def test_odometry_drift_grows_during_the_fault_and_stays_after_it() -> None:
    robot = faulty(
        {
            "class": "odometry_drift",
            "start_s": 0.0,
            "duration_s": 2.0,
            "params": {"vx_mps": 0.1, "yaw_degps": 0.0},
        }
    )
    advance_to(robot, 1.0)
    assert robot.base_pose().x_m == pytest.approx(0.1)
    advance_to(robot, 4.0)
    assert robot.base_pose().x_m == pytest.approx(0.2)


def test_dropped_odometry_and_imu_repeat_their_last_values_with_old_stamps() -> None:
    robot = faulty({"class": "odometry_drop", "start_s": 1.0}, {"class": "imu_drop", "start_s": 1.0})
    robot.command_twist(Twist(0.5, 0.0, 0.0))
    advance_to(robot, 0.98)
    pose, imu = robot.base_pose(), robot.imu()
    advance_to(robot, 2.0)
    assert robot.base_pose() == pose and robot.imu() is imu
    stamps = robot.sensor_stamps()
    assert stamps.odometry_s == stamps.imu_s == pytest.approx(1.0) and stamps.camera_s == pytest.approx(2.0)


def test_imu_spikes_are_large_and_random() -> None:
    robot = faulty({"class": "imu_spike", "start_s": 0.0, "params": {"probability": 0.5, "gyro_radps": 30.0}})
    rates = [float(np.linalg.norm(robot.imu().angular_velocity_radps)) for _ in range(200)]
    spiked = np.asarray(rates) > 20.0
    assert 0.3 < spiked.mean() < 0.7


def test_ignored_commands_do_not_reach_the_robot_whose_watchdog_stops_it() -> None:
    robot = faulty({"class": "commands_ignored", "start_s": 1.0, "duration_s": 2.0})
    robot.command_twist(Twist(0.5, 0.0, 0.0))
    advance_to(robot, 1.2)
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    assert robot.inner.base_twist().linear_x_mps == 0.5 and robot.last_twist_received.linear_x_mps == 1.0
    advance_to(robot, 1.6)
    assert robot.inner.base_twist().linear_x_mps == 0.0  # its own watchdog, 0.5 s after the fault began
    advance_to(robot, 3.0)
    robot.command_twist(Twist(0.2, 0.0, 0.0))
    assert robot.inner.base_twist().linear_x_mps == 0.2


def test_a_clock_jump_moves_the_clock_and_every_stamp_and_jumps_back_at_the_end() -> None:
    robot = faulty({"class": "clock_jump", "start_s": 1.0, "duration_s": 1.0, "params": {"jump_s": -30.0}})
    advance_to(robot, 1.5)
    assert robot.now_s() == pytest.approx(-28.5)
    assert robot.observe().stamp_s == robot.sensor_stamps().camera_s == pytest.approx(-28.5)
    advance_to(robot, 2.5)
    assert robot.now_s() == pytest.approx(2.5)


# --- the perception decorator and the executive's screen ------------------------------------------


def frame() -> Observation:
    return NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0)).observe()


class OneAnswer:
    def submit(self, **_: object) -> ReadyJob:
        scene = SceneEvidence((SceneProposal((10.0, 20.0), "chair"),), 0.8)
        return ReadyJob(PerceptionResult(scene, (), 0.0, 2.5, 1.2), ready_at_s=2.5)


def perceive(*entries: dict, now_s: float = 0.0, poll_s: float = 3.0) -> PerceptionResult | None:
    source = FaultyPerception(
        OneAnswer(), parse_faults(list(entries), where="x"), elapsed_s=lambda: now_s, seed=0
    )
    job = source.submit(
        observation=frame(), instruction="find the chair", target_label="chair", motion=Twist(), now_s=now_s
    )
    return job.poll(now_s=poll_s)


def test_model_errors_late_replies_and_garbage_are_what_a_failing_model_would_give() -> None:
    error = perceive({"class": "perception_error", "start_s": 0.0, "params": {"source": "vlm"}})
    assert error is not None and error.scene is None and error.detections == ()
    assert error.errors == ("vlm: request failed (endpoint returned HTTP 503)",)

    late = {"class": "perception_late", "start_s": 0.0, "params": {"delay_s": 10.0}}
    assert perceive(late, poll_s=3.0) is None
    source = FaultyPerception(OneAnswer(), parse_faults([late], where="x"), elapsed_s=lambda: 0.0, seed=0)
    job = source.submit(observation=frame(), instruction="", target_label="chair", motion=Twist(), now_s=0.0)
    assert job.poll(now_s=3.0) is None and job.poll(now_s=12.9) is None
    answer = job.poll(now_s=13.0)
    assert answer is not None and answer.scene_latency_s == pytest.approx(12.5)

    garbage = perceive({"class": "perception_garbage", "start_s": 0.0})
    assert garbage is not None and garbage.scene is not None and math.isnan(garbage.scene.scene_confidence)
    screened = screen_result(garbage)
    assert screened.scene is None and screened.detections is None
    assert [e.split(":")[0] for e in screened.errors] == ["vlm reply rejected", "detector reply rejected"]

    nonsense = perceive({"class": "perception_garbage", "start_s": 0.0, "params": {"malformed": False}})
    assert nonsense is not None and screen_result(nonsense) == nonsense  # well-formed: it passes the screen

    before = perceive({"class": "perception_error", "start_s": 5.0}, now_s=0.0)
    assert before is not None and before.errors == ()  # submitted before the fault: untouched


# --- the whole path -------------------------------------------------------------------------------


def test_run_with_a_fault_file_stops_the_mission_naming_the_lost_sensor(tmp_path: Path) -> None:
    faults = tmp_path / "faults.yaml"
    faults.write_text("faults:\n  - {class: camera_drop, start_s: 4}\n")
    record = tmp_path / "run.json"
    done = subprocess.run(
        [sys.executable, "-m", "semexp_bt", "run", "trees/object_search.yaml", "--scene", "office", "--seed", "0",
         "--relevance", "lexical", "--faults", str(faults), "--json", str(record)],
        cwd=REPO, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 1, done.stderr
    assert "sensor_lost: camera" in done.stdout
    import json

    episode = json.loads(record.read_text())
    assert episode["outcome"] == "sensor_lost: camera"
    assert episode["sim_time_s"] == pytest.approx(4.0 + 5.0, abs=0.2)  # the guard's lost_after_s
    assert episode["faults"][0]["class"] == "camera_drop"
    kinds = [e["kind"] for e in episode["events"] if e["kind"].startswith("sensor")]
    assert kinds == ["sensor_unhealthy", "sensor_stop"]


def test_run_refuses_a_bad_fault_file_with_one_line_and_status_2(tmp_path: Path) -> None:
    faults = tmp_path / "faults.yaml"
    faults.write_text("faults:\n  - {class: camera_drop, start_s: 4, params: {drop_probability: 3}}\n")
    done = subprocess.run(
        [sys.executable, "-m", "semexp_bt", "run", "trees/object_search.yaml", "--scene", "office",
         "--relevance", "lexical", "--faults", str(faults)],
        cwd=REPO, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"error: {faults}: key 'faults[0].params.drop_probability' must lie in [0.0, 1.0], got 3.0"
    ]


def test_the_mujoco_imu_gives_one_sample_per_instant() -> None:
    from tests.test_mujoco_backend import make_kinematic

    robot = make_kinematic(seed=1)
    try:
        a, b = robot.imu(), robot.imu()
        np.testing.assert_array_equal(a.angular_velocity_radps, b.angular_velocity_radps)
        robot.advance(TICK_S)
        assert not np.array_equal(robot.imu().angular_velocity_radps, a.angular_velocity_radps)
    finally:
        robot.close()
