"""How well a text prompt describes a scene object: the grade the emulated models respond to, and the
ground truth of which objects an instruction names.

A real open-vocabulary detector prompted with "robot dog" boxes a quadruped robot, and "black chair"
prefers the black chair to the grey one (GroundingDINO's phrase grounding scores every box against the
prompt's tokens). The emulator reproduces that with three grades, computed from data:

- ``match``: the prompt's noun phrase is one of the object's names (its label, its category or one of its
  ``aliases`` in the scene data, read with the lexicon of :mod:`semexp_bt.core.language`, so plurals and
  synonyms count), with colour and size words stripped from both, and the prompt's colours and sizes
  agree with the object's ``colour`` and ``size`` (an attribute the object does not state agrees). "Chair"
  matches a black chair; "black chair" matches it; "grey chair" does not.
- ``related``: the same noun with a conflicting attribute ("grey chair" for a black chair), a name one
  of whose pairs the data marks close (the scene's goal and its ``distractor`` objects, which the scene
  builder placed *because* they look alike, and :data:`GENERIC_CLOSE_LABELS`), or a lexical relevance of
  at least :data:`semexp_bt.core.relevance.RELATED_RELEVANCE` ("toy robot dog" for "robot dog").
- ``unrelated``: anything else.

The same grades are the episode's ground truth: the objects an instruction names (:func:`named_objects`)
are its ``match`` objects, so a success counts near any of them, whatever the wording, and never at a
distractor.

Example:
    >>> from semexp_bt.core.scene import SceneObject
    >>> chair = SceneObject(0, "c", "black chair", "chair", "box", (0, 0, 0.2), (0.2, 0.2, 0.2), colour="black")
    >>> [grade(chair, p).kind for p in ("the chair", "black chairs", "grey chair", "piano")]
    ['match', 'match', 'related', 'unrelated']
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

from semexp_bt.core.instruction import ParsedInstruction, parse_instruction
from semexp_bt.core.language import canonical_tokens, is_attribute, words_of
from semexp_bt.core.relevance import RELATED_RELEVANCE, phrase_similarity
from semexp_bt.core.scene import SceneObject, SceneSpec

#: Pairs of names that open-vocabulary detectors and VLMs confuse regardless of the scene.
GENERIC_CLOSE_LABELS: tuple[tuple[str, str], ...] = (
    ("fire extinguisher", "red trash can"),
    ("fire extinguisher", "red bottle"),
    ("fire extinguisher", "fire hydrant"),
    ("fire extinguisher", "gas cylinder"),
    ("trash can", "recycling bin"),
    ("chair", "stool"),
    ("potted plant", "bush"),
    ("stop sign", "red sign"),
    ("traffic sign", "advertising board"),
    ("traffic cone", "orange bucket"),
    ("cardboard box", "wooden crate"),
    ("cardboard box", "plastic crate"),
    ("backpack", "handbag"),
    ("cabinet", "locker"),
    ("cart", "hand truck"),
    ("bus station", "kiosk"),
    ("quadruped robot", "toy robot dog"),
)

Grade = Literal["match", "related", "unrelated"]


@dataclass(frozen=True)
class PromptGrade:
    """How well a prompt describes one object.

    Attributes:
        kind: ``match``, ``related`` or ``unrelated`` (see the module docstring).
        relevance: the lexical relevance of the prompt to the object's closest name, in [0, 1].
    """

    kind: Grade
    relevance: float


NounKey = tuple[frozenset[str], str | None]


@functools.lru_cache(maxsize=4096)
def _noun_key(phrase: str) -> NounKey:
    """A phrase's concept tokens without colour and size words, and its head: equal keys, same noun."""
    tokens, head = canonical_tokens(" ".join(w for w in words_of(phrase) if not is_attribute(w)))
    return frozenset(tokens), head


@functools.cache
def _object_nouns(names: tuple[str, ...]) -> frozenset[NounKey]:
    return frozenset(_noun_key(name) for name in names)


def _attributes_agree(obj: SceneObject, prompt: ParsedInstruction) -> bool:
    if prompt.colours and obj.colour and obj.colour not in prompt.colours:
        return False
    return not (prompt.sizes and obj.size and obj.size not in prompt.sizes)


def _as_parsed(prompt: str | ParsedInstruction) -> ParsedInstruction:
    return prompt if isinstance(prompt, ParsedInstruction) else parse_instruction(prompt)


def names_match(obj: SceneObject, prompt: str | ParsedInstruction) -> bool:
    """Whether the prompt names ``obj`` (grade ``match``; see the module docstring)."""
    parsed = _as_parsed(prompt)
    return _noun_key(parsed.noun_phrase) in _object_nouns(obj.names) and _attributes_agree(obj, parsed)


def close_name_pairs(
    scene: SceneSpec, *, generic: Iterable[tuple[str, str]] = GENERIC_CLOSE_LABELS
) -> frozenset[frozenset[NounKey]]:
    """Every unordered pair of nouns the data marks as close: each of the goal's names with each name of
    each ``distractor`` object, and the generic pairs."""
    pairs: set[frozenset[NounKey]] = set()
    goal_nouns = _object_nouns(scene.goal.names)
    for obj in scene.objects:
        if obj.role != "distractor":
            continue
        for g in goal_nouns:
            for d in _object_nouns(obj.names):
                if g != d:
                    pairs.add(frozenset({g, d}))
    for a, b in generic:
        ka, kb = _noun_key(a), _noun_key(b)
        if ka != kb:
            pairs.add(frozenset({ka, kb}))
    return frozenset(pairs)


def grade(
    obj: SceneObject,
    prompt: str | ParsedInstruction,
    pairs: frozenset[frozenset[NounKey]] = frozenset(),
) -> PromptGrade:
    """How well ``prompt`` describes ``obj`` (see the module docstring)."""
    parsed = _as_parsed(prompt)
    relevance = max(phrase_similarity(parsed.object_phrase, name) for name in obj.names)
    prompt_noun = _noun_key(parsed.noun_phrase)
    nouns = _object_nouns(obj.names)
    if prompt_noun in nouns:
        return PromptGrade("match" if _attributes_agree(obj, parsed) else "related", relevance)
    if any(frozenset({prompt_noun, noun}) in pairs for noun in nouns) or relevance >= RELATED_RELEVANCE:
        return PromptGrade("related", relevance)
    return PromptGrade("unrelated", relevance)


def named_objects(scene: SceneSpec, instruction: str) -> tuple[SceneObject, ...]:
    """The objects of ``scene`` that ``instruction`` names (ground truth for SR and SA): its ``match``
    objects, walls excluded. Empty for an instruction naming nothing the scene holds."""
    parsed = parse_instruction(instruction)
    return tuple(o for o in scene.objects if o.role != "wall" and names_match(o, parsed))


def own_names(obj: SceneObject) -> tuple[str, ...]:
    """The names a VLM may use for ``obj`` in its own words: its label first, then its aliases."""
    return tuple(dict.fromkeys((obj.label, *obj.aliases)))


def close_names_of(objects: Sequence[SceneObject], prompt: str | ParsedInstruction) -> tuple[str, ...]:
    """The labels of the objects that ``prompt`` grades ``related``, sorted (reproducible draws)."""
    parsed = _as_parsed(prompt)
    return tuple(
        sorted({o.label for o in objects if o.role != "wall" and grade(o, parsed).kind == "related"})
    )
