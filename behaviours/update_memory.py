"""UpdateMemory: grow the topological memory from the arbitrated evidence (paper Eq. 5-7).

Semantics (it never returns RUNNING):

- SUCCESS: always, after updating the memory as below; offers the memory rejected, and why, are in the
  feedback.
- Halted: nothing to undo; the revival counts (below) are kept over the mission.

Reads ``arbitration``, ``target``, ``observation``, ``scene_evidence``, ``subgoal``, ``local_map``,
``instruction`` and ``target_label``; writes ``memory``. It also adds the labels of places (directions,
frontiers) to ``services.place_labels``, which the map-based decay reads.

When there is an ``observation``, it back-projects the target pixel through the frame's intrinsics and
camera-to-world transform (Eq. 5) and offers the point to the memory's gated insert-or-merge (Eq. 6).
Candidates other than t* are offered too (with ``offer_all_candidates``; their normalised score must pass
the memory's C_f gate), so one view can add an object and an unexplored direction; so are the other
objects the VLM named (landmarks, e.g. "shelving rack"), weighted by the calibrated scene confidence,
and up to ``max_frontiers`` open directions of the depth frame (``offer_frontiers``). Directions and
frontiers are places to go, not objects to touch: their node stands ``standoff_m`` in front of the surface
the pixel sees, at most ``direction_range_m`` ahead; an object's or a landmark's node sits on it. Only
evidence for the instructed object may relabel a nearby node of another label, and evidence that names it
with a detector box behind it takes a place's node over whatever the confidences
(``TopologicalMemory.update``'s ``takes_over``, with ``services.place_labels``): a direction the VLM named
with C_f 1.0 otherwise swallowed the goal's detection (garden_sim seed 0, docs/memory.md). Object evidence
that names the instructed object enters under one label, ``target_label``, whichever words the detector or
the VLM used (``memory_label``), so the memory holds the same nodes for every wording of the instruction.

Then, with or without an observation: the surroundings of the robot count as observed (Eq. 7 decay);
with a ``local_map``, place nodes whose neighbourhood the map has mostly seen decay too and the map's
frontiers are offered as "unexplored area" nodes; and a subgoal within ``visit_radius_m`` is marked
visited.

A glance aside (``instructed_only``; the explore step's side looks, trees/subtrees/explore_step.yaml):
only object evidence that the detector boxed and whose label names the instructed object is offered, and
nothing else changes (no places, frontiers, Eq. 7 decay or visit): the step's own view did those from the
same spot, and each further view of the VLM alone is one more chance of a look-alike's name (Table III,
seeds 0-4: with every name of the instructed object offered, SR 76.0 % and SPL 39.1 %; with boxed names
only, 80.0 % and 40.2 %; docs/planner.md, twenty-eighth round).

Revival: a candidate for the instructed object whose raw Eq. 2 score reaches ``revive_min_score`` (both
sources agree on it, not a lone weak detection) raises the potential of the node it merged into back to
that node's confidence, at most ``max_revivals`` times per node. Without it, an object node demoted once
(the robot was blocked on the way) stays under tau_p however clearly the robot sees the object again;
the bound keeps an unreachable object from pulling the robot back for ever.

Example:
    - type: UpdateMemory
      name: UpdateMemory
      params: {direction_range_m: 3.0}
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.evidence import calibrate, candidate_box
from semexp_bt.core.geometry import back_project, object_surface_depth
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.relevance import RELATED_RELEVANCE
from semexp_bt.core.types import FloatArray, Pose2D
from semexp_bt.nav.costmap import Costmap
from semexp_bt.nav.frontier import depth_frontiers

Box = tuple[float, float, float, float]


class Offer(NamedTuple):
    """One offer to the memory's gated insert (Eq. 6)."""

    pixel: tuple[float, float]
    box: Box | None  # the object's detection box or VLM region; None for places
    label: str
    confidence: float
    is_place: bool
    score: float | None = None  # raw Eq. 2 score of the arbitration candidate behind it
    boxed: bool = False  # a detector box stands behind it (ScoredCandidate.has_box)


#: Label of a geometric frontier node (the relevance scorer sees it like a VLM's direction label).
FRONTIER_LABEL = "unexplored area"
#: A place node counts as seen once the costmap has observed this share of its neighbourhood ...
PLACE_SEEN_FRACTION = 0.85
#: ... of this radius, m: nothing is left to discover there.
PLACE_NEIGHBOURHOOD_M = 1.0


