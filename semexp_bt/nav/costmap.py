"""A 2-D costmap from depth and odometry: marking, ray-cast clearing, inflation from the footprint.

What Nav2's ``costmap_2d`` does with an obstacle layer and an inflation layer, for a head RGB-D camera:

- **Cells** are ``unknown`` (no ray has said anything about them), ``free`` or ``lethal``. Each cell keeps a
  log-odds of being occupied: a depth return inside the robot's height band (``obstacle_min_z_m`` ..
  ``obstacle_max_z_m`` above the floor) *marks* its cell (``+hit_log_odds``, once per cell and frame), and a
  ray *clears* (``-miss_log_odds``) the cells it crosses while it is lower than ``obstacle_min_z_m``:
  there, nothing in the band can stand, whatever the ray met later. This is ray casting with the height
  of the ray taken into account, which a 2-D Bresenham clearing ignores: a ray that passes over a low box
  on its way to the floor behind it says nothing about the box, and here it does not clear it. Only the
  last stretch of each floor ray clears (about the last sixth for the Go1's 0.30 m camera), and the rays
  of neighbouring image rows overlap there, so the visible floor is covered with a few samples per ray.
  A cell is ``lethal`` when its log-odds exceeds ``lethal_log_odds``. The cells under the robot's own
  footprint are cleared every frame (the robot stands there), as Nav2's ``footprint_clearing_enabled``.
- **Inflation**: the distance from every cell to the nearest lethal cell (``scipy.ndimage``'s exact
  Euclidean distance transform), capped at ``inflation_radius_m``, is kept up to date in the window a
  frame changed (plus the cap). Never-observed cells within ``unseen_extension_m`` of a lethal cell count
  as obstacles there: what the camera saw of an object is only its near side. Costs follow Nav2's inflation layer: 254 on a lethal cell, 253 within the
  *inscribed* radius of the (padded) footprint, where the base centre collides in every heading, then
  ``252 exp(-cost_scaling_factor (d - inscribed))`` out to the inflation radius, beyond the
  *circumscribed* radius (from which on no heading collides); 255 is unknown. The controller checks the
  oriented footprint against the distance field itself (``semexp_bt.nav.controller``).
- **Extent**: the grid starts as a few tiles around the first pose and grows by whole tiles to hold what
  the robot observes, up to ``max_extent_m`` on each side: memory is bounded by
  ``(max_extent_m / resolution_m)^2`` cells of 10 bytes (14.4 MB for the default 120 m at 5 cm).
  Observations outside that square are dropped and counted (``dropped_points``).

Frames: ``map`` (REP-105 ``odom`` on a real robot: the paper does no global pose-graph optimisation). Grid
row ``r``, column ``c`` is the cell whose lower-left corner is ``origin + (c, r) * resolution``, as in a ROS
``nav_msgs/OccupancyGrid``.

Example:
    >>> cm = Costmap(CostmapConfig(), footprint=Footprint(-0.378, 0.29, 0.15), origin_xy=(0.0, 0.0))
    >>> cm.state_at((1.0, 0.0))
    'unknown'
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from semexp_bt.core.bounds import field_range
from semexp_bt.core.config import field_problem
from semexp_bt.core.types import FloatArray, InvalidInputError, Observation, PixelGrid, Pose2D, require_finite
from semexp_bt.nav.footprint import Footprint

CellState = Literal["unknown", "free", "lethal"]

#: Nav2's cost values (``nav2_costmap_2d/cost_values.hpp``).
LETHAL_COST = 254
INSCRIBED_COST = 253
MAX_NON_OBSTACLE_COST = 252
NO_INFORMATION_COST = 255


@dataclass(frozen=True)
class CostmapConfig:
    """Every constant of the costmap, named once (units in the names)."""

    resolution_m: float = field(default=0.05, metadata=field_range(0.005, 1.0))
    """Cell side."""
    tile_cells: int = field(default=64, metadata=field_range(4, 4096))
    """The grid grows by whole tiles of this many cells per side (3.2 m at 5 cm)."""
    max_extent_m: float = field(default=120.0, metadata=field_range(1.0, 2000.0))
    """Largest side of the grid: the memory bound."""
    pixel_stride: int = field(default=4, metadata=field_range(1, 64))
    """Depth pixels read: every ``pixel_stride``-th row and column, half a stride in."""
    max_range_m: float = field(default=6.0, metadata=field_range(0.1, 100.0))
    """Returns farther than this (horizontally) neither mark nor clear: depth error grows with range."""
    obstacle_min_z_m: float = field(default=0.05, metadata=field_range(0.0, 2.0))
    """Returns lower than this above the floor are floor; rays clear cells while they are this low."""
    obstacle_max_z_m: float = field(default=0.6, metadata=field_range(0.01, 5.0))
    """Returns higher than this are overhangs the robot walks under."""
    hit_log_odds: float = field(default=1.0, metadata=field_range(0.0, 10.0, low_open=True))
    """Log-odds added to a cell marked in a frame."""
    miss_log_odds: float = field(default=0.4, metadata=field_range(0.0, 10.0))
    """Log-odds removed from a cell cleared in a frame."""
    lethal_log_odds: float = field(default=0.5, metadata=field_range(-10.0, 10.0))
    """A cell is lethal above this log-odds (one marking frame suffices; about three clearing frames undo it)."""
    min_log_odds: float = field(default=-2.0, metadata=field_range(-20.0, 0.0))
    """Log-odds floor (a cell seen free many times still flips after a few hits)."""
    max_log_odds: float = field(default=3.5, metadata=field_range(0.0, 20.0))
    """Log-odds ceiling."""
    clearance_m: float = field(default=0.13, metadata=field_range(0.0, 1.0))
    """Padding of the footprint for inflation: the controller's least clearance (OASR's 0.1 m plus half a
    cell, ``SafetyRules.min_clearance_m``), so that a passage the planner takes is one the controller can
    drive: 0.56 m of free width for the 0.30 m body (0.60 m while the controller's check was a disc cover
    that overshot the rectangle's sides)."""
    inflation_radius_m: float = field(default=1.0, metadata=field_range(0.0, 10.0, low_open=True))
    """Distances (and costs) are kept out to this far from lethal cells."""
    cost_scaling_factor: float = field(default=3.0, metadata=field_range(0.0, 100.0))
    """Nav2's exponential decay rate of the inflation cost beyond the inscribed radius (1/m)."""
    unseen_extension_m: float = field(default=0.0, metadata=field_range(0.0, 2.0))
    """Never-observed cells this close to a lethal cell count as obstacles in the distance field (an object
    seen from one side goes on behind what the camera saw). Off by default: at 0.3 m it removed the
    contacts of living_room seed 0 (the rear of the body swept the unseen far side of an armchair), but the
    unseen ring round a start pose next to an obstacle then walled five of ten robots in at their start
    (docs/planner.md)."""

    def __post_init__(self) -> None:
        problem = field_problem(self)
        if problem is not None:
            raise InvalidInputError(f"CostmapConfig.{problem}")
        if not self.obstacle_min_z_m < self.obstacle_max_z_m:
            raise InvalidInputError("CostmapConfig.obstacle_min_z_m must be below obstacle_max_z_m")
        if not self.min_log_odds < self.lethal_log_odds < self.max_log_odds:
            raise InvalidInputError(
                "CostmapConfig.lethal_log_odds must lie between min_log_odds and max_log_odds"
            )


@dataclass
class UpdateStats:
    """What one :meth:`Costmap.integrate` did."""

    rays: int = 0
    marked_cells: int = 0
    cleared_cells: int = 0
    lethal_changed: int = 0
    dropped_points: int = 0


@dataclass
class Costmap:
    """The costmap: log-odds, observed and distance layers over a grid that grows with what is seen.

    Args:
        config: constants.
        footprint: the robot's footprint (inflation radii, footprint clearing).
        origin_xy: where the mission starts; the first tiles are centred on it.
    """

    config: CostmapConfig
    footprint: Footprint
    origin_xy: tuple[float, float]
    revision: int = field(default=0, init=False)
    """Increases each time some cell turns lethal or stops being lethal (the global planner replans)."""
    frames: int = field(default=0, init=False)
    dropped_points: int = field(default=0, init=False)
    frozen: bool = field(default=False, init=False)
    """Set by :meth:`set_known`: the map is the truth and depth frames no longer change it."""

    def __post_init__(self) -> None:
        require_finite("origin_xy", self.origin_xy)
        cfg = self.config
        tiles = 2
        size = tiles * cfg.tile_cells
        self._lower = np.array(self.origin_xy, dtype=float) - 0.5 * size * cfg.resolution_m
        self.log_odds = np.zeros((size, size), dtype=np.float32)
        self.observed = np.zeros((size, size), dtype=bool)
        self.distance_m = np.full((size, size), np.float32(cfg.inflation_radius_m), dtype=np.float32)
        self._max_cells = int(math.floor(cfg.max_extent_m / cfg.resolution_m))

    # ------------------------------------------------------------------ geometry
    @property
    def resolution_m(self) -> float:
        return self.config.resolution_m

    @property
    def shape(self) -> tuple[int, int]:
        rows, cols = self.log_odds.shape
        return int(rows), int(cols)

    @property
    def lower_left_xy(self) -> tuple[float, float]:
        """World position of the grid's lower-left corner."""
        return (float(self._lower[0]), float(self._lower[1]))

    @property
    def padded_footprint(self) -> Footprint:
        """The footprint grown by the clearance: what must stay off lethal cells."""
        return self.footprint.padded(self.config.clearance_m)

    @property
    def inscribed_radius_m(self) -> float:
        """Inscribed radius of the padded footprint (Nav2's ``inscribed_radius`` with footprint padding)."""
        return self.padded_footprint.inscribed_radius_m

    @property
    def circumscribed_radius_m(self) -> float:
        return self.padded_footprint.circumscribed_radius_m

    @property
    def sampled_pixels(self) -> PixelGrid:
        """The only depth pixels :meth:`integrate` reads."""
        return PixelGrid.centred(self.config.pixel_stride)

    def cell_of(self, xy: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """``(..., 2)`` world xy -> ``(..., 2)`` (row, col), unclipped."""
        p = np.asarray(xy, dtype=float)
        scaled = np.floor((p - self._lower) / self.config.resolution_m).astype(np.int64)
        return scaled[..., ::-1]

    def centre_of(self, row: npt.ArrayLike, col: npt.ArrayLike) -> FloatArray:
        """Cell centres ``(..., 2)`` in ``map``."""
        res = self.config.resolution_m
        x = self._lower[0] + (np.asarray(col, dtype=float) + 0.5) * res
        y = self._lower[1] + (np.asarray(row, dtype=float) + 0.5) * res
        return np.stack([x, y], axis=-1)

    def inside(self, cells: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        rows, cols = self.shape
        return (cells[..., 0] >= 0) & (cells[..., 0] < rows) & (cells[..., 1] >= 0) & (cells[..., 1] < cols)

    # ------------------------------------------------------------------ layers
    def lethal(self) -> npt.NDArray[np.bool_]:
        return self.log_odds > self.config.lethal_log_odds

    def free(self) -> npt.NDArray[np.bool_]:
        return self.observed & ~self.lethal()

    def state_at(self, xy: npt.ArrayLike) -> CellState:
        """``unknown``, ``free`` or ``lethal`` at a world point (outside the grid: unknown)."""
        cell = self.cell_of(xy)
        if not bool(self.inside(cell)):
            return "unknown"
        r, c = int(cell[0]), int(cell[1])
        if self.log_odds[r, c] > self.config.lethal_log_odds:
            return "lethal"
        return "free" if self.observed[r, c] else "unknown"

    def distance_at(self, xy: FloatArray) -> FloatArray:
        """Distance (m) to the nearest lethal cell at world points ``(..., 2)``, bilinear between cell
        centres, capped at the inflation radius (outside the grid: the cap)."""
        padded = self._padded("distance")
        rows, cols = padded.shape
        p = (np.asarray(xy, dtype=float) - self._lower) / self.config.resolution_m + 0.5  # padded cell units
        cx = np.clip(p[..., 0], 0.0, cols - 1.001)
        cy = np.clip(p[..., 1], 0.0, rows - 1.001)
        c0 = cx.astype(np.int64)
        r0 = cy.astype(np.int64)
        fx, fy = cx - c0, cy - r0
        flat = padded.ravel()
        i = r0 * cols + c0
        top = flat[i] * (1.0 - fx) + flat[i + 1] * fx
        bottom = flat[i + cols] * (1.0 - fx) + flat[i + cols + 1] * fx
        return top * (1.0 - fy) + bottom * fy

    def known_at(self, xy: FloatArray) -> npt.NDArray[np.bool_]:
        """Whether the cells holding world points ``(..., 2)`` were observed (outside the grid: no)."""
        padded = self._padded("observed")
        rows, cols = padded.shape
        p = (np.asarray(xy, dtype=float) - self._lower) / self.config.resolution_m + 1.0
        c = np.clip(p[..., 0], 0.0, cols - 1.0).astype(np.int64)
        r = np.clip(p[..., 1], 0.0, rows - 1.0).astype(np.int64)
        return padded.ravel()[r * cols + c]

    def _padded(self, layer: str) -> npt.NDArray:
        """A layer with its one-cell border (the cap for distances, unobserved): the storage itself."""
        return self._distance_pad if layer == "distance" else self._observed_pad

    # The distance and observed layers live inside arrays one cell larger on every side, so that look-ups
    # near the edge need no bounds checks and no copy per query.
    @property
    def distance_m(self) -> npt.NDArray[np.float32]:
        """Distance (m) from each cell to the nearest lethal cell, capped at the inflation radius."""
        return self._distance_pad[1:-1, 1:-1]

    @distance_m.setter
    def distance_m(self, value: npt.NDArray[np.float32]) -> None:
        cap = np.float32(self.config.inflation_radius_m)
        self._distance_pad = np.pad(np.asarray(value, dtype=np.float32), 1, constant_values=cap)

    @property
    def observed(self) -> npt.NDArray[np.bool_]:
        """Whether some ray (or the footprint) has said anything about each cell."""
        return self._observed_pad[1:-1, 1:-1]

    @observed.setter
    def observed(self, value: npt.NDArray[np.bool_]) -> None:
        self._observed_pad = np.pad(np.asarray(value, dtype=bool), 1, constant_values=False)

    def cost(
        self, distance_m: npt.ArrayLike | None = None, observed: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.uint8]:
        """Nav2 costs (0-255) from a distance field (default: the whole grid's)."""
        d = np.asarray(self.distance_m if distance_m is None else distance_m, dtype=float)
        seen = self.observed if observed is None else observed
        return inflation_cost(d, seen, inscribed_radius_m=self.inscribed_radius_m,
                              resolution_m=self.config.resolution_m,
                              cost_scaling_factor=self.config.cost_scaling_factor)  # fmt: skip

    # ------------------------------------------------------------------ growth
    def _ensure(
        self, cells_min: npt.NDArray[np.int64], cells_max: npt.NDArray[np.int64]
    ) -> npt.NDArray[np.int64]:
        """Grow the grid by whole tiles to hold cells ``cells_min..cells_max`` (within the bound); returns
        the shift that was applied to every existing cell index."""
        rows, cols = self.shape
        tile = self.config.tile_cells
        lo = np.minimum(cells_min, 0)
        hi = np.maximum(cells_max + 1, (rows, cols))
        grow_lo = -(np.floor_divide(lo, tile)) * tile  # cells to add before (multiple of the tile)
        grow_hi = (np.ceil((hi - np.array([rows, cols])) / tile)).astype(np.int64) * tile
        new_shape = np.array([rows, cols]) + grow_lo + grow_hi
        for axis in (0, 1):  # keep within the bound, trimming the growth on the far side first
            excess = int(new_shape[axis] - self._max_cells)
            if excess > 0:
                cut_hi = min(excess, int(grow_hi[axis]))
                grow_hi[axis] -= cut_hi
                grow_lo[axis] -= min(excess - cut_hi, int(grow_lo[axis]))
        shift = grow_lo.astype(np.int64)
        if not shift.any() and not grow_hi.any():
            return shift
        pad = ((int(grow_lo[0]), int(grow_hi[0])), (int(grow_lo[1]), int(grow_hi[1])))
        cap = np.float32(self.config.inflation_radius_m)
        self.log_odds = np.pad(self.log_odds, pad)
        self.observed = np.pad(self.observed, pad)
        self.distance_m = np.pad(self.distance_m, pad, constant_values=cap)
        self._lower = self._lower - shift[::-1] * self.config.resolution_m
        return shift

    # ------------------------------------------------------------------ update
    def integrate(self, observation: Observation, *beside: Observation) -> UpdateStats:
        """Add one depth frame (marking, clearing, footprint clearing, inflation where it changed), and
        the frames ``beside`` it taken at the same instant (the flank cameras'), in one update: one
        footprint clearing and one inflation pass for all of them."""
        cfg = self.config
        stats = UpdateStats()
        if self.frozen:
            return stats
        clears_x, clears_y, hits_x, hits_y = [], [], [], []
        for frame in (observation, *beside):
            clear_x, clear_y, hit_x, hit_y, rays = self._rays(frame)
            clears_x.append(clear_x)
            clears_y.append(clear_y)
            hits_x.append(hit_x)
            hits_y.append(hit_y)
            stats.rays += rays
        clear_x, clear_y = np.concatenate(clears_x), np.concatenate(clears_y)
        hit_x, hit_y = np.concatenate(hits_x), np.concatenate(hits_y)

        # Footprint clearing: the cells under the robot (shrunk by a cell: an obstacle it touches stays).
        pose = observation.base_pose
        fp_cells = self._footprint_points(pose, shrink_m=cfg.resolution_m)

        all_x = np.concatenate([clear_x, hit_x, fp_cells[:, 0]])
        all_y = np.concatenate([clear_y, hit_y, fp_cells[:, 1]])
        if all_x.size == 0:
            self.frames += 1
            return stats
        cells = self.cell_of(np.stack([all_x, all_y], axis=1))
        shift = self._ensure(cells.min(axis=0), cells.max(axis=0))
        cells = cells + shift
        inside = self.inside(cells)
        stats.dropped_points = int(np.count_nonzero(~inside))
        self.dropped_points += stats.dropped_points
        n_clear, n_hit = clear_x.size, hit_x.size
        kind = np.concatenate(
            [np.zeros(n_clear, np.int8), np.ones(n_hit, np.int8), np.full(len(fp_cells), 2, np.int8)]
        )
        cells, kind = cells[inside], kind[inside]
        if cells.size == 0:
            self.frames += 1
            return stats
        # Work in the bounding box of the touched cells only (a few metres), as one flat index.
        r0, c0 = cells.min(axis=0)
        r1, c1 = cells.max(axis=0) + 1
        width = int(c1 - c0)
        flat = (cells[:, 0] - r0) * width + (cells[:, 1] - c0)
        box_size = int((r1 - r0) * width)
        hit = np.bincount(flat[kind == 1], minlength=box_size) > 0
        clear = np.bincount(flat[kind == 0], minlength=box_size) > 0
        under = np.bincount(flat[kind == 2], minlength=box_size) > 0
        shape = (int(r1 - r0), width)
        window = (slice(int(r0), int(r1)), slice(int(c0), int(c1)))
        lo = self.log_odds[window]
        before = lo > cfg.lethal_log_odds
        seen_before = self.observed[window].copy()
        clear_only = (clear & ~hit).reshape(shape)
        hit = hit.reshape(shape)
        lo[clear_only] = np.maximum(lo[clear_only] - cfg.miss_log_odds, cfg.min_log_odds)
        lo[hit] = np.minimum(lo[hit] + cfg.hit_log_odds, cfg.max_log_odds)
        under = under.reshape(shape) & ~hit
        lo[under] = np.minimum(lo[under], 0.0)
        self.observed[window] |= clear_only | hit | under
        after = lo > cfg.lethal_log_odds
        changed = before != after
        if cfg.unseen_extension_m > 0.0:
            # A newly observed cell that was an unseen extension of an obstacle no longer is one.
            newly_seen = self.observed[window] & ~seen_before
            changed |= newly_seen & (self.distance_m[window] <= cfg.unseen_extension_m + cfg.resolution_m)
        stats.marked_cells = int(np.count_nonzero(hit))
        stats.cleared_cells = int(np.count_nonzero(clear_only))
        stats.lethal_changed = int(np.count_nonzero(changed))
        if stats.lethal_changed:
            rr, cc = np.nonzero(changed)
            self._update_distances(
                int(r0 + rr.min()), int(c0 + cc.min()), int(r0 + rr.max()) + 1, int(c0 + cc.max()) + 1
            )
            self.revision += 1
        self.frames += 1
        return stats

    def _rays(self, observation: Observation) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, int]:
        """One frame's clearing points (each floor ray's stretch below ``obstacle_min_z_m``, every half
        cell), its marking points, and how many of its rays were within range."""
        cfg = self.config
        grid = self.sampled_pixels
        depth_full = observation.depth_m
        rows_px = grid.indices(depth_full.shape[0])
        cols_px = grid.indices(depth_full.shape[1])
        depth = np.asarray(
            depth_full[grid.offset :: grid.stride, grid.offset :: grid.stride], dtype=np.float64
        )
        with np.errstate(invalid="ignore"):
            valid = np.isfinite(depth) & (depth > 0.0)
        k = observation.intrinsics
        t = np.asarray(observation.camera_to_world, dtype=float)
        r_idx, c_idx = np.nonzero(valid)
        z = depth[r_idx, c_idx]
        x_cam = (cols_px[c_idx] - k.cx_px) / k.fx_px * z
        y_cam = (rows_px[r_idx] - k.cy_px) / k.fy_px * z
        rot, origin = t[:3, :3], t[:3, 3]
        wx = rot[0, 0] * x_cam + rot[0, 1] * y_cam + rot[0, 2] * z + origin[0]
        wy = rot[1, 0] * x_cam + rot[1, 1] * y_cam + rot[1, 2] * z + origin[1]
        wz = rot[2, 0] * x_cam + rot[2, 1] * y_cam + rot[2, 2] * z + origin[2]
        horizontal = np.hypot(wx - origin[0], wy - origin[1])
        near = horizontal <= cfg.max_range_m
        is_hit = near & (wz >= cfg.obstacle_min_z_m) & (wz <= cfg.obstacle_max_z_m)
        is_floor = near & (wz < cfg.obstacle_min_z_m)

        # Clearing: the stretch of each floor ray that runs below obstacle_min_z_m, sampled every half cell.
        fx, fy, fz = wx[is_floor], wy[is_floor], wz[is_floor]
        drop = origin[2] - fz  # > 0: the ray descends to the floor
        start = np.clip((origin[2] - cfg.obstacle_min_z_m) / np.maximum(drop, 1e-6), 0.0, 1.0)
        seg = horizontal[is_floor] * (1.0 - start)
        step = 0.5 * cfg.resolution_m
        counts = np.floor(seg / step).astype(np.int64) + 1
        total = int(counts.sum())
        ray = np.repeat(np.arange(fx.size), counts)
        offsets = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        frac = 1.0 - (offsets * step) / np.maximum(horizontal[is_floor], 1e-9)[ray]
        clear_x = origin[0] + (fx - origin[0])[ray] * frac
        clear_y = origin[1] + (fy - origin[1])[ray] * frac
        hit_x, hit_y = wx[is_hit], wy[is_hit]
        return clear_x, clear_y, hit_x, hit_y, int(np.count_nonzero(near))

    def _footprint_points(self, pose: Pose2D, *, shrink_m: float) -> FloatArray:
        """World points on a half-cell lattice inside the footprint at ``pose``, shrunk by ``shrink_m``."""
        fp = self.footprint
        step = 0.5 * self.config.resolution_m
        xs = np.arange(fp.x_min_m + shrink_m, fp.x_max_m - shrink_m + 1e-9, step)
        ys = np.arange(-fp.half_width_m + shrink_m, fp.half_width_m - shrink_m + 1e-9, step)
        if xs.size == 0 or ys.size == 0:
            return np.zeros((0, 2))
        gx, gy = np.meshgrid(xs, ys)
        c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
        px = pose.x_m + c * gx.ravel() - s * gy.ravel()
        py = pose.y_m + s * gx.ravel() + c * gy.ravel()
        return np.stack([px, py], axis=1)

    def _update_distances(self, r0: int, c0: int, r1: int, c1: int) -> None:
        """Recompute the capped distance field over the changed window ``[r0, r1) x [c0, c1)``, grown by the
        cap, from the lethal cells within twice the cap (exact there: farther cells cannot be nearer)."""
        # Reach: the cap, plus the unseen extension (an extended cell lies that far from its lethal cell).
        span_m = self.config.inflation_radius_m + max(self.config.unseen_extension_m, 0.0)
        reach = int(math.ceil(span_m / self.config.resolution_m)) + 1
        rows, cols = self.shape
        out_r0, out_c0 = max(r0 - reach, 0), max(c0 - reach, 0)
        out_r1, out_c1 = min(r1 + reach, rows), min(c1 + reach, cols)
        in_r0, in_c0 = max(out_r0 - reach, 0), max(out_c0 - reach, 0)
        in_r1, in_c1 = min(out_r1 + reach, rows), min(out_c1 + reach, cols)
        cfg = self.config
        lethal = self.log_odds[in_r0:in_r1, in_c0:in_c1] > cfg.lethal_log_odds
        cap = np.float32(cfg.inflation_radius_m)
        if lethal.any():
            dist = ndimage.distance_transform_edt(~lethal, sampling=cfg.resolution_m)
            if cfg.unseen_extension_m > 0.0:
                unseen = ~self.observed[in_r0:in_r1, in_c0:in_c1]
                extended = lethal | (unseen & (dist <= cfg.unseen_extension_m))
                if extended.sum() > lethal.sum():
                    dist = ndimage.distance_transform_edt(~extended, sampling=cfg.resolution_m)
            dist = np.minimum(dist, cap).astype(np.float32)
        else:
            dist = np.full(lethal.shape, cap, dtype=np.float32)
        self.distance_m[out_r0:out_r1, out_c0:out_c1] = dist[
            out_r0 - in_r0 : out_r1 - in_r0, out_c0 - in_c0 : out_c1 - in_c0
        ]

    # ------------------------------------------------------------------ editing
    def clear_around(self, xy: tuple[float, float], *, radius_m: float, keep_radius_m: float = 0.0) -> int:
        """Forget every cell between ``keep_radius_m`` and ``radius_m`` of ``xy`` (back to unknown), as Nav2's
        ``ClearCostmapAroundRobot`` (which keeps nothing): the next frames rebuild them from what the camera
        sees now. Returns how many cells were reset."""
        require_finite("xy", xy)
        if self.frozen:
            return 0
        found = self._disc(xy, radius_m)
        if found is None:
            return 0
        (r0, c0, r1, c1), squared = found
        ring = (squared <= radius_m * radius_m) & (squared > keep_radius_m * keep_radius_m)
        window = (slice(r0, r1), slice(c0, c1))
        had_lethal = bool((self.log_odds[window][ring] > self.config.lethal_log_odds).any())
        self.log_odds[window][ring] = 0.0
        self.observed[window][ring] = False
        if had_lethal:
            self._update_distances(r0, c0, r1, c1)
            self.revision += 1
        return int(np.count_nonzero(ring))

    def assume_free_around(self, xy: tuple[float, float], *, radius_m: float) -> int:
        """Count the never-observed cells within ``radius_m`` of ``xy`` as observed free (the start pose's
        turning circle: the robot is set down with room to turn, and the camera, blind to the floor within
        0.8 m of the base, can never see it). Lethal and already observed cells keep what they hold.
        Returns how many cells changed."""
        require_finite("xy", xy)
        if self.frozen:
            return 0
        res = self.config.resolution_m
        reach = np.array([radius_m, radius_m])
        cells = self.cell_of(np.stack([np.asarray(xy) - reach - res, np.asarray(xy) + reach + res]))
        self._ensure(cells.min(axis=0), cells.max(axis=0))
        found = self._disc(xy, radius_m)
        if found is None:
            return 0
        (r0, c0, r1, c1), squared = found
        window = (slice(r0, r1), slice(c0, c1))
        fresh = (squared <= radius_m * radius_m) & ~self.observed[window]
        self.observed[window] |= fresh
        return int(np.count_nonzero(fresh))

    def _disc(
        self, xy: tuple[float, float], radius_m: float
    ) -> tuple[tuple[int, int, int, int], npt.NDArray[np.float64]] | None:
        """The grid window ``(r0, c0, r1, c1)`` around a disc and the squared distance (m^2) of each cell's
        centre from ``xy``; None when the disc lies off the grid."""
        res = self.config.resolution_m
        centre = self.cell_of(np.asarray(xy, dtype=float))
        reach = int(math.ceil(radius_m / res)) + 1
        rows, cols = self.shape
        r0, r1 = max(int(centre[0]) - reach, 0), min(int(centre[0]) + reach + 1, rows)
        c0, c1 = max(int(centre[1]) - reach, 0), min(int(centre[1]) + reach + 1, cols)
        if r1 <= r0 or c1 <= c0:
            return None
        rr, cc = np.mgrid[r0:r1, c0:c1]
        centres = self.centre_of(rr, cc)
        squared = (centres[..., 0] - xy[0]) ** 2 + (centres[..., 1] - xy[1]) ** 2
        return (r0, c0, r1, c1), np.asarray(squared, dtype=np.float64)

    def set_known(
        self, lethal: npt.NDArray[np.bool_], *, lower_left_xy: tuple[float, float], resolution_m: float
    ) -> None:
        """Replace the map by a fully known occupancy grid (rows along y), resampled to this resolution.

        PRIVILEGED use only: the ``oracle_nav`` reference strategy is handed the true map of the scene.
        """
        if lethal.ndim != 2:
            raise InvalidInputError(f"lethal must be a 2-D grid, got shape {lethal.shape}")
        require_finite("lower_left_xy", lower_left_xy)
        res = self.config.resolution_m
        height_m, width_m = lethal.shape[0] * resolution_m, lethal.shape[1] * resolution_m
        rows = min(int(math.ceil(height_m / res)), self._max_cells)
        cols = min(int(math.ceil(width_m / res)), self._max_cells)
        self._lower = np.array(lower_left_xy, dtype=float)
        centres = self._lower + (np.stack(np.meshgrid(np.arange(cols), np.arange(rows)), axis=-1) + 0.5) * res
        src = np.floor((centres - np.array(lower_left_xy)) / resolution_m).astype(np.int64)
        src_c = np.clip(src[..., 0], 0, lethal.shape[1] - 1)
        src_r = np.clip(src[..., 1], 0, lethal.shape[0] - 1)
        occupied = lethal[src_r, src_c]
        cfg = self.config
        self.log_odds = np.where(occupied, cfg.max_log_odds, cfg.min_log_odds).astype(np.float32)
        self.observed = np.ones((rows, cols), dtype=bool)
        self.distance_m = np.full((rows, cols), np.float32(cfg.inflation_radius_m), dtype=np.float32)
        self._update_distances(0, 0, rows, cols)
        self.revision += 1
        self.frozen = True

    # ------------------------------------------------------------------ exploration (the memory reads these)
    def frontiers(
        self, around_xy: tuple[float, float], *, radius_m: float, min_cells: int = 8
    ) -> list[tuple[float, float, int]]:
        """Frontier clusters near ``around_xy`` as ``(x, y, cells)`` (:func:`semexp_bt.nav.frontiers.costmap_frontiers`)."""
        from semexp_bt.nav.frontiers import costmap_frontiers

        found = costmap_frontiers(self, around_xy=around_xy, radius_m=radius_m, min_cells=min_cells)
        return [(f.x_m, f.y_m, f.cells) for f in found]

    def known_fraction(self, xy: npt.ArrayLike, *, radius_m: float) -> float:
        """Share of the cells within ``radius_m`` of ``xy`` that were observed."""
        from semexp_bt.nav.frontiers import known_fraction

        point = np.asarray(xy, dtype=float)
        return known_fraction(self, (float(point[0]), float(point[1])), radius_m=radius_m)

    def memory_bytes(self) -> int:
        """Bytes held by the layers."""
        return int(self.log_odds.nbytes + self.observed.nbytes + self.distance_m.nbytes)


def inflation_cost(
    distance_m: FloatArray,
    observed: npt.NDArray[np.bool_],
    *,
    inscribed_radius_m: float,
    resolution_m: float,
    cost_scaling_factor: float,
) -> npt.NDArray[np.uint8]:
    """Nav2's inflation-layer cost of each cell from its distance to the nearest lethal cell.

    254 on lethal cells (distance below half a cell), 253 within ``inscribed_radius_m``, then
    ``252 exp(-cost_scaling_factor (d - inscribed_radius_m))``; 255 where nothing was observed.
    """
    d = np.asarray(distance_m, dtype=np.float32)
    decay = MAX_NON_OBSTACLE_COST * np.exp(-cost_scaling_factor * np.maximum(d - inscribed_radius_m, 0.0))
    cost = np.where(d <= inscribed_radius_m, INSCRIBED_COST, decay)
    cost = np.where(d < 0.5 * resolution_m, LETHAL_COST, cost)
    cost = np.where(observed, cost, NO_INFORMATION_COST)
    return cost.astype(np.uint8)
