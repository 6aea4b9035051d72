"""Tests for the controlled-growth semantic topological memory (paper Sec. III-D, Eq. 5-7)."""

from __future__ import annotations

import json
import math

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.config import MemoryConfig
from semexp_bt.core.memory import (
    SNAPSHOT_FORMAT,
    SNAPSHOT_VERSION,
    MemoryUpdate,
    TopologicalMemory,
    UnknownNodeError,
)
from semexp_bt.core.types import InvalidInputError

# Round numbers so the hand-worked examples below are easy to follow.
CONFIG = MemoryConfig(
    delta_d=1.0,
    cf_gate=0.3,
    rho=0.25,
    delta_r=2.0,
    k_nearest=2,
    xi=0.5,
    observe_radius_m=1.5,
    prune_potential=0.1,
    prune_confidence=0.2,
    merge_radius_m=1.5,
    maintenance_every=1000,
    max_nodes=1000,
)
FAR = (-50.0, 0.0, 0.0)  # master position well away from the action in most examples


def fresh(config: MemoryConfig = CONFIG, master_at: tuple[float, float, float] = FAR) -> TopologicalMemory:
    memory = TopologicalMemory(config)
    memory.add_master(position_m=master_at, stamp_s=0.0)
    return memory


def insert(memory: TopologicalMemory, position, label: str = "chair", confidence: float = 0.8) -> int:
    result = memory.update(position_m=position, label=label, confidence=confidence, stamp_s=1.0)
    assert result.action == "inserted", result
    assert result.node_id is not None
    return result.node_id


def snapshot_of(nodes: list[tuple[int, tuple[float, float, float], str, float, float]], edges, master=None):
    """A hand-built snapshot: nodes as (id, position, label, confidence, potential); edges as (u, v)."""
    pos = {n: p for n, p, *_ in nodes}
    return {
        "format": SNAPSHOT_FORMAT,
        "version": SNAPSHOT_VERSION,
        "next_id": max(pos) + 1,
        "master_id": master,
        "nodes": [
            {
                "id": n,
                "position": list(p),
                "label": label,
                "confidence": c,
                "potential": pot,
                "visits": 0,
                "is_master": n == master,
                "created_s": 0.0,
                "updated_s": 0.0,
                "observations": 1,
            }
            for n, p, label, c, pot in nodes
        ],
        "edges": [[u, v, math.dist(pos[u], pos[v])] for u, v in edges],
    }


# --------------------------------------------------------------------------- master node


def test_master_is_a_pinned_zero_potential_anchor() -> None:
    memory = TopologicalMemory(CONFIG)
    master = memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    state = memory.node(master)
    assert (state.is_master, state.label, state.potential, state.confidence) == (True, "start", 0.0, 0.0)
    assert memory.master_id == master and len(memory) == 1
    with pytest.raises(InvalidInputError, match="master"):
        memory.add_master(position_m=(9.0, 0.0, 0.0), stamp_s=0.0)

    # A confident observation on top of the master takes over its label (C_f beats the master's 0) and
    # raises its potential, but the master never moves.
    result = memory.update(position_m=(0.6, 0.0, 0.0), label="sofa", confidence=0.6, stamp_s=1.0)
    assert (result.action, result.node_id, result.label_switched) == ("merged", master, True)
    state = memory.node(master)
    assert state.position_m == (0.0, 0.0, 0.0)
    assert state.label == "sofa"
    assert state.confidence == pytest.approx(0.25 * 0.6)
    assert state.potential == pytest.approx(0.6)


# --------------------------------------------------------------------------- Eq. 6 gate and EMA


