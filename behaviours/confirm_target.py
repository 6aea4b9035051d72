"""ConfirmTarget: declare the goal found only on consistent, calibrated evidence from close by.

Semantics:

- It first reads the step's own ``arbitration`` (with ``scene_evidence`` and ``observation``). If that
  view does not vote for a target (below), FAILURE at once, unless the ``subgoal`` the robot went to is a
  memory node of the instructed object, in view and within ``reject_radius_m``: then it looks again, at
  most ``first_vote_views`` views in all, and the first view that votes starts the confirmation.
- RUNNING: while it steps up to the first vote (below), then while it takes further views from where it
  stands (``robot.observe()`` and a perception request each; RUNNING while the models think), at most
  ``max_extra_views``. With ``view_from_m`` set, the views come first from that far away and a second set
  from close by (below).
- SUCCESS: as soon as ``extra_views`` further views vote for a point within ``consistency_radius_m`` of
  the first, the mean of the voting points lies within ``confirm_radius_m`` of the robot, and the names
  heard at that spot agree (below); it then appends the object to ``found_objects``.
- FAILURE: when too few views are left to reach ``extra_views``, or the votes' mean lies beyond
  ``confirm_radius_m``, or the names disagree. After every failure, an aligned memory node next to the
  robot and inside the camera's view has its exploration potential scaled by ``reject_potential_factor``.
- Halted: the pending perception request is cancelled; the next start begins a new confirmation (the
  names heard are kept over the mission).

Reads ``arbitration``, ``scene_evidence``, ``observation``, ``instruction``, ``target_label``,
``found_objects``, ``memory``, ``local_map`` and ``subgoal``; writes ``found_objects``, ``memory`` (node potentials) and,
while it steps up, ``cmd_twist`` and ``cmd_stamp_s``.

Stepping up: before the further views, the robot turns until the first vote's point is within
``face_tolerance_deg`` of straight ahead, then walks straight at it until it is ``approach_to_m`` away
(Nav2-style checks of every motion against the costmap, ``motion_is_admissible``: the footprint's
clearance, unseen space, the body's sweep; it stops where the next half second of motion would not pass
them, or after ``approach_timeout_s``), and waits for the base to stand still (at most ``_SETTLE_S``: a
legged base never reads exactly zero).

Why: an object at the image's edge or at the success radius's rim is what a single stop leaves most
often (the twelve dev episodes of docs/planner.md's seventh round: robots 0.81-0.91 m from the goal whose
further views voted 2 of 4 or 0 of 2, and one whose votes averaged 1.00 m away while it stood at 0.87 m);
the emulated detector, like a real one, sees a centred object more reliably (its truncation and off-axis
factors, docs/perception.md), and the mean of votes from 0.7 m lies inside r_s. A real operator does the
same: look at it squarely, from close by.

Two standpoints (``view_from_m`` > 0; off by default): from 0.7 m of the base centre the head camera is
0.3-0.5 m from the object, which the image border cuts (docs/planner.md, "Where SPL is lost"). With
``view_from_m`` set, the robot first walks up to, or backs straight away from, the first vote until it is
about ``view_from_m`` away (backing only onto floor the costmap has seen, the controller's rule), takes
the further views there, then steps up to ``approach_to_m`` to declare. If the step up stops more than
``_DECLARE_SLACK_M`` beyond ``approach_to_m`` of the votes' mean, it looks again from where it stopped
(the default order's evidence: votes from where it declares). With some votes from afar but too few, it
takes a second set of at most ``max_extra_views`` views from close by, counted afresh; with no vote from
afar, or a base that could not back up, none. Measured with ``view_from_m: 1.0`` (docs/executive.md,
session 25): better on 40 dev episodes, worse on the first 22-33 of Table III, so it is not the default.

Voting: a view *votes* for the target when one of its arbitration candidates is an object whose
label names the instructed object (relevance >= ``align_threshold``), whose raw posterior score S(t)
of Eq. 2 reaches ``min_score``, and whose back-projected position lies within ``confirm_radius_m`` +
``vote_slack_m`` of the robot. At least one of the votes must come with a detector box (a ``fused`` or
``object`` candidate): the VLM alone does not confirm. Its mistakes repeat from one viewpoint: it named
the advertising board beside the sidewalk's traffic sign "traffic sign" in most views (sidewalk seed 0,
"find the grey traffic sign"; its confusion rate is 0.16 a view, but the views continue until the votes
are in), and its candidates alone confirmed the board. A look-alike must now fool the detector too,
whose confusions are independent draws. Requiring a box in every vote instead made the real goal fail
too often (docs/executive.md).

Success also needs the mean of the voting positions to lie within ``confirm_radius_m`` (the success
radius r_s) less ``declare_margin_m``: one view's depth is noisy by a decimetre or more, so a robot
standing 0.9 m from the target would lose single votes at a hard 1.0 m gate, while the mean of four views
says whether the target is within r_s to a few centimetres; the margin covers those (a dynamic run
declared with the mean 0.96 m away and the object 1.002 m away in truth). The candidate need not be the
view's winner t*: an unexplored direction may outscore the object in Eq. 2 (it is where to look next), yet the object
is still seen here.

A k-of-n vote rather than k views in a row: each emulated (or real) view misses a present object now and
then, while a distractor fools most views only rarely (docs/executive.md, "Confirmation", has the
arithmetic). Lowering the potential of a rejected node keeps the decision from sending the robot straight
back (a distractor that fooled the detector once is not trusted twice), while a real target missed once
can still be revisited.

Label agreement: every view the behaviour inspects (first and further, over the whole mission) also
records what the VLM *called* the objects in front of the robot, in its own words: a mark at each of its
object proposals near the robot, naming the target or something else. The detector's boxes leave no
mark: a prompted detector (GroundingDINO) labels every box with the prompt's phrase, so its label echoes
the instruction and says nothing of what the object is. Before declaring success, the marks within
``label_agreement_radius_m`` of the target must name the target at least ``min_label_agreement`` of the
time. A plain shelf that the VLM
calls "shelf" in half its views and "bucket shelf" in the other half collects three votes now and
then; it never collects a majority of 0.7. A real bucket shelf is named so in most views. In a view where
the detector boxed the target, a name whose region lies mostly off those boxes (less than
``same_object_share`` of it inside) belongs to a neighbour and leaves no mark: a grey chair beside the
black chair, a kiosk against the bus station, named within 0.5 m of the target's point in every view,
outvoted the target's own name before (docs/planner.md, seventeenth round). Another name for the boxed
object itself (the VLM's "shelf" for the detector's "bucket shelf") still lies on the box and still counts.

Looking again for the first vote: from close by a real goal votes in about a third of the views (the
detector's confidence falls as the image border cuts the object), so a robot that walked to a node of
the instructed object and missed it in the one view it took walked on, and often came back minutes later
(laboratory seed 1001: the black chair boxed at 0.31-0.32 from 0.55 m, scores 0.017 against 0.05, then
62 m more of search; docs/planner.md, twenty-fourth round). With p = 0.34 a view, one view starts 34 % of
such confirmations and four 81 %; a look-alike voting 0.12 a view starts 40 %, and still needs the votes,
the box and the names.

Example:
    - type: ConfirmTarget
      name: Confirm
      params: {confirm_radius_m: 1.0, extra_views: 3, max_extra_views: 8, first_vote_views: 4}
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.follow_path import motion_is_admissible
from behaviours.spec import param
from behaviours.spin import turn_rate_toward
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.evidence import ArbitrationResult, arbitrate, candidate_box
from semexp_bt.core.geometry import box_share_inside, locate_in_view, wrap_angle
from semexp_bt.core.relevance import NAMES_OBJECT_RELEVANCE
from semexp_bt.core.types import Observation, SceneEvidence, Twist
from semexp_bt.perception.interface import PerceptionJob, PerceptionResult
from semexp_bt.perception.validation import screen_result


def _in_view(point_m: tuple[float, float, float], observation: Observation) -> bool:
    """Whether a world point projects inside the observation's image, in front of the camera."""
    world_to_camera = np.linalg.inv(np.asarray(observation.camera_to_world, dtype=float))
    x, y, z = world_to_camera[:3, :3] @ np.asarray(point_m, dtype=float) + world_to_camera[:3, 3]
    if z <= 0.0:
        return False
    k = observation.intrinsics
    u, v = k.fx_px * x / z + k.cx_px, k.fy_px * y / z + k.cy_px
    return 0.0 <= u < k.width_px and 0.0 <= v < k.height_px


