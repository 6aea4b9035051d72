"""What one model did for one view: the account every adapter returns beside its evidence."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class ModelCall:
    """What one model did for one view (for records, ``semexp-bt perceive`` and the benchmarks).

    Attributes:
        source: ``vlm``, ``detector`` or ``llm``.
        model: the model's name (or checkpoint).
        ok: whether its answer was accepted.
        reply: the raw reply text (chat models), or None.
        error: why it was rejected or failed, or None; never carries an API key.
        latency_s: wall time of the whole call.
        timings_ms: wall time per stage: ``encode``, ``request``, ``parse`` (chat models) or
            ``preprocess``, ``inference``, ``postprocess`` (detectors).
    """

    source: str
    model: str
    ok: bool
    reply: str | None = None
    error: str | None = None
    latency_s: float = 0.0
    timings_ms: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "model": self.model,
            "ok": self.ok,
            "reply": self.reply,
            "error": self.error,
            "latency_s": round(self.latency_s, 4),
            "timings_ms": {k: round(v, 3) for k, v in self.timings_ms.items()},
        }