def test_eq6_ema_position_step_and_potential_hand_worked() -> None:
    memory = fresh()
    node = insert(memory, (5.0, 0.0, 0.0), confidence=0.8)
    assert memory.node(node).potential == pytest.approx(0.8)  # initialised from the fused confidence

    result = memory.update(position_m=(5.4, 0.0, 0.0), label="chair", confidence=0.4, stamp_s=2.0)
    assert result.action == "merged" and result.node_id == node
    assert result.distance_to_nearest == pytest.approx(0.4)
    state = memory.node(node)
    assert state.confidence == pytest.approx(0.75 * 0.8 + 0.25 * 0.4)  # 0.70
    assert state.position_m[0] == pytest.approx(5.0 + 0.25 * 0.4 * 0.4)  # step rho * C_f = 0.1 of 0.4 m
    assert state.potential == pytest.approx(0.8)  # same label: potential untouched
    assert memory.graph.nodes[node]["observations"] == 2
    assert memory.graph.nodes[node]["updated_s"] == 2.0

    stronger = memory.update(position_m=(5.04, 0.5, 0.0), label="chair", confidence=1.0, stamp_s=3.0)
    assert not stronger.label_switched
    state = memory.node(node)
    assert state.confidence == pytest.approx(0.75 * 0.70 + 0.25 * 1.0)  # 0.775
    assert state.position_m[1] == pytest.approx(0.25 * 0.5)
    assert state.potential == pytest.approx(1.0)  # more confident than the node: raised, same label
    memory.check_invariants()


def test_the_potential_raise_does_not_depend_on_the_label_string() -> None:
    """Equal evidence under two names leaves equal potentials (the phrasing benchmark's warehouse_b)."""
    potentials = {}
    for label in ("fire extinguisher", "extinguisher"):
        memory = fresh()
        node = insert(memory, (0.0, 0.0, 0.0), confidence=0.6, label="fire extinguisher")
        memory.scale_potential(node_id=node, factor=0.5)  # a rejected confirmation: 0.6 -> 0.3
        update = memory.update(position_m=(0.1, 0.0, 0.0), label=label, confidence=0.9, stamp_s=2.0)
        assert update.label_switched == (label != "fire extinguisher")
        assert "potential 0.300 -> 0.900" in update.reason
        potentials[label] = memory.node(node).potential
    assert potentials == {"fire extinguisher": pytest.approx(0.9), "extinguisher": pytest.approx(0.9)}


def test_label_switches_only_when_the_new_confidence_beats_the_node() -> None:
    memory = fresh()
    node = insert(memory, (0.0, 0.0, 0.0), confidence=0.5)
    memory.mark_visited(node_id=node)  # potential 0.5 -> 0.25

    weaker = memory.update(position_m=(0.1, 0.0, 0.0), label="sofa", confidence=0.4, stamp_s=2.0)
    assert not weaker.label_switched
    state = memory.node(node)
    assert state.label == "chair"
    assert state.confidence == pytest.approx(0.75 * 0.5 + 0.25 * 0.4)  # 0.475
    assert state.potential == pytest.approx(0.25)

    stronger = memory.update(position_m=(0.1, 0.0, 0.0), label="sofa", confidence=0.9, stamp_s=3.0)
    assert stronger.label_switched
    state = memory.node(node)
    assert state.label == "sofa"
    assert state.confidence == pytest.approx(0.75 * 0.475 + 0.25 * 0.9)  # 0.58125
    assert state.potential == pytest.approx(0.9)  # a new hypothesis is worth a visit


def test_an_object_takes_over_a_place_whatever_the_confidences() -> None:
    memory = fresh()
    place = insert(memory, (0.0, 0.0, 0.0), label="unexplored area", confidence=1.0)
    memory.mark_visited(node_id=place)  # potential 1.0 -> 0.5
    other = insert(memory, (3.0, 0.0, 0.0), label="hedge", confidence=0.9)

    # Without the place's label in takes_over, weaker evidence leaves the node the place's (Eq. 6).
    kept = memory.update(position_m=(0.4, 0.0, 0.0), label="green bin", confidence=0.5, stamp_s=2.0)
    assert not kept.label_switched and memory.node(place).label == "unexplored area"

    taken = memory.update(
        position_m=(0.4, 0.0, 0.0),
        label="green bin",
        confidence=0.45,
        stamp_s=3.0,
        takes_over={"unexplored area"},
    )
    print(taken.reason)
    assert (taken.action, taken.node_id, taken.label_switched) == ("merged", place, True)
    state = memory.node(place)
    assert state.label == "green bin"
    assert state.confidence == pytest.approx(0.45)  # the object's hypothesis starts with its own evidence
    assert state.potential == pytest.approx(0.5)  # max(P, C_f): never lowered
    # The usual step towards the observation (rho C_f of the way): a place stands where the robot can.
    assert state.position_m == pytest.approx((0.05 + 0.25 * 0.45 * 0.35, 0.0, 0.0))
    # Only a place's label is taken over; an object's node follows Eq. 6 as before.
    hedge = memory.update(
        position_m=(3.1, 0.0, 0.0),
        label="green bin",
        confidence=0.5,
        stamp_s=4.0,
        takes_over={"unexplored area"},
    )
    assert hedge.node_id == other and memory.node(other).label == "hedge"
    memory.check_invariants()