#: A view's vote: the label it voted for, the voted point in ``map`` and whether a detector box was among
#: the voting candidates.
Vote = tuple[str, np.ndarray, bool]

#: Why a confirmation was refused, as its ``confirmation_rejected`` event's ``cause`` says (the benchmark
#: rows count them, ``semexp_bt.bench.rows``): too few further views voted; the votes' mean lay beyond
#: the declaration distance; no vote carried a detector box; the names heard at the spot disagreed.
REFUSAL_CAUSES = ("too_few_views", "mean_beyond_radius", "no_detector_box", "label_agreement")
#: The step up stops before this margin beyond ``approach_to_m`` (it creeps no closer).
_APPROACH_SLACK_M = 0.05
#: The base backs away for the views from afar only when the first vote is this much nearer than
#: ``view_from_m``, m (a short shuffle back buys little view); once it backs, it backs all the way.
_BACK_UP_SLACK_M = 0.15
#: Votes from afar declare only if the step up then brought the robot this close beyond ``approach_to_m``
#: to their mean, m; a robot stopped farther out looks again from where it stands.
_DECLARE_SLACK_M = 0.15
#: Each motion of the step up is checked this far ahead, s.
_STEP_LOOKAHEAD_S = 0.5
#: The base counts as standing still below these speeds (m/s, rad/s).
_STILL_MPS = 0.02
_STILL_RADPS = 0.05
#: The views start after this long even if the base still reads as moving, s.
_SETTLE_S = 1.0
#: The step up's turn is no faster than Spin's default, rad/s.
_TURN_MAX_RADPS = 0.8


