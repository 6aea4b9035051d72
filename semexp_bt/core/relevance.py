"""Semantic relevance S_LLM between an instruction and a node label (paper Sec. III-E, Eq. 9).

The paper asks a language model for a normalised relevance score S in [0, 1] between the instruction
and each candidate node's label. This module defines the interface every scorer implements
(:class:`RelevanceScorer`) and the scorers that need no neural network:

- :class:`LexicalRelevance`: a deterministic token-overlap score with plural stripping, a small synonym
  table for the product's object vocabulary and a colour-conflict penalty;
- :class:`CachedRelevance`: a per-(instruction, label) cache in front of any scorer (the decision asks
  for the same pairs every tick).

The sentence-embedding scorer (the product default) lives in ``semexp_bt.perception.embedding_relevance``
because it needs torch, and the paper's LLM scorer in ``semexp_bt.perception.llm_relevance`` because it
talks to a model server; this is a core module (standard library and numpy only).
"""

from __future__ import annotations

import re
import threading
from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

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


# --------------------------------------------------------------------------------------------------
# Instruction parsing
# --------------------------------------------------------------------------------------------------

#: Leading phrases that carry the request, not the object. Matched as whole words, longest first,
#: repeatedly (so "please can you go to" is stripped in three steps).
INSTRUCTION_PREFIXES: tuple[str, ...] = (
    "i want you to",
    "i need you to",
    "i would like you to",
    "explore to find",
    "try to find",
    "can you",
    "could you",
    "would you",
    "will you",
    "please",
    "hey robot",
    "ok robot",
    "hey",
    "now",
    "then",
    "and",
    "go and",
    "find",
    "locate",
    "search for",
    "look for",
    "seek",
    "go to",
    "go towards",
    "go toward",
    "navigate to",
    "move to",
    "walk to",
    "head to",
    "get to",
    "bring me to",
    "take me to",
    "lead me to",
    "where is",
    "where s",
    "approach",
    "reach",
)

#: Determiners dropped in front of the object phrase.
DETERMINERS: frozenset[str] = frozenset({"the", "a", "an", "some", "any", "my", "that", "this", "our"})

#: Trailing courtesy phrases.
INSTRUCTION_SUFFIXES: tuple[str, ...] = ("thank you", "for me", "please", "thanks", "now")

#: Words that start a spatial or relative clause; the object phrase ends before the first of them.
CLAUSE_MARKERS: tuple[str, ...] = (
    "in front of",
    "next to",
    "close to",
    "near",
    "beside",
    "behind",
    "in",
    "on",
    "at",
    "under",
    "by",
    "that",
    "which",
    "located",
)

_NON_WORD = re.compile(r"[^a-z0-9]+")


def _normalise_text(text: str) -> list[str]:
    """Lower-case word tokens; anything that is not a letter or a digit separates words."""
    return [tok for tok in _NON_WORD.split(text.lower()) if tok]


def _phrase_tokens(phrases: Sequence[str]) -> list[tuple[str, ...]]:
    return sorted((tuple(p.split()) for p in phrases), key=len, reverse=True)


_PREFIX_TOKENS = _phrase_tokens(INSTRUCTION_PREFIXES)
_SUFFIX_TOKENS = _phrase_tokens(INSTRUCTION_SUFFIXES)
_CLAUSE_TOKENS = _phrase_tokens(CLAUSE_MARKERS)


