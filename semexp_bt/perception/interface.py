"""The perception interface the executive calls: scene-level (VLM) and object-level (detector) evidence.

Three kinds of source sit behind it: the perception emulator in simulation (``sims/``), real model
adapters (an OpenAI-compatible VLM endpoint, GroundingDINO through transformers; user-supplied weights),
and test fakes. A request never blocks a tick: ``submit`` returns a job at once, and the behaviour
polls it with the backend clock until both sources have answered (the emulator releases its answer
when the simulated model latency has passed; a real adapter when its worker thread is done).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from semexp_bt.core.clock import is_due
from semexp_bt.core.types import Detection, Observation, SceneEvidence, Twist


@dataclass(frozen=True)
class PerceptionResult:
    """What one viewpoint's perception produced.

    Attributes:
        scene: the VLM's proposals and scene confidence, or None when that source is disabled or failed.
        detections: the detector's boxes; None when that source is disabled or failed (an empty tuple
            means it ran and saw nothing).
        observation_stamp_s: stamp of the frame it was computed on.
        scene_latency_s: how long the VLM took (backend clock).
        detector_latency_s: how long the detector took (backend clock).
        errors: human-readable failures of a source (a garbled VLM reply, a dead endpoint).
    """

    scene: SceneEvidence | None
    detections: tuple[Detection, ...] | None
    observation_stamp_s: float
    scene_latency_s: float = 0.0
    detector_latency_s: float = 0.0
    errors: tuple[str, ...] = ()


class PerceptionJob(Protocol):
    """A pending perception request."""

    def poll(self, *, now_s: float) -> PerceptionResult | None:
        """The result once every enabled source has answered by ``now_s``, else None."""
        ...

    def cancel(self) -> None:
        """Drop the request (the behaviour was preempted)."""
        ...


class PerceptionSource(Protocol):
    """Anything that turns a frame and an instruction into evidence."""

    def submit(
        self, *, observation: Observation, instruction: str, target_label: str, motion: Twist, now_s: float
    ) -> PerceptionJob:
        """Start perceiving ``observation``; return at once."""
        ...


@dataclass
class ReadyJob:
    """A job whose result is released at fixed backend times (used by emulators and fakes)."""

    result: PerceptionResult
    ready_at_s: float
    cancelled: bool = False

    def poll(self, *, now_s: float) -> PerceptionResult | None:
        if self.cancelled or not is_due(now_s=now_s, due_s=self.ready_at_s):
            return None
        return self.result

    def cancel(self) -> None:
        self.cancelled = True
