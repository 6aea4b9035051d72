"""The LLM relevance scorer S_LLM against a real chat-completions server on 127.0.0.1: batching,
deterministic decoding, the memory and disk caches, failures that fall back and are recorded, and the
perception worker's prefetch."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("openai")
pytest.importorskip("jsonschema")

from semexp_bt.app.components import ComponentRequest, build_perception, build_relevance
from semexp_bt.app.strategies import resolve_strategy
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import InvalidInputError
from semexp_bt.perception.adapters.chat import ChatReply, CircuitBreaker, OpenAIChatClient, ReplyError
from semexp_bt.perception.adapters.stack import ModelStack
from semexp_bt.perception.llm_relevance import LLMRelevance, parse_relevance_scores
from semexp_bt.perception.model_config import CircuitBreakerConfig, LLMConfig, ModelsProfile
from semexp_bt.perception.prompts import RELEVANCE, load_prompt
from sims.scripted_chat_server import (
    ScriptedChatServer,
    ScriptedReply,
    scripted_models,
    scripted_relevance_reply,
)
from tests.models_support import INSTRUCTION, TARGET, observation, still, vlm_config

LABELS = ["fire extinguisher", "extinguisher", "sofa", "red trash can", "open corridor"]
LEXICAL = LexicalRelevance()


@pytest.fixture()
def server() -> Iterator[ScriptedChatServer]:
    with ScriptedChatServer(scripted_relevance_reply) as running:
        yield running


def llm_config(url: str, **overrides: object) -> LLMConfig:
    values: dict[str, object] = {
        "base_url": url,
        "model": "gpt-4o",
        "timeout_s": 2.0,
        "max_retries": 0,
        "cache_path": "",
    }
    values.update(overrides)
    return LLMConfig(**values)  # type: ignore[arg-type]


def scorer(url: str, **overrides: object) -> LLMRelevance:
    config = llm_config(url, **overrides)
    client = OpenAIChatClient(
        config=config,
        breaker=CircuitBreaker(CircuitBreakerConfig(failures_to_open=100), name="llm"),
        role="llm",
        environ={},
    )
    return LLMRelevance(config, client)


def test_labels_are_scored_in_batches_at_temperature_zero(server: ScriptedChatServer) -> None:
    llm = scorer(server.url, batch_size=2)
    values = llm.scores(instruction=INSTRUCTION, labels=LABELS)
    print(dict(zip(LABELS, values.tolist(), strict=True)))
    np.testing.assert_allclose(values, LEXICAL.scores(instruction=TARGET, labels=LABELS), atol=1e-4)
    assert len(server.requests) == 3  # 2 + 2 + 1
    first = server.requests[0]
    assert first.body["model"] == "gpt-4o" and first.body["temperature"] == 0.0
    assert first.image_data_url() is None
    assert '1. "fire extinguisher"\n2. "extinguisher"' in first.text()
    assert first.body["response_format"]["json_schema"]["schema"] == load_prompt(RELEVANCE).schema
    assert llm.stats.requests == 3 and llm.stats.asked == 5 and llm.drain_errors() == []


def test_a_repeated_lookup_asks_nothing_and_duplicates_are_asked_once(server: ScriptedChatServer) -> None:
    llm = scorer(server.url)
    llm.scores(instruction=INSTRUCTION, labels=["sofa", "sofa", "extinguisher"])
    assert server.requests[-1].text().count('"sofa"') == 1
    before = len(server.requests)
    assert llm.score(instruction=INSTRUCTION, label="sofa") == pytest.approx(0.0)
    assert len(server.requests) == before
    assert llm.stats.memory_hits == 1 and llm.stats.hit_rate == pytest.approx(1 - 2 / 3)


def test_the_disk_cache_is_keyed_by_model_prompt_version_instruction_and_label(
    server: ScriptedChatServer, tmp_path: Path
) -> None:
    cache = str(tmp_path / "cache" / "relevance.sqlite3")
    scorer(server.url, cache_path=cache).scores(instruction=INSTRUCTION, labels=LABELS)
    assert len(server.requests) == 1

    again = scorer(server.url, cache_path=cache)  # a new process, say
    np.testing.assert_allclose(
        again.scores(instruction=INSTRUCTION, labels=LABELS),
        LEXICAL.scores(instruction=TARGET, labels=LABELS),
        atol=1e-4,
    )
    assert len(server.requests) == 1 and again.stats.disk_hits == len(LABELS)

    scorer(server.url, cache_path=cache, model="another-model").scores(instruction=INSTRUCTION, labels=LABELS)
    assert len(server.requests) == 2
    scorer(server.url, cache_path=cache).scores(instruction="find the sofa", labels=LABELS)
    assert len(server.requests) == 3
    edited = scorer(server.url, cache_path=cache)
    prompt = load_prompt(RELEVANCE)
    edited.prompt = dataclasses.replace(
        prompt, text=prompt.text + "\nBe brief.", version=prompt.version + "-edited"
    )
    edited.scores(instruction=INSTRUCTION, labels=LABELS)
    assert len(server.requests) == 4


def test_an_unusable_cache_path_is_reported_and_scoring_goes_on(
    server: ScriptedChatServer, tmp_path: Path
) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    llm = scorer(server.url, cache_path=str(blocker / "relevance.sqlite3"))
    assert llm.score(instruction=INSTRUCTION, label="extinguisher") > 0.5
    (error,) = llm.drain_errors()
    assert "cache" in error and "running without it" in error


BAD = {
    "HTTP 500": (ScriptedReply(status=500, content="down"), "HTTP 500"),
    "prose": (ScriptedReply(content='The scores are {"scores": []}'), "not JSON"),
    "a missing id": (
        ScriptedReply(content=json.dumps({"scores": [{"id": 1, "relevance": 0.5}]})),
        "no score for label id(s) [2]",
    ),
    "a repeated id": (
        ScriptedReply(
            content=json.dumps({"scores": [{"id": 1, "relevance": 0.5}, {"id": 1, "relevance": 0.5}]})
        ),
        "scored twice",
    ),
    "out of range": (
        ScriptedReply(
            content=json.dumps({"scores": [{"id": 1, "relevance": 1.5}, {"id": 2, "relevance": 0.5}]})
        ),
        "scores[0].relevance",
    ),
    "an unknown id": (
        ScriptedReply(
            content=json.dumps({"scores": [{"id": 1, "relevance": 0.5}, {"id": 7, "relevance": 0.5}]})
        ),
        "names no label",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_failed_batch_falls_back_uncached_and_is_recorded(server: ScriptedChatServer, case: str) -> None:
    reply, reason = BAD[case]
    server.set_script([reply])
    llm = scorer(server.url)
    labels = ["extinguisher", "sofa"]
    values = llm.scores(instruction=INSTRUCTION, labels=labels)
    np.testing.assert_allclose(values, LEXICAL.scores(instruction=INSTRUCTION, labels=labels))
    (error,) = llm.drain_errors()
    print(case, "->", error)
    assert reason in error and "LexicalRelevance fallback" in error and error.startswith("llm ")
    assert llm.stats.fallbacks == 2 and llm.calls[-1].ok is False

    server.set_script(scripted_relevance_reply)  # the model recovers: the fallback was not cached
    llm.scores(instruction=INSTRUCTION, labels=labels)
    assert llm.drain_errors() == [] and llm.calls[-1].ok


def test_parse_relevance_scores_reads_ids_in_label_order() -> None:
    schema = load_prompt(RELEVANCE).schema
    text = json.dumps({"scores": [{"id": 2, "relevance": 0.25}, {"id": 1, "relevance": 1}]})
    assert parse_relevance_scores(ChatReply(text, "stop", 0.0, 1), n_labels=2, schema=schema) == [1.0, 0.25]
    with pytest.raises(ReplyError, match="breaks the schema at scores"):
        parse_relevance_scores(
            ChatReply('{"scores": [{"id": 1}]}', "stop", 0.0, 1), n_labels=1, schema=schema
        )


def test_the_perception_worker_prefetches_each_views_labels(tmp_path: Path) -> None:
    with ScriptedChatServer(scripted_models) as server:
        profile = ModelsProfile(vlm=vlm_config(server.url), llm=llm_config(server.url, model="gpt-4o"))
        stack = ModelStack(profile)
        request = ComponentRequest(seed=0, strategy=resolve_strategy("ours"), models=stack)
        perception = build_perception("models", request)
        relevance = build_relevance("llm", request)
        assert isinstance(relevance, CachedRelevance) and relevance.scorer is stack.relevance()
        job = perception.submit(
            observation=observation(), instruction=INSTRUCTION, target_label=TARGET, motion=still(), now_s=0.0
        )
        report = job.wait(10.0)  # type: ignore[attr-defined]
        assert report is not None and report.result.errors == ()
        assert [c.source for c in report.calls] == ["vlm", "llm"]
        asked = len(server.requests)
        labels = [TARGET, "open corridor", "unexplored area on the left"]
        relevance.scores(instruction=INSTRUCTION, labels=labels)  # what Arbitrate and Decide will ask
        assert len(server.requests) == asked  # all cache hits: no LLM call inside a tick
        stack.close()


def test_prefetch_failures_reach_the_perception_result() -> None:
    def answer(body: dict) -> ScriptedReply:  # type: ignore[type-arg]
        return scripted_models(body) if "image_url" in json.dumps(body) else ScriptedReply(content="no idea")

    with ScriptedChatServer(answer) as server:
        stack = ModelStack(ModelsProfile(vlm=vlm_config(server.url), llm=llm_config(server.url)))
        request = ComponentRequest(seed=0, strategy=resolve_strategy("ours"), models=stack)
        build_relevance("llm", request)
        job = build_perception("models", request).submit(
            observation=observation(), instruction=INSTRUCTION, target_label=TARGET, motion=still(), now_s=0.0
        )
        report = job.wait(10.0)  # type: ignore[attr-defined]
        assert report is not None and report.result.scene is not None  # the VLM's evidence stands
        (error,) = report.result.errors
        assert error.startswith("llm gpt-4o: reply is not JSON") and "fallback" in error
        stack.close()


def test_the_llm_row_needs_a_models_profile() -> None:
    with pytest.raises(InvalidInputError, match="needs a models profile"):
        build_relevance("llm")
    with pytest.raises(InvalidInputError, match="needs a models profile"):
        build_relevance("llm", ComponentRequest(seed=0, strategy=resolve_strategy("ours")))
    with pytest.raises(ValueError, match="no 'llm' section"):
        build_relevance(
            "llm",
            ComponentRequest(seed=0, strategy=resolve_strategy("ours"), models=ModelStack(ModelsProfile())),
        )


class BrokenTransport:
    model = "broken"

    def complete(self, request: object) -> ChatReply:
        raise TypeError("a bug in a transport")


def test_an_unexpected_failure_inside_a_tick_lookup_falls_back_instead_of_raising() -> None:
    llm = LLMRelevance(llm_config("http://unused/v1"), BrokenTransport())  # type: ignore[arg-type]
    assert llm.score(instruction=INSTRUCTION, label="extinguisher") == LEXICAL.score(
        instruction=INSTRUCTION, label="extinguisher"
    )
    (error,) = llm.drain_errors()
    assert error.startswith("llm broken: unexpected TypeError: a bug in a transport") and "fallback" in error
