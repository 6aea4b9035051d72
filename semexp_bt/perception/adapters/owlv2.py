"""OWLv2 through transformers: an open-vocabulary detector queried with the object phrase.

The phrase is OWLv2's one text query (truncated to the checkpoint's query length). The processor pads the frame to a square, and its
``post_process_grounded_object_detection`` (given the frame's own size) scales boxes back to the frame;
boxes scoring below ``box_threshold`` are dropped there. The rest become detections of the phrase
(``semexp_bt.perception.adapters.detection``), their confidence the query's sigmoid score.

Example (a checkpoint directory such as ``google/owlv2-base-patch16-ensemble`` saved locally)::

    detector = OWLv2Detector.load(DetectorConfig(kind="owlv2", weights="/models/owlv2-base", device="cpu"))
    detector.detect(rgb, "fire extinguisher").detections
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import Detection
from semexp_bt.perception.adapters.detection import detections_from_boxes
from semexp_bt.perception.adapters.hf_detector import HFZeroShotDetector


class OWLv2Detector(HFZeroShotDetector):
    """OWLv2 zero-shot detection (see the module docstring)."""

    def inputs(self, rgb: npt.NDArray[np.uint8], prompt: str) -> Any:
        # Truncated to the checkpoint's query length (16 tokens for OWLv2): a long phrase keeps its start.
        return self.processor(images=rgb, text=[[prompt.strip()]], return_tensors="pt", truncation=True)

    def boxes(
        self, outputs: Any, inputs: Any, *, prompt: str, height: int, width: int
    ) -> tuple[Detection, ...]:
        result = self.processor.post_process_grounded_object_detection(
            outputs, threshold=self.config.box_threshold, target_sizes=[(height, width)]
        )[0]
        return detections_from_boxes(
            result["boxes"].detach().cpu().numpy(),
            result["scores"].detach().cpu().numpy(),
            label=prompt,
            width=width,
            height=height,
            max_detections=self.config.max_detections,
        )
