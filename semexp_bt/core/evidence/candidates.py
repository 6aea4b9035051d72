"""The candidates of one view: calibrated evidence (Eq. 1), associated by overlap, in one table.

Object-level evidence (detections with confidences C_o) and scene-level evidence (a VLM's proposals
with one scene confidence C_s) are read and calibrated onto one scale (Eq. 1); each aligned detection
is associated with at most one aligned scene object proposal by maximum overlap between the detection
box and the proposal's scene region r_s; the candidates are then one table in tie-break order:
detection-derived candidates (fused or object) by detection index, then scene-only candidates by
proposal index. The choices the paper leaves open are in ``docs/arbitration.md``.

This is a core module: standard library, numpy and ``semexp_bt`` core modules only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from semexp_bt.core.config import ArbitrationConfig
from semexp_bt.core.evidence.result import CandidateSource, ScoredCandidate, TargetKind
from semexp_bt.core.geometry import (
    check_box,
    check_boxes,
    clip_box,
    clip_boxes,
    fast_clip,
    iou_matrix_unchecked,
)
from semexp_bt.core.types import (
    Detection,
    FloatArray,
    InvalidInputError,
    SceneEvidence,
    SceneProposal,
    require_finite,
)

IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

_SCENE_KINDS = ("object", "direction")


# ----------------------------------------------------------------------------------------------------------
# Eq. 1: calibration
# ----------------------------------------------------------------------------------------------------------


def check_tau(name: str, tau: float) -> float:
    """``tau`` as a float, checked to lie in [0, 1) (the domain of Eq. 1)."""
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
    t = check_tau("tau", tau)
    c = _check_confidence("confidence", confidence)
    return min(1.0, max(0.0, (c - t) / (1.0 - t)))


def calibrate_array(confidences: npt.ArrayLike, tau: float, *, name: str = "confidences") -> FloatArray:
    """Vectorised :func:`calibrate` (Eq. 1); the error names the first bad entry as ``name[i]``."""
    t = check_tau("tau", tau)
    values = np.asarray(confidences, dtype=float)
    flat = values.reshape(-1)
    bad = ~(np.isfinite(flat) & (flat >= 0.0) & (flat <= 1.0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(f"{name}[{i}] must be a finite number in [0, 1], got {flat[i]!r}")
    return fast_clip((values - t) / (1.0 - t), 0.0, 1.0)


# ----------------------------------------------------------------------------------------------------------
# Regions and boxes
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


def resolve_image_size(
    image_size: tuple[int, int] | None, depth: npt.NDArray[np.generic] | None
) -> tuple[int, int] | None:
    """The ``(width, height)`` every box, region and point is clipped to: ``image_size`` or the depth
    image's, which must agree; None when neither is given."""
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


# ----------------------------------------------------------------------------------------------------------
# The two sources, read and calibrated
# ----------------------------------------------------------------------------------------------------------


class ObjectEvidence(NamedTuple):
    """The object-level source of one view (the open-vocabulary detector).

    Attributes:
        present: the detector answered for this view (an empty answer is present; None is missing).
        detections: the detections, in input order.
        boxes: ``(N, 4)`` their boxes, checked and clipped to the image when its size is known.
        confidences: ``(N,)`` their calibrated confidences C~_o (Eq. 1).
        aligned: indices of the detections whose label is aligned with the instruction.
    """

    present: bool
    detections: Sequence[Detection]
    boxes: FloatArray
    confidences: FloatArray
    aligned: list[int]


class SceneView(NamedTuple):
    """The scene-level source of one view (the VLM).

    Attributes:
        present: the VLM answered for this view.
        proposals: its proposals, in input order.
        confidence: the calibrated scene confidence C~_s (Eq. 1), None when the source is missing.
        points: ``(M, 2)`` the proposals' points, clipped to the image when its size is known.
        regions: ``(M, 4)`` their scene regions r_s (see :func:`scene_region`), clipped likewise.
        aligned_objects: indices of the ``"object"`` proposals whose label is aligned.
    """

    present: bool
    proposals: tuple[SceneProposal, ...]
    confidence: float | None
    points: FloatArray
    regions: FloatArray
    aligned_objects: list[int]


