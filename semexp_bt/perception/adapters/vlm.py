"""The scene-level VLM adapter (Qwen2.5-VL in the paper): proposals (image point, label) and C_s.

:class:`SceneVLM` turns one frame into a :class:`ChatRequest` (the frame as a PNG or JPEG image content
part, the fixed prompt ``prompts/scene_proposals_v1.md`` filled with the instruction, its object phrase
and the image size, the reply schema ``scene_proposals_v1.schema.json``), sends it through a
:class:`ChatTransport`, and validates the reply before anything reaches the tree:

* it is JSON (:func:`reply_json`: bare, or one fenced block) and satisfies the schema;
* every label is non-empty after trimming; every point is finite and lies on the image
  (``0 <= u <= width - 1``, ``0 <= v <= height - 1``, after converting ``normalized_1000`` points);
* ``scene_confidence`` is a finite number in [0, 1].

Any violation rejects the whole reply: :meth:`SceneVLM.perceive` then returns no evidence and the
reason, never a partial or made-up :class:`SceneEvidence`. Proposals beyond ``max_proposals`` are dropped
(the prompt asks for at most that many).

Example:
    >>> vlm = SceneVLM(VLMConfig(base_url="http://127.0.0.1:8000/v1", model="qwen"), transport)  # doctest: +SKIP
    >>> call = vlm.perceive(rgb=frame, instruction="find the chair", target_label="chair", stamp_s=0.0)  # doctest: +SKIP
    >>> call.evidence.proposals[0].label, call.evidence.scene_confidence  # doctest: +SKIP
    ('chair', 0.8)
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import SceneEvidence, SceneProposal
from semexp_bt.perception.adapters.calls import ModelCall
from semexp_bt.perception.adapters.chat import (
    ChatReply,
    ChatRequest,
    ChatTransport,
    ReplyError,
    ask,
    check_schema,
    image_data_url,
    reply_json,
    schema_validator,
)
from semexp_bt.perception.model_config import VLMConfig
from semexp_bt.perception.prompts import SCENE_PROPOSALS, PromptTemplate, load_prompt

#: The scale of ``normalized_1000`` points: 0..1000 across each image axis.
NORMALIZED_SCALE = 1000.0


@dataclass(frozen=True)
class SceneCall:
    """The VLM's part of a view: the accepted evidence (None when rejected) and the call's account."""

    evidence: SceneEvidence | None
    call: ModelCall


class SceneVLM:
    """Scene proposals and C_s from an OpenAI-compatible VLM.

    Args:
        config: the endpoint and the reply options.
        transport: what sends the request (an :class:`OpenAIChatClient` in production).
        prompt: the prompt (default: ``scene_proposals_v1``).
    """

    def __init__(self, config: VLMConfig, transport: ChatTransport, prompt: PromptTemplate | None = None):
        self.config = config
        self.transport = transport
        self.prompt = prompt if prompt is not None else load_prompt(SCENE_PROPOSALS)
        schema_validator(self.prompt.schema)  # imports the validator now, not in the first view

    def request(self, *, rgb: npt.NDArray[np.uint8], instruction: str, target_label: str) -> ChatRequest:
        """The exact request for one frame (encodes the image)."""
        height, width = int(rgb.shape[0]), int(rgb.shape[1])
        text = self.prompt.render(
            instruction=json.dumps(instruction),
            target=json.dumps(target_label),
            width=str(width),
            height=str(height),
            max_proposals=str(self.config.max_proposals),
        )
        return ChatRequest(
            prompt=text,
            schema=self.prompt.schema,
            schema_name=self.prompt.name,
            image_data_url=image_data_url(
                rgb, image_format=self.config.image_format, jpeg_quality=self.config.jpeg_quality
            ),
        )

    def parse(self, reply: ChatReply, *, width: int, height: int, stamp_s: float) -> SceneEvidence:
        """Validate a reply into evidence for a ``width`` x ``height`` frame.

        Raises:
            ReplyError: naming the first rule the reply breaks.
        """
        value = reply_json(reply)
        check_schema(value, self.prompt.schema)
        data = cast(dict[str, Any], value)
        proposals = []
        for i, item in enumerate(data["proposals"][: self.config.max_proposals]):
            label = str(item["label"]).strip()
            if not label:
                raise ReplyError(f"proposals[{i}].label is empty")
            u, v = self._to_pixels(item["point"], width=width, height=height, where=f"proposals[{i}].point")
            proposals.append(SceneProposal(point_px=(u, v), label=label, kind=item["kind"]))
        confidence = float(data["scene_confidence"])
        if not (math.isfinite(confidence) and 0.0 <= confidence <= 1.0):
            raise ReplyError(f"scene_confidence {confidence!r} is outside [0, 1]")
        return SceneEvidence(proposals=tuple(proposals), scene_confidence=confidence, stamp_s=stamp_s)

    def _to_pixels(self, point: list[float], *, width: int, height: int, where: str) -> tuple[float, float]:
        x, y = float(point[0]), float(point[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ReplyError(f"{where} {point!r} is not finite")
        if self.config.point_format == "normalized_1000":
            if not (0.0 <= x <= NORMALIZED_SCALE and 0.0 <= y <= NORMALIZED_SCALE):
                raise ReplyError(f"{where} {point!r} is outside [0, {NORMALIZED_SCALE:g}] (normalized_1000)")
            x, y = x / NORMALIZED_SCALE * (width - 1), y / NORMALIZED_SCALE * (height - 1)
        if not (0.0 <= x <= width - 1 and 0.0 <= y <= height - 1):
            raise ReplyError(f"{where} {point!r} lies outside the {width}x{height} image")
        return x, y

    def perceive(
        self, *, rgb: npt.NDArray[np.uint8], instruction: str, target_label: str, stamp_s: float
    ) -> SceneCall:
        """Ask the VLM about one frame; never raises for a model's failure or a bad reply."""
        height, width = int(rgb.shape[0]), int(rgb.shape[1])
        evidence, call = ask(
            "vlm",
            self.transport,
            lambda: self.request(rgb=rgb, instruction=instruction, target_label=target_label),
            lambda reply: self.parse(reply, width=width, height=height, stamp_s=stamp_s),
        )
        return SceneCall(evidence=evidence, call=call)
