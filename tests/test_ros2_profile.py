"""The ROS 2 robot profile, the /sim protocol payloads, and the default path's independence from rclpy.

None of this needs rclpy: it runs in the default environment.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from robots.camera import CameraConfig
from robots.go1 import CAMERA_NAME, TRUNK_BODY_NAME
from robots.mujoco_backend import MujocoRobot
from robots.ros2_profile import (
    GO1_PROFILE_PATH,
    ProfileError,
    Ros2Profile,
    load_ros2_profile,
    profile_from_dict,
)
from robots.ros2_sim_protocol import (
    CAMERA_REQUEST_TOPIC,
    OUTCOME_TOPIC,
    STATE_FIELDS,
    STEP_TOPIC,
    CameraRequest,
    Outcome,
    SimProtocolError,
    SimState,
    decode_camera_request,
    decode_outcome,
    decode_simulation_info,
    decode_state,
    encode_camera_request,
    encode_outcome,
    encode_simulation_info,
    encode_state,
)
from robots.side_depth import SideDepthConfig
from semexp_bt.core.types import InvalidInputError, PixelGrid, Pose2D, Twist
from sims.catalogue import build_scene
from sims.ros2_bridge import BridgeOptions, side_depth_config_for

ROOT = Path(__file__).resolve().parents[1]


def _as_nested_dict(value: object) -> object:
    if dataclasses.is_dataclass(value):
        return {f.name: _as_nested_dict(getattr(value, f.name)) for f in dataclasses.fields(value)}
    return value


def test_the_shipped_go1_profile_states_every_key_at_its_default() -> None:
    """The YAML is the user's template: it must show every key, and say what the code defaults to."""
    written = yaml.safe_load(GO1_PROFILE_PATH.read_text())
    defaults = _as_nested_dict(Ros2Profile())
    assert isinstance(defaults, dict)
    defaults.pop("source")
    assert written == defaults
    profile = load_ros2_profile()
    assert profile.source == str(GO1_PROFILE_PATH)
    assert profile.topics.depth_image == "/camera/camera/aligned_depth_to_color/image_raw"
    assert profile.qos.cmd_vel.reliability == "best_effort"
    assert profile.command.driver_timeout_s == 0.4 and profile.command.rate_hz >= 20.0


@pytest.mark.parametrize(
    ("document", "message"),
    [
        ({"topics": {"odm": "/odom"}}, "unknown key 'topics.odm'"),
        ({"topics": {"odom": "odom"}}, "key 'topics.odom' must be an absolute topic name"),
        ({"topics": {"odom": 5}}, "key 'topics.odom' must be a non-empty string"),
        ({"frames": {"base": ""}}, "key 'frames.base' must be a non-empty string"),
        ({"qos": {"odom": {"reliability": "sure"}}}, "key 'qos.odom.reliability' must be one of"),
        ({"qos": {"odom": {"depth": 0}}}, "key 'qos.odom.depth' must lie in"),
        ({"deadlines_s": {"color_image": 0}}, "key 'deadlines_s.color_image' must lie in"),
        ({"command": {"rate_hz": 10}}, "key 'command.rate_hz' must lie in [20.0"),
        ({"camera": {"mount": {"pitch_rad": "down"}}}, "key 'camera.mount.pitch_rad' must be a number"),
        (
            {"side_depth": {"left": {"image": "depth"}}},
            "key 'side_depth.left.image' must be an absolute topic",
        ),
        ({"side_depth": {"right": {"frame": ""}}}, "key 'side_depth.right.frame' must be a non-empty string"),
        ({"side_depth": {"enabled": "yes"}}, "key 'side_depth.enabled' must be"),
        ({"side_depth": {"middle": {}}}, "unknown key 'side_depth.middle'"),
        ({"source": "x"}, "unknown key 'source'"),
        (["not", "a", "mapping"], "'<root>' must be a mapping"),
    ],
)
def test_a_bad_profile_key_is_named_with_its_file(document: object, message: str) -> None:
    with pytest.raises(ProfileError) as error:
        profile_from_dict(document, where="my_robot.yaml")
    print(error.value)
    assert str(error.value).startswith("my_robot.yaml: ")
    assert message in str(error.value)


