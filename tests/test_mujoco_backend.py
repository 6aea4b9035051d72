"""The MuJoCo backend: camera model, depth and segmentation, kinematic base, collisions, determinism."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.camera import CameraConfig, depth_from_reversed_z
from robots.go1 import load_go1_spec
from robots.interface import Fidelity
from robots.mjcf_scene import build_mjcf, geom_object_ids, object_id_from_geom_name
from robots.mujoco_backend import BaseMotionLimits, MujocoRobot
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import BACKGROUND_OBJECT_ID, InvalidInputError, PixelGrid, Pose2D, Twist
from sims.catalogue import build_scene
from sims.episodes import sample_episode

LEVEL_CAMERA = CameraConfig(mount_pitch_down_deg=0.0)
BOX_ID = 7
WALL_ID = 3
RUG_ID = 9


def make_scene(*, box_face_x_m: float = 3.0, wall_x_m: float | None = None) -> SceneSpec:
    """A tall box straight ahead of the origin (face at ``box_face_x_m``), an optional wall, a rug."""
    objects = [
        SceneObject(
            object_id=BOX_ID,
            name="box_7",
            label="cabinet",
            category="cabinet",
            shape="box",
            position_m=(box_face_x_m + 0.25, 0.0, 1.5),
            size_m=(0.25, 0.6, 1.5),
            rgba=(0.8, 0.2, 0.2, 1.0),
            parts=(("cylinder", -0.1, 0.0, 1.6, 0.1, 0.1, 0.1, 0.1, 0.1, 0.9, 1.0),),
        ),
        SceneObject(
            object_id=RUG_ID,
            name="rug_9",
            label="rug",
            category="rug",
            shape="box",
            position_m=(1.0, 1.0, 0.005),
            size_m=(0.5, 0.5, 0.005),
            is_obstacle=False,
            role="clutter",
        ),
    ]
    if wall_x_m is not None:
        objects.append(
            SceneObject(
                object_id=WALL_ID,
                name="wall_3",
                label="wall",
                category="wall",
                shape="box",
                position_m=(wall_x_m + 0.05, 0.0, 1.0),
                size_m=(0.05, 3.0, 1.0),
                role="wall",
            )
        )
    return SceneSpec(
        name="tiny",
        title="Tiny",
        seed=0,
        bounds_m=(-4.0, -4.0, 8.0, 4.0),
        objects=tuple(objects),
        goal_object_id=BOX_ID,
        instruction="find the cabinet",
    )


@pytest.fixture(scope="module")
def level_robot() -> MujocoRobot:
    robot = MujocoRobot(
        scene=make_scene(),
        fidelity="kinematic",
        start_pose=Pose2D(0.0, 0.0, 0.0),
        seed=0,
        camera=LEVEL_CAMERA,
    )
    yield robot
    robot.close()


# ---------------------------------------------------------------- camera model


def test_default_camera_is_a_d435i_colour_stream_rendered_at_half_size() -> None:
    config = CameraConfig()
    native = CameraConfig(downscale=1).intrinsics()
    half = config.intrinsics()
    assert (half.width_px, half.height_px) == (320, 240)
    # D435i colour at 640x480: fx = fy of about 615 px, 42.5 x 55 deg.
    assert native.fy_px == pytest.approx(240.0 / math.tan(math.radians(42.5 / 2.0)))
    assert native.fx_px == pytest.approx(615.0, abs=3.0)
    horizontal_fov = 2.0 * math.degrees(math.atan(native.width_px / 2.0 / native.fx_px))
    assert horizontal_fov == pytest.approx(54.9, abs=0.2)
    assert half.fx_px == pytest.approx(native.fx_px / 2.0)
    assert (half.cx_px, half.cy_px) == (159.5, 119.5)


@given(downscale=st.sampled_from([1, 2, 4, 5, 8, 10, 16, 20]), fov=st.floats(20.0, 100.0))
def test_intrinsics_scale_with_the_downscale_and_reproduce_the_fov(downscale: int, fov: float) -> None:
    config = CameraConfig(downscale=downscale, vertical_fov_deg=fov)
    k = config.intrinsics()
    native = CameraConfig(downscale=1, vertical_fov_deg=fov).intrinsics()
    assert k.fy_px * downscale == pytest.approx(native.fy_px)
    assert 2.0 * math.degrees(math.atan(k.height_px / 2.0 / k.fy_px)) == pytest.approx(fov)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("downscale", 3),
        ("downscale", 0),
        ("vertical_fov_deg", float("nan")),
        ("min_depth_m", 20.0),
        ("mount_pitch_down_deg", 95.0),
    ],
)
def test_bad_camera_config_names_the_field(field: str, value: float) -> None:
    with pytest.raises(InvalidInputError, match=field.split("_")[0]):
        CameraConfig(**{field: value})


def test_reversed_z_depth_maps_near_to_near_and_far_to_far() -> None:
    depth = depth_from_reversed_z(np.array([1.0, 0.0, 0.5], dtype=np.float32), near_m=0.1, far_m=10.0)
    assert depth[0] == pytest.approx(0.1)
    assert depth[1] == pytest.approx(10.0)
    assert depth[2] == pytest.approx(0.1 * 10.0 / (0.1 + 0.5 * 9.9))


# ---------------------------------------------------------------- rendering


def test_depth_at_the_image_centre_is_the_distance_to_the_box_face(level_robot: MujocoRobot) -> None:
    obs = level_robot.observe()
    camera_x = obs.camera_to_world[0, 3]
    expected = 3.0 - camera_x  # box face at x = 3, optical axis along +x
    centre = obs.depth_m[119:121, 159:161]
    np.testing.assert_allclose(centre, expected, atol=0.01)
    # Depth is along the optical axis, not the ray: the whole flat face reads the same.
    face = obs.depth_m[obs.segmentation == BOX_ID]
    assert face.size > 1000
    assert np.percentile(np.abs(face - expected), 95) < 0.01


def test_segmentation_labels_the_object_ahead_and_the_floor_as_background(level_robot: MujocoRobot) -> None:
    obs = level_robot.observe()
    seg = obs.segmentation
    assert seg is not None and seg.dtype == np.int32 and seg.shape == (240, 320)
    assert seg[120, 160] == BOX_ID
    assert seg[-1, 160] == BACKGROUND_OBJECT_ID  # the floor just ahead of the robot
    assert set(np.unique(seg)) == {BOX_ID, RUG_ID, BACKGROUND_OBJECT_ID}
    # The rug lies ahead-left (world +y): it shows in the left half of the image, below the horizon.
    rug_rows, rug_cols = np.nonzero(seg == RUG_ID)
    assert rug_cols.max() < 160 and rug_rows.min() > 120
    # Background beyond the depth range (the black sky above the box's sides is out of range) reads 0.
    assert np.all(obs.depth_m[seg == BOX_ID] > 0.3)


def test_observation_fields_and_camera_pose(level_robot: MujocoRobot) -> None:
    obs = level_robot.observe()
    assert obs.rgb.shape == (240, 320, 3) and obs.rgb.dtype == np.uint8
    assert obs.depth_m.shape == (240, 320) and obs.depth_m.dtype == np.float32
    assert obs.stamp_s == level_robot.now_s()
    assert obs.intrinsics == LEVEL_CAMERA.intrinsics()
    rotation = obs.camera_to_world[:3, :3]
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-9)
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    # Optical frame: z forward (world +x at yaw 0), x right (world -y), y down (world -z).
    np.testing.assert_allclose(rotation[:, 2], [1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(rotation[:, 0], [0, -1, 0], atol=1e-9)
    np.testing.assert_allclose(rotation[:, 1], [0, 0, -1], atol=1e-9)
    spec = load_go1_spec()
    np.testing.assert_allclose(obs.camera_to_world[:3, 3], [0.28, 0.0, spec.standing_trunk_height_m + 0.05])
    # The box is red: the centre pixel is mostly red.
    red, green, blue = (int(c) for c in obs.rgb[120, 160])
    assert red > 2 * green and red > 2 * blue
    assert np.all(obs.depth_m[obs.depth_m > 0] <= 10.0)


def test_pitched_camera_back_projects_onto_the_box_face() -> None:
    """Every box pixel, lifted with K and T_w<-c, lands on the face plane x = 3 (end-to-end convention check)."""
    robot = MujocoRobot(
        scene=make_scene(),
        fidelity="kinematic",
        start_pose=Pose2D(0.0, 0.0, 0.0),
        seed=0,
        camera=CameraConfig(),
    )
    try:
        obs = robot.observe()
    finally:
        robot.close()
    rows, cols = np.nonzero((obs.segmentation == BOX_ID) & (obs.depth_m > 0))
    assert rows.size > 1000
    k = obs.intrinsics
    z = obs.depth_m[rows, cols].astype(float)
    points_camera = np.stack(
        [(cols - k.cx_px) / k.fx_px * z, (rows - k.cy_px) / k.fy_px * z, z, np.ones_like(z)]
    )
    points_world = obs.camera_to_world @ points_camera
    front = points_world[0] < 3.02  # the cylinder part on top sits behind the face
    assert front.mean() > 0.95
    np.testing.assert_allclose(points_world[0][front], 3.0, atol=0.02)
    assert np.all(np.abs(points_world[1][front]) <= 0.62)


def test_geom_names_carry_object_ids_and_rugs_do_not_collide() -> None:
    model = mujoco.MjModel.from_xml_string(build_mjcf(make_scene(), fidelity="dynamic"))
    ids = geom_object_ids(model)
    assert ids[model.geom("obj7_0").id] == BOX_ID
    assert ids[model.geom("obj7_1").id] == BOX_ID
    assert ids[model.geom("floor").id] == BACKGROUND_OBJECT_ID
    assert ids[model.geom("FR_foot").id] == BACKGROUND_OBJECT_ID
    assert model.geom_conaffinity[model.geom("obj9_0").id] == 0
    assert object_id_from_geom_name("obj12_3") == 12 and object_id_from_geom_name("objx_1") is None


def test_malformed_scene_object_is_reported_by_name() -> None:
    bad = SceneObject(
        object_id=1,
        name="blob_1",
        label="blob",
        category="blob",
        shape="sphere",  # type: ignore[arg-type]
        position_m=(1.0, 0.0, 0.5),
        size_m=(0.1, 0.1, 0.1),
    )
    scene = SceneSpec(
        name="bad",
        title="Bad",
        seed=0,
        bounds_m=(-1, -1, 1, 1),
        objects=(bad,),
        goal_object_id=1,
        instruction="",
    )
    with pytest.raises(ValueError, match="blob_1"):
        build_mjcf(scene, fidelity="kinematic")
    with pytest.raises(ValueError, match="fidelity"):
        build_mjcf(scene, fidelity="wheeled")  # type: ignore[arg-type]


# ---------------------------------------------------------------- kinematic base


def make_kinematic(**kwargs: object) -> MujocoRobot:
    return MujocoRobot(
        scene=kwargs.pop("scene", make_scene(box_face_x_m=6.0)),  # type: ignore[arg-type]
        fidelity="kinematic",
        start_pose=kwargs.pop("start_pose", Pose2D(0.0, 0.0, 0.0)),  # type: ignore[arg-type]
        seed=int(kwargs.pop("seed", 0)),  # type: ignore[arg-type]
        **kwargs,  # type: ignore[arg-type]
    )


def test_kinematic_base_drives_about_one_metre_in_two_seconds_at_half_a_metre_per_second() -> None:
    robot = make_kinematic()
    robot.command_twist(Twist(0.5, 0.0, 0.0))
    robot.advance(2.0)
    # 50 Hz steps, 2 m/s^2: v = 0.04, 0.08, ..., 0.48 for 12 steps, then 0.5 for 88 steps.
    expected = 0.02 * (0.04 * sum(range(1, 13)) + 0.5 * 88)
    pose = robot.base_pose()
    assert pose.x_m == pytest.approx(expected, abs=1e-9)
    assert pose.x_m == pytest.approx(0.94, abs=0.01)
    assert (pose.y_m, pose.yaw_rad) == (0.0, 0.0)
    assert robot.now_s() == pytest.approx(2.0)
    assert robot.base_twist() == Twist(0.5, 0.0, 0.0)
    assert robot.safety().events == []


def test_kinematic_base_clamps_speed_and_turns_its_heading() -> None:
    robot = make_kinematic()
    robot.command_twist(Twist(3.0, -2.0, 4.0))
    robot.advance(1.0)
    assert robot.base_twist() == Twist(1.0, -0.5, 1.5)
    robot.command_twist(Twist(0.0, 0.0, 0.0))
    robot.advance(1.0)
    robot.command_twist(Twist(0.0, 0.0, 1.0))
    robot.advance(1.0)
    robot.stop()
    robot.advance(1.0)
    assert robot.base_twist() == Twist.zero()
    # Turning a quarter turn, then driving forward moves the base along world +y.
    start = make_kinematic(start_pose=Pose2D(0.0, 0.0, math.pi / 2))
    start.command_twist(Twist(0.5, 0.0, 0.0))
    start.advance(1.0)
    pose = start.base_pose()
    assert pose.x_m == pytest.approx(0.0, abs=1e-9) and pose.y_m > 0.4


def test_kinematic_imu_reads_yaw_rate_and_gravity() -> None:
    robot = make_kinematic()
    robot.command_twist(Twist(0.0, 0.0, 1.0))
    robot.advance(1.0)
    imu = robot.imu()
    assert imu.angular_velocity_radps[2] == pytest.approx(1.0, abs=0.03)
    assert imu.linear_acceleration_mps2[2] == pytest.approx(9.81, abs=0.2)
    yaw = robot.base_pose().yaw_rad
    np.testing.assert_allclose(imu.orientation_wxyz, [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)])


def test_driving_into_a_wall_stops_at_the_wall_and_records_one_collision() -> None:
    robot = make_kinematic(scene=make_scene(box_face_x_m=6.0, wall_x_m=2.0), clearance_m=0.1)
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    front_m = 0.29  # the head housing's front face, in the trunk frame
    for _ in range(200):  # 4 s, far more than the 2 m to the wall
        robot.advance(0.02)
        assert robot.base_pose().x_m + front_m <= 2.0 + 1e-4  # contact tolerance of the kinematic base
    assert robot.base_pose().x_m + front_m == pytest.approx(2.0, abs=0.02)
    assert robot.base_twist().linear_x_mps < 0.1
    safety = robot.safety()
    kinds = [(event.kind, event.object_id) for event in safety.events]
    assert kinds == [("clearance", WALL_ID), ("collision", WALL_ID)]
    clearance, collision = safety.events
    assert 0.0 < clearance.distance_m < 0.1 and clearance.stamp_s < collision.stamp_s
    assert collision.distance_m <= 0.0
    assert 0.0 <= safety.min_clearance_m < 0.02
    assert not safety.fallen
    # Backing away is allowed; coming back is a second collision.
    robot.command_twist(Twist(-0.5, 0.0, 0.0))
    robot.advance(1.0)
    assert robot.safety().min_clearance_m > 0.2
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    robot.advance(2.0)
    assert [e.kind for e in robot.safety().events] == ["clearance", "collision", "clearance", "collision"]


def test_rugs_are_driven_over_without_events() -> None:
    robot = make_kinematic(start_pose=Pose2D(0.0, 1.0, 0.0))
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    robot.advance(2.0)
    assert robot.base_pose().x_m > 1.5
    assert robot.safety().events == []


def test_same_seed_same_run_and_different_seed_different_imu_noise() -> None:
    def run(seed: int) -> tuple[Pose2D, np.ndarray, np.ndarray]:
        robot = make_kinematic(seed=seed, scene=make_scene(box_face_x_m=3.0))
        robot.command_twist(Twist(0.6, 0.1, 0.3))
        robot.advance(1.5)
        gyro = robot.imu().angular_velocity_radps
        rgb = robot.observe().rgb
        robot.close()
        return robot.base_pose(), gyro, rgb

    pose_a, gyro_a, rgb_a = run(3)
    pose_b, gyro_b, rgb_b = run(3)
    _, gyro_c, _ = run(4)
    assert pose_a == pose_b
    np.testing.assert_array_equal(gyro_a, gyro_b)
    np.testing.assert_array_equal(rgb_a, rgb_b)
    assert not np.array_equal(gyro_a, gyro_c)


@settings(max_examples=25, deadline=None)
@given(steps=st.lists(st.floats(0.0, 0.1), min_size=1, max_size=20))
def test_clock_accumulates_requested_durations(steps: list[float]) -> None:
    robot = make_kinematic()
    for duration in steps:
        robot.advance(duration)
    assert robot.now_s() == pytest.approx(sum(steps), abs=0.002)


def test_bad_commands_raise_naming_the_input() -> None:
    robot = make_kinematic()
    with pytest.raises(InvalidInputError, match="twist"):
        robot.command_twist(Twist(float("nan"), 0.0, 0.0))
    with pytest.raises(InvalidInputError, match="duration_s"):
        robot.advance(-1.0)
    with pytest.raises(InvalidInputError, match="targets_rad"):
        robot.command_joint_targets(np.zeros(11))
    with pytest.raises(InvalidInputError, match="start_pose"):
        make_kinematic(start_pose=Pose2D(float("inf"), 0.0, 0.0))
    with pytest.raises(InvalidInputError, match="control_dt_s"):
        make_kinematic(control_dt_s=0.003)
    with pytest.raises(InvalidInputError, match="max_forward_mps"):
        BaseMotionLimits(max_forward_mps=-1.0)
    with pytest.raises(ValueError, match="fidelity"):
        MujocoRobot(scene=make_scene(), fidelity="wheeled", start_pose=Pose2D(0, 0, 0), seed=0)  # type: ignore[arg-type]
    assert robot.joint_state().position_rad.shape == (12,)


# ---------------------------------------------------------------- dynamic Go1


def test_dynamic_go1_stands_and_sees_what_the_kinematic_base_sees() -> None:
    robot = MujocoRobot(
        scene=make_scene(), fidelity="dynamic", start_pose=Pose2D(0.5, -0.2, 0.3), seed=0, camera=LEVEL_CAMERA
    )
    try:
        assert robot.now_s() == 0.0
        robot.command_twist(Twist(0.5, 0.0, 0.0))  # stored for the gait; nobody walks yet
        assert robot.commanded_twist == Twist(0.5, 0.0, 0.0)
        robot.advance(1.0)
        pose = robot.base_pose()
        assert pose.x_m == pytest.approx(0.5, abs=0.02) and pose.y_m == pytest.approx(-0.2, abs=0.02)
        assert pose.yaw_rad == pytest.approx(0.3, abs=0.02)
        state = robot.joint_state()
        np.testing.assert_allclose(state.position_rad, load_go1_spec().standing_pose_rad, atol=0.25)
        assert np.abs(state.velocity_radps).max() < 0.05
        imu = robot.imu()
        assert np.linalg.norm(imu.linear_acceleration_mps2) == pytest.approx(9.81, abs=0.3)
        safety = robot.safety()
        assert safety.fallen is False and safety.events == []
        obs = robot.observe()
        spec = load_go1_spec()
        camera_height = obs.camera_to_world[2, 3]
        assert camera_height == pytest.approx(spec.standing_trunk_height_m + 0.05, abs=0.02)
        assert obs.segmentation is not None and obs.segmentation[120, 160] == BOX_ID
    finally:
        robot.close()


def test_dynamic_go1_tipped_over_is_fallen() -> None:
    robot = MujocoRobot(scene=make_scene(), fidelity="dynamic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0)
    robot.data.qpos[3:7] = [math.cos(0.6), math.sin(0.6), 0.0, 0.0]  # rolled by 1.2 rad
    robot.advance(0.02)
    assert robot.safety().fallen


def test_dynamic_joint_targets_drive_the_actuators_within_limits() -> None:
    robot = MujocoRobot(scene=make_scene(), fidelity="dynamic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0)
    targets = load_go1_spec().standing_pose_rad.copy()
    targets[2] = -5.0  # beyond the knee range: clipped
    robot.command_joint_targets(targets)
    assert robot.data.ctrl[2] == pytest.approx(-2.818)
    robot.stop()
    np.testing.assert_allclose(robot.data.ctrl, load_go1_spec().standing_pose_rad)


def test_dynamic_go1_near_a_wall_reports_clearance_from_the_start() -> None:
    # Head front (x = +0.29 in the trunk frame) 5 cm from the wall face at x = 2.
    robot = MujocoRobot(
        scene=make_scene(box_face_x_m=6.0, wall_x_m=2.0),
        fidelity="dynamic",
        start_pose=Pose2D(2.0 - 0.29 - 0.05, 0.0, 0.0),
        seed=0,
        clearance_m=0.1,
    )
    robot.advance(0.1)
    safety = robot.safety()
    assert [(e.kind, e.object_id, e.stamp_s) for e in safety.events] == [("clearance", WALL_ID, 0.0)]
    assert safety.min_clearance_m == pytest.approx(0.05, abs=0.015)


def test_kinematic_base_started_inside_a_wall_may_back_out_but_not_go_deeper() -> None:
    robot = make_kinematic(
        scene=make_scene(box_face_x_m=6.0, wall_x_m=2.0), start_pose=Pose2D(1.75, 0.0, 0.0)
    )
    assert robot.safety().min_clearance_m < 0.0
    assert [e.kind for e in robot.safety().events] == ["clearance", "collision"]
    robot.command_twist(Twist(0.5, 0.0, 0.0))
    robot.advance(0.5)
    assert robot.base_pose().x_m == pytest.approx(1.75)
    robot.command_twist(Twist(-0.5, 0.0, 0.0))
    robot.advance(1.0)
    safety = robot.safety()
    assert robot.base_pose().x_m < 1.4 and safety.min_clearance_m > 0.0
    assert safety.least_clearance_m < 0.0  # the episode's least is kept after backing out


def test_outdoor_sky_is_background_with_no_depth() -> None:
    scene = make_scene()
    outdoor = SceneSpec(**{**vars(scene), "outdoor": True})
    robot = MujocoRobot(scene=outdoor, fidelity="kinematic", start_pose=Pose2D(0, 0, math.pi), seed=0)
    try:
        obs = robot.observe()
    finally:
        robot.close()
    # Looking away from the box: the top rows are sky, lit (not the black clear colour), no depth, no id.
    sky = obs.rgb[:10].reshape(-1, 3).mean(axis=0)
    assert sky[2] > 100
    assert np.all(obs.depth_m[:10] == 0.0)
    assert np.all(obs.segmentation[:10] == BACKGROUND_OBJECT_ID)


def test_depth_only_observation_matches_the_full_one_and_teleport_moves_the_view(
    level_robot: MujocoRobot,
) -> None:
    full = level_robot.observe()
    depth_only = level_robot.observe_depth()
    assert depth_only.rgb.size == 0 and depth_only.segmentation is None
    np.testing.assert_array_equal(depth_only.depth_m, full.depth_m)
    np.testing.assert_array_equal(depth_only.camera_to_world, full.camera_to_world)
    clock = level_robot.now_s()
    level_robot.teleport(Pose2D(1.0, 0.0, 0.0))
    try:
        assert level_robot.now_s() == clock
        assert level_robot.base_twist() == Twist.zero()
        closer = level_robot.observe_depth()
        np.testing.assert_allclose(
            closer.depth_m[119:121, 159:161], full.depth_m[119:121, 159:161] - 1.0, atol=0.01
        )
    finally:
        level_robot.teleport(Pose2D(0.0, 0.0, 0.0))


@pytest.mark.parametrize("scene_name", ["garden_sim", "laboratory"])
def test_flat_colour_depth_pass_reads_the_lit_pass_depth_to_the_bit(scene_name: str) -> None:
    # The local planner's depth-only render skips lighting and textures; its depth must not change.
    scene = build_scene(scene_name, seed=0)
    xs, ys = scene.bounds_m[0::2], scene.bounds_m[1::2]
    centre = Pose2D(0.5 * (xs[0] + xs[1]), 0.5 * (ys[0] + ys[1]), 0.0)
    robot = MujocoRobot(scene=scene, fidelity="kinematic", start_pose=centre, seed=0)
    try:
        for yaw in (0.0, 2.1, 4.2):
            robot.teleport(Pose2D(centre.x_m, centre.y_m, yaw))
            full = robot.observe()
            depth_only = robot.observe_depth()
            assert np.count_nonzero(full.depth_m) > 1000
            np.testing.assert_array_equal(depth_only.depth_m, full.depth_m)
    finally:
        robot.close()


#: The pixels UpdateCostmap asks for (the costmap's grid), and the 6-pixel grid perception-side maps read.
PLANNER_AND_MAP_GRIDS = (PixelGrid(stride=4, offset=2), PixelGrid(stride=6, offset=0))


@pytest.mark.parametrize(
    ("scene_name", "fidelity"), [("office", "kinematic"), ("road", "kinematic"), ("garden_sim", "dynamic")]
)
def test_ray_cast_depth_matches_the_rendered_depth_at_the_sampled_pixels(
    scene_name: str, fidelity: str
) -> None:
    scene = build_scene(scene_name, seed=0)
    start = sample_episode(scene, seed=0).start
    robot = MujocoRobot(scene=scene, fidelity=fidelity, start_pose=start, seed=0)  # type: ignore[arg-type]
    try:
        sampled = np.zeros((240, 320), dtype=bool)
        for grid in PLANNER_AND_MAP_GRIDS:
            sampled |= grid.mask(height_px=240, width_px=320)
        for turn in (0.0, 2.1, 4.2):
            robot.teleport(Pose2D(start.x_m, start.y_m, start.yaw_rad + turn))
            rendered = robot.observe_depth().depth_m
            rays = robot.observe_depth(pixel_grids=PLANNER_AND_MAP_GRIDS)
            assert rays.rgb.size == 0 and rays.segmentation is None
            print(
                f"{scene_name} yaw +{turn}: {sampled.sum()} rays, {np.count_nonzero(rendered[sampled])} valid"
            )
            # Not measured: every pixel off the grids; measured: every pixel on them.
            assert np.all(np.isnan(rays.depth_m[~sampled]))
            assert np.all(np.isfinite(rays.depth_m[sampled]))
            on_grid, reference = rays.depth_m[sampled], rendered[sampled]
            assert np.count_nonzero(reference) > 1000
            # The bottom rows see the floor, not the trunk the camera sits in.
            assert np.all((rays.depth_m[-2, sampled[-2]] > 0) == (rendered[-2, sampled[-2]] > 0))
            assert np.mean((on_grid > 0) == (reference > 0)) > 0.999
            both = (on_grid > 0) & (reference > 0)
            assert np.mean(np.abs(on_grid[both] - reference[both]) <= 0.01) > 0.995
    finally:
        robot.close()


def test_raster_depth_sampling_renders_the_whole_frame_and_unknown_sampling_is_refused(
    level_robot: MujocoRobot,
) -> None:
    scene = make_scene()
    robot = MujocoRobot(
        scene=scene, fidelity="kinematic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0, camera=LEVEL_CAMERA,
        depth_sampling="raster",
    )  # fmt: skip
    try:
        whole = robot.observe_depth(pixel_grids=PLANNER_AND_MAP_GRIDS).depth_m
        np.testing.assert_array_equal(whole, level_robot.observe_depth().depth_m)
    finally:
        robot.close()
    with pytest.raises(ValueError, match="depth_sampling"):
        MujocoRobot(scene=scene, fidelity="kinematic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0,
                    depth_sampling="lidar")  # type: ignore[arg-type]  # fmt: skip


def test_ray_cast_depth_reads_the_box_face_at_the_centre(level_robot: MujocoRobot) -> None:
    centre_grid = PixelGrid(stride=40, offset=0)  # rows 0, 40, ..., 200 and columns 0, 40, ..., 280
    observation = level_robot.observe_depth(pixel_grids=[centre_grid])
    depth = observation.depth_m
    # Depth along the optical axis: the flat face reads the same at the centre and 40 px beside it.
    expected = 3.0 - observation.camera_to_world[0, 3]
    assert depth[120, 160] == pytest.approx(expected, abs=1e-3)
    assert depth[120, 200] == pytest.approx(expected, abs=1e-3)
    assert np.isnan(depth[121, 160])


def test_pixel_grid_marks_every_stride_th_row_and_column_from_its_offset() -> None:
    mask = PixelGrid(stride=4, offset=2).mask(height_px=240, width_px=320)
    print(np.argwhere(mask)[:3])
    assert mask.sum() == 60 * 80
    assert mask[2, 2] and mask[2, 6] and mask[6, 2] and not mask[0, 0] and not mask[2, 3]
    for bad in ({"stride": 0}, {"stride": 4, "offset": 4}, {"stride": 4, "offset": -1}, {"stride": 2.0}):
        with pytest.raises(InvalidInputError, match="PixelGrid"):
            PixelGrid(**bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("fidelity", ["kinematic", "dynamic"])
def test_the_pose_is_reported_as_odometry_reports_it_to_the_bit(fidelity: Fidelity) -> None:
    """``base_pose`` and ``camera_to_world`` are what the ROS 2 backend derives from ``/odom`` filled with
    ``base_odometry`` (the simulation bridge's message), bit for bit, and the render's own camera pose
    (MuJoCo's compiled camera) agrees with the reported one to rounding."""
    from types import SimpleNamespace

    from robots.ros2_messages import fill_odometry, odometry_to_transform, pose2d_of
    from robots.ros2_profile import load_ros2_profile

    def vector() -> SimpleNamespace:
        return SimpleNamespace(x=0.0, y=0.0, z=0.0)

    optical_to_base = load_ros2_profile().optical_to_base()
    scene = build_scene("showroom", seed=9)
    robot = MujocoRobot(
        scene=scene, fidelity=fidelity, start_pose=sample_episode(scene, seed=9).start, seed=9
    )
    rng = np.random.default_rng(1)
    try:
        for step in range(120):
            if step % 20 == 0:
                robot.command_twist(Twist(*(float(v) for v in rng.uniform(-1.0, 1.0, 3))))
            robot.advance(0.02)
            odom = SimpleNamespace(
                header=SimpleNamespace(stamp=SimpleNamespace(sec=0, nanosec=0), frame_id=""),
                child_frame_id="",
                pose=SimpleNamespace(pose=SimpleNamespace(position=vector(), orientation=vector())),
                twist=SimpleNamespace(twist=SimpleNamespace(linear=vector(), angular=vector())),
            )
            odom.pose.pose.orientation.w = 1.0
            position, orientation = robot.base_odometry()
            fill_odometry(
                odom, position, orientation, robot.base_twist(), stamp_s=0.0, odom_frame="o", base_frame="b"
            )
            base_to_odom = odometry_to_transform(odom)
            assert robot.base_pose() == pose2d_of(base_to_odom)
            if step % 30 == 29:
                observation = robot.observe_depth(pixel_grids=[PixelGrid(stride=40)])
                np.testing.assert_array_equal(observation.camera_to_world, base_to_odom @ optical_to_base)
                assert observation.base_pose == robot.base_pose()
                assert robot.camera is not None
                rendered = robot.camera.camera_to_world(robot.data)
                np.testing.assert_allclose(rendered, observation.camera_to_world, rtol=0.0, atol=1e-12)
    finally:
        robot.close()


def _kinematic_state(robot: MujocoRobot) -> tuple[object, ...]:
    """Every value a kinematic step changes or a reader derives from it, as bytes or plain values."""
    data = robot.data
    safety = robot.safety()
    return (
        data.qpos.tobytes(),
        float(data.time),
        data.xpos.tobytes(),
        data.xmat.tobytes(),
        data.geom_xpos.tobytes(),
        data.geom_xmat.tobytes(),
        robot.base_pose(),
        robot.base_twist(),
        robot.commanded_twist,
        [(e.stamp_s, e.object_id, e.distance_m, e.kind) for e in safety.events],
        safety.min_clearance_m,
        safety.least_clearance_m,
        robot.imu().angular_velocity_radps.tobytes(),
    )


def test_a_restored_snapshot_takes_a_step_back_to_the_bit() -> None:
    # The ROS 2 bridge's speculative step (sims/ros2_bridge.py, Speculation) relies on this: a step into
    # the wall (a clearance and a collision event) taken back leaves the robot as it was, and the step
    # then taken instead gives the bits of a robot that never speculated.
    scene = make_scene(box_face_x_m=6.0, wall_x_m=2.0)
    robot, twin = make_kinematic(scene=scene), make_kinematic(scene=scene)
    for each in (robot, twin):
        each.command_twist(Twist(0.8, 0.0, 0.3))
        each.advance(1.9)  # 0.3 m short of the wall's clearance band
    before = _kinematic_state(robot)
    assert _kinematic_state(twin) == before  # (and the twin draws its IMU noise as the robot does)
    snapshot = robot.snapshot()
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    robot.advance(0.6)  # into the wall
    assert len(robot.safety().events) > len(twin.safety().events)
    robot.restore(snapshot)
    assert _kinematic_state(robot) == before
    for each in (robot, twin):
        each.command_twist(Twist(-0.2, 0.1, -0.5))
        each.advance(0.04)
    assert _kinematic_state(robot) == _kinematic_state(twin)


def test_the_world_viewed_at_a_snapshot_is_the_snapshots_and_now_is_kept_to_the_bit() -> None:
    # The ROS 2 bridge renders the executive's instant between the steps it took ahead of it and keeps
    # those steps (sims/ros2_bridge.py, _publish_frame_at_asked): the frame must be the one a robot that
    # never stepped ahead renders, and the steps ahead (their events included) must survive the render.
    scene = make_scene(box_face_x_m=6.0, wall_x_m=2.0)
    robot, twin = make_kinematic(scene=scene), make_kinematic(scene=scene)
    for each in (robot, twin):
        each.command_twist(Twist(0.8, 0.0, 0.3))
        each.advance(1.9)
    snapshot = robot.snapshot()
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    robot.advance(0.6)  # ahead, into the wall: events logged
    ahead = _kinematic_state(robot)
    assert len(robot.safety().events) > len(twin.safety().events)
    grids = [PixelGrid.centred(8)]
    with robot.viewed_at(snapshot):
        depth, full = robot.observe_depth(pixel_grids=grids), robot.observe()
    for seen, expected in ((depth, twin.observe_depth(pixel_grids=grids)), (full, twin.observe())):
        np.testing.assert_array_equal(seen.depth_m, expected.depth_m)
        np.testing.assert_array_equal(seen.camera_to_world, expected.camera_to_world)
        assert (seen.stamp_s, seen.base_pose) == (expected.stamp_s, expected.base_pose)
    np.testing.assert_array_equal(full.rgb, twin.observe().rgb)
    assert _kinematic_state(robot) == ahead
    with pytest.raises(InvalidInputError, match="kinematic-only"):
        with MujocoRobot(
            scene=make_scene(), fidelity="dynamic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0
        ).viewed_at(snapshot):
            pass


def test_snapshots_are_kinematic_only_and_not_restored_past_the_event_log() -> None:
    robot = make_kinematic(scene=make_scene(box_face_x_m=6.0, wall_x_m=2.0))
    robot.command_twist(Twist(1.0, 0.0, 0.0))
    robot.advance(4.0)  # at the wall: events logged
    snapshot = robot.snapshot()
    stale = make_kinematic(scene=make_scene(box_face_x_m=6.0, wall_x_m=2.0))
    with pytest.raises(InvalidInputError, match="newer than this robot's event log"):
        stale.restore(snapshot)
    dynamic = MujocoRobot(scene=make_scene(), fidelity="dynamic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0)
    with pytest.raises(InvalidInputError, match="kinematic-only"):
        dynamic.snapshot()
