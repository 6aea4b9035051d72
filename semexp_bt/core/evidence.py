"""Confidence-calibrated semantic evidence arbitration (paper Sec. III-C, Eq. 1-4).

Scene-level evidence (a VLM's proposals with one scene confidence C_s) and object-level evidence
(open-vocabulary detections with confidences C_o) are calibrated onto one scale (Eq. 1), associated by
maximum spatial overlap, scored by a posterior-like product (Eq. 2), and the best candidate is selected
with a normalised fused confidence C_f (Eq. 3); its image location fuses both sources (Eq. 4).

Every choice the paper leaves open (the scene region of a point proposal, the depth-feasibility rule
kappa, the association rule, tie-breaks, the 0/0 guard of Eq. 4) is documented in ``docs/arbitration.md``.

This is a core module: standard library, numpy and ``semexp_bt`` core modules only.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from semexp_bt.core.config import ArbitrationConfig
from semexp_bt.core.geometry import (
    box_depth_stats,
    check_box,
    check_boxes,
    clip_box,
    clip_boxes,
    fast_clip,
    in_image,
    iou_matrix_unchecked,
    patch_depth_stats,
)
from semexp_bt.core.types import (
    Detection,
    FloatArray,
    InvalidInputError,
    SceneEvidence,
    SceneProposal,
    Target,
    require_finite,
)

CandidateSource = Literal["fused", "object", "scene"]
TargetKind = Literal["object", "direction"]

#: Scores within this relative distance of the maximum are a tie (broken by candidate order, see
#: :func:`arbitrate`), so that two candidates whose scores differ only by float rounding are treated alike.
TIE_RELATIVE_TOLERANCE = 1e-9

#: Location weight w of Eq. 4 when both calibrated terms are 0 (the 0/0 case): the midpoint, since
#: neither source is preferred. Such a candidate has S = 0 and can only be reported, never selected.
ZERO_CONFIDENCE_OBJECT_WEIGHT = 0.5

_SCENE_KINDS = ("object", "direction")


class ScoredCandidate(NamedTuple):
    """One arbitration candidate with every term of Eq. 2 and where it came from.

    An immutable named tuple rather than a frozen dataclass: :func:`arbitrate` builds one per candidate
    on every perception event, and a frozen dataclass costs three times as much to construct.

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
        region_px: the scene region r_s (see :func:`scene_region`).
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


