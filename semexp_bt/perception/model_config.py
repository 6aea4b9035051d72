"""The typed configuration of the real perception and relevance models (a models profile).

A models profile says which real models run behind the perception seam and where: the scene-level
VLM (Qwen2.5-VL in the paper) and the relevance LLM (GPT-4 in the paper) as OpenAI-compatible
chat-completions endpoints, and an open-vocabulary detector (GroundingDINO-T in the paper) loaded
through Hugging Face transformers. It holds the *names* of the environment variables that carry API
keys, never a key. The profile is written in YAML and read by ``semexp_bt.app.models_profile``; the
adapters (``semexp_bt.perception.adapters``) take these dataclasses and nothing else.

Every numeric field carries its range in ``metadata["range"]`` as ``(lo, hi, lo_open, hi_open)``, the
convention ``semexp_bt.core.config.config_from_dict`` checks.

Example:
    >>> vlm = VLMConfig(base_url="http://127.0.0.1:8000/v1", model="Qwen/Qwen2.5-VL-7B-Instruct")
    >>> ModelsProfile(vlm=vlm).enabled_sources()
    ('vlm',)
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Literal

from semexp_bt.core.bounds import field_range

#: How a chat server is asked for JSON: a JSON schema (vLLM, SGLang, OpenAI, Ollama), any JSON object
#: (servers without schema support), or nothing but the prompt.
ResponseFormat = Literal["json_schema", "json_object", "none"]
#: How the VLM's points are written: image pixels of the frame as sent, or 0..1000 per axis (Qwen2-VL).
PointFormat = Literal["pixels", "normalized_1000"]
DetectorKind = Literal["grounding_dino", "owlv2", "yolo_world"]

#: An environment variable's name (what ``api_key_env`` may hold); "" means no key is sent.
ENV_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: A torch device string the detectors accept.
DEVICE = re.compile(r"^(cpu|cuda(:\d+)?|mps)$")


@dataclass(frozen=True)
class ChatEndpointConfig:
    """An OpenAI-compatible chat-completions endpoint (vLLM, SGLang, Ollama, DashScope, OpenAI)."""

    base_url: str
    """The API root, e.g. ``http://127.0.0.1:8000/v1`` (the client appends ``/chat/completions``)."""
    model: str
    """The model name the server knows, sent in every request."""
    api_key_env: str = ""
    """The NAME of the environment variable holding the API key; "" sends no key (a local server)."""
    timeout_s: float = field(default=30.0, metadata=field_range(0.0, 600.0, low_open=True))
    """Per-attempt timeout: connect, send, and wait for the whole reply."""
    max_retries: int = field(default=2, metadata=field_range(0, 10))
    """Retries after the first attempt on 408/409/429/5xx, connection errors and timeouts, with the
    ``openai`` client's exponential backoff (it honours ``Retry-After``)."""
    response_format: ResponseFormat = "json_schema"
    """How the server is asked for JSON (see :data:`ResponseFormat`)."""
    max_tokens: int = field(default=1024, metadata=field_range(16, 32768))
    """Upper bound on the reply's length in tokens (a reply cut by it is truncated JSON: rejected)."""


@dataclass(frozen=True)
class VLMConfig(ChatEndpointConfig):
    """The scene-level VLM: proposals (image point, label) and the scene confidence C_s."""

    image_format: Literal["png", "jpeg"] = "png"
    """How the frame is encoded into the request's image content part (PNG is lossless)."""
    jpeg_quality: int = field(default=90, metadata=field_range(1, 100))
    """JPEG quality when ``image_format`` is ``jpeg``."""
    point_format: PointFormat = "pixels"
    """How the model writes points (see :data:`PointFormat`); converted to pixels when read."""
    max_proposals: int = field(default=8, metadata=field_range(1, 64))
    """Proposals kept per reply (the prompt asks for at most this many; extra ones are dropped)."""


@dataclass(frozen=True)
class LLMConfig(ChatEndpointConfig):
    """The relevance LLM (S_LLM in [0, 1] between the instruction and a memory node's label)."""

    batch_size: int = field(default=16, metadata=field_range(1, 256))
    """Labels scored per request."""
    cache_path: str = "~/.cache/semexp-bt/relevance.sqlite3"
    """The on-disk cache (SQLite) per (model, prompt version, instruction, label); "" keeps none."""
    prefetch: bool = True
    """Score each view's labels in the perception worker thread, so the tree's later lookups hit the
    cache instead of waiting for the LLM in a tick (needs ``cache_path``)."""


@dataclass(frozen=True)
class DetectorConfig:
    """An open-vocabulary detector run in-process through transformers (or ultralytics)."""

    kind: DetectorKind
    """``grounding_dino`` (the paper's GroundingDINO-T), ``owlv2``, or ``yolo_world`` (ultralytics)."""
    weights: str
    """A local checkpoint directory (or file, for YOLO-World), or a hub id already in the user's cache."""
    device: str = "cpu"
    """``cpu``, ``cuda``, ``cuda:N`` or ``mps``."""
    box_threshold: float = field(default=0.35, metadata=field_range(0.0, 1.0))
    """Boxes scoring below this are dropped (GroundingDINO's box threshold, OWLv2's and YOLO's score)."""
    text_threshold: float = field(default=0.25, metadata=field_range(0.0, 1.0))
    """GroundingDINO only: a box's prompt tokens must score this much to name it."""
    max_detections: int = field(default=20, metadata=field_range(1, 1000))
    """Detections kept per frame, highest confidence first."""
    allow_download: bool = False
    """False keeps the Hugging Face libraries offline: weights must already be on disk."""


@dataclass(frozen=True)
class CircuitBreakerConfig:
    """When a failing endpoint stops being asked (for every model of the profile)."""

    failures_to_open: int = field(default=3, metadata=field_range(1, 100))
    """Consecutive failed requests (after their retries) that open the circuit."""
    open_s: float = field(default=30.0, metadata=field_range(0.0, 3600.0))
    """How long an open circuit refuses requests before one trial request is let through."""


@dataclass(frozen=True)
class SimulationConfig:
    """How real models meet a simulated robot."""

    real_time_factor: float = field(default=1.0, metadata=field_range(0.0, 1000.0))
    """At most this many robot seconds per wall second; 1 holds the simulation to real time, so a model's
    wall-clock latency costs the robot what it would on a real robot (unpaced, the simulator runs many
    times faster than real time and every request would look like a time-out to the tree); 0 runs
    unpaced."""


@dataclass(frozen=True)
class ModelsProfile:
    """Which real models run, and where. A section left out disables that model."""

    vlm: VLMConfig | None = None
    llm: LLMConfig | None = None
    detector: DetectorConfig | None = None
    circuit_breaker: CircuitBreakerConfig = field(default_factory=CircuitBreakerConfig)
    simulation: SimulationConfig = field(default_factory=SimulationConfig)
    source: str = "<models profile>"
    """Where the profile came from (a file path, or the command line), for error messages."""

    def enabled_sources(self) -> tuple[str, ...]:
        """The configured models, in the order ``vlm``, ``llm``, ``detector``."""
        return tuple(name for name in ("vlm", "llm", "detector") if getattr(self, name) is not None)
