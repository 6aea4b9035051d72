"""What every open-vocabulary detector adapter shares: the interface, box conversion, safe calls, loading.

A :class:`Detector` takes an RGB frame and a text prompt (the instruction's object phrase, as the
paper prompts GroundingDINO-T) and returns the core's :class:`Detection` boxes. Every box carries the
prompt as its label: with one phrase in the prompt, a box is the detector's claim that the phrase is
there (the perception emulator does the same). :func:`detections_from_boxes` turns a model's boxes
and scores into detections: non-finite boxes or scores are dropped, boxes are clipped to the image
(``0..width-1``, ``0..height-1``) and dropped when less than :data:`MIN_BOX_SIDE_PX` remains of a side,
scores must lie in [0, 1], and the rest are sorted by confidence, at most ``max_detections``.

:func:`load_detector` builds the configured adapter (importing its library then); weights come from a
local path or the user's Hugging Face cache, never from the network unless ``allow_download`` is set.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import Detection
from semexp_bt.perception.adapters.calls import ModelCall
from semexp_bt.perception.model_config import DetectorConfig

#: A clipped box narrower or lower than this (pixels) is not a detection.
MIN_BOX_SIDE_PX = 1.0


class DetectorLoadError(ValueError):
    """A detector's library or weights are missing; the message says which and how to get them."""


@dataclass(frozen=True)
class DetectorOutput:
    """One frame's detections and the adapter's time per stage (``preprocess``, ``inference``,
    ``postprocess``, in ms)."""

    detections: tuple[Detection, ...]
    timings_ms: dict[str, float]

    @classmethod
    def timed(
        cls, detections: tuple[Detection, ...], *, start: float, inference: float, postprocess: float
    ) -> DetectorOutput:
        """The output with its stages timed from ``time.perf_counter`` marks (the end is now)."""
        end = time.perf_counter()
        return cls(
            detections=detections,
            timings_ms={
                "preprocess": (inference - start) * 1e3,
                "inference": (postprocess - inference) * 1e3,
                "postprocess": (end - postprocess) * 1e3,
            },
        )


class Detector(Protocol):
    """An open-vocabulary detector."""

    @property
    def name(self) -> str:
        """``kind weights``, how records name it."""
        ...

    def detect(self, rgb: npt.NDArray[np.uint8], prompt: str) -> DetectorOutput:
        """Boxes of ``prompt`` in an ``(H, W, 3)`` uint8 RGB frame."""
        ...


def detections_from_boxes(
    boxes_xyxy: npt.ArrayLike,
    scores: npt.ArrayLike,
    *,
    label: str,
    width: int,
    height: int,
    max_detections: int,
) -> tuple[Detection, ...]:
    """Boxes ``(N, 4)`` in pixels (x0, y0, x1, y1) and scores ``(N,)`` as detections of ``label``.

    Raises:
        ValueError: when the shapes disagree.
    """
    boxes = np.asarray(boxes_xyxy, dtype=float).reshape(-1, 4) if np.size(boxes_xyxy) else np.zeros((0, 4))
    conf = np.asarray(scores, dtype=float).reshape(-1)
    if boxes.shape[0] != conf.shape[0]:
        raise ValueError(f"{boxes.shape[0]} boxes but {conf.shape[0]} scores")
    keep = np.isfinite(boxes).all(axis=1) & np.isfinite(conf) & (conf >= 0.0) & (conf <= 1.0)
    boxes, conf = boxes[keep], conf[keep]
    x0 = np.clip(np.minimum(boxes[:, 0], boxes[:, 2]), 0.0, width - 1.0)
    x1 = np.clip(np.maximum(boxes[:, 0], boxes[:, 2]), 0.0, width - 1.0)
    y0 = np.clip(np.minimum(boxes[:, 1], boxes[:, 3]), 0.0, height - 1.0)
    y1 = np.clip(np.maximum(boxes[:, 1], boxes[:, 3]), 0.0, height - 1.0)
    sized = (x1 - x0 >= MIN_BOX_SIDE_PX) & (y1 - y0 >= MIN_BOX_SIDE_PX)
    order = [i for i in np.argsort(-conf, kind="stable") if sized[i]][:max_detections]
    return tuple(
        Detection(
            box_xyxy_px=(float(x0[i]), float(y0[i]), float(x1[i]), float(y1[i])),
            label=label,
            confidence=float(conf[i]),
        )
        for i in order
    )


def detect_safely(
    detector: Detector, rgb: npt.NDArray[np.uint8], prompt: str
) -> tuple[tuple[Detection, ...] | None, ModelCall]:
    """Run ``detector``; any failure is a :class:`ModelCall` with the error and no detections."""
    start = time.perf_counter()
    try:
        output = detector.detect(rgb, prompt)
    except Exception as exc:
        return None, ModelCall(
            source="detector",
            model=detector.name,
            ok=False,
            error=f"detector {detector.name}: {type(exc).__name__}: {exc}",
            latency_s=time.perf_counter() - start,
        )
    return output.detections, ModelCall(
        source="detector",
        model=detector.name,
        ok=True,
        latency_s=time.perf_counter() - start,
        timings_ms=dict(output.timings_ms),
    )


def load_detector(config: DetectorConfig) -> Detector:
    """The adapter of ``config.kind`` with its weights loaded.

    Raises:
        DetectorLoadError: its library is not installed, or the weights are not on disk.
    """
    if config.kind == "grounding_dino":
        from semexp_bt.perception.adapters.grounding_dino import GroundingDINODetector

        return GroundingDINODetector.load(config)
    if config.kind == "owlv2":
        from semexp_bt.perception.adapters.owlv2 import OWLv2Detector

        return OWLv2Detector.load(config)
    from semexp_bt.perception.adapters.yolo_world import YOLOWorldDetector

    return YOLOWorldDetector.load(config)
