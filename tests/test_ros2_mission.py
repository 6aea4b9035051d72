"""The mission over ROS 2, end to end: the bridge and the executive as separate processes on loopback DDS.

- The in-process outcome over ROS 2, on two fixed kinematic episodes in lockstep: the test runs the
  episode in process (``semexp-bt run --scene``, the MuJoCo backend) and over ROS 2 (``sim-bridge`` plus
  ``run --backend ros2``) with the same mission file, seed and options, and asserts that the two runs are
  the same mission: the same outcome and found objects, the same ticks (at every one the same node
  statuses, feedback and blackboard writes, less the clearance guard's feedback: contact distances only a
  simulator knows; ``scripts/compare_tick_records.py``), the same decisions, the same simulated time,
  and the same path to 1e-6 m (by the executive's odometry and by the bridge's ground truth). Besides that, the contract of a mission
  over ROS 2: it runs to its end, executive and bridge agree on the outcome, a declared success is real,
  and the exit status follows the outcome. This holds to the bit because both sides see the same
  numbers: whole-millimetre depth, the simulator's float clock, and the pose as the robot's odometry
  reports it (position and quaternion), with the camera pose from it and the mount by the same
  arithmetic (``MujocoRobot.base_odometry``, docs/ros2.md "Lockstep and realtime").
  The episodes were fixed before any ROS 2 run, by a rule that reads no outcome: the two smallest indoor
  scenes of the session-8 solved-episode list by object count (showroom, 13 objects; living_room, 14),
  with that list's seeds. The mission is ``trees/object_search.yaml`` with its budget cut to
  :data:`E2E_BUDGET_S` (both runs read the same copy): the comparison is tick by tick, so a short mission
  tests the same thing, and the full 600 s budget cost about 4 minutes of wall time per episode on the
  2-core CI machine, which put the default suite over its 20-minute limit.
- Loss: the lockstep's per-tick pair is best effort; with every 50th step reply left out by the bridge
  (``--drop-step-replies``) the executive asks again and the mission is still the in-process one.
- Safety: a sensor topic silent past its profile deadline zeroes the twist and halts the mission naming
  the topic; the bridge killed mid-mission makes the executive stop commanding and exit non-zero within
  2 s; the executive killed makes the bridge, like the Go1 driver, stop the robot within 0.5 s.

Needs the ROS 2 environment (``make ros2-env``); ``make test`` runs this file with it, inside a network
namespace with only ``lo`` (scripts/ros2_isolated.sh). Each test uses a domain id of its own.
"""

from __future__ import annotations

import json
import math
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rclpy", reason="the ROS 2 environment (make ros2-env) provides rclpy")

from robots.ros2_backend import LOCKSTEP_REPLY_MIN_S, WAIT_SLICE_S
from tests.ros2_support import (
    MISSION,
    ROOT,
    CommandSpy,
    fresh_domain_id,
    isolated_env,
    mission_with_budget,
    semexp,
    stop,
    wait_for,
    wait_for_bridge,
)

#: Fixed before any ROS 2 run (module docstring).
EPISODES: list[tuple[str, int]] = [("showroom", 9), ("living_room", 0)]
#: The end-to-end missions' budget (robot-clock seconds; the shipped mission has 600): the panoramic
#: start, the first decisions and the navigation toward them, in well under 90 s of wall time per episode
#: on a loaded 2-core machine (module docstring; figures in docs/ros2.md). 55 since the explore step's
#: glances (about 8 s before each decision): at 40 s both episodes ended before the robot had moved 0.1 m.
E2E_BUDGET_S = 55
#: Compares two missions' per-tick records (statuses, feedback, blackboard writes) and names the first
#: difference.
COMPARE_RECORDS = ROOT / "scripts" / "compare_tick_records.py"