def test_gate_insert_merge_reject() -> None:
    memory = fresh(master_at=(0.0, 0.0, 0.0))
    # Exactly delta_d away: not strictly farther, so it merges (into the master).
    at_gate = memory.update(position_m=(1.0, 0.0, 0.0), label="door", confidence=0.9, stamp_s=1.0)
    assert at_gate.action == "merged" and at_gate.distance_to_nearest == pytest.approx(1.0)
    # Far but C_f exactly at the gate: rejected (C_f must exceed cf_gate), nothing changes.
    before = memory.snapshot()
    rejected = memory.update(position_m=(4.0, 0.0, 0.0), label="door", confidence=0.3, stamp_s=2.0)
    assert rejected == MemoryUpdate(
        action="rejected",
        node_id=None,
        distance_to_nearest=pytest.approx(4.0),
        reason=rejected.reason,
    )
    assert "cf_gate" in rejected.reason
    after = memory.snapshot()
    assert after["nodes"] == before["nodes"] and after["edges"] == before["edges"]
    # Far and just above the gate: inserted.
    inserted = memory.update(position_m=(4.0, 0.0, 0.0), label="door", confidence=0.31, stamp_s=3.0)
    assert inserted.action == "inserted" and len(memory) == 2
    # Close and far below the gate: still merged (the EMA lowers the node's confidence).
    low = memory.update(position_m=(4.2, 0.0, 0.0), label="door", confidence=0.0, stamp_s=4.0)
    assert low.action == "merged" and low.node_id == inserted.node_id
    assert memory.node(inserted.node_id).confidence == pytest.approx(0.75 * 0.31)
    assert memory.node(inserted.node_id).position_m == (4.0, 0.0, 0.0)  # C_f = 0: no step


def test_update_into_empty_memory_without_master() -> None:
    memory = TopologicalMemory(CONFIG)
    result = memory.update(position_m=(1.0, 2.0, 0.0), label="tv", confidence=0.7, stamp_s=0.0)
    assert result.action == "inserted" and result.distance_to_nearest == math.inf
    assert (
        memory.update(position_m=(9.0, 2.0, 0.0), label="tv", confidence=0.1, stamp_s=0.0).action
        == "rejected"
    )


def test_merge_move_fuses_same_label_but_holds_still_for_another_label() -> None:
    memory = fresh()
    a = insert(memory, (0.0, 0.0, 0.0), confidence=0.8)
    b = insert(memory, (1.1, 0.0, 0.0), confidence=0.6)
    # Nearest is a (0.5 m vs 0.6 m); a steps by rho * 1.0 = 0.25 of 0.5 m to x = 0.125, now 0.975 m
    # from b, inside delta_d: same label, so they fuse and the more confident a survives in place.
    result = memory.update(position_m=(0.5, 0.0, 0.0), label="chair", confidence=1.0, stamp_s=2.0)
    assert (result.action, result.node_id, result.fused_node_ids) == ("merged", a, (b,))
    assert b not in memory
    state = memory.node(a)
    assert state.position_m[0] == pytest.approx(0.125)
    assert state.confidence == pytest.approx(0.85)
    assert state.potential == pytest.approx(1.0)  # C_f 1.0 beat a's 0.8: raised before the fusion
    assert memory.graph.nodes[a]["observations"] == 3
    memory.check_invariants()

    other = fresh()
    a = insert(other, (0.0, 0.0, 0.0), confidence=0.8)
    b = insert(other, (1.1, 0.0, 0.0), label="table", confidence=0.6)
    result = other.update(position_m=(0.5, 0.0, 0.0), label="chair", confidence=1.0, stamp_s=2.0)
    assert result.fused_node_ids == () and "position kept" in result.reason
    assert other.node(a).position_m == (0.0, 0.0, 0.0) and b in other
    other.check_invariants()


