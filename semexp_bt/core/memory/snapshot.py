"""The memory's snapshot: one JSON-serialisable dictionary of the whole state, written and read back.

The format (``SNAPSHOT_FORMAT``, version ``SNAPSHOT_VERSION``)::

    {"format": "semexp_bt.core.memory", "version": 1, "next_id": 3, "master_id": 0,
     "updates_since_maintenance": 2, "pending_maintenance": [2],
     "nodes": [{"id": 0, "position": [x, y, z], "label": "start", "confidence": 0.0, "potential": 0.0,
                "visits": 0, "is_master": true, "created_s": 0.0, "updated_s": 0.0, "observations": 1}, ...],
     "edges": [[u, v, cost], ...]}

:func:`read_snapshot` checks every key and value and returns the contents in the memory's own types;
``TopologicalMemory.from_snapshot`` builds the memory from them. Episode records carry a snapshot of the
final memory.

This is a core module: standard library and networkx only.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import networkx as nx

from semexp_bt.core.memory.inputs import as_count, as_label, as_number, as_position, as_unit
from semexp_bt.core.memory.spatial_index import Vec3
from semexp_bt.core.types import InvalidInputError

#: Version of the dictionary written by :func:`write_snapshot`.
SNAPSHOT_VERSION = 1
#: Tag that identifies a memory snapshot.
SNAPSHOT_FORMAT = "semexp_bt.core.memory"
#: The attributes of every node, besides its id.
NODE_KEYS = (
    "position",
    "label",
    "confidence",
    "potential",
    "visits",
    "is_master",
    "created_s",
    "updated_s",
    "observations",
)


def write_snapshot(
    *,
    attrs: Mapping[int, Mapping[str, Any]],
    graph: nx.Graph,
    next_id: int,
    master_id: int | None,
    updates_since_maintenance: int,
    pending_maintenance: Iterable[int],
) -> dict[str, Any]:
    """The snapshot dictionary of a memory's state (nodes by id, edges sorted)."""
    nodes = []
    for n in sorted(attrs):
        a = attrs[n]
        nodes.append(
            {
                "id": n,
                "position": list(a["position"]),
                "label": a["label"],
                "confidence": a["confidence"],
                "potential": a["potential"],
                "visits": a["visits"],
                "is_master": a["is_master"],
                "created_s": a["created_s"],
                "updated_s": a["updated_s"],
                "observations": a["observations"],
            }
        )
    edges = sorted([min(u, v), max(u, v), c] for u, v, c in graph.edges(data="cost"))
    return {
        "format": SNAPSHOT_FORMAT,
        "version": SNAPSHOT_VERSION,
        "next_id": next_id,
        "master_id": master_id,
        "updates_since_maintenance": updates_since_maintenance,
        "pending_maintenance": sorted(pending_maintenance),
        "nodes": nodes,
        "edges": edges,
    }


class NodeRecord(NamedTuple):
    """One node of a snapshot, checked: its id, position and the other attributes."""

    node_id: int
    position: Vec3
    fields: dict[str, Any]


class SnapshotContents(NamedTuple):
    """A checked snapshot, in the memory's own types.

    Attributes:
        nodes: the nodes, in the snapshot's order.
        master_id: the master node's id, or None.
        edges: ``(u, v, cost)`` in the snapshot's order.
        next_id: the id the next new node gets.
        updates_since_maintenance: updates since the last maintenance pass.
        pending_maintenance: the nodes the next maintenance pass examines (every node when the snapshot
            does not say).
    """

    nodes: list[NodeRecord]
    master_id: int | None
    edges: list[tuple[int, int, float]]
    next_id: int
    updates_since_maintenance: int
    pending_maintenance: set[int]


