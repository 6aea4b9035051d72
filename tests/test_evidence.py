"""Tests for semexp_bt.core.evidence: calibration (Eq. 1), scoring (Eq. 2), selection (Eq. 3), location fusion
(Eq. 4), association, depth feasibility kappa, and input validation."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.config import ArbitrationConfig
from semexp_bt.core.evidence import (
    TIE_RELATIVE_TOLERANCE,
    ArbitrationResult,
    arbitrate,
    calibrate,
    calibrate_array,
    candidate_box,
    depth_feasibility,
    scene_region,
)
from semexp_bt.core.types import Detection, InvalidInputError, SceneEvidence, SceneProposal

WIDTH, HEIGHT = 640, 480
TARGET = "mug"

# tau = 0.5 makes Eq. 1 easy to work by hand: C~ = 2 C - 1 above 0.5. beta_s = 2 tells C~_s^beta_s apart
# from C~_s; lambda = 0.5 makes the IoU term a square root.
# The hand-worked examples use the paper's literal rule (a term whose source does not cover the candidate
# is omitted); the cross-source consistency reading is tested separately below.
CONFIG = ArbitrationConfig(
    tau=0.5,
    beta_o=1.0,
    beta_s=2.0,
    lambda_iou=0.5,
    mu=1.0,
    epsilon=1e-3,
    cross_source_consistency=False,
    direction_prior=1.0,
)


def aligned(label: str) -> bool:
    return label == TARGET


def run(**kwargs: object) -> ArbitrationResult:
    base: dict[str, object] = {"is_aligned": aligned, "config": CONFIG, "image_size": (WIDTH, HEIGHT)}
    base.update(kwargs)
    return arbitrate(**base)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------------------
# Eq. 1 calibration
# ---------------------------------------------------------------------------------------------------------


def test_calibrate_hand_worked() -> None:
    # tau = 0.25: (0.7 - 0.25) / 0.75 = 0.6; at or below tau -> 0; C = 1 -> 1.
    assert calibrate(0.7, 0.25) == pytest.approx(0.6)
    assert calibrate(0.25, 0.25) == 0.0
    assert calibrate(0.1, 0.25) == 0.0
    assert calibrate(1.0, 0.25) == 1.0
    # tau = 0 is the identity.
    assert calibrate(0.37, 0.0) == pytest.approx(0.37)
    np.testing.assert_allclose(calibrate_array([0.1, 0.7, 1.0], 0.25), [0.0, 0.6, 1.0])


@pytest.mark.parametrize("tau", [1.0, -0.1, math.nan, math.inf])
def test_calibrate_rejects_bad_tau(tau: float) -> None:
    with pytest.raises(InvalidInputError, match="tau"):
        calibrate(0.5, tau)


@pytest.mark.parametrize("confidence", [math.nan, math.inf, -math.inf, 1.5, -0.1])
def test_calibrate_rejects_bad_confidence(confidence: float) -> None:
    with pytest.raises(InvalidInputError, match="confidence"):
        calibrate(confidence, 0.25)
    with pytest.raises(InvalidInputError, match=r"confidences\[1\]"):
        calibrate_array([0.5, confidence], 0.25)


@given(
    c1=st.floats(0.0, 1.0),
    c2=st.floats(0.0, 1.0),
    tau=st.floats(0.0, 1.0, exclude_max=True),
)
def test_calibrate_is_monotone_and_bounded(c1: float, c2: float, tau: float) -> None:
    low, high = sorted((c1, c2))
    cal_low, cal_high = calibrate(low, tau), calibrate(high, tau)
    assert 0.0 <= cal_low <= cal_high <= 1.0
    assert calibrate_array([low, high], tau).tolist() == pytest.approx([cal_low, cal_high])


# ---------------------------------------------------------------------------------------------------------
# Scene regions
# ---------------------------------------------------------------------------------------------------------


def test_scene_region_square_clipped_or_given() -> None:
    config = dataclasses.replace(CONFIG, scene_region_half_size_px=40.0)
    point_only = SceneProposal(point_px=(10.0, 470.0), label=TARGET)
    assert scene_region(point_only, config) == (-30.0, 430.0, 50.0, 510.0)
    assert scene_region(point_only, config, WIDTH, HEIGHT) == (0.0, 430.0, 50.0, 479.0)
    boxed = SceneProposal(point_px=(10.0, 10.0), label=TARGET, region_px=(5.0, 6.0, 700.0, 20.0))
    assert scene_region(boxed, config, WIDTH, HEIGHT) == (5.0, 6.0, 639.0, 20.0)
    with pytest.raises(InvalidInputError, match="region_px"):
        scene_region(SceneProposal((1.0, 1.0), TARGET, region_px=(5.0, 5.0, 1.0, 9.0)), config)
    with pytest.raises(InvalidInputError, match="point_px"):
        scene_region(SceneProposal((math.nan, 1.0), TARGET), config)


# ---------------------------------------------------------------------------------------------------------
# Eq. 2-4 hand-worked
# ---------------------------------------------------------------------------------------------------------

# Detection A: box (100, 100, 200, 200), centre (150, 150), C_o = 0.9 -> C~_o = 0.8.
DET_A = Detection(box_xyxy_px=(100.0, 100.0, 200.0, 200.0), label=TARGET, confidence=0.9)
# Detection B: box (400, 300, 450, 350), C_o = 0.7 -> C~_o = 0.4; overlaps no scene region.
DET_B = Detection(box_xyxy_px=(400.0, 300.0, 450.0, 350.0), label=TARGET, confidence=0.7)
# Scene object proposal at (200, 150) with region (150, 100, 250, 200): IoU with A = 5000 / 15000 = 1/3.
PROP_MUG = SceneProposal(
    point_px=(200.0, 150.0), label=TARGET, kind="object", region_px=(150.0, 100.0, 250.0, 200.0)
)
# An unexplored direction, far from everything.
PROP_DOOR = SceneProposal(point_px=(600.0, 50.0), label="doorway", kind="direction")
# C_s = 0.8 -> C~_s = 0.6 -> C~_s^2 = 0.36.
SCENE_CONFIDENCE = 0.8


def test_eq2_eq3_hand_worked_three_candidates() -> None:
    scene = SceneEvidence(proposals=(PROP_MUG, PROP_DOOR), scene_confidence=SCENE_CONFIDENCE)
    result = run(scene=scene, detections=[DET_A, DET_B])
    fused, lone, door = result.candidates
    # Fused A + mug: S = 0.8 * 0.36 * (1/3 + 0.001)^0.5 = 0.288 * 0.578216 = 0.1665261.
    assert (fused.source, fused.detection_index, fused.proposal_index) == ("fused", 0, 0)
    assert fused.iou == pytest.approx(1.0 / 3.0)
    assert fused.calibrated_object_confidence == pytest.approx(0.8)
    assert fused.calibrated_scene_confidence == pytest.approx(0.6)
    assert fused.score == pytest.approx(0.1665261, rel=1e-6)
    # Detection B alone: no C_s and no IoU term: S = 0.4.
    assert (lone.source, lone.detection_index, lone.proposal_index) == ("object", 1, None)
    assert lone.calibrated_scene_confidence is None and lone.iou is None
    assert lone.score == pytest.approx(0.4)
    # Direction alone: no C_o and no IoU term: S = 0.36.
    assert (door.source, door.kind, door.proposal_index) == ("scene", "direction", 1)
    assert door.score == pytest.approx(0.36)
    # Eq. 3: t* = B, C_f = 0.4 / (0.1665261 + 0.4 + 0.36) = 0.4317202.
    assert result.winner_index == 1
    assert result.target is not None
    assert result.target.fused_confidence == pytest.approx(0.4317202, rel=1e-6)
    assert result.target.source == "object" and result.target.kind == "object"
    assert result.target.pixel_px == pytest.approx((425.0, 325.0))
    assert result.target.depth_m is None
    assert sum(c.normalised_score for c in result.candidates) == pytest.approx(1.0)
    assert all(c.kappa is None for c in result.candidates)  # no depth image: no kappa term


def test_eq4_fused_location_hand_worked() -> None:
    scene = SceneEvidence(proposals=(PROP_MUG,), scene_confidence=SCENE_CONFIDENCE)
    result = run(scene=scene, detections=[DET_A])
    assert len(result.candidates) == 1  # the mug proposal was absorbed by detection A
    # w = 0.8 / (0.8 + 0.36) = 0.6896552; p_t = w (150, 150) + (1 - w) (200, 150) = (165.5172, 150).
    winner = result.winner
    assert winner is not None and winner.object_weight == pytest.approx(0.6896552, rel=1e-6)
    assert result.target is not None
    assert result.target.pixel_px == pytest.approx((165.5172414, 150.0))
    assert result.target.source == "fused"
    assert result.target.fused_confidence == 1.0  # a single candidate takes all the mass
    assert result.target.label == TARGET


def test_fused_candidate_carries_the_detection_label() -> None:
    # The VLM words the object differently; both are aligned with the instruction.
    def is_mug(label: str) -> bool:
        return "mug" in label

    vlm = dataclasses.replace(PROP_MUG, label="a coffee mug")
    result = run(scene=SceneEvidence((vlm,), 0.8), detections=[DET_A], is_aligned=is_mug)
    assert result.target is not None and result.target.label == TARGET


def test_candidate_box_is_the_detection_box_else_the_vlm_region_else_none() -> None:
    boxed = dataclasses.replace(PROP_MUG, label="a red cup", region_px=(10.0, 20.0, 30.0, 40.0))
    bare = dataclasses.replace(PROP_MUG, label="a blue cup", point_px=(400.0, 300.0), region_px=None)
    scene = SceneEvidence((PROP_MUG, boxed, bare, PROP_DOOR), 0.8)
    result = run(scene=scene, detections=[DET_A], is_aligned=lambda label: label == TARGET or "cup" in label)
    by_label = {c.label: c for c in result.candidates}
    assert candidate_box(by_label[TARGET], scene) == DET_A.box_xyxy_px  # fused: the detection's box
    assert candidate_box(by_label["a red cup"], scene) == (10.0, 20.0, 30.0, 40.0)
    assert candidate_box(by_label["a blue cup"], scene) is None
    assert candidate_box(by_label[PROP_DOOR.label], scene) is None  # a direction outlines no object


def test_prior_multiplies_the_score() -> None:
    scene = SceneEvidence(proposals=(PROP_DOOR,), scene_confidence=SCENE_CONFIDENCE)
    # B: S = 0.4 * 1 = 0.4; door: S = 0.36 * 2 = 0.72 -> the door wins with C_f = 0.72 / 1.12.
    result = run(scene=scene, detections=[DET_B], prior=lambda label: 2.0 if label == "doorway" else 1.0)
    assert result.target is not None and result.target.kind == "direction"
    assert result.target.fused_confidence == pytest.approx(0.72 / 1.12)
    assert result.candidates[1].prior == 2.0


@pytest.mark.parametrize("bad_prior", [-1.0, math.nan, math.inf])
def test_bad_prior_is_rejected(bad_prior: float) -> None:
    with pytest.raises(InvalidInputError, match="prior"):
        run(scene=None, detections=[DET_B], prior=lambda label: bad_prior)


# ---------------------------------------------------------------------------------------------------------
# Missing sources and candidate sets
# ---------------------------------------------------------------------------------------------------------


def test_object_only_when_scene_missing() -> None:
    result = run(scene=None, detections=[DET_A, DET_B])
    assert [c.source for c in result.candidates] == ["object", "object"]
    # S = C~_o: 0.8 and 0.4 -> A wins with C_f = 0.8 / 1.2.
    assert [c.score for c in result.candidates] == pytest.approx([0.8, 0.4])
    assert result.target is not None and result.target.fused_confidence == pytest.approx(2.0 / 3.0)


def test_scene_only_when_no_detection() -> None:
    scene = SceneEvidence(proposals=(PROP_MUG, PROP_DOOR), scene_confidence=SCENE_CONFIDENCE)
    result = run(scene=scene, detections=[])
    assert [(c.source, c.kind) for c in result.candidates] == [("scene", "object"), ("scene", "direction")]
    # Both S = C~_s^2 = 0.36: a tie, broken by proposal order -> the mug (index 0), C_f = 0.5.
    assert result.winner_index == 0
    assert result.target is not None and result.target.fused_confidence == pytest.approx(0.5)
    assert result.target.pixel_px == (200.0, 150.0)


def test_unaligned_evidence_is_ignored_but_directions_are_kept() -> None:
    chair_det = Detection((100.0, 100.0, 200.0, 200.0), "chair", 0.99)
    chair_prop = SceneProposal((150.0, 150.0), "chair", "object")
    scene = SceneEvidence(proposals=(chair_prop, PROP_DOOR), scene_confidence=SCENE_CONFIDENCE)
    result = run(scene=scene, detections=[chair_det])
    assert [(c.source, c.label) for c in result.candidates] == [("scene", "doorway")]
    empty = run(scene=SceneEvidence((chair_prop,), 0.9), detections=[chair_det])
    assert empty.target is None and empty.candidates == () and "no candidates" in empty.reason
    assert run(scene=None, detections=[]).target is None


def test_detection_without_overlap_stays_separate_from_scene_proposal() -> None:
    scene = SceneEvidence(proposals=(PROP_MUG,), scene_confidence=SCENE_CONFIDENCE)
    result = run(scene=scene, detections=[DET_B])
    assert [c.source for c in result.candidates] == ["object", "scene"]


def test_direction_proposals_never_associate() -> None:
    door_over_a = SceneProposal(point_px=(150.0, 150.0), label=TARGET, kind="direction")
    result = run(scene=SceneEvidence((door_over_a,), SCENE_CONFIDENCE), detections=[DET_A])
    assert [c.source for c in result.candidates] == ["object", "scene"]


def test_all_zero_scores_give_no_target() -> None:
    weak = Detection((10.0, 10.0, 20.0, 20.0), TARGET, 0.5)  # C~_o = 0 at tau = 0.5
    scene = SceneEvidence(proposals=(PROP_DOOR,), scene_confidence=0.3)  # C~_s = 0
    result = run(scene=scene, detections=[weak])
    assert result.target is None and result.winner is None
    assert "zero" in result.reason
    assert len(result.candidates) == 2
    assert all(c.score == 0.0 and c.normalised_score == 0.0 for c in result.candidates)


def test_ties_go_to_the_earliest_candidate() -> None:
    twin = Detection((300.0, 300.0, 310.0, 310.0), TARGET, 0.9)
    result = run(scene=None, detections=[twin, DET_A])  # both S = 0.8
    assert result.winner_index == 0 and result.target is not None
    assert result.target.pixel_px == (305.0, 305.0)
    # A detection and a direction with equal scores: the detection (listed first) wins.
    equal = Detection((300.0, 300.0, 310.0, 310.0), TARGET, 0.68)  # C~_o = 0.36 = C~_s^2
    scene = SceneEvidence(proposals=(PROP_DOOR,), scene_confidence=SCENE_CONFIDENCE)
    mixed = run(scene=scene, detections=[equal])
    assert mixed.candidates[0].score == pytest.approx(mixed.candidates[1].score)
    assert mixed.target is not None and mixed.target.source == "object"


# ---------------------------------------------------------------------------------------------------------
# Association by maximum overlap
# ---------------------------------------------------------------------------------------------------------


def test_association_is_greedy_by_iou() -> None:
    # det0 (0,0,100,100) overlaps p0 (50,0,150,100): IoU 5000/15000 = 0.333 and p1 (0,0,100,80): IoU 0.8.
    # det1 (0,0,100,90) overlaps p0: IoU 4500/14500 = 0.310 and p1: IoU 8000/9000 = 0.889.
    # Greedy: (det1, p1) 0.889 first, then det0's best free proposal is p0 (0.333).
    det0 = Detection((0.0, 0.0, 100.0, 100.0), TARGET, 0.9)
    det1 = Detection((0.0, 0.0, 100.0, 90.0), TARGET, 0.9)
    p0 = SceneProposal((100.0, 50.0), TARGET, "object", region_px=(50.0, 0.0, 150.0, 100.0))
    p1 = SceneProposal((50.0, 40.0), TARGET, "object", region_px=(0.0, 0.0, 100.0, 80.0))
    result = run(scene=SceneEvidence((p0, p1), SCENE_CONFIDENCE), detections=[det0, det1])
    pairs = {(c.detection_index, c.proposal_index): c.iou for c in result.candidates}
    assert pairs == {(0, 0): pytest.approx(1.0 / 3.0), (1, 1): pytest.approx(8.0 / 9.0)}


def test_each_proposal_associates_with_one_detection_at_most() -> None:
    # Two detections over one proposal: the higher IoU takes it, the other stays an object candidate.
    det_big = Detection((0.0, 0.0, 100.0, 100.0), TARGET, 0.9)
    det_small = Detection((40.0, 40.0, 60.0, 60.0), TARGET, 0.9)
    prop = SceneProposal((50.0, 50.0), TARGET, "object", region_px=(0.0, 0.0, 90.0, 90.0))
    result = run(scene=SceneEvidence((prop,), SCENE_CONFIDENCE), detections=[det_small, det_big])
    assert [(c.source, c.detection_index, c.proposal_index) for c in result.candidates] == [
        ("object", 0, None),
        ("fused", 1, 0),
    ]


def test_default_scene_region_is_a_square_around_the_point() -> None:
    # Half side 40 around (150, 150): (110, 110, 190, 190), inside A's box: IoU = 6400 / 10000 = 0.64.
    prop = SceneProposal((150.0, 150.0), TARGET, "object")
    config = dataclasses.replace(CONFIG, scene_region_half_size_px=40.0)
    result = run(scene=SceneEvidence((prop,), SCENE_CONFIDENCE), detections=[DET_A], config=config)
    assert result.candidates[0].iou == pytest.approx(0.64)
    assert result.candidates[0].region_px == (110.0, 110.0, 190.0, 190.0)


# ---------------------------------------------------------------------------------------------------------
# Depth feasibility kappa
# ---------------------------------------------------------------------------------------------------------

KAPPA_CONFIG = ArbitrationConfig(depth_min_m=0.3, depth_max_m=10.0, depth_patch_px=5, occluder_margin_m=0.3)


def _flat_depth(value: float = 2.0) -> np.ndarray:
    return np.full((HEIGHT, WIDTH), value, dtype=np.float32)


def test_kappa_valid_depth_is_one() -> None:
    assert depth_feasibility((100.0, 100.0), _flat_depth(), KAPPA_CONFIG) == 1.0


def test_kappa_hole_is_zero_and_partial_hole_scales() -> None:
    depth = _flat_depth()
    depth[98:103, 98:103] = np.nan  # the whole 5x5 patch
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG) == 0.0
    depth = _flat_depth()
    depth[98:103, 98:100] = 0.0  # 10 of 25 patch pixels are holes -> kappa = 15 / 25
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG) == pytest.approx(0.6)


@pytest.mark.parametrize("value", [0.1, 12.0])
def test_kappa_out_of_range_is_zero(value: float) -> None:
    assert depth_feasibility((100.0, 100.0), _flat_depth(value), KAPPA_CONFIG) == 0.0


def test_kappa_occlusion_factor() -> None:
    depth = _flat_depth(4.0)
    box = (50.0, 50.0, 150.0, 150.0)  # the box is at 4 m
    depth[98:103, 98:103] = 2.0  # something 2 m nearer at the target pixel: gap 2 >= 2 * 0.3 -> occluded
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG, box=box) == 0.0
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG) == 1.0  # no box: no occlusion test
    depth[98:103, 98:103] = 3.55  # gap 0.45 -> o = 2 - 0.45 / 0.3 = 0.5
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG, box=box) == pytest.approx(0.5)
    depth[98:103, 98:103] = 3.8  # gap 0.2 <= margin -> o = 1
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG, box=box) == 1.0
    depth[98:103, 98:103] = 9.0  # target farther than the box (background): not an occlusion
    assert depth_feasibility((100.0, 100.0), depth, KAPPA_CONFIG, box=box) == 1.0


def test_kappa_rejects_bad_pixel_but_not_nan_depth() -> None:
    depth = np.full((HEIGHT, WIDTH), np.nan)
    assert depth_feasibility((1.0, 1.0), depth, KAPPA_CONFIG) == 0.0
    with pytest.raises(InvalidInputError, match="pixel"):
        depth_feasibility((math.nan, 1.0), depth, KAPPA_CONFIG)
    with pytest.raises(InvalidInputError, match="pixel"):
        depth_feasibility((WIDTH + 5.0, 1.0), depth, KAPPA_CONFIG)


def test_arbitrate_kappa_term_hand_worked() -> None:
    config = dataclasses.replace(CONFIG, depth_patch_px=5, occluder_margin_m=0.3)
    depth = _flat_depth(2.0)
    result = run(scene=None, detections=[DET_A, DET_B], depth_m=depth, image_size=None, config=config)
    a, b = result.candidates
    # Flat 2 m: kappa = 1 -> S_A = 0.8 * (1 + 0.001) = 0.8008, S_B = 0.4 * 1.001 = 0.4004.
    assert a.kappa == 1.0 and a.score == pytest.approx(0.8008)
    assert b.kappa == 1.0 and b.score == pytest.approx(0.4004)
    # Now B's box is a hole (a glass door, a black object): kappa 0 -> S_B = 0.4 * 0.001 = 0.0004.
    depth[300:351, 400:451] = 0.0
    result = run(scene=None, detections=[DET_A, DET_B], depth_m=depth, image_size=None, config=config)
    a, b = result.candidates
    assert b.kappa == 0.0 and b.score == pytest.approx(0.0004) and b.depth_m is None
    assert result.target is not None and result.target.depth_m == pytest.approx(2.0)
    # C_f = 0.8008 / (0.8008 + 0.0004).
    assert result.target.fused_confidence == pytest.approx(0.8008 / 0.8012)


def test_kappa_alone_cannot_change_a_uniform_choice() -> None:
    # Every candidate in a hole gets the same (0 + eps)^mu factor, which cancels in C_f.
    depth = np.zeros((HEIGHT, WIDTH), dtype=np.float32)
    with_depth = run(scene=None, detections=[DET_A, DET_B], depth_m=depth, image_size=None)
    without = run(scene=None, detections=[DET_A, DET_B])
    assert with_depth.target is not None and without.target is not None
    assert with_depth.target.fused_confidence == pytest.approx(without.target.fused_confidence)


# ---------------------------------------------------------------------------------------------------------
# Input validation
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"detections": [DET_A, Detection((0, 0, 1, 1), TARGET, math.nan)]}, r"detections\[1\]"),
        ({"detections": [Detection((0, 0, 1, 1), TARGET, 1.2)]}, r"detections\[0\]"),
        ({"detections": [Detection((5, 0, 1, 1), TARGET, 0.9)]}, r"detections\[0\]\.box_xyxy_px"),
        ({"detections": [Detection((0, 0, math.inf, 1), TARGET, 0.9)]}, r"detections\[0\]\.box_xyxy_px"),
        ({"scene": SceneEvidence((PROP_DOOR,), math.nan)}, r"scene\.scene_confidence"),
        ({"scene": SceneEvidence((PROP_DOOR,), 1.5)}, r"scene\.scene_confidence"),
        (
            {"scene": SceneEvidence((PROP_DOOR, SceneProposal((math.nan, 1.0), TARGET)), 0.9)},
            r"scene\.proposals\[1\]\.point_px",
        ),
        (
            {"scene": SceneEvidence((SceneProposal((1.0, 1.0), TARGET, region_px=(9, 9, 1, 1)),), 0.9)},
            r"scene\.proposals\[0\]\.region_px",
        ),
        (
            {"scene": SceneEvidence((SceneProposal((1.0, 1.0), TARGET, kind="room"),), 0.9)},  # type: ignore[arg-type]
            r"scene\.proposals\[0\]\.kind",
        ),
        ({"depth_m": np.ones((10, 10)), "image_size": (WIDTH, HEIGHT)}, "image_size"),
        ({"image_size": (0, 10)}, "image_size"),
        ({"config": dataclasses.replace(CONFIG, tau=1.0)}, r"config\.tau"),
        ({"config": dataclasses.replace(CONFIG, epsilon=0.0)}, r"config\.epsilon"),
    ],
)
def test_arbitrate_rejects_bad_input_naming_the_field(kwargs: dict[str, object], field: str) -> None:
    call: dict[str, object] = {"scene": None, "detections": [DET_A]}
    call.update(kwargs)
    with pytest.raises(InvalidInputError, match=field):
        run(**call)


def test_nan_depth_pixels_are_holes_not_errors() -> None:
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.5, 5.0, (HEIGHT, WIDTH))
    depth[rng.uniform(size=depth.shape) < 0.3] = np.nan
    depth[rng.uniform(size=depth.shape) < 0.1] = np.inf
    scene = SceneEvidence(proposals=(PROP_MUG, PROP_DOOR), scene_confidence=SCENE_CONFIDENCE)
    result = run(scene=scene, detections=[DET_A, DET_B], depth_m=depth, image_size=None)
    assert result.target is not None
    assert all(c.kappa is not None and 0.0 <= c.kappa <= 1.0 for c in result.candidates)


def test_points_and_boxes_are_clipped_to_the_image() -> None:
    outside = Detection((600.0, 400.0, 700.0, 500.0), TARGET, 0.9)  # clipped to (600, 400, 639, 479)
    far_point = SceneProposal((900.0, -20.0), "exit", "direction")  # clipped to (639, 0)
    result = run(scene=SceneEvidence((far_point,), 0.9), detections=[outside])
    assert result.candidates[0].box_xyxy_px == (600.0, 400.0, 639.0, 479.0)
    assert result.candidates[0].pixel_px == (619.5, 439.5)
    assert result.candidates[1].pixel_px == (639.0, 0.0)


# ---------------------------------------------------------------------------------------------------------
# Properties
# ---------------------------------------------------------------------------------------------------------

coordinate_u = st.floats(0.0, WIDTH - 1.0)
coordinate_v = st.floats(0.0, HEIGHT - 1.0)
labels = st.sampled_from([TARGET, "chair", "doorway"])


@st.composite
def detections_strategy(draw: st.DrawFn) -> Detection:
    u0, v0 = draw(coordinate_u), draw(coordinate_v)
    w, h = draw(st.floats(0.0, 200.0)), draw(st.floats(0.0, 200.0))
    return Detection((u0, v0, u0 + w, v0 + h), draw(labels), draw(st.floats(0.0, 1.0)))


@st.composite
def proposals_strategy(draw: st.DrawFn) -> SceneProposal:
    point = (draw(coordinate_u), draw(coordinate_v))
    kind = draw(st.sampled_from(["object", "direction"]))
    region = None
    if draw(st.booleans()):
        u0, v0 = draw(coordinate_u), draw(coordinate_v)
        region = (u0, v0, u0 + draw(st.floats(0.0, 200.0)), v0 + draw(st.floats(0.0, 200.0)))
    return SceneProposal(point, draw(labels), kind, region)


configs = st.builds(
    ArbitrationConfig,
    tau=st.floats(0.0, 0.95),
    beta_o=st.floats(0.0, 3.0),
    beta_s=st.floats(0.0, 3.0),
    lambda_iou=st.floats(0.0, 3.0),
    mu=st.floats(0.0, 3.0),
    scene_region_half_size_px=st.floats(1.0, 100.0),
)


@settings(max_examples=150, deadline=None)
@given(
    detections=st.lists(detections_strategy(), max_size=8),
    proposals=st.lists(proposals_strategy(), max_size=6),
    scene_confidence=st.floats(0.0, 1.0),
    has_scene=st.booleans(),
    config=configs,
    use_depth=st.booleans(),
    seed=st.integers(0, 2**16),
)
def test_arbitration_invariants(
    detections: list[Detection],
    proposals: list[SceneProposal],
    scene_confidence: float,
    has_scene: bool,
    config: ArbitrationConfig,
    use_depth: bool,
    seed: int,
) -> None:
    scene = SceneEvidence(tuple(proposals), scene_confidence) if has_scene else None
    depth = None
    if use_depth:
        rng = np.random.default_rng(seed)
        depth = rng.uniform(0.0, 12.0, (HEIGHT // 8, WIDTH // 8)).repeat(8, axis=0).repeat(8, axis=1)
        depth[rng.uniform(size=depth.shape) < 0.2] = np.nan
    result = run(scene=scene, detections=detections, config=config, depth_m=depth)
    scores = [c.score for c in result.candidates]
    assert all(math.isfinite(s) and s >= 0.0 for s in scores)
    if result.target is None:
        assert sum(scores) == 0.0
    else:
        assert 0.0 <= result.target.fused_confidence <= 1.0
        assert sum(c.normalised_score for c in result.candidates) == pytest.approx(1.0)
        # The winner is the maximum, up to the documented tie tolerance.
        assert result.winner is not None
        assert result.winner.score >= max(scores) * (1.0 - TIE_RELATIVE_TOLERANCE)
        assert (
            0.0 <= result.target.pixel_px[0] <= WIDTH - 1 and 0.0 <= result.target.pixel_px[1] <= HEIGHT - 1
        )
    used_proposals = [c.proposal_index for c in result.candidates if c.proposal_index is not None]
    assert len(used_proposals) == len(set(used_proposals))  # a proposal is used once at most
    for candidate in result.candidates:
        if candidate.source != "fused":
            continue
        # Eq. 4: the fused point lies on the segment between its two sources.
        assert candidate.object_pixel_px is not None and candidate.scene_pixel_px is not None
        assert candidate.object_weight is not None and 0.0 <= candidate.object_weight <= 1.0
        p, a, b = (
            np.array(x) for x in (candidate.pixel_px, candidate.object_pixel_px, candidate.scene_pixel_px)
        )
        assert np.linalg.norm(p - a) + np.linalg.norm(p - b) == pytest.approx(np.linalg.norm(a - b), abs=1e-6)
        assert candidate.iou is not None and candidate.iou > 0.0
        assert candidate.label == detections[candidate.detection_index].label  # type: ignore[index]


bad_numbers = st.sampled_from([math.nan, math.inf, -math.inf])


@settings(max_examples=60, deadline=None)
@given(bad=bad_numbers, where=st.sampled_from(["confidence", "box", "point", "scene_confidence", "region"]))
def test_non_finite_inputs_raise(bad: float, where: str) -> None:
    detection = Detection((10.0, 10.0, 50.0, 50.0), TARGET, 0.9)
    proposal = SceneProposal((30.0, 30.0), TARGET, "object")
    scene_confidence = 0.8
    if where == "confidence":
        detection = dataclasses.replace(detection, confidence=bad)
    elif where == "box":
        detection = dataclasses.replace(detection, box_xyxy_px=(10.0, bad, 50.0, 50.0))
    elif where == "point":
        proposal = dataclasses.replace(proposal, point_px=(bad, 30.0))
    elif where == "region":
        proposal = dataclasses.replace(proposal, region_px=(0.0, 0.0, bad, 10.0))
    else:
        scene_confidence = bad
    with pytest.raises(InvalidInputError):
        run(scene=SceneEvidence((proposal,), scene_confidence), detections=[detection])


def test_cross_source_consistency_rewards_corroboration() -> None:
    """Both sources answered: the corroborated detection beats a stronger uncorroborated one.

    tau = 0.5, beta_o = 1, beta_s = 2, lambda = 0.5, eps = 1e-3, unsupported_iou = 0.05.
    Scene confidence 0.9 -> C~s = 0.8, term 0.64.
    Fused: C~o = (0.8 - 0.5)/0.5 = 0.6; IoU of box (100,100,140,140) with region (100,100,140,140) = 1
      -> S = 0.6 * 0.64 * (1.001)^0.5 = 0.38419.
    Lone: C~o = (0.9 - 0.5)/0.5 = 0.8 -> S = 0.8 * 0.64 * (0.051)^0.5 = 0.11563.
    """
    config = ArbitrationConfig(tau=0.5, beta_o=1.0, beta_s=2.0, lambda_iou=0.5, mu=1.0, epsilon=1e-3)
    scene = SceneEvidence(
        proposals=(
            SceneProposal(point_px=(120.0, 120.0), label="fire extinguisher", region_px=(100, 100, 140, 140)),
        ),
        scene_confidence=0.9,
    )
    detections = [
        Detection((100.0, 100.0, 140.0, 140.0), "fire extinguisher", 0.8),
        Detection((10.0, 10.0, 30.0, 30.0), "fire extinguisher", 0.9),
    ]
    result = arbitrate(scene=scene, detections=detections, is_aligned=lambda label: True, config=config)
    scores = sorted((c.score for c in result.candidates), reverse=True)
    assert scores == pytest.approx([0.6 * 0.64 * 1.001**0.5, 0.8 * 0.64 * 0.051**0.5], rel=1e-6)
    assert result.target is not None and result.target.source == "fused"
    # With the detector missing (None), the lone-source rule applies: only the scene proposal remains.
    vlm_only = arbitrate(scene=scene, detections=None, is_aligned=lambda label: True, config=config)
    assert [c.source for c in vlm_only.candidates] == ["scene"]
    assert vlm_only.candidates[0].score == pytest.approx(0.64)


def test_direction_prior_lets_corroborated_object_evidence_outrank_a_bare_direction() -> None:
    """Scene confidence 0.85 (tau 0.25 -> C~s = 0.8), detection 0.9 (C~o = 0.8667), IoU 0.4164 (lambda 0.5).

    Fused object: 0.8667 * 0.8 * (0.4174)^0.5 = 0.4479. Direction: 0.8 * P with P = 0.25 -> 0.2; with the
    literal P = 1 the direction (0.8) would win although the target is in plain view.
    """
    scene = SceneEvidence(
        proposals=(
            SceneProposal(point_px=(97.5, 119.5), label="fire extinguisher"),
            SceneProposal(point_px=(40.0, 170.0), label="open area", kind="direction"),
        ),
        scene_confidence=0.85,
    )
    detections = [Detection((77.0, 87.0, 118.0, 152.0), "fire extinguisher", 0.9)]
    ours = arbitrate(
        scene=scene,
        detections=detections,
        is_aligned=lambda label: label == "fire extinguisher",
        config=ArbitrationConfig(),
    )
    assert ours.target is not None and ours.target.kind == "object"
    assert [round(c.score, 4) for c in ours.candidates] == [0.4479, 0.2]
    literal = arbitrate(
        scene=scene,
        detections=detections,
        is_aligned=lambda label: label == "fire extinguisher",
        config=ArbitrationConfig(direction_prior=1.0),
    )
    assert literal.target is not None and literal.target.kind == "direction"
