"""Geometric exploration frontiers from one depth frame: open image directions when the VLM names none.

The paper's scene-level VLM proposes unexplored directions along with objects; a real VLM often does
not (or its answer is garbled), and a search whose memory receives no place to go stalls at its
start. Classical frontier exploration supplies those places from geometry alone. This module finds,
in one depth frame, runs of image columns in which nothing in the robot's height band is nearer than
``open_range_m`` (the floor and overhangs do not count; a pixel with no return counts as open), and
returns one frontier per run wide enough to walk through: its middle column and the pixel on the
horizon there, which the memory update back-projects like a VLM direction.

This is a core module: standard library and numpy only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import CameraIntrinsics, FloatArray, InvalidInputError


@dataclass(frozen=True)
class Frontier:
    """One open direction in the image.

    Attributes:
        pixel_px: ``(u, v)``: the run's middle column, on the horizon row (clipped into the image).
        width_deg: horizontal angle the open run spans.
        clearance_m: horizontal range of the nearest obstacle-band point in the middle column
            (``inf`` when the column sees none).
    """

    pixel_px: tuple[float, float]
    width_deg: float
    clearance_m: float


def horizon_row(*, intrinsics: CameraIntrinsics, camera_to_world: FloatArray) -> float:
    """Image row whose rays are horizontal in ``map`` (optical frame: x right, y down, z forward)."""
    rot = np.asarray(camera_to_world, dtype=float)[:3, :3]
    r21, r22 = float(rot[2, 1]), float(rot[2, 2])
    if abs(r21) < 1e-6:
        return intrinsics.cy_px
    return intrinsics.cy_px - intrinsics.fy_px * r22 / r21


def depth_frontiers(
    *,
    depth_m: npt.NDArray[np.floating[Any]],
    intrinsics: CameraIntrinsics,
    camera_to_world: FloatArray,
    open_range_m: float,
    min_width_deg: float,
    band_min_height_m: float = 0.05,
    band_max_height_m: float = 0.6,
    depth_min_m: float = 0.1,
    depth_max_m: float = 10.0,
    pixel_stride: int = 2,
) -> list[Frontier]:
    """Open directions of one depth frame, widest first.

    Args:
        depth_m: ``(H, W)`` depth along the optical axis; 0, NaN, inf or outside
            ``[depth_min_m, depth_max_m]`` is no return (open).
        intrinsics: pinhole intrinsics of the depth image.
        camera_to_world: ``(4, 4)`` optical camera frame to ``map`` (z up, floor at z = 0).
        open_range_m: a column is open when no obstacle-band point in it is nearer (horizontally).
        min_width_deg: runs of open columns narrower than this are ignored.
        band_min_height_m: points lower than this above the floor are floor.
        band_max_height_m: points higher than this are overhangs the robot walks under.
        depth_min_m: nearer depth is invalid.
        depth_max_m: farther depth is invalid.
        pixel_stride: every stride-th row is examined (all columns are).

    Raises:
        InvalidInputError: on a depth image whose shape does not match the intrinsics, or bad ranges.
    """
    depth = np.asarray(depth_m, dtype=float)
    if depth.shape != (intrinsics.height_px, intrinsics.width_px):
        raise InvalidInputError(
            f"depth_m shape {depth.shape} does not match intrinsics ({intrinsics.height_px}, {intrinsics.width_px})"
        )
    if not (open_range_m > 0.0 and math.isfinite(open_range_m)):
        raise InvalidInputError(f"open_range_m must be a positive finite number, got {open_range_m!r}")
    if pixel_stride < 1:
        raise InvalidInputError(f"pixel_stride must be >= 1, got {pixel_stride!r}")
    transform = np.asarray(camera_to_world, dtype=float)
    rows = np.arange(0, depth.shape[0], pixel_stride, dtype=float)
    cols = np.arange(depth.shape[1], dtype=float)
    sub = depth[::pixel_stride, :]
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(sub) & (sub >= depth_min_m) & (sub <= depth_max_m)
    z = np.where(valid, sub, 0.0)
    x_cam = (cols[None, :] - intrinsics.cx_px) / intrinsics.fx_px * z
    y_cam = (rows[:, None] - intrinsics.cy_px) / intrinsics.fy_px * z
    rot, origin = transform[:3, :3], transform[:3, 3]
    world_x = rot[0, 0] * x_cam + rot[0, 1] * y_cam + rot[0, 2] * z
    world_y = rot[1, 0] * x_cam + rot[1, 1] * y_cam + rot[1, 2] * z
    world_z = rot[2, 0] * x_cam + rot[2, 1] * y_cam + rot[2, 2] * z + origin[2]
    obstacle = valid & (world_z >= band_min_height_m) & (world_z <= band_max_height_m)
    horizontal = np.hypot(world_x, world_y)
    clearance = np.where(obstacle, horizontal, np.inf).min(axis=0)  # (W,)
    open_col = clearance >= open_range_m

    horizon = float(
        np.clip(horizon_row(intrinsics=intrinsics, camera_to_world=transform), 0, depth.shape[0] - 1)
    )
    out: list[Frontier] = []
    u = 0
    width = depth.shape[1]
    while u < width:
        if not open_col[u]:
            u += 1
            continue
        start = u
        while u + 1 < width and open_col[u + 1]:
            u += 1
        span_deg = math.degrees(
            math.atan2(u + 0.5 - intrinsics.cx_px, intrinsics.fx_px)
            - math.atan2(start - 0.5 - intrinsics.cx_px, intrinsics.fx_px)
        )
        if span_deg >= min_width_deg:
            mid = (start + u) // 2
            out.append(
                Frontier(
                    pixel_px=(float(mid), horizon), width_deg=span_deg, clearance_m=float(clearance[mid])
                )
            )
        u += 1
    out.sort(key=lambda f: -f.width_deg)
    return out
