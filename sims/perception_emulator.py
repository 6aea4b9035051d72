"""Perception emulator: detector-like and VLM-like evidence from what the simulated camera really sees.

The emulator stands in for Qwen2.5-VL (scene-level proposals + scene confidence C_s) and
GroundingDINO / YOLO-World (boxes + confidence C_o) in simulation. It reads only this frame's
``Observation``: the per-pixel segmentation says which objects have visible pixels (occlusion and the
field of view are therefore automatic), the depth image gives their distance, the mask geometry gives
truncation and viewing angle, and the ``motion`` twist gives blur. The ``SceneSpec`` is used only for
what a model "knows" about a class: labels, categories, which classes the scene marks as close
(``role == "distractor"``), nominal sizes and whether a thing is an obstacle. No object position is
ever read, so nothing can be reported about an object the camera cannot see.

Noise model (every parameter in ``sims/perception_noise.yaml``, documented in ``docs/perception.md``):

* per visible object a *quality* ``q`` in [0, 1], the product of distance, visible-area, occlusion,
  truncation, off-axis and motion-blur factors;
* detector: the prompt is the target label; an object that matches it is detected with probability
  ``max_detection_probability * q``, confidence ~ Beta around a mean rising with ``q``; an object the
  data marks as close to the prompt is reported *with the prompt's label* with probability
  ``confusion_rate * q`` and a lower confidence; any other non-wall object becomes a false positive
  with probability ``false_positive_rate * q``. Boxes are the visible mask's bounding box with each edge
  pulled inwards by a random fraction, so a box never leaves the visible mask's bounding box;
* VLM: object proposals for visible relevant objects (point jittered by a fraction of the mask's size,
  label possibly confused), "direction" proposals for open image columns, an occasional hallucinated
  target proposal placed on an in-view pixel that is not the target, and C_s from clutter and blur;
* latency: uniform jitter around a configured mean per model (VLM 2.5 s, detector 1.2 s by default).

Two entry points: the pure function :func:`emulate` (one frame in, evidence + latencies out) and
:class:`PerceptionEmulator`, a ``semexp_bt.perception.interface.PerceptionSource`` whose jobs release their result
once the simulated latency has passed on the backend clock. Both are deterministic for a given numpy
``Generator`` state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import yaml

from semexp_bt.core.bounds import field_range
from semexp_bt.core.config import ConfigError, config_from_dict
from semexp_bt.core.instruction import ParsedInstruction, parse_instruction
from semexp_bt.core.language import canonical_tokens
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import (
    BACKGROUND_OBJECT_ID,
    Detection,
    InvalidInputError,
    Observation,
    SceneEvidence,
    SceneProposal,
    Twist,
    require_finite,
)
from semexp_bt.perception.interface import PerceptionResult, ReadyJob
from sims.naming import NounKey, PromptGrade, close_name_pairs, grade, own_names

#: The default noise model shipped with the package.
DEFAULT_NOISE_PATH = Path(__file__).with_name("perception_noise.yaml")

DetectorProfileName = Literal["detector", "detector_yolo_world"]

#: Bounds that keep a Beta mean away from 0 and 1 (where the shape parameters would vanish).
_MEAN_EPS = 1e-3


# --------------------------------------------------------------------------------------------------
# Configuration (loaded from YAML with semexp_bt.core.config.config_from_dict: unknown keys, wrong types and
# out-of-range values raise ConfigError naming the file and the dotted key)
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LatencyConfig:
    """Simulated model latency on the backend clock."""

    mean_s: float = field(default=1.2, metadata=field_range(0.0, 600.0))
    """Mean latency (s)."""
    jitter_s: float = field(default=0.1, metadata=field_range(0.0, 600.0))
    """Half-width of the uniform jitter around the mean (s); must not exceed ``mean_s``."""


@dataclass(frozen=True)
class VisibilityConfig:
    """How the view of one object degrades a model's chance to see it (the quality factors)."""

    min_pixels: int = field(default=30, metadata=field_range(1, 10_000_000))
    """Objects with fewer visible pixels are never reported."""
    distance_ref_m: float = field(default=2.5, metadata=field_range(0.0, 100.0))
    """No distance penalty up to this depth (m)."""
    distance_scale_m: float = field(default=8.0, metadata=field_range(0.0, 1000.0, low_open=True))
    """Beyond ``distance_ref_m`` the distance factor decays as exp(-(d - ref) / scale)."""
    area_half_px: float = field(default=40.0, metadata=field_range(0.0, 1e9))
    """Area factor n / (n + area_half_px) of n visible pixels: 0.5 at this many pixels."""
    occlusion_exponent: float = field(default=0.7, metadata=field_range(0.0, 10.0))
    """Occlusion factor = visible_fraction ** occlusion_exponent."""
    truncation_weight: float = field(default=0.5, metadata=field_range(0.0, 1.0))
    """Truncation factor = 1 - weight * truncation (truncation in [0, 1] from the mask at the border)."""
    off_axis_weight: float = field(default=0.15, metadata=field_range(0.0, 1.0))
    """Off-axis factor = 1 - weight * (bearing of the mask centroid / half horizontal FoV)."""
    exposure_s: float = field(default=0.02, metadata=field_range(0.0, 1.0))
    """Exposure time that turns base motion into blur (px = exposure * (fx * |omega| + fx * |v| / d))."""
    blur_scale_px: float = field(default=10.0, metadata=field_range(0.0, 1e6, low_open=True))
    """Blur factor = exp(-blur_px / blur_scale_px)."""


