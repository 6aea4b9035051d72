"""A global planner on the costmap: the robot to the subgoal, or the explicit answer that no plan reaches it.

Like Nav2's NavFn it computes a *navigation function*: one Dijkstra search (``scipy.sparse.csgraph``) from
the goal region over a grid of planning cells, which gives every cell its cost to go; the path descends
it from the robot. The controller reads the same field to score its trajectories (a trajectory that
ends lower on it has made progress along the plan), so a plan a few hundred milliseconds old still
pulls the robot the right way.

- **Cells**: blocks of ``cell_factor`` x ``cell_factor`` costmap cells (0.1 m by default), each with the
  distance to the nearest lethal cell at its centre (the mean of its block). A cell is passable when that distance
  reaches the inscribed radius of the padded footprint: nearer, the base centre collides in every
  heading. Never-observed cells are passable (the planner is optimistic, as SemExp's and VLFM's
  planners over their maps) at ``unknown_cost`` times the step length; known cells cost
  ``1 + cost_weight * inflation_cost / 252``, so paths keep to the middle of passages.
- **Lattice**: 16-connected (king and knight moves, a knight move only where both cells it crosses are
  passable), within 2.8 % of Euclidean length instead of an 8-connected grid's 8.2 %.
- **Goal region**: a subgoal may lie on an object's surface (a memory node of an object), inside lethal
  cells. Every passable cell within ``goal_tolerance_m`` of it is a goal, entered at a price:
  ``goal_gap_weight`` x its distance from the subgoal plus ``standoff_weight`` x how much closer than
  ``standoff_m`` it is to an obstacle (room to turn and look). A virtual source joined to every goal cell
  with those prices makes this one Dijkstra run.
- **Window**: the search runs on the bounding box of robot and subgoal grown by ``window_margin_m``;
  when nothing within it reaches, once more on a box grown by ``wide_window_margin_m``.
- **Results**: ``ok`` with the path; ``no_path`` when no passable goal cell is connected to the robot
  (the subgoal is walled in, or every cell near it is inside an obstacle); ``start_blocked`` when no
  passable cell lies within ``start_escape_m`` of the robot.

Example:
    >>> planner = GlobalPlanner()  # doctest: +SKIP
    >>> plan = planner.plan(costmap, start_xy=(0.0, 0.0), goal_xy=(4.0, 2.0))  # doctest: +SKIP
    >>> plan.status, plan.length_m  # doctest: +SKIP
    ('ok', 4.6)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from semexp_bt.core.bounds import field_range
from semexp_bt.core.config import field_problem
from semexp_bt.core.geometry import lattice_steps
from semexp_bt.core.types import FloatArray, InvalidInputError, require_finite
from semexp_bt.nav.costmap import MAX_NON_OBSTACLE_COST, Costmap

PlanStatus = Literal["ok", "no_path", "start_blocked"]


@dataclass(frozen=True)
class GlobalPlannerConfig:
    """Every constant of the global planner, named once."""

    cell_factor: int = field(default=2, metadata=field_range(1, 16))
    """Planning cells are blocks of this many costmap cells per side."""
    unknown_cost: float = field(default=1.5, metadata=field_range(0.0, 100.0, low_open=True))
    """Step cost multiplier through never-observed cells."""
    cost_weight: float = field(default=2.0, metadata=field_range(0.0, 100.0))
    """Extra step cost multiplier at the highest non-lethal inflation cost (252)."""
    goal_tolerance_m: float = field(default=0.8, metadata=field_range(0.0, 10.0, low_open=True))
    """Passable cells within this distance of the subgoal are goals."""
    goal_gap_weight: float = field(default=4.0, metadata=field_range(0.0, 100.0))
    """Price (m of travel) per metre a goal cell lies from the subgoal."""
    standoff_m: float = field(default=0.7, metadata=field_range(0.0, 5.0))
    """A goal cell with less room than this to the nearest lethal cell pays for it: the robot stops about
    this far from an object it was sent to, which the camera then sees whole (closer, the detector's
    views of it are truncated and the confirmation vote fails: measured in laboratory seed 1000)."""
    standoff_weight: float = field(default=10.0, metadata=field_range(0.0, 1000.0))
    """Price (m of travel) per metre of missing standoff."""
    window_margin_m: float = field(default=4.0, metadata=field_range(0.0, 200.0, low_open=True))
    """The search box: robot and subgoal, grown by this much."""
    wide_window_margin_m: float = field(default=12.0, metadata=field_range(0.0, 200.0, low_open=True))
    """The second, wider box when nothing reaches within the first."""
    start_escape_m: float = field(default=0.6, metadata=field_range(0.0, 5.0))
    """When the robot's own cell is not passable, the path starts at the nearest passable cell this close."""

    def __post_init__(self) -> None:
        problem = field_problem(self)
        if problem is not None:
            raise InvalidInputError(f"GlobalPlannerConfig.{problem}")


