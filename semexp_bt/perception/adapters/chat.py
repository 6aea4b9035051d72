"""An OpenAI-compatible chat-completions client that never hangs and never trusts the other side.

:class:`OpenAIChatClient` sends one :class:`ChatRequest` (a prompt, optionally one image as a content
part, and the JSON schema the reply must follow) through the ``openai`` client library, which speaks to
vLLM, SGLang, Ollama, DashScope and OpenAI alike. Around each request:

* a per-attempt timeout (``timeout_s``), and at most ``max_retries`` retries on 408/409/429/5xx,
  connection errors and time-outs, waiting :data:`BACKOFF_INITIAL_S` x 2^n (at most
  :data:`BACKOFF_MAX_S`; a server's ``Retry-After`` is honoured up to the same cap). The library's own
  retries are off: it honours a ``Retry-After`` of up to two minutes, which would outlast the tree's
  perception time-out, so one request is bounded by ``(1 + max_retries) * timeout_s`` plus the waits;
* a :class:`CircuitBreaker` per endpoint: after ``failures_to_open`` failed requests in a row the
  endpoint is not asked for ``open_s`` seconds, then one trial request decides;
* every failure is a :class:`ModelCallError` whose message is safe to record: the API key never appears
  in it (:meth:`OpenAIChatClient.redact`).

:func:`reply_json` reads a reply as JSON: the whole reply, or one fenced code block that is the whole
reply. Prose around JSON, truncated JSON, an empty reply, NaN and Infinity are :class:`ReplyError`.
:func:`check_schema` validates the parsed reply against the prompt's schema with ``jsonschema``.

The ``openai`` and ``jsonschema`` packages are the ``models`` extra; they are imported on first use.
"""

from __future__ import annotations

import base64
import functools
import json
import math
import os
import re
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

from semexp_bt.perception.adapters.calls import ModelCall
from semexp_bt.perception.model_config import ChatEndpointConfig, CircuitBreakerConfig

#: First wait before a retry, s; doubled on each further retry.
BACKOFF_INITIAL_S = 0.5
#: Longest wait before a retry, s (also the cap on a server's ``Retry-After``).
BACKOFF_MAX_S = 4.0
#: HTTP statuses worth a retry (the rest are the request's fault and would fail again).
RETRYABLE_STATUSES = frozenset({408, 409, 429, 500, 502, 503, 504})
#: How much of a bad reply an error message quotes.
REPLY_EXCERPT_CHARS = 200

_FENCE = re.compile(r"^```[A-Za-z0-9_-]*\s*\n(?P<body>.*?)\n?\s*```$", re.DOTALL)


class ModelCallError(RuntimeError):
    """A model request failed: transport, HTTP status, time-out or open circuit. The message names the
    endpoint and the cause and never carries an API key."""


class ReplyError(ValueError):
    """A model's reply is not what its prompt asked for (not JSON, wrong schema, out of range)."""


@dataclass(frozen=True)
class ChatRequest:
    """One chat-completions request.

    Attributes:
        prompt: the user message's text.
        schema: the JSON schema of the reply (sent as structured output where the endpoint asks for it).
        schema_name: the schema's name in ``response_format`` (letters, digits, ``_`` and ``-``).
        image_data_url: the frame as a ``data:image/...;base64,`` URL, sent as an image content part.
    """

    prompt: str
    schema: Mapping[str, Any]
    schema_name: str
    image_data_url: str | None = None


@dataclass(frozen=True)
class ChatReply:
    """What the server answered.

    Attributes:
        text: the first choice's message content ("" when it had none).
        finish_reason: why generation stopped (``stop``; ``length`` means the reply was cut).
        latency_s: wall time of the whole request, retries included.
        attempts: requests sent (1 + retries used).
    """

    text: str
    finish_reason: str | None
    latency_s: float
    attempts: int


class ChatTransport(Protocol):
    """Anything that answers a :class:`ChatRequest` (the OpenAI client, a test double)."""

    @property
    def model(self) -> str:
        """The model name sent with every request."""
        ...

    def complete(self, request: ChatRequest) -> ChatReply:
        """The reply; raises :class:`ModelCallError` on any failure."""
        ...


# --------------------------------------------------------------------------------------------------
# Circuit breaker
# --------------------------------------------------------------------------------------------------

BreakerState = Literal["closed", "open", "half_open"]