@dataclass(frozen=True)
class DetectorProfile:
    """An open-vocabulary detector prompted with the target label (GroundingDINO-like by default)."""

    visibility: VisibilityConfig = field(default_factory=VisibilityConfig)
    latency: LatencyConfig = field(default_factory=LatencyConfig)
    max_detection_probability: float = field(default=0.95, metadata=field_range(0.0, 1.0))
    """Detection probability of a prompt-matching object seen at quality 1."""
    quality_exponent: float = field(default=0.5, metadata=field_range(0.0, 10.0))
    """Report probabilities scale with q ** quality_exponent (below 1: a fair view is usually enough)."""
    confidence_floor: float = field(default=0.25, metadata=field_range(0.0, 1.0))
    """Mean confidence of a true detection at quality 0."""
    confidence_ceiling: float = field(default=0.75, metadata=field_range(0.0, 1.0))
    """Mean confidence of a true detection at quality 1."""
    confidence_concentration: float = field(default=12.0, metadata=field_range(0.0, 1e6, low_open=True))
    """Beta concentration kappa = a + b: larger means confidences closer to their mean."""
    confusion_rate: float = field(default=0.18, metadata=field_range(0.0, 1.0))
    """Probability (times q ** quality_exponent) that a visible object marked close to the prompt is boxed
    with the prompt's label."""
    confusion_confidence_scale: float = field(default=0.8, metadata=field_range(0.0, 1.0))
    """A confusion's mean confidence is this fraction of a true detection's at the same quality."""
    false_positive_rate: float = field(default=0.03, metadata=field_range(0.0, 1.0))
    """Probability (times q ** quality_exponent) that any other visible non-wall object is boxed with the
    prompt's label."""
    false_positive_confidence_mean: float = field(default=0.3, metadata=field_range(0.0, 1.0))
    """Mean confidence of such a false positive."""
    box_shrink_frac: float = field(default=0.08, metadata=field_range(0.0, 0.5))
    """Each box edge moves inwards by U(0, this) times the mask's bounding-box side."""


@dataclass(frozen=True)
class DirectionConfig:
    """Open-space 'direction' proposals of the VLM (columns where the camera sees far and clear)."""

    open_depth_m: float = field(default=2.0, metadata=field_range(0.0, 1000.0, low_open=True))
    """A column is open when no obstacle pixel in the band is nearer than this (m)."""
    band_top_frac: float = field(default=0.2, metadata=field_range(0.0, 1.0))
    """Top of the row band searched for obstacles, as a fraction of the image height."""
    band_bottom_frac: float = field(default=0.95, metadata=field_range(0.0, 1.0))
    """Bottom of that band."""
    min_width_deg: float = field(default=6.0, metadata=field_range(0.0, 180.0))
    """Open runs narrower than this horizontal angle are ignored."""
    doorway_max_deg: float = field(default=20.0, metadata=field_range(0.0, 180.0))
    """An open run bounded by obstacles on both sides and narrower than this is called a doorway."""
    report_probability: float = field(default=0.85, metadata=field_range(0.0, 1.0))
    """Probability that the VLM mentions each open direction it could see."""
    max_directions: int = field(default=3, metadata=field_range(0, 100))
    """At most this many direction proposals per view (widest first)."""


@dataclass(frozen=True)
class SceneConfidenceConfig:
    """The VLM's scene confidence C_s ~ Beta around a mean that falls with clutter and blur."""

    max_mean: float = field(default=0.8, metadata=field_range(0.0, 1.0))
    """Mean C_s of a clear, static view."""
    clutter_weight: float = field(default=0.3, metadata=field_range(0.0, 1.0))
    """Mean drop at full clutter."""
    clutter_objects_ref: int = field(default=8, metadata=field_range(1, 10_000))
    """Number of visible non-wall objects that counts as full clutter."""
    blur_weight: float = field(default=0.3, metadata=field_range(0.0, 1.0))
    """Mean drop at full blur (blur factor 0)."""
    concentration: float = field(default=20.0, metadata=field_range(0.0, 1e6, low_open=True))
    """Beta concentration of C_s."""


@dataclass(frozen=True)
class VlmProfile:
    """A scene-level VLM asked where the target is (Qwen2.5-VL-like)."""

    visibility: VisibilityConfig = field(
        default_factory=lambda: VisibilityConfig(
            distance_ref_m=3.0, occlusion_exponent=0.5, truncation_weight=0.3, off_axis_weight=0.1
        )
    )
    latency: LatencyConfig = field(default_factory=lambda: LatencyConfig(mean_s=2.5, jitter_s=0.25))
    max_mention_probability: float = field(default=0.95, metadata=field_range(0.0, 1.0))
    """Probability (times quality ** quality_exponent) that a visible matching or close object is proposed."""
    quality_exponent: float = field(default=0.5, metadata=field_range(0.0, 10.0))
    """Mention probabilities scale with q ** quality_exponent."""
    mention_other_rate: float = field(default=0.15, metadata=field_range(0.0, 1.0))
    """Probability (times q ** quality_exponent) that another visible non-wall object is proposed under its
    own label."""
    confusion_rate: float = field(default=0.16, metadata=field_range(0.0, 1.0))
    """Probability that a proposed object marked close to the target is labelled as the target."""
    swap_rate: float = field(default=0.05, metadata=field_range(0.0, 1.0))
    """Probability that a proposed target object is labelled with one of its close labels instead."""
    hallucination_rate: float = field(default=0.03, metadata=field_range(0.0, 1.0))
    """Probability per view of a target proposal on an in-view pixel that is not the target."""
    point_jitter_frac: float = field(default=0.1, metadata=field_range(0.0, 10.0))
    """Std of the point jitter as a fraction of the visible mask's bounding-box width/height."""
    emit_regions: bool = True
    """Attach a coarse region (jittered mask bounding box) to object proposals."""
    region_jitter_frac: float = field(default=0.2, metadata=field_range(0.0, 10.0))
    """Std of each region edge's jitter as a fraction of the box side."""
    order_noise: float = field(default=0.25, metadata=field_range(0.0, 100.0))
    """Gumbel scale added to the quality when the VLM orders its object proposals."""
    max_object_proposals: int = field(default=5, metadata=field_range(0, 1000))
    """At most this many object proposals per view."""
    directions: DirectionConfig = field(default_factory=DirectionConfig)
    scene_confidence: SceneConfidenceConfig = field(default_factory=SceneConfidenceConfig)


