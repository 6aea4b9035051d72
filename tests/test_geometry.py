"""Tests for semexp_bt.core.geometry: back-projection (paper Eq. 5), projection, boxes, depth statistics, poses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.geometry import (
    back_project,
    back_project_pixels,
    base_to_world,
    bearing_in_base,
    box_depth_stats,
    box_iou,
    box_iou_matrix,
    clip_box,
    in_image,
    object_surface_depth,
    patch_depth_stats,
    project_points,
    project_to_image,
    robust_depth,
    world_to_base,
    wrap_angle,
)
from semexp_bt.core.types import CameraIntrinsics, InvalidInputError, Pose2D

WIDTH, HEIGHT = 640, 480
K = CameraIntrinsics(fx_px=500.0, fy_px=500.0, cx_px=319.5, cy_px=239.5, width_px=WIDTH, height_px=HEIGHT)

# A camera at (1, 2, 0.5) in map looking along map +x: optical z -> map x, optical x (right) -> map -y,
# optical y (down) -> map -z. The columns of R are the optical axes expressed in map.
FORWARD_CAMERA = np.array(
    [
        [0.0, 0.0, 1.0, 1.0],
        [-1.0, 0.0, 0.0, 2.0],
        [0.0, -1.0, 0.0, 0.5],
        [0.0, 0.0, 0.0, 1.0],
    ]
)


def _rotation_from_quaternion(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


# ---------------------------------------------------------------------------------------------------------
# Eq. 5 back-projection
# ---------------------------------------------------------------------------------------------------------


def test_back_project_identity_hand_worked() -> None:
    # u - cx = 419.5 - 319.5 = 100 -> x = 100 * 2 / 500 = 0.4; v - cy = 139.5 - 239.5 = -100 -> y = -0.4; z = 2.
    point = back_project((419.5, 139.5), 2.0, K, np.eye(4))
    np.testing.assert_allclose(point, [0.4, -0.4, 2.0])


def test_back_project_forward_camera_hand_worked() -> None:
    # Camera frame (0.4, -0.4, 2) -> R @ c = (2, -0.4, 0.4); + t (1, 2, 0.5) = (3, 1.6, 0.9):
    # 2 m ahead, 0.4 m to the right (y decreases) and 0.4 m above the camera (the pixel is above centre).
    point = back_project((419.5, 139.5), 2.0, K, FORWARD_CAMERA)
    np.testing.assert_allclose(point, [3.0, 1.6, 0.9])


def test_back_project_principal_point_lies_on_optical_axis() -> None:
    np.testing.assert_allclose(back_project((319.5, 239.5), 5.0, K, FORWARD_CAMERA), [6.0, 2.0, 0.5])


@pytest.mark.parametrize("depth", [math.nan, math.inf, -math.inf, 0.0, -1.0])
def test_back_project_rejects_bad_depth(depth: float) -> None:
    with pytest.raises(InvalidInputError, match="depth_m"):
        back_project((100.0, 100.0), depth, K, np.eye(4))


@pytest.mark.parametrize(
    "pixel", [(-1.0, 10.0), (639.5, 10.0), (10.0, 479.5), (10.0, -0.6), (math.nan, 10.0), (10.0, math.inf)]
)
def test_back_project_rejects_bad_pixel(pixel: tuple[float, float]) -> None:
    with pytest.raises(InvalidInputError, match="pixel_px"):
        back_project(pixel, 1.0, K, np.eye(4))


def test_back_project_accepts_the_whole_image_area() -> None:
    # The image covers [-0.5, W - 0.5) x [-0.5, H - 0.5): both extreme corners are valid.
    back_project((-0.5, -0.5), 1.0, K, np.eye(4))
    back_project((639.49, 479.49), 1.0, K, np.eye(4))


def test_back_project_rejects_non_rigid_transform() -> None:
    scaled = np.eye(4)
    scaled[:3, :3] *= 2.0
    with pytest.raises(InvalidInputError, match="camera_to_world"):
        back_project((100.0, 100.0), 1.0, K, scaled)
    reflected = np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(InvalidInputError, match="camera_to_world"):
        back_project((100.0, 100.0), 1.0, K, reflected)
    with pytest.raises(InvalidInputError, match="camera_to_world"):
        back_project((100.0, 100.0), 1.0, K, np.full((4, 4), np.nan))
    with pytest.raises(InvalidInputError, match="camera_to_world"):
        back_project((100.0, 100.0), 1.0, K, np.eye(3))


def test_back_project_rejects_bad_intrinsics() -> None:
    bad = CameraIntrinsics(fx_px=0.0, fy_px=500.0, cx_px=1.0, cy_px=1.0, width_px=10, height_px=10)
    with pytest.raises(InvalidInputError, match="intrinsics"):
        back_project((1.0, 1.0), 1.0, bad, np.eye(4))


def test_batch_back_project_matches_scalar_and_names_bad_row() -> None:
    pixels = np.array([[419.5, 139.5], [0.0, 0.0], [639.0, 479.0]])
    depths = np.array([2.0, 0.5, 9.0])
    batch = back_project_pixels(pixels, depths, K, FORWARD_CAMERA)
    for row, (pixel, depth) in enumerate(zip(pixels, depths, strict=True)):
        np.testing.assert_allclose(batch[row], back_project(tuple(pixel), float(depth), K, FORWARD_CAMERA))
    with pytest.raises(InvalidInputError, match=r"depths_m\[1\]"):
        back_project_pixels(pixels, [1.0, math.nan, 1.0], K, FORWARD_CAMERA)
    with pytest.raises(InvalidInputError, match=r"pixels_px\[2\]"):
        back_project_pixels([[1.0, 1.0], [2.0, 2.0], [700.0, 1.0]], [1.0, 1.0, 1.0], K, FORWARD_CAMERA)


# ---------------------------------------------------------------------------------------------------------
# Projection
# ---------------------------------------------------------------------------------------------------------


def test_project_hand_worked_and_behind_camera() -> None:
    u, v, z = project_to_image((3.0, 1.6, 0.9), K, FORWARD_CAMERA)  # type: ignore[misc]
    assert (u, v, z) == pytest.approx((419.5, 139.5, 2.0))
    assert project_to_image((0.0, 2.0, 0.5), K, FORWARD_CAMERA) is None  # 1 m behind
    assert project_to_image((1.0, 5.0, 0.5), K, FORWARD_CAMERA) is None  # in the image plane (z = 0)
    with pytest.raises(InvalidInputError, match="point_world"):
        project_to_image((math.nan, 0.0, 0.0), K, FORWARD_CAMERA)


def test_project_points_marks_behind_rows() -> None:
    uv, z = project_points([[3.0, 1.6, 0.9], [0.0, 2.0, 0.5]], K, FORWARD_CAMERA)
    np.testing.assert_allclose(uv[0], [419.5, 139.5])
    np.testing.assert_allclose(z, [2.0, -1.0])
    assert np.all(np.isnan(uv[1]))


unit = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(
    u=st.floats(-0.5, WIDTH - 0.51),
    v=st.floats(-0.5, HEIGHT - 0.51),
    depth=st.floats(0.05, 50.0),
    quaternion=st.tuples(unit, unit, unit, unit).filter(lambda q: np.linalg.norm(q) > 0.1),
    translation=st.tuples(*(st.floats(-20.0, 20.0),) * 3),
)
def test_back_project_then_project_round_trips(
    u: float,
    v: float,
    depth: float,
    quaternion: tuple[float, float, float, float],
    translation: tuple[float, float, float],
) -> None:
    transform = np.eye(4)
    transform[:3, :3] = _rotation_from_quaternion(np.array(quaternion))
    transform[:3, 3] = translation
    point = back_project((u, v), depth, K, transform)
    projected = project_to_image(point, K, transform)
    assert projected is not None
    assert projected == pytest.approx((u, v, depth), rel=1e-7, abs=1e-6)
    uv, z = project_points(point[None, :], K, transform)
    assert (uv[0, 0], uv[0, 1], z[0]) == pytest.approx((u, v, depth), rel=1e-7, abs=1e-6)


# ---------------------------------------------------------------------------------------------------------
# Boxes
# ---------------------------------------------------------------------------------------------------------


def test_box_iou_hand_worked() -> None:
    # Overlap 5 x 5 = 25; union 100 + 100 - 25 = 175 -> 1/7.
    assert box_iou((0, 0, 10, 10), (5, 5, 15, 15)) == pytest.approx(1.0 / 7.0)
    assert box_iou((0, 0, 10, 10), (0, 0, 10, 10)) == 1.0
    assert box_iou((0, 0, 10, 10), (10, 0, 20, 10)) == 0.0  # touching edges
    assert box_iou((0, 0, 10, 10), (2, 2, 4, 4)) == pytest.approx(4.0 / 100.0)  # nested
    assert box_iou((3, 3, 3, 3), (3, 3, 3, 3)) == 0.0  # no area, no overlap


@pytest.mark.parametrize(
    "bad", [(5, 0, 0, 10), (0, 5, 10, 0), (0, 0, math.nan, 1), (0, 0, 1), (0, 0, math.inf, 1)]
)
def test_box_iou_rejects_malformed_boxes(bad: tuple[float, ...]) -> None:
    with pytest.raises(InvalidInputError, match="a_xyxy"):
        box_iou(bad, (0, 0, 1, 1))


boxes = st.tuples(*(st.floats(-100.0, 800.0),) * 2, *(st.floats(0.0, 300.0),) * 2).map(
    lambda b: (b[0], b[1], b[0] + b[2], b[1] + b[3])
)


@settings(max_examples=100, deadline=None)
@given(a=st.lists(boxes, min_size=1, max_size=5), b=st.lists(boxes, min_size=1, max_size=5))
def test_box_iou_matrix_matches_scalar_and_is_bounded(a: list, b: list) -> None:
    matrix = box_iou_matrix(a, b)
    assert matrix.shape == (len(a), len(b))
    for i, box_a in enumerate(a):
        for j, box_b in enumerate(b):
            expected = box_iou(box_a, box_b)
            assert 0.0 <= expected <= 1.0
            assert matrix[i, j] == pytest.approx(expected, abs=1e-12)
            assert box_iou(box_b, box_a) == pytest.approx(expected, abs=1e-12)


def test_box_iou_matrix_names_bad_row() -> None:
    with pytest.raises(InvalidInputError, match=r"b_xyxy\[1\]"):
        box_iou_matrix([(0, 0, 1, 1)], [(0, 0, 1, 1), (2, 0, 1, 1)])


def test_clip_box() -> None:
    assert clip_box((-10, -5, 700, 100), WIDTH, HEIGHT) == (0.0, 0.0, 639.0, 100.0)
    assert clip_box((700, 500, 800, 600), WIDTH, HEIGHT) == (639.0, 479.0, 639.0, 479.0)
    assert clip_box((10, 20, 30, 40), WIDTH, HEIGHT) == (10.0, 20.0, 30.0, 40.0)
    with pytest.raises(InvalidInputError, match="box"):
        clip_box((30, 20, 10, 40), WIDTH, HEIGHT)


def test_in_image_bounds() -> None:
    assert in_image((-0.5, -0.5), 4, 3)
    assert in_image((3.49, 2.49), 4, 3)
    assert not in_image((3.5, 0.0), 4, 3)
    assert not in_image((0.0, -0.51), 4, 3)


# ---------------------------------------------------------------------------------------------------------
# Depth statistics
# ---------------------------------------------------------------------------------------------------------


def test_robust_depth_median_ignores_holes() -> None:
    depth = np.full((10, 10), 3.0, dtype=np.float32)
    # 3 x 3 patch around (u=5, v=4): rows 3..5, cols 4..6. Values 1..9, with two holes (0 and NaN).
    depth[3:6, 4:7] = np.arange(1, 10, dtype=np.float32).reshape(3, 3)
    depth[3, 4] = 0.0  # was 1
    depth[5, 6] = np.nan  # was 9
    # Valid: 2..8 -> median 5.
    assert robust_depth(depth, (5.0, 4.0), 3) == pytest.approx(5.0)
    # Pixel (5.4, 3.6) lies in pixel (5, 4): same patch.
    assert robust_depth(depth, (5.4, 3.6), 3) == pytest.approx(5.0)
    median, fraction = patch_depth_stats(depth, [(5.0, 4.0)], 3)
    assert fraction[0] == pytest.approx(7.0 / 9.0)
    # A 1-pixel patch is the pixel itself: depth[4, 5] = 5.
    assert robust_depth(depth, (5.0, 4.0), 1) == pytest.approx(5.0)


def test_robust_depth_even_count_averages_middle_pair() -> None:
    depth = np.array([[1.0, 2.0, 0.0], [4.0, 10.0, np.inf], [0.0, 0.0, 0.0]])
    # Patch 3x3 around (1, 1): valid 1, 2, 4, 10 -> median (2 + 4) / 2 = 3.
    assert robust_depth(depth, (1.0, 1.0), 3) == pytest.approx(3.0)


def test_robust_depth_all_holes_is_none() -> None:
    depth = np.zeros((8, 8))
    depth[0, 0] = np.nan
    assert robust_depth(depth, (3.0, 3.0), 5) is None
    median, fraction = patch_depth_stats(depth, [(3.0, 3.0)], 5)
    assert math.isnan(median[0]) and fraction[0] == 0.0


def test_robust_depth_patch_at_border_counts_only_image_pixels() -> None:
    depth = np.full((6, 6), 2.0)
    depth[0, 1] = np.nan
    # 3x3 patch at (0, 0): only the 2x2 corner is on the image, one of them a hole -> fraction 3/4.
    median, fraction = patch_depth_stats(depth, [(0.0, 0.0)], 3)
    assert median[0] == 2.0 and fraction[0] == pytest.approx(0.75)
    # An even patch side rounds up to the next odd side.
    _, fraction_even = patch_depth_stats(depth, [(3.0, 3.0)], 2)
    assert fraction_even[0] == 1.0


def test_robust_depth_rejects_bad_input() -> None:
    depth = np.ones((4, 4))
    with pytest.raises(InvalidInputError, match="pixel"):
        robust_depth(depth, (math.nan, 1.0), 3)
    with pytest.raises(InvalidInputError, match="pixel"):
        robust_depth(depth, (9.0, 1.0), 3)
    with pytest.raises(InvalidInputError, match="depth_m"):
        robust_depth(np.ones(4), (1.0, 1.0), 3)


def test_box_depth_stats_median_and_fraction() -> None:
    depth = np.full((100, 100), 5.0)
    depth[20:40, 20:40] = 4.0  # the object
    depth[20:25, 20:25] = 0.5  # a small near outlier in its corner
    depth[35:40, 35:40] = 0.0  # and a hole
    median, fraction = box_depth_stats(depth, [(20, 20, 39, 39), (60, 60, 80, 80)])
    # Samples on a 16 x 16 grid over the box: 4 x 4 of them hit the outlier, 4 x 4 the hole; the median of
    # the 240 valid samples is the object's 4 m (a mean would be pulled to about 3.8 m).
    assert median[0] == 4.0 and fraction[0] == pytest.approx(240.0 / 256.0)
    assert median[1] == 5.0 and fraction[1] == 1.0
    depth[60:81, 60:81] = np.nan
    median, fraction = box_depth_stats(depth, [(60, 60, 80, 80)])
    assert math.isnan(median[0]) and fraction[0] == 0.0


def test_object_surface_depth_finds_a_thin_object_in_front_of_the_wall() -> None:
    """A sign on a pole at 2 m in front of a wall at 6 m: the VLM's point lands on the wall beside it."""
    depth = np.full((120, 160), 6.0)
    depth[20:50, 70:100] = 2.0  # the sign plate
    depth[50:110, 83:87] = 2.0  # its pole
    box = (68.0, 18.0, 102.0, 108.0)
    point_on_the_wall = (95.0, 80.0)
    assert robust_depth(depth, point_on_the_wall, 5) == 6.0  # the patch median sees only the wall
    assert object_surface_depth(depth, point_on_the_wall, box, 5) == pytest.approx(2.0)
    # Without a box it is the patch median; an all-invalid box falls back to it too.
    assert object_surface_depth(depth, point_on_the_wall, None, 5) == 6.0
    holes = depth.copy()
    holes[18:109, 68:103] = 0.0
    holes[78:83, 93:98] = 6.0
    assert object_surface_depth(holes, point_on_the_wall, box, 5) == 6.0
    with pytest.raises(InvalidInputError, match="box_xyxy"):
        object_surface_depth(depth, point_on_the_wall, (10.0, 10.0, 5.0, 20.0), 5)


