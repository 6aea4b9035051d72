"""Open-vocabulary detector adapters on tiny randomly initialised models built from their transformers
configs here (nothing downloads): loading from a local directory, pre- and post-processing,
thresholds, box conversion and label mapping; YOLO-World's adapter on a stand-in model."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from semexp_bt.core.types import Detection
from semexp_bt.perception.adapters.detection import (
    DetectorLoadError,
    DetectorOutput,
    detect_safely,
    detections_from_boxes,
    load_detector,
)
from semexp_bt.perception.adapters.source import ModelsPerception
from semexp_bt.perception.model_config import DetectorConfig
from tests.models_support import INSTRUCTION, TARGET, observation, still

HEIGHT, WIDTH = 60, 80
WORDS = ["fire", "extinguisher", "chair", "red", "a", "photo", "of"]


def tiny_frame() -> np.ndarray:
    return np.random.default_rng(1).integers(0, 255, (HEIGHT, WIDTH, 3), dtype=np.uint8)


@pytest.fixture(scope="module")
def grounding_dino_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 50k-parameter GroundingDINO (Swin + BERT) with random weights, saved like a hub checkpoint."""
    pytest.importorskip("transformers")
    import torch
    from transformers import (
        BertConfig,
        BertTokenizer,
        GroundingDinoConfig,
        GroundingDinoForObjectDetection,
        GroundingDinoImageProcessorPil,
        GroundingDinoProcessor,
        SwinConfig,
    )

    root = tmp_path_factory.mktemp("grounding_dino")
    vocab = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", ".", *WORDS]
    (root / "vocab.txt").write_text("\n".join(vocab) + "\n")
    processor = GroundingDinoProcessor(
        image_processor=GroundingDinoImageProcessorPil(size={"shortest_edge": 64, "longest_edge": 96}),
        tokenizer=BertTokenizer(str(root / "vocab.txt")),
    )
    config = GroundingDinoConfig(
        backbone_config=SwinConfig(
            embed_dim=8, depths=[1, 1], num_heads=[1, 1], window_size=2, out_features=["stage1", "stage2"], image_size=64
        ),
        text_config=BertConfig(
            vocab_size=len(vocab), hidden_size=16, num_hidden_layers=1, num_attention_heads=2, intermediate_size=16,
            max_position_embeddings=32,
        ),
        d_model=32, encoder_layers=1, decoder_layers=2, encoder_ffn_dim=16, decoder_ffn_dim=16,
        encoder_attention_heads=2, decoder_attention_heads=2, num_queries=12, num_feature_levels=2,
        encoder_n_points=1, decoder_n_points=1, max_text_len=32,
    )  # fmt: skip
    torch.manual_seed(0)
    model = GroundingDinoForObjectDetection(config).eval()
    model.save_pretrained(root / "checkpoint")
    processor.save_pretrained(root / "checkpoint")
    return root / "checkpoint"