@dataclass(frozen=True)
class PerceptionNoiseConfig:
    """The whole noise model: two detector profiles and one VLM profile."""

    detector: DetectorProfile = field(default_factory=DetectorProfile)
    detector_yolo_world: DetectorProfile = field(default_factory=DetectorProfile)
    vlm: VlmProfile = field(default_factory=VlmProfile)


def _check_cross_fields(config: PerceptionNoiseConfig, where: str) -> None:
    def latency(prefix: str, lat: LatencyConfig) -> None:
        if lat.jitter_s > lat.mean_s:
            raise ConfigError(
                f"{where}: key '{prefix}.latency.jitter_s' must not exceed '{prefix}.latency.mean_s' "
                f"({lat.jitter_s} > {lat.mean_s}): a latency cannot be negative"
            )

    for name in ("detector", "detector_yolo_world"):
        prof: DetectorProfile = getattr(config, name)
        latency(name, prof.latency)
        if prof.confidence_floor > prof.confidence_ceiling:
            raise ConfigError(
                f"{where}: key '{name}.confidence_floor' must not exceed '{name}.confidence_ceiling'"
            )
    latency("vlm", config.vlm.latency)
    d = config.vlm.directions
    if d.band_top_frac >= d.band_bottom_frac:
        raise ConfigError(
            f"{where}: key 'vlm.directions.band_top_frac' must be below 'vlm.directions.band_bottom_frac'"
        )


def noise_config_from_dict(data: Any, *, where: str = "<perception noise>") -> PerceptionNoiseConfig:
    """Build and validate a :class:`PerceptionNoiseConfig` from nested mappings.

    Raises:
        ConfigError: naming ``where`` and the dotted key on an unknown key, a wrong type, an
            out-of-range value or inconsistent pairs (jitter above mean, floor above ceiling).
    """
    config = config_from_dict(data, cls=PerceptionNoiseConfig, where=where)
    _check_cross_fields(config, where)
    return config