@dataclass(frozen=True, slots=True)
class ArbitrationResult:
    """The outcome of :func:`arbitrate`.

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


# ----------------------------------------------------------------------------------------------------------
# Eq. 1: calibration
# ----------------------------------------------------------------------------------------------------------


def _check_tau(name: str, tau: float) -> float:
    require_finite(name, tau)
    if not 0.0 <= float(tau) < 1.0:
        raise InvalidInputError(f"{name} must lie in [0, 1), got {tau!r}")
    return float(tau)


def _check_confidence(name: str, confidence: float) -> float:
    try:
        value = float(confidence)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a number in [0, 1], got {confidence!r}") from exc
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise InvalidInputError(f"{name} must be a finite number in [0, 1], got {confidence!r}")
    return value


def calibrate(confidence: float, tau: float) -> float:
    """Monotonic confidence calibration, paper Eq. 1: C~ = min(1, max(0, (C - tau) / (1 - tau))).

    Args:
        confidence: raw confidence C in [0, 1].
        tau: threshold in [0, 1); confidences at or below it calibrate to 0.

    Returns:
        The calibrated confidence in [0, 1].

    Raises:
        InvalidInputError: ``confidence`` is NaN/inf or outside [0, 1], or ``tau`` outside [0, 1).
    """
    t = _check_tau("tau", tau)
    c = _check_confidence("confidence", confidence)
    return min(1.0, max(0.0, (c - t) / (1.0 - t)))


def calibrate_array(confidences: npt.ArrayLike, tau: float, *, name: str = "confidences") -> FloatArray:
    """Vectorised :func:`calibrate`; the error names the first bad entry as ``name[i]``."""
    t = _check_tau("tau", tau)
    values = np.asarray(confidences, dtype=float)
    flat = values.reshape(-1)
    bad = ~(np.isfinite(flat) & (flat >= 0.0) & (flat <= 1.0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(f"{name}[{i}] must be a finite number in [0, 1], got {flat[i]!r}")
    return fast_clip((values - t) / (1.0 - t), 0.0, 1.0)


# ----------------------------------------------------------------------------------------------------------
# Scene regions and depth feasibility
# ----------------------------------------------------------------------------------------------------------


def scene_region(
    proposal: SceneProposal,
    config: ArbitrationConfig,
    width: int | None = None,
    height: int | None = None,
) -> tuple[float, float, float, float]:
    """The scene region r_s of a proposal, for the IoU of Eq. 2.

    The proposal's own ``region_px`` when the VLM gave one, else the square of half side
    ``config.scene_region_half_size_px`` centred on ``point_px``. With an image size, the region is
    clipped to the image (:func:`semexp_bt.core.geometry.clip_box`).

    Raises:
        InvalidInputError: a NaN/inf point, a malformed or inverted region, or only one of width/height.
    """
    if (width is None) != (height is None):
        raise InvalidInputError("scene_region needs both width and height, or neither")
    if proposal.region_px is not None:
        box = check_box("proposal.region_px", proposal.region_px)
    else:
        require_finite("proposal.point_px", proposal.point_px)
        u, v = float(proposal.point_px[0]), float(proposal.point_px[1])
        half = float(config.scene_region_half_size_px)
        box = (u - half, v - half, u + half, v + half)
    if width is not None and height is not None:
        box = clip_box(box, width, height)
    return box


def candidate_box(
    candidate: ScoredCandidate, scene: SceneEvidence | None
) -> tuple[float, float, float, float] | None:
    """The box that outlines a candidate's object: the detection box, else the region the VLM gave with
    its proposal, else None (a bare VLM point, or a direction, which outlines no object)."""
    if candidate.kind == "direction":
        return None
    if candidate.box_xyxy_px is not None:
        return candidate.box_xyxy_px
    if scene is not None and candidate.proposal_index is not None:
        return scene.proposals[candidate.proposal_index].region_px
    return None


def _kappa_and_depth(
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
    kappa, _ = _kappa_and_depth(depth, np.asarray(pixel, dtype=float).reshape(1, 2), boxes, config)
    return float(kappa[0])


# ----------------------------------------------------------------------------------------------------------
# Eq. 2-4: association, scoring, selection, location fusion
# ----------------------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=32)
def _check_config(config: ArbitrationConfig) -> None:
    """Validate the fields arbitration uses (a config built in code bypasses the YAML loader's checks)."""
    _check_tau("config.tau", config.tau)
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


def _as_rows(name: str, rows: list[object], width: int, field_suffix: str) -> FloatArray:
    try:
        arr = np.array(rows, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"{name}: every {field_suffix.lstrip('.')} must hold {width} numbers"
        ) from exc
    if arr.size == 0:
        return arr.reshape(0, width)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise InvalidInputError(f"{name}: every {field_suffix.lstrip('.')} must hold {width} numbers")
    return arr


def _resolve_image_size(
    image_size: tuple[int, int] | None, depth: npt.NDArray[np.generic] | None
) -> tuple[int, int] | None:
    size = None
    if image_size is not None:
        if (
            len(image_size) != 2
            or not all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) for x in image_size)
            or min(image_size) <= 0
        ):
            raise InvalidInputError(
                f"image_size must be (width, height) positive integers, got {image_size!r}"
            )
        size = (int(image_size[0]), int(image_size[1]))
    if depth is not None:
        if depth.ndim != 2 or depth.size == 0:
            raise InvalidInputError(f"depth_m must be a non-empty (H, W) image, got shape {depth.shape}")
        depth_size = (int(depth.shape[1]), int(depth.shape[0]))
        if size is not None and size != depth_size:
            raise InvalidInputError(
                f"image_size {size} disagrees with depth_m of (width, height) {depth_size}"
            )
        size = depth_size
    return size


