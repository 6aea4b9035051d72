"""Controlled-growth semantic topological memory (paper Sec. III-D, Eq. 5-7).

The memory is a :class:`networkx.Graph` whose nodes are revisitable 3D locations in ``map`` carrying a
semantic label, a fused confidence C_f and an exploration potential P_explore; edges carry a traversal
``cost`` (Euclidean distance, metres). Growth is controlled by the gate of Eq. 6: an observation becomes
a new node only if it lies farther than ``delta_d`` from every node *and* its fused confidence exceeds
``cf_gate``; otherwise it is merged into its nearest node (confidence EMA with factor ``rho``) or, when it
is far from every node but not confident enough, rejected. Potentials decay by Eq. 7 when a node is
visited or its surroundings are observed, and a periodic maintenance pass prunes nodes that are both
spent (low potential) and unreliable (low confidence) and merges edge-connected neighbours with the same
label.

Every rule the paper leaves open is decided and justified in ``docs/memory.md``. The invariants the
memory keeps (checked by :meth:`TopologicalMemory.check_invariants`):

* no two nodes are within ``delta_d`` of each other, which bounds the node count by a packing argument;
* the graph stays connected (insertion always links the new node; removals reconnect the neighbours);
* confidences and potentials stay in [0, 1]; nothing non-finite ever enters the graph.

The modules:

* :mod:`.graph`: :class:`TopologicalMemory`, the graph itself (Eq. 6-7, maintenance, travel costs) and
  what its operations report;
* :mod:`.spatial_index`: node positions in a uniform-grid spatial hash and a contiguous array, queried by
  radius and by k nearest;
* :mod:`.snapshot`: the snapshot format, written and checked on reading;
* :mod:`.inputs`: the checks of what callers and snapshots hand the memory.

Callers import from this package (``from semexp_bt.core.memory import TopologicalMemory``).

This is a core package: it imports only the standard library, numpy and networkx.
"""

from semexp_bt.core.memory.graph import (
    MaintenanceReport,
    MemoryInvariantError,
    MemoryUpdate,
    TopologicalMemory,
    TravelMode,
    UnknownNodeError,
)
from semexp_bt.core.memory.snapshot import SNAPSHOT_FORMAT, SNAPSHOT_VERSION

__all__ = [
    "SNAPSHOT_FORMAT",
    "SNAPSHOT_VERSION",
    "MaintenanceReport",
    "MemoryInvariantError",
    "MemoryUpdate",
    "TopologicalMemory",
    "TravelMode",
    "UnknownNodeError",
]