def load_noise_model(path: str | Path | None = None) -> PerceptionNoiseConfig:
    """Load the noise model from YAML (the shipped ``sims/perception_noise.yaml`` when ``path`` is None).

    Raises:
        ConfigError: naming the file and key on any invalid entry, or if the file cannot be read/parsed.
    """
    path = DEFAULT_NOISE_PATH if path is None else Path(path)
    where = str(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{where}: cannot read noise model: {exc}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{where}: invalid YAML: {exc}") from exc
    return noise_config_from_dict(data or {}, where=where)


# --------------------------------------------------------------------------------------------------
# What the camera sees of each object
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class VisibleObject:
    """Measurements of one object's visible mask in one frame (nothing here comes from hidden state).

    Attributes:
        object_id: the scene object id the segmentation holds.
        pixel_count: number of visible pixels.
        bbox_px: ``(u_min, v_min, u_max, v_max)`` of the visible pixels, in pixel-centre coordinates.
        anchor_px: the visible pixel nearest the mask centroid ``(u, v)`` (always on the object).
        depth_m: median valid depth over the visible pixels (inf when none is valid).
        visible_fraction: visible pixels / pixels the object's narrowest nominal silhouette would cover
            at that depth (along a dimension cut by the image border, the visible extent), clipped to
            [0, 1]: 1 - occlusion.
        truncation: in [0, 1], the largest share of the mask's extent lying on one image border.
        off_axis: bearing of the centroid over the half horizontal field of view, in [0, 1].
    """

    object_id: int
    pixel_count: int
    bbox_px: tuple[int, int, int, int]
    anchor_px: tuple[int, int]
    depth_m: float
    visible_fraction: float
    truncation: float
    off_axis: float


def _valid_depth(depth: npt.NDArray[np.floating[Any]]) -> npt.NDArray[np.bool_]:
    return np.isfinite(depth) & (depth > 0.0)


def _nominal_silhouette_m(obj: SceneObject) -> tuple[float, float]:
    """Width and height (m) of the object's narrowest side silhouette (its nominal size, not its pose).

    The narrowest width is used so that a box seen edge-on is not mistaken for an occluded one.
    """
    sx, sy, sz = (abs(float(s)) for s in obj.size_m)
    width = 2.0 * sx if obj.shape == "cylinder" else 2.0 * min(sx, sy)
    return width, 2.0 * sz


def _validate_observation(observation: Observation) -> npt.NDArray[np.int32]:
    seg = observation.segmentation
    if seg is None:
        raise InvalidInputError(
            "observation.segmentation is None: the perception emulator needs the simulator's segmentation"
        )
    seg = np.asarray(seg)
    depth = np.asarray(observation.depth_m)
    k = observation.intrinsics
    expected = (k.height_px, k.width_px)
    if seg.shape != expected:
        raise InvalidInputError(f"observation.segmentation has shape {seg.shape}, expected {expected}")
    if depth.shape != expected:
        raise InvalidInputError(f"observation.depth_m has shape {depth.shape}, expected {expected}")
    if not np.issubdtype(seg.dtype, np.integer):
        raise InvalidInputError(f"observation.segmentation must hold integer ids, got dtype {seg.dtype}")
    require_finite("observation.intrinsics", [k.fx_px, k.fy_px, k.cx_px, k.cy_px])
    if k.fx_px <= 0 or k.fy_px <= 0:
        raise InvalidInputError("observation.intrinsics focal lengths must be positive")
    return seg


def analyse_view(
    observation: Observation, scene: SceneSpec, *, min_pixels: int = 1
) -> dict[int, VisibleObject]:
    """Measure every object with at least ``min_pixels`` visible pixels in ``observation``.

    Raises:
        InvalidInputError: when the segmentation is missing, has the wrong shape, or holds an id the
            scene does not know.
    """
    seg = _validate_observation(observation)
    depth = np.asarray(observation.depth_m, dtype=np.float64)
    k = observation.intrinsics
    height, width = seg.shape
    valid = _valid_depth(depth)
    objects = {obj.object_id: obj for obj in scene.objects}
    ids, counts = np.unique(seg, return_counts=True)
    half_fov = math.atan2(width / 2.0, k.fx_px)
    out: dict[int, VisibleObject] = {}
    for oid, count in zip(ids.tolist(), counts.tolist(), strict=True):
        if oid == BACKGROUND_OBJECT_ID:
            continue
        if oid not in objects:
            raise InvalidInputError(
                f"observation.segmentation holds id {oid}, unknown to scene '{scene.name}'"
            )
        if count < min_pixels:
            continue
        rows, cols = np.nonzero(seg == oid)
        u0, u1, v0, v1 = int(cols.min()), int(cols.max()), int(rows.min()), int(rows.max())
        mask_depth = depth[rows, cols][valid[rows, cols]]
        depth_m = float(np.median(mask_depth)) if mask_depth.size else math.inf
        box_h, box_w = v1 - v0 + 1, u1 - u0 + 1
        cut_horizontally = u0 == 0 or u1 == width - 1
        cut_vertically = v0 == 0 or v1 == height - 1
        if math.isfinite(depth_m):
            # Expected pixels of the whole object at the measured depth. Along a dimension cut by the
            # image border the visible extent is all one can expect: truncation has its own factor.
            width_m, height_m = _nominal_silhouette_m(objects[oid])
            expected_w = box_w if cut_horizontally else k.fx_px * width_m / depth_m
            expected_h = box_h if cut_vertically else k.fy_px * height_m / depth_m
            expected_px = expected_w * expected_h
            visible_fraction = min(1.0, count / expected_px) if expected_px > 0 else 1.0
        else:
            visible_fraction = 1.0
        truncation = 0.0
        if u0 == 0:
            truncation = max(truncation, np.unique(rows[cols == 0]).size / box_h)
        if u1 == width - 1:
            truncation = max(truncation, np.unique(rows[cols == width - 1]).size / box_h)
        if v0 == 0:
            truncation = max(truncation, np.unique(cols[rows == 0]).size / box_w)
        if v1 == height - 1:
            truncation = max(truncation, np.unique(cols[rows == height - 1]).size / box_w)
        uc, vc = float(cols.mean()), float(rows.mean())
        nearest = int(np.argmin((cols - uc) ** 2 + (rows - vc) ** 2))
        off_axis = min(1.0, abs(math.atan2(uc - k.cx_px, k.fx_px)) / half_fov)
        out[oid] = VisibleObject(
            object_id=oid,
            pixel_count=int(count),
            bbox_px=(u0, v0, u1, v1),
            anchor_px=(int(cols[nearest]), int(rows[nearest])),
            depth_m=depth_m,
            visible_fraction=float(visible_fraction),
            truncation=float(truncation),
            off_axis=float(off_axis),
        )
    return out


@dataclass(frozen=True)
class QualityFactors:
    """The factors whose product is an object's view quality ``q`` (each in [0, 1])."""

    distance: float
    area: float
    occlusion: float
    truncation: float
    off_axis: float
    blur: float

    @property
    def quality(self) -> float:
        return self.distance * self.area * self.occlusion * self.truncation * self.off_axis * self.blur


def _blur_px(motion: Twist, fx_px: float, depth_m: float, exposure_s: float) -> float:
    linear = math.hypot(motion.linear_x_mps, motion.linear_y_mps)
    per_depth = linear / depth_m if math.isfinite(depth_m) and depth_m > 0 else 0.0
    return exposure_s * fx_px * (abs(motion.angular_z_radps) + per_depth)


def quality_factors(
    vis: VisibleObject, cfg: VisibilityConfig, *, motion: Twist, fx_px: float
) -> QualityFactors:
    """The view-quality factors of ``vis`` under ``cfg`` while the base moves with ``motion``."""
    d = vis.depth_m
    distance = math.exp(-max(0.0, d - cfg.distance_ref_m) / cfg.distance_scale_m) if math.isfinite(d) else 0.0
    area = vis.pixel_count / (vis.pixel_count + cfg.area_half_px)
    occlusion = vis.visible_fraction**cfg.occlusion_exponent
    truncation = 1.0 - cfg.truncation_weight * vis.truncation
    off_axis = 1.0 - cfg.off_axis_weight * vis.off_axis
    blur = math.exp(-_blur_px(motion, fx_px, d, cfg.exposure_s) / cfg.blur_scale_px)
    return QualityFactors(distance, area, occlusion, truncation, off_axis, blur)


def _beta(rng: np.random.Generator, mean: float, concentration: float) -> float:
    mean = min(1.0 - _MEAN_EPS, max(_MEAN_EPS, mean))
    return float(rng.beta(mean * concentration, (1.0 - mean) * concentration))


# --------------------------------------------------------------------------------------------------
# Outputs
# --------------------------------------------------------------------------------------------------

ReportKind = Literal["true", "confusion", "false_positive", "other", "hallucination", "direction"]


@dataclass(frozen=True)
class ReportProvenance:
    """Ground truth behind one emulated report (for tests, calibration and debugging only).

    Attributes:
        source: ``"detector"`` or ``"vlm"``.
        index: position of the report in its source's output (detections, or scene proposals).
        kind: ``"true"`` (prompt-matching object, right label), ``"confusion"`` (close class labelled as
            the target, or the target labelled as a close class), ``"false_positive"``, ``"other"``
            (an unrelated object under its own label), ``"hallucination"``, ``"direction"``.
        object_id: the object it was generated from; None for hallucinations and directions.
        quality: the object's view quality q (0 for hallucinations and directions).
    """

    source: Literal["detector", "vlm"]
    index: int
    kind: ReportKind
    object_id: int | None
    quality: float


@dataclass(frozen=True)
class EmulatedPerception:
    """One frame's emulated evidence.

    Attributes:
        scene_evidence: the VLM's proposals and scene confidence C_s.
        detections: the detector's boxes, highest confidence first.
        vlm_latency_s: simulated VLM latency on the backend clock.
        detector_latency_s: simulated detector latency on the backend clock.
        debug: provenance of every report (ground truth; never feed it to the method).
    """

    scene_evidence: SceneEvidence
    detections: tuple[Detection, ...]
    vlm_latency_s: float
    detector_latency_s: float
    debug: tuple[ReportProvenance, ...] = ()


def _draw_latency(rng: np.random.Generator, cfg: LatencyConfig) -> float:
    return float(max(0.0, cfg.mean_s + rng.uniform(-cfg.jitter_s, cfg.jitter_s)))


def _shrunk_box(
    rng: np.random.Generator, bbox: tuple[int, int, int, int], frac: float
) -> tuple[float, float, float, float]:
    u0, v0, u1, v1 = (float(x) for x in bbox)
    w, h = u1 - u0, v1 - v0
    du0, dv0, du1, dv1 = rng.uniform(0.0, frac, size=4)
    # Each side moves inwards by at most frac <= 0.5 of the side, so the box stays ordered and inside.
    return (u0 + du0 * w, v0 + dv0 * h, u1 - du1 * w, v1 - dv1 * h)


def _emulate_detector(
    visible: dict[int, VisibleObject],
    grades: dict[int, PromptGrade],
    *,
    prompt: str,
    profile: DetectorProfile,
    motion: Twist,
    fx_px: float,
    rng: np.random.Generator,
) -> tuple[list[Detection], list[tuple[ReportKind, int, float]]]:
    """Boxes for the visible objects, each drawn by its grade (a prompted detector labels every box with
    the prompt's phrase, as GroundingDINO labels a box with the prompt tokens it grounded)."""
    found: list[tuple[Detection, ReportKind, int, float]] = []
    span = profile.confidence_ceiling - profile.confidence_floor
    for oid in sorted(visible):
        vis, graded = visible[oid], grades.get(oid)
        if graded is None or vis.pixel_count < profile.visibility.min_pixels:
            continue
        q = quality_factors(vis, profile.visibility, motion=motion, fx_px=fx_px).quality
        seen = q**profile.quality_exponent
        true_mean = profile.confidence_floor + span * q
        kind: ReportKind
        if graded.kind == "match":
            kind = "true"
            probability, mean = profile.max_detection_probability * seen, true_mean
        elif graded.kind == "related":
            kind = "confusion"
            probability, mean = profile.confusion_rate * seen, profile.confusion_confidence_scale * true_mean
        else:
            kind = "false_positive"
            probability, mean = profile.false_positive_rate * seen, profile.false_positive_confidence_mean
        if rng.random() >= probability:
            continue
        confidence = _beta(rng, mean, profile.confidence_concentration)
        box = _shrunk_box(rng, vis.bbox_px, profile.box_shrink_frac)
        found.append((Detection(box_xyxy_px=box, label=prompt, confidence=confidence), kind, oid, q))
    # Stable sort: ties keep the object-id order, so the output is reproducible.
    found.sort(key=lambda item: -item[0].confidence)
    return [f[0] for f in found], [(f[1], f[2], f[3]) for f in found]


def _clip_point(u: float, v: float, width: int, height: int) -> tuple[float, float]:
    return (min(max(u, 0.0), width - 1.0), min(max(v, 0.0), height - 1.0))


def _horizon_row(observation: Observation) -> float:
    """Image row of the horizon through the principal point (where a level ray meets the image)."""
    k = observation.intrinsics
    rot = np.asarray(observation.camera_to_world, dtype=np.float64)[:3, :3]
    r21, r22 = float(rot[2, 1]), float(rot[2, 2])
    if abs(r21) < 1e-6:
        return k.cy_px
    return k.cy_px - k.fy_px * r22 / r21


def open_directions(
    observation: Observation, scene: SceneSpec, cfg: DirectionConfig
) -> list[tuple[tuple[float, float], str, tuple[float, float, float, float], float]]:
    """Open image directions: runs of columns where no obstacle pixel is nearer than ``open_depth_m``.

    A column's clearance is the nearest valid depth over its obstacle pixels (segmentation ids of
    objects with ``is_obstacle``) inside the row band; a column with none is open. Each run of open
    columns at least ``min_width_deg`` wide yields a point on an open pixel (background or a
    non-obstacle, depth beyond ``open_depth_m`` or no return) nearest the horizon in its middle column.

    Returns:
        ``(point_px, label, region_px, width_deg)`` per run, widest first.
    """
    seg = _validate_observation(observation)
    depth = np.asarray(observation.depth_m, dtype=np.float64)
    k = observation.intrinsics
    height, width = seg.shape
    obstacle_ids = np.array([o.object_id for o in scene.objects if o.is_obstacle], dtype=np.int64)
    is_obstacle = np.isin(seg, obstacle_ids)
    valid = _valid_depth(depth)
    top = int(math.floor(cfg.band_top_frac * height))
    bottom = max(top + 1, int(math.ceil(cfg.band_bottom_frac * height)))
    band_obstacle_depth = np.where(is_obstacle & valid, depth, np.inf)[top:bottom]
    # An obstacle pixel with no depth return is too close or too far to tell: treat it as blocking.
    band_blind = (is_obstacle & ~valid)[top:bottom].any(axis=0)
    clearance = band_obstacle_depth.min(axis=0)
    open_col = (clearance >= cfg.open_depth_m) & ~band_blind
    open_px = ~is_obstacle & (~valid | (depth >= cfg.open_depth_m))
    horizon = _horizon_row(observation)
    deg_per_col = lambda u0, u1: math.degrees(  # noqa: E731 - tiny local helper
        math.atan2(u1 + 0.5 - k.cx_px, k.fx_px) - math.atan2(u0 - 0.5 - k.cx_px, k.fx_px)
    )
    runs: list[tuple[int, int]] = []
    u = 0
    while u < width:
        if open_col[u]:
            start = u
            while u + 1 < width and open_col[u + 1]:
                u += 1
            runs.append((start, u))
        u += 1
    out = []
    for u0, u1 in runs:
        width_deg = deg_per_col(u0, u1)
        if width_deg < cfg.min_width_deg:
            continue
        mid = (u0 + u1) // 2
        rows = np.nonzero(open_px[:, mid])[0]
        if rows.size == 0:
            continue
        v = int(rows[np.argmin(np.abs(rows - horizon))])
        left_edge, right_edge = u0 == 0, u1 == width - 1
        if left_edge and not right_edge:
            label = "unexplored area on the left"
        elif right_edge and not left_edge:
            label = "unexplored area on the right"
        elif not left_edge and not right_edge and width_deg <= cfg.doorway_max_deg:
            label = "doorway"
        else:
            label = "open corridor"
        region = (float(u0), float(top), float(u1), float(bottom - 1))
        out.append(((float(mid), float(v)), label, region, width_deg))
    out.sort(key=lambda item: -item[3])
    return out


def _scene_confidence(
    visible: dict[int, VisibleObject],
    objects: dict[int, SceneObject],
    profile: VlmProfile,
    *,
    motion: Twist,
    fx_px: float,
    rng: np.random.Generator,
) -> float:
    cfg = profile.scene_confidence
    n_objects = sum(1 for oid in visible if objects[oid].role != "wall")
    clutter = min(1.0, n_objects / cfg.clutter_objects_ref)
    blur = math.exp(
        -_blur_px(motion, fx_px, math.inf, profile.visibility.exposure_s) / profile.visibility.blur_scale_px
    )
    mean = cfg.max_mean - cfg.clutter_weight * clutter - cfg.blur_weight * (1.0 - blur)
    return _beta(rng, mean, cfg.concentration)


def _own_name(obj: SceneObject, rng: np.random.Generator) -> str:
    """What the VLM calls ``obj`` in its own words: its label half of the time, else one of its aliases."""
    names = own_names(obj)
    if len(names) == 1 or rng.random() < 0.5:
        return names[0]
    return names[1 + int(rng.integers(len(names) - 1))]


def _emulate_vlm(
    observation: Observation,
    scene: SceneSpec,
    visible: dict[int, VisibleObject],
    objects: dict[int, SceneObject],
    grades: dict[int, PromptGrade],
    *,
    profile: VlmProfile,
    motion: Twist,
    rng: np.random.Generator,
) -> tuple[SceneEvidence, list[tuple[ReportKind, int | None, float]]]:
    """Proposals for the visible objects in the VLM's own words (never the instruction's): an object the
    prompt names under one of its names; a related one under its own, or now and then (a confusion)
    under the name of an object of the prompted kind in the scene; others under their own names."""
    k = observation.intrinsics
    seg = np.asarray(observation.segmentation)
    height, width = seg.shape
    # The names of the prompted kind in this scene, which a confused VLM gives to a look-alike.
    prompted = [o for o in objects.values() if grades.get(o.object_id, _UNRELATED).kind == "match"]
    prompted_names = tuple(sorted({o.label for o in prompted}))
    related_names = tuple(sorted({objects[oid].label for oid, g in grades.items() if g.kind == "related"}))
    # (names the prompted kind, salience, proposal, kind, object id, quality); the VLM answers with what
    # it believes is the prompted kind first, then by salience.
    items: list[tuple[bool, float, SceneProposal, ReportKind, int | None, float]] = []
    for oid in sorted(visible):
        vis, graded = visible[oid], grades.get(oid)
        if graded is None or vis.pixel_count < profile.visibility.min_pixels:
            continue
        obj = objects[oid]
        q = quality_factors(vis, profile.visibility, motion=motion, fx_px=k.fx_px).quality
        seen = q**profile.quality_exponent
        kind: ReportKind
        if graded.kind == "match":
            probability = profile.max_mention_probability * seen
            label, kind = _own_name(obj, rng), "true"
            if related_names and rng.random() < profile.swap_rate:
                label, kind = related_names[int(rng.integers(len(related_names)))], "confusion"
        elif graded.kind == "related":
            probability = profile.max_mention_probability * seen
            label, kind = _own_name(obj, rng), "other"
            if prompted_names and rng.random() < profile.confusion_rate:
                label, kind = prompted_names[int(rng.integers(len(prompted_names)))], "confusion"
        else:
            probability = profile.mention_other_rate * seen
            label, kind = _own_name(obj, rng), "other"
        if rng.random() >= probability:
            continue
        u0, v0, u1, v1 = vis.bbox_px
        bw, bh = u1 - u0 + 1.0, v1 - v0 + 1.0
        jitter = rng.normal(0.0, profile.point_jitter_frac, size=2) * (bw, bh)
        point = _clip_point(vis.anchor_px[0] + jitter[0], vis.anchor_px[1] + jitter[1], width, height)
        region = None
        if profile.emit_regions:
            e = rng.normal(0.0, profile.region_jitter_frac, size=4) * (bw, bh, bw, bh)
            a, b = _clip_point(u0 + e[0], v0 + e[1], width, height)
            c, d = _clip_point(u1 + e[2], v1 + e[3], width, height)
            region = (min(a, c), min(b, d), max(a, c), max(b, d))
        salience = q + profile.order_noise * float(rng.gumbel())
        believed = kind == "true" or label in prompted_names
        proposal = SceneProposal(point_px=point, label=label, region_px=region)
        items.append((believed, salience, proposal, kind, oid, q))

    if prompted_names and rng.random() < profile.hallucination_rate:
        # A prompted kind the scene holds, seen where it is not: on in-view pixels of anything else.
        target_ids = [o.object_id for o in prompted]
        candidates = np.flatnonzero(~np.isin(seg, target_ids))
        if candidates.size:
            flat = int(candidates[int(rng.integers(candidates.size))])
            v, u = divmod(flat, width)
            salience = float(rng.uniform(0.0, 1.0)) + profile.order_noise * float(rng.gumbel())
            label = prompted_names[int(rng.integers(len(prompted_names)))]
            proposal = SceneProposal(point_px=(float(u), float(v)), label=label)
            items.append((True, salience, proposal, "hallucination", None, 0.0))

    items.sort(key=lambda it: (not it[0], -it[1]))
    items = items[: profile.max_object_proposals]

    directions: list[SceneProposal] = []
    for point, label, region, _ in open_directions(observation, scene, profile.directions):
        if len(directions) >= profile.directions.max_directions:
            break
        if rng.random() < profile.directions.report_probability:
            directions.append(SceneProposal(point_px=point, label=label, kind="direction", region_px=region))

    scene_confidence = _scene_confidence(visible, objects, profile, motion=motion, fx_px=k.fx_px, rng=rng)
    proposals = tuple(it[2] for it in items) + tuple(directions)
    provenance: list[tuple[ReportKind, int | None, float]] = [(it[3], it[4], it[5]) for it in items]
    provenance += [("direction", None, 0.0)] * len(directions)
    evidence = SceneEvidence(
        proposals=proposals, scene_confidence=scene_confidence, stamp_s=observation.stamp_s
    )
    return evidence, provenance


_UNRELATED = PromptGrade("unrelated", 0.0)


def prompt_grades(scene: SceneSpec, prompt: ParsedInstruction) -> dict[int, PromptGrade]:
    """Every non-wall object's grade for ``prompt``."""
    pairs: frozenset[frozenset[NounKey]] = close_name_pairs(scene)
    return {o.object_id: grade(o, prompt, pairs) for o in scene.objects if o.role != "wall"}


def emulate(
    observation: Observation,
    scene: SceneSpec,
    *,
    target_label: str,
    motion: Twist | None = None,
    rng: np.random.Generator,
    noise: PerceptionNoiseConfig | None = None,
    detector_profile: DetectorProfileName = "detector",
) -> EmulatedPerception:
    """Emulate the VLM and the detector on one frame.

    Args:
        observation: the frame; its ``segmentation`` is required (simulation ground truth of what is
            visible).
        scene: the scene's labels, categories, roles and nominal sizes (positions are never read).
        target_label: the detector's text prompt and the VLM's query (``instruction_target(instruction)``).
        motion: the base twist while the frame was taken (blur); None means standing still.
        rng: the only source of randomness; the same generator state gives the same evidence.
        noise: the noise model; the shipped default when None.
        detector_profile: ``"detector"`` (GroundingDINO-like) or ``"detector_yolo_world"``.

    Raises:
        InvalidInputError: on a missing/ill-shaped segmentation, an unknown id, an empty target label or
            a non-finite motion.
    """
    if not canonical_tokens(target_label)[0]:
        raise InvalidInputError(f"target_label must name something, got {target_label!r}")
    motion = Twist.zero() if motion is None else motion
    require_finite("motion", [motion.linear_x_mps, motion.linear_y_mps, motion.angular_z_radps])
    noise = _default_noise() if noise is None else noise
    if detector_profile not in ("detector", "detector_yolo_world"):
        raise InvalidInputError(
            f"detector_profile must be 'detector' or 'detector_yolo_world', got {detector_profile!r}"
        )
    det_profile: DetectorProfile = getattr(noise, detector_profile)
    objects = {obj.object_id: obj for obj in scene.objects}
    min_pixels = min(det_profile.visibility.min_pixels, noise.vlm.visibility.min_pixels)
    visible = analyse_view(observation, scene, min_pixels=min_pixels)
    grades = prompt_grades(scene, parse_instruction(target_label))
    fx = observation.intrinsics.fx_px

    detections, det_prov = _emulate_detector(
        visible, grades, prompt=target_label, profile=det_profile, motion=motion, fx_px=fx, rng=rng
    )
    evidence, vlm_prov = _emulate_vlm(
        observation, scene, visible, objects, grades, profile=noise.vlm, motion=motion, rng=rng
    )
    vlm_latency = _draw_latency(rng, noise.vlm.latency)
    det_latency = _draw_latency(rng, det_profile.latency)
    debug = tuple(
        ReportProvenance("detector", i, kind, oid, q) for i, (kind, oid, q) in enumerate(det_prov)
    ) + tuple(ReportProvenance("vlm", i, kind, oid, q) for i, (kind, oid, q) in enumerate(vlm_prov))
    return EmulatedPerception(
        scene_evidence=evidence,
        detections=tuple(detections),
        vlm_latency_s=vlm_latency,
        detector_latency_s=det_latency,
        debug=debug,
    )


_DEFAULT_NOISE: PerceptionNoiseConfig | None = None


def _default_noise() -> PerceptionNoiseConfig:
    global _DEFAULT_NOISE
    if _DEFAULT_NOISE is None:
        _DEFAULT_NOISE = load_noise_model()
    return _DEFAULT_NOISE


class PerceptionEmulator:
    """A ``semexp_bt.perception.interface.PerceptionSource`` backed by :func:`emulate`.

    ``submit`` computes the evidence at once (the frame is what the camera saw at ``now_s``) but the job
    releases it only when the slower enabled model's simulated latency has passed on the backend clock,
    as the two models run in parallel (paper Sec. V: about 2.5 s per viewpoint).

    Args:
        scene: the scene being explored.
        seed: seeds the emulator's own ``numpy.random.Generator``; one generator serves every request,
            so a run is reproducible from its seed and its sequence of requests.
        noise: the noise model (the shipped default when None).
        detector_profile: which detector profile to emulate.
        enable_vlm: emulate the VLM (False for a detector-only baseline).
        enable_detector: emulate the detector (False for a VLM-only baseline).
    """

    def __init__(
        self,
        scene: SceneSpec,
        *,
        seed: int,
        noise: PerceptionNoiseConfig | None = None,
        detector_profile: DetectorProfileName = "detector",
        enable_vlm: bool = True,
        enable_detector: bool = True,
    ) -> None:
        if not (enable_vlm or enable_detector):
            raise ValueError("PerceptionEmulator needs at least one of enable_vlm / enable_detector")
        self.scene = scene
        self.noise = _default_noise() if noise is None else noise
        self.detector_profile: DetectorProfileName = detector_profile
        self.enable_vlm = enable_vlm
        self.enable_detector = enable_detector
        self._rng = np.random.default_rng(seed)
        self.last: EmulatedPerception | None = None
        """The last emulation, provenance included (for recorders and tests)."""

    def submit(
        self, *, observation: Observation, instruction: str, target_label: str, motion: Twist, now_s: float
    ) -> ReadyJob:
        """Emulate both models on ``observation``; the job is ready after the simulated latency."""
        del instruction  # the emulator is prompted with the target label, as the detector would be
        require_finite("now_s", now_s)
        out = emulate(
            observation,
            self.scene,
            target_label=target_label,
            motion=motion,
            rng=self._rng,
            noise=self.noise,
            detector_profile=self.detector_profile,
        )
        self.last = out
        latencies = [out.vlm_latency_s] if self.enable_vlm else []
        latencies += [out.detector_latency_s] if self.enable_detector else []
        result = PerceptionResult(
            scene=out.scene_evidence if self.enable_vlm else None,
            detections=out.detections if self.enable_detector else None,
            observation_stamp_s=observation.stamp_s,
            scene_latency_s=out.vlm_latency_s if self.enable_vlm else 0.0,
            detector_latency_s=out.detector_latency_s if self.enable_detector else 0.0,
        )
        return ReadyJob(result=result, ready_at_s=now_s + max(latencies))
