"""Instruction understanding (semexp_bt.core.instruction, semexp_bt.core.language)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from semexp_bt.core.instruction import instruction_target, parse_instruction
from semexp_bt.core.language import canonical_tokens, correct_spelling
from semexp_bt.core.types import InvalidInputError


@pytest.mark.parametrize(
    ("instruction", "phrase"),
    [
        ("find the fire extinguisher", "fire extinguisher"),
        ("Where is the fire extinguisher?", "fire extinguisher"),
        ("can you look for the green dustbin for me", "green dustbin"),
        ("I need the bucket rack", "bucket rack"),
        ("Could you please go to the bus stop, thanks!", "bus stop"),
        ("look for black chairs", "black chair"),
        ("LOOK FOR BUCKET SHELVES!!!", "bucket shelf"),
        ("where can I find a carton box", "carton box"),
        ("is there a red trash can here?", "red trash can"),
        ("find the bin that is green", "green bin"),
        ("find the chair which is gray", "grey chair"),
        ("find the big bus station", "big bus station"),
        ("find the box next to the door", "box"),
        ("the traffic sign near the lamp post", "traffic sign"),
    ],
)
def test_object_phrase(instruction: str, phrase: str) -> None:
    assert instruction_target(instruction) == phrase


def test_attributes_and_relation_are_kept_apart() -> None:
    parsed = parse_instruction("Where is the small bin that is green, next to the hedge?")
    print(parsed)
    assert parsed.object_phrase == "small green bin"
    assert parsed.noun_phrase == "bin"
    assert parsed.colours == ("green",) and parsed.sizes == ("small",)
    assert parsed.relation == "next to the hedge"


@pytest.mark.parametrize(
    ("typed", "meant"),
    [("extingusher", "extinguisher"), ("trafic", "traffic"), ("staton", "station"), ("blak", "black"),
     ("boxx", "box"), ("shelv", "shelf"), ("bim", "bin"), ("chiar", "chair")],
)  # fmt: skip
def test_one_edit_misspellings_are_corrected(typed: str, meant: str) -> None:
    assert correct_spelling(typed) == meant
    assert parse_instruction(f"find the {typed}").corrections == ((typed, meant),)


def test_ambiguous_unknown_and_known_words_are_left_alone() -> None:
    assert correct_spelling("cat") == "cat"  # one edit from both "car" and "cart": not guessed
    assert correct_spelling("elephant") == "elephant"  # nothing known nearby
    assert correct_spelling("bins") == "bins"  # a plural of a known word
    assert correct_spelling("ox") == "ox"  # too short to correct


def test_synonyms_plurals_and_colour_spellings_share_tokens() -> None:
    assert canonical_tokens("robot dogs") == canonical_tokens("quadruped robot")
    assert canonical_tokens("road sign") == canonical_tokens("traffic sign")
    assert canonical_tokens("gray chair") == canonical_tokens("grey chair")
    assert canonical_tokens("shelf with buckets")[1] == "shelf"


def test_an_instruction_naming_nothing_known_still_parses() -> None:
    assert instruction_target("find the zorblax") == "zorblax"


def test_an_instruction_without_words_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="at least one word"):
        parse_instruction(" ?! ")


@given(st.text(max_size=80))
def test_any_text_parses_or_is_refused_cleanly(text: str) -> None:
    try:
        parsed = parse_instruction(text)
    except InvalidInputError:
        return
    assert parsed.object_phrase
    assert parsed.object_phrase == parsed.object_phrase.lower()