@dataclass
class GlobalPlan:
    """One planning result.

    Attributes:
        status: ``ok``, ``no_path`` or ``start_blocked``.
        path_xy: ``(N, 2)`` waypoints in ``map`` from the robot to the goal cell (empty unless ``ok``).
        goal_xy: the subgoal planned for.
        length_m: the path's length (inf unless ``ok``).
        revision: the costmap revision planned on.
        stamp_s: when it was planned.
        cost_to_go: the navigation function over the window (m of weighted travel; inf: unreachable).
        lower_left_xy: world position of the window's lower-left corner.
        cell_m: planning cell side.
    """

    status: PlanStatus
    path_xy: FloatArray
    goal_xy: tuple[float, float]
    length_m: float
    revision: int
    stamp_s: float = 0.0
    cost_to_go: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    lower_left_xy: tuple[float, float] = (0.0, 0.0)
    cell_m: float = 0.1

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def cost_to_go_at(self, xy: FloatArray) -> FloatArray:
        """The navigation function at world points ``(..., 2)`` (nearest cell; inf outside the window)."""
        p = np.asarray(xy, dtype=float)
        col = np.floor((p[..., 0] - self.lower_left_xy[0]) / self.cell_m).astype(np.int64)
        row = np.floor((p[..., 1] - self.lower_left_xy[1]) / self.cell_m).astype(np.int64)
        rows, cols = self.cost_to_go.shape
        ok = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        values = self.cost_to_go[np.clip(row, 0, max(rows - 1, 0)), np.clip(col, 0, max(cols - 1, 0))]
        return np.where(ok, values, np.inf)