def test_fusion_stops_when_the_moved_node_is_absorbed() -> None:
    memory = fresh()
    a = insert(memory, (0.0, 0.0, 0.0), confidence=0.5)
    b = insert(memory, (0.85, 0.65, 0.0), confidence=0.9)
    c = insert(memory, (0.85, -0.65, 0.0), confidence=0.6)
    # a moves to x = 0.15, 0.955 m from both b and c. It fuses into the more confident b, which keeps
    # its old place (1.3 m from c), so c must survive.
    result = memory.update(position_m=(0.6, 0.0, 0.0), label="chair", confidence=1.0, stamp_s=2.0)
    assert (result.node_id, result.fused_node_ids) == (b, (a,))
    assert c in memory and memory.node(b).position_m == (0.85, 0.65, 0.0)
    assert memory.node(b).potential == pytest.approx(1.0)  # the larger: a's, raised by C_f 1.0
    memory.check_invariants()


# --------------------------------------------------------------------------- edges


def test_edges_within_delta_r_then_k_nearest_fallback() -> None:
    memory = fresh(master_at=(0.0, 0.0, 0.0))
    a = insert(memory, (1.5, 0.0, 0.0))
    assert memory.graph[0][a]["cost"] == pytest.approx(1.5)
    b = insert(memory, (3.0, 0.0, 0.0))  # within 2.0 of a only
    assert set(memory.graph[b]) == {a}
    c = insert(memory, (10.0, 0.0, 0.0))  # nothing within delta_r: the k = 2 nearest
    assert set(memory.graph[c]) == {a, b}
    assert memory.graph[c][b]["cost"] == pytest.approx(7.0)
    assert memory.graph[c][a]["cost"] == pytest.approx(8.5)
    memory.check_invariants()


# --------------------------------------------------------------------------- Eq. 7 decay


def test_eq7_decay_hand_worked() -> None:
    memory = fresh()
    near = insert(memory, (1.0, 0.0, 0.0), confidence=0.8)
    far = insert(memory, (4.0, 0.0, 0.0), confidence=0.6)
    assert memory.observe_surroundings(robot_position_m=(0.0, 0.0, 0.0)) == [near]
    assert memory.node(near).potential == pytest.approx(0.4)
    assert memory.node(far).potential == pytest.approx(0.6)
    memory.observe_surroundings(robot_position_m=(0.0, 0.0, 0.0))
    assert memory.node(near).potential == pytest.approx(0.2)
    assert memory.observe_surroundings(robot_position_m=(0.0, 0.0, 0.0), radius_m=5.0) == [near, far]
    assert memory.node(near).potential == pytest.approx(0.1)
    assert memory.node(far).potential == pytest.approx(0.3)

    memory.mark_visited(node_id=far)
    assert memory.node(far).potential == pytest.approx(0.15) and memory.node(far).visits == 1
    memory.scale_potential(node_id=far, factor=0.5)
    assert memory.node(far).potential == pytest.approx(0.075)
    assert memory.node(far).confidence == pytest.approx(0.6)  # decay never touches the confidence
    assert [s.node_id for s in memory.nodes(min_potential=0.1)] == [near]
    with pytest.raises(InvalidInputError, match="factor"):
        memory.scale_potential(node_id=far, factor=1.5)


# --------------------------------------------------------------------------- maintenance


def _make_prunable(memory: TopologicalMemory, node: int, position) -> None:
    for _ in range(2):  # confidence 0.35 -> 0.2625 -> 0.196875 < 0.2
        memory.update(position_m=position, label="chair", confidence=0.0, stamp_s=5.0)
    for _ in range(2):  # potential 0.35 -> 0.175 -> 0.0875 < 0.1
        memory.mark_visited(node_id=node)


