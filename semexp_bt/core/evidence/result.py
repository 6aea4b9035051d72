"""What arbitration returns: every candidate with its terms, and the selected target.

This is a core module: standard library and ``semexp_bt`` core modules only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

from semexp_bt.core.types import Target

CandidateSource = Literal["fused", "object", "scene"]
TargetKind = Literal["object", "direction"]


class ScoredCandidate(NamedTuple):
    """One arbitration candidate with every term of Eq. 2 and where it came from.

    An immutable named tuple rather than a frozen dataclass: ``arbitrate`` builds one per candidate on
    every perception event, and a frozen dataclass costs three times as much to construct.

    Attributes:
        source: ``"fused"`` (aligned detection + associated scene proposal), ``"object"`` (detection
            only) or ``"scene"`` (scene proposal only).
        kind: ``"direction"`` for a scene proposal of an unexplored direction, else ``"object"``.
        label: the candidate's label (the detection's label for ``"fused"``).
        pixel_px: location p_t (Eq. 4 for ``"fused"``, else the available point).
        score: raw S(t) of Eq. 2.
        normalised_score: S(t) / sum S; these sum to 1 over the candidates (all 0 when every S is 0).
        prior: P(t).
        calibrated_object_confidence: C~_o(t), None without a detection.
        calibrated_scene_confidence: C~_s(t), None without a scene proposal.
        object_weight: w of Eq. 4, only for ``"fused"``.
        iou: IoU(r_s, b) of the association, only for ``"fused"``.
        kappa: depth feasibility kappa_t in [0, 1], None when no depth image was given.
        depth_m: robust depth at ``pixel_px``, None without a depth image or without valid depth there.
        object_pixel_px: p_o (centre of the clipped detection box), None without a detection.
        scene_pixel_px: p_s (the proposal's point, clipped to the image), None without a proposal.
        box_xyxy_px: the detection box (clipped to the image when its size is known).
        region_px: the scene region r_s (see ``semexp_bt.core.evidence.scene_region``).
        detection_index: index into ``detections``, None without a detection.
        proposal_index: index into ``scene.proposals``, None without a proposal.
    """

    source: CandidateSource
    kind: TargetKind
    label: str
    pixel_px: tuple[float, float]
    score: float
    normalised_score: float
    prior: float
    calibrated_object_confidence: float | None
    calibrated_scene_confidence: float | None
    object_weight: float | None
    iou: float | None
    kappa: float | None
    depth_m: float | None
    object_pixel_px: tuple[float, float] | None
    scene_pixel_px: tuple[float, float] | None
    box_xyxy_px: tuple[float, float, float, float] | None
    region_px: tuple[float, float, float, float] | None
    detection_index: int | None
    proposal_index: int | None

    @property
    def has_box(self) -> bool:
        """Whether a detector box stands behind the candidate (source ``fused`` or ``object``): the
        evidence the VLM's repeated confusions cannot give alone."""
        return self.detection_index is not None


@dataclass(frozen=True, slots=True)
class ArbitrationResult:
    """The outcome of ``arbitrate``.

    Attributes:
        target: the selected target (p_t, L_t, C_f), or None when there is no candidate or every score is 0.
        candidates: every candidate in tie-break order: detection-derived candidates (fused or object) by
            detection index, then scene-only candidates by proposal index.
        reason: one human-readable sentence explaining the decision.
        winner_index: index of the selected candidate in ``candidates``, or None.
    """

    target: Target | None
    candidates: tuple[ScoredCandidate, ...]
    reason: str
    winner_index: int | None = None

    @property
    def winner(self) -> ScoredCandidate | None:
        """The selected candidate with its full provenance, or None."""
        return None if self.winner_index is None else self.candidates[self.winner_index]
