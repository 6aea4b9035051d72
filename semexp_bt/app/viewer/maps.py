"""The map the world view draws: one adapter from the navigation stack's costmap to a plain grid.

:func:`map_layer` is the only place the viewer reads a map. It reads the costmap on the board
(``local_map``, :class:`~semexp_bt.nav.costmap.Costmap`) and the global path planned on it
(``global_plan``, :class:`~semexp_bt.nav.global_planner.GlobalPlan`), and turns the costmap's Nav2 costs
into ``nav_msgs/OccupancyGrid`` cell values as Nav2's costmap publisher does (:func:`occupancy_values`):
the Rerun logging and the MCAP export draw the inflation gradient as well as the obstacles.

It runs on the tick thread, at most once per :data:`MAP_PERIOD_S` of robot time, and returns an immutable
copy, so the viewer's worker thread never reads a map the planner is writing.

Example:
    >>> from semexp_bt.nav.costmap import Costmap, CostmapConfig
    >>> from semexp_bt.nav.footprint import Footprint
    >>> costmap = Costmap(CostmapConfig(), footprint=Footprint(-0.378, 0.29, 0.15), origin_xy=(0.0, 0.0))
    >>> map_layer({"/local_map": costmap}) is None  # nothing observed yet: nothing to draw
    True
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.app.viewer.frames import MapLayer
from semexp_bt.nav.costmap import INSCRIBED_COST, LETHAL_COST, NO_INFORMATION_COST, Costmap
from semexp_bt.nav.global_planner import GlobalPlan

#: Cell values of ``nav_msgs/OccupancyGrid`` (and of Rerun's ``RvizMap`` colour map).
UNKNOWN_CELL = -1
FREE_CELL = 0
OCCUPIED_CELL = 100
#: The value of a cell where the base centre collides in every heading (Nav2's inscribed cost).
INSCRIBED_CELL = 99
#: The view redraws the map at most this often (robot time, s): the costmap changes at 6 Hz, and a 1 Hz
#: copy of it costs the tick thread well under a millisecond per simulated second.
MAP_PERIOD_S = 1.0
#: Unknown cells kept around the observed part of the map (cells), so the drawn map has a border.
MAP_MARGIN_CELLS = 5


def _occupancy_of_each_cost() -> npt.NDArray[np.int8]:
    """The ``OccupancyGrid`` value of each Nav2 cost 0-255, indexed by the cost (see :func:`occupancy_values`)."""
    c = np.arange(256, dtype=np.int32)
    values = 1 + (97 * (c - 1)) // (INSCRIBED_COST - 2)
    values = np.where(c == 0, FREE_CELL, values)
    values = np.where(c == INSCRIBED_COST, INSCRIBED_CELL, values)
    values = np.where(c == LETHAL_COST, OCCUPIED_CELL, values)
    values = np.where(c == NO_INFORMATION_COST, UNKNOWN_CELL, values)
    return values.astype(np.int8)


#: The translation table of :func:`occupancy_values`: a cost is one of 256 values, so the map is translated by
#: one look-up per cell instead of five passes of arithmetic over it.
_OCCUPANCY_OF_COST = _occupancy_of_each_cost()


def occupancy_values(cost: npt.NDArray[np.uint8]) -> npt.NDArray[np.int8]:
    """Nav2 costs (0-255) as ``OccupancyGrid`` values: 255 -> -1, 254 -> 100, 253 -> 99, 0 -> 0 and the
    inflation costs 1-252 spread over 1-98 (the translation of Nav2's ``costmap_2d_publisher``)."""
    return _OCCUPANCY_OF_COST[np.asarray(cost, dtype=np.uint8)]


def _plan_of(storage: Mapping[str, Any]) -> GlobalPlan | None:
    plan = storage.get("/global_plan")
    return plan if isinstance(plan, GlobalPlan) and plan.ok and len(plan.path_xy) > 1 else None


def map_version(storage: Mapping[str, Any]) -> int | None:
    """A number that changes whenever the map or the path does, or None when the board holds no costmap
    (cheap: every tick)."""
    costmap = storage.get("/local_map")
    if not isinstance(costmap, Costmap):
        return None
    plan = _plan_of(storage)
    return hash((int(costmap.frames), costmap.revision, None if plan is None else plan.stamp_s))


def map_layer(storage: Mapping[str, Any]) -> MapLayer | None:
    """The costmap as a :class:`MapLayer`, cropped to what has been observed, with the global path; None
    before anything has been observed.

    Args:
        storage: the blackboard's storage (``py_trees.blackboard.Blackboard.storage``: ``/key`` -> value).
    """
    costmap = storage.get("/local_map")
    if not isinstance(costmap, Costmap):
        return None
    # The observed part's bounding box from the rows and columns that hold an observed cell: two
    # reductions, not the index of every observed cell.
    observed = costmap.observed
    rows = np.flatnonzero(observed.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(observed.any(axis=0))
    height, width = costmap.shape
    lo_r = max(int(rows[0]) - MAP_MARGIN_CELLS, 0)
    hi_r = min(int(rows[-1]) + 1 + MAP_MARGIN_CELLS, height)
    lo_c = max(int(cols[0]) - MAP_MARGIN_CELLS, 0)
    hi_c = min(int(cols[-1]) + 1 + MAP_MARGIN_CELLS, width)
    window = (slice(lo_r, hi_r), slice(lo_c, hi_c))
    cells = occupancy_values(costmap.cost(costmap.distance_m[window], observed[window]))
    cells[costmap.lethal()[window]] = OCCUPIED_CELL
    corner = costmap.centre_of(np.array(lo_r), np.array(lo_c)) - 0.5 * costmap.resolution_m
    plan = _plan_of(storage)
    return MapLayer(
        cells=np.ascontiguousarray(cells),
        origin_xy=(float(corner[0]), float(corner[1])),
        resolution_m=float(costmap.resolution_m),
        version=map_version(storage) or 0,
        path_xy=None if plan is None else np.array(plan.path_xy, dtype=np.float64),
    )
