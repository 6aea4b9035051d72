"""Camera and planar geometry shared by the evidence arbitration and the topological memory.

Conventions (see ``semexp_bt.core.types``):

* Image coordinates ``(u, v)`` are (column, row) in pixels. Pixel ``(i, j)`` has its centre at the integer
  point ``(i, j)`` and covers ``[i - 0.5, i + 0.5) x [j - 0.5, j + 0.5)``, so the whole image is
  ``[-0.5, W - 0.5) x [-0.5, H - 0.5)``; this matches ``CameraIntrinsics.from_fov`` (``cx = (W - 1) / 2``).
  A depth image is indexed ``depth[row, column]``.
* Boxes are ``(u0, v0, u1, v1)`` in the same coordinates with ``u0 <= u1`` and ``v0 <= v1``.
  :func:`clip_box` clips to the span of pixel centres ``[0, W - 1] x [0, H - 1]``, so the centre of a
  clipped box, and any convex combination of such centres, is always a pixel of the image.
* The camera frame is the optical frame (x right, y down, z forward); ``camera_to_world`` is the 4x4
  rigid transform T_w<-c.
* Planar poses follow REP-103: x forward, y left, yaw counter-clockwise about +z.

This is a core module: standard library and numpy only. Batch functions take ``(N, ...)`` arrays and
never loop over pixels in Python.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, overload

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import (
    CameraIntrinsics,
    FloatArray,
    InvalidInputError,
    Observation,
    Pose2D,
    require_finite,
)

#: Tolerance on ``R R^T = I`` and ``det R = 1`` when checking that a transform is rigid. Loose enough for
#: float32 quaternion round trips, tight enough to catch a scaled or sheared matrix.
RIGID_TOLERANCE = 1e-5

#: How many samples per side :func:`box_depth_stats` draws from a box (a regular grid). A 16 x 16 grid
#: gives the median of 256 depths, robust and cheap whatever the box size.
BOX_DEPTH_SAMPLES_PER_SIDE = 16

_TWO_PI = 2.0 * math.pi


def fast_clip(values: npt.NDArray[Any], low: Any, high: Any) -> npt.NDArray[Any]:
    """``np.clip`` for the hot paths: two ufunc calls, without ``np.clip``'s per-call Python overhead
    (several microseconds, which dominates on the small arrays of one arbitration)."""
    return np.minimum(np.maximum(values, low), high)


# ----------------------------------------------------------------------------------------------------------
# Validation helpers
# ----------------------------------------------------------------------------------------------------------


def _check_intrinsics(intrinsics: CameraIntrinsics) -> None:
    for name in ("fx_px", "fy_px", "cx_px", "cy_px"):
        require_finite(f"intrinsics.{name}", getattr(intrinsics, name))
    if intrinsics.fx_px <= 0.0 or intrinsics.fy_px <= 0.0:
        raise InvalidInputError(
            f"intrinsics.fx_px and intrinsics.fy_px must be positive, got {intrinsics.fx_px}, {intrinsics.fy_px}"
        )
    if intrinsics.width_px <= 0 or intrinsics.height_px <= 0:
        raise InvalidInputError(
            f"intrinsics.width_px and intrinsics.height_px must be positive, "
            f"got {intrinsics.width_px}, {intrinsics.height_px}"
        )


def _check_rigid(name: str, transform: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Validate a 4x4 rigid transform and return its rotation and translation."""
    matrix = np.asarray(transform, dtype=float)
    if matrix.shape != (4, 4):
        raise InvalidInputError(f"{name} must be a 4x4 matrix, got shape {matrix.shape}")
    if not np.all(np.isfinite(matrix)):
        raise InvalidInputError(f"{name} must be finite, got {matrix!r}")
    if not np.allclose(matrix[3], (0.0, 0.0, 0.0, 1.0), atol=RIGID_TOLERANCE):
        raise InvalidInputError(f"{name} must have last row (0, 0, 0, 1), got {matrix[3]!r}")
    rotation = matrix[:3, :3]
    if not np.allclose(rotation @ rotation.T, np.eye(3), atol=RIGID_TOLERANCE) or (
        np.linalg.det(rotation) < 0.0
    ):
        raise InvalidInputError(f"{name} must be a rigid transform (rotation block orthonormal, det +1)")
    return rotation, matrix[:3, 3]


