"""The paper's LLM relevance S_LLM (GPT-4 in the paper) over an OpenAI-compatible chat endpoint.

:class:`LLMRelevance` is a :class:`semexp_bt.core.relevance.RelevanceScorer`. For one instruction it
asks for many labels at once: the fixed prompt ``prompts/relevance_v1.md`` numbers up to ``batch_size``
labels and the reply must be ``{"scores": [{"id": 1, "relevance": 0.9}, ...]}`` with every id exactly
once and every relevance a finite number in [0, 1] (schema ``relevance_v1.schema.json``), decoded at
temperature 0. Values are cached twice:

* in memory, for the process (the perception worker's prefetch and the tree's lookups share it);
* on disk (SQLite, ``cache_path``), per (model, prompt version, instruction, label), so a repeated
  mission, or the next process, asks nothing twice. The prompt version carries a hash of the prompt's
  files, so editing the prompt never serves stale values.

Never trusting: a batch whose request fails or whose reply breaks a rule is scored by the fallback
scorer (the lexical one) for this call only, not cached, and the reason is queued for the record
(:meth:`LLMRelevance.drain_errors`; the models perception source puts them into its results). A
lookup therefore never raises for the model's sake, and never returns a value the model did not give
except through the documented fallback.

Never blocking: with ``prefetch`` on, the models perception source calls :meth:`LLMRelevance.prefetch`
in its worker thread with every label of a view, so the tree's lookups for those labels are cache hits.
A label the prefetch did not see is asked in the tick that first needs it; that tick waits for the LLM
(at most the endpoint's timeout times its attempts).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sqlite3
import threading
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from semexp_bt.core.relevance import FloatArray, LexicalRelevance, RelevanceScorer, instruction_target
from semexp_bt.perception.adapters.calls import ModelCall
from semexp_bt.perception.adapters.chat import (
    ChatReply,
    ChatRequest,
    ChatTransport,
    ReplyError,
    ask,
    check_schema,
    reply_json,
    schema_validator,
)
from semexp_bt.perception.model_config import LLMConfig
from semexp_bt.perception.prompts import RELEVANCE, PromptTemplate, load_prompt

#: At most this many model errors wait for the record; older ones are dropped (and counted).
MAX_PENDING_ERRORS = 100


def parse_relevance_scores(reply: ChatReply, *, n_labels: int, schema: dict[str, Any]) -> list[float]:
    """The relevance of labels ``1..n_labels`` from a reply, in label order.

    Raises:
        ReplyError: not JSON, breaks the schema, an id missing, repeated or out of range, or a
            relevance outside [0, 1].
    """
    value = reply_json(reply)
    check_schema(value, schema)
    by_id: dict[int, float] = {}
    for i, entry in enumerate(cast(dict[str, Any], value)["scores"]):
        label_id, relevance = int(entry["id"]), float(entry["relevance"])
        if not 1 <= label_id <= n_labels:
            raise ReplyError(f"scores[{i}].id {label_id} names no label (1..{n_labels})")
        if label_id in by_id:
            raise ReplyError(f"scores[{i}].id {label_id} is scored twice")
        if not (math.isfinite(relevance) and 0.0 <= relevance <= 1.0):
            raise ReplyError(f"scores[{i}].relevance {relevance!r} is outside [0, 1]")
        by_id[label_id] = relevance
    missing = [i for i in range(1, n_labels + 1) if i not in by_id]
    if missing:
        raise ReplyError(f"no score for label id(s) {missing[:10]} of {n_labels}")
    return [by_id[i] for i in range(1, n_labels + 1)]


class RelevanceDiskCache:
    """Relevance values in SQLite, keyed by (model, prompt version, instruction, label). Thread-safe;
    several processes (a sweep's workers) may share one file.

    Raises:
        sqlite3.Error, OSError: when the file cannot be created or opened.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._db = sqlite3.connect(str(path), timeout=10.0, check_same_thread=False)
        with self._db:
            self._db.execute(
                "CREATE TABLE IF NOT EXISTS relevance (model TEXT NOT NULL, prompt_version TEXT NOT NULL,"
                " instruction TEXT NOT NULL, label TEXT NOT NULL, relevance REAL NOT NULL,"
                " PRIMARY KEY (model, prompt_version, instruction, label))"
            )

    def get(
        self, model: str, prompt_version: str, instruction: str, labels: Sequence[str]
    ) -> dict[str, float]:
        """The cached values among ``labels``."""
        found: dict[str, float] = {}
        with self._lock:
            for label in labels:
                row = self._db.execute(
                    "SELECT relevance FROM relevance WHERE model=? AND prompt_version=? AND instruction=?"
                    " AND label=?",
                    (model, prompt_version, instruction, label),
                ).fetchone()
                if row is not None and math.isfinite(row[0]) and 0.0 <= row[0] <= 1.0:
                    found[label] = float(row[0])
        return found

    def put(self, model: str, prompt_version: str, instruction: str, values: dict[str, float]) -> None:
        with self._lock, self._db:
            self._db.executemany(
                "INSERT OR REPLACE INTO relevance VALUES (?, ?, ?, ?, ?)",
                [(model, prompt_version, instruction, label, value) for label, value in values.items()],
            )

    def close(self) -> None:
        with self._lock:
            self._db.close()


@dataclass
class RelevanceStats:
    """Where lookups were answered (the cache's hit rate is ``1 - asked / lookups``).

    Attributes:
        lookups: labels looked up (a label repeated within one call counts once).
        memory_hits: answered from the in-process cache.
        disk_hits: answered from the on-disk cache.
        asked: labels sent to the LLM.
        requests: requests sent (batches).
        fallbacks: labels the fallback scorer answered because their batch failed.
    """

    lookups: int = 0
    memory_hits: int = 0
    disk_hits: int = 0
    asked: int = 0
    requests: int = 0
    fallbacks: int = 0

    @property
    def hit_rate(self) -> float:
        """Share of lookups answered without asking the LLM (0 when nothing was looked up)."""
        return 0.0 if self.lookups == 0 else 1.0 - self.asked / self.lookups


class LLMRelevance:
    """S_LLM from a chat model, batched, cached in memory and on disk (see the module docstring).

    Args:
        config: the endpoint, the batch size and the cache path.
        transport: what sends requests (an ``OpenAIChatClient`` in production).
        fallback: scores a failed batch (default: :class:`LexicalRelevance`).
        prompt: the prompt (default: ``relevance_v1``).
    """

    def __init__(
        self,
        config: LLMConfig,
        transport: ChatTransport,
        *,
        fallback: RelevanceScorer | None = None,
        prompt: PromptTemplate | None = None,
    ) -> None:
        self.config = config
        self.transport = transport
        self.fallback: RelevanceScorer = fallback if fallback is not None else LexicalRelevance()
        self.prompt = prompt if prompt is not None else load_prompt(RELEVANCE)
        schema_validator(self.prompt.schema)  # imports the validator now, not in the first lookup
        self.stats = RelevanceStats()
        self.calls: deque[ModelCall] = deque(maxlen=MAX_PENDING_ERRORS)
        """The last requests' accounts (reply, error, latency), newest last."""
        self._memory: dict[tuple[str, str], float] = {}
        self._errors: deque[str] = deque(maxlen=MAX_PENDING_ERRORS)
        self._lock = threading.Lock()
        self._request_lock = threading.Lock()
        self._disk: RelevanceDiskCache | None = None
        self._disk_opened = not config.cache_path

    # ------------------------------------------------------------------ RelevanceScorer

    def score(self, *, instruction: str, label: str) -> float:
        return float(self.scores(instruction=instruction, labels=(label,))[0])

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        values, _ = self._scores(instruction, labels)
        return np.array([values[label] for label in labels], dtype=float)

    # ------------------------------------------------------------------ the rest

    def prefetch(self, *, instruction: str, labels: Sequence[str]) -> tuple[ModelCall, ...]:
        """Score ``labels`` now so that later lookups hit the cache; the requests' accounts."""
        _, calls = self._scores(instruction, labels)
        return calls

    def drain_errors(self) -> list[str]:
        """The model errors queued since the last drain (oldest first), for the record."""
        with self._lock:
            errors = list(self._errors)
            self._errors.clear()
        return errors

    def request(self, *, instruction: str, labels: Sequence[str]) -> ChatRequest:
        """The exact request for one batch."""
        lines = "\n".join(f"{i}. {json.dumps(label)}" for i, label in enumerate(labels, start=1))
        text = self.prompt.render(
            instruction=json.dumps(instruction),
            target=json.dumps(instruction_target(instruction)),
            labels=lines,
        )
        return ChatRequest(prompt=text, schema=self.prompt.schema, schema_name=self.prompt.name)

    def close(self) -> None:
        if self._disk is not None:
            self._disk.close()

    def _disk_cache(self) -> RelevanceDiskCache | None:
        if not self._disk_opened:
            self._disk_opened = True
            path = Path(self.config.cache_path).expanduser()
            try:
                self._disk = RelevanceDiskCache(path)
            except (OSError, sqlite3.Error) as exc:
                self._queue_error(f"llm relevance cache {path} unusable, running without it: {exc}")
        return self._disk

    def _queue_error(self, message: str) -> None:
        with self._lock:
            self._errors.append(message)

    def _scores(
        self, instruction: str, labels: Sequence[str]
    ) -> tuple[dict[str, float], tuple[ModelCall, ...]]:
        unique = list(dict.fromkeys(labels))
        model, version = self.transport.model, self.prompt.version
        with self._lock:
            values = {
                lb: self._memory[(instruction, lb)] for lb in unique if (instruction, lb) in self._memory
            }
            self.stats.lookups += len(unique)
            self.stats.memory_hits += len(values)
        missing = [lb for lb in unique if lb not in values]
        calls: list[ModelCall] = []
        if missing:
            # One request at a time: a tick's lookup waits for a prefetch of the same labels instead of
            # asking for them again.
            with self._request_lock:
                with self._lock:
                    late = {
                        lb: self._memory[(instruction, lb)]
                        for lb in missing
                        if (instruction, lb) in self._memory
                    }
                    self.stats.memory_hits += len(late)
                values.update(late)
                missing = [lb for lb in missing if lb not in late]
                disk = self._disk_cache() if missing else None
                if disk is not None:
                    try:
                        found = disk.get(model, version, instruction, missing)
                    except sqlite3.Error as exc:
                        self._queue_error(f"llm relevance cache read failed: {exc}")
                        found = {}
                    with self._lock:
                        self.stats.disk_hits += len(found)
                        self._memory.update({(instruction, lb): v for lb, v in found.items()})
                    values.update(found)
                    missing = [lb for lb in missing if lb not in found]
                for start in range(0, len(missing), self.config.batch_size):
                    batch = missing[start : start + self.config.batch_size]
                    fresh, call = self._ask(instruction, batch)
                    calls.append(call)
                    if fresh is None:
                        fallback = np.asarray(self.fallback.scores(instruction=instruction, labels=batch))
                        values.update(zip(batch, (float(v) for v in fallback), strict=True))
                        with self._lock:
                            self.stats.fallbacks += len(batch)
                        continue
                    values.update(fresh)
                    with self._lock:
                        self._memory.update({(instruction, lb): v for lb, v in fresh.items()})
                    if disk is not None:
                        try:
                            disk.put(model, version, instruction, fresh)
                        except sqlite3.Error as exc:
                            self._queue_error(f"llm relevance cache write failed: {exc}")
        return values, tuple(calls)

    def _ask(self, instruction: str, batch: list[str]) -> tuple[dict[str, float] | None, ModelCall]:
        with self._lock:
            self.stats.asked += len(batch)
            self.stats.requests += 1
        start = time.perf_counter()
        try:
            scores, call = ask(
                "llm",
                self.transport,
                lambda: self.request(instruction=instruction, labels=batch),
                lambda reply: parse_relevance_scores(reply, n_labels=len(batch), schema=self.prompt.schema),
            )
        except Exception as exc:
            scores, call = (
                None,
                ModelCall(
                    source="llm",
                    model=self.transport.model,
                    ok=False,
                    error=f"llm {self.transport.model}: unexpected {type(exc).__name__}: {exc}",
                    latency_s=time.perf_counter() - start,
                ),
            )
        if scores is None:
            note = f" ({len(batch)} labels scored by the {type(self.fallback).__name__} fallback)"
            call = dataclasses.replace(call, error=f"{call.error}{note}")
            self._queue_error(str(call.error))
        self.calls.append(call)
        return (None if scores is None else dict(zip(batch, scores, strict=True))), call
