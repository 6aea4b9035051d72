"""Zero-shot detectors through Hugging Face transformers: loading, devices and the timed forward pass.

:class:`HFZeroShotDetector` holds a processor and a model (``AutoProcessor`` and
``AutoModelForZeroShotObjectDetection``) and runs one frame: preprocess (the processor), inference
(``torch.inference_mode`` on the configured device), postprocess (the subclass: the processor's own
post-processing, then :func:`detections_from_boxes`). The subclasses (``grounding_dino``, ``owlv2``)
say how the prompt is written and how the processor's results are read.

Nothing downloads unless the profile says ``allow_download: true``: loading passes
``local_files_only=True`` and sets the Hugging Face offline switches, so the weights must be a local
directory or a hub id already in the user's cache (``HF_HOME``).
"""

from __future__ import annotations

import abc
import os
import time
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import Detection
from semexp_bt.perception.adapters.chat import rgb_frame
from semexp_bt.perception.adapters.detection import DetectorLoadError, DetectorOutput
from semexp_bt.perception.embedding_relevance import OFFLINE_ENV
from semexp_bt.perception.model_config import DetectorConfig


def load_pretrained(config: DetectorConfig) -> tuple[Any, Any]:
    """``(processor, model)`` from ``config.weights``, the model on ``config.device`` in eval mode.

    Raises:
        DetectorLoadError: transformers is missing, or the weights are not on disk (the message says
            that nothing downloads unless ``allow_download`` is set).
    """
    if not config.allow_download:
        for key, value in OFFLINE_ENV.items():
            os.environ[key] = value
    try:
        import transformers
    except ImportError as exc:
        raise DetectorLoadError(
            f"detector {config.kind} needs transformers (pip install 'semexp-bt[models]'): {exc}"
        ) from None
    transformers.utils.logging.disable_progress_bar()
    local_only = not config.allow_download
    try:
        processor = transformers.AutoProcessor.from_pretrained(config.weights, local_files_only=local_only)
        model = transformers.AutoModelForZeroShotObjectDetection.from_pretrained(
            config.weights, local_files_only=local_only
        )
    except (OSError, ValueError) as exc:
        where = "a local directory or a hub id already in your cache" if local_only else "a hub id or a path"
        raise DetectorLoadError(
            f"detector {config.kind}: cannot load weights {config.weights!r} ({where}; nothing downloads "
            f"unless allow_download: true): {exc}"
        ) from None
    try:
        model = model.to(config.device).eval()
    except (RuntimeError, AssertionError) as exc:
        raise DetectorLoadError(f"detector {config.kind}: device {config.device!r} unusable: {exc}") from None
    return processor, model


class HFZeroShotDetector(abc.ABC):
    """A transformers zero-shot detector (see the module docstring).

    Args:
        config: weights, device, thresholds.
        processor: the model's processor (``AutoProcessor``).
        model: the model, already on ``config.device``.
    """

    def __init__(self, config: DetectorConfig, *, processor: Any, model: Any) -> None:
        self.config = config
        self.processor = processor
        self.model = model

    @classmethod
    def load(cls, config: DetectorConfig) -> HFZeroShotDetector:
        """The detector with its weights loaded (:func:`load_pretrained`)."""
        processor, model = load_pretrained(config)
        return cls(config, processor=processor, model=model)

    @property
    def name(self) -> str:
        return f"{self.config.kind} {self.config.weights}"

    @abc.abstractmethod
    def inputs(self, rgb: npt.NDArray[np.uint8], prompt: str) -> Any:
        """The processor's tensors for one frame and prompt."""

    @abc.abstractmethod
    def boxes(
        self, outputs: Any, inputs: Any, *, prompt: str, height: int, width: int
    ) -> tuple[Detection, ...]:
        """The model's outputs as detections of ``prompt`` on a ``width`` x ``height`` frame."""

    def detect(self, rgb: npt.NDArray[np.uint8], prompt: str) -> DetectorOutput:
        import torch

        frame = rgb_frame(rgb)
        height, width = int(frame.shape[0]), int(frame.shape[1])
        start = time.perf_counter()
        inputs = self.inputs(frame, prompt).to(self.config.device)
        t_inference = time.perf_counter()
        with torch.inference_mode():
            outputs = self.model(**inputs)
        t_post = time.perf_counter()
        detections = self.boxes(outputs, inputs, prompt=prompt, height=height, width=width)
        return DetectorOutput.timed(detections, start=start, inference=t_inference, postprocess=t_post)
