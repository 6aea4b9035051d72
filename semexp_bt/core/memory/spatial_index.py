"""The memory's spatial index: node positions, queried by radius and by k nearest.

A uniform-grid spatial hash (:class:`SpatialGrid`) answers the memory's two hot queries (nodes within
delta_d of an observation, within delta_r of a new node) in time proportional to the nodes near the query
point, never to the size of the memory; a contiguous array of every position (:class:`PointStore`) answers
whole-memory queries (Euclidean travel costs, and a sparse memory queried far from its nodes) in one
vectorised pass. :class:`SpatialIndex` keeps the two and the position table in step. See
``docs/memory.md`` (Performance) for the measured costs.

This is a core module: standard library and numpy only.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Iterator

import numpy as np
import numpy.typing as npt

Vec3 = tuple[float, float, float]
CellKey = tuple[int, int, int]

#: A grid query that would visit more cells than this falls back to one vectorised scan of all nodes
#: (a sparse memory queried far from its nodes: scanning empty cells would cost more than the scan).
MAX_GRID_CELLS_PER_QUERY = 1500
#: Below this many nodes a plain scan is as cheap as the grid.
LINEAR_SCAN_MAX_NODES = 32


class SpatialGrid:
    """Uniform-grid spatial hash: cell key -> ids of the nodes whose position falls in that cell.

    The bounding box of the cells ever occupied is tracked (it only grows) so that queries clip their
    cell ranges to it: indoor memories are a few cells thick in z, so a 3D query costs about as much as
    a 2D one.
    """

    def __init__(self, cell_m: float) -> None:
        self.cell_m = cell_m
        self._inv = 1.0 / cell_m
        self.cells: dict[CellKey, set[int]] = {}
        self.lo = [math.inf, math.inf, math.inf]
        self.hi = [-math.inf, -math.inf, -math.inf]

    def key(self, p: Vec3) -> CellKey:
        inv = self._inv
        return (math.floor(p[0] * inv), math.floor(p[1] * inv), math.floor(p[2] * inv))

    def insert(self, node_id: int, p: Vec3) -> None:
        k = self.key(p)
        bucket = self.cells.get(k)
        if bucket is None:
            self.cells[k] = {node_id}
            for axis in range(3):
                if k[axis] < self.lo[axis]:
                    self.lo[axis] = k[axis]
                if k[axis] > self.hi[axis]:
                    self.hi[axis] = k[axis]
        else:
            bucket.add(node_id)

    def remove(self, node_id: int, p: Vec3) -> None:
        k = self.key(p)
        bucket = self.cells[k]
        bucket.discard(node_id)
        if not bucket:
            del self.cells[k]

    def move(self, node_id: int, old: Vec3, new: Vec3) -> None:
        if self.key(old) != self.key(new):
            self.remove(node_id, old)
            self.insert(node_id, new)

    def box_cells(self, p: Vec3, radius: float) -> tuple[range, range, range] | None:
        """Cell index ranges covering the ball (p, radius), clipped to the occupied box; None if empty."""
        inv = self._inv
        ranges = []
        for axis in range(3):
            lo = max(math.floor((p[axis] - radius) * inv), self.lo[axis])
            hi = min(math.floor((p[axis] + radius) * inv), self.hi[axis])
            if lo > hi:
                return None
            ranges.append(range(int(lo), int(hi) + 1))
        return ranges[0], ranges[1], ranges[2]

    def shell(self, c: CellKey, r: int) -> Iterator[set[int]]:
        """Buckets of the cells at Chebyshev distance exactly ``r`` from cell ``c``, inside the box."""
        cells = self.cells
        if r == 0:
            bucket = cells.get(c)
            if bucket:
                yield bucket
            return
        cx, cy, cz = c
        x_lo, x_hi = max(cx - r, self.lo[0]), min(cx + r, self.hi[0])
        y_lo, y_hi = max(cy - r, self.lo[1]), min(cy + r, self.hi[1])
        z_lo, z_hi = max(cz - r, self.lo[2]), min(cz + r, self.hi[2])
        if x_lo > x_hi or y_lo > y_hi or z_lo > z_hi:
            return
        full_z = range(int(z_lo), int(z_hi) + 1)
        cap_z = [z for z in (cz - r, cz + r) if z_lo <= z <= z_hi]
        all_y = range(int(y_lo), int(y_hi) + 1)
        face_y = [y for y in (cy - r, cy + r) if y_lo <= y <= y_hi]
        for i in range(int(x_lo), int(x_hi) + 1):
            if abs(i - cx) == r:  # an x face: the whole clipped square
                rows: Iterable[tuple[int, Iterable[int]]] = ((j, full_z) for j in all_y)
            elif cap_z:  # inside: the y faces plus the z caps of the other rows
                rows = ((j, full_z if abs(j - cy) == r else cap_z) for j in all_y)
            else:  # the z caps are clipped away: only the y faces remain
                rows = ((j, full_z) for j in face_y)
            for j, zs in rows:
                for k in zs:
                    bucket = cells.get((i, j, k))
                    if bucket:
                        yield bucket

    def clipped_cube_cells(self, c: CellKey, r: int) -> int:
        """How many cells of the cube of Chebyshev radius ``r`` around ``c`` lie inside the box."""
        count = 1
        for axis in range(3):
            count *= max(0, int(min(c[axis] + r, self.hi[axis]) - max(c[axis] - r, self.lo[axis])) + 1)
        return count


class PointStore:
    """Node positions in one contiguous numpy array, for vectorised whole-memory distance queries."""

    def __init__(self, capacity: int = 1024) -> None:
        self.xyz = np.zeros((capacity, 3))
        self.ids = np.full(capacity, -1, dtype=np.int64)
        self.slot_of: dict[int, int] = {}
        self._free: list[int] = list(range(capacity - 1, -1, -1))

    def add(self, node_id: int, p: Vec3) -> None:
        if not self._free:
            old = len(self.ids)
            self.xyz = np.concatenate([self.xyz, np.zeros((old, 3))])
            self.ids = np.concatenate([self.ids, np.full(old, -1, dtype=np.int64)])
            self._free = list(range(2 * old - 1, old - 1, -1))
        slot = self._free.pop()
        self.slot_of[node_id] = slot
        self.xyz[slot] = p
        self.ids[slot] = node_id

    def remove(self, node_id: int) -> None:
        slot = self.slot_of.pop(node_id)
        self.ids[slot] = -1
        self._free.append(slot)

    def move(self, node_id: int, p: Vec3) -> None:
        self.xyz[self.slot_of[node_id]] = p

    def distances(self, p: Vec3) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        live = self.ids >= 0
        ids = self.ids[live]
        d = np.sqrt(((self.xyz[live] - np.asarray(p)) ** 2).sum(axis=1))
        return ids, d


class SpatialIndex:
    """Node positions with the grid and the array kept in step: insert, remove and move go through here.

    Args:
        cell_m: side of a grid cell (m).
    """

    def __init__(self, cell_m: float) -> None:
        self.cell_m = cell_m
        self.positions: dict[int, Vec3] = {}
        """node id -> position: read it; change it only through :meth:`insert`, :meth:`remove` and
        :meth:`move`."""
        self._grid = SpatialGrid(cell_m)
        self._store = PointStore()

    def insert(self, node_id: int, p: Vec3) -> None:
        """Index a new node at ``p``."""
        self.positions[node_id] = p
        self._grid.insert(node_id, p)
        self._store.add(node_id, p)

    def remove(self, node_id: int) -> None:
        """Forget a node."""
        p = self.positions.pop(node_id)
        self._grid.remove(node_id, p)
        self._store.remove(node_id)

    def move(self, node_id: int, new_p: Vec3) -> None:
        """Move an indexed node to ``new_p``."""
        old_p = self.positions[node_id]
        self.positions[node_id] = new_p
        self._grid.move(node_id, old_p, new_p)
        self._store.move(node_id, new_p)

    def distances(self, p: Vec3) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """Ids of every node and their distances to ``p``, in one vectorised pass."""
        return self._store.distances(p)

    def consistency_problem(self) -> str | None:
        """What disagrees between the position table, the grid and the array; None when they agree."""
        indexed = [n for bucket in self._grid.cells.values() for n in bucket]
        if sorted(indexed) != sorted(self.positions) or set(self._store.slot_of) != set(self.positions):
            return "spatial index differs from the graph"
        for n, p in self.positions.items():
            if n not in self._grid.cells.get(self._grid.key(p), ()):
                return f"node {n}: indexed position differs from its attribute"
        return None

    def within(self, p: Vec3, radius: float) -> list[tuple[float, int]]:
        """``(distance, id)`` of the nodes within ``radius`` (inclusive) of ``p``, nearest first."""
        pos = self.positions
        out: list[tuple[float, int]] = []
        if not pos:
            return out
        if len(pos) <= LINEAR_SCAN_MAX_NODES:
            for n, q in pos.items():
                d = math.dist(p, q)
                if d <= radius:
                    out.append((d, n))
            out.sort()
            return out
        box = self._grid.box_cells(p, radius)
        if box is None:
            return out
        xs, ys, zs = box
        if len(xs) * len(ys) * len(zs) > MAX_GRID_CELLS_PER_QUERY:
            ids, dist = self._store.distances(p)
            hit = dist <= radius
            out = sorted(zip(dist[hit].tolist(), ids[hit].tolist(), strict=True))
            return out
        cells = self._grid.cells
        for i in xs:
            for j in ys:
                for k in zs:
                    bucket = cells.get((i, j, k))
                    if bucket:
                        for n in bucket:
                            d = math.dist(p, pos[n])
                            if d <= radius:
                                out.append((d, n))
        out.sort()
        return out

    def k_nearest(self, p: Vec3, k: int) -> list[tuple[float, int]]:
        """``(distance, id)`` of the ``k`` nodes nearest to ``p``, nearest first (ties: lower id)."""
        pos = self.positions
        if not pos:
            return []
        if len(pos) <= LINEAR_SCAN_MAX_NODES:
            return sorted((math.dist(p, q), n) for n, q in pos.items())[:k]
        grid = self._grid
        c = grid.key(p)
        # Cells at Chebyshev ring r + 1 are at least r * cell_m away, so once the k-th best distance is
        # within r * cell_m the search can stop. Start at the first ring that reaches the occupied box.
        r_start = max(0, *(max(grid.lo[a] - c[a], c[a] - grid.hi[a]) for a in range(3)))
        r_end = max(max(abs(c[a] - grid.lo[a]), abs(c[a] - grid.hi[a])) for a in range(3))
        heap: list[tuple[float, int]] = []  # max-heap of the best k as (-d, -id)
        for r in range(int(r_start), int(r_end) + 1):
            if grid.clipped_cube_cells(c, r) > MAX_GRID_CELLS_PER_QUERY:
                ids, dist = self._store.distances(p)
                order = np.lexsort((ids, dist))[:k]
                return [(float(dist[i]), int(ids[i])) for i in order]
            for bucket in grid.shell(c, r):
                for n in bucket:
                    item = (-math.dist(p, pos[n]), -n)
                    if len(heap) < k:
                        heapq.heappush(heap, item)
                    elif item > heap[0]:
                        heapq.heapreplace(heap, item)
            if len(heap) == k and -heap[0][0] <= r * grid.cell_m:
                break
        return sorted((-d, -n) for d, n in heap)
