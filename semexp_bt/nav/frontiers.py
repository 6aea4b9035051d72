"""Frontiers of the costmap: observed free cells next to never-observed ones, clustered, with a place to stand.

The classic exploration frontier (Yamauchi 1997; SemExp and VLFM plan to frontiers of their maps): a
cell the robot could stand on (observed, not lethal, at least the padded footprint's inscribed radius
from every lethal cell) that borders a never-observed cell. Frontier cells are grouped into 8-connected
clusters (``scipy.ndimage.label``); each cluster of at least ``min_cells`` cells gives one frontier at
its cell nearest the cluster's centroid, with its size. The cells within ``min_distance_m`` of the robot
are left out: the camera never sees the floor right around the robot (its view starts half a metre
ahead of the lens), so that ring is always unknown and is no place to explore.

These feed the topological memory as "unexplored area" place nodes (``behaviours/update_memory.py``):
its exploration potential and candidate set then cover the whole seen/unseen boundary, not only the
directions the current view happens to show, so the utility stops circling the area it has seen.

Example:
    >>> costmap_frontiers(costmap, around_xy=(0.0, 0.0), radius_m=6.0)  # doctest: +SKIP
    [Frontier(x_m=2.3, y_m=0.4, cells=31)]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

if TYPE_CHECKING:
    from semexp_bt.nav.costmap import Costmap

_EIGHT = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class Frontier:
    """One frontier cluster: where to stand (``x_m``, ``y_m``) and how many frontier cells it has."""

    x_m: float
    y_m: float
    cells: int


def costmap_frontiers(
    costmap: Costmap, *, around_xy: tuple[float, float], radius_m: float, min_cells: int = 8,
    min_distance_m: float = 1.0,
) -> list[Frontier]:  # fmt: skip
    """Frontier clusters within ``radius_m`` of ``around_xy`` (see the module docstring), largest first."""
    window = _window(costmap, around_xy, radius_m)
    if window is None:
        return []
    rows, cols = window
    observed = costmap.observed[rows, cols]
    lethal = costmap.log_odds[rows, cols] > costmap.config.lethal_log_odds
    standable = observed & ~lethal & (costmap.distance_m[rows, cols] >= costmap.inscribed_radius_m)
    unknown_near = ndimage.binary_dilation(~observed, structure=_EIGHT)
    frontier = standable & unknown_near
    r0, c0 = rows.start, cols.start
    rr, cc = np.ogrid[0 : frontier.shape[0], 0 : frontier.shape[1]]
    centre = costmap.cell_of(np.asarray(around_xy, dtype=float))
    res = costmap.resolution_m
    gap = np.hypot(rr + r0 - centre[0], cc + c0 - centre[1]) * res
    frontier &= (gap >= min_distance_m) & (gap <= radius_m)
    labels, count = ndimage.label(frontier, structure=_EIGHT)
    if count == 0:
        return []
    sizes = np.bincount(labels.ravel(), minlength=count + 1)
    keep = np.flatnonzero(sizes >= min_cells)
    keep = keep[keep > 0]
    if keep.size == 0:
        return []
    centroids = ndimage.center_of_mass(frontier, labels, keep)
    out = []
    for label, (cr, cc_) in zip(keep, centroids, strict=True):
        r_idx, c_idx = np.nonzero(labels == label)
        pick = int(np.argmin((r_idx - cr) ** 2 + (c_idx - cc_) ** 2))
        xy = costmap.centre_of(r_idx[pick] + r0, c_idx[pick] + c0)
        out.append(Frontier(float(xy[0]), float(xy[1]), int(sizes[label])))
    out.sort(key=lambda f: -f.cells)
    return out


def known_fraction(costmap: Costmap, xy: tuple[float, float], *, radius_m: float) -> float:
    """Share of the cells within ``radius_m`` of ``xy`` that were observed (0 outside the grid)."""
    window = _window(costmap, xy, radius_m)
    if window is None:
        return 0.0
    rows, cols = window
    centre = costmap.cell_of(np.asarray(xy, dtype=float))
    reach = radius_m / costmap.resolution_m
    rr, cc = np.ogrid[rows, cols]
    disc = (rr - centre[0]) ** 2 + (cc - centre[1]) ** 2 <= reach * reach
    if not disc.any():
        return 0.0
    # Cells of the disc outside the grid count as unobserved.
    total = math.pi * reach * reach
    return float(min(1.0, costmap.observed[rows, cols][disc].sum() / max(total, 1.0)))


def _window(costmap: Costmap, xy: tuple[float, float], radius_m: float) -> tuple[slice, slice] | None:
    centre = costmap.cell_of(np.asarray(xy, dtype=float))
    reach = int(math.ceil(radius_m / costmap.resolution_m))
    n_rows, n_cols = costmap.shape
    r0, r1 = max(int(centre[0]) - reach, 0), min(int(centre[0]) + reach + 1, n_rows)
    c0, c1 = max(int(centre[1]) - reach, 0), min(int(centre[1]) + reach + 1, n_cols)
    if r1 - r0 < 3 or c1 - c0 < 3:
        return None
    return slice(r0, r1), slice(c0, c1)