def place_is_seen(local_map: Costmap, position_m: Sequence[float]) -> bool:
    """Whether the costmap has observed ``PLACE_SEEN_FRACTION`` of the ``PLACE_NEIGHBOURHOOD_M`` around a
    place (Eq. 7 on the costmap decays it then; WatchPlaceSeen hands it back)."""
    xy = (float(position_m[0]), float(position_m[1]))
    return local_map.known_fraction(xy, radius_m=PLACE_NEIGHBOURHOOD_M) >= PLACE_SEEN_FRACTION


class UpdateMemory(SemExpBehaviour):
    READS = (
        "arbitration",
        "target",
        "observation",
        "subgoal",
        "scene_evidence",
        "local_map",
        "instruction",
        "target_label",
        "memory",
    )
    WRITES = ("memory",)

    direction_range_m: float = param(
        "float", doc="depth cap for unexplored-direction proposals, m", default=3.0, gt=0.0
    )
    visit_radius_m: float = param(
        "float", doc="a subgoal within this distance counts as visited, m", default=1.0, gt=0.0
    )
    standoff_m: float = param(
        "float",
        doc="place nodes (directions, landmarks) stop this far in front of the seen surface, m",
        default=0.6,
        ge=0.0,
    )
    landmark_weight: float = param(
        "float",
        doc="confidence of a VLM-named landmark node relative to the calibrated scene confidence "
        "(0: no landmark nodes)",
        default=0.8,
        ge=0.0,
        le=1.0,
    )
    offer_all_candidates: bool = param(
        "bool", doc="offer every candidate (not only t*) to the gated insert", default=True
    )
    offer_frontiers: bool = param(
        "bool",
        doc="also offer the depth frame's open directions (geometric frontiers) as place nodes, so "
        "the search never starves when the VLM names no direction",
        default=True,
    )
    frontier_open_range_m: float = param(
        "float", doc="a frontier column has no obstacle nearer than this, m", default=1.5, gt=0.0
    )
    frontier_min_width_deg: float = param(
        "float", doc="narrowest open run of columns that makes a frontier, degrees", default=8.0, gt=0.0
    )
    frontier_confidence: float = param(
        "float",
        doc="confidence of a geometric frontier node (above the memory's C_f gate)",
        default=0.5,
        ge=0.0,
        le=1.0,
    )
    max_frontiers: int = param("int", doc="at most this many frontiers per view", default=2, ge=0)
    map_frontier_confidence: float = param(
        "float",
        doc="confidence of a node at an costmap frontier (0: no map frontiers)",
        default=0.6,
        ge=0.0,
        le=1.0,
    )
    revive_min_score: float = param(
        "float",
        doc="least raw Eq. 2 score of an instructed-object candidate that revives the potential of "
        "the node it merges into (1: never revive)",
        default=0.15,
        ge=0.0,
        le=1.0,
    )
    max_revivals: int = param("int", doc="most revivals of one node per mission", default=2, ge=0)
    instructed_only: bool = param(
        "bool",
        doc="offer only object evidence that the detector boxed and that names the instructed object, and "
        "leave the potentials "
        "(Eq. 7 decay, the costmap's places and frontiers, the visit) as they are: for a glance aside "
        "at a stop whose own step already grew the memory",
        default=False,
    )

    #: A place node stands at least this far from the camera, m.
    min_place_depth_m = 0.5
    #: Eq. 7 on the costmap: place nodes within this radius of the robot are checked, and decay once the
    #: map has seen them (``place_is_seen``), m.
    map_observe_radius_m = 6.0

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._revivals: dict[int, int] = {}

    def _offers(self) -> list[Offer]:
        """(pixel, box, label, confidence, is_place, score, boxed) for t*, the other candidates and the
        landmarks.

        ``box`` is the detection box or the VLM's region of an object offer (None for places), from which
        :func:`~semexp_bt.core.geometry.object_surface_depth` takes the object's range.

        ``is_place`` marks offers that stand for a place to go to rather than an object to reach (an
        unexplored direction, a frontier): their node goes ``standoff_m`` in front of the surface the
        pixel sees, so the subgoal is somewhere the robot can stand. Only evidence for the instructed
        object may relabel an existing node (Eq. 6 relabels on higher confidence): a landmark or a
        frontier next to a fire-extinguisher node is dropped rather than renaming it.
        """
        result = self.read("arbitration")
        target = self.read("target")
        scene = self.read("scene_evidence")
        tau = self.services.config.arbitration.tau
        place_weight = 0.0 if scene is None else calibrate(scene.scene_confidence, tau) * self.landmark_weight
        offers: list[Offer] = []
        if target is not None and result is not None:
            winner = result.winner
            offers.append(
                Offer(
                    target.pixel_px,
                    None if winner is None else candidate_box(winner, scene),
                    target.label,
                    target.fused_confidence,
                    target.kind == "direction",
                    None if winner is None else winner.score,
                    winner is not None and winner.has_box,
                )
            )
            if self.offer_all_candidates:
                for cand in result.candidates:
                    if cand.pixel_px == target.pixel_px and cand.label == target.label:
                        continue
                    confidence = cand.normalised_score
                    if cand.kind == "direction":
                        # S(t)/sum S splits the mass among candidates, so with three directions in view
                        # none would pass the insertion gate; a direction the VLM named is a place worth
                        # as much as a landmark it named.
                        confidence = max(confidence, place_weight)
                    offers.append(
                        Offer(
                            cand.pixel_px,
                            candidate_box(cand, scene),
                            cand.label,
                            confidence,
                            cand.kind == "direction",
                            cand.score,
                            cand.has_box,
                        )
                    )
        if self.landmark_weight > 0.0 and scene is not None and not self.instructed_only:
            # The VLM also names context objects that are not candidates for the target ("shelving rack",
            # "desk"); kept as landmark nodes they give the decision semantic places to explore, with the
            # relevance scorer deciding how much each says about the instruction.
            candidate_pixels = {tuple(c.pixel_px) for c in (result.candidates if result is not None else ())}
            weight = place_weight
            for proposal in scene.proposals:
                if proposal.kind == "object" and tuple(proposal.point_px) not in candidate_pixels:
                    # An object, not a place: its node sits on it, so that a later instruction that asks
                    # for it ("find the red trash can" after the extinguisher) leads right up to it.
                    offers.append(Offer(proposal.point_px, proposal.region_px, proposal.label, weight, False))
        observation = self.read("observation")
        if self.offer_frontiers and observation is not None and not self.instructed_only:
            # Frontiers beside the VLM's directions: the gate of Eq. 6 merges one that lands on a node the
            # VLM already gave, so the memory does not grow twice for one opening.
            frontiers = depth_frontiers(
                depth_m=observation.depth_m,
                intrinsics=observation.intrinsics,
                camera_to_world=observation.camera_to_world,
                open_range_m=self.frontier_open_range_m,
                min_width_deg=self.frontier_min_width_deg,
            )
            for frontier in frontiers[: self.max_frontiers]:
                offers.append(Offer(frontier.pixel_px, None, FRONTIER_LABEL, self.frontier_confidence, True))
        self.services.place_labels.add(FRONTIER_LABEL)
        if result is not None:
            self.services.place_labels.update(c.label for c in result.candidates if c.kind == "direction")
        return offers

    def update(self) -> py_trees.common.Status:
        memory = self.read("memory")
        observation = self.read("observation")
        pose = self.services.robot.base_pose()
        robot_xyz = (pose.x_m, pose.y_m, 0.0)
        outcomes: list[str] = []
        with self.timed("memory_update"):
            if observation is not None:
                patch = self.services.config.arbitration.depth_patch_px
                offers = self._offers()
                if self.instructed_only:
                    offers = [
                        o
                        for o in offers
                        if o.boxed and not o.is_place and self.names_instructed_object(o.label)
                    ]
                for pixel, box, label, confidence, is_place, score, boxed in offers:
                    depth = object_surface_depth(observation.depth_m, pixel, None if is_place else box, patch)
                    if is_place:
                        seen = self.direction_range_m if depth is None else depth
                        depth = max(
                            self.min_place_depth_m, min(seen - self.standoff_m, self.direction_range_m)
                        )
                    if depth is None or not math.isfinite(depth):
                        outcomes.append(f"{label}: no depth")
                        continue
                    point = back_project(
                        pixel_px=pixel,
                        depth_m=depth,
                        intrinsics=observation.intrinsics,
                        camera_to_world=observation.camera_to_world,
                    )
                    if not self._instructed(label) and self._would_relabel(memory, point, label):
                        outcomes.append(f"{label}: kept the nearby node's label")
                        continue
                    # Only the instructed object, seen by the detector too, takes a place over: the VLM's
                    # confusions repeat from one viewpoint (ConfirmTarget asks a box for the same reason).
                    names_the_object = boxed and not is_place and self.names_instructed_object(label)
                    result = memory.update(
                        position_m=tuple(float(v) for v in point),
                        label=label if is_place else self.memory_label(label),
                        confidence=float(np.clip(confidence, 0.0, 1.0)),
                        stamp_s=self.now_s(),
                        takes_over=self.services.place_labels if names_the_object else frozenset(),
                    )
                    outcomes.append(f"{label}: {result.action}")
                    if result.action == "merged" and score is not None and not is_place:
                        outcomes += self._revive(memory, result.node_id, label, score)
            if self.instructed_only:
                self.feedback_message = f"{len(memory)} nodes; " + ", ".join(outcomes[:4])
                return py_trees.common.Status.SUCCESS
            memory.observe_surroundings(robot_position_m=robot_xyz)
            local_map = self.read("local_map")
            if local_map is not None:
                outcomes += self._map_exploration(memory, local_map, pose)
            subgoal = self.read("subgoal")
            if subgoal is not None and subgoal.node_id in memory.graph:
                gx, gy, _ = subgoal.position_m
                if math.hypot(gx - pose.x_m, gy - pose.y_m) <= self.visit_radius_m:
                    memory.mark_visited(node_id=subgoal.node_id)
        self.feedback_message = f"{len(memory)} nodes; " + ", ".join(outcomes[:4])
        return py_trees.common.Status.SUCCESS

    def _revive(self, memory: TopologicalMemory, node_id: int, label: str, score: float) -> list[str]:
        """Revival (see the module docstring): strong evidence for the instructed object restores its node."""
        if score < self.revive_min_score or self._revivals.get(node_id, 0) >= self.max_revivals:
            return []
        if not self.names_instructed_object(label):
            return []
        state = memory.node(node_id)
        if not memory.raise_potential(node_id=node_id, at_least=state.confidence):
            return []
        self._revivals[node_id] = self._revivals.get(node_id, 0) + 1
        return [f"{label}: revived node {node_id}"]

    def _instructed(self, label: str) -> bool:
        """Whether ``label`` names what the instruction asks for (only such evidence may relabel a node)."""
        return self.names_instructed_object(label, threshold=RELATED_RELEVANCE)

    @staticmethod
    def _would_relabel(memory: TopologicalMemory, point: Sequence[float] | FloatArray, label: str) -> bool:
        """Whether offering a place (a direction, a landmark, a frontier) at ``point`` would merge into a
        nearby node of another label: Eq. 6 relabels a node when the newcomer is more confident, and a
        frontier must never turn a fire-extinguisher node into "unexplored area"."""
        nearest = memory.nearest(position_m=tuple(float(v) for v in point))
        if nearest is None:
            return False
        node_id, distance = nearest
        return distance <= memory.config.delta_d and memory.node(node_id).label != label

    def _map_exploration(self, memory: TopologicalMemory, local_map: Costmap, pose: Pose2D) -> list[str]:
        """Eq. 7 with "surroundings observed" measured on the costmap, plus its frontiers as nodes.

        A place node (not an instructed object) whose 1 m neighbourhood the map has now mostly seen decays
        by (1 - xi): nothing is left to discover there. And the seen/unseen boundary of the map (the
        classic exploration frontier) is offered as "unexplored area" nodes, so the memory always holds
        somewhere new to go while the map has unseen parts within reach.
        """
        notes: list[str] = []
        xi = self.services.config.memory.xi
        robot_xy = (pose.x_m, pose.y_m, 0.0)
        for node_id in memory.within_radius(position_m=robot_xy, radius_m=self.map_observe_radius_m):
            state = memory.node(node_id)
            if state.is_master or state.potential <= 0.0:
                continue
            if state.label not in self.services.place_labels:
                continue  # objects and landmarks keep their pull: a later instruction may ask for them
            if place_is_seen(local_map, state.position_m):
                memory.scale_potential(node_id=node_id, factor=1.0 - xi)
        if self.map_frontier_confidence > 0.0:
            for x, y, cells in local_map.frontiers((pose.x_m, pose.y_m), radius_m=self.map_observe_radius_m):
                if self._would_relabel(memory, (x, y, 0.3), FRONTIER_LABEL):
                    continue
                result = memory.update(
                    position_m=(x, y, 0.3),
                    label=FRONTIER_LABEL,
                    confidence=self.map_frontier_confidence,
                    stamp_s=self.now_s(),
                )
                notes.append(f"frontier {cells} cells: {result.action}")
        return notes
