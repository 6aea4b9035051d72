"""A 2D occupancy map built from the head camera's depth, and shortest paths on it.

The paper's local planner (ViPlanner) sees only the current depth image. In rooms joined by narrow gaps,
a planner that sees only the current view turns back and forth in front of the partition instead of going
round it. A field user expects a small mapping layer under the local planner, as in Nav2 (a global
costmap and a planner over it, feeding a local controller). This module is that layer, and nothing more:

- :meth:`OccupancyMap.integrate` casts a subsample of the depth pixels into a world-frame grid (0.1 m by
  default). The end of a ray that lands on something between ``obstacle_min_z_m`` and
  ``obstacle_max_z_m`` above the floor counts as an obstacle hit. Every cell the ray crosses before it
  counts as seen free. A cell is occupied when its hits outweigh its free passes.
- :meth:`OccupancyMap.path` runs Dijkstra (scipy.sparse.csgraph) over the cells that are neither occupied
  nor within the robot's radius of an occupied cell. Unknown cells are traversable at a small extra cost:
  the planner is optimistic, and the local planner on live depth keeps the robot safe. It returns
  waypoints to the reachable cell nearest the goal within ``goal_tolerance_m``. A goal on an object's
  surface is reached by standing next to it.

The map is odometry-framed (``map`` = the backend's world frame, REP-105 ``odom`` on a real robot without
global optimisation, as in the paper) and bounded: a square of ``extent_m`` around the mission's start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from semexp_bt.core.types import Observation, PixelGrid, require_finite

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class OccupancyMapConfig:
    """Constants of the map, named once."""

    resolution_m: float = 0.1
    """Cell side."""
    extent_m: float = 40.0
    """Side of the square mapped around the start."""
    pixel_stride: int = 6
    """Use every n-th depth pixel in both directions."""
    max_range_m: float = 6.0
    """Rays are integrated up to this depth (free space beyond is not claimed)."""
    obstacle_min_z_m: float = 0.05
    """Returns lower than this above the floor are floor."""
    obstacle_max_z_m: float = 0.6
    """Returns higher than this are overhangs the robot passes under."""
    robot_radius_m: float = 0.38
    """Cells closer than this to an obstacle are not traversable: about the Go1's half-diagonal (0.41 m; its
    body is a 0.65 m x 0.30 m box, so a 0.30 m disc lets its corners clip walls on a turn), with the
    discretisation of the map in mind. A door-wide gap (1.1 m) stays passable."""
    standoff_m: float = 0.45
    """Where a path ends next to an obstacle (a subgoal on an object) it keeps this much room: the head is
    0.29 m ahead of the base centre, so it stays outside OASR's 0.1 m clearance."""
    unknown_cost: float = 1.5
    """Cost multiplier of crossing a never-observed cell."""
    near_obstacle_cost: float = 3.0
    """Extra cost multiplier within ``comfort_m`` of an obstacle (keeps paths off walls)."""
    comfort_m: float = 0.65
    """Distance to obstacles under which the near-obstacle cost applies."""
    goal_tolerance_m: float = 0.9
    """A goal inside an obstacle is reached at the nearest traversable cell within this distance."""
    window_margin_m: float = 4.0
    """Planning uses the bounding box of start and goal grown by this margin (keeps Dijkstra small)."""


