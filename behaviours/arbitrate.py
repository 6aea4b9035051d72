"""Arbitrate: confidence-calibrated evidence arbitration (paper Eq. 1-4) on the last perception.

Semantics (stateless; it never returns RUNNING, so halting it changes nothing):

- SUCCESS: always, after calling ``semexp_bt.core.evidence.arbitrate`` on the last perception. An empty
  or all-zero candidate set is a valid outcome: ``target`` is None and the reason is in the feedback.

Reads ``scene_evidence``, ``detections``, ``observation`` (its depth places the candidates) and
``instruction``; writes ``arbitration`` (every candidate with its score) and ``target`` (the winner t*
with its fused confidence C_f, or None). A label counts as instruction-aligned when its relevance to the
instruction reaches ``align_threshold``.

Example:
    - type: Arbitrate
      name: Arbitrate
      params: {align_threshold: 0.6}
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.evidence import arbitrate
from semexp_bt.core.relevance import RELATED_RELEVANCE


class Arbitrate(SemExpBehaviour):
    READS = ("scene_evidence", "detections", "observation", "instruction")
    WRITES = ("arbitration", "target")

    align_threshold: float = param(
        "float",
        doc="relevance at which a label counts as the instructed object in the arbitration (the core's "
        "RELATED_RELEVANCE: a related label is target evidence; only confirmation asks more)",
        default=RELATED_RELEVANCE,
        ge=0.0,
        le=1.0,
    )

    def is_aligned(self, label: str) -> bool:
        return self.names_instructed_object(label, threshold=self.align_threshold)

    def update(self) -> py_trees.common.Status:
        observation = self.read("observation")
        depth = observation.depth_m if observation is not None else None
        size = (observation.intrinsics.width_px, observation.intrinsics.height_px) if observation else None
        with self.timed("arbitration"):
            result = arbitrate(
                scene=self.read("scene_evidence"),
                detections=self.read("detections"),
                is_aligned=self.is_aligned,
                config=self.services.config.arbitration,
                depth_m=depth,
                image_size=size,
            )
        self.write("arbitration", result)
        self.write("target", result.target)
        target = result.target
        self.feedback_message = (
            f"t*={target.label!r} C_f={target.fused_confidence:.2f} of {len(result.candidates)}"
            if target is not None
            else f"no target: {result.reason}"
        )
        return py_trees.common.Status.SUCCESS