def test_prune_needs_low_potential_and_low_confidence_and_spares_the_master() -> None:
    memory = fresh(master_at=(0.0, 0.0, 0.0))
    weak = insert(memory, (1.5, 0.0, 0.0), confidence=0.35)
    spent = insert(memory, (3.0, 0.0, 0.0), confidence=0.9)
    for _ in range(4):  # potential 0.9 -> 0.05625, confidence stays 0.9
        memory.mark_visited(node_id=spent)
    assert memory.maintain().pruned_node_ids == ()
    _make_prunable(memory, weak, (1.5, 0.0, 0.0))
    report = memory.maintain()
    assert report.pruned_node_ids == (weak,)
    assert memory.master_id in memory and spent in memory  # master: P = C = 0 but never pruned
    memory.check_invariants()


def test_pruning_a_cut_vertex_reconnects_its_neighbours() -> None:
    memory = fresh(master_at=(0.0, 0.0, 0.0))
    a = insert(memory, (1.5, 0.0, 0.0))
    b = insert(memory, (3.0, 0.0, 0.0), confidence=0.35)
    c = insert(memory, (4.5, 0.0, 0.0))
    assert set(memory.graph[b]) == {a, c}
    _make_prunable(memory, b, (3.0, 0.0, 0.0))
    report = memory.maintain()
    assert report.pruned_node_ids == (b,) and report.edges_added == 1
    assert memory.graph[a][c]["cost"] == pytest.approx(3.0)
    assert nx.is_connected(memory.graph)


def test_pruning_a_hub_adds_a_spanning_tree_over_its_neighbours() -> None:
    leaves = [(1, (2.0, 0.0, 0.0)), (2, (0.0, 2.0, 0.0)), (3, (-2.0, 0.0, 0.0)), (4, (0.0, -2.0, 0.0))]
    nodes = [(0, (0.0, 0.0, 0.0), "chair", 0.1, 0.0)] + [(n, p, "chair", 0.9, 0.9) for n, p in leaves]
    memory = TopologicalMemory.from_snapshot(snapshot_of(nodes, [(0, n) for n, _ in leaves]), CONFIG)
    report = memory.maintain()
    assert report.pruned_node_ids == (0,) and report.edges_added == 3
    assert nx.is_connected(memory.graph) and memory.graph.number_of_edges() == 3


def test_maintenance_merges_adjacent_same_label_nodes_only() -> None:
    nodes = [
        (0, (0.0, 0.0, 0.0), "start", 0.0, 0.0),
        (1, (1.2, 0.0, 0.0), "chair", 0.5, 0.7),
        (2, (2.4, 0.0, 0.0), "chair", 0.8, 0.2),
        (3, (2.4, 1.2, 0.0), "table", 0.9, 0.9),
        (4, (3.6, 1.2, 0.0), "table", 0.9, 0.9),
    ]
    # 3 and 4 share a label and lie 1.2 m apart but no edge joins them: not merged.
    memory = TopologicalMemory.from_snapshot(
        snapshot_of(nodes, [(0, 1), (1, 2), (2, 3), (2, 4)], master=0), CONFIG
    )
    memory.graph.nodes[1]["visits"] = 2
    report = memory.maintain()
    assert report.merged == ((1, 2),)  # the more confident 2 survives in place
    merged = memory.graph.nodes[2]
    assert (merged["confidence"], merged["potential"], merged["visits"]) == (0.8, 0.7, 2)
    assert merged["position"] == (2.4, 0.0, 0.0)
    assert set(memory.graph[2]) == {0, 3, 4}  # inherits 1's edge to the master
    assert memory.graph[2][0]["cost"] == pytest.approx(2.4)
    assert 3 in memory and 4 in memory
    memory.check_invariants()


def test_maintenance_runs_every_n_updates() -> None:
    memory = fresh(MemoryConfig(maintenance_every=3))
    results = [
        memory.update(position_m=(float(3 * i), 0.0, 0.0), label="x", confidence=0.9, stamp_s=float(i))
        for i in range(7)
    ]
    ran = [i for i, r in enumerate(results) if r.maintenance is not None]
    assert ran == [3, 6]