def instruction_target(instruction: str) -> str:
    """Extract the object phrase from an instruction.

    The rule, applied to lower-cased word tokens (punctuation removed):

    1. strip leading request phrases (:data:`INSTRUCTION_PREFIXES`: "please", "can you", "find",
       "go to", "look for", ...) and determiners (:data:`DETERMINERS`), repeatedly;
    2. strip trailing courtesy phrases (:data:`INSTRUCTION_SUFFIXES`: "please", "for me", ...);
    3. cut at the first spatial or relative clause marker (:data:`CLAUSE_MARKERS`: "near", "next to",
       "in", "on", "that", ...), but never at the first word, so the object phrase is what precedes it.

    If nothing is left (the instruction was only request words) the normalised instruction is
    returned, so a scorer always has something to compare.

    Examples:
        >>> instruction_target("Find the fire extinguisher.")
        'fire extinguisher'
        >>> instruction_target("go to the black chair please")
        'black chair'
        >>> instruction_target("look for a carton box next to the door")
        'carton box'

    Raises:
        InvalidInputError: if the instruction has no words.
    """
    tokens = _normalise_text(instruction)
    if not tokens:
        raise InvalidInputError(f"instruction must contain at least one word, got {instruction!r}")
    words = list(tokens)
    changed = True
    while changed and words:
        changed = False
        if words[0] in DETERMINERS:
            words.pop(0)
            changed = True
            continue
        for phrase in _PREFIX_TOKENS:
            if tuple(words[: len(phrase)]) == phrase:
                del words[: len(phrase)]
                changed = True
                break
    changed = True
    while changed and words:
        changed = False
        for phrase in _SUFFIX_TOKENS:
            if len(words) > len(phrase) and tuple(words[-len(phrase) :]) == phrase:
                del words[-len(phrase) :]
                changed = True
                break
    for i in range(1, len(words)):
        if any(tuple(words[i : i + len(m)]) == m for m in _CLAUSE_TOKENS):
            words = words[:i]
            break
    return " ".join(words) if words else " ".join(tokens)


# --------------------------------------------------------------------------------------------------
# Lexical relevance
# --------------------------------------------------------------------------------------------------

#: Plurals that the suffix rules below would get wrong.
IRREGULAR_SINGULARS: dict[str, str] = {
    "shelves": "shelf",
    "knives": "knife",
    "leaves": "leaf",
    "buses": "bus",
    "people": "person",
    "children": "child",
    "feet": "foot",
}

#: Synonym table for the product's object vocabulary: every phrase maps to one concept token. Phrases
#: are matched after plural stripping, longest first. A concept token joins a multi-word phrase with
#: "_" so it counts as one word (and as the head of the phrase).
SYNONYMS: dict[str, str] = {
    "fire extinguisher": "extinguisher",
    "extinguisher": "extinguisher",
    "trash can": "bin",
    "trash bin": "bin",
    "garbage can": "bin",
    "garbage bin": "bin",
    "waste bin": "bin",
    "rubbish bin": "bin",
    "litter bin": "bin",
    "recycling bin": "bin",
    "dustbin": "bin",
    "wastebasket": "bin",
    "bin": "bin",
    "traffic sign": "sign",
    "road sign": "sign",
    "street sign": "sign",
    "signpost": "sign",
    "sign": "sign",
    "trolley": "cart",
    "handcart": "cart",
    "cart": "cart",
    "robot dog": "quadruped_robot",
    "robotic dog": "quadruped_robot",
    "quadruped robot": "quadruped_robot",
    "legged robot": "quadruped_robot",
    "quadruped": "quadruped_robot",
    "bus stop": "bus_stop",
    "bus station": "bus_stop",
    "bus shelter": "bus_stop",
    "cardboard box": "box",
    "carton box": "box",
    "carton": "box",
    "box": "box",
    "couch": "sofa",
    "sofa": "sofa",
    "pail": "bucket",
    "rack": "shelf",
    "shelving": "shelf",
    "gray": "grey",
}

#: Colour words: two phrases that both name a colour, and no colour in common, conflict.
COLOURS: frozenset[str] = frozenset(
    {
        "black",
        "white",
        "grey",
        "red",
        "green",
        "blue",
        "yellow",
        "orange",
        "purple",
        "pink",
        "brown",
        "silver",
        "gold",
        "beige",
        "cyan",
        "magenta",
    }
)

#: Words that carry no object identity.
STOPWORDS: frozenset[str] = frozenset(
    {"the", "a", "an", "some", "of", "with", "for", "and", "on", "in", "to"}
)

#: Prepositions that end the head noun phrase ("shelf with buckets": the head is "shelf").
HEAD_BREAKERS: frozenset[str] = frozenset({"of", "with", "for", "on", "in"})

#: Weight of a phrase's head noun (its last word before any preposition) in the overlap score; other
#: words weigh 1. A shared head says "same kind of object", a shared modifier only "similar".
HEAD_WEIGHT = 2.0

