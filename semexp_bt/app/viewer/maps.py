"""The map the world view draws: one adapter from whatever map the planner uses to a plain grid.

:func:`map_layer` is the only place the viewer reads a map. Today it reads the occupancy map on the board
(``local_map``, :class:`~semexp_bt.nav.local_map.OccupancyMap`); a costmap or a global path that the
navigation stack puts on the board later plugs in here, and the Rerun logging and the MCAP export
(``nav_msgs/OccupancyGrid`` cell values) stay as they are.

It runs on the tick thread, at most once per :data:`MAP_PERIOD_S` of robot time, and returns an immutable
copy, so the viewer's worker thread never reads a map the planner is writing.

Example:
    >>> from semexp_bt.nav.local_map import OccupancyMap
    >>> layer = map_layer({"/local_map": OccupancyMap(origin_xy=(0.0, 0.0))})
    >>> layer is None  # nothing observed yet: nothing to draw
    True
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.nav.local_map import OccupancyMap

#: Cell values of ``nav_msgs/OccupancyGrid`` (and of Rerun's ``RvizMap`` colour map).
UNKNOWN_CELL = -1
FREE_CELL = 0
OCCUPIED_CELL = 100
#: The view redraws the map at most this often (robot time, s): the planner's map changes at 4 Hz, and a
#: 1 Hz copy of it costs the tick thread about 0.3 ms per simulated second.
MAP_PERIOD_S = 1.0
#: Unknown cells kept around the observed part of the map (cells), so the drawn map has a border.
MAP_MARGIN_CELLS = 5


@dataclass(frozen=True)
class MapLayer:
    """A snapshot of the planner's map, ready to draw.

    Attributes:
        cells: ``(H, W)`` int8 in ``nav_msgs/OccupancyGrid`` convention (-1 unknown, 0 free, 100
            occupied; a costmap may use the values between); row ``i`` is ``y = origin_y + i * res``,
            column ``j`` is ``x = origin_x + j * res`` (row-major from the lower-left corner, as ROS).
        origin_xy: world position (``map``) of the outer corner of cell ``(0, 0)``, m.
        resolution_m: cell side, m.
        version: changes whenever the map does (here: frames integrated so far).
        path_xy: ``(N, 2)`` the global path planned on this map, when the planner publishes one; None today.
    """

    cells: npt.NDArray[np.int8]
    origin_xy: tuple[float, float]
    resolution_m: float
    version: int
    path_xy: npt.NDArray[np.float64] | None = None


def map_version(storage: Mapping[str, Any]) -> int | None:
    """A number that changes whenever the map does, or None when the board holds no map (cheap: every tick)."""
    local_map = storage.get("/local_map")
    return None if not isinstance(local_map, OccupancyMap) else int(local_map.frames)


def map_layer(storage: Mapping[str, Any]) -> MapLayer | None:
    """The planner's map as a :class:`MapLayer`, cropped to what has been observed; None before that.

    Args:
        storage: the blackboard's storage (``py_trees.blackboard.Blackboard.storage``: ``/key`` -> value).
    """
    local_map = storage.get("/local_map")
    if not isinstance(local_map, OccupancyMap) or local_map.frames == 0:
        return None
    known = local_map.known()
    rows, cols = np.nonzero(known)
    if rows.size == 0:
        return None
    # OccupancyMap indexes (row = x, col = y); crop, then transpose to ROS order (row = y, col = x).
    lo_x = max(int(rows.min()) - MAP_MARGIN_CELLS, 0)
    hi_x = min(int(rows.max()) + 1 + MAP_MARGIN_CELLS, local_map.size)
    lo_y = max(int(cols.min()) - MAP_MARGIN_CELLS, 0)
    hi_y = min(int(cols.max()) + 1 + MAP_MARGIN_CELLS, local_map.size)
    window = (slice(lo_x, hi_x), slice(lo_y, hi_y))
    cells = np.full((hi_x - lo_x, hi_y - lo_y), UNKNOWN_CELL, dtype=np.int8)
    cells[known[window]] = FREE_CELL
    cells[local_map.occupied()[window]] = OCCUPIED_CELL
    resolution = float(local_map.config.resolution_m)
    corner = local_map.centre_of(np.array([lo_x, lo_y])) - 0.5 * resolution
    return MapLayer(
        cells=np.ascontiguousarray(cells.T),
        origin_xy=(float(corner[0]), float(corner[1])),
        resolution_m=resolution,
        version=int(local_map.frames),
    )
