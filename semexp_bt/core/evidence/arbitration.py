"""``arbitrate``: one view's scene-level and object-level evidence into one target (paper Eq. 1-4).

It composes the three steps: the candidates (:mod:`.candidates`: Eq. 1 and the association), their
locations (:mod:`.fuse`: Eq. 4), their scores (:mod:`.score`: Eq. 2 with kappa) and the selection
(:mod:`.fuse`: Eq. 3), and reports every candidate with its terms.

This is a core module: standard library, numpy and ``semexp_bt`` core modules only.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from semexp_bt.core.config import ArbitrationConfig
from semexp_bt.core.evidence.candidates import (
    CandidateTable,
    associate,
    candidate_table,
    check_tau,
    read_object_evidence,
    read_scene_evidence,
    resolve_image_size,
)
from semexp_bt.core.evidence.fuse import Selection, fuse_locations, select
from semexp_bt.core.evidence.result import ArbitrationResult, ScoredCandidate
from semexp_bt.core.evidence.score import Scores, candidate_priors, confidence_terms, score_candidates
from semexp_bt.core.types import (
    Detection,
    FloatArray,
    InvalidInputError,
    SceneEvidence,
    Target,
    require_finite,
)


def arbitrate(
    *,
    scene: SceneEvidence | None,
    detections: Sequence[Detection] | None,
    is_aligned: Callable[[str], bool],
    config: ArbitrationConfig,
    depth_m: npt.ArrayLike | None = None,
    image_size: tuple[int, int] | None = None,
    prior: Callable[[str], float] | None = None,
) -> ArbitrationResult:
    """Arbitrate scene-level and object-level evidence into one target (paper Eq. 1-4).

    Candidates are (i) detections whose label is aligned with the instruction and (ii) scene proposals
    of kind ``"direction"`` plus aligned scene ``"object"`` proposals that no detection absorbed. Each
    aligned detection is associated with at most one aligned scene object proposal by greedy maximum
    IoU (IoU > 0) between the detection box and the proposal's scene region; an associated pair is one
    ``"fused"`` candidate carrying the detection's label. Direction proposals never associate: they
    assert unexplored space, not an object, and stay candidates of their own.

    Eq. 2 scores ``S = P * C~_o^beta_o * C~_s^beta_s * (IoU + eps)^lambda * (kappa + eps)^mu``, omitting
    the terms whose source is missing (no C~_s and no IoU for a detection alone; no C~_o and no IoU for
    a proposal alone; no kappa without a depth image). Eq. 3 selects the maximum; ties (within
    ``TIE_RELATIVE_TOLERANCE``) go to the earliest candidate in :attr:`ArbitrationResult.candidates`
    order, i.e. detection-derived before scene-only, then by input index. Eq. 4 fuses the location of a
    fused candidate.

    Args:
        scene: the VLM's evidence for this view, or None when the scene source is missing.
        detections: open-vocabulary detections (may be empty), or None when the object-level source is
            missing (disabled or failed) for this view.
        is_aligned: whether a label matches the instruction (called once per distinct label).
        config: the hyperparameters of Eq. 1-2 and the depth-feasibility rule.
        depth_m: optional ``(H, W)`` depth image in metres; NaN/inf/0 pixels are holes.
        image_size: optional ``(width, height)``; taken from ``depth_m`` when that is given. With an image
            size, boxes, regions and points are clipped to the image, so every output pixel lies on it.
        prior: optional P(t) from the candidate's label, finite and >= 0; defaults to 1.

    Returns:
        An :class:`ArbitrationResult`; its ``target`` is None when there is no candidate or every S is 0.

    Raises:
        InvalidInputError: a NaN/inf/out-of-range confidence, a malformed or inverted box or region, a
            NaN/inf point, an unknown proposal kind, a bad prior value, an image size that disagrees with
            the depth image, or an invalid config; the message names the field.
    """
    _check_config(config)
    depth = None if depth_m is None else np.asarray(depth_m)
    size = resolve_image_size(image_size, depth)
    aligned = _memoised(is_aligned)
    objects = read_object_evidence(detections, config.tau, size, aligned)
    scene_view = read_scene_evidence(scene, config, size, aligned)
    table = candidate_table(objects, scene_view, associate(objects, scene_view))
    if table is None:
        return _no_candidates(len(objects.detections), None if scene is None else len(scene_view.proposals))
    terms = confidence_terms(table, config)
    weights, pixels = fuse_locations(table, terms)
    scores = score_candidates(
        table,
        terms,
        candidate_priors(table, prior),
        pixels,
        depth,
        scene_confidence=scene_view.confidence,
        detector_present=objects.present,
        config=config,
    )
    selection = select(scores.score)
    candidates = _scored_candidates(table, scene_view.confidence, weights, pixels, scores, selection)
    return _result(candidates, selection, config.tau)


@functools.lru_cache(maxsize=32)
def _check_config(config: ArbitrationConfig) -> None:
    """Validate the fields arbitration uses (a config built in code bypasses the YAML loader's checks)."""
    check_tau("config.tau", config.tau)
    for name in ("beta_o", "beta_s", "lambda_iou", "mu", "depth_min_m", "depth_max_m", "occluder_margin_m"):
        value = getattr(config, name)
        require_finite(f"config.{name}", value)
        if value < 0.0:
            raise InvalidInputError(f"config.{name} must be non-negative, got {value!r}")
    require_finite("config.epsilon", config.epsilon)
    if config.epsilon <= 0.0:
        raise InvalidInputError(f"config.epsilon must be positive, got {config.epsilon!r}")
    require_finite("config.scene_region_half_size_px", config.scene_region_half_size_px)
    if config.scene_region_half_size_px < 0.0:
        raise InvalidInputError("config.scene_region_half_size_px must be non-negative")
    if config.depth_patch_px < 1:
        raise InvalidInputError(f"config.depth_patch_px must be at least 1, got {config.depth_patch_px!r}")


def _memoised(is_aligned: Callable[[str], bool]) -> Callable[[str], bool]:
    """``is_aligned`` called at most once per distinct label of one view."""
    alignment: dict[str, bool] = {}

    def aligned(label: str) -> bool:
        if label not in alignment:
            alignment[label] = bool(is_aligned(label))
        return alignment[label]

    return aligned


def _no_candidates(n_detections: int, n_proposals: int | None) -> ArbitrationResult:
    """The result of a view with no candidate (``n_proposals`` None: no scene evidence)."""
    scene_part = (
        "there is no scene evidence"
        if n_proposals is None
        else f"none of {n_proposals} scene proposal(s) is a direction or aligned"
    )
    return ArbitrationResult(
        target=None,
        candidates=(),
        reason=(
            f"no candidates: none of {n_detections} detection(s) is aligned with the instruction and "
            f"{scene_part}"
        ),
    )


def _scored_candidates(
    table: CandidateTable,
    scene_confidence: float | None,
    weights: FloatArray,
    pixels: FloatArray,
    scores: Scores,
    selection: Selection,
) -> tuple[ScoredCandidate, ...]:
    """One :class:`ScoredCandidate` per row of the table, with every term that applies to it."""
    n_cand = len(table.labels)
    # One bulk conversion to Python objects: indexing numpy arrays element by element costs more than
    # the whole vectorised scoring.
    score_l, norm_l, prior_l = scores.score.tolist(), selection.normalised.tolist(), scores.priors.tolist()
    co_l, weight_l, iou_l = table.object_confidence.tolist(), weights.tolist(), scores.iou.tolist()
    kappa_l: list[float | None] = [None] * n_cand if scores.kappa is None else scores.kappa.tolist()
    depth_l: list[float | None] = [None] * n_cand
    if scores.target_depth is not None:
        depth_l = [None if math.isnan(x) else x for x in scores.target_depth.tolist()]
    pixel_l = [tuple(row) for row in pixels.tolist()]
    p_o_l = [tuple(row) for row in table.object_pixels.tolist()]
    p_s_l = [tuple(row) for row in table.scene_pixels.tolist()]
    box_l = [tuple(row) for row in table.boxes.tolist()]
    region_l = [tuple(row) for row in table.regions.tolist()]
    sources, kinds, labels = table.sources, table.kinds, table.labels
    candidates = []
    for k, (d_idx, p_idx) in enumerate(
        zip(table.detection_of.tolist(), table.proposal_of.tolist(), strict=True)
    ):
        has_det, has_prop = d_idx >= 0, p_idx >= 0
        is_fused = has_det and has_prop
        candidates.append(
            ScoredCandidate(
                source=sources[k],
                kind=kinds[k],
                label=labels[k],
                pixel_px=pixel_l[k],
                score=score_l[k],
                normalised_score=norm_l[k],
                prior=prior_l[k],
                calibrated_object_confidence=co_l[k] if has_det else None,
                calibrated_scene_confidence=scene_confidence if has_prop else None,
                object_weight=weight_l[k] if is_fused else None,
                iou=iou_l[k] if is_fused else None,
                kappa=kappa_l[k],
                depth_m=depth_l[k],
                object_pixel_px=p_o_l[k] if has_det else None,
                scene_pixel_px=p_s_l[k] if has_prop else None,
                box_xyxy_px=box_l[k] if has_det else None,
                region_px=region_l[k] if has_prop else None,
                detection_index=d_idx if has_det else None,
                proposal_index=p_idx if has_prop else None,
            )
        )
    return tuple(candidates)


def _result(candidates: tuple[ScoredCandidate, ...], selection: Selection, tau: float) -> ArbitrationResult:
    """The target of Eq. 3 (p_t, L_t, C_f) and the sentence that explains it."""
    if selection.winner is None:
        return ArbitrationResult(
            target=None,
            candidates=candidates,
            reason=(
                f"all {len(candidates)} candidate score(s) are zero (confidences at or below tau={tau:g}, "
                f"or a zero prior): no target"
            ),
        )
    best = candidates[selection.winner]
    target = Target(
        pixel_px=best.pixel_px,
        label=best.label,
        fused_confidence=min(1.0, max(0.0, best.normalised_score)),
        source=best.source,
        kind=best.kind,
        depth_m=best.depth_m,
    )
    reason = (
        f"selected {best.source} {best.kind} candidate {best.label!r} at "
        f"({best.pixel_px[0]:.1f}, {best.pixel_px[1]:.1f}) px: S={selection.best_score:.4g}, "
        f"C_f={target.fused_confidence:.3f} among {len(candidates)} candidate(s)"
    )
    return ArbitrationResult(
        target=target, candidates=candidates, reason=reason, winner_index=selection.winner
    )