@dataclass
class OccupancyMap:
    """Hit/free counts per cell, in a world-aligned grid centred on ``origin_xy``."""

    origin_xy: tuple[float, float]
    config: OccupancyMapConfig = field(default_factory=OccupancyMapConfig)

    def __post_init__(self) -> None:
        require_finite("origin_xy", self.origin_xy)
        n = int(math.ceil(self.config.extent_m / self.config.resolution_m))
        self.size = n
        self.hits = np.zeros((n, n), dtype=np.float32)
        self.free = np.zeros((n, n), dtype=np.float32)
        self.frames = 0
        self._lower = np.array(self.origin_xy, dtype=float) - 0.5 * n * self.config.resolution_m

    # ------------------------------------------------------------------ geometry
    def cell_of(self, xy: FloatArray) -> npt.NDArray[np.int64]:
        """``(..., 2)`` world xy -> ``(..., 2)`` (row = x index, col = y index), unclipped."""
        xy = np.asarray(xy, dtype=float)
        return np.stack([self._axis_index(xy[..., 0], 0), self._axis_index(xy[..., 1], 1)], axis=-1)

    def _axis_index(self, values: FloatArray, axis: int) -> npt.NDArray[np.int64]:
        """World coordinates along ``axis`` (0: x, 1: y) -> grid indices along it, unclipped."""
        return np.floor((values - self._lower[axis]) / self.config.resolution_m).astype(np.int64)

    def centre_of(self, cells: npt.NDArray[np.int64]) -> FloatArray:
        return self._lower + (np.asarray(cells, dtype=float) + 0.5) * self.config.resolution_m

    @property
    def sampled_pixels(self) -> PixelGrid:
        """The only depth pixels :meth:`integrate` reads: every ``pixel_stride``-th from the corner."""
        return PixelGrid(stride=self.config.pixel_stride, offset=0)

    # ------------------------------------------------------------------ mapping
    def integrate(self, observation: Observation) -> int:
        """Add one depth frame; returns how many rays were used."""
        cfg = self.config
        grid = self.sampled_pixels
        depth = np.asarray(
            observation.depth_m[grid.offset :: grid.stride, grid.offset :: grid.stride], dtype=float
        )
        k = observation.intrinsics
        rows, cols = np.meshgrid(
            grid.indices(observation.depth_m.shape[0]),
            grid.indices(observation.depth_m.shape[1]),
            indexing="ij",
        )
        valid = np.isfinite(depth) & (depth > 0.0) & (depth <= cfg.max_range_m)
        if not valid.any():
            return 0
        z = depth[valid]
        pts_cam = np.stack(
            [(cols[valid] - k.cx_px) / k.fx_px * z, (rows[valid] - k.cy_px) / k.fy_px * z, z], axis=1
        )
        t = np.asarray(observation.camera_to_world, dtype=float)
        pts = pts_cam @ t[:3, :3].T + t[:3, 3]
        origin = t[:3, 3]
        height = pts[:, 2]
        is_hit = (height >= cfg.obstacle_min_z_m) & (height <= cfg.obstacle_max_z_m)
        keep = is_hit | (height < cfg.obstacle_min_z_m)  # overhang returns say nothing about the floor plane
        pts, is_hit = pts[keep], is_hit[keep]
        if pts.shape[0] == 0:
            return 0
        # Free space: cells along each ray (in the plane) before its end, sampled at half a cell. A frame
        # has about 2,000 rays and 200,000 samples: x and y are worked one axis at a time, because
        # numpy's (N, 2) gathers and broadcasts cost more than two (N,) ones for the same values.
        delta = pts[:, :2] - origin[:2]
        length = np.linalg.norm(delta, axis=1)
        step = 0.5 * cfg.resolution_m
        n_steps = np.floor(np.maximum(length - cfg.resolution_m, 0.0) / step).astype(np.int64)
        total = int(n_steps.sum())
        if total:
            ray_index = np.repeat(np.arange(pts.shape[0]), n_steps)
            offsets = np.arange(total) - np.repeat(np.cumsum(n_steps) - n_steps, n_steps)
            frac = (offsets * step) / np.maximum(length, 1e-9)[ray_index]
            free_x = origin[0] + delta[:, 0][ray_index] * frac
            free_y = origin[1] + delta[:, 1][ray_index] * frac
            self._accumulate_axes(self.free, free_x, free_y)
        self._accumulate(self.hits, pts[is_hit, :2])
        # A floor return also marks its own cell free.
        self._accumulate(self.free, pts[~is_hit, :2])
        self.frames += 1
        return int(pts.shape[0])

    def _accumulate(self, grid: npt.NDArray[np.float32], xy: FloatArray) -> None:
        self._accumulate_axes(grid, xy[:, 0], xy[:, 1])

    def _accumulate_axes(self, grid: npt.NDArray[np.float32], x: FloatArray, y: FloatArray) -> None:
        if x.shape[0] == 0:
            return
        rows, cols = self._axis_index(x, 0), self._axis_index(y, 1)
        inside = (rows >= 0) & (rows < self.size) & (cols >= 0) & (cols < self.size)
        if not inside.all():
            rows, cols = rows[inside], cols[inside]
        if rows.size == 0:
            return
        # Count within the bounding box of this frame's cells (a few metres), not the whole map: the
        # grid is 160,000 cells and a frame touches a few thousand.
        row0, col0 = int(rows.min()), int(cols.min())
        height, width = int(rows.max()) + 1 - row0, int(cols.max()) + 1 - col0
        counts = np.bincount((rows - row0) * width + (cols - col0), minlength=height * width)
        window = grid[row0 : row0 + height, col0 : col0 + width]
        # At most 4 per cell and frame: one frame cannot outvote many.
        window += np.minimum(counts, 4).astype(np.float32).reshape(height, width)

    def occupied(self) -> npt.NDArray[np.bool_]:
        return (self.hits > 0.0) & (self.hits >= 0.5 * self.free)

    def known(self) -> npt.NDArray[np.bool_]:
        return (self.hits + self.free) > 0.0

    def clearance_at(self, xy: FloatArray) -> float:
        """Mapped distance (m) from ``xy`` to the nearest occupied cell within 2 m (2.0 when none)."""
        cell = self.cell_of(np.asarray(xy, dtype=float))
        reach = int(round(2.0 / self.config.resolution_m))
        lo, hi = np.clip(cell - reach, 0, self.size), np.clip(cell + reach + 1, 0, self.size)
        rows, cols = np.nonzero(self.occupied()[lo[0] : hi[0], lo[1] : hi[1]])
        if rows.size == 0:
            return 2.0
        centres = self.centre_of(np.stack([rows + lo[0], cols + lo[1]], axis=1))
        return float(min(2.0, np.min(np.hypot(centres[:, 0] - xy[0], centres[:, 1] - xy[1]))))

    def known_fraction(self, xy: npt.ArrayLike, *, radius_m: float) -> float:
        """Share of the cells within ``radius_m`` of ``xy`` that some ray has observed."""
        cell = self.cell_of(np.asarray(xy, dtype=float))
        reach = int(math.ceil(radius_m / self.config.resolution_m))
        lo, hi = np.clip(cell - reach, 0, self.size), np.clip(cell + reach + 1, 0, self.size)
        if np.any(hi <= lo):
            return 0.0
        rr, cc = np.ogrid[lo[0] : hi[0], lo[1] : hi[1]]
        disc = (rr - cell[0]) ** 2 + (cc - cell[1]) ** 2 <= reach * reach
        known = self.known()[lo[0] : hi[0], lo[1] : hi[1]]
        return float(known[disc].mean()) if disc.any() else 0.0

    def frontiers(
        self, around_xy: npt.ArrayLike, *, radius_m: float, min_cells: int = 6
    ) -> list[tuple[float, float, int]]:
        """Frontier clusters near ``around_xy``: seen-free cells the robot could stand on that border cells
        no ray has reached. Returns ``(x, y, cells)`` per cluster, at the cluster's cell nearest its centroid."""
        cfg = self.config
        centre = self.cell_of(np.asarray(around_xy, dtype=float))
        reach = int(math.ceil(radius_m / cfg.resolution_m))
        lo, hi = np.clip(centre - reach, 0, self.size), np.clip(centre + reach + 1, 0, self.size)
        occupied = self.occupied()[lo[0] : hi[0], lo[1] : hi[1]]
        known = self.known()[lo[0] : hi[0], lo[1] : hi[1]]
        if min(occupied.shape) < 3:
            return []
        clearance = ndimage.distance_transform_edt(~occupied) * cfg.resolution_m if occupied.any() else None
        standable = known & ~occupied
        if clearance is not None:
            standable &= clearance >= cfg.robot_radius_m
        unknown_near = ndimage.binary_dilation(~known, structure=np.ones((3, 3), dtype=bool))
        frontier = standable & unknown_near
        labels, count = ndimage.label(frontier, structure=np.ones((3, 3), dtype=bool))
        out: list[tuple[float, float, int]] = []
        for k in range(1, count + 1):
            rows, cols = np.nonzero(labels == k)
            if rows.size < min_cells:
                continue
            mean = np.array([rows.mean(), cols.mean()])
            pick = int(np.argmin((rows - mean[0]) ** 2 + (cols - mean[1]) ** 2))
            xy = self.centre_of(np.array([rows[pick] + lo[0], cols[pick] + lo[1]]))
            out.append((float(xy[0]), float(xy[1]), int(rows.size)))
        return out

    # ------------------------------------------------------------------ planning
    def path(self, start_xy: tuple[float, float], goal_xy: tuple[float, float]) -> FloatArray | None:
        """Waypoints ``(N, 2)`` from ``start_xy`` to the reachable cell nearest ``goal_xy`` (within the goal
        tolerance), or None when no such cell is reachable. The start cell is always traversable (the robot
        stands there)."""
        require_finite("start_xy", start_xy)
        require_finite("goal_xy", goal_xy)
        cfg = self.config
        res = cfg.resolution_m
        lo = self.cell_of(np.minimum(start_xy, goal_xy) - cfg.window_margin_m)
        hi = self.cell_of(np.maximum(start_xy, goal_xy) + cfg.window_margin_m) + 1
        lo, hi = np.clip(lo, 0, self.size), np.clip(hi, 0, self.size)
        occupied = self.occupied()[lo[0] : hi[0], lo[1] : hi[1]]
        known = self.known()[lo[0] : hi[0], lo[1] : hi[1]]
        shape = occupied.shape
        if min(shape) < 2:
            return None
        clearance = (
            ndimage.distance_transform_edt(~occupied) * res if occupied.any() else np.full(shape, np.inf)
        )
        start = self.cell_of(np.asarray(start_xy)) - lo
        if not (0 <= start[0] < shape[0] and 0 <= start[1] < shape[1]):
            return None
        passable = clearance >= cfg.robot_radius_m
        # The robot's own cell and a small disc around it stay passable: it may stand close to a wall.
        rr, cc = np.ogrid[: shape[0], : shape[1]]
        near_start = (rr - start[0]) ** 2 + (cc - start[1]) ** 2 <= (cfg.robot_radius_m / res) ** 2
        passable |= near_start & (clearance > 0.5 * res)
        weight = np.where(known, 1.0, cfg.unknown_cost) * np.where(
            clearance < cfg.comfort_m, cfg.near_obstacle_cost, 1.0
        )
        graph = _grid_graph(passable, weight, res)
        start_index = int(start[0] * shape[1] + start[1])
        dist, predecessors = dijkstra(graph, directed=True, indices=start_index, return_predecessors=True)
        # Goal region: passable cells within the tolerance of the goal; the cheapest one wins, ties to
        # the nearest to the goal.
        centres_x = self._lower[0] + (np.arange(lo[0], hi[0]) + 0.5) * res
        centres_y = self._lower[1] + (np.arange(lo[1], hi[1]) + 0.5) * res
        gap = np.hypot(centres_x[:, None] - goal_xy[0], centres_y[None, :] - goal_xy[1])
        reach = dist.reshape(shape)
        candidates = (
            (gap <= cfg.goal_tolerance_m) & np.isfinite(reach) & passable & (clearance >= cfg.standoff_m)
        )
        if not candidates.any():
            return None
        score = np.where(candidates, gap * 4.0 + reach * 0.25, np.inf)
        goal_index = int(np.argmin(score))
        cells = []
        node = goal_index
        while node != start_index and node >= 0:
            cells.append(node)
            node = int(predecessors[node])
        cells.append(start_index)
        cells.reverse()
        idx = np.array(cells)
        grid_cells = np.stack([idx // shape[1], idx % shape[1]], axis=1) + lo
        waypoints = self.centre_of(grid_cells)
        waypoints[0] = start_xy
        return waypoints


def _grid_graph(passable: npt.NDArray[np.bool_], weight: FloatArray, res: float) -> csr_matrix:
    """8-connected directed graph over passable cells; an edge costs length x the mean cell weight."""
    rows, cols = passable.shape
    index = np.arange(rows * cols).reshape(rows, cols)
    sources, targets, costs = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1), (0, -1), (-1, 0), (-1, -1), (-1, 1)):
        r0, r1 = max(0, -dr), rows - max(0, dr)
        c0, c1 = max(0, -dc), cols - max(0, dc)
        a = passable[r0:r1, c0:c1] & passable[r0 + dr : r1 + dr, c0 + dc : c1 + dc]
        if dr and dc:  # no corner cutting
            a &= passable[r0 + dr : r1 + dr, c0:c1] & passable[r0:r1, c0 + dc : c1 + dc]
        src = index[r0:r1, c0:c1][a]
        dst = index[r0 + dr : r1 + dr, c0 + dc : c1 + dc][a]
        w = 0.5 * (weight[r0:r1, c0:c1][a] + weight[r0 + dr : r1 + dr, c0 + dc : c1 + dc][a])
        sources.append(src)
        targets.append(dst)
        costs.append(w * res * math.hypot(dr, dc))
    n = rows * cols
    return csr_matrix(
        (np.concatenate(costs), (np.concatenate(sources), np.concatenate(targets))), shape=(n, n)
    )


def lookahead_point(waypoints: FloatArray, *, distance_m: float) -> FloatArray:
    """The point ``distance_m`` along the path from its start (its end when the path is shorter)."""
    if waypoints.shape[0] == 1:
        return waypoints[0]
    seg = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    along = np.concatenate([[0.0], np.cumsum(seg)])
    if along[-1] <= distance_m:
        return waypoints[-1]
    i = int(np.searchsorted(along, distance_m) - 1)
    t = (distance_m - along[i]) / max(seg[i], 1e-9)
    return waypoints[i] + t * (waypoints[i + 1] - waypoints[i])