@pytest.fixture(scope="module")
def owlv2_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny OWLv2 (CLIP text and vision towers) with random weights, saved like a hub checkpoint."""
    pytest.importorskip("transformers")
    import torch
    from transformers import (
        CLIPTokenizer,
        Owlv2Config,
        Owlv2ForObjectDetection,
        Owlv2ImageProcessorPil,
        Owlv2Processor,
    )

    root = tmp_path_factory.mktemp("owlv2")
    vocab: dict[str, int] = {"!": 0}
    for word in WORDS:
        vocab[word + "</w>"] = len(vocab)
    for ch in "abcdefghijklmnopqrstuvwxyz":
        vocab.setdefault(ch, len(vocab))
        vocab.setdefault(ch + "</w>", len(vocab))
    # OWL treats a query whose first token id is 0 as padding: the start token must not be id 0.
    vocab["<|startoftext|>"] = len(vocab)
    vocab["<|endoftext|>"] = len(vocab)
    (root / "vocab.json").write_text(json.dumps(vocab))
    (root / "merges.txt").write_text("#version: 0.2\n")
    processor = Owlv2Processor(
        image_processor=Owlv2ImageProcessorPil(size={"height": 32, "width": 32}),
        # Real OWLv2 checkpoints cap queries at 16 tokens; this vocabulary spells words letter by letter, so
        # the prompt is longer than that and the adapter's truncation is exercised.
        tokenizer=CLIPTokenizer(str(root / "vocab.json"), str(root / "merges.txt"), model_max_length=16),
    )
    special = {"bos_token_id": len(vocab) - 2, "eos_token_id": len(vocab) - 1, "pad_token_id": len(vocab) - 1}
    config = Owlv2Config(
        text_config={"vocab_size": len(vocab), "hidden_size": 16, "intermediate_size": 16, "num_hidden_layers": 1,
                     "num_attention_heads": 2, "max_position_embeddings": 16, **special},
        vision_config={"hidden_size": 16, "intermediate_size": 16, "num_hidden_layers": 1, "num_attention_heads": 2,
                       "image_size": 32, "patch_size": 8},
        projection_dim=16,
    )  # fmt: skip
    torch.manual_seed(0)
    model = Owlv2ForObjectDetection(config).eval()
    model.save_pretrained(root / "checkpoint")
    processor.save_pretrained(root / "checkpoint")
    return root / "checkpoint"


def raw_boxes_and_scores(detector: Any, prompt: str, *, square: bool) -> tuple[np.ndarray, np.ndarray]:
    """The model's own boxes and scores, converted here by hand: (cx, cy, w, h) in [0, 1] -> pixels."""
    import torch

    inputs = detector.inputs(tiny_frame(), prompt)
    with torch.inference_mode():
        outputs = detector.model(**inputs)
    cx, cy, w, h = outputs.pred_boxes[0].numpy().T
    scale_x, scale_y = (max(WIDTH, HEIGHT), max(WIDTH, HEIGHT)) if square else (WIDTH, HEIGHT)
    boxes = np.stack(
        [(cx - w / 2) * scale_x, (cy - h / 2) * scale_y, (cx + w / 2) * scale_x, (cy + h / 2) * scale_y], 1
    )
    scores = torch.sigmoid(outputs.logits[0]).max(-1).values.numpy()
    return boxes, scores


def test_grounding_dino_loads_from_a_local_directory_and_maps_boxes_to_the_prompt(
    grounding_dino_dir: Path,
) -> None:
    detector = load_detector(
        DetectorConfig(kind="grounding_dino", weights=str(grounding_dino_dir), box_threshold=0.0, text_threshold=0.0,
                       max_detections=5)
    )  # fmt: skip
    output = detector.detect(tiny_frame(), TARGET)
    print(output)
    assert set(output.timings_ms) == {"preprocess", "inference", "postprocess"}
    assert len(output.detections) == 5
    assert all(d.label == TARGET for d in output.detections)
    confidences = [d.confidence for d in output.detections]
    assert confidences == sorted(confidences, reverse=True)
    boxes, scores = raw_boxes_and_scores(detector, TARGET, square=False)
    expected = detections_from_boxes(
        boxes, scores, label=TARGET, width=WIDTH, height=HEIGHT, max_detections=5
    )
    for got, want in zip(output.detections, expected, strict=True):
        np.testing.assert_allclose(got.box_xyxy_px, want.box_xyxy_px, atol=1e-3)
        assert got.confidence == pytest.approx(want.confidence, abs=1e-5)
    for d in output.detections:
        u0, v0, u1, v1 = d.box_xyxy_px
        assert 0 <= u0 < u1 <= WIDTH - 1 and 0 <= v0 < v1 <= HEIGHT - 1


def test_grounding_dino_thresholds(grounding_dino_dir: Path) -> None:
    from semexp_bt.perception.adapters.grounding_dino import GroundingDINODetector

    loaded = load_detector(DetectorConfig(kind="grounding_dino", weights=str(grounding_dino_dir)))
    assert isinstance(loaded, GroundingDINODetector)

    def detect(box_threshold: float, text_threshold: float) -> tuple[Detection, ...]:
        config = DetectorConfig(
            kind="grounding_dino", weights="tiny", box_threshold=box_threshold, text_threshold=text_threshold,
            max_detections=100,
        )  # fmt: skip
        detector = GroundingDINODetector(config, processor=loaded.processor, model=loaded.model)
        return detector.detect(tiny_frame(), TARGET).detections

    all_scores = [d.confidence for d in detect(0.0, 0.0)]
    middle = float(np.median(all_scores))
    kept = detect(middle, 0.0)
    assert kept and len(kept) < len(all_scores) and all(d.confidence > middle for d in kept)
    assert detect(1.0, 0.0) == ()  # it ran and saw nothing: an empty tuple, not None
    # A text threshold no prompt word reaches leaves boxes that name nothing: dropped.
    assert detect(0.0, 1.0) == ()


