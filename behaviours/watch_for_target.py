"""WatchForTarget: perception on the move; hand the subgoal back once the instructed object is in view.

Semantics:

- RUNNING: while the robot travels. Every ``period_s`` of robot time (the first view ``period_s`` after it
  starts: the step's own Perceive has just looked) it grabs one frame and submits it to perception with the
  base's twist of that instant (a moving camera sees worse: blurred views score lower, with the emulated
  detector as with a real one); it never blocks a tick. When the reply arrives it arbitrates it with the
  mission's calibration and offers to the memory each object candidate that names the instructed object
  (relevance at least ``align_threshold``) with a raw Eq. 2 score of at least ``min_score``, placed on the
  object as UpdateMemory places object offers (Eq. 5-6), with C_f for the view's winner t* and the
  normalised score for the others, under one label as in UpdateMemory (``memory_label``); an offer with a
  detector box behind it that lands on a place's node (an unexplored direction, a frontier) takes it over,
  as in UpdateMemory.
- FAILURE, with ``nav_failure`` = ``superseded`` and a ``target_sighted`` event: once such an offer lands
  in a memory node the decision may choose (potential at least tau_p) that is not the subgoal's node and
  lies more than ``superseded_beyond_m`` from the subgoal. The tree's recovery then returns the subgoal to
  the decision layer untouched (``NavFailureIs [superseded]``), and the next step looks from a stable
  viewpoint and decides again, with the new node in memory. Each node hands a subgoal back at most once
  per mission, so a distractor that fooled one blurred view cannot pull the robot off every later path.
  A privileged subgoal (``oracle_nav``'s, the true goal) is never handed back: no sighting can be a better
  subgoal than the goal itself, and a look-alike's would only stop the reference on its way.
- It never succeeds: it runs beside the controller, whose arrival ends the execute branch.
- Halted: the pending request is cancelled; the views' clock starts again at the next start.
- The paper's stop-and-perceive (the strategy switch ``perception: stop_and_perceive``, strategy
  ``ours_stop_and_perceive``): it takes no views and only runs.

Reads ``instruction``, ``target_label``, ``subgoal`` and ``memory``; writes ``memory`` and ``nav_failure``.

Why: the mission otherwise perceives only where a step begins (the paper's stop-and-perceive), so a robot
walking past the goal on its way to a frontier does not see it. On the dev episodes that happened: garden_sim
seed 1000 passed 0.9 m from the green bin at 505 s, bound for "unexplored area", and never added the bin to
its memory (docs/planner.md, "Perception on the move").

Example:
    - type: WatchForTarget
      name: WatchForTarget
      params: {period_s: 2.0}
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.decide import PRIVILEGED_GOAL_NODE_ID
from behaviours.nav_failure_is import SUPERSEDED
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.evidence import ArbitrationResult, ScoredCandidate, arbitrate, candidate_box
from semexp_bt.core.geometry import locate_in_view
from semexp_bt.core.relevance import NAMES_OBJECT_RELEVANCE
from semexp_bt.core.types import Observation
from semexp_bt.perception.interface import PerceptionJob
from semexp_bt.perception.validation import screen_result

#: The strategy switch that chooses the perception mode, and its two values.
PERCEPTION_SWITCH = "perception"
ON_THE_MOVE = "on_the_move"
STOP_AND_PERCEIVE = "stop_and_perceive"


class WatchForTarget(SemExpBehaviour):
    READS = ("instruction", "target_label", "subgoal", "memory")
    WRITES = ("memory", "nav_failure")

    period_s: float = param(
        "float",
        doc="robot time between two views on the move, s (one request in flight at a time)",
        default=2.0,
        gt=0.0,
    )
    align_threshold: float = param(
        "float",
        doc="relevance at which a label counts as the instructed object (0.9: the instructed label or a "
        "synonym, as ConfirmTarget asks; a related class does not turn the robot)",
        default=NAMES_OBJECT_RELEVANCE,
        ge=0.0,
        le=1.0,
    )
    min_score: float = param(
        "float",
        doc="least raw Eq. 2 score of a candidate offered from a view on the move (0.04 since session 37: "
        "a goal boxed from 3 m on the move scores 0.043-0.047 with no VLM name beside the box, docs/planner.md, "
        "twenty-fifth round)",
        default=0.04,
        ge=0.0,
        le=1.0,
    )
    superseded_beyond_m: float = param(
        "float",
        doc="a sighted node this close to the subgoal does not hand it back (the robot is going there), m",
        default=1.0,
        ge=0.0,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._job: PerceptionJob | None = None
        self._observation: Observation | None = None
        self._last_view_s = 0.0
        #: Nodes that have handed a subgoal back (over the mission).
        self._handed_back: set[int] = set()

    def initialise(self) -> None:
        self._job = None
        self._observation = None
        self._last_view_s = self.now_s()

    def update(self) -> py_trees.common.Status:
        if self.services.strategy.get(PERCEPTION_SWITCH, ON_THE_MOVE) == STOP_AND_PERCEIVE:
            self.feedback_message = "stop-and-perceive: no views on the move"
            return py_trees.common.Status.RUNNING
        if self._job is None:
            if has_elapsed(since_s=self._last_view_s, now_s=self.now_s(), duration_s=self.period_s):
                self._observation = self.services.robot.observe()
                self._last_view_s = self.now_s()
                self._job = self.submit_view(self._observation)
            return py_trees.common.Status.RUNNING
        result = self._job.poll(now_s=self.now_s())
        if result is None:
            return py_trees.common.Status.RUNNING
        self._job = None
        result = screen_result(result)
        for error in result.errors:
            self.services.log_event("perception_error", message=error)
        sighted = self._offer_sightings(result.scene, result.detections)
        if sighted is None:
            return py_trees.common.Status.RUNNING
        node_id, label, distance_m = sighted
        self._handed_back.add(node_id)
        self.write("nav_failure", SUPERSEDED)
        self.services.log_event(
            "target_sighted", label=label, node_id=node_id, distance_m=round(distance_m, 2)
        )
        self.feedback_message = (
            f"sighted {label!r} (node {node_id}, {distance_m:.1f} m away): subgoal handed back"
        )
        return py_trees.common.Status.FAILURE

    def _offer_sightings(self, scene: Any, detections: Any) -> tuple[int, str, float] | None:
        """Offer this view's instructed-object candidates to the memory; the first node that supersedes
        the subgoal (see the module docstring) as (node id, label, distance from the robot), or None."""
        observation = self._observation
        assert observation is not None
        config = self.services.config
        arbitration = arbitrate(
            scene=scene,
            detections=detections,
            is_aligned=lambda label: self.names_instructed_object(label, threshold=self.align_threshold),
            config=config.arbitration,
            depth_m=observation.depth_m,
            image_size=(observation.intrinsics.width_px, observation.intrinsics.height_px),
        )
        memory = self.read("memory")
        subgoal = self.read("subgoal")
        pose = self.services.robot.base_pose()
        offered = 0
        sighted: tuple[int, str, float] | None = None
        # No sighting is a better subgoal than the true goal (oracle_nav's): its sightings only enter the memory.
        may_supersede = subgoal is None or subgoal.node_id != PRIVILEGED_GOAL_NODE_ID
        for index, candidate in enumerate(arbitration.candidates):
            if candidate.kind == "direction" or candidate.score < self.min_score:
                continue
            if not self.names_instructed_object(candidate.label, threshold=self.align_threshold):
                continue
            point = locate_in_view(
                observation,
                candidate.pixel_px,
                candidate_box(candidate, scene),
                config.arbitration.depth_patch_px,
            )
            if point is None:
                continue
            update = memory.update(
                position_m=tuple(float(v) for v in point),
                label=self.memory_label(candidate.label),
                confidence=float(np.clip(self._confidence(arbitration, index), 0.0, 1.0)),
                stamp_s=self.now_s(),
                # As in UpdateMemory: only boxed evidence naming the instructed object takes a place over
                # (align_threshold may admit related classes too).
                takes_over=self.services.place_labels if self._takes_places(candidate) else frozenset(),
            )
            offered += 1
            if not may_supersede or sighted is not None:
                continue
            if update.node_id is None or update.node_id in self._handed_back:
                continue
            node = memory.node(update.node_id)
            if node.potential < config.decision.tau_p:
                continue
            if subgoal is not None:
                if subgoal.node_id == update.node_id:
                    continue
                gx, gy, _ = subgoal.position_m
                if math.hypot(point[0] - gx, point[1] - gy) <= self.superseded_beyond_m:
                    continue
            sighted = (update.node_id, candidate.label, math.hypot(point[0] - pose.x_m, point[1] - pose.y_m))
        self.feedback_message = f"view on the move: {offered} instructed-object offers"
        return sighted

    def _takes_places(self, candidate: ScoredCandidate) -> bool:
        """Whether ``candidate`` may take a place's node over (see UpdateMemory)."""
        return candidate.has_box and self.names_instructed_object(candidate.label)

    @staticmethod
    def _confidence(arbitration: ArbitrationResult, index: int) -> float:
        """C_f for the winner t*, the normalised score S(t) / sum S for the others (as UpdateMemory offers them)."""
        if index == arbitration.winner_index and arbitration.target is not None:
            return arbitration.target.fused_confidence
        return arbitration.candidates[index].normalised_score

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID and self._job is not None:
            self._job.cancel()
        self._job = None
