"""``FaultyPerception``: a perception-source decorator that injects the model-side faults.

A request submitted while a fault is active gets the fault; one submitted before it does not. The reply
is changed only in what a failing model or endpoint would change:

- ``perception_error``: the chosen source's reply is missing (``None``) and the result carries the error
  message an adapter reports for a failed request.
- ``perception_late``: the reply is released ``delay_s`` after the model really answered, with the
  latency to match.
- ``perception_garbage``: the chosen source's reply is replaced: with ``malformed`` replies, points and
  confidences that are not numbers and boxes that are inside out; otherwise well-formed proposals and
  boxes naming things that are not there, with high confidence.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from semexp_bt.core.types import Detection, Observation, SceneEvidence, SceneProposal, Twist
from semexp_bt.perception.interface import PerceptionJob, PerceptionResult, PerceptionSource
from sims.faults.spec import (
    FaultSpec,
    PerceptionErrorParams,
    PerceptionGarbageParams,
    PerceptionLateParams,
    PerceptionSourceName,
)

#: Labels of confident nonsense replies: nothing any scene holds.
NONSENSE_LABELS = ("zebra crossing sign", "grand piano", "hot air balloon", "submarine hatch", "lighthouse")
#: What an adapter reports for a request that failed (the executive logs it as a perception error).
ERROR_MESSAGE = "{source}: request failed (endpoint returned HTTP 503)"


def _sources(choice: PerceptionSourceName) -> tuple[str, ...]:
    return ("vlm", "detector") if choice == "both" else (choice,)


def garbage_scene(
    rng: np.random.Generator, *, width_px: int, height_px: int, malformed: bool
) -> SceneEvidence:
    """A VLM reply that is not evidence (see the module docstring)."""
    proposals: tuple[SceneProposal, ...]
    if malformed:
        proposals = (
            SceneProposal(point_px=(float("nan"), float(height_px / 2)), label="chair"),
            SceneProposal(point_px=(1e9, -1e9), label="", region_px=(50.0, 50.0, 10.0, 10.0)),
        )
        return SceneEvidence(proposals=proposals, scene_confidence=float("nan"))
    proposals = tuple(
        SceneProposal(
            point_px=(float(rng.uniform(0, width_px - 1)), float(rng.uniform(0, height_px - 1))),
            label=str(NONSENSE_LABELS[int(rng.integers(len(NONSENSE_LABELS)))]),
        )
        for _ in range(3)
    )
    return SceneEvidence(proposals=proposals, scene_confidence=0.95)


def garbage_detections(
    rng: np.random.Generator, *, width_px: int, height_px: int, malformed: bool, label: str
) -> tuple[Detection, ...]:
    """A detector reply that is not evidence (see the module docstring)."""
    if malformed:
        return (
            Detection(box_xyxy_px=(200.0, 150.0, 20.0, 10.0), label=label, confidence=1.7),
            Detection(box_xyxy_px=(float("nan"), 0.0, 10.0, 10.0), label=label, confidence=float("nan")),
        )
    out = []
    for _ in range(2):
        u0, v0 = float(rng.uniform(0, width_px / 2)), float(rng.uniform(0, height_px / 2))
        out.append(
            Detection(
                box_xyxy_px=(u0, v0, u0 + width_px / 4, v0 + height_px / 4),
                label=str(NONSENSE_LABELS[int(rng.integers(len(NONSENSE_LABELS)))]),
                confidence=0.9,
            )
        )
    return tuple(out)


@dataclass
class _FaultyJob:
    """A request whose reply is changed by the faults that were active when it was submitted."""

    inner: PerceptionJob
    faults: tuple[FaultSpec, ...]
    rng: np.random.Generator
    image_size: tuple[int, int]
    target_label: str
    _answered_at_s: float | None = None
    _result: PerceptionResult | None = field(default=None, repr=False)

    def poll(self, *, now_s: float) -> PerceptionResult | None:
        if self._result is None:
            result = self.inner.poll(now_s=now_s)
            if result is None:
                return None
            self._answered_at_s = now_s
            self._result = self._changed(result)
        assert self._answered_at_s is not None
        if now_s + 1e-9 < self._answered_at_s + self._delay_s():
            return None
        return self._result

    def cancel(self) -> None:
        self.inner.cancel()

    def _delay_s(self) -> float:
        return max(
            (f.params.delay_s for f in self.faults if isinstance(f.params, PerceptionLateParams)), default=0.0
        )

    def _changed(self, result: PerceptionResult) -> PerceptionResult:
        width, height = self.image_size
        errors = list(result.errors)
        for fault in self.faults:
            params = fault.params
            if isinstance(params, PerceptionErrorParams):
                for source in _sources(params.source):
                    errors.append(ERROR_MESSAGE.format(source=source))
                    result = (
                        replace(result, scene=None) if source == "vlm" else replace(result, detections=None)
                    )
            elif isinstance(params, PerceptionGarbageParams):
                sources = _sources(params.source)
                if "vlm" in sources and result.scene is not None:
                    result = replace(
                        result,
                        scene=garbage_scene(
                            self.rng, width_px=width, height_px=height, malformed=params.malformed
                        ),
                    )
                if "detector" in sources and result.detections is not None:
                    garbage = garbage_detections(
                        self.rng,
                        width_px=width,
                        height_px=height,
                        malformed=params.malformed,
                        label=self.target_label,
                    )
                    result = replace(result, detections=garbage)
            elif isinstance(params, PerceptionLateParams):
                sources = _sources(params.source)
                result = replace(
                    result,
                    scene_latency_s=result.scene_latency_s + (params.delay_s if "vlm" in sources else 0.0),
                    detector_latency_s=result.detector_latency_s
                    + (params.delay_s if "detector" in sources else 0.0),
                )
        return replace(result, errors=tuple(errors))


class FaultyPerception:
    """A :class:`~semexp_bt.perception.interface.PerceptionSource` whose replies fail as faults say.

    Args:
        inner: the real source.
        faults: the faults (only the perception-side ones are used).
        elapsed_s: seconds since the mission started on the backend's own clock (the schedule).
        seed: seeds nonsense replies.
    """

    def __init__(
        self,
        inner: PerceptionSource,
        faults: Sequence[FaultSpec],
        *,
        elapsed_s: Callable[[], float],
        seed: int,
    ) -> None:
        self.inner = inner
        self.faults = tuple(f for f in faults if f.kind.target == "perception")
        self.elapsed_s = elapsed_s
        self._rng = np.random.default_rng([int(seed), 4])

    def submit(
        self, *, observation: Observation, instruction: str, target_label: str, motion: Twist, now_s: float
    ) -> PerceptionJob:
        job = self.inner.submit(
            observation=observation,
            instruction=instruction,
            target_label=target_label,
            motion=motion,
            now_s=now_s,
        )
        elapsed = self.elapsed_s()
        active = tuple(f for f in self.faults if f.active(elapsed))
        if not active:
            return job
        size = (observation.intrinsics.width_px, observation.intrinsics.height_px)
        return _FaultyJob(job, active, self._rng, size, target_label)
