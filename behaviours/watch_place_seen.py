"""WatchPlaceSeen: hand a place subgoal back once the cameras have seen it on the way.

Semantics:

- Off by default: the strategy switch ``places: hand_back_when_seen`` (strategy ``ours_place_handback``)
  turns it on; otherwise it only runs, and a place subgoal is walked to as the paper's executive does.
  On Table III's 200 episodes it moved SR from 86.5 to 88.0 % and SPL from 34.1 to 33.5 %, both inside the
  noise, and lengthened the median success by 12 s (docs/planner.md, twenty-seventh round).
- RUNNING: while the robot travels to its ``subgoal``, and always when the subgoal is not a place (an
  unexplored direction or a frontier, ``services.place_labels``), when its surroundings were already seen
  as the trip began, or when the robot is within ``finish_within_m`` of it (it may as well arrive).
- FAILURE, with ``nav_failure`` = ``explored`` and a ``place_seen`` event: once the costmap has observed
  the surroundings of a place subgoal (``update_memory.place_is_seen``: 0.85 of its 1 m neighbourhood)
  that were unseen when the trip began. The tree's recovery then returns the subgoal to the decision layer
  untouched (``NavFailureIs [superseded, explored]``); the next step looks from where the robot stands,
  decays the seen place (UpdateMemory's Eq. 7 on the costmap) and decides again. Each node hands a
  subgoal back at most once per mission, so a place chosen again is walked to the end.
- It never succeeds: it runs beside the controller, whose arrival ends the execute branch.
- Halted: nothing to undo; the next start records the new trip's unseen share afresh.

Reads ``subgoal``, ``memory`` and ``local_map``; writes ``nav_failure``.

Why: a place is a promise of something unseen there. The head and flank cameras see it from metres away
on the way, so walking the rest of the trip adds path and nothing to the map: a frontier explorer
(SemExp, VLFM) replans its frontier every map update for the same reason. The paper's executive decides
only at a stable viewpoint, so the subgoal is handed back and the next step decides from there
(docs/planner.md, twenty-seventh round).

Example:
    - type: WatchPlaceSeen
      name: WatchPlaceSeen
      params: {finish_within_m: 1.5}
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.nav_failure_is import EXPLORED
from behaviours.spec import param
from behaviours.update_memory import place_is_seen

#: The strategy switch that chooses what happens to a place subgoal seen on the way, and its two values.
PLACES_SWITCH = "places"
WALK_TO = "walk_to"
HAND_BACK_WHEN_SEEN = "hand_back_when_seen"


class WatchPlaceSeen(SemExpBehaviour):
    READS = ("subgoal", "memory", "local_map")
    WRITES = ("nav_failure",)

    finish_within_m: float = param(
        "float",
        doc="within this distance of the place the robot walks on to it, m",
        default=1.5,
        ge=0.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        #: The subgoal's node of this trip while it is an unseen place; None once nothing is to be watched.
        self._watched: int | None = None
        #: Nodes that have handed a subgoal back (over the mission).
        self._handed_back: set[int] = set()
        #: Whether the watched place is seen, and the costmap frame that said so: only a new frame adds
        #: observed cells within a trip (the map integrates at 6 Hz, the tree ticks at 50).
        self._seen = False
        self._judged_frame = -1

    def initialise(self) -> None:
        self._watched = None
        self._seen = False
        self._judged_frame = -1
        if self.services.strategy.get(PLACES_SWITCH, WALK_TO) != HAND_BACK_WHEN_SEEN:
            return
        subgoal = self.read("subgoal")
        if subgoal is None or subgoal.node_id in self._handed_back or not self._is_place(subgoal.node_id):
            return
        if not self._is_seen(subgoal.position_m):
            self._watched = subgoal.node_id

    def update(self) -> py_trees.common.Status:
        subgoal = self.read("subgoal")
        if self._watched is None or subgoal is None or subgoal.node_id != self._watched:
            self.feedback_message = "no unseen place to watch"
            return py_trees.common.Status.RUNNING
        if not self._is_place(subgoal.node_id):
            self._watched = None  # evidence for an object took the place over: go there
            self.feedback_message = "the place became an object"
            return py_trees.common.Status.RUNNING
        local_map = self.read("local_map")
        if local_map is not None and local_map.frames != self._judged_frame:
            self._judged_frame = local_map.frames
            self._seen = place_is_seen(local_map, subgoal.position_m)
        pose = self.services.robot.base_pose()
        distance_m = math.hypot(subgoal.position_m[0] - pose.x_m, subgoal.position_m[1] - pose.y_m)
        self.feedback_message = f"place {'seen' if self._seen else 'unseen'}, {distance_m:.1f} m away"
        if distance_m <= self.finish_within_m or not self._seen:
            return py_trees.common.Status.RUNNING
        self._handed_back.add(subgoal.node_id)
        self.write("nav_failure", EXPLORED)
        self.services.log_event(
            "place_seen", node_id=subgoal.node_id, label=subgoal.label, distance_m=round(distance_m, 2)
        )
        self.feedback_message = f"place {subgoal.node_id} seen from {distance_m:.1f} m: subgoal handed back"
        return py_trees.common.Status.FAILURE

    def _is_place(self, node_id: int) -> bool:
        memory = self.read("memory")
        return node_id in memory and memory.node(node_id).label in self.services.place_labels

    def _is_seen(self, position_m: tuple[float, float, float]) -> bool:
        local_map = self.read("local_map")
        return local_map is not None and place_is_seen(local_map, position_m)
