"""The flank depth cameras (robots/side_depth.py): what they see beside the body, and that the costmap
learns the turning circle from them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robots.go1 import go1_footprint
from robots.mujoco_backend import MujocoRobot
from robots.side_depth import SideDepthConfig
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import InvalidInputError, Observation, PixelGrid, Pose2D
from semexp_bt.nav.costmap import Costmap, CostmapConfig

#: A low box beside the robot's right flank: its near face 0.30 m from the centre line, 0.25 m tall, so
#: the head camera (floor visible from 0.8 m ahead) never sees it from the start pose.
BOX_FACE_RIGHT_M = 0.30


def box_on_the_right() -> SceneSpec:
    box = SceneObject(
        object_id=5,
        name="box_5",
        label="box",
        category="box",
        shape="box",
        position_m=(0.0, -(BOX_FACE_RIGHT_M + 0.2), 0.125),
        size_m=(0.4, 0.2, 0.125),
    )
    return SceneSpec(
        name="flank",
        title="Flank",
        seed=0,
        bounds_m=(-3.0, -3.0, 3.0, 3.0),
        objects=(box,),
        goal_object_id=5,
        instruction="find the box",
    )


def world_points(frame: Observation) -> np.ndarray:
    """Every valid depth pixel of ``frame``, back-projected to the world: ``(N, 3)``."""
    k = frame.intrinsics
    rows, cols = np.nonzero(frame.depth_m > 0.0)
    z = frame.depth_m[rows, cols].astype(float)
    cam = np.stack([(cols - k.cx_px) / k.fx_px * z, (rows - k.cy_px) / k.fy_px * z, z, np.ones_like(z)])
    return (frame.camera_to_world @ cam)[:3].T


@pytest.fixture(scope="module")
def robot() -> MujocoRobot:
    robot = MujocoRobot(
        scene=box_on_the_right(), fidelity="kinematic", start_pose=Pose2D(0.0, 0.0, 0.0), seed=0
    )
    yield robot
    robot.close()


def test_the_right_camera_sees_the_box_and_the_left_one_the_floor(robot: MujocoRobot) -> None:
    left, right = robot.observe_side_depth()
    for frame in (left, right):
        assert frame.rgb.shape == (0, 0, 3) and frame.segmentation is None
        assert frame.depth_m.shape == (96, 128)
    # The right camera's points on the box's near face, the left one's on the floor.
    points = {"left": world_points(left), "right": world_points(right)}
    print({side: (len(p), p[:, 1].min().round(3), p[:, 1].max().round(3)) for side, p in points.items()})
    on_face = np.abs(points["right"][:, 1] + BOX_FACE_RIGHT_M) < 0.01
    assert np.count_nonzero(on_face & (points["right"][:, 2] > 0.05)) > 20
    assert points["left"][:, 1].min() > 0.05, "the left camera looks left"
    assert np.abs(points["left"][:, 2]).max() < 0.01, "nothing but floor on the left"


def test_the_legs_are_masked_out(robot: MujocoRobot) -> None:
    left, right = robot.observe_side_depth()
    for frame in (left, right):
        world = world_points(frame)
        beside_the_legs = (np.abs(world[:, 0]) < 0.3) & (np.abs(world[:, 1]) < 0.16) & (world[:, 2] > 0.02)
        assert not beside_the_legs.any(), "a point on the robot's own legs"


def test_a_costmap_fed_by_the_flank_cameras_knows_the_turning_circle(robot: MujocoRobot) -> None:
    grid = CostmapConfig().pixel_stride
    with_sides, head_only = (
        Costmap(CostmapConfig(), footprint=go1_footprint(), origin_xy=(0.0, 0.0)) for _ in range(2)
    )
    head = robot.observe_depth(pixel_grids=[PixelGrid.centred(grid)])
    with_sides.integrate(head, *robot.observe_side_depth(pixel_grids=[PixelGrid.centred(grid)]))
    head_only.integrate(head)
    assert with_sides.frames == head_only.frames == 1
    angles = np.linspace(0.0, math.tau, 16, endpoint=False)
    ring = np.stack([0.4 * np.cos(angles), 0.4 * np.sin(angles)], axis=1)
    print("head only:", "".join("k" if k else "." for k in head_only.known_at(ring)))
    print("with sides:", "".join("k" if k else "." for k in with_sides.known_at(ring)))
    beside = np.abs(np.sin(angles)) > 0.7  # the ring's points beside the body
    assert not head_only.known_at(ring)[beside].any()
    # Left: open floor, all of it seen. Right: the gap to the box seen free, its face lethal; behind
    # the face (the ring's right side runs inside the box) nothing can be seen, and nothing is assumed.
    assert with_sides.known_at(ring)[beside & (np.sin(angles) > 0)].all()
    gap = [(x, -0.24) for x in (-0.2, 0.0, 0.2)]
    assert [with_sides.state_at(xy) for xy in gap] == ["free"] * 3
    assert [with_sides.state_at((x, -BOX_FACE_RIGHT_M - 0.02)) for x in (-0.2, 0.0, 0.2)] == ["lethal"] * 3
    assert [head_only.state_at(xy) for xy in gap] == ["unknown"] * 3


def test_a_robot_built_without_them_has_none() -> None:
    robot = MujocoRobot(
        scene=box_on_the_right(),
        fidelity="kinematic",
        start_pose=Pose2D(0.0, 0.0, 0.0),
        seed=0,
        side_depth=None,
    )
    try:
        assert robot.observe_side_depth() == []
    finally:
        robot.close()


@pytest.mark.parametrize(
    ("field", "value"),
    [("width_px", 0), ("vertical_fov_deg", 180.0), ("min_depth_m", 5.0), ("mount_pitch_down_deg", 95.0)],
)
def test_bad_config_names_the_field(field: str, value: float) -> None:
    with pytest.raises(InvalidInputError, match=field):
        SideDepthConfig(**{field: value})