def test_grounding_dino_prompt_and_phrase_rules() -> None:
    from semexp_bt.perception.adapters.grounding_dino import grounding_prompt, names_a_word

    assert grounding_prompt(" Fire Extinguisher. ") == "fire extinguisher."
    assert names_a_word("fire extinguisher") and not names_a_word(". [SEP]") and not names_a_word("")


def test_owlv2_boxes_are_scaled_back_from_the_padded_square(owlv2_dir: Path) -> None:
    detector = load_detector(
        DetectorConfig(kind="owlv2", weights=str(owlv2_dir), box_threshold=0.0, max_detections=4)
    )
    output = detector.detect(tiny_frame(), TARGET)
    print(output)
    assert len(output.detections) == 4 and all(d.label == TARGET for d in output.detections)
    boxes, scores = raw_boxes_and_scores(detector, TARGET, square=True)
    expected = detections_from_boxes(
        boxes, scores, label=TARGET, width=WIDTH, height=HEIGHT, max_detections=4
    )
    for got, want in zip(output.detections, expected, strict=True):
        np.testing.assert_allclose(got.box_xyxy_px, want.box_xyxy_px, atol=1e-3)
        assert got.confidence == pytest.approx(want.confidence, abs=1e-5)
    strict = load_detector(DetectorConfig(kind="owlv2", weights=str(owlv2_dir), box_threshold=1.0))
    assert strict.detect(tiny_frame(), TARGET).detections == ()


def test_missing_weights_fail_clearly_and_nothing_downloads(tmp_path: Path) -> None:
    pytest.importorskip("transformers")
    with pytest.raises(DetectorLoadError, match="nothing downloads unless allow_download"):
        load_detector(DetectorConfig(kind="grounding_dino", weights=str(tmp_path / "no-such-checkpoint")))
    with pytest.raises(DetectorLoadError, match="cannot load weights 'IDEA-Research/grounding-dino-tiny'"):
        load_detector(DetectorConfig(kind="grounding_dino", weights="IDEA-Research/grounding-dino-tiny"))


def test_detections_from_boxes_drops_clips_orders_and_caps() -> None:
    boxes = [
        [10, 10, 30, 40],  # kept
        [-5, -5, 20, 20],  # clipped to the image
        [float("nan"), 0, 1, 1],  # not finite: dropped
        [50, 50, 50.5, 55],  # narrower than a pixel: dropped
        [70, 10, 60, 20],  # corners swapped: normalised
        [100, 100, 120, 120],  # entirely off the image: nothing left, dropped
        [0, 0, 5, 5],  # a score above 1: dropped
    ]
    scores = [0.5, 0.9, 0.99, 0.8, 0.7, 0.95, 1.2]
    out = detections_from_boxes(boxes, scores, label="chair", width=WIDTH, height=HEIGHT, max_detections=10)
    assert out == (
        Detection((0.0, 0.0, 20.0, 20.0), "chair", 0.9),
        Detection((60.0, 10.0, 70.0, 20.0), "chair", 0.7),
        Detection((10.0, 10.0, 30.0, 40.0), "chair", 0.5),
    )
    assert (
        len(detections_from_boxes(boxes, scores, label="chair", width=WIDTH, height=HEIGHT, max_detections=2))
        == 2
    )
    assert (
        detections_from_boxes(
            np.zeros((0, 4)), [], label="chair", width=WIDTH, height=HEIGHT, max_detections=2
        )
        == ()
    )
    with pytest.raises(ValueError, match="2 boxes but 1 scores"):
        detections_from_boxes(
            [[0, 0, 1, 1], [0, 0, 2, 2]], [0.5], label="c", width=9, height=9, max_detections=2
        )


