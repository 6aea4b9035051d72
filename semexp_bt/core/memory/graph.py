"""The topological memory G = (V, E) itself: growth (Eq. 6), potentials (Eq. 7), maintenance and travel
costs (paper Sec. III-D).

:class:`TopologicalMemory` keeps the graph and its node attributes; every position query goes through
its spatial index (:mod:`semexp_bt.core.memory.spatial_index`), so an update costs time proportional to
the number of nodes near the observation, never to the size of the memory. Maintenance is incremental:
it examines only nodes touched since its last run, which finds exactly what a full scan would find (see
:meth:`TopologicalMemory.maintain`). The invariants the class keeps are listed in the package docstring
and checked by :meth:`TopologicalMemory.check_invariants`.

Snapshots (:meth:`TopologicalMemory.snapshot`, :meth:`TopologicalMemory.from_snapshot`) use the format of
:mod:`semexp_bt.core.memory.snapshot`. The graph is exposed as :attr:`TopologicalMemory.graph` for
reading (Dijkstra, drawing, export); mutate it only through this class, or the spatial index goes stale.
The class is not thread-safe.

This is a core module: it imports only the standard library, numpy and networkx.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from typing import Any, Literal

import networkx as nx
import numpy as np

from semexp_bt.core.config import MemoryConfig
from semexp_bt.core.memory.inputs import as_label, as_number, as_position, as_unit
from semexp_bt.core.memory.snapshot import read_snapshot, write_snapshot
from semexp_bt.core.memory.spatial_index import SpatialIndex, Vec3
from semexp_bt.core.types import InvalidInputError, NodeState

TravelMode = Literal["graph", "euclidean"]

#: Smallest grid cell (m); guards against a degenerate cell when delta_d and delta_r are tiny.
MIN_CELL_M = 0.05
#: The lazy eviction heap is rebuilt when it holds more than this many entries per live node.
EVICTION_HEAP_SLACK = 3


class UnknownNodeError(InvalidInputError, KeyError):
    """A node id that is not (or no longer) in the memory."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class MemoryInvariantError(RuntimeError):
    """Raised by :meth:`TopologicalMemory.check_invariants` when the memory is inconsistent (a bug)."""


@dataclass(frozen=True)
class MaintenanceReport:
    """What one maintenance pass did.

    Attributes:
        pruned_node_ids: nodes removed because potential < prune_potential and confidence <
            prune_confidence.
        merged: ``(removed_id, survivor_id)`` pairs of same-label neighbours merged, in order.
        edges_added: edges added to keep the graph connected after pruning.
        examined: how many nodes the pass examined (the nodes touched since the previous pass).
    """

    pruned_node_ids: tuple[int, ...] = ()
    merged: tuple[tuple[int, int], ...] = ()
    edges_added: int = 0
    examined: int = 0


@dataclass(frozen=True)
class MemoryUpdate:
    """The outcome of one :meth:`TopologicalMemory.update` (the gate of Eq. 6).

    Attributes:
        action: ``"inserted"`` (a new node), ``"merged"`` (folded into the nearest node) or
            ``"rejected"`` (far from every node but not confident enough for a new one).
        node_id: the node inserted or merged into (after any fusion it caused: the survivor); None when
            rejected. It is valid when ``update`` returns.
        distance_to_nearest: distance (m) from the observation to the nearest node before the update;
            ``inf`` when the memory was empty.
        reason: a one-line human-readable explanation with the numbers that decided.
        label_switched: a merge replaced the node's label with the observation's.
        fused_node_ids: nodes absorbed because a merge moved the node within delta_d of them.
        evicted_node_ids: nodes evicted to respect ``max_nodes``.
        edges_added: edges added for a new node.
        maintenance: the report of the periodic maintenance run at the start of this update, if any.
    """

    action: Literal["inserted", "merged", "rejected"]
    node_id: int | None
    distance_to_nearest: float
    reason: str
    label_switched: bool = False
    fused_node_ids: tuple[int, ...] = ()
    evicted_node_ids: tuple[int, ...] = ()
    edges_added: int = 0
    maintenance: MaintenanceReport | None = None


def _clamp_unit(value: float) -> float:
    return 0.0 if value < 0.0 else 1.0 if value > 1.0 else value


