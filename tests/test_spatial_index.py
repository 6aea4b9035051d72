"""Tests for semexp_bt.core.memory.spatial_index on its own: every query agrees with a brute-force scan,
whichever path (plain scan, grid, vectorised fallback) answers it, through inserts, moves and removals."""

from __future__ import annotations

import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.memory import MemoryInvariantError, TopologicalMemory
from semexp_bt.core.memory.spatial_index import LINEAR_SCAN_MAX_NODES, MAX_GRID_CELLS_PER_QUERY, SpatialIndex


def _random_index(seed: int, nodes: int, extent_m: float, cell_m: float = 0.75) -> SpatialIndex:
    rng = random.Random(seed)
    index = SpatialIndex(cell_m)
    for node_id in range(nodes):
        index.insert(
            node_id, (rng.uniform(-extent_m, extent_m), rng.uniform(-extent_m, extent_m), rng.uniform(0, 2))
        )
    for node_id in rng.sample(range(nodes), nodes // 4):
        index.remove(node_id)
    for node_id in rng.sample(sorted(index.positions), len(index.positions) // 4):
        index.move(
            node_id, (rng.uniform(-extent_m, extent_m), rng.uniform(-extent_m, extent_m), rng.uniform(0, 2))
        )
    return index


def _brute(index: SpatialIndex, p: tuple[float, float, float]) -> list[tuple[float, int]]:
    return sorted((math.dist(p, q), n) for n, q in index.positions.items())


def _agree(found: list[tuple[float, int]], expected: list[tuple[float, int]]) -> bool:
    # The vectorised fallback computes distances in numpy, which may differ from math.dist in the last bit.
    return [n for _, n in found] == [n for _, n in expected] and [d for d, _ in found] == pytest.approx(
        [d for d, _ in expected], rel=1e-12
    )


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    nodes=st.sampled_from([5, LINEAR_SCAN_MAX_NODES + 1, 120]),
    extent_m=st.sampled_from([3.0, 30.0, 300.0]),
    query=st.tuples(st.floats(-40, 40), st.floats(-40, 40), st.floats(-3, 3)),
    radius=st.floats(0.0, 8.0),
    k=st.integers(1, 8),
)
def test_queries_agree_with_a_brute_force_scan(seed, nodes, extent_m, query, radius, k) -> None:
    index = _random_index(seed, nodes, extent_m)
    brute = _brute(index, query)
    assert _agree(index.within(query, radius), [(d, n) for d, n in brute if d <= radius])
    assert _agree(index.k_nearest(query, k), brute[:k])
    ids, distances = index.distances(query)
    assert _agree(sorted(zip(distances.tolist(), ids.tolist(), strict=True)), brute)
    assert index.consistency_problem() is None


def test_a_query_over_too_many_cells_falls_back_to_the_vectorised_scan() -> None:
    index = _random_index(seed=1, nodes=200, extent_m=50.0, cell_m=0.05)
    radius = 10.0  # (2 * 10 / 0.05)^2 cells in the plane alone: far above the limit
    assert (2 * radius / index.cell_m) ** 2 > MAX_GRID_CELLS_PER_QUERY
    brute = _brute(index, (0.0, 0.0, 1.0))
    assert _agree(index.within((0.0, 0.0, 1.0), radius), [(d, n) for d, n in brute if d <= radius])
    assert _agree(index.k_nearest((0.0, 0.0, 1.0), 3), brute[:3])


def test_check_invariants_reports_a_stale_index() -> None:
    memory = TopologicalMemory()
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    node = memory.update(position_m=(3.0, 0.0, 0.5), label="chair", confidence=0.8, stamp_s=1.0).node_id
    memory.check_invariants()
    memory.graph.nodes[node]["position"] = (9.0, 0.0, 0.5)  # mutated behind the index's back
    with pytest.raises(MemoryInvariantError, match=f"node {node}: indexed position differs"):
        memory.check_invariants()
