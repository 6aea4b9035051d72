"""YOLO-World through ultralytics (optional): a fast open-vocabulary detector.

The object phrase becomes YOLO-World's one class (``set_classes``, redone only when the phrase
changes); ``predict`` runs on the BGR frame with ``conf = box_threshold`` and ``max_det =
max_detections``; its boxes become detections of the phrase
(``semexp_bt.perception.adapters.detection``). ``ultralytics`` is not part of the ``models`` extra:
install it yourself. Its ``set_classes`` encodes the phrase with a CLIP text model, whose weights
ultralytics fetches on first use: put them in place beforehand on a machine without network.

Example::

    detector = YOLOWorldDetector.load(DetectorConfig(kind="yolo_world", weights="/models/yolov8s-worldv2.pt"))
    detector.detect(rgb, "fire extinguisher").detections
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.perception.adapters.chat import rgb_frame
from semexp_bt.perception.adapters.detection import DetectorLoadError, DetectorOutput, detections_from_boxes
from semexp_bt.perception.model_config import DetectorConfig


class YOLOWorldDetector:
    """YOLO-World detection (see the module docstring).

    Args:
        config: weights (a ``.pt`` file), device, thresholds.
        model: an ``ultralytics.YOLOWorld`` (or anything with its ``set_classes`` and ``predict``).
    """

    def __init__(self, config: DetectorConfig, *, model: Any) -> None:
        self.config = config
        self.model = model
        self._classes: str | None = None
        self._lock = threading.Lock()

    @classmethod
    def load(cls, config: DetectorConfig) -> YOLOWorldDetector:
        """The detector with its weights loaded.

        Raises:
            DetectorLoadError: ultralytics is missing, or the weights file is not on disk.
        """
        try:
            from ultralytics import YOLOWorld
        except ImportError as exc:
            raise DetectorLoadError(
                f"detector yolo_world needs ultralytics (pip install ultralytics): {exc}"
            ) from None
        if not config.allow_download and not Path(config.weights).is_file():
            raise DetectorLoadError(
                f"detector yolo_world: weights file {config.weights!r} not found (nothing downloads unless "
                "allow_download: true)"
            )
        return cls(config, model=YOLOWorld(config.weights))

    @property
    def name(self) -> str:
        return f"{self.config.kind} {self.config.weights}"

    def detect(self, rgb: npt.NDArray[np.uint8], prompt: str) -> DetectorOutput:
        frame = rgb_frame(rgb)
        height, width = int(frame.shape[0]), int(frame.shape[1])
        start = time.perf_counter()
        with self._lock:  # set_classes changes the model: one frame at a time
            phrase = prompt.strip()
            if self._classes != phrase:
                self.model.set_classes([phrase])
                self._classes = phrase
            t_inference = time.perf_counter()
            results = self.model.predict(
                np.ascontiguousarray(frame[:, :, ::-1]),
                conf=self.config.box_threshold,
                max_det=self.config.max_detections,
                device=self.config.device,
                verbose=False,
            )
        t_post = time.perf_counter()
        boxes = results[0].boxes
        detections = detections_from_boxes(
            np.asarray(boxes.xyxy.cpu().numpy() if hasattr(boxes.xyxy, "cpu") else boxes.xyxy),
            np.asarray(boxes.conf.cpu().numpy() if hasattr(boxes.conf, "cpu") else boxes.conf),
            label=prompt,
            width=width,
            height=height,
            max_detections=self.config.max_detections,
        )
        return DetectorOutput.timed(detections, start=start, inference=t_inference, postprocess=t_post)
