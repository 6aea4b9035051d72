"""Instruction understanding: from the user's sentence to the object phrase the models are asked about.

"Where is the green garbage bin?", "can you look for the bin that is green for me", "Find the GREEN BIM!"
and "look for green bins next to the hedge" all ask for one thing: a green bin. :func:`parse_instruction`
reads request verbs and questions, articles, plurals, casing and punctuation, colour and size attributes
(in front of the noun or in a "that is green" clause), relative and spatial clauses (kept aside: the
executive cannot check them) and misspellings one edit from a known word (:mod:`semexp_bt.core.language`).
An instruction that names nothing a scene could hold still parses: finding nothing is the mission's
business, not the parser's.

This is a core module: standard library only.

Example:
    >>> parsed = parse_instruction("Where is the bin that is green, next to the hedge?")
    >>> parsed.object_phrase, parsed.colours, parsed.relation
    ('green bin', ('green',), 'next to the hedge')
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from semexp_bt.core.language import (
    COLOUR_VARIANTS,
    attribute_words,
    correct_spelling,
    is_attribute,
    known_words,
    singularise,
    words_of,
)
from semexp_bt.core.types import InvalidInputError

#: Leading phrases that carry the request, not the object. Matched as whole words, longest first,
#: repeatedly (so "please can you go to" is stripped in three steps).
INSTRUCTION_PREFIXES: tuple[str, ...] = (
    "i want you to", "i need you to", "i would like you to", "i d like you to", "explore to find",
    "try to find", "can you", "could you", "would you", "will you", "please", "hey robot", "ok robot",
    "hey", "now", "then", "and", "go and", "find", "locate", "search for", "look for", "looking for",
    "look around for", "seek", "go to", "go towards", "go toward", "navigate to", "move to", "walk to",
    "head to", "get to", "bring me to", "take me to", "lead me to", "show me", "where is", "where s",
    "where are", "where can i find", "do you see", "can you see", "have you seen", "is there",
    "are there", "i need", "i want", "i am looking for", "i m looking for", "help me find", "approach",
    "reach", "spot", "get",
)  # fmt: skip
#: Determiners dropped in front of the object phrase.
DETERMINERS: frozenset[str] = frozenset(
    {"the", "a", "an", "some", "any", "my", "that", "this", "our", "your"}
)
#: Trailing courtesy phrases.
INSTRUCTION_SUFFIXES: tuple[str, ...] = ("thank you", "for me", "please", "thanks", "now", "here")
#: Words that start a spatial or relative clause; the object phrase ends before the first of them.
CLAUSE_MARKERS: tuple[str, ...] = (
    "in front of", "next to", "close to", "near", "beside", "behind", "in", "on", "at", "under", "by",
    "that", "which", "located", "standing", "sitting", "left of", "right of", "opposite",
)  # fmt: skip
#: Words that introduce an attribute clause ("the bin that is green"): marker, then one of these.
ATTRIBUTE_CLAUSE_VERBS: frozenset[str] = frozenset({"is", "are", "s"})


@dataclass(frozen=True)
class ParsedInstruction:
    """What an instruction asks for.

    Attributes:
        text: the instruction as given.
        object_phrase: the object asked for, normalised: attributes first, singular, spelling corrected
            ("green bin"); the detector's text prompt and the relevance scorers' query.
        noun_phrase: the object phrase without its colour and size words ("bin").
        colours: colour words asked for ("grey" for "gray").
        sizes: sizes asked for (``large`` or ``small``).
        relation: the spatial or relative clause that followed the object ("next to the hedge"), or "".
        corrections: the ``(typed, corrected)`` words spelling correction changed.
    """

    text: str
    object_phrase: str
    noun_phrase: str
    colours: tuple[str, ...] = ()
    sizes: tuple[str, ...] = ()
    relation: str = ""
    corrections: tuple[tuple[str, str], ...] = ()


def _phrase_tokens(phrases: Sequence[str]) -> list[tuple[str, ...]]:
    return sorted((tuple(p.split()) for p in phrases), key=len, reverse=True)


_PREFIX_TOKENS = _phrase_tokens(INSTRUCTION_PREFIXES)
_SUFFIX_TOKENS = _phrase_tokens(INSTRUCTION_SUFFIXES)
_CLAUSE_TOKENS = _phrase_tokens(CLAUSE_MARKERS)
_REQUEST_WORDS = frozenset(w for phrase in (*INSTRUCTION_PREFIXES, *INSTRUCTION_SUFFIXES, *CLAUSE_MARKERS)
                           for w in phrase.split()) | DETERMINERS | ATTRIBUTE_CLAUSE_VERBS  # fmt: skip


def _strip_request(words: list[str]) -> list[str]:
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
    return words


def _split_clause(words: list[str]) -> tuple[list[str], list[str], list[str]]:
    """(object words, attribute words from a "that is green" clause, the relation clause's words)."""
    for i in range(1, len(words)):
        marker = next((m for m in _CLAUSE_TOKENS if tuple(words[i : i + len(m)]) == m), None)
        if marker is None:
            continue
        rest = words[i + len(marker) :]
        if marker[0] in ("that", "which") and rest and rest[0] in ATTRIBUTE_CLAUSE_VERBS:
            attributes = []
            j = 1
            while j < len(rest) and (is_attribute(rest[j]) or rest[j] in ("and", "in", "colour", "color")):
                if is_attribute(rest[j]):
                    attributes.append(rest[j])
                j += 1
            if attributes:
                tail = rest[j:]
                objects, more, relation = _split_clause([*words[:i], *tail]) if tail else (words[:i], [], [])
                return objects, attributes + more, relation
        return words[:i], [], words[i:]
    return words, [], []


def parse_instruction(instruction: str) -> ParsedInstruction:
    """Read an instruction (see the module docstring for what it understands).

    Raises:
        InvalidInputError: if the instruction has no words.
    """
    tokens = words_of(instruction)
    if not tokens:
        raise InvalidInputError(f"instruction must contain at least one word, got {instruction!r}")
    vocabulary = known_words() | _REQUEST_WORDS
    corrected = [correct_spelling(w, vocabulary) for w in tokens]
    corrections = tuple((a, b) for a, b in zip(tokens, corrected, strict=True) if a != b)
    words = _strip_request(list(corrected))
    objects, clause_attributes, relation = _split_clause(words)
    objects = [singularise(w) for w in objects] or [singularise(w) for w in corrected]
    attribute_list = [w for w in objects if is_attribute(w)] + clause_attributes
    colours, sizes = attribute_words(attribute_list)
    nouns = [w for w in objects if not is_attribute(w)]
    spoken_attributes = [COLOUR_VARIANTS.get(w, w) for w in attribute_list]
    phrase = " ".join(dict.fromkeys([*spoken_attributes, *nouns]))
    return ParsedInstruction(
        text=instruction,
        object_phrase=phrase,
        noun_phrase=" ".join(nouns) or phrase,
        colours=colours,
        sizes=sizes,
        relation=" ".join(relation),
        corrections=corrections,
    )


def instruction_target(instruction: str) -> str:
    """The object phrase of an instruction (:attr:`ParsedInstruction.object_phrase`).

    Examples:
        >>> instruction_target("Find the fire extinguisher.")
        'fire extinguisher'
        >>> instruction_target("go to the black chair please")
        'black chair'
        >>> instruction_target("look for a carton box next to the door")
        'carton box'
    """
    return parse_instruction(instruction).object_phrase