def check_box(name: str, box: Sequence[float] | npt.ArrayLike) -> tuple[float, float, float, float]:
    """Validate one ``(u0, v0, u1, v1)`` box: four finite numbers, not inverted.

    Args:
        name: the field to name in errors.
        box: the box.

    Returns:
        The box as a tuple of floats.

    Raises:
        InvalidInputError: wrong length, NaN/inf, or ``u1 < u0`` / ``v1 < v0``.
    """
    arr = np.asarray(box, dtype=float)
    if arr.shape != (4,):
        raise InvalidInputError(f"{name} must be (u0, v0, u1, v1), got {box!r}")
    require_finite(name, arr)
    u0, v0, u1, v1 = (float(x) for x in arr)
    if u1 < u0 or v1 < v0:
        raise InvalidInputError(f"{name} is inverted (need u0 <= u1 and v0 <= v1), got {box!r}")
    return (u0, v0, u1, v1)


def check_boxes(name: str, boxes: npt.ArrayLike, field_suffix: str = "") -> FloatArray:
    """Validate an ``(N, 4)`` array of boxes.

    Args:
        name: the collection to name in errors.
        boxes: the boxes, one per row.
        field_suffix: appended to the row name, so the first bad row is reported as
            ``f"{name}[{i}]{field_suffix}"`` (e.g. ``detections[3].box_xyxy_px``).

    Returns:
        The boxes as an ``(N, 4)`` float array.
    """
    arr = np.asarray(boxes, dtype=float)
    if arr.size == 0:
        return arr.reshape(0, 4)
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise InvalidInputError(f"{name} must have shape (N, 4), got {arr.shape}")
    bad_finite = ~np.all(np.isfinite(arr), axis=1)
    if bad_finite.any():
        i = int(np.argmax(bad_finite))
        raise InvalidInputError(f"{name}[{i}]{field_suffix} must be finite, got {tuple(arr[i])!r}")
    inverted = (arr[:, 2] < arr[:, 0]) | (arr[:, 3] < arr[:, 1])
    if inverted.any():
        i = int(np.argmax(inverted))
        raise InvalidInputError(
            f"{name}[{i}]{field_suffix} is inverted (need u0 <= u1 and v0 <= v1), got {tuple(arr[i])!r}"
        )
    return arr


def in_image(pixel_px: Sequence[float], width_px: int, height_px: int) -> bool:
    """Whether ``(u, v)`` lies on the image ``[-0.5, W - 0.5) x [-0.5, H - 0.5)``."""
    u, v = float(pixel_px[0]), float(pixel_px[1])
    return -0.5 <= u < width_px - 0.5 and -0.5 <= v < height_px - 0.5


# ----------------------------------------------------------------------------------------------------------
# Camera model (paper Eq. 5)
# ----------------------------------------------------------------------------------------------------------


def back_project(
    pixel_px: Sequence[float],
    depth_m: float,
    intrinsics: CameraIntrinsics,
    camera_to_world: npt.ArrayLike,
) -> FloatArray:
    """Back-project one pixel with its depth to a world point: P = T_w<-c pi^-1(p, D(p)) (paper Eq. 5).

    Args:
        pixel_px: ``(u, v)`` image point; must lie on the image.
        depth_m: depth along the optical axis (z in the camera frame), finite and positive.
        intrinsics: pinhole intrinsics K.
        camera_to_world: 4x4 rigid transform T_w<-c.

    Returns:
        The ``(3,)`` world point in metres.

    Raises:
        InvalidInputError: naming ``pixel_px``, ``depth_m``, ``intrinsics.*`` or ``camera_to_world``.
    """
    if len(pixel_px) != 2:
        raise InvalidInputError(f"pixel_px must be (u, v), got {pixel_px!r}")
    require_finite("pixel_px", pixel_px)
    require_finite("depth_m", depth_m)
    if depth_m <= 0.0:
        raise InvalidInputError(f"depth_m must be positive, got {depth_m!r}")
    _check_intrinsics(intrinsics)
    if not in_image(pixel_px, intrinsics.width_px, intrinsics.height_px):
        raise InvalidInputError(
            f"pixel_px {tuple(pixel_px)!r} lies outside the {intrinsics.width_px}x{intrinsics.height_px} image"
        )
    rotation, translation = _check_rigid("camera_to_world", camera_to_world)
    u, v = float(pixel_px[0]), float(pixel_px[1])
    z = float(depth_m)
    point_camera = np.array(
        [(u - intrinsics.cx_px) * z / intrinsics.fx_px, (v - intrinsics.cy_px) * z / intrinsics.fy_px, z]
    )
    return rotation @ point_camera + translation


