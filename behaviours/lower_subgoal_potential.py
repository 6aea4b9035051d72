"""LowerSubgoalPotential: mark the current subgoal as hard to reach and clear it.

Semantics (it never returns RUNNING and holds no state, so halting it changes nothing):

- SUCCESS: after scaling the exploration potential of the subgoal's memory node by ``factor`` (Eq. 7
  style: an unreachable subgoal loses its pull), logging a ``subgoal_demoted`` event and clearing
  ``subgoal``, so the next decision picks something else.
- SUCCESS, with a note and nothing changed, when there is no subgoal or its node is no longer in memory.
  It never fails.

Reads and writes ``subgoal`` and ``memory``.

Example:
    - type: LowerSubgoalPotential
      name: Demote
      params: {factor: 0.2}
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param


class LowerSubgoalPotential(SemExpBehaviour):
    READS = ("subgoal", "memory")
    WRITES = ("subgoal", "memory")

    factor: float = param(
        "float", doc="scale applied to the subgoal node's exploration potential", default=0.2, ge=0.0, le=1.0
    )

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        memory = self.read("memory")
        if subgoal is None or subgoal.node_id not in memory.graph:
            self.feedback_message = "no subgoal to demote"
            return py_trees.common.Status.SUCCESS
        memory.scale_potential(node_id=subgoal.node_id, factor=self.factor)
        self.services.log_event("subgoal_demoted", node_id=subgoal.node_id, label=subgoal.label)
        self.write("subgoal", None)
        self.feedback_message = f"node {subgoal.node_id} potential x{self.factor}"
        return py_trees.common.Status.SUCCESS