def test_a_profile_file_that_is_not_yaml_names_its_line(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text("topics:\n  odom: /odom\n  imu: [unclosed\n")
    with pytest.raises(ProfileError, match=r"robot profile .*robot\.yaml:\d+:\d+: YAML syntax error"):
        load_ros2_profile(path)
    with pytest.raises(ProfileError, match=r"robot profile .*missing\.yaml: not found"):
        load_ros2_profile(tmp_path / "missing.yaml")


def test_a_partial_profile_keeps_the_defaults_of_what_it_does_not_state(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text("topics: {cmd_vel: /go1/cmd_vel}\ndeadlines_s: {odom: 0.2}\n")
    profile = load_ros2_profile(path)
    assert profile.topics.cmd_vel == "/go1/cmd_vel" and profile.deadline_of("odom") == 0.2
    assert profile.topics.odom == "/odom" and profile.deadline_of("imu") == 0.5


def test_the_profile_mount_places_the_optical_frame_where_the_simulated_camera_is() -> None:
    """One camera, two descriptions: the profile's mount (REP-103 optical frame on camera_link) and the
    MuJoCo head camera (robots/camera.py). The bridge builds its camera from the profile, and the shipped
    defaults must describe the camera the in-process runs use."""
    profile = load_ros2_profile()
    mount = profile.camera.mount
    sim = CameraConfig()
    assert (mount.x_m, mount.y_m, mount.z_m) == sim.mount_position_m
    assert math.isclose(math.degrees(mount.pitch_rad), sim.mount_pitch_down_deg, abs_tol=1e-12)
    robot = MujocoRobot(
        scene=build_scene("showroom", seed=0), fidelity="kinematic", start_pose=Pose2D(1.0, 2.0, 0.7), seed=0
    )
    try:
        data, model = robot.data, robot.model
        trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, TRUNK_BODY_NAME)
        base_to_world = np.eye(4)
        base_to_world[:3, :3] = data.xmat[trunk].reshape(3, 3)
        base_to_world[:3, 3] = data.xpos[trunk]
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA_NAME)
        assert camera >= 0
        simulated = robot.observe_depth(pixel_grids=[PixelGrid(stride=40)]).camera_to_world
    finally:
        robot.close()
    from_profile = base_to_world @ profile.optical_to_base()
    print(np.round(from_profile, 6))
    np.testing.assert_allclose(from_profile, simulated, atol=1e-6)


def test_the_profile_side_mounts_place_the_flank_cameras_where_the_simulated_ones_are() -> None:
    profile = load_ros2_profile()
    simulated = SideDepthConfig()
    for side in ("left", "right"):
        np.testing.assert_array_equal(profile.side_optical_to_base(side), simulated.optical_to_base(side))
    assert side_depth_config_for(profile) == simulated
    assert profile.topic_of("right_depth_info") == "/body_camera/right/depth/camera_info"
    assert profile.deadline_of("left_depth_image") == profile.deadlines_s.side_depth
    assert not profile.side_depth.enabled, "the unitree_ros driver does not publish the body cameras"


def test_the_bridge_refuses_flank_mounts_it_cannot_simulate() -> None:
    lopsided = profile_from_dict({"side_depth": {"right": {"mount": {"y_m": -0.1}}}}, where="my_robot.yaml")
    with pytest.raises(
        InvalidInputError, match=r"my_robot.yaml: .*'side_depth.left.mount' and 'side_depth.right.mount'"
    ):
        side_depth_config_for(lopsided)