def back_project_pixels(
    pixels_px: npt.ArrayLike,
    depths_m: npt.ArrayLike,
    intrinsics: CameraIntrinsics,
    camera_to_world: npt.ArrayLike,
) -> FloatArray:
    """Batch :func:`back_project`: ``(N, 2)`` pixels and ``(N,)`` depths to ``(N, 3)`` world points.

    Raises:
        InvalidInputError: as :func:`back_project`, naming the first bad row (``pixels_px[i]``, ``depths_m[i]``).
    """
    pixels = np.asarray(pixels_px, dtype=float).reshape(-1, 2)
    depths = np.asarray(depths_m, dtype=float).reshape(-1)
    if depths.shape[0] != pixels.shape[0]:
        raise InvalidInputError(f"depths_m has {depths.shape[0]} entries for {pixels.shape[0]} pixels_px")
    _check_intrinsics(intrinsics)
    rotation, translation = _check_rigid("camera_to_world", camera_to_world)
    bad_pixel = ~np.all(np.isfinite(pixels), axis=1)
    bad_pixel |= ~(
        (pixels[:, 0] >= -0.5)
        & (pixels[:, 0] < intrinsics.width_px - 0.5)
        & (pixels[:, 1] >= -0.5)
        & (pixels[:, 1] < intrinsics.height_px - 0.5)
    )
    if bad_pixel.any():
        i = int(np.argmax(bad_pixel))
        raise InvalidInputError(
            f"pixels_px[{i}] = {tuple(pixels[i])!r} is not finite or lies outside the image"
        )
    bad_depth = ~(np.isfinite(depths) & (depths > 0.0))
    if bad_depth.any():
        i = int(np.argmax(bad_depth))
        raise InvalidInputError(f"depths_m[{i}] must be finite and positive, got {depths[i]!r}")
    points_camera = np.stack(
        [
            (pixels[:, 0] - intrinsics.cx_px) * depths / intrinsics.fx_px,
            (pixels[:, 1] - intrinsics.cy_px) * depths / intrinsics.fy_px,
            depths,
        ],
        axis=1,
    )
    return points_camera @ rotation.T + translation


def project_to_image(
    point_world: Sequence[float] | npt.ArrayLike,
    intrinsics: CameraIntrinsics,
    camera_to_world: npt.ArrayLike,
) -> tuple[float, float, float] | None:
    """Project a world point into the image (the inverse of :func:`back_project`).

    The result is not clipped to the image: check it with :func:`in_image`.

    Args:
        point_world: ``(3,)`` point in ``map``.
        intrinsics: pinhole intrinsics K.
        camera_to_world: 4x4 rigid transform T_w<-c.

    Returns:
        ``(u, v, z_cam)``, or None when the point is not in front of the camera (``z_cam <= 0``).

    Raises:
        InvalidInputError: naming ``point_world``, ``intrinsics.*`` or ``camera_to_world``.
    """
    point = np.asarray(point_world, dtype=float)
    if point.shape != (3,):
        raise InvalidInputError(f"point_world must be (x, y, z), got {point_world!r}")
    require_finite("point_world", point)
    _check_intrinsics(intrinsics)
    rotation, translation = _check_rigid("camera_to_world", camera_to_world)
    x, y, z = rotation.T @ (point - translation)
    if z <= 0.0:
        return None
    u = intrinsics.fx_px * x / z + intrinsics.cx_px
    v = intrinsics.fy_px * y / z + intrinsics.cy_px
    return (float(u), float(v), float(z))


