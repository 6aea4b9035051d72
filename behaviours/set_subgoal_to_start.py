"""SetSubgoalToStart: make the master node (where the mission started) the subgoal.

Semantics (it never returns RUNNING and holds no state, so halting it changes nothing):

- SUCCESS: after writing a ``subgoal`` at the master node v_m (utility 1).
- FAILURE: when the memory has no master node; nothing is written.

Reads ``memory``; writes ``subgoal``. Used by "search, then return to the start".

Example:
    - type: SetSubgoalToStart
      name: GoHome
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from semexp_bt.core.types import Subgoal


class SetSubgoalToStart(SemExpBehaviour):
    READS = ("memory",)
    WRITES = ("subgoal",)

    def update(self) -> py_trees.common.Status:
        memory = self.read("memory")
        masters = [n for n in memory.nodes() if n.is_master]
        if not masters:
            self.feedback_message = "no master node"
            return py_trees.common.Status.FAILURE
        master = masters[0]
        self.write(
            "subgoal",
            Subgoal(node_id=master.node_id, position_m=master.position_m, label=master.label, utility=1.0),
        )
        self.feedback_message = f"returning to master node {master.node_id}"
        return py_trees.common.Status.SUCCESS