def test_capacity_evicts_the_lowest_value_node_but_never_master_or_newcomer() -> None:
    memory = fresh(MemoryConfig(max_nodes=3, cf_gate=0.05), master_at=(0.0, 0.0, 0.0))
    strong = insert(memory, (2.0, 0.0, 0.0), confidence=0.9)
    weak = insert(memory, (4.0, 0.0, 0.0), confidence=0.5)
    newcomer = memory.update(position_m=(6.0, 0.0, 0.0), label="chair", confidence=0.1, stamp_s=3.0)
    assert newcomer.evicted_node_ids == (weak,)
    assert set(memory.graph) == {memory.master_id, strong, newcomer.node_id}
    memory.check_invariants()


# --------------------------------------------------------------------------- travel costs


def test_travel_costs_graph_versus_euclidean() -> None:
    nodes = [
        (0, (0.0, 0.0, 0.0), "a", 0.5, 0.5),
        (1, (3.0, 0.0, 0.0), "b", 0.5, 0.5),
        (2, (3.0, 4.0, 0.0), "c", 0.5, 0.5),
        (3, (30.0, 0.0, 0.0), "island", 0.5, 0.5),
    ]
    memory = TopologicalMemory.from_snapshot(snapshot_of(nodes, [(0, 1), (1, 2)]), CONFIG)
    robot = (0.0, 1.0, 0.0)  # entry: node 0, 1 m away
    graph = memory.travel_costs(from_position_m=robot, mode="graph")
    assert graph[0] == pytest.approx(1.0)
    assert graph[1] == pytest.approx(1.0 + 3.0)
    assert graph[2] == pytest.approx(1.0 + 3.0 + 4.0)
    assert graph[3] == math.inf
    euclid = memory.travel_costs(from_position_m=robot, mode="euclidean")
    assert euclid == pytest.approx({0: 1.0, 1: math.sqrt(10.0), 2: math.sqrt(18.0), 3: math.sqrt(901.0)})
    assert TopologicalMemory(CONFIG).travel_costs(from_position_m=robot) == {}
    with pytest.raises(InvalidInputError, match="mode"):
        memory.travel_costs(from_position_m=robot, mode="manhattan")  # type: ignore[arg-type]


# --------------------------------------------------------------------------- snapshot


def _random_memory(seed: int, steps: int = 300) -> TopologicalMemory:
    rng = np.random.default_rng(seed)
    memory = fresh(MemoryConfig(maintenance_every=7), master_at=(0.0, 0.0, 0.0))
    for t in range(steps):
        p = tuple(rng.uniform(-6.0, 6.0, size=3) * (1.0, 1.0, 0.2))
        memory.update(
            position_m=p, label=str(rng.choice(["a", "b", "c"])), confidence=rng.uniform(), stamp_s=t
        )
        if t % 9 == 0:
            memory.observe_surroundings(robot_position_m=p)
    return memory


def test_snapshot_round_trip_through_json() -> None:
    memory = _random_memory(seed=3)
    data = json.loads(json.dumps(memory.snapshot()))
    restored = TopologicalMemory.from_snapshot(data, memory.config)
    assert restored.snapshot() == memory.snapshot()
    restored.check_invariants()
    # Both continue identically.
    for mem in (memory, restored):
        mem.update(position_m=(0.3, 0.2, 0.0), label="a", confidence=0.9, stamp_s=1e3)
        mem.update(position_m=(7.5, 7.5, 0.0), label="z", confidence=0.9, stamp_s=1e3)
        mem.maintain()
    assert restored.snapshot() == memory.snapshot()


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.pop("nodes"), "missing key 'nodes'"),
        (lambda d: d.update(version=99), "snapshot.version"),
        (lambda d: d["nodes"][1].update(confidence=float("nan")), r"nodes\[1\].confidence"),
        (lambda d: d["nodes"][1].update(potential=1.5), r"nodes\[1\].potential"),
        (lambda d: d["nodes"][0].update(position=[0.0, 1.0]), r"nodes\[0\].position"),
        (lambda d: d["edges"].append([0, 999, 1.0]), r"edges\[\d+\]"),
        (lambda d: d.update(master_id=1), "master_id"),
    ],
)
def test_malformed_snapshot_names_the_key(mutate, message) -> None:
    data = _random_memory(seed=1, steps=30).snapshot()
    mutate(data)
    with pytest.raises(InvalidInputError, match=message):
        TopologicalMemory.from_snapshot(data, CONFIG)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"position_m": (math.nan, 0.0, 0.0)}, "position_m"),
        ({"position_m": (0.0, math.inf, 0.0)}, "position_m"),
        ({"position_m": np.array([0.0, 0.0, -math.inf])}, "position_m"),
        ({"position_m": (0.0, 0.0)}, "position_m"),
        ({"position_m": "here"}, "position_m"),
        ({"confidence": math.nan}, "confidence"),
        ({"confidence": 1.01}, "confidence"),
        ({"confidence": -0.01}, "confidence"),
        ({"label": ""}, "label"),
        ({"label": "   "}, "label"),
        ({"label": None}, "label"),
        ({"stamp_s": math.inf}, "stamp_s"),
    ],
)
def test_bad_update_input_raises_naming_the_field_and_changes_nothing(kwargs, field) -> None:
    memory = _random_memory(seed=2, steps=20)
    before = memory.snapshot()
    args = {"position_m": (0.0, 0.0, 0.0), "label": "chair", "confidence": 0.5, "stamp_s": 1.0} | kwargs
    with pytest.raises(InvalidInputError, match=field):
        memory.update(**args)
    assert memory.snapshot() == before


