"""LowerSubgoalPotential: give the current subgoal up, and tell the decision layer how hard it was to reach.

Semantics (it never returns RUNNING and holds no state, so halting it changes nothing):

- SUCCESS: after scaling the exploration potential of the subgoal's memory node by ``factor`` (Eq. 7
  style: a subgoal the robot could not get to loses its pull), or by ``unreachable_factor`` (0: the node
  is marked unreachable) when navigation failed because no plan reaches it (``nav_failure`` is
  ``no_path`` or ``start_blocked``), logging a ``subgoal_demoted`` (or ``subgoal_unreachable``) event and
  clearing ``subgoal``, so the next decision picks something else. Eq. 8's candidate filter
  (P_explore >= tau_p) and Decide's relaxed pass (P > 0) both respect a zero potential, so an unreachable
  node is never chosen again unless new evidence for the instructed object revives it (UpdateMemory).
- SUCCESS, with a note and nothing changed, when there is no subgoal or its node is no longer in memory.
  It never fails.

Reads ``nav_failure``; reads and writes ``subgoal`` and ``memory``.

Example:
    - type: LowerSubgoalPotential
      name: Demote
      params: {factor: 0.2}
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param

#: ``nav_failure`` values that mean no plan reaches the subgoal.
UNREACHABLE_FAILURES = ("no_path", "start_blocked")


class LowerSubgoalPotential(SemExpBehaviour):
    READS = ("subgoal", "memory", "nav_failure")
    WRITES = ("subgoal", "memory")

    factor: float = param(
        "float", doc="scale applied to the subgoal node's exploration potential", default=0.2, ge=0.0, le=1.0
    )
    unreachable_factor: float = param(
        "float",
        doc="scale applied instead when no plan reaches the subgoal (0: marked unreachable)",
        default=0.0,
        ge=0.0,
        le=1.0,
    )

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        memory = self.read("memory")
        if subgoal is None or subgoal.node_id not in memory.graph:
            self.feedback_message = "no subgoal to demote"
            return py_trees.common.Status.SUCCESS
        unreachable = self.read("nav_failure") in UNREACHABLE_FAILURES
        factor = self.unreachable_factor if unreachable else self.factor
        memory.scale_potential(node_id=subgoal.node_id, factor=factor)
        kind = "subgoal_unreachable" if unreachable else "subgoal_demoted"
        self.services.log_event(kind, node_id=subgoal.node_id, label=subgoal.label)
        self.write("subgoal", None)
        self.feedback_message = f"node {subgoal.node_id} potential x{factor}" + (
            " (unreachable)" if unreachable else ""
        )
        return py_trees.common.Status.SUCCESS
