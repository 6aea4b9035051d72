"""CloserStandpoint: after a confirmation that had its votes from just too far away, go and look from closer by.

Semantics (it never returns RUNNING, so halting it changes nothing):

- SUCCESS: ``closer_look`` is set (ConfirmTarget's near miss) and this spot has had fewer than
  ``looks_per_spot`` closer looks: it writes a ``subgoal`` at the voted point (the memory node nearest to
  it, the votes' label, utility 1: not a decision's) and clears ``closer_look``. The execute branch then
  walks up to the point and faces it; the next step perceives there and confirms again.
- FAILURE: no ``closer_look`` (the usual case: the decision decides), or this spot had its closer looks
  (``closer_look`` is cleared either way, so a near miss is acted on once, right after it), or no memory
  node lies within ``spot_radius_m`` of the point.

Why: a large object (a bus shelter, a shelf) is voted for at its surface, while the robot stops where the
plan to the object's node ends; standing 1.1 m from the surface it collects every vote and still fails the
success radius of 1 m, and the node it failed at is lowered. One more, closer viewpoint is what a person
would take; the spot's budget keeps a distractor that is voted for from afar from holding the robot.

Reads ``closer_look`` and ``memory``; writes ``closer_look`` and ``subgoal``.

Example (before the decision, so a near miss takes precedence over deciding anew):
    - type: Selector
      name: DecideOrLookAround
      params: {memory: true}
      children:
        - type: CloserStandpoint
          name: LookCloser
        - type: Decide
          name: Decide
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.types import Subgoal


class CloserStandpoint(SemExpBehaviour):
    READS = ("closer_look", "memory")
    WRITES = ("closer_look", "subgoal")

    looks_per_spot: int = param(
        "int", doc="closer looks taken at most per spot over the mission", default=1, ge=1, le=10
    )
    spot_radius_m: float = param(
        "float",
        doc="near misses this close to an earlier one are the same spot; the subgoal's node lies this "
        "close to the point, m",
        default=1.0,
        gt=0.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        #: The points looked at from closer by, over the mission.
        self._looked: list[tuple[float, float]] = []

    def update(self) -> py_trees.common.Status:
        look = self.read("closer_look")
        if look is None:
            self.feedback_message = "no closer look asked"
            return py_trees.common.Status.FAILURE
        self.write("closer_look", None)
        x, y = look.position_m[0], look.position_m[1]
        earlier = sum(math.hypot(x - lx, y - ly) <= self.spot_radius_m for lx, ly in self._looked)
        if earlier >= self.looks_per_spot:
            self.feedback_message = f"{look.label!r} at ({x:.2f}, {y:.2f}) already looked at from closer by"
            return py_trees.common.Status.FAILURE
        memory = self.read("memory")
        near = memory.within_radius(position_m=look.position_m, radius_m=self.spot_radius_m)
        if not near:
            self.feedback_message = f"no memory node within {self.spot_radius_m:.1f} m of ({x:.2f}, {y:.2f})"
            return py_trees.common.Status.FAILURE
        self._looked.append((x, y))
        self.write(
            "subgoal", Subgoal(node_id=near[0], position_m=look.position_m, label=look.label, utility=1.0)
        )
        self.services.log_event(
            "closer_look", label=look.label, position_m=[round(v, 3) for v in look.position_m],
            distance_m=round(look.distance_m, 3),
        )  # fmt: skip
        self.feedback_message = f"closer look at {look.label!r}, voted {look.distance_m:.2f} m away"
        return py_trees.common.Status.SUCCESS
