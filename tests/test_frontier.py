"""Geometric frontiers from depth (semexp_bt.nav.frontier)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from semexp_bt.core.types import CameraIntrinsics, InvalidInputError
from semexp_bt.nav.frontier import depth_frontiers, horizon_row

K = CameraIntrinsics.from_fov(width_px=320, height_px=240, vertical_fov_deg=42.5)
CAMERA_HEIGHT_M = 0.3


def level_camera_to_world(height_m: float = CAMERA_HEIGHT_M) -> np.ndarray:
    """A level optical camera (x right, y down, z forward) looking along world +x at ``height_m``."""
    transform = np.eye(4)
    transform[:3, 0] = [0.0, -1.0, 0.0]
    transform[:3, 1] = [0.0, 0.0, -1.0]
    transform[:3, 2] = [1.0, 0.0, 0.0]
    transform[2, 3] = height_m
    return transform


def test_horizon_of_a_level_camera_is_the_principal_row() -> None:
    assert horizon_row(intrinsics=K, camera_to_world=level_camera_to_world()) == pytest.approx(K.cy_px)


def test_one_open_run_gives_one_frontier_in_its_middle() -> None:
    # A wall 1 m ahead everywhere except the 100 leftmost columns, which see 5 m.
    depth = np.full((K.height_px, K.width_px), 1.0)
    depth[:, :100] = 5.0
    frontiers = depth_frontiers(
        depth_m=depth,
        intrinsics=K,
        camera_to_world=level_camera_to_world(),
        open_range_m=1.5,
        min_width_deg=8.0,
    )
    assert len(frontiers) == 1
    (frontier,) = frontiers
    assert frontier.pixel_px == (49.0, pytest.approx(K.cy_px))
    expected_width = math.degrees(math.atan2(99.5 - K.cx_px, K.fx_px) - math.atan2(-0.5 - K.cx_px, K.fx_px))
    assert frontier.width_deg == pytest.approx(expected_width)
    # The middle column's nearest band point is the far wall, 5 m along the optical axis.
    assert 5.0 <= frontier.clearance_m <= 5.0 * math.hypot(1.0, (K.cx_px - 49.0) / K.fx_px) + 1e-9


def test_floor_and_missing_returns_are_open_and_narrow_runs_are_ignored() -> None:
    depth = np.full((K.height_px, K.width_px), 1.0)
    depth[:, 150:156] = np.nan  # 6 columns with no return: open but narrower than 8 degrees
    frontiers = depth_frontiers(
        depth_m=depth,
        intrinsics=K,
        camera_to_world=level_camera_to_world(),
        open_range_m=1.5,
        min_width_deg=8.0,
    )
    assert frontiers == []
    depth[:, 150:200] = np.nan
    frontiers = depth_frontiers(
        depth_m=depth,
        intrinsics=K,
        camera_to_world=level_camera_to_world(),
        open_range_m=1.5,
        min_width_deg=8.0,
    )
    assert [f.pixel_px[0] for f in frontiers] == [174.0]
    assert frontiers[0].clearance_m == math.inf


def test_bad_depth_shape_names_the_field() -> None:
    with pytest.raises(InvalidInputError, match="depth_m"):
        depth_frontiers(
            depth_m=np.ones((10, 10)), intrinsics=K, camera_to_world=level_camera_to_world(),
            open_range_m=1.5, min_width_deg=8.0,
        )  # fmt: skip
