"""GroundingDINO through transformers (the paper's GroundingDINO-T): boxes of a text prompt, C_o.

The prompt is the instruction's object phrase, lower-cased and ended with a period as GroundingDINO
expects ("fire extinguisher."). The processor's ``post_process_grounded_object_detection`` keeps
boxes whose best token scores above ``box_threshold`` and names each box by the prompt tokens scoring
above ``text_threshold``; a box that no prompt word reaches (only markers such as ``[SEP]`` or the
period pass) names nothing and is dropped. The rest become detections of the prompt (see
``semexp_bt.perception.adapters.detection``), their confidence the box score.

Example (a checkpoint directory such as ``IDEA-Research/grounding-dino-tiny`` saved locally)::

    detector = GroundingDINODetector.load(
        DetectorConfig(kind="grounding_dino", weights="/models/grounding-dino-tiny", device="cuda")
    )
    detector.detect(rgb, "fire extinguisher").detections
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import Detection
from semexp_bt.perception.adapters.detection import detections_from_boxes
from semexp_bt.perception.adapters.hf_detector import HFZeroShotDetector

#: Tokenizer markers that may survive ``text_threshold`` without naming anything.
_MARKERS = ("[CLS]", "[SEP]", "[PAD]", "[UNK]", "[MASK]")


def grounding_prompt(phrase: str) -> str:
    """``phrase`` as GroundingDINO's text input: lower case, one trailing period."""
    return phrase.strip().lower().rstrip(".").strip() + "."


def names_a_word(text_label: str) -> bool:
    """Whether a box's grounded text holds a word (not only markers and punctuation)."""
    for marker in _MARKERS:
        text_label = text_label.replace(marker, " ")
    return any(ch.isalnum() for ch in text_label)


class GroundingDINODetector(HFZeroShotDetector):
    """GroundingDINO zero-shot detection (see the module docstring)."""

    def inputs(self, rgb: npt.NDArray[np.uint8], prompt: str) -> Any:
        return self.processor(images=rgb, text=grounding_prompt(prompt), return_tensors="pt")

    def boxes(
        self, outputs: Any, inputs: Any, *, prompt: str, height: int, width: int
    ) -> tuple[Detection, ...]:
        result = self.processor.post_process_grounded_object_detection(
            outputs,
            inputs["input_ids"],
            threshold=self.config.box_threshold,
            text_threshold=self.config.text_threshold,
            target_sizes=[(height, width)],
        )[0]
        named = [names_a_word(text) for text in result["text_labels"]]
        boxes = result["boxes"].detach().cpu().numpy()[named] if any(named) else np.zeros((0, 4))
        scores = result["scores"].detach().cpu().numpy()[named] if any(named) else np.zeros(0)
        return detections_from_boxes(
            boxes, scores, label=prompt, width=width, height=height, max_detections=self.config.max_detections
        )
