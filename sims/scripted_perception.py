"""ScriptedPerception: a PerceptionSource that answers from a script, for benchmarks and tests.

Each ``submit`` takes the next entry of ``script`` (cycling), releases it after ``latency_s`` of backend
time, and records what it was asked. An entry is a :class:`PerceptionResult` or a callable
``(observation) -> PerceptionResult`` (to place evidence relative to what the robot sees). It reads
nothing but its script, so it isolates the executive from the perception emulator.

Example:
    >>> from semexp_bt.core.types import SceneEvidence, SceneProposal
    >>> ahead = PerceptionResult(scene=SceneEvidence((SceneProposal((160.0, 200.0), "open corridor", "direction"),), 0.8),
    ...                          detections=(), observation_stamp_s=0.0)
    >>> source = ScriptedPerception([ahead], latency_s=2.5)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

from semexp_bt.core.types import Observation, Twist, require_finite
from semexp_bt.perception.interface import PerceptionResult, ReadyJob

ScriptEntry = PerceptionResult | Callable[[Observation], PerceptionResult]


class ScriptedPerception:
    """Answers from a fixed script (see module docstring).

    Args:
        script: the answers, used in turn and then again from the start.
        latency_s: backend time between a request and its answer (paper: about 2.5 s).
    """

    def __init__(self, script: Sequence[ScriptEntry], *, latency_s: float = 2.5) -> None:
        if not script:
            raise ValueError("ScriptedPerception needs at least one scripted answer")
        require_finite("latency_s", latency_s)
        self.script = list(script)
        self.latency_s = latency_s
        self.requests: list[tuple[float, str]] = []

    def submit(
        self, *, observation: Observation, instruction: str, target_label: str, motion: Twist, now_s: float
    ) -> ReadyJob:
        entry = self.script[len(self.requests) % len(self.script)]
        self.requests.append((now_s, target_label))
        result = entry(observation) if callable(entry) else entry
        result = dataclasses.replace(result, observation_stamp_s=observation.stamp_s)
        return ReadyJob(result=result, ready_at_s=now_s + self.latency_s)