class ConfirmTarget(SemExpBehaviour):
    READS = (
        "arbitration",
        "scene_evidence",
        "observation",
        "instruction",
        "target_label",
        "found_objects",
        "memory",
        "local_map",
        "subgoal",
    )
    WRITES = ("found_objects", "memory", "cmd_twist", "cmd_stamp_s")

    confirm_radius_m: float = param(
        "float",
        doc="the target must lie this close to the robot, m (the success radius r_s: a declared "
        "success is a real one)",
        default=1.0,
        gt=0.0,
    )
    declare_margin_m: float = param(
        "float",
        doc="the mean of the votes must lie this much inside confirm_radius_m to declare, m (the mean of "
        "a few views is still off by a few centimetres)",
        default=0.05,
        ge=0.0,
    )
    vote_slack_m: float = param(
        "float",
        doc="a single view may place the target this much beyond confirm_radius_m and still vote, m "
        "(the mean of the votes must lie within confirm_radius_m)",
        default=0.3,
        ge=0.0,
    )
    min_score: float = param(
        "float",
        doc="least raw posterior score S(t*) of a confirming view (C_f is 1 for a lone candidate, "
        "so an absolute level is needed too)",
        default=0.05,
        ge=0.0,
        le=1.0,
    )
    extra_views: int = param(
        "int", doc="further views that must vote for the target before success", default=3, ge=0, le=10
    )
    max_extra_views: int = param(
        "int",
        doc="most further views taken to collect ``extra_views`` votes (at least ``extra_views``; 8 since "
        "session 33: from close by a real goal votes in about a third of the views, docs/executive.md)",
        default=8,
        ge=0,
        le=20,
    )
    first_vote_views: int = param(
        "int",
        doc="at a memory node of the instructed object in view, views taken until one votes, the step's own "
        "included (1: the step's view only, as before session 36)",
        default=4,
        ge=1,
        le=10,
    )
    consistency_radius_m: float = param(
        "float", doc="agreeing views place the target within this distance, m", default=0.8, gt=0.0
    )
    align_threshold: float = param(
        "float",
        doc="relevance at which a label counts as the instructed object (0.9: the instructed label or a synonym; "
        "a partial match such as 'shelf' for 'bucket shelf' is a distractor, never a success)",
        default=NAMES_OBJECT_RELEVANCE,
        ge=0.0,
        le=1.0,
    )
    reject_potential_factor: float = param(
        "float",
        doc="potential scale of an aligned node that failed (0.5: a second failed visit puts it "
        "under the decision's tau_p)",
        default=0.5,
        ge=0.0,
        le=1.0,
    )
    min_label_agreement: float = param(
        "float",
        doc="least share of the object names recorded at the target's spot, over the mission, that "
        "name the instructed object (0: no label-agreement check)",
        default=0.7,
        ge=0.0,
        le=1.0,
    )
    label_agreement_radius_m: float = param(
        "float",
        doc="names recorded this close to the target's point count toward the agreement, m",
        default=0.5,
        gt=0.0,
    )
    same_object_share: float = param(
        "float",
        doc="in a view where the detector boxed the target, a name the VLM gave counts toward the "
        "agreement only if at least this share of its region lies inside one of those boxes (0: every "
        "name near the target's point counts)",
        default=0.3,
        ge=0.0,
        le=1.0,
    )
    reject_radius_m: float = param(
        "float",
        doc="only aligned nodes this close to the robot and inside the camera's view are "
        "lowered on a failed confirmation, m",
        default=1.2,
        gt=0.0,
    )

    face_tolerance_deg: float = param(
        "float",
        doc="before the further views, turn until the first vote is this close to straight ahead, degrees "
        "(180: never turn)",
        default=10.0,
        gt=0.0,
        le=180.0,
    )
    approach_to_m: float = param(
        "float",
        doc="then walk straight at the first vote until it is this far away, m (0: stay where the view was "
        "taken)",
        default=0.7,
        ge=0.0,
    )
    view_from_m: float = param(
        "float",
        doc="take the further views first with the first vote about this far away (walking up to it or "
        "backing away), m, and a second set from close by only if those fall short (0, the default: views "
        "from close by only; 1.0 measured worse on Table III, docs/executive.md)",
        default=0.0,
        ge=0.0,
    )
    approach_speed_mps: float = param(
        "float", doc="walking speed of the step up, m/s", default=0.2, gt=0.0, le=0.5
    )
    approach_timeout_s: float = param(
        "float", doc="the step up (turn and walk) ends after this long, s", default=8.0, gt=0.0
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        if self.approach_to_m >= self._declare_within_m:
            raise ValueError(
                f"{name}: approach_to_m ({self.approach_to_m}) must be less than confirm_radius_m "
                f"- declare_margin_m ({self._declare_within_m})"
            )
        if self.view_from_m > 0.0 and not (
            self.approach_to_m < self.view_from_m <= self.confirm_radius_m + self.vote_slack_m
        ):
            raise ValueError(
                f"{name}: view_from_m ({self.view_from_m}) must lie beyond approach_to_m "
                f"({self.approach_to_m}) and within confirm_radius_m + vote_slack_m "
                f"({self.confirm_radius_m + self.vote_slack_m})"
            )
        if self.max_extra_views < self.extra_views:
            raise ValueError(
                f"{name}: max_extra_views ({self.max_extra_views}) must be at least extra_views "
                f"({self.extra_views})"
            )
        #: (x, y, names the target) for every object name heard near the robot, over the mission.
        self._names: list[tuple[float, float, bool]] = []
        #: The label the first view voted for (None until it has), and every voting position, first first.
        self._label: str | None = None
        self._vote_points: list[np.ndarray] = []
        self._first_boxed = self._boxed = False
        self._views = 0
        #: Whether it is still looking for a first vote (the step's own view had none), and how many
        #: views it took for one so far, the step's included.
        self._seeking = False
        self._seeking_views = 0
        self._job: PerceptionJob | None = None
        #: Whether the views are still those from afar (before the step up), and whether it steps up to
        #: declare on votes from afar.
        self._from_afar = False
        self._declaring = False
        #: How far from the robot the first vote lay, m (the refusal and confirmation events say it).
        self._first_vote_m = 0.0
        #: Whether it is still turning or stepping up, and since when (robot clock); whether it backs away.
        self._stepping = False
        self._backing = False
        self._step_started_s = 0.0
        self._moved = False
        self._stopped_s = 0.0

    def initialise(self) -> None:
        self._label = None
        self._views = 0
        self._seeking = False
        self._seeking_views = 0
        self._vote_points = []
        self._boxed = False
        self._job = None
        self._from_afar = False
        self._declaring = False
        self._stepping = False
        self._moved = False

    @property
    def _votes(self) -> int:
        """Further views that agreed with the first (the first view's own vote is not counted)."""
        return max(0, len(self._vote_points) - 1)

    def _aligned(self, label: str) -> bool:
        return self.names_instructed_object(label, threshold=self.align_threshold)

    def _vote(
        self,
        arbitration: ArbitrationResult | None,
        scene: SceneEvidence | None,
        observation: Observation | None,
    ) -> Vote | None:
        """The label and world position of the best candidate in this view that votes for the target
        (see the module docstring), and whether a detector box is among the voting candidates; or None."""
        if arbitration is None or observation is None:
            return None
        pose = self.services.robot.base_pose()
        patch = self.services.config.arbitration.depth_patch_px

        def nearby_point(
            pixel: tuple[float, float], box: tuple[float, float, float, float] | None
        ) -> np.ndarray | None:
            point = locate_in_view(observation, pixel, box, patch)
            if point is None:
                return None
            reach = self.confirm_radius_m + self.vote_slack_m
            if math.hypot(point[0] - pose.x_m, point[1] - pose.y_m) > reach:
                return None
            return point

        best: tuple[float, str, np.ndarray] | None = None
        boxed = False
        named_proposals: set[int] = set()
        target_boxes = [
            c.box_xyxy_px
            for c in arbitration.candidates
            if c.kind != "direction" and c.box_xyxy_px is not None and self._aligned(c.label)
        ]

        def about_another_object(region: tuple[float, float, float, float] | None) -> bool:
            # A name whose region lies off every box the detector put on the target in this view names a
            # neighbour, not the target: it says nothing of what the target is.
            if region is None or not target_boxes or self.same_object_share <= 0.0:
                return False
            return max(box_share_inside(region, box) for box in target_boxes) < self.same_object_share

        for candidate in arbitration.candidates:
            if candidate.kind == "direction":
                continue
            aligned = self._aligned(candidate.label)
            if aligned and candidate.score < self.min_score:
                continue
            point = nearby_point(candidate.pixel_px, candidate_box(candidate, scene))
            if point is None:
                continue
            # A prompted detector labels every box with the prompt, so only the VLM's own name for the
            # object says what it is: a detection-only candidate leaves no name, a fused one the name
            # of its scene proposal.
            if scene is not None and candidate.proposal_index is not None:
                named_proposals.add(candidate.proposal_index)
                proposal = scene.proposals[candidate.proposal_index]
                if not about_another_object(proposal.region_px):
                    self._names.append((float(point[0]), float(point[1]), self._aligned(proposal.label)))
            if aligned:
                boxed = boxed or candidate.has_box
                if best is None or candidate.score > best[0]:
                    best = (candidate.score, candidate.label, point)
        if scene is not None:
            # Names the VLM gave that no candidate carries (the arbitration keeps only target-like labels).
            for index, proposal in enumerate(scene.proposals):
                if proposal.kind != "object" or index in named_proposals:
                    continue
                point = nearby_point(proposal.point_px, proposal.region_px)
                if point is not None and not about_another_object(proposal.region_px):
                    self._names.append((float(point[0]), float(point[1]), self._aligned(proposal.label)))
        return None if best is None else (best[1], best[2], boxed)

    def _label_agreement(self, point: np.ndarray) -> tuple[int, int]:
        """(names of the target, all names) recorded within ``label_agreement_radius_m`` of ``point``."""
        near = [
            names_target
            for x, y, names_target in self._names
            if math.hypot(x - point[0], y - point[1]) <= self.label_agreement_radius_m
        ]
        return sum(near), len(near)

    def _reject(self, why: str, cause: str | None = None) -> py_trees.common.Status:
        """Fail with ``why`` as feedback; once a label had a first vote, log the refusal with its ``cause``
        (one of :data:`REFUSAL_CAUSES`)."""
        memory = self.read("memory")
        pose = self.services.robot.base_pose()
        # Only a node the robot stands next to and looked at is evidence against itself: a target node
        # behind the robot, or seen from afar, was simply not in this view and keeps its potential.
        for node_id in self._target_nodes_in_view(self.read("observation")):
            memory.scale_potential(node_id=node_id, factor=self.reject_potential_factor)
        self.feedback_message = why
        if self._label is not None:
            # Where the first vote placed the target and where the robot stood: a sweep's rows then say
            # whether the refused object was the goal (seen badly) or a distractor, without a rerun.
            self.services.log_event(
                "confirmation_rejected",
                reason=why,
                cause=cause,
                position_m=[round(float(v), 3) for v in self._vote_points[0]],
                robot_xy=[round(pose.x_m, 3), round(pose.y_m, 3)],
                first_vote_m=self._first_vote_m,
            )
        return py_trees.common.Status.FAILURE

    def _target_nodes_in_view(self, observation: Observation | None) -> list[int]:
        """Memory nodes of the instructed object within ``reject_radius_m`` of the robot and in ``observation``."""
        if observation is None:
            return []
        memory = self.read("memory")
        pose = self.services.robot.base_pose()
        nodes = []
        for node_id in memory.within_radius(
            position_m=(pose.x_m, pose.y_m, 0.0), radius_m=self.reject_radius_m
        ):
            state = memory.node(node_id)
            if not state.is_master and self._aligned(state.label) and _in_view(state.position_m, observation):
                nodes.append(node_id)
        return nodes

    def _came_to_look(self, observation: Observation | None) -> bool:
        """Whether the robot walked to a node of the instructed object and stands at it, the node in view:
        the subgoal it went to is among :meth:`_target_nodes_in_view` (so a robot held elsewhere does not
        look again at every step at a node it merely stands near)."""
        subgoal = self.read("subgoal")
        return (
            self.first_vote_views > 1
            and subgoal is not None
            and subgoal.node_id in self._target_nodes_in_view(observation)
        )

    def _start_confirmation(self, vote: Vote) -> None:
        """Take ``vote`` as the first: the further views count toward it."""
        self._label, first_point, self._first_boxed = vote
        self._vote_points, self._boxed = [first_point], self._first_boxed
        self._first_vote_m = round(self._distance_to(first_point), 2)
        self._from_afar = self.view_from_m > 0.0
        self._start_moving()

    def _look_for_first_vote(self) -> py_trees.common.Status:
        """Another view at a node of the instructed object, until one votes or ``first_vote_views`` are spent."""
        judged, vote = self._next_view(
            f"looking again for the instructed object: view {self._seeking_views + 1} of at most "
            f"{self.first_vote_views}"
        )
        if not judged:
            return py_trees.common.Status.RUNNING
        self._seeking_views += 1
        if vote is not None:
            self._seeking = False
            self._start_confirmation(vote)
            return py_trees.common.Status.RUNNING
        if self._seeking_views >= self.first_vote_views:
            self.services.log_event("first_vote_missed", views=self._seeking_views)
            return self._reject(f"no confirmable target in {self._seeking_views} views")
        return py_trees.common.Status.RUNNING

    def _next_view(self, feedback: str) -> tuple[bool, Vote | None]:
        """Take the next view: observe and submit it (saying ``feedback``), then wait for its reply;
        ``(True, its vote)`` once the reply is judged, ``(False, None)`` while it is pending."""
        if self._job is None:
            self._observation = self.services.robot.observe()
            self._job = self.submit_view(self._observation)
            self.feedback_message = feedback
            return False, None
        result = self._job.poll(now_s=self.now_s())
        if result is None:
            return False, None
        self._job = None
        return True, self._judge(result, self._observation)

    def _judge(self, result: PerceptionResult, observation: Observation) -> Vote | None:
        """Arbitrate a perception reply on its own view and return that view's vote (see :meth:`_vote`)."""
        result = screen_result(result)  # a reply that is not evidence is missing, not used
        for error in result.errors:
            self.services.log_event("perception_error", message=error)
        arbitration = arbitrate(
            scene=result.scene,
            detections=result.detections,
            is_aligned=self._aligned,
            config=self.services.config.arbitration,
            depth_m=observation.depth_m,
            image_size=(observation.intrinsics.width_px, observation.intrinsics.height_px),
        )
        return self._vote(arbitration, result.scene, observation)

    def update(self) -> py_trees.common.Status:
        if self._label is None and not self._seeking:
            observation = self.read("observation")
            vote = self._vote(self.read("arbitration"), self.read("scene_evidence"), observation)
            if vote is None:
                if not self._came_to_look(observation):
                    return self._reject("no confirmable target here")
                self._seeking, self._seeking_views = True, 1
            else:
                self._start_confirmation(vote)
        if self._seeking:
            return self._look_for_first_vote()
        if self._votes >= self.extra_views and self._from_afar:
            self._from_afar, self._declaring = False, True  # the votes are in: step up to declare
            self._start_moving()
        if self._stepping:
            if self._from_afar:
                moving = self._move_to(self._vote_points[0], self.view_from_m, may_back_up=True)
            else:
                moving = self._move_to(self._step_up_point(), self.approach_to_m, may_back_up=False)
            if moving:
                return py_trees.common.Status.RUNNING
            self._stepping = False
            self._stopped_s = self.now_s()
            if self._moved:
                self.command(Twist.zero())
        if self._declaring and not self._stepping:
            self._declaring = False
            if self._distance_to(self._step_up_point()) > self.approach_to_m + _DECLARE_SLACK_M:
                # Stopped short (blocked, or out of time): the votes from afar do not say that the object
                # is within r_s of where it now stands, so it looks again from here.
                self.services.log_event("confirmation_looks_again", votes=self._votes, views=self._views)
                self._restart_votes()
        if self._votes >= self.extra_views:
            return self._succeed()
        if self._moved and not self._standing_still():
            return py_trees.common.Status.RUNNING  # a view from a moving base would be blurred
        where = "from afar" if self._from_afar else "from close by"
        judged, vote = self._next_view(
            f"confirming {self._label!r} {where}: {self._votes}/{self.extra_views} votes, "
            f"view {self._views + 1} of at most {self.max_extra_views}"
        )
        if not judged:
            return py_trees.common.Status.RUNNING
        self._views += 1
        if (
            vote is not None
            and np.linalg.norm(vote[1][:2] - self._vote_points[0][:2]) <= self.consistency_radius_m
        ):
            self._vote_points.append(vote[1])
            self._boxed = self._boxed or vote[2]
        if self._votes >= self.extra_views:
            if self._from_afar:
                return py_trees.common.Status.RUNNING  # next tick: the step up to declare
            return self._succeed()
        if self._votes + (self.max_extra_views - self._views) < self.extra_views:
            if self._from_afar and self._votes > 0 and self._beyond_step_up(self._vote_points[0]):
                self.services.log_event("confirmation_steps_closer", votes=self._votes, views=self._views)
                self._from_afar = False  # the second standpoint: close by, its views counted afresh
                self._restart_votes()
                self._start_moving()
                return py_trees.common.Status.RUNNING
            return self._reject(
                f"only {self._votes} of {self._views} further views confirmed {self._label!r}",
                "too_few_views",
            )
        return py_trees.common.Status.RUNNING

    def _start_moving(self) -> None:
        self._stepping, self._step_started_s, self._backing = True, self.now_s(), False

    def _restart_votes(self) -> None:
        """Count the further views afresh (the first vote stays the reference)."""
        self._vote_points, self._views, self._boxed = self._vote_points[:1], 0, self._first_boxed

    @property
    def _declare_within_m(self) -> float:
        """How close the votes' mean must be to declare: r_s less the margin, m."""
        return self.confirm_radius_m - self.declare_margin_m

    def _distance_to(self, point: np.ndarray) -> float:
        """The base's distance to ``point`` in the ground plane, m."""
        pose = self.services.robot.base_pose()
        return math.hypot(float(point[0]) - pose.x_m, float(point[1]) - pose.y_m)

    def _beyond_step_up(self, point: np.ndarray) -> bool:
        """Whether ``point`` is farther than the step up would leave it (so a step up would move the robot)."""
        return self.approach_to_m > 0.0 and self._distance_to(point) > self.approach_to_m + _APPROACH_SLACK_M

    def _step_up_point(self) -> np.ndarray:
        """Where the step up heads: the first vote's point, or the votes' mean once further views voted."""
        if len(self._vote_points) > 1:
            return np.mean(self._vote_points, axis=0)
        return self._vote_points[0]

    def _move_to(self, point: np.ndarray, distance_m: float, *, may_back_up: bool) -> bool:
        """Command the next motion toward ``distance_m`` from ``point``: turn to face it, then walk straight
        at it (or, if ``may_back_up``, back straight away from it); False once there, when the next motion
        would not pass the costmap's checks, or when time is up."""
        costmap = self.read("local_map")
        if costmap is None or has_elapsed(
            since_s=self._step_started_s, now_s=self.now_s(), duration_s=self.approach_timeout_s
        ):
            return False
        pose = self.services.robot.base_pose()
        dx, dy = float(point[0]) - pose.x_m, float(point[1]) - pose.y_m
        bearing = wrap_angle(math.atan2(dy, dx) - pose.yaw_rad)
        distance = math.hypot(dx, dy)
        gap = distance - distance_m  # > 0: too far, < 0: too close
        speed = min(self.approach_speed_mps, max(0.05, abs(gap)))
        if abs(bearing) > math.radians(self.face_tolerance_deg):
            rate = turn_rate_toward(bearing, max_radps=_TURN_MAX_RADPS)
            twist, doing = Twist(angular_z_radps=rate), "turning to face"
        elif distance_m > 0.0 and gap > _APPROACH_SLACK_M:
            twist = Twist(linear_x_mps=speed, angular_z_radps=float(np.clip(1.5 * bearing, -0.3, 0.3)))
            doing = "walking up to"
        elif may_back_up and -gap > (_APPROACH_SLACK_M if self._backing else _BACK_UP_SLACK_M):
            twist, doing = Twist(linear_x_mps=-speed), "backing away from"
            self._backing = True
        else:
            return False
        if not motion_is_admissible(costmap, pose, twist, duration_s=_STEP_LOOKAHEAD_S):
            return False
        self.command(twist)
        self._moved = True
        self.feedback_message = f"{doing} {self._label!r}, {distance:.2f} m away"
        return True

    def _standing_still(self) -> bool:
        if has_elapsed(since_s=self._stopped_s, now_s=self.now_s(), duration_s=_SETTLE_S):
            return True
        twist = self.services.robot.base_twist()
        return (
            math.hypot(twist.linear_x_mps, twist.linear_y_mps) < _STILL_MPS
            and abs(twist.angular_z_radps) < _STILL_RADPS
        )

    def _succeed(self) -> py_trees.common.Status:
        label = self._label
        pose = self.services.robot.base_pose()
        point = np.mean(self._vote_points, axis=0)
        reach = self._distance_to(point)
        if reach > self._declare_within_m:
            return self._reject(
                f"{label!r} has the votes, but its mean position is {reach:.2f} m away", "mean_beyond_radius"
            )
        if not self._boxed:
            return self._reject(
                f"{label!r} has the votes, but the detector boxed it in none of them", "no_detector_box"
            )
        agreeing, heard = self._label_agreement(point)
        if heard and agreeing < self.min_label_agreement * heard:
            return self._reject(
                f"{label!r} has the votes, but only {agreeing} of {heard} names heard at its spot name it",
                "label_agreement",
            )
        found = list(self.read("found_objects", []))
        found.append(
            {
                "label": label,
                "instruction": self.read("instruction"),
                "robot_xy": [round(pose.x_m, 3), round(pose.y_m, 3)],
                "position_m": [round(float(v), 3) for v in point],
                "stamp_s": round(self.now_s(), 3),
            }
        )
        self.write("found_objects", found)
        self.services.log_event(
            "target_confirmed",
            label=label,
            position_m=found[-1]["position_m"],
            first_vote_m=self._first_vote_m,
        )
        self.feedback_message = f"confirmed {label!r} at {found[-1]['position_m']}"
        return py_trees.common.Status.SUCCESS

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if self._stepping and self._moved:
            self.command(Twist.zero())
        self._stepping = False
        if self._job is not None:
            self._job.cancel()
            self._job = None
