"""The chat client's rules against a real server on 127.0.0.1: time-outs, bounded retries with backoff on
429/5xx, the circuit breaker, and API keys that never reach a record, a log or an error message."""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("openai")
pytest.importorskip("jsonschema")

from semexp_bt.perception.adapters.chat import (
    BACKOFF_INITIAL_S,
    BACKOFF_MAX_S,
    ChatReply,
    ChatRequest,
    CircuitBreaker,
    ModelCallError,
    OpenAIChatClient,
    ReplyError,
    _backoff_s,
    reply_json,
)
from semexp_bt.perception.adapters.source import ModelsPerception
from semexp_bt.perception.adapters.vlm import SceneVLM
from semexp_bt.perception.model_config import CircuitBreakerConfig
from sims.scripted_chat_server import ScriptedChatServer, ScriptedReply
from tests.models_support import (
    INSTRUCTION,
    TARGET,
    frame,
    observation,
    perceive_once,
    scene_json,
    still,
    vlm_config,
)

SECRET = "sk-test-5f3c9a1e7d2b4c6a"
REQUEST = ChatRequest(prompt="hello", schema={"type": "object"}, schema_name="test")


@pytest.fixture()
def server() -> Iterator[ScriptedChatServer]:
    with ScriptedChatServer([ScriptedReply(content="{}")]) as running:
        yield running


def client(
    server: ScriptedChatServer, *, sleeps: list[float] | None = None, **overrides: object
) -> OpenAIChatClient:
    waits = sleeps if sleeps is not None else []
    return OpenAIChatClient(
        config=vlm_config(server.url, **overrides),  # type: ignore[arg-type]
        breaker=CircuitBreaker(CircuitBreakerConfig(failures_to_open=3, open_s=60.0), name="test endpoint"),
        role="vlm",
        environ={},
        sleep=waits.append,
    )


def test_a_slow_reply_past_the_timeout_fails_after_the_bounded_attempts(server: ScriptedChatServer) -> None:
    server.set_script([ScriptedReply(content="{}", delay_s=3.0)])
    start = time.perf_counter()
    with pytest.raises(ModelCallError, match=r"no reply within the 0.3 s timeout \(2 attempts\)"):
        client(server, timeout_s=0.3, max_retries=1).complete(REQUEST)
    elapsed = time.perf_counter() - start
    print(f"two 0.3 s attempts took {elapsed:.2f} s")
    assert len(server.requests) == 2
    assert elapsed < 2.0  # bounded by the attempts, not by the server's 3 s


def test_429_is_retried_with_the_servers_retry_after_then_succeeds(server: ScriptedChatServer) -> None:
    server.set_script(
        [ScriptedReply(status=429, headers={"retry-after-ms": "20"}), ScriptedReply(content='{"ok": true}')]
    )
    sleeps: list[float] = []
    reply = client(server, sleeps=sleeps, max_retries=2).complete(REQUEST)
    assert reply.text == '{"ok": true}' and reply.attempts == 2
    assert sleeps == [pytest.approx(0.02)]
    assert len(server.requests) == 2


def test_retry_after_is_capped_and_backoff_doubles() -> None:
    assert _backoff_s(1, 120.0) == BACKOFF_MAX_S  # a server asking for two minutes gets the cap
    assert [_backoff_s(n, None) for n in (1, 2, 3)] == [
        BACKOFF_INITIAL_S,
        2 * BACKOFF_INITIAL_S,
        4 * BACKOFF_INITIAL_S,
    ]
    assert _backoff_s(10, None) == BACKOFF_MAX_S


@pytest.mark.parametrize("status", [429, 500, 503])
def test_a_persistent_429_or_5xx_fails_after_max_retries_with_backoff(
    server: ScriptedChatServer, status: int
) -> None:
    server.set_script([ScriptedReply(status=status, content="overloaded")])
    sleeps: list[float] = []
    with pytest.raises(ModelCallError, match=rf"HTTP {status}: .*overloaded.* \(3 attempts\)"):
        client(server, sleeps=sleeps, max_retries=2).complete(REQUEST)
    assert len(server.requests) == 3
    assert sleeps == [BACKOFF_INITIAL_S, 2 * BACKOFF_INITIAL_S]


def test_a_400_is_not_retried(server: ScriptedChatServer) -> None:
    server.set_script([ScriptedReply(status=400, content="bad schema")])
    with pytest.raises(ModelCallError, match=r"HTTP 400: .*bad schema.* \(1 attempt\)"):
        client(server, max_retries=2).complete(REQUEST)
    assert len(server.requests) == 1


def test_a_dead_endpoint_is_a_connection_error() -> None:
    dead = ScriptedChatServer()  # bound, never started: nothing answers on its port
    url = dead.url
    dead.stop()
    config = vlm_config(url, timeout_s=0.5, max_retries=1)
    broken = OpenAIChatClient(
        config=config,
        breaker=CircuitBreaker(CircuitBreakerConfig(), name="dead"),
        environ={},
        sleep=lambda s: None,
    )
    with pytest.raises(ModelCallError, match=r"cannot connect.*\(2 attempts\)"):
        broken.complete(REQUEST)


