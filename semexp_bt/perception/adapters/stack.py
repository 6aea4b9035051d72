"""One mission's real models, built once from a models profile and shared by everything that uses them.

A :class:`ModelStack` builds, on first use, the chat clients (one :class:`CircuitBreaker` per endpoint,
shared when the VLM and the LLM are one server and model), the :class:`SceneVLM`, the
:class:`LLMRelevance` and the detector (its weights load then). The component factory hands the same
stack to the ``models`` perception source and the ``llm`` relevance scorer, so that the perception
worker's relevance prefetch fills the cache the tree reads, and the scorer's errors reach the
perception results (and so the record).

Example:
    >>> stack = ModelStack(ModelsProfile(vlm=VLMConfig(base_url="http://127.0.0.1:8000/v1", model="q")))
    >>> stack.perception().detector is None
    True
    >>> stack.close()
"""

from __future__ import annotations

import dataclasses
from typing import Any

from semexp_bt.perception.adapters.chat import CircuitBreaker, OpenAIChatClient
from semexp_bt.perception.adapters.detection import Detector, load_detector
from semexp_bt.perception.adapters.source import ModelsPerception
from semexp_bt.perception.adapters.vlm import SceneVLM
from semexp_bt.perception.llm_relevance import LLMRelevance
from semexp_bt.perception.model_config import ChatEndpointConfig, ModelsProfile, VLMConfig


class ModelStack:
    """The real models of one profile (see the module docstring).

    Args:
        profile: which models, where.

    Raises (from the accessors):
        ValueError: a model the profile does not configure, or an API key variable that is not set.
        DetectorLoadError: the detector's library or weights are missing.
    """

    def __init__(self, profile: ModelsProfile) -> None:
        self.profile = profile
        self._breakers: dict[tuple[str, str], CircuitBreaker] = {}
        self._vlm: SceneVLM | None = None
        self._relevance: LLMRelevance | None = None
        self._detector: Detector | None = None
        self._sources: list[ModelsPerception] = []

    def _client(self, config: ChatEndpointConfig, role: str) -> OpenAIChatClient:
        key = (config.base_url, config.model)
        if key not in self._breakers:
            self._breakers[key] = CircuitBreaker(
                self.profile.circuit_breaker, name=f"{config.model} ({config.base_url})"
            )
        return OpenAIChatClient(config=config, breaker=self._breakers[key], role=role)

    def vlm(self) -> SceneVLM:
        """The scene-level VLM."""
        if self._vlm is None:
            config = self.profile.vlm
            if config is None:
                raise ValueError(
                    f"{self.profile.source}: no 'vlm' section (give one, or --vlm-url/--vlm-model)"
                )
            self._vlm = SceneVLM(config, self._client(config, "vlm"))
        return self._vlm

    def relevance(self) -> LLMRelevance:
        """The LLM relevance scorer (one per stack: its caches are shared)."""
        if self._relevance is None:
            config = self.profile.llm
            if config is None:
                raise ValueError(
                    f"{self.profile.source}: no 'llm' section (give one, or --llm-url/--llm-model)"
                )
            self._relevance = LLMRelevance(config, self._client(config, "llm"))
        return self._relevance

    def detector(self) -> Detector:
        """The open-vocabulary detector, weights loaded."""
        if self._detector is None:
            config = self.profile.detector
            if config is None:
                raise ValueError(f"{self.profile.source}: no 'detector' section")
            self._detector = load_detector(config)
        return self._detector

    def perception(self, *, enable_vlm: bool = True, enable_detector: bool = True) -> ModelsPerception:
        """A perception source over the configured VLM and detector (each also switched by the strategy).

        The LLM scorer, once the mission has built it (:meth:`relevance`), reports its errors through
        this source and, with ``prefetch``, scores each view's labels in the VLM's worker.

        Raises:
            ValueError: when no enabled model is configured.
        """
        vlm_config: VLMConfig | None = self.profile.vlm if enable_vlm else None
        use_detector = enable_detector and self.profile.detector is not None
        if vlm_config is None and not use_detector:
            raise ValueError(
                f"{self.profile.source}: the models perception source needs a 'vlm' or a 'detector' section"
                " (for the strategy's enabled sources)"
            )
        source = ModelsPerception(
            vlm=self.vlm() if vlm_config is not None else None,
            detector=self.detector() if use_detector else None,
            relevance=lambda: self._relevance,
            prefetch=self.profile.llm is not None and self.profile.llm.prefetch,
        )
        self._sources.append(source)
        return source

    def summary(self) -> dict[str, Any]:
        """What the stack's models did, for the episode record: each model's calls, failures and latency
        (from the perception sources), the relevance scorer's counters (its cache's hit rate among them)
        and the profile's models."""
        out: dict[str, Any] = {"profile": self.profile.source, "models": list(self.profile.enabled_sources())}
        for source in self._sources:
            out.setdefault("calls", {}).update(source.call_stats())
        if self._relevance is not None:
            stats = self._relevance.stats
            out["relevance"] = {**dataclasses.asdict(stats), "hit_rate": round(stats.hit_rate, 4)}
        return out

    def drain_errors(self) -> list[str]:
        """Model errors not yet handed to a perception result (the LLM scorer's, in an emulator run)."""
        return self._relevance.drain_errors() if self._relevance is not None else []

    def close(self) -> None:
        """Stop the sources' threads and close the relevance cache."""
        for source in self._sources:
            source.close()
        if self._relevance is not None:
            self._relevance.close()