class FakeBoxes:
    def __init__(self) -> None:
        self.xyxy = np.array([[5.0, 6.0, 25.0, 30.0], [40.0, 10.0, 90.0, 50.0]])
        self.conf = np.array([0.4, 0.8])


class FakeYOLOWorld:
    """Records what the adapter asks of ultralytics' YOLOWorld."""

    def __init__(self) -> None:
        self.classes: list[list[str]] = []
        self.frames: list[np.ndarray] = []
        self.kwargs: list[dict[str, Any]] = []

    def set_classes(self, classes: list[str]) -> None:
        self.classes.append(classes)

    def predict(self, frame: np.ndarray, **kwargs: Any) -> list[Any]:
        self.frames.append(frame)
        self.kwargs.append(kwargs)
        return [type("Result", (), {"boxes": FakeBoxes()})()]


def test_yolo_world_sets_the_class_once_per_phrase_and_predicts_on_bgr() -> None:
    from semexp_bt.perception.adapters.yolo_world import YOLOWorldDetector

    model = FakeYOLOWorld()
    detector = YOLOWorldDetector(
        DetectorConfig(kind="yolo_world", weights="yolov8s-worldv2.pt", box_threshold=0.3, max_detections=7),
        model=model,
    )
    rgb = tiny_frame()
    first = detector.detect(rgb, TARGET)
    detector.detect(rgb, TARGET)
    detector.detect(rgb, "chair")
    assert model.classes == [[TARGET], ["chair"]]
    np.testing.assert_array_equal(model.frames[0], rgb[:, :, ::-1])
    assert model.kwargs[0] == {"conf": 0.3, "max_det": 7, "device": "cpu", "verbose": False}
    assert first.detections == (
        Detection((40.0, 10.0, 79.0, 50.0), TARGET, 0.8),  # clipped to the 80-pixel-wide frame
        Detection((5.0, 6.0, 25.0, 30.0), TARGET, 0.4),
    )


def test_yolo_world_without_ultralytics_or_weights_fails_clearly(tmp_path: Path) -> None:
    from semexp_bt.perception.adapters.yolo_world import YOLOWorldDetector

    with pytest.raises(DetectorLoadError, match="ultralytics|not found"):
        YOLOWorldDetector.load(DetectorConfig(kind="yolo_world", weights=str(tmp_path / "none.pt")))


class Exploding:
    name = "exploding test-detector"

    def detect(self, rgb: np.ndarray, prompt: str) -> DetectorOutput:
        raise RuntimeError("CUDA out of memory")


def test_a_detector_failure_is_no_detections_and_a_recorded_error() -> None:
    detections, call = detect_safely(Exploding(), tiny_frame(), TARGET)
    assert detections is None and not call.ok
    assert call.error == "detector exploding test-detector: RuntimeError: CUDA out of memory"
    source = ModelsPerception(vlm=None, detector=Exploding())
    report = source.submit(
        observation=observation(), instruction=INSTRUCTION, target_label=TARGET, motion=still(), now_s=0.0
    ).wait(5.0)
    source.close()
    assert report is not None
    assert report.result.detections is None and report.result.scene is None
    assert report.result.errors == ("detector exploding test-detector: RuntimeError: CUDA out of memory",)


@pytest.fixture()
def detector_source(grounding_dino_dir: Path) -> Iterator[ModelsPerception]:
    config = DetectorConfig(
        kind="grounding_dino", weights=str(grounding_dino_dir), box_threshold=0.0, text_threshold=0.0
    )
    source = ModelsPerception(vlm=None, detector=load_detector(config))
    yield source
    source.close()


def test_a_detector_only_source_returns_detections_in_a_worker(detector_source: ModelsPerception) -> None:
    job = detector_source.submit(
        observation=observation(), instruction=INSTRUCTION, target_label=TARGET, motion=still(), now_s=0.0
    )
    report = job.wait(30.0)
    assert report is not None and report.result.scene is None
    assert report.result.detections and all(d.label == TARGET for d in report.result.detections)
    assert report.result.errors == () and report.result.detector_latency_s > 0.0
    assert job.poll(now_s=0.0) is report.result
