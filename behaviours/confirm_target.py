"""ConfirmTarget: declare the goal found only on consistent, calibrated evidence from close by.

Semantics: reads the last ``target``. If it is instruction-aligned (relevance >= ``align_threshold``),
its fused confidence C_f reaches ``min_fused_confidence``, its raw posterior score S(t*) reaches
``min_score``, and its back-projected position lies within
``confirm_radius_m`` of the robot, the behaviour asks for ``extra_views`` more perceptions from the
same stable viewpoint (RUNNING while the models think) and re-arbitrates each; it returns SUCCESS,
appending the object to ``found_objects``, only if every extra view confirms a target of the same label
within ``consistency_radius_m`` of the first. Otherwise FAILURE; when the robot stands at an aligned
memory node that failed confirmation, that node's exploration potential is scaled by
``reject_potential_factor`` so the decision does not send the robot straight back (a distractor that
fooled the detector once is not trusted twice).

Example:
    - type: ConfirmTarget
      name: Confirm
      params: {confirm_radius_m: 1.0, extra_views: 2, min_fused_confidence: 0.3}
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.evidence import arbitrate
from semexp_bt.geometry import back_project, robust_depth
from semexp_bt.perception import PerceptionJob


def _in_view(point_m: tuple[float, float, float], observation) -> bool:
    """Whether a world point projects inside the observation's image, in front of the camera."""
    world_to_camera = np.linalg.inv(np.asarray(observation.camera_to_world, dtype=float))
    x, y, z = world_to_camera[:3, :3] @ np.asarray(point_m, dtype=float) + world_to_camera[:3, 3]
    if z <= 0.0:
        return False
    k = observation.intrinsics
    u, v = k.fx_px * x / z + k.cx_px, k.fy_px * y / z + k.cy_px
    return 0.0 <= u < k.width_px and 0.0 <= v < k.height_px