def read_object_evidence(
    detections: Sequence[Detection] | None,
    tau: float,
    size: tuple[int, int] | None,
    aligned: Callable[[str], bool],
) -> ObjectEvidence:
    """Check the detections, clip their boxes and calibrate their confidences (Eq. 1).

    Raises:
        InvalidInputError: a malformed, inverted or non-finite box, or a bad confidence, named as
            ``detections[i]...``.
    """
    present = detections is not None
    detections = () if detections is None else detections
    n_det = len(detections)
    boxes = check_boxes(
        "detections",
        _as_rows("detections", [d.box_xyxy_px for d in detections], 4, ".box_xyxy_px"),
        ".box_xyxy_px",
    )
    confidences = calibrate_array(
        [d.confidence for d in detections] if n_det else np.zeros(0), tau, name="detections"
    )
    if size is not None:
        boxes = clip_boxes(boxes, size[0], size[1])
    return ObjectEvidence(
        present=present,
        detections=detections,
        boxes=boxes,
        confidences=confidences,
        aligned=[i for i, d in enumerate(detections) if aligned(d.label)],
    )


def read_scene_evidence(
    scene: SceneEvidence | None,
    config: ArbitrationConfig,
    size: tuple[int, int] | None,
    aligned: Callable[[str], bool],
) -> SceneView:
    """Check the proposals, build their scene regions, clip to the image and calibrate C_s (Eq. 1).

    Raises:
        InvalidInputError: a bad scene confidence, a non-finite point, an unknown kind, or a malformed
            region, named as ``scene.proposals[i]...``.
    """
    proposals: tuple[SceneProposal, ...] = ()
    confidence: float | None = None
    if scene is not None:
        confidence = calibrate(
            _check_confidence("scene.scene_confidence", scene.scene_confidence), config.tau
        )
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
    return SceneView(
        present=scene is not None,
        proposals=proposals,
        confidence=confidence,
        points=points,
        regions=regions,
        aligned_objects=[i for i, p in enumerate(proposals) if p.kind == "object" and aligned(p.label)],
    )


# ----------------------------------------------------------------------------------------------------------
# Association by maximum overlap
# ----------------------------------------------------------------------------------------------------------


class Association(NamedTuple):
    """Which aligned detection absorbed which aligned scene object proposal.

    Attributes:
        proposal_of: detection index -> the proposal index it absorbed.
        iou: detection index -> IoU(r_s, b) with that proposal.
    """

    proposal_of: dict[int, int]
    iou: dict[int, float]


def greedy_pairs(iou: FloatArray) -> dict[int, int]:
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


def associate(objects: ObjectEvidence, scene: SceneView) -> Association:
    """Pair each aligned detection with at most one aligned scene object proposal (:func:`greedy_pairs`
    over IoU(b, r_s)). Directions never associate: they assert open space, not an object."""
    aligned_dets, aligned_objects = objects.aligned, scene.aligned_objects
    if not (aligned_dets and aligned_objects):
        return Association({}, {})
    iou_table = iou_matrix_unchecked(objects.boxes[aligned_dets], scene.regions[aligned_objects])
    pairs = greedy_pairs(iou_table)
    return Association(
        proposal_of={aligned_dets[r]: aligned_objects[c] for r, c in pairs.items()},
        iou={aligned_dets[r]: float(iou_table[r, c]) for r, c in pairs.items()},
    )


# ----------------------------------------------------------------------------------------------------------
# The candidate table
# ----------------------------------------------------------------------------------------------------------