class TopologicalMemory:
    """The controlled-growth semantic topological memory G = (V, E) of paper Sec. III-D.

    Node attributes in :attr:`graph`: ``position`` (x, y, z in m), ``label``, ``confidence`` (C_f),
    ``potential`` (P_explore), ``visits``, ``is_master``, ``created_s``, ``updated_s``, ``observations``.
    Edge attribute: ``cost`` (Euclidean length, m).

    Args:
        config: the memory hyperparameters; defaults to :class:`MemoryConfig`.

    Example:
        >>> memory = TopologicalMemory(MemoryConfig())
        >>> memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
        0
        >>> memory.update(position_m=(3.0, 0.0, 0.5), label="chair", confidence=0.8, stamp_s=1.0).action
        'inserted'
    """

    def __init__(self, config: MemoryConfig | None = None) -> None:
        self.config = config if config is not None else MemoryConfig()
        self.graph: nx.Graph = nx.Graph()
        # The two hot queries have radius delta_d (the gate) and delta_r (the edges); a cell of at least
        # delta_r / 2 keeps the edge query to at most 5 cells per axis without crowding the gate query.
        self.cell_m = max(self.config.delta_d, self.config.delta_r / 2.0, MIN_CELL_M)
        self._index = SpatialIndex(self.cell_m)
        self._pos: Mapping[int, Vec3] = self._index.positions  # read-only: the index keeps it
        self._attrs: dict[int, dict[str, Any]] = {}
        self._next_id = 0
        self._master_id: int | None = None
        self._dirty: set[int] = set()
        self._updates_since_maintenance = 0
        self._evict_heap: list[tuple[float, float, int, int]] = []
        self._version: dict[int, int] = {}

    # ------------------------------------------------------------------ basic access

    def __len__(self) -> int:
        return self.graph.number_of_nodes()

    def __contains__(self, node_id: object) -> bool:
        return node_id in self._attrs

    @property
    def master_id(self) -> int | None:
        """Id of the master node v_m, or None before :meth:`add_master`."""
        return self._master_id

    def node(self, node_id: int) -> NodeState:
        """A read-only view of one node.

        Raises:
            UnknownNodeError: if ``node_id`` is not in the memory.
        """
        return self._state(self._require_node(node_id))

    def nodes(self, *, min_potential: float = 0.0) -> list[NodeState]:
        """All nodes whose potential is at least ``min_potential``, in increasing id order.

        Args:
            min_potential: lower bound on P_explore (inclusive), e.g. tau_p of Eq. 8.
        """
        threshold = as_number("min_potential", min_potential)
        attrs = self._attrs
        return [self._state(n) for n in sorted(attrs) if attrs[n]["potential"] >= threshold]

    def nearest(self, *, position_m: Any) -> tuple[int, float] | None:
        """The node nearest to a point and its distance (m); None when the memory is empty.

        Ties are broken by the lower node id.
        """
        found = self._index.k_nearest(as_position("position_m", position_m), 1)
        return (found[0][1], found[0][0]) if found else None

    def within_radius(self, *, position_m: Any, radius_m: float) -> list[int]:
        """Ids of the nodes within ``radius_m`` (inclusive) of a point, nearest first."""
        p = as_position("position_m", position_m)
        radius = as_number("radius_m", radius_m)
        if radius < 0.0:
            raise InvalidInputError(f"radius_m must be >= 0, got {radius_m!r}")
        return [n for _, n in self._index.within(p, radius)]

    # ------------------------------------------------------------------ growth (Eq. 6)

    def add_master(
        self,
        *,
        position_m: Any,
        stamp_s: float,
        label: str = "start",
        confidence: float = 0.0,
        potential: float = 0.0,
    ) -> int:
        """Add the master node v_m: the robot's initial viewpoint, never pruned, merged away or moved.

        Its potential defaults to 0 because the robot is standing there and has just looked around
        (panoramic init), so the decision must not send it back; its confidence defaults to 0 because a
        viewpoint is not semantic evidence (a confident observation that lands on it then takes over its
        label, see :meth:`update`).

        Args:
            position_m: the robot's position (x, y, z) in ``map``.
            stamp_s: the time of the panoramic init.
            label: the master's label.
            confidence: its initial C_f, in [0, 1].
            potential: its initial P_explore, in [0, 1].

        Returns:
            The master's node id.

        Raises:
            InvalidInputError: on bad input, or if a master already exists.
        """
        p = as_position("position_m", position_m)
        stamp = as_number("stamp_s", stamp_s)
        name = as_label("label", label)
        conf = as_unit("confidence", confidence)
        pot = as_unit("potential", potential)
        if self._master_id is not None:
            raise InvalidInputError(f"the memory already has a master node (id {self._master_id})")
        if self._index.within(p, self.config.delta_d):
            raise InvalidInputError(
                f"position_m {p} lies within delta_d={self.config.delta_d} m of an existing node; "
                "add the master before any observation"
            )
        node_id = self._add_node(p, label=name, confidence=conf, potential=pot, stamp=stamp, is_master=True)
        self._master_id = node_id
        self._connect_new(node_id)
        return node_id

    def update(
        self,
        *,
        position_m: Any,
        label: str,
        confidence: float,
        stamp_s: float,
        takes_over: AbstractSet[str] = frozenset(),
    ) -> MemoryUpdate:
        """Fold one arbitrated target (P_vc of Eq. 5, L_t, C_f) into the memory (Eq. 6).

        * nearest node within delta_d (inclusive): merge. Confidence follows the EMA
          ``C <- (1 - rho) C + rho C_f``. When C_f beats the node's confidence before the EMA, the
          potential is raised to at least C_f (stronger evidence is worth a visit, whatever it is
          called) and the label switches to the observation's. The position moves towards the
          observation by the fraction ``rho * C_f`` (the master never moves), and if that brings it
          within delta_d of another node the two fuse.
        * a merge into a node labelled with one of ``takes_over`` (places: an unexplored direction, a
          frontier) hands the node to the observation whatever the confidences: its label, C = C_f and
          P = max(P, C_f); the position steps as in any merge (a place stands where the robot can). A place
          says where to look; an object seen there is what is there.
        * no node within delta_d and C_f > cf_gate: insert a node with P_explore = C_f, linked to every
          node within delta_r or, if none, to the k nearest.
        * no node within delta_d and C_f <= cf_gate: reject (reported, memory unchanged).

        Every ``maintenance_every`` updates, :meth:`maintain` runs first (so ``node_id`` of the returned
        report is valid when this returns). An insertion beyond ``max_nodes`` evicts the lowest-value
        node other than the master and the one just inserted.

        Args:
            position_m: the candidate position P_vc (x, y, z) in ``map``.
            label: its semantic label L_t.
            confidence: its fused confidence C_f, in [0, 1].
            stamp_s: observation time.
            takes_over: labels of nodes this observation takes over on a merge (see above).

        Raises:
            InvalidInputError: naming the field, on a non-finite position, stamp or confidence, a
                confidence outside [0, 1], or an empty label. The memory is unchanged.
        """
        p = as_position("position_m", position_m)
        name = as_label("label", label)
        c_f = as_unit("confidence", confidence)
        stamp = as_number("stamp_s", stamp_s)
        cfg = self.config

        maintenance = None
        if self._updates_since_maintenance >= cfg.maintenance_every:
            maintenance = self.maintain()
        self._updates_since_maintenance += 1

        close = self._index.within(p, cfg.delta_d)
        if close:
            d_nn, target = close[0]
            return self._merge_observation(target, p, name, c_f, stamp, d_nn, maintenance, takes_over)
        # Most updates merge, so the wider edge query runs only when the gate did not merge.
        close = self._index.within(p, cfg.delta_r) if cfg.delta_r > cfg.delta_d else []

        if c_f <= cfg.cf_gate:
            nn = close[0] if close else (self._index.k_nearest(p, 1) or [(math.inf, -1)])[0]
            return MemoryUpdate(
                action="rejected",
                node_id=None,
                distance_to_nearest=nn[0],
                reason=(
                    f"nearest node {nn[0]:.3f} m > delta_d={cfg.delta_d} but C_f={c_f:.3f} <= "
                    f"cf_gate={cfg.cf_gate}"
                ),
                maintenance=maintenance,
            )

        d_nn = close[0][0] if close else math.inf
        node_id = self._add_node(p, label=name, confidence=c_f, potential=c_f, stamp=stamp, is_master=False)
        within_r = [n for _, n in close]
        if not within_r:
            knn = self._index.k_nearest(p, cfg.k_nearest + 1)
            within_r = [n for _, n in knn if n != node_id][: cfg.k_nearest]
            if within_r:
                d_nn = min(math.dist(p, self._pos[n]) for n in within_r)
        for n in within_r:
            self._add_edge(node_id, n)
        evicted = self._enforce_capacity(protect=node_id)
        return MemoryUpdate(
            action="inserted",
            node_id=node_id,
            distance_to_nearest=d_nn,
            reason=(
                f"nearest node {d_nn:.3f} m > delta_d={cfg.delta_d} and C_f={c_f:.3f} > cf_gate={cfg.cf_gate}"
            ),
            evicted_node_ids=tuple(evicted),
            edges_added=len(within_r),
            maintenance=maintenance,
        )

    # ------------------------------------------------------------------ potential (Eq. 7)

    def observe_surroundings(self, *, robot_position_m: Any, radius_m: float | None = None) -> list[int]:
        """Decay the potential of every node the robot now sees around it (Eq. 7).

        ``P <- (1 - xi) P`` for each node within ``radius_m`` (default ``observe_radius_m``) of the robot.

        Returns:
            The ids of the decayed nodes, in increasing order.
        """
        p = as_position("robot_position_m", robot_position_m)
        radius = self.config.observe_radius_m if radius_m is None else as_number("radius_m", radius_m)
        if radius < 0.0:
            raise InvalidInputError(f"radius_m must be >= 0, got {radius_m!r}")
        decayed = sorted(n for _, n in self._index.within(p, radius))
        for n in decayed:
            self._decay(n)
        return decayed

    def mark_visited(self, *, node_id: int) -> None:
        """Record that the robot reached a node: ``visits += 1`` and one Eq. 7 decay of its potential."""
        n = self._require_node(node_id)
        self._attrs[n]["visits"] += 1
        self._decay(n)

    def scale_potential(self, *, node_id: int, factor: float) -> None:
        """Multiply a node's potential by ``factor`` in [0, 1] (recovery lowers an unreachable subgoal)."""
        n = self._require_node(node_id)
        f = as_unit("factor", factor)
        attrs = self._attrs[n]
        attrs["potential"] = _clamp_unit(attrs["potential"] * f)
        self._touch(n)

    def raise_potential(self, *, node_id: int, at_least: float) -> bool:
        """Raise a node's potential to ``at_least`` in [0, 1] if it is lower (new evidence revives a node
        that decay or recovery had spent). Returns whether the potential changed."""
        n = self._require_node(node_id)
        floor = as_unit("at_least", at_least)
        attrs = self._attrs[n]
        if attrs["potential"] >= floor:
            return False
        attrs["potential"] = floor
        self._touch(n)
        return True

    # ------------------------------------------------------------------ maintenance

    def maintain(self, *, full: bool = False) -> MaintenanceReport:
        """Prune spent, unreliable nodes and merge same-label neighbours.

        A node other than the master is pruned when ``potential < prune_potential`` and
        ``confidence < prune_confidence``; its former neighbours are reconnected by a Euclidean minimum
        spanning tree over them, so the graph stays connected. Two edge-connected nodes with the same label
        closer than ``merge_radius_m`` are merged (see ``docs/memory.md`` for which survives and how the
        attributes combine).

        Only nodes touched since the previous pass are examined (plus those the pass itself touches). A node
        can become prunable or mergeable only when its own attributes, position or edges change, and every
        such change marks it, so this finds exactly what a full scan would.

        Args:
            full: examine every node instead (after external surgery, or to cross-check).
        """
        self._updates_since_maintenance = 0
        cfg = self.config
        if full:
            self._dirty.update(self._attrs)
        pruned: list[int] = []
        merged: list[tuple[int, int]] = []
        edges_added = 0
        examined = 0
        while self._dirty:
            batch = sorted(self._dirty)
            self._dirty.clear()
            for n in batch:
                if n not in self._attrs:
                    continue
                examined += 1
                attrs = self._attrs[n]
                if (
                    not attrs["is_master"]
                    and attrs["potential"] < cfg.prune_potential
                    and attrs["confidence"] < cfg.prune_confidence
                ):
                    edges_added += self._remove_and_reconnect(n)
                    pruned.append(n)
                    continue
                current = n
                while True:
                    partner = self._merge_partner(current)
                    if partner is None:
                        break
                    survivor, removed = self._fuse(current, partner)
                    merged.append((removed, survivor))
                    if survivor != current:
                        break  # the survivor was marked dirty and is examined in a later batch
        return MaintenanceReport(
            pruned_node_ids=tuple(pruned), merged=tuple(merged), edges_added=edges_added, examined=examined
        )

    # ------------------------------------------------------------------ travel cost (Eq. 9's d)

    def travel_costs(self, *, from_position_m: Any, mode: TravelMode = "graph") -> dict[int, float]:
        """Travel cost d(P_robot, P_v) from a point to every node (Eq. 9).

        Args:
            from_position_m: the robot position (x, y, z).
            mode: ``"graph"``: straight line to the nearest node (the entry), then the shortest path on
                edge costs (single-source Dijkstra); nodes the entry cannot reach get ``inf``.
                ``"euclidean"``: straight-line distance.

        Returns:
            node id -> cost in metres; empty when the memory is empty.
        """
        p = as_position("from_position_m", from_position_m)
        if mode not in ("graph", "euclidean"):
            raise InvalidInputError(f"mode must be 'graph' or 'euclidean', got {mode!r}")
        if not self._attrs:
            return {}
        if mode == "euclidean":
            ids, dist = self._index.distances(p)
            return dict(zip(ids.tolist(), dist.tolist(), strict=True))
        d_entry, entry = self._index.k_nearest(p, 1)[0]
        lengths = self._dijkstra(entry)
        return {n: d_entry + lengths[n] if n in lengths else math.inf for n in self._attrs}

    # ------------------------------------------------------------------ persistence

    def snapshot(self) -> dict[str, Any]:
        """A JSON-serialisable dictionary of the whole memory state (nodes, edges, bookkeeping); see
        :mod:`semexp_bt.core.memory.snapshot` for the format."""
        return write_snapshot(
            attrs=self._attrs,
            graph=self.graph,
            next_id=self._next_id,
            master_id=self._master_id,
            updates_since_maintenance=self._updates_since_maintenance,
            pending_maintenance=self._dirty,
        )

    @classmethod
    def from_snapshot(cls, data: Any, config: MemoryConfig | None = None) -> TopologicalMemory:
        """Rebuild a memory from :meth:`snapshot` output.

        Nodes and edges are restored as they are; the gates of ``config`` apply to later updates only.

        Raises:
            InvalidInputError: naming the key, on a malformed snapshot (wrong format or version, missing
                key, non-finite or out-of-range value, duplicate id, edge to an unknown node).
        """
        contents = read_snapshot(data)
        memory = cls(config)
        for record in contents.nodes:
            memory._insert_node_record(record.node_id, record.position, dict(record.fields))
        memory._master_id = contents.master_id
        for u, v, cost in contents.edges:
            memory.graph.add_edge(u, v, cost=cost)
        memory._next_id = contents.next_id
        memory._updates_since_maintenance = contents.updates_since_maintenance
        memory._dirty = contents.pending_maintenance
        return memory

    # ------------------------------------------------------------------ diagnostics

    def check_invariants(self, *, require_connected: bool = True) -> None:
        """Verify the memory's invariants (used by tests; cost O(N * neighbourhood)).

        Raises:
            MemoryInvariantError: describing the first violation found.
        """
        cfg = self.config
        attrs = self._attrs
        if set(attrs) != set(self.graph.nodes) or set(attrs) != set(self._pos):
            raise MemoryInvariantError("node bookkeeping differs from the graph")
        index_problem = self._index.consistency_problem()
        if index_problem is not None:
            raise MemoryInvariantError(index_problem)
        for n, a in attrs.items():
            p = a["position"]
            if p != self._pos[n]:
                raise MemoryInvariantError(f"node {n}: indexed position differs from its attribute")
            if not all(math.isfinite(x) for x in p):
                raise MemoryInvariantError(f"node {n}: non-finite position {p}")
            for key in ("confidence", "potential"):
                if not 0.0 <= a[key] <= 1.0:
                    raise MemoryInvariantError(f"node {n}: {key}={a[key]} outside [0, 1]")
            close = [m for _, m in self._index.within(p, cfg.delta_d) if m != n]
            if close:
                raise MemoryInvariantError(f"nodes {n} and {close[0]} are within delta_d={cfg.delta_d}")
            if a["is_master"] != (n == self._master_id):
                raise MemoryInvariantError(f"node {n}: is_master disagrees with master_id")
        for u, v, cost in self.graph.edges(data="cost"):
            if not math.isclose(cost, math.dist(self._pos[u], self._pos[v]), rel_tol=1e-9, abs_tol=1e-9):
                raise MemoryInvariantError(f"edge ({u}, {v}): cost {cost} is not its Euclidean length")
        if require_connected and attrs and not nx.is_connected(self.graph):
            raise MemoryInvariantError("the graph is not connected")

    # ------------------------------------------------------------------ internals

    def _require_node(self, node_id: Any) -> int:
        if isinstance(node_id, bool) or not isinstance(node_id, (int, np.integer)):
            raise InvalidInputError(f"node_id must be an integer, got {node_id!r}")
        n = int(node_id)
        if n not in self._attrs:
            raise UnknownNodeError(f"node_id {n} is not in the memory")
        return n

    def _state(self, n: int) -> NodeState:
        a = self._attrs[n]
        return NodeState(
            node_id=n,
            position_m=a["position"],
            label=a["label"],
            confidence=a["confidence"],
            potential=a["potential"],
            visits=a["visits"],
            is_master=a["is_master"],
        )

    def _add_node(
        self, p: Vec3, *, label: str, confidence: float, potential: float, stamp: float, is_master: bool
    ) -> int:
        node_id = self._next_id
        self._next_id += 1
        self._insert_node_record(
            node_id,
            p,
            {
                "label": label,
                "confidence": confidence,
                "potential": potential,
                "visits": 0,
                "is_master": is_master,
                "created_s": stamp,
                "updated_s": stamp,
                "observations": 1,
            },
        )
        return node_id

    def _insert_node_record(self, node_id: int, p: Vec3, fields: dict[str, Any]) -> None:
        self.graph.add_node(node_id, position=p, **fields)
        self._attrs[node_id] = self.graph.nodes[node_id]
        self._index.insert(node_id, p)
        self._version[node_id] = 0
        self._touch(node_id)

    def _connect_new(self, node_id: int) -> int:
        """Link a node to every node within delta_r, or to its k nearest if none (Sec. III-D)."""
        p = self._pos[node_id]
        targets = [n for _, n in self._index.within(p, self.config.delta_r) if n != node_id]
        if not targets:
            knn = self._index.k_nearest(p, self.config.k_nearest + 1)
            targets = [n for _, n in knn if n != node_id][: self.config.k_nearest]
        for n in targets:
            self._add_edge(node_id, n)
        return len(targets)

    def _add_edge(self, u: int, v: int) -> bool:
        if u == v or self.graph.has_edge(u, v):
            return False
        self.graph.add_edge(u, v, cost=math.dist(self._pos[u], self._pos[v]))
        return True

    def _remove_node(self, n: int) -> None:
        self._index.remove(n)
        self.graph.remove_node(n)
        del self._attrs[n]
        del self._version[n]
        self._dirty.discard(n)

    def _remove_and_reconnect(self, n: int) -> int:
        """Remove a node and join its former neighbours by a Euclidean MST; return the edges added.

        Any path through the removed node entered and left it through two of its neighbours, which the
        tree still joins, so connectivity is preserved with at most deg - 1 new edges.
        """
        neighbours = sorted(self.graph.neighbors(n))
        self._remove_node(n)
        added = 0
        if len(neighbours) >= 2:
            pts = np.array([self._pos[m] for m in neighbours])
            dist = np.sqrt(((pts[:, None, :] - pts[None, :, :]) ** 2).sum(axis=2))
            in_tree = np.zeros(len(neighbours), dtype=bool)
            in_tree[0] = True
            best = dist[0].copy()
            parent = np.zeros(len(neighbours), dtype=np.int64)
            for _ in range(len(neighbours) - 1):
                masked = np.where(in_tree, np.inf, best)
                j = int(np.argmin(masked))
                in_tree[j] = True
                added += self._add_edge(neighbours[int(parent[j])], neighbours[j])
                closer = dist[j] < best
                best = np.where(closer, dist[j], best)
                parent = np.where(closer, j, parent)
        for m in neighbours:
            self._touch(m)
        return added

    def _merge_partner(self, n: int) -> int | None:
        """The nearest edge-connected neighbour with the same label closer than merge_radius_m."""
        a = self._attrs[n]
        p = self._pos[n]
        best: tuple[float, int] | None = None
        for m in self.graph.neighbors(n):
            if self._attrs[m]["label"] != a["label"]:
                continue
            d = math.dist(p, self._pos[m])
            if d < self.config.merge_radius_m and (best is None or (d, m) < best):
                best = (d, m)
        return None if best is None else best[1]

    def _fuse(self, a: int, b: int) -> tuple[int, int]:
        """Merge two nodes into one; return ``(survivor, removed)``.

        The survivor is the master if either is; otherwise the more confident (ties: the lower id). It
        keeps its position, so the fusion cannot bring it within delta_d of a third node. It takes the
        label and confidence of the more confident of the two, the larger potential, the summed visits
        and observations, and the removed node's edges.
        """
        attrs_a, attrs_b = self._attrs[a], self._attrs[b]

        def rank(n: int, at: dict[str, Any]) -> tuple[bool, float, int]:
            return (at["is_master"], at["confidence"], -n)

        survivor, removed = (a, b) if rank(a, attrs_a) >= rank(b, attrs_b) else (b, a)
        s, r = self._attrs[survivor], self._attrs[removed]
        if r["confidence"] > s["confidence"]:  # only when the survivor is the master
            s["label"] = r["label"]
            s["confidence"] = r["confidence"]
        s["potential"] = max(s["potential"], r["potential"])
        s["visits"] += r["visits"]
        s["observations"] += r["observations"]
        s["created_s"] = min(s["created_s"], r["created_s"])
        s["updated_s"] = max(s["updated_s"], r["updated_s"])
        neighbours = [m for m in self.graph.neighbors(removed) if m != survivor]
        self._remove_node(removed)
        for m in neighbours:
            self._add_edge(survivor, m)
        self._touch(survivor)
        return survivor, removed

    def _merge_observation(
        self,
        n: int,
        p: Vec3,
        label: str,
        c_f: float,
        stamp: float,
        d_nn: float,
        maintenance: MaintenanceReport | None,
        takes_over: AbstractSet[str] = frozenset(),
    ) -> MemoryUpdate:
        cfg = self.config
        a = self._attrs[n]
        old_c = a["confidence"]
        taken_over = label != a["label"] and a["label"] in takes_over and not a["is_master"]
        more_confident = c_f > old_c or taken_over
        switched = more_confident and label != a["label"]
        if switched:
            a["label"] = label
        old_potential = a["potential"]
        if more_confident:
            # Compared by evidence, not by name: whether the VLM's word for the object equals the
            # instruction's must not decide whether the node is worth a visit (docs/memory.md).
            a["potential"] = max(old_potential, c_f)
        # A node taken over starts as the object's hypothesis: the place's confidence was about another.
        a["confidence"] = c_f if taken_over else _clamp_unit((1.0 - cfg.rho) * old_c + cfg.rho * c_f)
        a["observations"] += 1
        a["updated_s"] = stamp
        fused: list[int] = []
        survivor = n
        held_still = False
        step = cfg.rho * c_f
        if not a["is_master"] and step > 0.0:
            old_p = self._pos[n]
            new_p = (
                old_p[0] + step * (p[0] - old_p[0]),
                old_p[1] + step * (p[1] - old_p[1]),
                old_p[2] + step * (p[2] - old_p[2]),
            )
            crowding = [m for _, m in self._index.within(new_p, cfg.delta_d) if m != n]
            if any(self._attrs[m]["label"] != a["label"] for m in crowding):
                # Moving would crowd a different hypothesis; fusing would lose one label, so stay put.
                held_still = True
            else:
                self._move(n, new_p)
                for m in crowding:
                    survivor, removed = self._fuse(survivor, m)
                    fused.append(removed)
                    if survivor == m:
                        break  # m kept its old position, which was clear of every other node
        self._touch(survivor)
        reason = (
            f"nearest node {n} at {d_nn:.3f} m <= delta_d={cfg.delta_d}: C {old_c:.3f} -> "
            f"{a['confidence']:.3f} (rho={cfg.rho}, C_f={c_f:.3f})"
        )
        if taken_over:
            reason += f"; a place taken over by {label!r}"
        elif switched:
            reason += f"; label -> {label!r}"
        if a["potential"] > old_potential:
            reason += f"; potential {old_potential:.3f} -> {a['potential']:.3f}"
        if fused:
            reason += f"; moved onto and fused with {fused}"
        if held_still:
            reason += "; position kept (moving would crowd a node with another label)"
        return MemoryUpdate(
            action="merged",
            node_id=survivor,
            distance_to_nearest=d_nn,
            reason=reason,
            label_switched=switched,
            fused_node_ids=tuple(fused),
            maintenance=maintenance,
        )

    def _move(self, n: int, new_p: Vec3) -> None:
        self._index.move(n, new_p)
        self._attrs[n]["position"] = new_p
        for m, edge in self.graph.adj[n].items():
            edge["cost"] = math.dist(new_p, self._pos[m])

    def _decay(self, n: int) -> None:
        attrs = self._attrs[n]
        attrs["potential"] = _clamp_unit((1.0 - self.config.xi) * attrs["potential"])
        self._touch(n)

    def _touch(self, n: int) -> None:
        """Mark a node for the next maintenance pass and refresh its eviction-heap entry."""
        self._dirty.add(n)
        attrs = self._attrs[n]
        if attrs["is_master"]:
            return
        version = self._version[n] + 1
        self._version[n] = version
        value = max(attrs["potential"], attrs["confidence"])
        heapq.heappush(self._evict_heap, (value, attrs["updated_s"], n, version))
        if len(self._evict_heap) > EVICTION_HEAP_SLACK * len(self._attrs) + 64:
            self._evict_heap = [
                (max(at["potential"], at["confidence"]), at["updated_s"], m, self._version[m])
                for m, at in self._attrs.items()
                if not at["is_master"]
            ]
            heapq.heapify(self._evict_heap)

    def _enforce_capacity(self, *, protect: int) -> list[int]:
        """Evict lowest-value nodes (value = max(potential, confidence); ties: least recently updated)."""
        evicted: list[int] = []
        held: list[tuple[float, float, int, int]] = []
        while len(self._attrs) > self.config.max_nodes and self._evict_heap:
            entry = heapq.heappop(self._evict_heap)
            _, _, n, version = entry
            if n not in self._attrs or self._version[n] != version:
                continue  # stale
            if n == protect:
                held.append(entry)
                continue
            self._remove_and_reconnect(n)
            evicted.append(n)
        for entry in held:
            heapq.heappush(self._evict_heap, entry)
        return evicted

    def _dijkstra(self, source: int) -> dict[int, float]:
        """Shortest-path cost from ``source`` to every reachable node, on edge ``cost``.

        Same result as ``networkx.single_source_dijkstra_path_length(graph, source, weight="cost")``
        (checked by the tests) at about half the time: it walks networkx's adjacency dict (``Graph._adj``,
        the storage networkx documents for subclasses) instead of going through views and a weight
        callback, which dominates at 10k nodes.
        """
        adjacency = self.graph._adj
        dist: dict[int, float] = {source: 0.0}
        settled: set[int] = set()
        heap = [(0.0, source)]
        pop, push, inf = heapq.heappop, heapq.heappush, math.inf
        while heap:
            d, u = pop(heap)
            if u in settled:
                continue
            settled.add(u)
            for v, edge in adjacency[u].items():
                candidate = d + edge["cost"]
                if candidate < dist.get(v, inf):
                    dist[v] = candidate
                    push(heap, (candidate, v))
        return dist