class ConfirmTarget(SemExpBehaviour):
    READS = ("arbitration", "observation", "instruction", "target_label", "found_objects", "memory")
    WRITES = ("found_objects", "memory")
    PARAMS = {
        "confirm_radius_m": ParamSpec(
            "float", doc="the target must lie this close to the robot, m", default=1.0, gt=0.0
        ),
        "min_score": ParamSpec(
            "float",
            doc="least raw posterior score S(t*) of a confirming view (C_f is 1 for a lone candidate, "
            "so an absolute level is needed too)",
            default=0.1,
            ge=0.0,
            le=1.0,
        ),
        "min_fused_confidence": ParamSpec(
            "float",
            doc="least fused confidence C_f of a confirming view (C_f is shared with the view's "
            "direction candidates, so it is a relative check; min_score is the absolute one)",
            default=0.3,
            ge=0.0,
            le=1.0,
        ),
        "extra_views": ParamSpec(
            "int", doc="further views that must agree before success", default=2, ge=0, le=10
        ),
        "consistency_radius_m": ParamSpec(
            "float", doc="agreeing views place the target within this distance, m", default=0.8, gt=0.0
        ),
        "align_threshold": ParamSpec(
            "float",
            doc="relevance at which a label counts as the instructed object (0.9: the instructed label or a synonym; "
            "a partial match such as 'shelf' for 'bucket shelf' is a distractor, never a success)",
            default=0.9,
            ge=0.0,
            le=1.0,
        ),
        "reject_potential_factor": ParamSpec(
            "float", doc="potential scale of an aligned node that failed", default=0.2, ge=0.0, le=1.0
        ),
        "reject_radius_m": ParamSpec(
            "float",
            doc="only aligned nodes this close to the robot and inside the camera's view are "
            "lowered on a failed confirmation, m",
            default=1.2,
            gt=0.0,
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        confirm_radius_m: float = 1.0,
        min_score: float = 0.1,
        min_fused_confidence: float = 0.3,
        extra_views: int = 2,
        consistency_radius_m: float = 0.8,
        align_threshold: float = 0.9,
        reject_potential_factor: float = 0.2,
        reject_radius_m: float = 1.2,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.confirm_radius_m = confirm_radius_m
        self.min_fused_confidence = min_fused_confidence
        self.min_score = min_score
        self.extra_views = extra_views
        self.consistency_radius_m = consistency_radius_m
        self.align_threshold = align_threshold
        self.reject_potential_factor = reject_potential_factor
        self.reject_radius_m = reject_radius_m
        self._first: tuple[str, np.ndarray] | None = None
        self._confirmations = 0
        self._job: PerceptionJob | None = None

    def initialise(self) -> None:
        self._first = None
        self._confirmations = 0
        self._job = None

    def _aligned(self, label: str) -> bool:
        return self.names_instructed_object(label, threshold=self.align_threshold)

    def _confirmable(self, arbitration, observation) -> np.ndarray | None:
        """The target's world position if it passes every check, else None."""
        target = None if arbitration is None else arbitration.target
        if target is None or observation is None or target.kind == "direction":
            return None
        if arbitration.winner.score < self.min_score:
            return None
        if not self._aligned(target.label) or target.fused_confidence < self.min_fused_confidence:
            return None
        depth = robust_depth(
            observation.depth_m, target.pixel_px, self.services.config.arbitration.depth_patch_px
        )
        if depth is None:
            return None
        point = back_project(
            pixel_px=target.pixel_px,
            depth_m=depth,
            intrinsics=observation.intrinsics,
            camera_to_world=observation.camera_to_world,
        )
        pose = self.services.robot.base_pose()
        if math.hypot(point[0] - pose.x_m, point[1] - pose.y_m) > self.confirm_radius_m:
            return None
        return point

    def _reject(self, why: str) -> py_trees.common.Status:
        memory = self.read("memory")
        observation = self.read("observation")
        pose = self.services.robot.base_pose()
        # Only a node the robot stands next to and looked at is evidence against itself: a target node
        # behind the robot, or seen from afar, was simply not in this view and keeps its potential.
        for node_id in memory.within_radius(
            position_m=(pose.x_m, pose.y_m, 0.0), radius_m=self.reject_radius_m
        ):
            state = memory.node(node_id)
            if (
                not state.is_master
                and self._aligned(state.label)
                and observation is not None
                and _in_view(state.position_m, observation)
            ):
                memory.scale_potential(node_id=node_id, factor=self.reject_potential_factor)
        self.feedback_message = why
        if self._first is not None:
            self.services.log_event("confirmation_rejected", reason=why)
        return py_trees.common.Status.FAILURE

    def update(self) -> py_trees.common.Status:
        if self._first is None:
            point = self._confirmable(self.read("arbitration"), self.read("observation"))
            if point is None:
                return self._reject("no confirmable target here")
            self._first = (self.read("arbitration").target.label, point)
            self._confirmations = 1
        if self._confirmations > self.extra_views:
            return self._succeed()
        if self._job is None:
            robot = self.services.robot
            self._observation = robot.observe()
            self._job = self.services.perception.submit(
                observation=self._observation,
                instruction=self.read("instruction"),
                target_label=self.read("target_label"),
                motion=robot.base_twist(),
                now_s=self.now_s(),
            )
            self.feedback_message = f"confirming {self._first[0]!r}: view {self._confirmations + 1}"
            return py_trees.common.Status.RUNNING
        result = self._job.poll(now_s=self.now_s())
        if result is None:
            return py_trees.common.Status.RUNNING
        self._job = None
        observation = self._observation
        arbitration = arbitrate(
            scene=result.scene,
            detections=result.detections,
            is_aligned=self._aligned,
            config=self.services.config.arbitration,
            depth_m=observation.depth_m,
            image_size=(observation.intrinsics.width_px, observation.intrinsics.height_px),
        )
        point = self._confirmable(arbitration, observation)
        if point is None or np.linalg.norm(point[:2] - self._first[1][:2]) > self.consistency_radius_m:
            return self._reject(f"view {self._confirmations + 1} did not confirm {self._first[0]!r}")
        self._confirmations += 1
        if self._confirmations > self.extra_views:
            return self._succeed()
        return py_trees.common.Status.RUNNING

    def _succeed(self) -> py_trees.common.Status:
        label, point = self._first
        found = list(self.read("found_objects", []))
        pose = self.services.robot.base_pose()
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
        self.services.log_event("target_confirmed", label=label, position_m=found[-1]["position_m"])
        self.feedback_message = f"confirmed {label!r} at {found[-1]['position_m']}"
        return py_trees.common.Status.SUCCESS

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if self._job is not None:
            self._job.cancel()
            self._job = None