#: Factor applied when both phrases name colours and share none ("grey chair" vs "black chair").
COLOUR_CONFLICT_FACTOR = 0.75

_SYNONYM_TOKENS = sorted(((tuple(k.split()), v) for k, v in SYNONYMS.items()), key=lambda kv: -len(kv[0]))


def singularise(word: str) -> str:
    """Strip an English plural with a few suffix rules (documented in ``docs/decision.md``).

    Words of three letters or fewer and words ending in "ss", "us" or "is" are kept as they are.
    """
    if word in IRREGULAR_SINGULARS:
        return IRREGULAR_SINGULARS[word]
    if len(word) <= 3 or word.endswith(("ss", "us", "is")):
        return word
    if word.endswith("ies") and len(word) > 4:
        return word[:-3] + "y"
    if word.endswith(("xes", "ches", "shes", "zes")):
        return word[:-2]
    if word.endswith("s"):
        return word[:-1]
    return word


def canonical_tokens(phrase: str) -> tuple[tuple[str, ...], str | None]:
    """Normalise a phrase into concept tokens and its head.

    Steps: lower-case word tokens, plural stripping, synonym phrases replaced by their concept token
    (longest match first), stopwords dropped. The head is the last concept token before the first
    preposition in :data:`HEAD_BREAKERS`.

    Returns:
        ``(tokens, head)``; ``head`` is None when the phrase has no content word.
    """
    words = [singularise(w) for w in _normalise_text(phrase)]
    concepts: list[str] = []
    i = 0
    while i < len(words):
        for key, concept in _SYNONYM_TOKENS:
            if tuple(words[i : i + len(key)]) == key:
                concepts.append(concept)
                i += len(key)
                break
        else:
            concepts.append(words[i])
            i += 1
    head: str | None = None
    for word in concepts:
        if word in HEAD_BREAKERS and head is not None:
            break
        if word not in STOPWORDS:
            head = word
    tokens = tuple(dict.fromkeys(w for w in concepts if w not in STOPWORDS))
    return tokens, head


def _weights(tokens: tuple[str, ...], head: str | None) -> dict[str, float]:
    return {t: (HEAD_WEIGHT if t == head else 1.0) for t in tokens}


class LexicalRelevance:
    """Deterministic token-overlap relevance; needs no model.

    The instruction is reduced to its object phrase (:func:`instruction_target`); both phrases are
    normalised by :func:`canonical_tokens`. The score is a weighted Dice overlap, the head noun
    weighing :data:`HEAD_WEIGHT` and other words 1::

        S = sum_{t in A & B} (w_A(t) + w_B(t)) / (sum_A w + sum_B w)

    times :data:`COLOUR_CONFLICT_FACTOR` when both phrases name a colour and none in common. It is 1
    exactly when both phrases reduce to the same tokens and head, 0 when they share no token.
    """

    def score(self, *, instruction: str, label: str) -> float:
        target_tokens, target_head = canonical_tokens(instruction_target(instruction))
        return self._score_tokens(target_tokens, target_head, label)

    def scores(self, *, instruction: str, labels: Sequence[str]) -> FloatArray:
        target_tokens, target_head = canonical_tokens(instruction_target(instruction))
        return np.array([self._score_tokens(target_tokens, target_head, lb) for lb in labels], dtype=float)

    @staticmethod
    def _score_tokens(target_tokens: tuple[str, ...], target_head: str | None, label: str) -> float:
        label_tokens, label_head = canonical_tokens(label)
        if not target_tokens or not label_tokens:
            return 0.0
        wa = _weights(target_tokens, target_head)
        wb = _weights(label_tokens, label_head)
        shared = wa.keys() & wb.keys()
        value = sum(wa[t] + wb[t] for t in shared) / (sum(wa.values()) + sum(wb.values()))
        colours_a = COLOURS.intersection(target_tokens)
        colours_b = COLOURS.intersection(label_tokens)
        if colours_a and colours_b and not (colours_a & colours_b):
            value *= COLOUR_CONFLICT_FACTOR
        return float(min(max(value, 0.0), 1.0))


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