def _associate(iou: FloatArray) -> dict[int, int]:
    """Greedy one-to-one association by IoU: repeatedly take the highest-IoU free pair with IoU > 0.

    Ties are broken by the lower row (detection) index, then the lower column (proposal) index.

    Returns:
        Map from row index to column index.
    """
    rows, cols = np.nonzero(iou > 0.0)
    if rows.size == 0:
        return {}
    order = np.lexsort((cols, rows, -iou[rows, cols]))
    pairs: dict[int, int] = {}
    taken_cols: set[int] = set()
    limit = min(iou.shape)
    for r, c in zip(rows[order].tolist(), cols[order].tolist(), strict=True):
        if r in pairs or c in taken_cols:
            continue
        pairs[r] = c
        taken_cols.add(c)
        if len(pairs) == limit:
            break
    return pairs


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
    :data:`TIE_RELATIVE_TOLERANCE`) go to the earliest candidate in :attr:`ArbitrationResult.candidates`
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
    detector_present = detections is not None
    detections = () if detections is None else detections
    depth = None if depth_m is None else np.asarray(depth_m)
    size = _resolve_image_size(image_size, depth)
    tau = config.tau

    # --- object-level evidence -------------------------------------------------------------------------
    n_det = len(detections)
    det_boxes = check_boxes(
        "detections",
        _as_rows("detections", [d.box_xyxy_px for d in detections], 4, ".box_xyxy_px"),
        ".box_xyxy_px",
    )
    det_conf = calibrate_array(
        [d.confidence for d in detections] if n_det else np.zeros(0), tau, name="detections"
    )
    if size is not None:
        det_boxes = clip_boxes(det_boxes, size[0], size[1])
    alignment: dict[str, bool] = {}

    def aligned(label: str) -> bool:
        if label not in alignment:
            alignment[label] = bool(is_aligned(label))
        return alignment[label]

    aligned_dets = [i for i, d in enumerate(detections) if aligned(d.label)]

    # --- scene-level evidence --------------------------------------------------------------------------
    proposals: tuple[SceneProposal, ...] = ()
    scene_conf: float | None = None
    if scene is not None:
        scene_conf = calibrate(_check_confidence("scene.scene_confidence", scene.scene_confidence), tau)
        proposals = tuple(scene.proposals)
    n_prop = len(proposals)
    points = _as_rows("scene.proposals", [p.point_px for p in proposals], 2, ".point_px")
    bad_points = ~np.all(np.isfinite(points), axis=1)
    if bad_points.any():
        i = int(np.argmax(bad_points))
        raise InvalidInputError(
            f"scene.proposals[{i}].point_px must be finite, got {proposals[i].point_px!r}"
        )
    half = float(config.scene_region_half_size_px)
    regions = np.concatenate([points - half, points + half], axis=1) if n_prop else np.zeros((0, 4))
    for i, p in enumerate(proposals):
        if p.kind not in _SCENE_KINDS:
            raise InvalidInputError(
                f"scene.proposals[{i}].kind must be one of {_SCENE_KINDS}, got {p.kind!r}"
            )
        if p.region_px is not None:
            regions[i] = check_box(f"scene.proposals[{i}].region_px", p.region_px)
    if size is not None and n_prop:
        regions = clip_boxes(regions, size[0], size[1])
        points = fast_clip(points, 0.0, (size[0] - 1.0, size[1] - 1.0))
    aligned_objects = [i for i, p in enumerate(proposals) if p.kind == "object" and aligned(p.label)]

    # --- association by maximum overlap ----------------------------------------------------------------
    absorbed_by: dict[int, int] = {}  # detection index -> proposal index
    pair_iou: dict[int, float] = {}  # detection index -> IoU with its proposal
    if aligned_dets and aligned_objects:
        iou_table = iou_matrix_unchecked(det_boxes[aligned_dets], regions[aligned_objects])
        pairs = _associate(iou_table)
        absorbed_by = {aligned_dets[r]: aligned_objects[c] for r, c in pairs.items()}
        pair_iou = {aligned_dets[r]: float(iou_table[r, c]) for r, c in pairs.items()}
    absorbed = set(absorbed_by.values())
    scene_candidates = set(aligned_objects).difference(absorbed)
    scene_only = [i for i, p in enumerate(proposals) if p.kind == "direction" or i in scene_candidates]

    # --- candidate table (tie-break order) -------------------------------------------------------------
    n_cand = len(aligned_dets) + len(scene_only)
    if n_cand == 0:
        return ArbitrationResult(
            target=None,
            candidates=(),
            reason=(
                f"no candidates: none of {n_det} detection(s) is aligned with the instruction and "
                + (
                    "there is no scene evidence"
                    if scene is None
                    else f"none of {n_prop} scene proposal(s) is a direction or aligned"
                )
            ),
        )
    det_of = np.array(aligned_dets + [-1] * len(scene_only), dtype=np.int64)
    prop_of = np.array([absorbed_by.get(i, -1) for i in aligned_dets] + scene_only, dtype=np.int64)
    has_o = det_of >= 0
    has_s = prop_of >= 0
    fused = has_o & has_s
    co = np.where(has_o, det_conf[np.maximum(det_of, 0)] if n_det else 0.0, 0.0)
    cs = np.where(has_s, scene_conf if scene_conf is not None else 0.0, 0.0)
    iou = np.zeros(n_cand)
    if absorbed_by:
        iou[: len(aligned_dets)] = [pair_iou.get(i, 0.0) for i in aligned_dets]
    boxes_o = det_boxes[np.maximum(det_of, 0)] if n_det else np.zeros((n_cand, 4))
    p_o = 0.5 * (boxes_o[:, :2] + boxes_o[:, 2:])
    p_s = points[np.maximum(prop_of, 0)] if n_prop else np.zeros((n_cand, 2))
    regions_c = regions[np.maximum(prop_of, 0)] if n_prop else np.zeros((n_cand, 4))

    # Eq. 4 weight; the terms are the same powers as in Eq. 2.
    term_o = np.where(has_o, co**config.beta_o, 1.0)
    term_s = np.where(has_s, cs**config.beta_s, 1.0)
    denom = term_o + term_s
    weight = np.where(denom > 0.0, term_o / np.where(denom > 0.0, denom, 1.0), ZERO_CONFIDENCE_OBJECT_WEIGHT)
    fused_px = weight[:, None] * p_o + (1.0 - weight[:, None]) * p_s
    pixels = np.where(fused[:, None], fused_px, np.where(has_o[:, None], p_o, p_s))

    # Eq. 2
    label_of = [detections[i].label for i in aligned_dets] + [proposals[i].label for i in scene_only]
    priors = np.ones(n_cand)
    if prior is not None:
        cache: dict[str, float] = {}
        for k, label in enumerate(label_of):
            if label not in cache:
                value = prior(label)
                try:
                    cache[label] = float(value)
                except (TypeError, ValueError) as exc:
                    raise InvalidInputError(f"prior({label!r}) must be a number, got {value!r}") from exc
                if not (math.isfinite(cache[label]) and cache[label] >= 0.0):
                    raise InvalidInputError(
                        f"prior({label!r}) must be finite and non-negative, got {value!r}"
                    )
            priors[k] = cache[label]
    # Cross-source consistency (our reading of "a missing source drops its term"): a source that is
    # present in this view but does not support a candidate is not missing, it disagrees. An object
    # candidate (a detection, or an instruction-aligned VLM object) that the other present source did not
    # corroborate gets the consistency term with IoU = config.unsupported_iou, and an unassociated
    # detection also carries the view's scene confidence. Directions assert open space, not an object,
    # so no detector can corroborate them: they keep only their own terms.
    if config.cross_source_consistency and scene is not None and detector_present:
        is_object = np.array([True] * len(aligned_dets) + [proposals[i].kind == "object" for i in scene_only])
        unsupported = is_object & ~fused
        iou = np.where(unsupported, config.unsupported_iou, iou)
        lone_det = has_o & ~has_s
        term_s = np.where(lone_det, (scene_conf or 0.0) ** config.beta_s, term_s)
        consistency = fused | unsupported
    else:
        consistency = fused
    # P(t) for unexplored directions: a direction is a place to look, never the target itself, so its
    # prior is config.direction_prior (< 1). Without it every Eq. 2 factor is <= 1 and an object seen by
    # both sources (two confidences and an IoU term) could never outrank a bare direction.
    is_direction = np.array(
        [False] * len(aligned_dets) + [proposals[i].kind == "direction" for i in scene_only]
    )
    priors = np.where(is_direction, priors * config.direction_prior, priors)
    score = priors * term_o * term_s
    score = score * np.where(consistency, (iou + config.epsilon) ** config.lambda_iou, 1.0)
    kappa = target_depth = None
    if depth is not None:
        kappa_box = np.where(has_o[:, None], boxes_o, regions_c)
        kappa, target_depth = _kappa_and_depth(depth, pixels, kappa_box, config)
        score = score * (kappa + config.epsilon) ** config.mu

    # Eq. 3
    total = float(score.sum())
    best_score = float(score.max())
    if total > 0.0:
        normalised = score / total
        winner = int(np.argmax(score >= best_score * (1.0 - TIE_RELATIVE_TOLERANCE)))
    else:
        normalised = np.zeros(n_cand)
        winner = None

    # --- result ----------------------------------------------------------------------------------------
    kinds: list[TargetKind] = ["object"] * len(aligned_dets)
    kinds += [proposals[i].kind for i in scene_only]
    sources: list[CandidateSource] = ["fused" if i in absorbed_by else "object" for i in aligned_dets]
    sources += ["scene"] * len(scene_only)
    # One bulk conversion to Python objects: indexing numpy arrays element by element costs more than
    # the whole vectorised scoring above.
    score_l, norm_l, prior_l = score.tolist(), normalised.tolist(), priors.tolist()
    co_l, weight_l, iou_l = co.tolist(), weight.tolist(), iou.tolist()
    kappa_l: list[float | None] = [None] * n_cand if kappa is None else kappa.tolist()
    depth_l: list[float | None] = [None] * n_cand
    if target_depth is not None:
        depth_l = [None if math.isnan(x) else x for x in target_depth.tolist()]
    pixel_l = [tuple(row) for row in pixels.tolist()]
    p_o_l = [tuple(row) for row in p_o.tolist()]
    p_s_l = [tuple(row) for row in p_s.tolist()]
    box_l = [tuple(row) for row in boxes_o.tolist()]
    region_l = [tuple(row) for row in regions_c.tolist()]
    candidates = []
    for k, (d_idx, p_idx) in enumerate(zip(det_of.tolist(), prop_of.tolist(), strict=True)):
        has_det, has_prop = d_idx >= 0, p_idx >= 0
        is_fused = has_det and has_prop
        candidates.append(
            ScoredCandidate(
                source=sources[k],
                kind=kinds[k],
                label=label_of[k],
                pixel_px=pixel_l[k],  # type: ignore[arg-type]
                score=score_l[k],
                normalised_score=norm_l[k],
                prior=prior_l[k],
                calibrated_object_confidence=co_l[k] if has_det else None,
                calibrated_scene_confidence=scene_conf if has_prop else None,
                object_weight=weight_l[k] if is_fused else None,
                iou=iou_l[k] if is_fused else None,
                kappa=kappa_l[k],
                depth_m=depth_l[k],
                object_pixel_px=p_o_l[k] if has_det else None,  # type: ignore[arg-type]
                scene_pixel_px=p_s_l[k] if has_prop else None,  # type: ignore[arg-type]
                box_xyxy_px=box_l[k] if has_det else None,  # type: ignore[arg-type]
                region_px=region_l[k] if has_prop else None,  # type: ignore[arg-type]
                detection_index=d_idx if has_det else None,
                proposal_index=p_idx if has_prop else None,
            )
        )

    if winner is None:
        return ArbitrationResult(
            target=None,
            candidates=tuple(candidates),
            reason=(
                f"all {n_cand} candidate score(s) are zero (confidences at or below tau={tau:g}, "
                f"or a zero prior): no target"
            ),
        )
    best = candidates[winner]
    target = Target(
        pixel_px=best.pixel_px,
        label=best.label,
        fused_confidence=min(1.0, max(0.0, norm_l[winner])),
        source=best.source,
        kind=best.kind,
        depth_m=best.depth_m,
    )
    reason = (
        f"selected {best.source} {best.kind} candidate {best.label!r} at "
        f"({best.pixel_px[0]:.1f}, {best.pixel_px[1]:.1f}) px: S={best_score:.4g}, C_f={target.fused_confidence:.3f} "
        f"among {n_cand} candidate(s)"
    )
    return ArbitrationResult(target=target, candidates=tuple(candidates), reason=reason, winner_index=winner)