def test_unknown_node_and_bad_queries() -> None:
    memory = fresh()
    with pytest.raises(UnknownNodeError, match="42"):
        memory.node(42)
    with pytest.raises(KeyError):
        memory.mark_visited(node_id=42)
    with pytest.raises(InvalidInputError, match="radius_m"):
        memory.within_radius(position_m=(0.0, 0.0, 0.0), radius_m=-1.0)
    with pytest.raises(InvalidInputError, match="robot_position_m"):
        memory.observe_surroundings(robot_position_m=(math.nan, 0.0, 0.0))
    assert TopologicalMemory(CONFIG).nearest(position_m=(0.0, 0.0, 0.0)) is None


# --------------------------------------------------------------------------- properties

positions = st.tuples(
    st.floats(-4.0, 4.0, allow_nan=False), st.floats(-4.0, 4.0, allow_nan=False), st.floats(0.0, 1.5)
)
operations = st.lists(
    st.one_of(
        st.tuples(st.just("update"), positions, st.sampled_from(["a", "b", "c"]), st.floats(0.0, 1.0)),
        # "b" and "c" take over nodes labelled "a" (an object over a place).
        st.tuples(st.just("take"), positions, st.sampled_from(["b", "c"]), st.floats(0.0, 1.0)),
        st.tuples(st.just("observe"), positions),
        st.tuples(st.just("visit"), st.integers(0, 200)),
        st.tuples(st.just("scale"), st.integers(0, 200), st.floats(0.0, 1.0)),
        st.tuples(st.just("maintain")),
    ),
    max_size=120,
)


