"""The score of each candidate, paper Eq. 2, and its depth-feasibility term kappa.

``S = P * C~_o^beta_o * C~_s^beta_s * (IoU + eps)^lambda * (kappa + eps)^mu``, each term omitted where
its source does not cover the candidate (docs/arbitration.md says which, and the cross-source
consistency reading of a present source that does not corroborate).

This is a core module: standard library, numpy and ``semexp_bt`` core modules only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from semexp_bt.core.config import ArbitrationConfig
from semexp_bt.core.evidence.candidates import CandidateTable
from semexp_bt.core.geometry import box_depth_stats, check_box, fast_clip, in_image, patch_depth_stats
from semexp_bt.core.types import FloatArray, InvalidInputError, require_finite

# ----------------------------------------------------------------------------------------------------------
# Depth feasibility kappa
# ----------------------------------------------------------------------------------------------------------


def kappa_and_depth(
    depth: npt.NDArray[np.generic],
    pixels: FloatArray,
    boxes: FloatArray | None,
    config: ArbitrationConfig,
) -> tuple[FloatArray, FloatArray]:
    """Vectorised kappa (see :func:`depth_feasibility`) and the robust target depth (NaN where none)."""
    target_depth, valid_fraction = patch_depth_stats(depth, pixels, config.depth_patch_px)
    with np.errstate(invalid="ignore"):
        in_range = (target_depth >= config.depth_min_m) & (target_depth <= config.depth_max_m)
    occlusion = np.ones(len(pixels))
    if boxes is not None and len(boxes):
        box_depth, _ = box_depth_stats(depth, boxes)
        # gap > 0: the ray through the target pixel stops in front of the bulk of the box.
        gap = box_depth - target_depth
        margin = float(config.occluder_margin_m)
        with np.errstate(invalid="ignore"):
            if margin > 0.0:
                occlusion = fast_clip(2.0 - gap / margin, 0.0, 1.0)
            else:
                occlusion = np.where(gap > 0.0, 0.0, 1.0)
        occlusion = np.where(np.isnan(gap), 1.0, occlusion)
    kappa = np.where(np.isnan(target_depth), 0.0, valid_fraction * in_range * occlusion)
    return kappa, target_depth


def depth_feasibility(
    pixel: Sequence[float],
    depth_m: npt.ArrayLike,
    config: ArbitrationConfig,
    box: Sequence[float] | None = None,
) -> float:
    """Depth-based feasibility kappa in [0, 1] of Eq. 2.

    ``kappa = f_valid * 1[d_min <= d_t <= d_max] * o``, where, over the ``config.depth_patch_px`` patch
    around ``pixel``, ``f_valid`` is the fraction of valid (finite, > 0) depths and ``d_t`` their median.
    With a ``box`` (the detection box or scene region), ``o`` is the occlusion factor: with
    ``g = d_box - d_t`` (``d_box`` the robust depth of the box) and margin ``m = config.occluder_margin_m``,
    ``o = clip(2 - g / m, 0, 1)``: 1 while the target pixel is at most ``m`` nearer than the box, falling
    linearly to 0 at ``2 m`` nearer (``m = 0``: a step). Without a box, or when the box has no valid
    depth, ``o = 1``. kappa is 0 when the patch has no valid depth.

    Args:
        pixel: ``(u, v)`` target location on the image.
        depth_m: ``(H, W)`` depth image in metres; NaN, inf and 0 are holes, never errors.
        config: the arbitration config (depth range, patch size, occluder margin).
        box: optional ``(u0, v0, u1, v1)`` box around the target.

    Raises:
        InvalidInputError: ``pixel`` is NaN/inf or off the image, ``box`` is malformed, or ``depth_m``
            is not a 2-D numeric image.
    """
    depth = np.asarray(depth_m)
    if depth.ndim != 2:
        raise InvalidInputError(f"depth_m must be an (H, W) image, got shape {depth.shape}")
    require_finite("pixel", pixel)
    if not in_image(pixel, depth.shape[1], depth.shape[0]):
        raise InvalidInputError(
            f"pixel {tuple(pixel)!r} lies outside the {depth.shape[1]}x{depth.shape[0]} image"
        )
    boxes = None if box is None else np.array([check_box("box", box)])
    kappa, _ = kappa_and_depth(depth, np.asarray(pixel, dtype=float).reshape(1, 2), boxes, config)
    return float(kappa[0])


# ----------------------------------------------------------------------------------------------------------
# Eq. 2
# ----------------------------------------------------------------------------------------------------------


def confidence_terms(table: CandidateTable, config: ArbitrationConfig) -> tuple[FloatArray, FloatArray]:
    """``C~_o^beta_o`` and ``C~_s^beta_s`` per candidate, 1 where the candidate lacks that source.

    Eq. 2's confidence terms and the weights of Eq. 4's location fusion.
    """
    term_o = np.where(table.has_object, table.object_confidence**config.beta_o, 1.0)
    term_s = np.where(table.has_scene, table.scene_confidence**config.beta_s, 1.0)
    return term_o, term_s


def candidate_priors(table: CandidateTable, prior: Callable[[str], float] | None) -> FloatArray:
    """P(t) of Eq. 2 from each candidate's label (``prior`` called once per distinct label; 1 without it).

    Raises:
        InvalidInputError: ``prior`` returned something that is not a finite non-negative number.
    """
    priors = np.ones(len(table.labels))
    if prior is None:
        return priors
    cache: dict[str, float] = {}
    for k, label in enumerate(table.labels):
        if label not in cache:
            value = prior(label)
            try:
                cache[label] = float(value)
            except (TypeError, ValueError) as exc:
                raise InvalidInputError(f"prior({label!r}) must be a number, got {value!r}") from exc
            if not (math.isfinite(cache[label]) and cache[label] >= 0.0):
                raise InvalidInputError(f"prior({label!r}) must be finite and non-negative, got {value!r}")
        priors[k] = cache[label]
    return priors


class Scores(NamedTuple):
    """Eq. 2 for every candidate, with the terms that vary by candidate.

    Attributes:
        score: ``(K,)`` raw S(t).
        priors: ``(K,)`` P(t), the direction prior applied.
        iou: ``(K,)`` the IoU each consistency term used (``unsupported_iou`` for an uncorroborated one).
        kappa: ``(K,)`` depth feasibility, None without a depth image.
        target_depth: ``(K,)`` robust depth at each pixel (NaN where none), None without a depth image.
    """

    score: FloatArray
    priors: FloatArray
    iou: FloatArray
    kappa: FloatArray | None
    target_depth: FloatArray | None


def score_candidates(
    table: CandidateTable,
    terms: tuple[FloatArray, FloatArray],
    priors: FloatArray,
    pixels: FloatArray,
    depth: npt.NDArray[np.generic] | None,
    *,
    scene_confidence: float | None,
    detector_present: bool,
    config: ArbitrationConfig,
) -> Scores:
    """Eq. 2: ``S = P * C~_o^beta_o * C~_s^beta_s * (IoU + eps)^lambda * (kappa + eps)^mu``.

    Args:
        table: the candidates.
        terms: :func:`confidence_terms` of the table.
        priors: :func:`candidate_priors` of the table.
        pixels: ``(K, 2)`` each candidate's location p_t (Eq. 4), where kappa is read.
        depth: the ``(H, W)`` depth image, or None (the kappa term is then dropped).
        scene_confidence: the view's calibrated scene confidence C~_s, None when the scene source is missing.
        detector_present: whether the object source answered for this view.
        config: the exponents, epsilon, the direction prior and the consistency rule.
    """
    term_o, term_s = terms
    iou = table.iou
    # Cross-source consistency (our reading of "a missing source drops its term"): a source that is
    # present in this view but does not support a candidate is not missing, it disagrees. An object
    # candidate (a detection, or an instruction-aligned VLM object) that the other present source did not
    # corroborate gets the consistency term with IoU = config.unsupported_iou, and an unassociated
    # detection also carries the view's scene confidence. Directions assert open space, not an object,
    # so no detector can corroborate them: they keep only their own terms.
    if config.cross_source_consistency and scene_confidence is not None and detector_present:
        unsupported = table.is_object & ~table.fused
        iou = np.where(unsupported, config.unsupported_iou, iou)
        lone_det = table.has_object & ~table.has_scene
        term_s = np.where(lone_det, scene_confidence**config.beta_s, term_s)
        consistency = table.fused | unsupported
    else:
        consistency = table.fused
    # P(t) for unexplored directions: a direction is a place to look, never the target itself, so its
    # prior is config.direction_prior (< 1). Without it every Eq. 2 factor is <= 1 and an object seen by
    # both sources (two confidences and an IoU term) could never outrank a bare direction.
    priors = np.where(table.is_direction, priors * config.direction_prior, priors)
    score = priors * term_o * term_s
    score = score * np.where(consistency, (iou + config.epsilon) ** config.lambda_iou, 1.0)
    kappa = target_depth = None
    if depth is not None:
        kappa_box = np.where(table.has_object[:, None], table.boxes, table.regions)
        kappa, target_depth = kappa_and_depth(depth, pixels, kappa_box, config)
        score = score * (kappa + config.epsilon) ** config.mu
    return Scores(score=score, priors=priors, iou=iou, kappa=kappa, target_depth=target_depth)