class CircuitBreaker:
    """Stops asking an endpoint that keeps failing.

    Closed: every request goes. After ``failures_to_open`` consecutive failures it opens: requests are
    refused at once for ``open_s`` seconds. Then it is half open: one trial request goes (others are
    refused meanwhile); its success closes the breaker, its failure opens it again. Thread-safe.

    Args:
        config: the thresholds.
        name: how refusals name the endpoint.
        clock: monotonic seconds (injectable for tests).
    """

    def __init__(
        self, config: CircuitBreakerConfig, *, name: str, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.config = config
        self.name = name
        self._clock = clock
        self._lock = threading.Lock()
        self._failures = 0
        self._opened_at: float | None = None
        self._trial_in_flight = False

    @property
    def state(self) -> BreakerState:
        with self._lock:
            return self._state()

    def _state(self) -> BreakerState:
        if self._opened_at is None:
            return "closed"
        if self._clock() - self._opened_at < self.config.open_s:
            return "open"
        return "half_open"

    def before_request(self) -> None:
        """Let a request through, or raise :class:`ModelCallError` while the circuit is open."""
        with self._lock:
            state = self._state()
            if state == "closed":
                return
            if state == "half_open" and not self._trial_in_flight:
                self._trial_in_flight = True
                return
            assert self._opened_at is not None
            wait = max(0.0, self.config.open_s - (self._clock() - self._opened_at))
            raise ModelCallError(
                f"{self.name}: circuit open after {self._failures} failed requests in a row; "
                f"not asking for {wait:.1f} s more"
            )

    def record_success(self) -> None:
        with self._lock:
            self._failures = 0
            self._opened_at = None
            self._trial_in_flight = False

    def record_failure(self) -> None:
        with self._lock:
            self._failures += 1
            if self._trial_in_flight or self._failures >= self.config.failures_to_open:
                self._opened_at = self._clock()
            self._trial_in_flight = False


# --------------------------------------------------------------------------------------------------
# The client
# --------------------------------------------------------------------------------------------------


@dataclass
class _Attempt:
    error: str
    retryable: bool
    retry_after_s: float | None = None


@dataclass
class OpenAIChatClient:
    """A :class:`ChatTransport` over the ``openai`` library (see the module docstring for the rules).

    Args:
        config: the endpoint.
        breaker: the endpoint's circuit breaker (shared by every client of the same endpoint).
        role: how messages name this client (``vlm``, ``llm``).
        environ: where the API key's environment variable is read (``os.environ``).
        sleep: how retries wait (injectable for tests).

    Raises:
        ValueError: at construction when ``api_key_env`` names a variable that is not set.
    """

    config: ChatEndpointConfig
    breaker: CircuitBreaker
    role: str = "model"
    environ: Mapping[str, str] = field(default_factory=lambda: os.environ, repr=False)
    sleep: Callable[[float], None] = time.sleep
    _client: Any = field(default=None, init=False, repr=False)
    _api_key: str = field(default="", init=False, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, init=False, repr=False)

    def __post_init__(self) -> None:
        name = self.config.api_key_env
        if name:
            if not self.environ.get(name):
                raise ValueError(
                    f"{self.role}: the environment variable {name} (api_key_env) is not set; "
                    "export it, or set api_key_env: '' for a server that needs no key"
                )
            self._api_key = self.environ[name]
        # Built now, not at the first request: the import costs a second, which would land on the first
        # view's latency (and a missing package is a configuration error, reported before the mission).
        try:
            self._openai()
        except ImportError as exc:
            raise ValueError(
                f"{self.role}: the openai package is missing (pip install 'semexp-bt[models]'): {exc}"
            ) from None

    @property
    def model(self) -> str:
        return self.config.model

    @property
    def label(self) -> str:
        """``role model (base_url)``, how errors name this endpoint."""
        return f"{self.role} {self.config.model} ({self.config.base_url})"

    def redact(self, text: str) -> str:
        """``text`` with the API key (if any) replaced by ``[redacted]``."""
        return text.replace(self._api_key, "[redacted]") if self._api_key else text

    def _openai(self) -> Any:
        with self._lock:
            if self._client is None:
                import openai

                self._client = openai.OpenAI(
                    base_url=self.config.base_url,
                    # An explicit placeholder keeps the library from reading OPENAI_API_KEY for a server
                    # the profile says needs no key.
                    api_key=self._api_key or "no-key",
                    timeout=self.config.timeout_s,
                    max_retries=0,
                )
            return self._client

    def _response_format(self, request: ChatRequest) -> dict[str, Any] | None:
        kind = self.config.response_format
        if kind == "json_schema":
            return {
                "type": "json_schema",
                "json_schema": {"name": request.schema_name, "schema": dict(request.schema), "strict": True},
            }
        if kind == "json_object":
            return {"type": "json_object"}
        return None

    def complete(self, request: ChatRequest) -> ChatReply:
        """Send ``request``; retries, time-outs and the breaker as in the module docstring.

        Raises:
            ModelCallError: every attempt failed, or the circuit is open; the message names the endpoint,
                the attempts and the last cause, with the key redacted.
        """
        self.breaker.before_request()
        start = time.perf_counter()
        content: list[dict[str, Any]] = []
        if request.image_data_url is not None:
            content.append({"type": "image_url", "image_url": {"url": request.image_data_url}})
        content.append({"type": "text", "text": request.prompt})
        kwargs: dict[str, Any] = {
            "model": self.config.model,
            "messages": [{"role": "user", "content": content}],
            "temperature": 0.0,
            "max_tokens": self.config.max_tokens,
        }
        response_format = self._response_format(request)
        if response_format is not None:
            kwargs["response_format"] = response_format
        attempts = 0
        last: _Attempt | None = None
        client = self._openai()
        for attempt in range(self.config.max_retries + 1):
            if attempt > 0:
                self.sleep(_backoff_s(attempt, last.retry_after_s if last else None))
            attempts += 1
            try:
                completion = client.chat.completions.create(**kwargs)
            except Exception as exc:
                last = _describe(exc, timeout_s=self.config.timeout_s)
                if not last.retryable:
                    break
                continue
            self.breaker.record_success()
            return _reply_of(completion, latency_s=time.perf_counter() - start, attempts=attempts)
        self.breaker.record_failure()
        assert last is not None
        tries = f"{attempts} attempt" + ("s" if attempts != 1 else "")
        raise ModelCallError(self.redact(f"{self.label}: {last.error} ({tries})"))


def _backoff_s(retry: int, retry_after_s: float | None) -> float:
    """The wait before retry number ``retry`` (1-based): the server's ``Retry-After`` when it gave one,
    else exponential; never more than :data:`BACKOFF_MAX_S`."""
    if retry_after_s is not None and math.isfinite(retry_after_s) and retry_after_s >= 0.0:
        return min(retry_after_s, BACKOFF_MAX_S)
    return min(BACKOFF_INITIAL_S * 2.0 ** (retry - 1), BACKOFF_MAX_S)


def _retry_after_s(headers: Any) -> float | None:
    for header, divisor in (("retry-after-ms", 1000.0), ("retry-after", 1.0)):
        value = headers.get(header) if headers is not None else None
        if value is None:
            continue
        try:
            return float(value) / divisor
        except ValueError:
            continue
    return None


def _describe(exc: Exception, *, timeout_s: float) -> _Attempt:
    """One failed attempt, as a safe message and whether it is worth another try."""
    import openai

    if isinstance(exc, openai.APITimeoutError):
        return _Attempt(f"no reply within the {timeout_s:g} s timeout", retryable=True)
    if isinstance(exc, openai.APIConnectionError):
        return _Attempt(f"cannot connect: {type(exc).__name__}", retryable=True)
    if isinstance(exc, openai.APIStatusError):
        status = int(exc.status_code)
        message = _excerpt(str(getattr(exc, "message", "")) or str(exc))
        return _Attempt(
            f"HTTP {status}: {message}",
            retryable=status in RETRYABLE_STATUSES,
            retry_after_s=_retry_after_s(exc.response.headers),
        )
    return _Attempt(f"{type(exc).__name__}: {_excerpt(str(exc))}", retryable=False)


def _reply_of(completion: Any, *, latency_s: float, attempts: int) -> ChatReply:
    choices = getattr(completion, "choices", None) or []
    if not choices:
        return ChatReply(text="", finish_reason=None, latency_s=latency_s, attempts=attempts)
    choice = choices[0]
    message = getattr(choice, "message", None)
    text = getattr(message, "content", None)
    return ChatReply(
        text=text if isinstance(text, str) else "",
        finish_reason=getattr(choice, "finish_reason", None),
        latency_s=latency_s,
        attempts=attempts,
    )


_Parsed = TypeVar("_Parsed")


def ask(
    source: str,
    transport: ChatTransport,
    request: Callable[[], ChatRequest],
    parse: Callable[[ChatReply], _Parsed],
) -> tuple[_Parsed | None, ModelCall]:
    """One timed request: build it (``encode``), send it (``request``), read the reply (``parse``).

    Never raises for the model's sake: a failed request or a reply ``parse`` rejects gives None and a
    :class:`ModelCall` whose error names ``source`` and the model (the reply text is kept).

    Raises:
        Whatever ``request`` or ``parse`` raise besides :class:`ModelCallError`, :class:`ReplyError`
        and ``ValueError`` (a bug, for the caller's own guard).
    """
    start = time.perf_counter()
    timings: dict[str, float] = {}
    reply: ChatReply | None = None
    try:
        built = request()
        timings["encode"] = (time.perf_counter() - start) * 1e3
        t_request = time.perf_counter()
        reply = transport.complete(built)
        timings["request"] = (time.perf_counter() - t_request) * 1e3
        t_parse = time.perf_counter()
        value = parse(reply)
        timings["parse"] = (time.perf_counter() - t_parse) * 1e3
    except (ModelCallError, ReplyError, ValueError) as exc:
        error = str(exc) if isinstance(exc, ModelCallError) else f"{source} {transport.model}: {exc}"
        return None, ModelCall(
            source=source,
            model=transport.model,
            ok=False,
            reply=None if reply is None else reply.text,
            error=error,
            latency_s=time.perf_counter() - start,
            timings_ms=timings,
        )
    return value, ModelCall(
        source=source,
        model=transport.model,
        ok=True,
        reply=reply.text,
        latency_s=time.perf_counter() - start,
        timings_ms=timings,
    )


# --------------------------------------------------------------------------------------------------
# Reading replies
# --------------------------------------------------------------------------------------------------


def rgb_frame(rgb: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    """``rgb`` as an ``(H, W, 3)`` uint8 array.

    Raises:
        ValueError: for any other shape or type.
    """
    frame = np.asarray(rgb)
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3 or frame.size == 0:
        raise ValueError(f"the frame must be (H, W, 3) uint8 RGB, got {frame.shape} {frame.dtype}")
    return frame


def _excerpt(text: str) -> str:
    return text if len(text) <= REPLY_EXCERPT_CHARS else text[:REPLY_EXCERPT_CHARS] + "..."


def _reject_constant(name: str) -> Any:
    raise ReplyError(f"reply holds {name}, which is not a JSON number")


def reply_json(reply: ChatReply) -> Any:
    """The reply's JSON value: the whole text, or one fenced code block that is the whole text.

    Raises:
        ReplyError: the reply was cut at ``max_tokens``, is empty, is not JSON (prose around it,
            truncated), or holds NaN or Infinity; the message quotes the start of the reply.
    """
    text = reply.text.strip()
    if not text:
        raise ReplyError("empty reply")
    if reply.finish_reason == "length":
        raise ReplyError(f"reply cut at max_tokens (truncated): {_excerpt(text)!r}")
    fenced = _FENCE.match(text)
    if fenced is not None:
        text = fenced.group("body").strip()
    try:
        return json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise ReplyError(
            f"reply is not JSON ({exc.msg} at character {exc.pos}): {_excerpt(text)!r}"
        ) from None


@functools.lru_cache(maxsize=16)
def _validator(schema_json: str) -> Any:
    import jsonschema

    return jsonschema.Draft202012Validator(json.loads(schema_json))


def schema_validator(schema: Mapping[str, Any]) -> Any:
    """The (cached) ``jsonschema`` validator of a prompt's schema; adapters build theirs up front.

    Raises:
        ValueError: when the jsonschema package is missing.
    """
    try:
        return _validator(json.dumps(schema, sort_keys=True))
    except ImportError as exc:
        raise ValueError(
            f"reply validation needs jsonschema (pip install 'semexp-bt[models]'): {exc}"
        ) from None


def check_schema(value: Any, schema: Mapping[str, Any]) -> None:
    """Validate a parsed reply against its prompt's JSON schema.

    Raises:
        ReplyError: naming the first offending place (``proposals[1].point``) and the rule it breaks.
    """
    import jsonschema

    error = jsonschema.exceptions.best_match(schema_validator(schema).iter_errors(value))
    if error is None:
        return
    where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path).lstrip(".")
    raise ReplyError(f"reply breaks the schema at {where or 'the top level'}: {_excerpt(error.message)}")


def image_data_url(
    rgb: npt.NDArray[np.uint8], *, image_format: Literal["png", "jpeg"] = "png", jpeg_quality: int = 90
) -> str:
    """An ``(H, W, 3)`` uint8 RGB frame as a base64 ``data:`` URL (OpenCV encodes it).

    Raises:
        ValueError: on a frame of another shape or type, or when encoding fails.
    """
    import cv2

    bgr = np.ascontiguousarray(rgb_frame(rgb)[:, :, ::-1])
    if image_format == "jpeg":
        ok, buffer = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
    else:
        ok, buffer = cv2.imencode(".png", bgr)
    if not ok:
        raise ValueError(f"OpenCV could not encode the frame as {image_format}")
    encoded = base64.b64encode(buffer.tobytes()).decode("ascii")
    return f"data:image/{image_format};base64,{encoded}"