def test_the_bridge_refuses_to_silence_what_it_cannot_silence() -> None:
    with pytest.raises(InvalidInputError, match=r"cannot silence \['gps'\]; streams: odom, imu"):
        BridgeOptions(scene="showroom", seed=0, silence={"gps": 1.0})
    # In lockstep the IMU and the joints ride on /sim/state: silencing them alone would do nothing.
    with pytest.raises(
        InvalidInputError, match=r"cannot silence \['imu'\] in lockstep: they ride on /sim/state"
    ):
        BridgeOptions(scene="showroom", seed=0, silence={"imu": 1.0, "odom": 2.0})
    assert BridgeOptions(scene="showroom", seed=0, mode="realtime", silence={"imu": 1.0}).silence == {
        "imu": 1.0
    }


def test_the_scene_announcement_withholds_where_things_are() -> None:
    scene = build_scene("showroom", seed=9)
    info = decode_simulation_info(
        encode_simulation_info(scene, mode="lockstep", control_period_s=0.02, seed=9, side_depth=True)
    )
    assert info.mode == "lockstep" and info.seed == 9 and info.control_period_s == 0.02
    assert info.side_depth
    assert [o.object_id for o in info.scene.objects] == [o.object_id for o in scene.objects]
    assert [(o.label, o.category, o.role, o.size_m) for o in info.scene.objects] == [
        (o.label, o.category, o.role, o.size_m) for o in scene.objects
    ]
    assert all(o.position_m == (0.0, 0.0, 0.0) and o.yaw_rad == 0.0 for o in info.scene.objects)
    assert info.scene.bounds_m == (0.0, 0.0, 0.0, 0.0)
    assert info.scene.goal.label == scene.goal.label and info.scene.instruction == scene.instruction


def test_camera_requests_and_outcomes_round_trip_and_bad_payloads_are_named() -> None:
    request = CameraRequest(kind="depth", grids=(PixelGrid(stride=8, offset=4), PixelGrid(stride=4)))
    assert decode_camera_request(encode_camera_request(request)) == request
    side = CameraRequest(kind="side", grids=(PixelGrid(stride=4, offset=2),), at_ns=83_660_000_000)
    assert decode_camera_request(encode_camera_request(side)) == side
    assert decode_camera_request(encode_camera_request(CameraRequest(kind="full"))) == CameraRequest(
        kind="full"
    )
    found = [{"label": "chair", "position_m": [1.0, 2.0, 0.5], "robot_xy": [0.5, 1.5]}]
    outcome = Outcome("success", found, at_ns=20_000_000)
    assert decode_outcome(encode_outcome(outcome)) == outcome
    assert decode_outcome(encode_outcome(Outcome("budget_exceeded", []))).at_ns is None
    for text, topic in [
        ("{", "/sim/camera/request: not JSON"),
        ('{"kind": "half"}', "/sim/camera/request: field 'kind'"),
        ('{"kind": "depth", "grids": [[4]]}', "/sim/camera/request: field 'grids'"),
        ('{"kind": "full", "at_ns": -1}', "/sim/camera/request: field 'at_ns'"),
        ('{"kind": "full", "at_ns": 0.5}', "/sim/camera/request: field 'at_ns'"),
    ]:
        with pytest.raises(SimProtocolError, match=topic):
            decode_camera_request(text)
    with pytest.raises(SimProtocolError, match="/sim/outcome: each found object needs 'position_m'"):
        decode_outcome('{"outcome": "success", "found_objects": [{"label": "x"}]}')
    with pytest.raises(SimProtocolError, match="/sim/outcome: field 'at_ns'"):
        decode_outcome('{"outcome": "success", "found_objects": [], "at_ns": true}')
    with pytest.raises(SimProtocolError, match="/sim/scene: missing field 'scene'"):
        decode_simulation_info('{"mode": "lockstep", "control_period_s": 0.02, "seed": 1}')