@settings(max_examples=60, deadline=None)
@given(ops=operations, every=st.integers(1, 12), cap=st.integers(4, 60))
def test_invariants_hold_after_any_sequence(ops, every, cap) -> None:
    config = MemoryConfig(
        delta_d=0.6, delta_r=1.2, merge_radius_m=0.9, maintenance_every=every, max_nodes=cap, cf_gate=0.2
    )
    memory = fresh(config, master_at=(0.0, 0.0, 0.0))
    for op in ops:
        if op[0] == "update":
            memory.update(position_m=op[1], label=op[2], confidence=op[3], stamp_s=1.0)
        elif op[0] == "take":
            memory.update(position_m=op[1], label=op[2], confidence=op[3], stamp_s=1.0, takes_over={"a"})
        elif op[0] == "observe":
            memory.observe_surroundings(robot_position_m=op[1])
        elif op[0] in ("visit", "scale") and op[1] in memory:
            if op[0] == "visit":
                memory.mark_visited(node_id=op[1])
            else:
                memory.scale_potential(node_id=op[1], factor=op[2])
        elif op[0] == "maintain":
            memory.maintain()
    # no two nodes within delta_d, connected, C and P in [0, 1], index consistent with the graph
    memory.check_invariants()
    assert len(memory) <= cap and memory.master_id in memory
    # Incremental maintenance finds exactly what a full scan would: nothing is left behind.
    memory.maintain()
    leftover = memory.maintain(full=True)
    assert leftover.pruned_node_ids == () and leftover.merged == ()


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), side=st.floats(2.0, 8.0), delta_d=st.floats(0.3, 1.0))
def test_node_count_obeys_the_packing_bound(seed, side, delta_d) -> None:
    # Pruning and the cap are switched off: only the delta_d gate limits growth.
    config = MemoryConfig(delta_d=delta_d, prune_potential=0.0, prune_confidence=0.0, max_nodes=10**6)
    memory = TopologicalMemory(config)
    rng = np.random.default_rng(seed)
    for t in range(1500):
        x, y = rng.uniform(0.0, side, size=2)
        memory.update(position_m=(x, y, 0.0), label="a", confidence=rng.uniform(0.5, 1.0), stamp_s=t)
    # Disjoint discs of radius delta_d / 2 around the nodes fit in the square grown by delta_d / 2.
    bound = (side + delta_d) ** 2 / (math.pi * (delta_d / 2.0) ** 2)
    assert 1 <= len(memory) <= bound
    points = np.array([s.position_m for s in memory.nodes()])
    assert np.all((points[:, :2] >= -1e-9) & (points[:, :2] <= side + 1e-9))  # merges stay in the hull


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    query=st.tuples(st.floats(-30, 30), st.floats(-30, 30), st.floats(-5, 5)),
    radius=st.floats(0.0, 6.0),
)
def test_queries_match_brute_force(seed, query, radius) -> None:
    memory = _random_memory(seed % 50, steps=120)  # > LINEAR_SCAN_MAX_NODES so the grid is exercised
    brute = sorted((math.dist(query, s.position_m), s.node_id) for s in memory.nodes())
    assert memory.nearest(position_m=query) == (brute[0][1], pytest.approx(brute[0][0]))
    assert memory.within_radius(position_m=query, radius_m=radius) == [n for d, n in brute if d <= radius]
    graph = memory.travel_costs(from_position_m=query, mode="graph")
    euclid = memory.travel_costs(from_position_m=query, mode="euclidean")
    assert all(graph[n] >= euclid[n] - 1e-9 for n in euclid)  # triangle inequality


non_finite = st.sampled_from([math.nan, math.inf, -math.inf])


@settings(max_examples=40, deadline=None)
@given(
    bad=non_finite,
    slot=st.integers(0, 3),
    base=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-5, 5), st.floats(0, 1)),
)
def test_non_finite_inputs_raise(bad, slot, base) -> None:
    memory = fresh()
    before = memory.snapshot()
    values = list(base)
    values[slot] = bad
    with pytest.raises(InvalidInputError, match="position_m" if slot < 3 else "confidence"):
        memory.update(position_m=tuple(values[:3]), label="a", confidence=values[3], stamp_s=0.0)
    assert memory.snapshot() == before


def test_graph_travel_costs_match_networkx_dijkstra() -> None:
    memory = _random_memory(seed=5, steps=400)
    robot = (0.4, -0.3, 0.1)
    entry, d_entry = memory.nearest(position_m=robot)
    reference = nx.single_source_dijkstra_path_length(memory.graph, entry, weight="cost")
    costs = memory.travel_costs(from_position_m=robot, mode="graph")
    assert costs.keys() == reference.keys()
    assert all(costs[n] == pytest.approx(d_entry + reference[n]) for n in reference)


def test_raise_potential_only_raises_and_checks_its_input() -> None:
    memory = TopologicalMemory()
    node = memory.update(position_m=(1.0, 0.0, 0.0), label="chair", confidence=0.8, stamp_s=0.0).node_id
    memory.scale_potential(node_id=node, factor=0.25)
    low = memory.node(node).potential
    assert memory.raise_potential(node_id=node, at_least=0.6)
    assert memory.node(node).potential == pytest.approx(0.6)
    assert not memory.raise_potential(node_id=node, at_least=low)
    assert memory.node(node).potential == pytest.approx(0.6)
    with pytest.raises(InvalidInputError):
        memory.raise_potential(node_id=node, at_least=1.5)
