"""The occupancy map under the local planner: depth rays into hit and free counts, paths round walls."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from semexp_bt.core.types import CameraIntrinsics, Observation, Pose2D
from semexp_bt.nav.local_map import OccupancyMap

CAMERA_HEIGHT_M = 0.3
WALL_X_M = 2.0
#: Optical frame (x right, y down, z forward) to a world frame where the camera looks along +x.
OPTICAL_TO_WORLD = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def wall_frame(*, wall_x_m: float = WALL_X_M) -> Observation:
    """A 160x120 depth image of a wall across the camera's view at ``wall_x_m``, floor below it."""
    intrinsics = CameraIntrinsics.from_fov(width_px=160, height_px=120, vertical_fov_deg=58.0)
    rows = np.arange(intrinsics.height_px, dtype=float)[:, None]
    below_horizon = np.maximum(rows - intrinsics.cy_px, 1e-9) / intrinsics.fy_px
    floor_depth = np.where(rows > intrinsics.cy_px, CAMERA_HEIGHT_M / below_horizon, np.inf)
    depth = np.minimum(floor_depth, wall_x_m) * np.ones((1, intrinsics.width_px))
    camera_to_world = np.eye(4)
    camera_to_world[:3, :3] = OPTICAL_TO_WORLD
    camera_to_world[:3, 3] = (0.0, 0.0, CAMERA_HEIGHT_M)
    return Observation(
        rgb=np.zeros((0, 0, 3), dtype=np.uint8),
        depth_m=depth.astype(np.float32),
        intrinsics=intrinsics,
        camera_to_world=camera_to_world,
        base_pose=Pose2D(0.0, 0.0, 0.0),
        stamp_s=0.0,
    )


def occupied_at(grid_map: OccupancyMap, x_m: float, y_m: float) -> bool:
    row, col = grid_map.cell_of(np.array([x_m, y_m]))
    return bool(grid_map.occupied()[row, col])


def known_at(grid_map: OccupancyMap, x_m: float, y_m: float) -> bool:
    row, col = grid_map.cell_of(np.array([x_m, y_m]))
    return bool(grid_map.known()[row, col])


def test_a_wall_in_view_is_occupied_the_floor_before_it_is_free_and_behind_it_unknown() -> None:
    grid_map = OccupancyMap(origin_xy=(0.0, 0.0))
    used = grid_map.integrate(wall_frame())
    assert used > 0 and grid_map.frames == 1
    assert occupied_at(grid_map, WALL_X_M + 0.02, 0.0)
    for x_m in (0.8, 1.2, 1.6):
        assert known_at(grid_map, x_m, 0.0) and not occupied_at(grid_map, x_m, 0.0)
    assert not known_at(grid_map, WALL_X_M + 0.5, 0.0)
    assert grid_map.clearance_at(np.array([1.0, 0.0])) == pytest.approx(1.0, abs=0.15)


def test_a_path_leads_round_a_mapped_wall_and_not_through_it() -> None:
    grid_map = OccupancyMap(origin_xy=(0.0, 0.0))
    for _ in range(3):
        grid_map.integrate(wall_frame())
    path = grid_map.path((0.0, 0.0), (4.0, 0.0))
    assert path is not None
    print(np.round(path[:: max(1, len(path) // 8)], 2))
    rows_cols = grid_map.cell_of(path)
    assert not grid_map.occupied()[rows_cols[:, 0], rows_cols[:, 1]].any()
    assert np.abs(path[:, 1]).max() > 0.5  # it had to leave the straight line to pass the wall


def test_counts_match_a_whole_grid_reference_capped_at_four_per_frame() -> None:
    """The windowed count adds what a whole-grid count would, ignores points off the map, caps at 4."""
    rng = np.random.default_rng(7)
    grid_map = OccupancyMap(origin_xy=(0.0, 0.0))
    points = np.concatenate(
        [rng.uniform(-3.0, 5.0, size=(5000, 2)), np.full((9, 2), 1.23), rng.uniform(-40.0, 40.0, (200, 2))]
    )
    reference = np.zeros_like(grid_map.free)
    for _ in range(2):
        grid_map._accumulate(grid_map.free, points)
        cells = grid_map.cell_of(points)
        cells = cells[np.all((cells >= 0) & (cells < grid_map.size), axis=1)]
        counts = np.zeros(reference.shape, dtype=np.int64)
        np.add.at(counts, (cells[:, 0], cells[:, 1]), 1)
        reference += np.minimum(counts, 4).astype(np.float32)
    assert np.array_equal(grid_map.free, reference)
    row, col = grid_map.cell_of(np.array([1.23, 1.23]))
    assert grid_map.free[row, col] == 8.0  # 9 points (and maybe a random one) per frame, capped at 4, twice


def test_the_map_reads_only_its_sampled_pixels() -> None:
    # A depth source that measures only the map's grid and leaves the rest NaN builds the same map.
    whole_map, sampled_map = OccupancyMap(origin_xy=(0.0, 0.0)), OccupancyMap(origin_xy=(0.0, 0.0))
    frame = wall_frame()
    grid = sampled_map.sampled_pixels
    partial = frame.depth_m.copy()
    partial[~grid.mask(height_px=partial.shape[0], width_px=partial.shape[1])] = np.nan
    assert np.isnan(partial).mean() > 0.9
    used = whole_map.integrate(frame)
    assert sampled_map.integrate(dataclasses.replace(frame, depth_m=partial)) == used > 0
    np.testing.assert_array_equal(whole_map.hits, sampled_map.hits)
    np.testing.assert_array_equal(whole_map.free, sampled_map.free)