def read_snapshot(data: Any) -> SnapshotContents:
    """Check a snapshot dictionary (:func:`write_snapshot`'s output) and return its contents.

    Raises:
        InvalidInputError: naming the key, on a malformed snapshot (wrong format or version, missing
            key, non-finite or out-of-range value, duplicate id, edge to an unknown node).
    """
    _check_header(data)
    nodes = _read_nodes(data["nodes"])
    ids = {record.node_id for record in nodes}
    masters = [record.node_id for record in nodes if record.fields["is_master"]]
    master_id = data["master_id"]
    if masters != ([] if master_id is None else [master_id]):
        raise InvalidInputError(
            f"snapshot.master_id ({master_id!r}) does not match the nodes flagged is_master ({masters})"
        )
    edges = _read_edges(data["edges"], ids)
    next_id = as_count("snapshot.next_id", data["next_id"])
    if ids and next_id <= max(ids):
        raise InvalidInputError(f"snapshot.next_id ({next_id}) must exceed every node id")
    updates = as_count("snapshot.updates_since_maintenance", data.get("updates_since_maintenance", 0))
    pending = data.get("pending_maintenance")
    if pending is None:
        pending_ids = set(ids)
    else:
        if not isinstance(pending, list):
            raise InvalidInputError("snapshot.pending_maintenance must be a list of node ids")
        pending_ids = {as_count(f"snapshot.pending_maintenance[{i}]", n) for i, n in enumerate(pending)} & ids
    return SnapshotContents(nodes, master_id, edges, next_id, updates, pending_ids)


def _check_header(data: Any) -> None:
    if not isinstance(data, dict):
        raise InvalidInputError(f"snapshot must be a mapping, got {type(data).__name__}")
    for key in ("format", "version", "next_id", "master_id", "nodes", "edges"):
        if key not in data:
            raise InvalidInputError(f"snapshot: missing key '{key}'")
    if data["format"] != SNAPSHOT_FORMAT:
        raise InvalidInputError(f"snapshot.format must be {SNAPSHOT_FORMAT!r}, got {data['format']!r}")
    if data["version"] != SNAPSHOT_VERSION:
        raise InvalidInputError(f"snapshot.version must be {SNAPSHOT_VERSION}, got {data['version']!r}")
    if not isinstance(data["nodes"], list) or not isinstance(data["edges"], list):
        raise InvalidInputError("snapshot.nodes and snapshot.edges must be lists")


def _read_nodes(raw_nodes: list[Any]) -> list[NodeRecord]:
    nodes: list[NodeRecord] = []
    seen: set[int] = set()
    for i, raw in enumerate(raw_nodes):
        where = f"snapshot.nodes[{i}]"
        if not isinstance(raw, dict):
            raise InvalidInputError(f"{where} must be a mapping")
        missing = [k for k in ("id", *NODE_KEYS) if k not in raw]
        if missing:
            raise InvalidInputError(f"{where}: missing key(s) {missing}")
        node_id = as_count(f"{where}.id", raw["id"])
        if node_id in seen:
            raise InvalidInputError(f"{where}.id: duplicate node id {node_id}")
        if not isinstance(raw["is_master"], bool):
            raise InvalidInputError(f"{where}.is_master must be a boolean, got {raw['is_master']!r}")
        position = as_position(f"{where}.position", raw["position"])
        fields = {
            "label": as_label(f"{where}.label", raw["label"]),
            "confidence": as_unit(f"{where}.confidence", raw["confidence"]),
            "potential": as_unit(f"{where}.potential", raw["potential"]),
            "visits": as_count(f"{where}.visits", raw["visits"]),
            "is_master": raw["is_master"],
            "created_s": as_number(f"{where}.created_s", raw["created_s"]),
            "updated_s": as_number(f"{where}.updated_s", raw["updated_s"]),
            "observations": as_count(f"{where}.observations", raw["observations"]),
        }
        seen.add(node_id)
        nodes.append(NodeRecord(node_id, position, fields))
    return nodes


def _read_edges(raw_edges: list[Any], ids: set[int]) -> list[tuple[int, int, float]]:
    edges: list[tuple[int, int, float]] = []
    for i, raw in enumerate(raw_edges):
        where = f"snapshot.edges[{i}]"
        if not isinstance(raw, (list, tuple)) or len(raw) != 3:
            raise InvalidInputError(f"{where} must be [u, v, cost]")
        u, v = as_count(f"{where}[0]", raw[0]), as_count(f"{where}[1]", raw[1])
        if u not in ids or v not in ids or u == v:
            raise InvalidInputError(f"{where}: edge ({u}, {v}) must join two distinct known nodes")
        cost = as_number(f"{where}[2]", raw[2])
        if cost < 0.0:
            raise InvalidInputError(f"{where}[2]: cost must be >= 0, got {cost}")
        edges.append((u, v, cost))
    return edges