def project_points(
    points_world: npt.ArrayLike,
    intrinsics: CameraIntrinsics,
    camera_to_world: npt.ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    """Batch :func:`project_to_image`.

    Args:
        points_world: ``(N, 3)`` points in ``map``; must be finite.
        intrinsics: pinhole intrinsics K.
        camera_to_world: 4x4 rigid transform T_w<-c.

    Returns:
        ``(uv, z_cam)``: ``(N, 2)`` image points and ``(N,)`` camera depths. Rows with ``z_cam <= 0`` are
        behind the camera and their ``uv`` is NaN, so the mask ``z_cam > 0`` must be applied before use.
    """
    points = np.asarray(points_world, dtype=float).reshape(-1, 3)
    bad = ~np.all(np.isfinite(points), axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(f"points_world[{i}] must be finite, got {tuple(points[i])!r}")
    _check_intrinsics(intrinsics)
    rotation, translation = _check_rigid("camera_to_world", camera_to_world)
    camera = (points - translation) @ rotation
    z = camera[:, 2]
    in_front = z > 0.0
    safe_z = np.where(in_front, z, 1.0)
    uv = np.stack(
        [
            intrinsics.fx_px * camera[:, 0] / safe_z + intrinsics.cx_px,
            intrinsics.fy_px * camera[:, 1] / safe_z + intrinsics.cy_px,
        ],
        axis=1,
    )
    uv[~in_front] = np.nan
    return uv, z


# ----------------------------------------------------------------------------------------------------------
# Boxes
# ----------------------------------------------------------------------------------------------------------


def box_iou(a_xyxy: Sequence[float], b_xyxy: Sequence[float]) -> float:
    """Intersection over union of two boxes, in [0, 1]; 0 when the union has no area.

    Raises:
        InvalidInputError: a box is not four finite numbers or is inverted.
    """
    a = check_box("a_xyxy", a_xyxy)
    b = check_box("b_xyxy", b_xyxy)
    inter = _intersection_area(a, b)
    union = _area(a) + _area(b) - inter
    if union <= 0.0:
        return 0.0
    return min(1.0, max(0.0, inter / union))


def box_share_inside(region_xyxy: Sequence[float], box_xyxy: Sequence[float]) -> float:
    """The share of ``region``'s area that lies inside ``box``, in [0, 1]; 0 for a region with no area.

    Unlike IoU it does not fall when the box is much larger than the region: a part named inside an
    object's box lies wholly inside it (``(10, 10, 20, 20)`` in ``(0, 0, 100, 100)``: 1.0).

    Raises:
        InvalidInputError: a box is not four finite numbers or is inverted.
    """
    region = check_box("region_xyxy", region_xyxy)
    box = check_box("box_xyxy", box_xyxy)
    area = _area(region)
    return 0.0 if area <= 0.0 else min(1.0, _intersection_area(region, box) / area)


def _area(box: tuple[float, float, float, float]) -> float:
    return (box[2] - box[0]) * (box[3] - box[1])


def _intersection_area(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> float:
    return max(0.0, min(a[2], b[2]) - max(a[0], b[0])) * max(0.0, min(a[3], b[3]) - max(a[1], b[1]))


def box_iou_matrix(a_xyxy: npt.ArrayLike, b_xyxy: npt.ArrayLike) -> FloatArray:
    """Pairwise IoU of ``(N, 4)`` and ``(M, 4)`` boxes as an ``(N, M)`` array in [0, 1].

    Raises:
        InvalidInputError: a row is not finite or is inverted (named ``a_xyxy[i]`` / ``b_xyxy[j]``).
    """
    return iou_matrix_unchecked(check_boxes("a_xyxy", a_xyxy), check_boxes("b_xyxy", b_xyxy))


def iou_matrix_unchecked(a: FloatArray, b: FloatArray) -> FloatArray:
    """:func:`box_iou_matrix` on boxes already validated by :func:`check_boxes` (no checks, for hot paths)."""
    inter_w = np.maximum(
        np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0]), 0.0
    )
    inter_h = np.maximum(
        np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1]), 0.0
    )
    inter = inter_w * inter_h
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, None] + area_b[None, :] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        iou = np.where(union > 0.0, inter / np.where(union > 0.0, union, 1.0), 0.0)
    return fast_clip(iou, 0.0, 1.0)