class CandidateTable(NamedTuple):
    """Every candidate of a view, one row each, in tie-break order (detection-derived, then scene-only).

    Attributes:
        detection_of: ``(K,)`` the candidate's detection index, -1 for a scene-only candidate.
        proposal_of: ``(K,)`` its scene proposal index, -1 for a detection without one.
        has_object: ``(K,)`` the candidate has a detection.
        has_scene: ``(K,)`` the candidate has a scene proposal.
        fused: ``(K,)`` both (a detection that absorbed a proposal).
        is_object: ``(K,)`` it outlines an object (every detection, and scene ``"object"`` proposals).
        is_direction: ``(K,)`` it is a scene ``"direction"`` proposal.
        labels: the candidates' labels (the detection's for a fused candidate).
        kinds: ``"object"`` or ``"direction"``.
        sources: ``"fused"``, ``"object"`` or ``"scene"``.
        object_confidence: ``(K,)`` C~_o, 0 without a detection.
        scene_confidence: ``(K,)`` C~_s, 0 without a proposal.
        iou: ``(K,)`` the association's IoU, 0 for a candidate that is not fused.
        boxes: ``(K, 4)`` the detection box (zeros or a stand-in row without a detection).
        object_pixels: ``(K, 2)`` p_o, the centre of ``boxes``.
        scene_pixels: ``(K, 2)`` p_s, the proposal's point (a stand-in row without a proposal).
        regions: ``(K, 4)`` r_s (a stand-in row without a proposal).
    """

    detection_of: IntArray
    proposal_of: IntArray
    has_object: BoolArray
    has_scene: BoolArray
    fused: BoolArray
    is_object: BoolArray
    is_direction: BoolArray
    labels: list[str]
    kinds: list[TargetKind]
    sources: list[CandidateSource]
    object_confidence: FloatArray
    scene_confidence: FloatArray
    iou: FloatArray
    boxes: FloatArray
    object_pixels: FloatArray
    scene_pixels: FloatArray
    regions: FloatArray


def candidate_table(
    objects: ObjectEvidence, scene: SceneView, association: Association
) -> CandidateTable | None:
    """The candidates: aligned detections (fused when they absorbed a proposal), then the scene-only
    proposals (every direction, and the aligned object proposals no detection absorbed); None when
    there is none."""
    aligned_dets, proposals = objects.aligned, scene.proposals
    absorbed_by = association.proposal_of
    absorbed = set(absorbed_by.values())
    scene_candidates = set(scene.aligned_objects).difference(absorbed)
    scene_only = [i for i, p in enumerate(proposals) if p.kind == "direction" or i in scene_candidates]
    n_det, n_prop, n_cand = len(objects.detections), len(proposals), len(aligned_dets) + len(scene_only)
    if n_cand == 0:
        return None

    det_of = np.array(aligned_dets + [-1] * len(scene_only), dtype=np.int64)
    prop_of = np.array([absorbed_by.get(i, -1) for i in aligned_dets] + scene_only, dtype=np.int64)
    has_o = det_of >= 0
    has_s = prop_of >= 0
    iou = np.zeros(n_cand)
    if absorbed_by:
        iou[: len(aligned_dets)] = [association.iou.get(i, 0.0) for i in aligned_dets]
    boxes_o = objects.boxes[np.maximum(det_of, 0)] if n_det else np.zeros((n_cand, 4))
    kinds: list[TargetKind] = ["object"] * len(aligned_dets)
    kinds += [proposals[i].kind for i in scene_only]
    sources: list[CandidateSource] = ["fused" if i in absorbed_by else "object" for i in aligned_dets]
    sources += ["scene"] * len(scene_only)
    is_object = np.array([kind == "object" for kind in kinds])  # every detection, and scene objects
    scene_confidence = scene.confidence if scene.confidence is not None else 0.0
    return CandidateTable(
        detection_of=det_of,
        proposal_of=prop_of,
        has_object=has_o,
        has_scene=has_s,
        fused=has_o & has_s,
        is_object=is_object,
        is_direction=~is_object,
        labels=[objects.detections[i].label for i in aligned_dets] + [proposals[i].label for i in scene_only],
        kinds=kinds,
        sources=sources,
        object_confidence=np.where(has_o, objects.confidences[np.maximum(det_of, 0)] if n_det else 0.0, 0.0),
        scene_confidence=np.where(has_s, scene_confidence, 0.0),
        iou=iou,
        boxes=boxes_o,
        object_pixels=0.5 * (boxes_o[:, :2] + boxes_o[:, 2:]),
        scene_pixels=scene.points[np.maximum(prop_of, 0)] if n_prop else np.zeros((n_cand, 2)),
        regions=scene.regions[np.maximum(prop_of, 0)] if n_prop else np.zeros((n_cand, 4)),
    )
