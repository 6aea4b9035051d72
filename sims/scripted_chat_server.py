"""A scripted OpenAI-compatible chat-completions server on 127.0.0.1, for tests and benchmarks.

It stands in for a model server (vLLM, Ollama, OpenAI) the way the perception emulator stands in for
the models themselves: a real HTTP server speaking the chat-completions protocol, so the model
adapters run their real client code. Each ``POST /v1/chat/completions`` is recorded
(:class:`RecordedRequest`: the JSON body and the headers) and answered by the script:

* a sequence of :class:`ScriptedReply` (used in turn; the last one repeats), or
* a callable ``(body) -> ScriptedReply`` that answers from the request, for example
  :func:`scripted_models`, which plays both prompts: a scene-proposal request (it carries an image) is
  answered with direction proposals placed on the decoded frame, a relevance request with the lexical
  scorer's values for the numbered labels.

A reply may be slow (``delay_s``), fail with an HTTP status (429 with ``Retry-After``, 500), be cut
(``finish_reason="length"``), or be anything at all as ``content``. It listens on loopback only and
stops with :meth:`ScriptedChatServer.stop` (or the ``with`` block); a reply still sleeping is cut short.

Example:
    >>> with ScriptedChatServer([ScriptedReply(content='{"scores": []}')]) as server:  # doctest: +SKIP
    ...     client = openai.OpenAI(base_url=server.url, api_key="none")
    ...     client.chat.completions.create(model="m", messages=[{"role": "user", "content": "hi"}])

Run one by hand (``semexp-bt perceive ... --vlm-url`` against it, no model needed)::

    python -m sims.scripted_chat_server --port 8765
"""

from __future__ import annotations

import argparse
import base64
import json
import re
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.core.relevance import LexicalRelevance

_TARGET = re.compile(r'The object to find: "(?P<target>(?:[^"\\]|\\.)*)"')
_NUMBERED_LABEL = re.compile(r'^(?P<id>\d+)\. (?P<label>".*")$', re.MULTILINE)


@dataclass(frozen=True)
class ScriptedReply:
    """One scripted answer.

    Attributes:
        content: the assistant message's text; for an error status, the error body's message.
        status: the HTTP status; anything but 200 answers with an OpenAI-style error body.
        delay_s: wait this long before answering.
        finish_reason: ``stop``, or ``length`` for a reply cut at max_tokens.
        headers: extra response headers (``retry-after-ms``).
    """

    content: str = ""
    status: int = 200
    delay_s: float = 0.0
    finish_reason: str = "stop"
    headers: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class RecordedRequest:
    """A request as the server saw it (header names lower-cased)."""

    path: str
    headers: dict[str, str]
    body: dict[str, Any]
    received_s: float

    @property
    def model(self) -> str | None:
        return self.body.get("model")

    def text(self) -> str:
        """The text parts of the user messages, joined."""
        return request_text(self.body)

    def image_data_url(self) -> str | None:
        """The first image content part's URL, or None."""
        return request_image_url(self.body)


Script = Sequence[ScriptedReply] | Callable[[dict[str, Any]], ScriptedReply]


def request_text(body: dict[str, Any]) -> str:
    """The text of every message's text content, joined by newlines."""
    parts = []
    for message in body.get("messages", []):
        content = message.get("content")
        if isinstance(content, str):
            parts.append(content)
        elif isinstance(content, list):
            parts += [p.get("text", "") for p in content if isinstance(p, dict) and p.get("type") == "text"]
    return "\n".join(parts)


def request_image_url(body: dict[str, Any]) -> str | None:
    """The first ``image_url`` content part's URL."""
    for message in body.get("messages", []):
        content = message.get("content")
        if isinstance(content, list):
            for part in content:
                if isinstance(part, dict) and part.get("type") == "image_url":
                    return str(part.get("image_url", {}).get("url"))
    return None