def clip_box(box: Sequence[float], width: int, height: int) -> tuple[float, float, float, float]:
    """Clip a box to the span of pixel centres ``[0, width - 1] x [0, height - 1]``.

    A box entirely outside the image collapses onto the nearest border (zero area, IoU 0 with anything).

    Raises:
        InvalidInputError: the box is malformed or the image size is not positive.
    """
    u0, v0, u1, v1 = check_box("box", box)
    if width <= 0 or height <= 0:
        raise InvalidInputError(f"width and height must be positive, got {width}, {height}")
    u_max, v_max = float(width - 1), float(height - 1)
    return (
        min(max(u0, 0.0), u_max),
        min(max(v0, 0.0), v_max),
        min(max(u1, 0.0), u_max),
        min(max(v1, 0.0), v_max),
    )


def clip_boxes(boxes: FloatArray, width: int, height: int) -> FloatArray:
    """Batch :func:`clip_box` for validated ``(N, 4)`` boxes; returns a new array."""
    limits = np.array([width - 1, height - 1, width - 1, height - 1], dtype=float)
    return fast_clip(boxes, 0.0, limits)


# ----------------------------------------------------------------------------------------------------------
# Depth statistics
# ----------------------------------------------------------------------------------------------------------


def _check_depth_image(depth_m: npt.ArrayLike) -> npt.NDArray[np.generic]:
    depth = np.asarray(depth_m)
    if depth.ndim != 2 or depth.shape[0] == 0 or depth.shape[1] == 0:
        raise InvalidInputError(f"depth_m must be a non-empty (H, W) image, got shape {depth.shape}")
    if not (np.issubdtype(depth.dtype, np.floating) or np.issubdtype(depth.dtype, np.integer)):
        raise InvalidInputError(f"depth_m must hold numbers (metres), got dtype {depth.dtype}")
    return depth


def _gather(
    depth: npt.NDArray[np.generic], rows: npt.NDArray[np.int64], cols: npt.NDArray[np.int64]
) -> FloatArray:
    """``depth[rows, cols]`` as float64 (indices broadcast together and already clipped to the image)."""
    if depth.flags.c_contiguous:
        # A flat take is markedly cheaper than 2-D fancy indexing, and reshape(-1) is free here.
        return depth.reshape(-1).take(rows * depth.shape[1] + cols).astype(float)
    return depth[rows, cols].astype(float)