def _run_in_process(tmp_path: Path, mission: Path, scene: str, seed: int) -> tuple[dict[str, Any], Path]:
    """The episode in process (the MuJoCo backend), with the options the ROS 2 executive gets."""
    record, ticks = tmp_path / "in_process.json", tmp_path / "in_process.jsonl"
    out = subprocess.run(
        [
            *semexp_cmd(),
            "run",
            str(mission),
            "--scene",
            scene,
            "--seed",
            str(seed),
            "--relevance",
            "lexical",
            "--json",
            str(record),
            "--record",
            str(ticks),
        ],
        env=isolated_env(fresh_domain_id()),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode in (0, 1), out.stdout[-2000:] + out.stderr[-2000:]
    return json.loads(record.read_text()), ticks


def _run_pair(
    tmp_path: Path,
    mission: Path,
    scene: str,
    seed: int,
    *,
    domain: int,
    executive_args: tuple[str, ...] = (),
    bridge_args: tuple[str, ...] = (),
) -> tuple[dict[str, Any], dict[str, Any], int, Path]:
    env = isolated_env(domain)
    bridge_json, exec_json = tmp_path / "bridge.json", tmp_path / "executive.json"
    ticks = tmp_path / "executive.jsonl"
    bridge = semexp(
        [
            "sim-bridge",
            "--scene",
            scene,
            "--seed",
            str(seed),
            "--json",
            str(bridge_json),
            "--max-wall-s",
            "600",
            *bridge_args,
        ],
        env=env,
        log=tmp_path / "bridge.log",
    )
    wait_for_bridge(tmp_path / "bridge.log", bridge)
    try:
        executive = semexp(
            [
                "run",
                str(mission),
                "--backend",
                "ros2",
                "--seed",
                str(seed),
                "--relevance",
                "lexical",
                "--json",
                str(exec_json),
                "--record",
                str(ticks),
                *executive_args,
            ],
            env=env,
            log=tmp_path / "executive.log",
        )
        try:
            rc = executive.wait(timeout=600)
            bridge.wait(timeout=60)
        finally:
            stop(executive, dump_stacks=True)
    finally:
        stop(bridge, dump_stacks=True)
        print((tmp_path / "executive.log").read_text()[-4000:])
        print((tmp_path / "bridge.log").read_text()[-4000:])
    return json.loads(exec_json.read_text()), json.loads(bridge_json.read_text()), rc, ticks


def _assert_the_same_ticks(in_process_ticks: Path, executive_ticks: Path) -> None:
    """The two tick records are the same mission (scripts/compare_tick_records.py names the first
    difference)."""
    compared = subprocess.run(
        [sys.executable, str(COMPARE_RECORDS), str(in_process_ticks), str(executive_ticks)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert compared.returncode == 0, f"not the in-process mission: {compared.stdout}{compared.stderr}"


def _decisions(record: dict[str, Any]) -> list[dict[str, Any]]:
    """The decision log less what only the in-process run knows (the oracle's choice, ground truth)."""
    return [{k: v for k, v in d.items() if k != "oracle_node_id"} for d in record["decisions"]]


@pytest.mark.parametrize(("scene", "seed"), EPISODES)
def test_the_mission_over_ros2_has_the_in_process_outcome(tmp_path: Path, scene: str, seed: int) -> None:
    started = time.monotonic()
    mission = mission_with_budget(tmp_path / "mission", E2E_BUDGET_S)
    in_process, in_process_ticks = _run_in_process(tmp_path, mission, scene, seed)
    # The short budget still covers a decision and the navigation toward it (else the test tests little).
    assert in_process["decisions"] and in_process["path_length_m"] > 0.1, in_process["outcome"]
    in_process_s = time.monotonic() - started
    executive, bridge, rc, executive_ticks = _run_pair(
        tmp_path, mission, scene, seed, domain=fresh_domain_id()
    )
    print(
        {
            "in_process": (in_process["outcome"], in_process["ticks"], in_process["path_length_m"]),
            "ros2": (executive["outcome"], executive["ticks"], executive["path_length_m"]),
            "bridge": (bridge["outcome"], bridge["success"], bridge["path_length_m"]),
            "wall_s": {"in_process": round(in_process_s, 1), "total": round(time.monotonic() - started, 1)},
        }
    )
    # The contract of a mission over ROS 2.
    assert executive["halted_by"] is None and executive["outcome_reported"]
    assert bridge["ended_by"] == "mission_end"
    assert executive["outcome"] == bridge["outcome"]
    assert bridge["success"] == (executive["outcome"] == "success"), "declared and real success differ"
    assert rc == (0 if executive["outcome"] == "success" else 1)
    # The in-process run's mission, tick for tick.
    _assert_the_same_ticks(in_process_ticks, executive_ticks)
    assert executive["outcome"] == in_process["outcome"]
    assert bridge["success"] == in_process["success"]
    assert executive["found_objects"] == in_process["found_objects"]
    assert executive["ticks"] == in_process["ticks"]
    assert executive["sim_time_s"] == in_process["sim_time_s"]
    assert _decisions(executive) == _decisions(in_process)
    # The executive measures the path on odometry, the bridge and the in-process scorer on ground truth.
    assert math.isclose(executive["path_length_m"], in_process["path_length_m"], abs_tol=1e-6)
    assert math.isclose(bridge["path_length_m"], in_process["path_length_m"], abs_tol=1e-6)
    # The bridge stepped ahead while the executive ticked and kept or took back those steps
    # (sims/ros2_bridge.py, Speculation), and the executive took states sent ahead without a wait: all
    # these paths are in the mission compared above.
    speculated = bridge["speculative_steps"]
    assert speculated["kept"] > 0 and speculated["taken_back"] > 0, speculated
    assert 0 < executive["steps_taken_ahead"] <= speculated["kept"], executive["steps_taken_ahead"]


@pytest.mark.parametrize("speculate", [True, False], ids=["speculating", "no-speculation"])
def test_lost_step_replies_are_asked_for_again_and_the_mission_is_unchanged(
    tmp_path: Path, speculate: bool
) -> None:
    # /sim/step and /sim/state are best effort (robots/ros2_backend.py, SIM_STEP_QOS): the bridge leaves
    # the state of every 50th step out, as a lost datagram would, and the executive must ask again and go
    # on with the in-process mission, tick for tick; with the bridge stepping ahead (a resend takes that
    # step back) and without. A state sent ahead and left out is missed only if the executive asks for
    # that step under the same twist; so with the step ahead some losses cost no resend.
    scene, seed = EPISODES[0]
    mission = mission_with_budget(tmp_path / "mission", E2E_BUDGET_S)
    in_process, in_process_ticks = _run_in_process(tmp_path, mission, scene, seed)
    bridge_args = ("--drop-step-replies", "50", *(() if speculate else ("--no-speculation",)))
    executive, bridge, rc, executive_ticks = _run_pair(
        tmp_path, mission, scene, seed, domain=fresh_domain_id(), bridge_args=bridge_args
    )
    replies, speculated = bridge["step_replies"], bridge["speculative_steps"]
    print(
        {
            "step_replies": replies,
            "speculative_steps": speculated,
            "steps_resent": executive["steps_resent"],
            "steps_taken_ahead": executive["steps_taken_ahead"],
            "ticks": executive["ticks"],
        }
    )
    assert (speculated["kept"] > 0) == speculate and (speculated["taken_back"] > 0) == speculate
    assert executive["halted_by"] is None and bridge["ended_by"] == "mission_end"
    assert replies["dropped"] == bridge["steps"] // 50 > 0
    lost = 1 if speculate else replies["dropped"]  # losses the executive must have asked again for
    assert executive["steps_resent"] >= lost
    assert replies["repeated"] >= lost
    _assert_the_same_ticks(in_process_ticks, executive_ticks)
    assert (executive["outcome"], executive["ticks"]) == (in_process["outcome"], in_process["ticks"])
    assert rc == (0 if executive["outcome"] == "success" else 1)


def _profile(tmp_path: Path, **deadlines: float) -> Path:
    """A robot profile whose deadlines are generous but for the ones given (a loaded CI machine must not
    trip another stream first)."""
    streams = ("odom", "imu", "joint_states", "color_image", "color_info", "depth_image", "side_depth")
    values = {stream: deadlines.get(stream, 5.0) for stream in streams}
    path = tmp_path / "robot.yaml"
    path.write_text("deadlines_s: {" + ", ".join(f"{k}: {v}" for k, v in values.items()) + "}\n")
    return path


@pytest.mark.viewer
def test_the_view_of_a_mission_over_ros2_is_saved_as_in_process(tmp_path: Path) -> None:
    """``--view-record`` on the ROS 2 backend: the tree's records of every tick and the world (the pose at
    10 Hz, each perceived frame) in the saved view, under the scene the bridge announced. Needs the viewer
    extra: ``make viewer-test`` runs it in the ROS 2 environment."""
    from semexp_bt.app.viewer import world as entities
    from semexp_bt.app.viewer.recording import open_recording
    from tests.viewer_support import timed_rows, written_at

    scene, seed = EPISODES[0]
    view_dir = tmp_path / "view"
    mission = mission_with_budget(tmp_path / "mission", E2E_BUDGET_S)
    executive, scored, rc, _ = _run_pair(
        tmp_path,
        mission,
        scene,
        seed,
        domain=fresh_domain_id(),
        executive_args=("--view-record", str(view_dir)),
    )
    assert rc in (0, 1) and executive["outcome"] != "halted", executive["halted_by"]
    saved = open_recording(view_dir)
    print(saved.manifest)
    assert saved.complete and saved.world_path is not None
    assert saved.manifest["mission"]["backend"] == "ros2" and saved.manifest["mission"]["scene"] == scene
    assert saved.manifest["title"].startswith(f"{scene} seed {seed} over ROS 2")
    assert saved.manifest["frames"]["dropped"] == 0 and saved.manifest["worker_errors"] == []
    assert [json.loads(line)["tick"] for line in saved.tick_lines] == list(range(1, executive["ticks"] + 1))
    rows = timed_rows(saved.world_path)
    robot = rows[entities.ROBOT]
    assert robot[0] == 0 and robot[-1] == executive["ticks"] and set(np.diff(robot[1:-1])) == {5}
    observed = written_at(saved.tick_lines, "/observation")
    assert observed and rows[entities.CAMERA_RGB] == observed
    # The bridge rendered each perceived frame the view holds (and the planner's depth between them).
    assert scored["ended_by"] == "mission_end" and scored["frames_published"] >= len(observed)


#: The live-view mission's budget (robot seconds; in lockstep 123 s of wall time on the loaded 2-core VM):
#: long enough for Rerun's web viewer to compile on a software rasteriser while the mission still streams.
LIVE_VIEW_BUDGET_S = 300
#: An object no scene holds: the mission searches to its budget, so the page has a running mission to follow.
ABSENT_OBJECT = "find the giraffe"


@pytest.mark.browser
def test_a_browser_follows_the_live_view_of_a_mission_over_ros2(
    tmp_path: Path, browser_context: tuple[Any, list[str]]
) -> None:
    """``run --backend ros2 --view`` with the lockstep bridge: headless Chromium loads the page the
    executive announces, sees the tree follow the running mission under the bridge's scene, and Rerun's
    world view receive the executive's live stream. Needs Chromium and the viewer extras: ``make
    viewer-test`` runs it in the ROS 2 environment, on loopback only. Lockstep, not realtime: the
    browser compiling Rerun's viewer on two cores starves a realtime bridge past the sensor deadlines
    (a first run halted on ``/imu: silent for 0.66 s``), which is the watchdog's job, not this test's."""
    from tests.viewer_support import ARTIFACTS, RERUN_START_S, page_statuses
    from tests.viewer_support import wait_for as wait_in_page

    context, outside = browser_context
    scene, seed = EPISODES[0]
    # BROWSER=true: the executive's "open the page" finds nothing to open; the test's Chromium loads it.
    env = isolated_env(fresh_domain_id(), BROWSER="true")
    mission = mission_with_budget(tmp_path / "mission", LIVE_VIEW_BUDGET_S)
    bridge_log, executive_log, record = (
        tmp_path / "bridge.log",
        tmp_path / "executive.log",
        tmp_path / "run.json",
    )
    bridge = semexp(
        ["sim-bridge", "--scene", scene, "--seed", str(seed), "--max-wall-s", "600"],
        env=env,
        log=bridge_log,
    )
    wait_for_bridge(bridge_log, bridge)
    try:
        executive = semexp(
            ["run", str(mission), "--backend", "ros2", "--seed", str(seed), "--relevance", "lexical",
             "--instruction", ABSENT_OBJECT, "--view", "--json", str(record)],
            env=env,
            log=executive_log,
        )  # fmt: skip
        try:
            announced = wait_for(
                lambda: "view: http" in executive_log.read_text() or executive.poll() is not None,
                timeout_s=120.0,
            )
            match = re.search(r"view: (http://\S+)", executive_log.read_text())
            assert announced and match, executive_log.read_text()[-3000:]
            page = context.new_page()
            page.goto(match.group(1))
            early = wait_in_page(page, "window.semexpView.ticks > 0 && window.semexpView.ticks", 60.0)
            assert page.inner_text("#title").startswith(f"{scene} seed {seed} over ROS 2")
            later = wait_in_page(
                page, f"window.semexpView.ticks > {early} + 100 && window.semexpView.ticks", 60.0
            )
            statuses = page_statuses(page)
            print({name: statuses[name] for name in ("Mission", "Search", "ExploreLoop", "Gait50Hz")})
            assert statuses["Mission"] == "RUNNING" and statuses["Gait50Hz"] == "RUNNING"
            assert page.evaluate("window.semexpView.shownTick") >= later  # following the running mission
            # Rerun receives the live stream over gRPC from the executive's process.
            wait_in_page(
                page, "window.semexpView.rerun.ready && window.semexpView.rerun.time > 100", RERUN_START_S
            )
            ARTIFACTS.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(ARTIFACTS / "viewer-live-ros2.png"))
            assert outside == [], f"the page tried to reach {outside}"
            rc = executive.wait(timeout=LIVE_VIEW_BUDGET_S + 120)
        finally:
            stop(executive, dump_stacks=True)
    finally:
        stop(bridge, dump_stacks=True)
        print(executive_log.read_text()[-3000:])
    result = json.loads(record.read_text())
    assert rc == 1 and result["outcome"] == "budget_exceeded"  # searched for what is not there, to the end
    assert result["ticks"] >= later


@pytest.mark.parametrize(
    ("stream", "deadline_key", "topic"),
    [
        ("color_image", "color_image", "/camera/camera/color/image_raw"),
        ("left_depth_image", "side_depth", "/body_camera/left/depth/image_raw"),
    ],
)
def test_a_silent_camera_zeroes_the_twist_and_halts_the_mission_naming_it(
    tmp_path: Path, stream: str, deadline_key: str, topic: str
) -> None:
    domain = fresh_domain_id()
    env = isolated_env(domain)
    profile = _profile(tmp_path, **{deadline_key: 1.0})
    bridge = semexp(
        [
            "sim-bridge",
            "--scene",
            "showroom",
            "--seed",
            "9",
            "--mode",
            "realtime",
            "--robot-profile",
            str(profile),
            "--silence",
            f"{stream}=15",
            "--max-wall-s",
            "120",
        ],
        env=env,
        log=tmp_path / "bridge.log",
    )
    wait_for_bridge(tmp_path / "bridge.log", bridge)
    spy = CommandSpy(env, tmp_path / "spy.log")
    try:
        executive = semexp(
            [
                "run",
                str(MISSION),
                "--backend",
                "ros2",
                "--seed",
                "9",
                "--relevance",
                "lexical",
                "--robot-profile",
                str(profile),
                "--json",
                str(tmp_path / "executive.json"),
            ],
            env=env,
            log=tmp_path / "executive.log",
        )
        rc = executive.wait(timeout=120)
        log = (tmp_path / "executive.log").read_text()
        print(log[-3000:])
        record = json.loads((tmp_path / "executive.json").read_text())
    finally:
        spy.close()
        stop(bridge)
    assert rc == 3
    assert record["outcome"] == "halted"
    assert record["halted_by"]["topic"] == topic
    assert (
        "silent for" in record["halted_by"]["reason"] and "deadline 1.00 s" in record["halted_by"]["reason"]
    )
    assert f"robot halted: {topic}" in log
    # The halt came about a deadline after the silence began (15 s of the bridge's clock), not later.
    halted_at = record["ros_time_at_start_s"] + record["sim_time_s"]
    assert 15.0 <= halted_at <= 15.0 + 1.0 + 1.0
    assert spy.moving_command_seen()
    assert spy.commands[-1][1:] == (0.0, 0.0)


def test_the_executive_stops_commanding_and_exits_within_2_s_when_the_bridge_dies(tmp_path: Path) -> None:
    domain = fresh_domain_id()
    env = isolated_env(domain)
    bridge = semexp(
        ["sim-bridge", "--scene", "showroom", "--seed", "9", "--max-wall-s", "120"],
        env=env,
        log=tmp_path / "bridge.log",
    )
    wait_for_bridge(tmp_path / "bridge.log", bridge)
    spy = CommandSpy(env, tmp_path / "spy.log")
    try:
        executive = semexp(
            ["run", str(MISSION), "--backend", "ros2", "--seed", "9", "--relevance", "lexical"],
            env=env,
            log=tmp_path / "executive.log",
        )
        assert wait_for(spy.moving_command_seen, timeout_s=90), (tmp_path / "executive.log").read_text()
        bridge.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        rc = executive.wait(timeout=30)
        exited_s = time.monotonic() - killed
        log = (tmp_path / "executive.log").read_text()
        print(log[-2000:], f"exited {exited_s:.2f} s after the bridge was killed")
    finally:
        spy.close()
        bridge.wait(timeout=10)
    # Where a slow exit spent its time: before the halt's closing zero twists, or after them (the teardown).
    last_command_s = spy.commands[-1][0] - killed if spy.commands else math.nan
    print(f"last /cmd_vel {last_command_s:.2f} s after the kill")
    assert rc == 3
    assert exited_s < 2.0, (
        f"exited {exited_s:.2f} s after the kill, the last /cmd_vel at {last_command_s:.2f} s"
    )
    assert "robot halted:" in log and "the simulation bridge fell silent" in log
    # The silence is counted from the bridge's last message as the executive handled it, which on a busy
    # 2-core machine comes a few milliseconds after the kill (its executor thread waits for the GIL): a
    # CI run saw the 25 Hz command timer's last moving command 1.6 ms after the last /odom plus the 1 s
    # deadline, and the halt's zero 0.5 ms later. One wait slice past the deadline covers that handling.
    halted_by = killed + LOCKSTEP_REPLY_MIN_S + WAIT_SLICE_S
    after = [(vx, wz) for t, vx, wz in spy.commands if t > halted_by]
    assert after and all(command == (0.0, 0.0) for command in after)
    assert not [t for t, _, _ in spy.commands if t > killed + exited_s + 0.2]


def test_the_bridge_stops_the_robot_within_half_a_second_when_the_executive_dies(tmp_path: Path) -> None:
    domain = fresh_domain_id()
    env = isolated_env(domain)
    result = tmp_path / "bridge.json"
    bridge = semexp(
        [
            "sim-bridge",
            "--scene",
            "showroom",
            "--seed",
            "9",
            "--mode",
            "realtime",
            "--json",
            str(result),
            "--max-wall-s",
            "120",
        ],
        env=env,
        log=tmp_path / "bridge.log",
    )
    wait_for_bridge(tmp_path / "bridge.log", bridge)
    spy = CommandSpy(env, tmp_path / "spy.log")
    try:
        executive = semexp(
            ["run", str(MISSION), "--backend", "ros2", "--seed", "9", "--relevance", "lexical"],
            env=env,
            log=tmp_path / "executive.log",
        )
        assert wait_for(spy.moving_command_seen, timeout_s=90), (tmp_path / "executive.log").read_text()
        time.sleep(0.3)  # let the base pick up speed
        executive.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        executive.wait(timeout=10)
        # In realtime mode the world lags the wall clock when the machine is loaded (a fresh-clone run had
        # 6.8 s of world time in 9.9 s of wall time), so a fixed wait could end the bridge before 0.4 s of
        # world time had passed: wait for the base to come to rest, then watch it stay there.
        wait_for(lambda: any(t > killed and speed < 1e-6 for t, speed in spy.speeds), timeout_s=30)
        time.sleep(2.0)
    finally:
        spy.close()
        stop(bridge)
    record = json.loads(result.read_text())
    print(record["cmd_vel"], record["ended_by"])
    assert record["ended_by"] == "SIGTERM"
    # The driver's rule: zero motion 0.4 s after the last command, checked every 20 ms control step. (A
    # starved executive on a loaded machine may have tripped it before too: that is the rule working.)
    # Asserted on the world's clock: a loaded machine may stall the control loop, and the world with it.
    timeout = record["cmd_vel"]["timeouts"][-1]
    print(timeout)
    assert timeout["sim_silent_s"] <= 0.5
    # The base then decelerates at its limit (2 m/s^2, 4 rad/s^2) and stays at rest.
    at_rest = [t for t, speed in spy.speeds if t > killed and speed < 1e-6]
    assert at_rest, spy.speeds[-5:]
    print(
        f"at rest {at_rest[0] - killed:.2f} s (wall) after the kill; zeroed after {timeout['silent_s']} s (wall)"
    )
    assert all(speed < 1e-6 for t, speed in spy.speeds if t > at_rest[0])


def test_the_executive_refuses_to_start_without_a_robot(tmp_path: Path) -> None:
    profile = tmp_path / "robot.yaml"
    profile.write_text("deadlines_s: {startup_s: 2.0}\n")
    env = isolated_env(fresh_domain_id())
    out = subprocess.run(
        [
            *semexp_cmd(),
            "run",
            str(MISSION),
            "--backend",
            "ros2",
            "--robot-profile",
            str(profile),
            "--relevance",
            "lexical",
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2
    assert "no message within 2.0 s on /sim/scene (is `semexp-bt sim-bridge` running?)" in out.stderr


def semexp_cmd() -> list[str]:
    return [sys.executable, "-m", "semexp_bt"]