def decode_image(data_url: str) -> npt.NDArray[np.uint8]:
    """An ``(H, W, 3)`` RGB array from a base64 ``data:image/...`` URL.

    Raises:
        ValueError: when it is not a decodable image.
    """
    import cv2

    header, _, payload = data_url.partition(",")
    if not header.startswith("data:image/") or not payload:
        raise ValueError(f"not an image data URL: {data_url[:40]!r}")
    bgr = cv2.imdecode(np.frombuffer(base64.b64decode(payload), dtype=np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError("the image data URL does not decode")
    return np.ascontiguousarray(bgr[:, :, ::-1])


def scripted_scene_reply(body: dict[str, Any], *, claim_target: bool = False) -> ScriptedReply:
    """Scene proposals placed on the request's decoded frame: "open corridor" at the centre of the lower
    half, "unexplored area on the left" near the left edge; with ``claim_target``, the prompt's target
    at the image centre. C_s 0.7."""
    url = request_image_url(body)
    if url is None:
        return ScriptedReply(status=400, content="a scene request carries an image")
    height, width = decode_image(url).shape[:2]
    proposals: list[dict[str, Any]] = [
        {"kind": "direction", "label": "open corridor", "point": [width // 2, int(height * 0.6)]},
        {"kind": "direction", "label": "unexplored area on the left", "point": [2, int(height * 0.6)]},
    ]
    match = _TARGET.search(request_text(body))
    if claim_target and match is not None:
        target = json.loads(f'"{match.group("target")}"')
        proposals.insert(0, {"kind": "object", "label": target, "point": [width // 2, height // 2]})
    return ScriptedReply(content=json.dumps({"proposals": proposals, "scene_confidence": 0.7}))


def scripted_relevance_reply(body: dict[str, Any]) -> ScriptedReply:
    """The lexical scorer's relevance for each numbered label of a relevance prompt."""
    text = request_text(body)
    match = _TARGET.search(text)
    target = json.loads(f'"{match.group("target")}"') if match else ""
    labels = [(int(m.group("id")), json.loads(m.group("label"))) for m in _NUMBERED_LABEL.finditer(text)]
    lexical = LexicalRelevance()
    scores = [
        {"id": label_id, "relevance": round(lexical.score(instruction=target or label, label=label), 4)}
        for label_id, label in labels
    ]
    return ScriptedReply(content=json.dumps({"scores": scores}))


def scripted_models(body: dict[str, Any]) -> ScriptedReply:
    """Both prompts: a request with an image gets scene proposals, one without gets relevance scores."""
    if request_image_url(body) is not None:
        return scripted_scene_reply(body)
    return scripted_relevance_reply(body)


class ScriptedChatServer:
    """The server (see the module docstring).

    Args:
        script: the replies in turn (the last repeats), or a callable answering from the request body.
        port: 0 picks a free port.
    """

    def __init__(self, script: Script = scripted_models, *, port: int = 0) -> None:
        self.script = script
        self.requests: list[RecordedRequest] = []
        self._replies_used = 0
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._httpd = ThreadingHTTPServer(("127.0.0.1", port), self._handler_class())
        self._httpd.daemon_threads = True
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        return int(self._httpd.server_address[1])

    @property
    def url(self) -> str:
        """The API root to give a client: ``http://127.0.0.1:PORT/v1``."""
        return f"http://127.0.0.1:{self.port}/v1"

    def start(self) -> ScriptedChatServer:
        self._thread = threading.Thread(
            target=self._httpd.serve_forever,
            kwargs={"poll_interval": 0.05},
            name="scripted-chat",
            daemon=True,
        )
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close the socket (cuts short a reply still waiting out its delay)."""
        self._stopping.set()
        if self._thread is not None:
            self._httpd.shutdown()
            self._thread.join(timeout=5.0)
        self._httpd.server_close()

    def __enter__(self) -> ScriptedChatServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def set_script(self, script: Script) -> None:
        """Answer from ``script`` from now on (a sequence starts again at its first reply)."""
        with self._lock:
            self.script = script
            self._replies_used = 0

    def next_reply(self, body: dict[str, Any]) -> ScriptedReply:
        if callable(self.script):
            return self.script(body)
        with self._lock:
            index = min(self._replies_used, len(self.script) - 1)
            self._replies_used += 1
        return self.script[index]

    def _handler_class(self) -> type[BaseHTTPRequestHandler]:
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"
            # Headers and body go out as two writes: without TCP_NODELAY, Nagle's algorithm and the
            # client's delayed ACK add about 40 ms to every reply (model servers set it too).
            disable_nagle_algorithm = True

            def log_message(self, format: str, *args: Any) -> None:
                del format, args  # quiet: tests read the records instead

            def do_GET(self) -> None:
                if self.path.rstrip("/").endswith("/models"):
                    self._send(200, {"object": "list", "data": [{"id": "scripted", "object": "model"}]})
                else:
                    self._send(404, {"error": {"message": f"no route {self.path}", "type": "not_found"}})

            def do_POST(self) -> None:
                length = int(self.headers.get("content-length", "0"))
                raw = self.rfile.read(length)
                try:
                    body = json.loads(raw)
                except json.JSONDecodeError:
                    self._send(400, {"error": {"message": "body is not JSON", "type": "invalid_request"}})
                    return
                with server._lock:
                    server.requests.append(
                        RecordedRequest(
                            path=self.path,
                            headers={k.lower(): v for k, v in self.headers.items()},
                            body=body,
                            received_s=time.monotonic(),
                        )
                    )
                if not self.path.rstrip("/").endswith("/chat/completions"):
                    self._send(404, {"error": {"message": f"no route {self.path}", "type": "not_found"}})
                    return
                reply = server.next_reply(body)
                if reply.delay_s > 0.0 and server._stopping.wait(reply.delay_s):
                    return
                if reply.status != 200:
                    message = reply.content or f"scripted status {reply.status}"
                    error = {"error": {"message": message, "type": "scripted"}}
                    self._send(reply.status, error, reply.headers)
                    return
                completion = {
                    "id": f"chatcmpl-scripted-{len(server.requests)}",
                    "object": "chat.completion",
                    "created": int(time.time()),
                    "model": body.get("model", ""),
                    "choices": [
                        {
                            "index": 0,
                            "message": {"role": "assistant", "content": reply.content},
                            "finish_reason": reply.finish_reason,
                        }
                    ],
                    "usage": {"prompt_tokens": 0, "completion_tokens": 0, "total_tokens": 0},
                }
                self._send(200, completion, reply.headers)

            def _send(
                self, status: int, payload: dict[str, Any], headers: dict[str, str] | None = None
            ) -> None:
                data = json.dumps(payload).encode("utf-8")
                try:
                    self.send_response(status)
                    self.send_header("content-type", "application/json")
                    self.send_header("content-length", str(len(data)))
                    for key, value in (headers or {}).items():
                        self.send_header(key, value)
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (its timeout): nothing to answer

        return Handler


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="a scripted OpenAI-compatible server on 127.0.0.1")
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--claim-target", action="store_true", help="also propose the target at the centre")
    args = parser.parse_args(argv)

    def script(body: dict[str, Any]) -> ScriptedReply:
        if request_image_url(body) is not None:
            return scripted_scene_reply(body, claim_target=args.claim_target)
        return scripted_relevance_reply(body)

    server = ScriptedChatServer(script, port=args.port).start()
    print(f"serving on {server.url} (Ctrl-C stops)", flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        server.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