class GlobalPlanner:
    """Robot -> subgoal on a :class:`~semexp_bt.nav.costmap.Costmap` (see the module docstring)."""

    def __init__(self, config: GlobalPlannerConfig | None = None) -> None:
        self.config = config or GlobalPlannerConfig()

    def plan(
        self,
        costmap: Costmap,
        *,
        start_xy: tuple[float, float],
        goal_xy: tuple[float, float],
        stamp_s: float = 0.0,
    ) -> GlobalPlan:
        """Plan from ``start_xy`` to the goal region around ``goal_xy``."""
        require_finite("start_xy", start_xy)
        require_finite("goal_xy", goal_xy)
        plan = self._plan_in_window(costmap, start_xy, goal_xy, self.config.window_margin_m, stamp_s)
        if plan.status == "no_path":
            plan = self._plan_in_window(costmap, start_xy, goal_xy, self.config.wide_window_margin_m, stamp_s)
        if not plan.ok:
            # A passage as narrow as the body allows (0.56-0.60 m) may have no planning cell centred in it
            # (nor the robot standing in it a passable cell of its own): once more with a planning cell
            # passable where any of its costmap cells is.
            plan = self._plan_in_window(
                costmap, start_xy, goal_xy, self.config.wide_window_margin_m, stamp_s, fine_passage=True
            )
        return plan

    def travel_distances(
        self, costmap: Costmap, *, start_xy: tuple[float, float], targets_xy: npt.ArrayLike
    ) -> FloatArray | None:
        """The length of the shortest way (m) from ``start_xy`` to each target, on the costmap.

        The way avoids what the costmap knows to be blocked and crosses never-observed cells at their
        length (optimistic, as the plans are): one Dijkstra from the robot over the planning cells of the
        box around the robot and every target, grown by ``window_margin_m``, with a cell passable where any
        of its costmap cells leaves room for the footprint (the narrow-passage rule of :meth:`plan`). A
        target counts as reached from any passable cell within ``goal_tolerance_m`` of it, plus the
        straight gap; ``inf`` when none is connected to the robot.

        Returns:
            ``(N,)`` distances, or None when no passable cell lies within ``start_escape_m`` of the robot.

        Example:
            Across a wall 4 m long from a node 1 m away, the node's distance is the way round the wall's
            end, not 1 m.
        """
        require_finite("start_xy", start_xy)
        targets = np.asarray(targets_xy, dtype=float).reshape(-1, 2)
        require_finite("targets_xy", targets)
        cfg = self.config
        cell = costmap.resolution_m * cfg.cell_factor
        start = np.asarray(start_xy, dtype=float)
        lo, rows, cols = _window(costmap, np.vstack([start[None, :], targets]), cfg.window_margin_m, cell)
        _, widest, _ = _pooled_layers(costmap, lo, rows, cols, cfg.cell_factor)
        passable = widest >= costmap.inscribed_radius_m
        centres_x = lo[0] + (np.arange(cols) + 0.5) * cell
        centres_y = lo[1] + (np.arange(rows) + 0.5) * cell
        start_cell = _start_cell(passable, centres_x, centres_y, start, lo, cell, cfg.start_escape_m)
        if start_cell is None:
            return None
        s_row, s_col = start_cell
        no_goal = np.full(rows * cols, np.nan)
        graph = _lattice_graph(passable, np.ones((rows, cols)), cell, extra_source_prices=no_goal)
        reached = csgraph.dijkstra(graph, directed=False, indices=s_row * cols + s_col)[: rows * cols]
        reached = reached.reshape(rows, cols)
        reach_cells = int(math.ceil(cfg.goal_tolerance_m / cell))
        distances = np.full(len(targets), np.inf)
        for i, (x, y) in enumerate(targets):
            col, row = int((x - lo[0]) // cell), int((y - lo[1]) // cell)
            r0, r1 = max(row - reach_cells, 0), min(row + reach_cells + 1, rows)
            c0, c1 = max(col - reach_cells, 0), min(col + reach_cells + 1, cols)
            gap = np.hypot(centres_x[None, c0:c1] - x, centres_y[r0:r1, None] - y)
            way = np.where(gap <= cfg.goal_tolerance_m, reached[r0:r1, c0:c1] + gap, np.inf)
            distances[i] = float(way.min()) if way.size else math.inf
        return distances

    # ------------------------------------------------------------------ internals
    def _plan_in_window(
        self, costmap: Costmap, start_xy: tuple[float, float], goal_xy: tuple[float, float], margin_m: float,
        stamp_s: float, *, fine_passage: bool = False,
    ) -> GlobalPlan:  # fmt: skip
        cfg = self.config
        res = costmap.resolution_m
        cell = res * cfg.cell_factor
        start = np.asarray(start_xy, dtype=float)
        goal = np.asarray(goal_xy, dtype=float)
        lo, rows, cols = _window(costmap, np.stack([start, goal]), margin_m, cell)
        distance, widest, observed = _pooled_layers(costmap, lo, rows, cols, cfg.cell_factor)
        inscribed = costmap.inscribed_radius_m
        passable = (widest if fine_passage else distance) >= inscribed
        normalised = costmap.cost(distance, np.ones_like(observed)).astype(float) / MAX_NON_OBSTACLE_COST
        weight = np.where(observed, 1.0 + cfg.cost_weight * np.minimum(normalised, 1.0), cfg.unknown_cost)

        failed = GlobalPlan("no_path", np.zeros((0, 2)), (float(goal[0]), float(goal[1])), math.inf,
                            costmap.revision, stamp_s, lower_left_xy=(float(lo[0]), float(lo[1])), cell_m=cell)  # fmt: skip
        centres_x = lo[0] + (np.arange(cols) + 0.5) * cell
        centres_y = lo[1] + (np.arange(rows) + 0.5) * cell
        start_cell = _start_cell(passable, centres_x, centres_y, start, lo, cell, cfg.start_escape_m)
        if start_cell is None:
            failed.status = "start_blocked"
            return failed
        s_row, s_col = start_cell
        # The goal region, entered through a virtual source at a price.
        gap = np.hypot(centres_x[None, :] - goal[0], centres_y[:, None] - goal[1])
        region = passable & (gap <= cfg.goal_tolerance_m)
        if not region.any():
            return failed
        price = cfg.goal_gap_weight * gap + cfg.standoff_weight * np.maximum(cfg.standoff_m - distance, 0.0)
        n = rows * cols
        graph = _lattice_graph(
            passable, weight, cell, extra_source_prices=np.where(region, price, np.nan).ravel()
        )
        dist, pred = csgraph.dijkstra(graph, directed=False, indices=n, return_predecessors=True)
        reached = dist[:n].reshape(rows, cols)
        cost_to_go = _extend_into_obstacles(reached, cell)
        start_index = s_row * cols + s_col
        if not math.isfinite(reached[s_row, s_col]):
            failed.cost_to_go = cost_to_go
            return failed
        nodes = [start_index]
        while True:
            previous = int(pred[nodes[-1]])
            if previous < 0 or previous == n:
                break
            nodes.append(previous)
        idx = np.asarray(nodes)
        path = np.stack([centres_x[idx % cols], centres_y[idx // cols]], axis=1)
        path = np.vstack([start, path])
        length = float(np.hypot(*np.diff(path, axis=0).T).sum())
        return GlobalPlan("ok", path, (float(goal[0]), float(goal[1])), length, costmap.revision, stamp_s,
                          cost_to_go, (float(lo[0]), float(lo[1])), cell)  # fmt: skip


def _window(
    costmap: Costmap, points_xy: FloatArray, margin_m: float, cell_m: float
) -> tuple[FloatArray, int, int]:
    """The search box around ``points_xy`` grown by ``margin_m``: its lower-left corner, rows and columns,
    aligned to the costmap's grid so that planning cells are whole costmap blocks."""
    grid_lower = np.asarray(costmap.lower_left_xy)
    lo = grid_lower + np.floor((points_xy.min(axis=0) - margin_m - grid_lower) / cell_m) * cell_m
    hi = grid_lower + np.ceil((points_xy.max(axis=0) + margin_m - grid_lower) / cell_m) * cell_m
    cols, rows = (int(v) for v in np.round((hi - lo) / cell_m))
    return lo, rows, cols


def _start_cell(
    passable: npt.NDArray[np.bool_], centres_x: FloatArray, centres_y: FloatArray, start: FloatArray,
    lower_xy: FloatArray, cell_m: float, escape_m: float,
) -> tuple[int, int] | None:  # fmt: skip
    """The robot's own planning cell ``(row, col)``, or the nearest passable one within ``escape_m``; None
    when there is none."""
    s_col, s_row = (int(v) for v in np.floor((start - lower_xy) / cell_m))
    if passable[s_row, s_col]:
        return s_row, s_col
    start_gap = np.hypot(centres_x[None, :] - start[0], centres_y[:, None] - start[1])
    near = passable & (start_gap <= escape_m)
    if not near.any():
        return None
    row, col = np.unravel_index(np.argmin(np.where(near, start_gap, np.inf)), near.shape)
    return int(row), int(col)


#: Cells inside the inflated obstacles get the navigation function of the nearest passable cell plus this
#: many times the way there (a slope out of the inflation toward the plan, for a robot that stands in it).
OBSTACLE_SLOPE = 3.0


def _extend_into_obstacles(cost_to_go: FloatArray, cell_m: float) -> FloatArray:
    """The navigation function, continued into unreachable cells from the nearest reachable one.

    A robot pushed into the inflation (or a footprint whose corner reaches into it) still needs a field
    that slopes toward the plan; Dijkstra leaves those cells at infinity.
    """
    reachable = np.isfinite(cost_to_go)
    if reachable.all() or not reachable.any():
        return cost_to_go
    distance, (ri, ci) = ndimage.distance_transform_edt(~reachable, return_indices=True)
    extended = cost_to_go[ri, ci] + OBSTACLE_SLOPE * distance * cell_m
    return np.where(reachable, cost_to_go, extended)


def _pooled_layers(
    costmap: Costmap, lower_xy: FloatArray, rows: int, cols: int, factor: int
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """The window's planning cells: the distance to a lethal cell at the centre, the largest distance among
    its costmap cells, and whether any part was observed (outside the costmap: far from everything,
    unobserved)."""
    res = costmap.resolution_m
    grid_rows, grid_cols = costmap.shape
    offset = np.round((lower_xy - np.asarray(costmap.lower_left_xy)) / res).astype(np.int64)
    c0, r0 = int(offset[0]), int(offset[1])
    fine_rows, fine_cols = rows * factor, cols * factor
    cap = np.float32(costmap.config.inflation_radius_m)
    distance = np.full((fine_rows, fine_cols), cap, dtype=np.float32)
    observed = np.zeros((fine_rows, fine_cols), dtype=bool)
    src_r0, src_r1 = max(r0, 0), min(r0 + fine_rows, grid_rows)
    src_c0, src_c1 = max(c0, 0), min(c0 + fine_cols, grid_cols)
    if src_r1 > src_r0 and src_c1 > src_c0:
        dst = (slice(src_r0 - r0, src_r1 - r0), slice(src_c0 - c0, src_c1 - c0))
        distance[dst] = costmap.distance_m[src_r0:src_r1, src_c0:src_c1]
        observed[dst] = costmap.observed[src_r0:src_r1, src_c0:src_c1]
    # The block's mean is the distance field at the planning cell's centre (bilinear between the fine
    # cells' centres), within a centimetre; the controller checks the footprint on the fine field.
    blocks = distance.reshape(rows, factor, cols, factor)
    seen: npt.NDArray[np.bool_] = np.asarray(observed.reshape(rows, factor, cols, factor).any(axis=(1, 3)))
    return blocks.mean(axis=(1, 3)).astype(float), blocks.max(axis=(1, 3)).astype(float), seen


def _lattice_graph(
    passable: npt.NDArray[np.bool_], weight: FloatArray, cell_m: float, *, extra_source_prices: FloatArray
) -> sparse.csr_matrix:
    """The 16-connected lattice over passable cells (an edge costs its length x the mean cell weight), plus
    one virtual node (index ``rows * cols``) joined to every cell with a finite price."""
    rows, cols = passable.shape
    index = np.arange(rows * cols).reshape(rows, cols)
    padded_w = np.pad(weight, 2, constant_values=1.0)
    sources, targets, costs = [], [], []
    for dr, dc, r, c in lattice_steps(passable):
        sources.append(index[r, c])
        targets.append(index[r + dr, c + dc])
        w_other = padded_w[2 + r + dr, 2 + c + dc]
        costs.append(0.5 * (weight[r, c] + w_other) * cell_m * math.hypot(dr, dc))
    n = rows * cols
    goal_cells = np.flatnonzero(np.isfinite(extra_source_prices))
    sources.append(np.full(goal_cells.size, n))
    targets.append(goal_cells)
    # csgraph drops explicit zeros: a goal cell right at the subgoal still needs a (tiny) edge.
    costs.append(np.maximum(extra_source_prices[goal_cells], 1e-6))
    return sparse.csr_matrix(
        (np.concatenate(costs), (np.concatenate(sources), np.concatenate(targets))), shape=(n + 1, n + 1)
    )