def test_the_circuit_opens_after_repeated_failures_and_a_trial_closes_it(server: ScriptedChatServer) -> None:
    now = [0.0]
    breaker = CircuitBreaker(
        CircuitBreakerConfig(failures_to_open=2, open_s=10.0), name="test endpoint", clock=lambda: now[0]
    )
    chat = OpenAIChatClient(
        config=vlm_config(server.url, max_retries=0), breaker=breaker, environ={}, sleep=lambda s: None
    )
    server.set_script([ScriptedReply(status=500)])
    for _ in range(2):
        with pytest.raises(ModelCallError, match="HTTP 500"):
            chat.complete(REQUEST)
    assert breaker.state == "open" and len(server.requests) == 2
    with pytest.raises(ModelCallError, match="circuit open after 2 failed requests"):
        chat.complete(REQUEST)
    assert len(server.requests) == 2  # refused without asking
    now[0] = 10.5
    assert breaker.state == "half_open"
    server.set_script([ScriptedReply(content="{}")])
    assert chat.complete(REQUEST).text == "{}"
    assert breaker.state == "closed" and len(server.requests) == 3


def test_a_failed_trial_opens_the_circuit_again() -> None:
    now = [0.0]
    breaker = CircuitBreaker(
        CircuitBreakerConfig(failures_to_open=1, open_s=5.0), name="e", clock=lambda: now[0]
    )
    breaker.before_request()
    breaker.record_failure()
    now[0] = 6.0
    breaker.before_request()  # the one trial
    with pytest.raises(ModelCallError, match="circuit open"):
        breaker.before_request()  # a second request while the trial is out
    breaker.record_failure()
    assert breaker.state == "open"


def test_an_open_circuit_is_a_recorded_error_in_the_tree(server: ScriptedChatServer, tmp_path: Path) -> None:
    server.set_script([ScriptedReply(status=503)])
    breaker = CircuitBreaker(CircuitBreakerConfig(failures_to_open=1, open_s=60.0), name="test endpoint")
    config = vlm_config(server.url, max_retries=0)
    vlm = SceneVLM(config, OpenAIChatClient(config=config, breaker=breaker, environ={}, sleep=lambda s: None))
    assert (
        vlm.perceive(rgb=frame(), instruction=INSTRUCTION, target_label=TARGET, stamp_s=0.0).evidence is None
    )
    result = perceive_once(tmp_path, ModelsPerception(vlm=vlm, detector=None))
    (error,) = [e for e in result.services.events if e["kind"] == "perception_error"]
    assert "circuit open" in error["message"] and len(server.requests) == 1


def test_a_missing_key_variable_is_a_clear_error(server: ScriptedChatServer) -> None:
    with pytest.raises(ValueError, match="environment variable MY_KEY .* is not set"):
        client_with_key(server, environ={})


def client_with_key(
    server: ScriptedChatServer, *, environ: dict[str, str], **overrides: object
) -> OpenAIChatClient:
    config = vlm_config(server.url, api_key_env="MY_KEY", **overrides)  # type: ignore[arg-type]
    return OpenAIChatClient(
        config=config,
        breaker=CircuitBreaker(CircuitBreakerConfig(), name="e"),
        environ=environ,
        sleep=lambda s: None,
    )


def test_the_api_key_is_sent_but_never_recorded_logged_or_put_in_an_error(
    server: ScriptedChatServer, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG)
    chat = client_with_key(server, environ={"MY_KEY": SECRET}, max_retries=1)
    server.set_script([ScriptedReply(content=scene_json())])
    assert chat.complete(REQUEST).attempts == 1
    assert server.requests[-1].headers["authorization"] == f"Bearer {SECRET}"  # it is sent...

    # ... and a server that echoes it back in its error body does not get it into our messages.
    server.set_script([ScriptedReply(status=401, content=f"invalid key {SECRET}")])
    with pytest.raises(ModelCallError) as failure:
        chat.complete(REQUEST)
    assert SECRET not in str(failure.value) and "[redacted]" in str(failure.value)
    assert SECRET not in repr(chat)

    vlm = SceneVLM(chat.config, chat)  # type: ignore[arg-type]
    source = ModelsPerception(vlm=vlm, detector=None)
    job = source.submit(
        observation=observation(), instruction=INSTRUCTION, target_label=TARGET, motion=still(), now_s=0.0
    )
    report = job.wait(10.0)
    assert report is not None and report.result.errors
    result = perceive_once(tmp_path, source)
    record = json.dumps({"report": report.as_dict(), "events": result.services.events}, default=str)
    assert "invalid key" in record and SECRET not in record
    assert SECRET not in caplog.text
    source.close()


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ('{"a": 1}', {"a": 1}),
        ('  \n{"a": 1}\n', {"a": 1}),
        ('```json\n{"a": 1}\n```', {"a": 1}),
        ('```\n{"a": 1}\n```', {"a": 1}),
    ],
)
def test_reply_json_reads_bare_or_fenced_json(text: str, value: object) -> None:
    assert reply_json(ChatReply(text=text, finish_reason="stop", latency_s=0.0, attempts=1)) == value


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("", "empty reply"),
        ('Here: {"a": 1}', "not JSON"),
        ('{"a": 1} is the answer', "not JSON"),
        ('```json\n{"a": 1}\n``` and more', "not JSON"),
        ('{"a": ', "not JSON"),
        ('{"a": Infinity}', "Infinity"),
    ],
)
def test_reply_json_rejects_everything_else(text: str, reason: str) -> None:
    with pytest.raises(ReplyError, match=reason):
        reply_json(ChatReply(text=text, finish_reason="stop", latency_s=0.0, attempts=1))