# ---------------------------------------------------------------------------------------------------------
# Planar pose helpers
# ---------------------------------------------------------------------------------------------------------


def test_wrap_angle_hand_worked() -> None:
    assert wrap_angle(0.5) == pytest.approx(0.5)
    assert wrap_angle(3.0 * math.pi) == pytest.approx(-math.pi)
    assert wrap_angle(math.pi) == pytest.approx(-math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(-math.pi)
    assert wrap_angle(1.5 * math.pi) == pytest.approx(-0.5 * math.pi)
    with pytest.raises(InvalidInputError, match="angle_rad"):
        wrap_angle(math.nan)


@given(st.floats(-1e4, 1e4))
def test_wrap_angle_property(angle: float) -> None:
    wrapped = wrap_angle(angle)
    assert -math.pi <= wrapped < math.pi
    turns = (angle - wrapped) / (2.0 * math.pi)
    assert turns == pytest.approx(round(turns), abs=1e-9)


@given(st.lists(st.floats(-1e4, 1e4), min_size=1, max_size=20))
def test_wrap_angle_of_an_array_is_bit_identical_to_the_scalar_wrap(angles: list[float]) -> None:
    # The planner wraps arrays and the robot backends scalars; one formula must give both the same bits.
    wrapped = wrap_angle(np.array(angles))
    assert wrapped.tolist() == [wrap_angle(a) for a in angles]


def test_wrap_angle_keeps_the_interval_half_open_where_the_modulo_rounds_to_two_pi() -> None:
    just_below_minus_pi = math.nextafter(-math.pi, -math.inf)
    assert (just_below_minus_pi + math.pi) % (2.0 * math.pi) == 2.0 * math.pi  # the rounding case
    assert wrap_angle(just_below_minus_pi) == -math.pi
    assert wrap_angle(np.array([just_below_minus_pi, math.pi])).tolist() == [-math.pi, -math.pi]


def test_wrap_angle_rejects_a_non_finite_entry_of_an_array() -> None:
    with pytest.raises(InvalidInputError, match="angle_rad"):
        wrap_angle(np.array([0.0, math.inf]))


def test_world_to_base_hand_worked() -> None:
    facing_plus_y = Pose2D(x_m=1.0, y_m=1.0, yaw_rad=math.pi / 2)
    assert world_to_base((1.0, 3.0), facing_plus_y) == pytest.approx((2.0, 0.0))  # 2 m ahead
    assert world_to_base((0.0, 1.0), facing_plus_y) == pytest.approx((0.0, 1.0), abs=1e-12)  # 1 m left
    assert bearing_in_base((0.0, 1.0), facing_plus_y) == pytest.approx(math.pi / 2)
    with pytest.raises(InvalidInputError, match="point_xy"):
        world_to_base((math.nan, 0.0), facing_plus_y)


@given(
    x=st.floats(-50, 50),
    y=st.floats(-50, 50),
    px=st.floats(-50, 50),
    py=st.floats(-50, 50),
    yaw=st.floats(-7, 7),
)
def test_world_to_base_round_trips(x: float, y: float, px: float, py: float, yaw: float) -> None:
    pose = Pose2D(x_m=px, y_m=py, yaw_rad=yaw)
    local = world_to_base((x, y), pose)
    assert math.hypot(*local) == pytest.approx(math.hypot(x - px, y - py), abs=1e-9)
    assert base_to_world(local, pose) == pytest.approx((x, y), abs=1e-9)