def _masked_median(values: FloatArray, valid: npt.NDArray[np.bool_]) -> FloatArray:
    """Row-wise median of ``values[k, valid[k]]``; NaN for rows with no valid entry. ``(K, N)`` -> ``(K,)``."""
    keyed = np.where(valid, values, np.inf)
    keyed.sort(axis=1)
    count = valid.sum(axis=1)
    last = values.shape[1] - 1
    lo = fast_clip((count - 1) // 2, 0, last)
    hi = fast_clip(count // 2, 0, last)
    rows = np.arange(values.shape[0])
    median = 0.5 * (keyed[rows, lo] + keyed[rows, hi])
    median[count == 0] = np.nan
    return median


def patch_depth_stats(
    depth_m: npt.ArrayLike, pixels_px: npt.ArrayLike, patch_px: int
) -> tuple[FloatArray, FloatArray]:
    """Median of the valid depths and fraction of valid pixels in a square patch around each pixel.

    A depth is valid when finite and positive (a D435i reports holes as 0; renderers may give NaN or inf).
    The patch has side ``2 * (patch_px // 2) + 1`` (an odd ``patch_px`` is used as is) centred on the
    pixel containing each point; the part of the patch that falls off the image is ignored.

    Args:
        depth_m: ``(H, W)`` depth image in metres.
        pixels_px: ``(K, 2)`` image points ``(u, v)``; must be finite.
        patch_px: patch side, at least 1.

    Returns:
        ``(median_m, valid_fraction)``, both ``(K,)``; ``median_m`` is NaN where no pixel is valid (and
        ``valid_fraction`` is then 0).
    """
    depth = _check_depth_image(depth_m)
    pixels = np.asarray(pixels_px, dtype=float).reshape(-1, 2)
    require_finite("pixels_px", pixels)
    if patch_px < 1:
        raise InvalidInputError(f"patch_px must be at least 1, got {patch_px}")
    height, width = depth.shape
    half = int(patch_px) // 2
    offsets = np.arange(-half, half + 1)
    cols = np.floor(pixels[:, 0] + 0.5).astype(np.int64)[:, None] + offsets
    rows = np.floor(pixels[:, 1] + 0.5).astype(np.int64)[:, None] + offsets
    inside = ((rows >= 0) & (rows < height))[:, :, None] & ((cols >= 0) & (cols < width))[:, None, :]
    values = _gather(
        depth, fast_clip(rows, 0, height - 1)[:, :, None], fast_clip(cols, 0, width - 1)[:, None, :]
    )
    values = values.reshape(len(pixels), -1)
    inside = inside.reshape(len(pixels), -1)
    with np.errstate(invalid="ignore"):
        valid = inside & np.isfinite(values) & (values > 0.0)
    n_inside = np.maximum(inside.sum(axis=1), 1)
    return _masked_median(values, valid), valid.sum(axis=1) / n_inside


def _box_depth_samples(
    depth: npt.NDArray[np.generic], boxes: FloatArray, samples_per_side: int
) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Depths on a ``samples_per_side`` squared grid inside each box (corners included, indices clipped to
    the image), ``(K, samples_per_side ** 2)``, with the mask of the valid (finite, > 0) ones."""
    if samples_per_side < 1:
        raise InvalidInputError(f"samples_per_side must be at least 1, got {samples_per_side}")
    height, width = depth.shape
    steps = np.linspace(0.0, 1.0, int(samples_per_side))
    us = boxes[:, 0, None] + (boxes[:, 2] - boxes[:, 0])[:, None] * steps
    vs = boxes[:, 1, None] + (boxes[:, 3] - boxes[:, 1])[:, None] * steps
    cols = fast_clip(np.floor(us + 0.5).astype(np.int64), 0, width - 1)
    rows = fast_clip(np.floor(vs + 0.5).astype(np.int64), 0, height - 1)
    values = _gather(depth, rows[:, :, None], cols[:, None, :]).reshape(len(boxes), -1)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(values) & (values > 0.0)
    return values, valid


def box_depth_stats(
    depth_m: npt.ArrayLike, boxes_xyxy: npt.ArrayLike, samples_per_side: int = BOX_DEPTH_SAMPLES_PER_SIDE
) -> tuple[FloatArray, FloatArray]:
    """Robust depth of each box: the median of valid depths on a regular grid of samples inside it.

    The grid (``samples_per_side`` squared points, box corners included, indices clipped to the image)
    keeps the cost independent of the box size; for a box narrower than the grid some pixels are
    sampled twice, which leaves the median essentially unchanged.

    Returns:
        ``(median_m, valid_fraction)``, both ``(K,)``; ``median_m`` is NaN where no sample is valid.
    """
    depth = _check_depth_image(depth_m)
    boxes = check_boxes("boxes_xyxy", boxes_xyxy)
    values, valid = _box_depth_samples(depth, boxes, samples_per_side)
    return _masked_median(values, valid), valid.mean(axis=1)


def robust_depth(depth_m: npt.ArrayLike, pixel: Sequence[float], patch_px: int) -> float | None:
    """Median of the valid (finite, > 0) depths in a ``patch_px`` patch around ``pixel``, or None.

    Raises:
        InvalidInputError: ``depth_m`` is not an image, ``pixel`` is not finite or lies off the image.
    """
    depth = _check_depth_image(depth_m)
    require_finite("pixel", pixel)
    if not in_image(pixel, depth.shape[1], depth.shape[0]):
        raise InvalidInputError(
            f"pixel {tuple(pixel)!r} lies outside the {depth.shape[1]}x{depth.shape[0]} image"
        )
    median, _ = patch_depth_stats(depth, np.asarray(pixel, dtype=float).reshape(1, 2), patch_px)
    return None if math.isnan(median[0]) else float(median[0])


#: Percentile of the valid depths inside an object's box that :func:`object_surface_depth` takes as the
#: object's range: low enough that a thin object (a sign on a pole, a chair's back) wins over the wall seen
#: around it, high enough that a few pixels of floor or an occluder's edge in the box do not.
OBJECT_DEPTH_PERCENTILE = 25.0


def object_surface_depth(
    depth_m: npt.ArrayLike,
    pixel: Sequence[float],
    box_xyxy: Sequence[float] | None,
    patch_px: int,
    *,
    percentile: float = OBJECT_DEPTH_PERCENTILE,
) -> float | None:
    """The range of the object a detection or a VLM answer points at, or None without valid depth.

    A point from a detector's box centre or a VLM's answer often lands beside a thin object, on the
    wall behind it; the median of a small patch then places the object metres too far. With a box (the
    detection box, or the VLM's region), the ``percentile`` of the valid depths on a grid inside the box
    is the nearest large surface there: the object. Without a box this is :func:`robust_depth`.

    Raises:
        InvalidInputError: as :func:`robust_depth`, or a malformed box.
    """
    if box_xyxy is None:
        return robust_depth(depth_m, pixel, patch_px)
    depth = _check_depth_image(depth_m)
    values, valid = _box_depth_samples(depth, check_boxes("box_xyxy", [box_xyxy]), BOX_DEPTH_SAMPLES_PER_SIDE)
    values = values[valid]
    if values.size == 0:
        return robust_depth(depth_m, pixel, patch_px)
    return float(np.percentile(values, percentile))


def locate_in_view(
    observation: Observation,
    pixel: Sequence[float],
    box_xyxy: Sequence[float] | None,
    patch_px: int,
) -> FloatArray | None:
    """The world point of the object a candidate points at in ``observation`` (its range by
    :func:`object_surface_depth`, back-projected through the frame's own camera pose: Eq. 5), or None
    without a finite range there."""
    depth = object_surface_depth(observation.depth_m, pixel, box_xyxy, patch_px)
    if depth is None or not math.isfinite(depth):
        return None
    return back_project(
        pixel_px=pixel,
        depth_m=depth,
        intrinsics=observation.intrinsics,
        camera_to_world=observation.camera_to_world,
    )


# ----------------------------------------------------------------------------------------------------------
# Planar pose helpers
# ----------------------------------------------------------------------------------------------------------


@overload
def wrap_angle(angle_rad: float) -> float: ...


@overload
def wrap_angle(angle_rad: npt.NDArray[Any]) -> FloatArray: ...


def wrap_angle(angle_rad: float | npt.NDArray[Any]) -> float | FloatArray:
    """Wrap an angle, or every angle of an array, to ``[-pi, pi)``: ``(a + pi) mod 2 pi - pi``.

    The one wrap of the code base (headings, bearings, yaw integration, arc scores): a different formula
    (``math.remainder``, say) differs in the last bits, and those bits change whole episodes.

    Example:
        >>> wrap_angle(1.5 * math.pi), wrap_angle(math.pi)
        (-1.5707963267948966, -3.141592653589793)

    Raises:
        InvalidInputError: a NaN or infinite angle.
    """
    require_finite("angle_rad", angle_rad)
    if isinstance(angle_rad, np.ndarray):
        wrapped_array = (angle_rad.astype(float, copy=False) + math.pi) % _TWO_PI - math.pi
        return np.where(wrapped_array >= math.pi, -math.pi, wrapped_array)
    wrapped = (float(angle_rad) + math.pi) % _TWO_PI - math.pi
    # The modulo of a value a hair below -pi can round up to exactly 2 pi; keep the interval half-open.
    return -math.pi if wrapped >= math.pi else wrapped


def world_to_base(point_xy: Sequence[float] | FloatArray, pose: Pose2D) -> tuple[float, float]:
    """Express a ``map`` point in the base frame of ``pose``: ``(x_fwd, y_left)`` in metres."""
    require_finite("point_xy", point_xy)
    require_finite("pose", (pose.x_m, pose.y_m, pose.yaw_rad))
    dx, dy = float(point_xy[0]) - pose.x_m, float(point_xy[1]) - pose.y_m
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    return (c * dx + s * dy, -s * dx + c * dy)


def base_to_world(point_fwd_left: Sequence[float], pose: Pose2D) -> tuple[float, float]:
    """The inverse of :func:`world_to_base`: a base-frame ``(x_fwd, y_left)`` point in ``map``."""
    require_finite("point_fwd_left", point_fwd_left)
    require_finite("pose", (pose.x_m, pose.y_m, pose.yaw_rad))
    x, y = float(point_fwd_left[0]), float(point_fwd_left[1])
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    return (pose.x_m + c * x - s * y, pose.y_m + s * x + c * y)


def bearing_in_base(point_xy: Sequence[float], pose: Pose2D) -> float:
    """Bearing of a ``map`` point seen from ``pose``, in ``[-pi, pi)`` (0 ahead, positive to the left)."""
    x, y = world_to_base(point_xy, pose)
    return wrap_angle(math.atan2(y, x))


# ----------------------------------------------------------------------------------------------------------
# Grid lattice
# ----------------------------------------------------------------------------------------------------------

#: The 16-connected lattice's moves ``(d_row, d_col, cells crossed)``, one of each opposite pair (a graph
#: built from them is undirected): the four straight and diagonal neighbours and the eight knight moves,
#: each with the cells a straight segment between the two centres passes through.
LATTICE_MOVES: tuple[tuple[int, int, tuple[tuple[int, int], ...]], ...] = (
    (0, 1, ()),
    (1, 0, ()),
    (1, 1, ((0, 1), (1, 0))),
    (1, -1, ((0, -1), (1, 0))),
    (1, 2, ((0, 1), (1, 1))),
    (2, 1, ((1, 0), (1, 1))),
    (1, -2, ((0, -1), (1, -1))),
    (2, -1, ((1, 0), (1, -1))),
)


def lattice_steps(
    passable: npt.NDArray[np.bool_],
) -> list[tuple[int, int, npt.NDArray[np.intp], npt.NDArray[np.intp]]]:
    """The edges of the 16-connected lattice over a grid's passable cells, one list entry per move of
    :data:`LATTICE_MOVES`: ``(d_row, d_col, rows, cols)``, the cells ``(rows, cols)`` from which that move
    ends on a passable cell through passable cells only (the grid's edge counts as impassable).

    Example:
        >>> steps = lattice_steps(np.ones((2, 2), dtype=bool))
        >>> [(dr, dc, len(r)) for dr, dc, r, _ in steps if len(r)]
        [(0, 1, 2), (1, 0, 2), (1, 1, 1), (1, -1, 1)]
    """
    rows, cols = passable.shape
    padded = np.pad(passable, 2, constant_values=False)  # so every offset slice stays in range

    def shifted(dr: int, dc: int) -> npt.NDArray[np.bool_]:
        return padded[2 + dr : 2 + dr + rows, 2 + dc : 2 + dc + cols]

    steps = []
    for dr, dc, crossed in LATTICE_MOVES:
        ok = passable & shifted(dr, dc)
        for cr, cc in crossed:
            ok &= shifted(cr, cc)
        r, c = np.nonzero(ok)
        steps.append((dr, dc, r, c))
    return steps