def test_a_step_state_round_trips_to_the_bit_and_bad_payloads_are_named() -> None:
    # A float clock that is not the stamp's rounding, and pose values with every bit significant.
    state = SimState(
        stamp_ns=599_980_000_000,
        sim_time_s=sum([0.02] * 29_999),
        position_m=(1.0 / 3.0, -2.0 / 7.0, 0.27),
        orientation_xyzw=(0.0, 0.0, math.sin(0.1), math.cos(0.1)),
        twist=Twist(0.3, -1e-17, 0.7),
        step_twist=Twist(0.25, -0.0, 1.0 / 3.0),
        from_ns=599_960_000_000,
        imu=(math.cos(0.1), 0.0, 0.0, math.sin(0.1), 1e-3 / 3, 0.0, -0.2, 0.01, -0.02, 9.81),
        joint_position_rad=(0.1, 0.8 / 3, -1.5),
        joint_velocity_radps=(0.0, -1e-9, 2.0 / 3),
    )
    values = encode_state(state)
    assert len(values) == len(STATE_FIELDS) + 2 * 3
    decoded = decode_state(values, joints=3)
    print(decoded)
    assert decoded == state
    imu = decoded.imu_reading()
    assert imu.orientation_wxyz.tolist() == list(state.imu[:4])
    assert imu.linear_acceleration_mps2.tolist() == list(state.imu[7:])
    assert decoded.joint_state().velocity_radps.tolist() == list(state.joint_velocity_radps)
    with pytest.raises(SimProtocolError, match=r"/sim/state: expected 32 values \(26 and 3 joints"):
        decode_state(values[:-1], joints=3)
    with pytest.raises(SimProtocolError, match="/sim/state: field 'orientation_w' must be finite"):
        decode_state([*values[:8], math.nan, *values[9:]], joints=3)
    with pytest.raises(SimProtocolError, match="/sim/state: field 'imu_linear_acceleration_z_mps2' must be"):
        decode_state([*values[:25], math.inf, *values[26:]], joints=3)
    with pytest.raises(SimProtocolError, match="/sim/state: field 'joint value 4' must be finite"):
        decode_state([*values[:30], math.nan, *values[31:]], joints=3)
    with pytest.raises(SimProtocolError, match="not exact in a float64"):
        encode_state(dataclasses.replace(state, stamp_ns=2**53))
    with pytest.raises(SimProtocolError, match="as many joint velocities as positions"):
        encode_state(dataclasses.replace(state, joint_velocity_radps=(0.0,)))


def test_the_default_path_never_imports_rclpy() -> None:
    """`semexp-bt --help`, `run --help` and building the component tables load no ROS library."""
    probe = (
        "import sys, contextlib, io\n"
        "from semexp_bt.cli import main\n"
        "import semexp_bt.app.components, semexp_bt.cli.run, semexp_bt.cli.sim_bridge\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    for argv in (['--help'], ['run', '--help']):\n"
        "        try:\n"
        "            main(argv)\n"
        "        except SystemExit:\n"
        "            pass\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'rosidl_parser', 'sensor_msgs')))\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_the_bridge_reads_what_the_executive_sends_on_udp_only() -> None:
    # The loopback profile gives the bridge's readers of the executive's topics a UDP locator of their own,
    # so that a killed bridge's shared-memory port cannot stall the executive's publishes
    # (scripts/fastdds_loopback.xml; docs/ros2.md, "What the watchdogs do"). A topic added on that side
    # without its profile would bring the stall back.
    import xml.etree.ElementTree as ET

    namespace = {"p": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}
    profiles = ET.parse(ROOT / "scripts" / "fastdds_loopback.xml").getroot()
    udp_only = {}
    for reader in profiles.findall("p:data_reader", namespace):
        addresses = [
            a.text for a in reader.findall("p:unicastLocatorList/p:locator/p:udpv4/p:address", namespace)
        ]
        kinds = [
            child.tag.split("}")[1] for child in reader.findall("p:unicastLocatorList/p:locator/*", namespace)
        ]
        udp_only[reader.get("profile_name")] = addresses == ["127.0.0.1"] and kinds == ["udpv4"]
    print(udp_only)
    sent_to_the_bridge = {
        STEP_TOPIC,
        CAMERA_REQUEST_TOPIC,
        OUTCOME_TOPIC,
        load_ros2_profile(None).topics.cmd_vel,
    }
    assert {topic for topic, only in udp_only.items() if only} == sent_to_the_bridge
