"""Semantic relevance S_LLM between an instruction and a node label (paper Sec. III-E, Eq. 9).

The paper asks a language model for a normalised relevance score S in [0, 1] between the instruction
and each candidate node's label. This module defines the interface every scorer implements
(:class:`RelevanceScorer`) and the scorers that need no neural network:

- :class:`LexicalRelevance`: a deterministic token-overlap score over the object lexicon of
  :mod:`semexp_bt.core.language` (plurals, synonyms) with an attribute-conflict penalty;
- :class:`HybridRelevance`: the larger of a learned scorer's value and the lexical one;
- :class:`CachedRelevance`: a per-(instruction, label) cache in front of any scorer (the decision asks
  for the same pairs every tick).

The sentence-embedding scorer lives in ``semexp_bt.perception.embedding_relevance`` because it needs
torch, the paper's LLM scorer in ``semexp_bt.perception.llm_relevance`` because it talks to a model
server, and the instruction parser in :mod:`semexp_bt.core.instruction`. This is a core module (standard
library and numpy only). :data:`NAMES_OBJECT_RELEVANCE` is the one threshold at which a label names the
instructed object.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from semexp_bt.core.instruction import instruction_target
from semexp_bt.core.language import NON_SUBSECTIVE_MODIFIERS, attribute_words, canonical_tokens, words_of
from semexp_bt.core.types import InvalidInputError

FloatArray = npt.NDArray[np.float64]


@runtime_checkable
class RelevanceScorer(Protocol):
    """Scores how relevant a memory node's label is to the instruction.

    Implementations must be deterministic for a fixed (instruction, label) and return finite values
    in [0, 1]. ``instruction`` is the user's sentence ("find the fire extinguisher"); scorers extract
    the object phrase themselves (see :func:`instruction_target`).
    """

    def score(self, *, instruction: str, label: str) -> float:
        """Relevance of one label to the instruction, in [0, 1]."""
        ...

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        """Relevance of each label, as a float array with ``len(labels)`` entries in [0, 1]."""
        ...


#: Relevance at which a label names the instructed object itself (its name, a synonym, the same thing
#: with compatible attributes), not merely something like it ("shelf" for "bucket shelf"). The one
#: threshold every such judgment uses: confirmation, the arbitration's alignment, the label majority,
#: the memory's target nodes.
NAMES_OBJECT_RELEVANCE = 0.9
#: Relevance at which a label is related to the instruction (a close class, a partial name).
RELATED_RELEVANCE = 0.6

#: Weight of a phrase's head noun (its last word before any preposition) in the overlap score; other
#: words weigh 1. A shared head says "same kind of object", a shared modifier only "similar".
HEAD_WEIGHT = 2.0
#: Factor applied when both phrases name colours (or sizes) and share none ("grey chair" vs "black chair").
ATTRIBUTE_CONFLICT_FACTOR = 0.75


def _weights(tokens: tuple[str, ...], head: str | None) -> dict[str, float]:
    return {t: (HEAD_WEIGHT if t == head else 1.0) for t in tokens}


def attributes_conflict(a: str, b: str) -> bool:
    """Whether two phrases both name a colour (or both a size) and share none ("grey chair", "black chair")."""
    colours_a, sizes_a = attribute_words(words_of(a))
    colours_b, sizes_b = attribute_words(words_of(b))
    return bool(
        (colours_a and colours_b and not set(colours_a) & set(colours_b))
        or (sizes_a and sizes_b and not set(sizes_a) & set(sizes_b))
    )


class LexicalRelevance:
    """Deterministic token-overlap relevance; needs no model.

    The instruction is reduced to its object phrase (:func:`instruction_target`); both phrases are
    normalised by :func:`canonical_tokens`. The score is a weighted Dice overlap, the head noun
    weighing :data:`HEAD_WEIGHT` and other words 1::

        S = sum_{t in A & B} (w_A(t) + w_B(t)) / (sum_A w + sum_B w)

    times :data:`ATTRIBUTE_CONFLICT_FACTOR` when both phrases name a colour (or a size) and none in
    common. It is 1 exactly when both phrases reduce to the same tokens and head, 0 when they share no
    token. Names are read with the lexicon of :mod:`semexp_bt.core.language` ("road sign" and "traffic
    sign" are one concept). A label that :func:`narrows` the instruction's object (a kind of it: "black
    office chair" for "the black chair") scores at least :data:`NAMES_OBJECT_RELEVANCE`: it names it,
    where the overlap alone (0.86) would call it only related and count a VLM's own alias against the
    object it names (docs/decision.md, "A narrower name names the object").
    """

    def score(self, *, instruction: str, label: str) -> float:
        return float(self.scores(instruction=instruction, labels=(label,))[0])

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        target = instruction_target(instruction)
        return np.array(
            [
                max(
                    phrase_similarity(target, label),
                    NAMES_OBJECT_RELEVANCE if narrows(target, label) else 0.0,
                )
                for label in labels
            ],
            dtype=float,
        )


def _without_unmatched_attributes(
    tokens_a: tuple[str, ...], tokens_b: tuple[str, ...], head_a: str | None, head_b: str | None
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Drop the colour (or size) words of a phrase when the other phrase states no colour (or size).

    An attribute only one side states neither agrees nor conflicts: a detector's label "fire
    extinguisher" says nothing of colour, so "the red fire extinguisher" names it; "find the chair" names a
    "black chair". When both sides state one, it stays and a mismatch is a conflict.
    """
    colours_a, sizes_a = attribute_words(tokens_a)
    colours_b, sizes_b = attribute_words(tokens_b)
    drop_a = (set() if colours_b else set(colours_a)) | (set() if sizes_b else set(sizes_a))
    drop_b = (set() if colours_a else set(colours_b)) | (set() if sizes_a else set(sizes_b))

    def kept(tokens: tuple[str, ...], drop: set[str], head: str | None) -> tuple[str, ...]:
        # The head stays: a phrase that is only an attribute ("the red one") keeps something to compare.
        return tuple(t for t in tokens if t == head or _attribute_key(t) not in drop)

    return kept(tokens_a, drop_a, head_a), kept(tokens_b, drop_b, head_b)


def _attribute_key(token: str) -> str:
    colours, sizes = attribute_words((token,))
    return colours[0] if colours else sizes[0] if sizes else ""


def phrase_similarity(a: str, b: str) -> float:
    """The lexical relevance of two object phrases (see :class:`LexicalRelevance`), symmetric, in [0, 1]."""
    tokens_a, head_a = canonical_tokens(a)
    tokens_b, head_b = canonical_tokens(b)
    if not tokens_a or not tokens_b:
        return 0.0
    tokens_a, tokens_b = _without_unmatched_attributes(tokens_a, tokens_b, head_a, head_b)
    wa = _weights(tokens_a, head_a)
    wb = _weights(tokens_b, head_b)
    shared = wa.keys() & wb.keys()
    value = sum(wa[t] + wb[t] for t in shared) / (sum(wa.values()) + sum(wb.values()))
    if attributes_conflict(a, b):
        value *= ATTRIBUTE_CONFLICT_FACTOR
    return float(min(max(value, 0.0), 1.0))


def narrows(target: str, label: str) -> bool:
    """Whether ``label`` is ``target`` with more modifiers, none of them non-subsective, and the same head:
    such a label names a kind of the target, so it names the target.

    One way only: "black office chair" narrows "black chair" (a black office chair is a black chair), but
    "shelf" does not narrow "bucket shelf" (a shelf need not be a bucket shelf), and "toy robot dog" does
    not narrow "robot dog" (a toy is no robot dog: "toy" is in
    :data:`~semexp_bt.core.language.NON_SUBSECTIVE_MODIFIERS`). Attributes that only the label states are
    left out first, as :func:`phrase_similarity` does, and conflicting ones never narrow.
    """
    tokens_t, head_t = canonical_tokens(target)
    tokens_l, head_l = canonical_tokens(label)
    if head_t is None or head_t != head_l or attributes_conflict(target, label):
        return False
    tokens_t, tokens_l = _without_unmatched_attributes(tokens_t, tokens_l, head_t, head_l)
    extra = set(tokens_l) - set(tokens_t)
    return set(tokens_t) <= set(tokens_l) and not extra & NON_SUBSECTIVE_MODIFIERS


class HybridRelevance:
    """The larger of a learned scorer's relevance and the lexical one, both attribute-aware.

    A small sentence embedding knows that "bin" and "trash can" are alike but misses common synonyms
    ("robot dog" and "quadruped robot": 0.19 with all-MiniLM-L6-v2); the lexicon knows those but nothing
    outside it. The maximum keeps what either knows. Both sides agree that two phrases naming different
    colours (or sizes) are different things: the learned score is scaled by
    :data:`ATTRIBUTE_CONFLICT_FACTOR` then, as the lexical one already is.

    Args:
        learned: any scorer (the sentence embedding, an LLM).
        lexical: the lexical scorer.
    """

    def __init__(self, learned: RelevanceScorer, lexical: RelevanceScorer | None = None) -> None:
        self.learned = learned
        self.lexical = lexical if lexical is not None else LexicalRelevance()

    def score(self, *, instruction: str, label: str) -> float:
        return float(self.scores(instruction=instruction, labels=(label,))[0])

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        learned = np.asarray(self.learned.scores(instruction=instruction, labels=labels), dtype=float)
        target = instruction_target(instruction)
        conflict = np.array([attributes_conflict(target, label) for label in labels], dtype=bool)
        learned = np.where(conflict, learned * ATTRIBUTE_CONFLICT_FACTOR, learned)
        lexical = np.asarray(self.lexical.scores(instruction=instruction, labels=labels), dtype=float)
        return np.maximum(learned, lexical)


# --------------------------------------------------------------------------------------------------
# Cache
# --------------------------------------------------------------------------------------------------


class CachedRelevance:
    """A per-(instruction, label) cache in front of any :class:`RelevanceScorer`.

    Every value the inner scorer returns is checked (finite, in [0, 1]) once, when it enters the cache.
    The cache is thread-safe: perception adapters may run in worker threads.

    Attributes:
        scorer: the wrapped scorer.
        hits: lookups answered from the cache.
        misses: lookups that had to ask the inner scorer.
    """

    def __init__(self, scorer: RelevanceScorer) -> None:
        self.scorer = scorer
        self.hits = 0
        self.misses = 0
        self._cache: dict[tuple[str, str], float] = {}
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._cache)

    def clear(self) -> None:
        """Forget every cached value and reset the counters."""
        with self._lock:
            self._cache.clear()
            self.hits = 0
            self.misses = 0

    def score(self, *, instruction: str, label: str) -> float:
        return float(self.scores(instruction=instruction, labels=(label,))[0])

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        cache = self._cache
        with self._lock:
            values = [cache.get((instruction, label)) for label in labels]
        missing = list(dict.fromkeys(lb for lb, v in zip(labels, values, strict=True) if v is None))
        if missing:
            fresh = np.asarray(self.scorer.scores(instruction=instruction, labels=missing), dtype=float)
            if fresh.shape != (len(missing),):
                raise InvalidInputError(
                    f"relevance scorer {type(self.scorer).__name__} returned shape {fresh.shape} "
                    f"for {len(missing)} labels"
                )
            for label, value in zip(missing, fresh, strict=True):
                if not (np.isfinite(value) and 0.0 <= value <= 1.0):
                    raise InvalidInputError(
                        f"relevance scorer {type(self.scorer).__name__} returned {value!r} for "
                        f"label {label!r}; relevance must be finite and in [0, 1]"
                    )
            with self._lock:
                for label, value in zip(missing, fresh, strict=True):
                    cache[(instruction, label)] = float(value)
                values = [cache[(instruction, label)] for label in labels]
        n_missing = len(missing)
        with self._lock:
            self.misses += n_missing
            self.hits += len(labels) - n_missing
        return np.array(values, dtype=float)
