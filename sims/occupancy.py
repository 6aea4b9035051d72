"""Occupancy grid of a :class:`~semexp_bt.core.scene.SceneSpec`, inflated by the robot's footprint.

The grid covers the scene's walkable bounds. Row ``r`` / column ``c`` holds the cell whose centre is
``(x_min + (c + 0.5) * res, y_min + (r + 0.5) * res)``, so ``grid[r, c]`` plotted with ``origin="lower"``
is the top-down view in ``map``.

A cell is *occupied* when its centre lies within half a cell of an obstacle's footprint (so thin posts
and walls are never missed between cell centres). The footprint of an object is its main geom and every
part that starts below :data:`~sims.robot_footprint.ROBOT_CLEARANCE_HEIGHT_M`; objects with
``is_obstacle=False`` (rugs, road markings) are ignored. Everything outside the bounds counts as
occupied. A cell is *blocked* when it is occupied or its centre is closer than the robot radius to an
occupied cell centre (Euclidean distance transform); *free* cells are the rest: places where the base
centre may stand in any heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from semexp_bt.core.scene import PlanarGeom, SceneObject, SceneSpec
from semexp_bt.core.types import InvalidInputError, require_finite
from sims.robot_footprint import ROBOT_CLEARANCE_HEIGHT_M, ROBOT_RADIUS_M

#: Default cell side (m).
DEFAULT_RESOLUTION_M = 0.05

BoolGrid = npt.NDArray[np.bool_]
FloatGrid = npt.NDArray[np.float64]


@dataclass(frozen=True)
class GridGeometry:
    """Where the grid lies in ``map``: origin (the bounds' lower-left corner), cell side and shape."""

    x_min_m: float
    y_min_m: float
    resolution_m: float
    rows: int
    cols: int

    @classmethod
    def over_bounds(cls, bounds_m: tuple[float, float, float, float], *, resolution_m: float) -> GridGeometry:
        """The grid that covers ``bounds_m = (x_min, y_min, x_max, y_max)`` with square cells."""
        require_finite("bounds_m", bounds_m)
        require_finite("resolution_m", resolution_m)
        x_min, y_min, x_max, y_max = (float(v) for v in bounds_m)
        if not (x_max > x_min and y_max > y_min):
            raise InvalidInputError(
                f"bounds_m must be (x_min, y_min, x_max, y_max) with max > min, got {bounds_m}"
            )
        if resolution_m <= 0.0:
            raise InvalidInputError(f"resolution_m must be positive, got {resolution_m}")
        cols = max(1, int(math.ceil((x_max - x_min) / resolution_m - 1e-9)))
        rows = max(1, int(math.ceil((y_max - y_min) / resolution_m - 1e-9)))
        return cls(x_min, y_min, float(resolution_m), rows, cols)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows, self.cols)

    def cell_of(self, xy: npt.ArrayLike) -> tuple[int, int]:
        """``(row, col)`` of the cell holding ``xy``; may lie outside the grid (check with :meth:`contains`)."""
        x, y = np.asarray(xy, dtype=float)[:2]
        return (
            int(math.floor((y - self.y_min_m) / self.resolution_m)),
            int(math.floor((x - self.x_min_m) / self.resolution_m)),
        )

    def contains(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.rows and 0 <= cell[1] < self.cols

    def centre_of(self, row: npt.ArrayLike, col: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Cell centres ``(..., 2)`` in ``map`` for arrays of rows and columns."""
        x = self.x_min_m + (np.asarray(col, dtype=float) + 0.5) * self.resolution_m
        y = self.y_min_m + (np.asarray(row, dtype=float) + 0.5) * self.resolution_m
        return np.stack([x, y], axis=-1)


def footprint_geoms(obj: SceneObject) -> list[PlanarGeom]:
    """The planar geoms that block the robot (``SceneObject.planar_geoms`` below the clearance height)."""
    return obj.planar_geoms(below_height_m=ROBOT_CLEARANCE_HEIGHT_M)


def rasterise_object(obj: SceneObject, grid: GridGeometry, *, whole: bool = False) -> BoolGrid:
    """Cells whose centre lies within half a cell of ``obj``'s blocking footprint (ignores ``is_obstacle``);
    ``whole``: of its whole footprint, overhead geoms included (the success region's base)."""
    mask = np.zeros(grid.shape, dtype=bool)
    margin = 0.5 * grid.resolution_m
    for shape, cx, cy, yaw, hx, hy in obj.planar_geoms() if whole else footprint_geoms(obj):
        reach = math.hypot(hx, hy) + margin
        r0, c0 = grid.cell_of((cx - reach, cy - reach))
        r1, c1 = grid.cell_of((cx + reach, cy + reach))
        r0, c0 = max(r0, 0), max(c0, 0)
        r1, c1 = min(r1, grid.rows - 1), min(c1, grid.cols - 1)
        if r1 < r0 or c1 < c0:
            continue  # entirely outside the grid
        rows, cols = np.mgrid[r0 : r1 + 1, c0 : c1 + 1]
        centres = grid.centre_of(rows, cols)
        dx, dy = centres[..., 0] - cx, centres[..., 1] - cy
        if shape == "cylinder":
            inside = dx * dx + dy * dy <= (hx + margin) ** 2
        elif shape == "box":
            cos_y, sin_y = math.cos(yaw), math.sin(yaw)
            local_x = cos_y * dx + sin_y * dy
            local_y = -sin_y * dx + cos_y * dy
            inside = (np.abs(local_x) <= hx + margin) & (np.abs(local_y) <= hy + margin)
        else:
            raise InvalidInputError(
                f"object '{obj.name}': unknown shape '{shape}' (expected box or cylinder)"
            )
        mask[r0 : r1 + 1, c0 : c1 + 1] |= inside
    return mask


def distance_to_mask_m(mask: BoolGrid, grid: GridGeometry) -> FloatGrid:
    """Distance (m) from every cell centre to the nearest ``True`` cell centre (inf if there is none)."""
    if not mask.any():
        return np.full(grid.shape, np.inf)
    return ndimage.distance_transform_edt(~mask) * grid.resolution_m


@dataclass(frozen=True)
class OccupancyGrid:
    """Occupied and inflated (blocked) cells of a scene.

    Attributes:
        geometry: where the grid lies.
        occupied: cells inside an obstacle's footprint.
        blocked: occupied cells and cells closer than ``robot_radius_m`` to one or to the bounds.
        clearance_m: distance from each cell centre to the nearest occupied cell or out-of-bounds cell.
        robot_radius_m: the inflation radius.
    """

    geometry: GridGeometry
    occupied: BoolGrid
    blocked: BoolGrid
    clearance_m: FloatGrid
    robot_radius_m: float

    @classmethod
    def from_scene(
        cls,
        scene: SceneSpec,
        *,
        resolution_m: float = DEFAULT_RESOLUTION_M,
        robot_radius_m: float = ROBOT_RADIUS_M,
    ) -> OccupancyGrid:
        """Rasterise every ``is_obstacle`` object of ``scene`` and inflate by ``robot_radius_m``."""
        geometry = GridGeometry.over_bounds(scene.bounds_m, resolution_m=resolution_m)
        occupied = np.zeros(geometry.shape, dtype=bool)
        for obj in scene.objects:
            if obj.is_obstacle:
                occupied |= rasterise_object(obj, geometry)
        return cls.from_occupied(occupied, geometry=geometry, robot_radius_m=robot_radius_m)

    @classmethod
    def from_occupied(
        cls, occupied: BoolGrid, *, geometry: GridGeometry, robot_radius_m: float
    ) -> OccupancyGrid:
        """Inflate a ready occupied mask (the bounds' outside counts as occupied)."""
        require_finite("robot_radius_m", robot_radius_m)
        if robot_radius_m < 0.0:
            raise InvalidInputError(f"robot_radius_m must be >= 0, got {robot_radius_m}")
        # One ring of occupied cells around the grid stands for the walls beyond the bounds.
        padded = np.pad(occupied, 1, constant_values=True)
        clearance = ndimage.distance_transform_edt(~padded)[1:-1, 1:-1] * geometry.resolution_m
        blocked = occupied | (clearance < robot_radius_m)
        return cls(geometry, occupied, blocked, clearance, float(robot_radius_m))

    @property
    def free(self) -> BoolGrid:
        return ~self.blocked

    def is_free(self, xy: npt.ArrayLike) -> bool:
        """Whether the robot centre may stand at ``xy`` (inside the bounds and not in an inflated obstacle)."""
        require_finite("xy", xy)
        cell = self.geometry.cell_of(xy)
        return self.geometry.contains(cell) and not bool(self.blocked[cell])

    def largest_free_component(self) -> BoolGrid:
        """The largest 8-connected region of free cells (empty if nothing is free)."""
        labels, count = ndimage.label(self.free, structure=np.ones((3, 3), dtype=int))
        if count == 0:
            return np.zeros(self.geometry.shape, dtype=bool)
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        return labels == int(np.argmax(sizes))
