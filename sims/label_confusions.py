"""Which labels the emulated models may confuse with each other, and which match a text prompt.

Two sources of "semantically close" pairs, and no others:

1. the scene data: every object whose ``role`` is ``"distractor"`` is close to the scene's goal (the
   scene builder placed it there *because* it looks like the goal: a red trash can next to a fire
   extinguisher, a grey chair among black chairs). Every name of the goal (label and category) is
   paired with every name of each distractor;
2. :data:`GENERIC_CLOSE_LABELS`, a short table of pairs that open-vocabulary models are known to mix
   up in general, so that an instruction for a class that is not the scene's goal still has realistic
   confusions.

Confusion is symmetric: if a red trash can may be called "fire extinguisher", a fire extinguisher may
be called "red trash can" when the prompt asks for trash cans.

Matching a prompt is done on normalised names (lower case, articles and punctuation dropped, single
spaces). An object *matches* a prompt when the prompt equals its label or its category, or when the
prompt is the head noun phrase of its label (prompt ``"chair"`` matches label ``"black chair"``): this
is what GroundingDINO does with a short text prompt, which scores every box against the prompt tokens.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from semexp_bt.core.scene import SceneObject, SceneSpec

#: Pairs of labels that open-vocabulary detectors and VLMs confuse regardless of the scene.
GENERIC_CLOSE_LABELS: tuple[tuple[str, str], ...] = (
    ("fire extinguisher", "red trash can"),
    ("fire extinguisher", "red bottle"),
    ("fire extinguisher", "fire hydrant"),
    ("trash can", "recycling bin"),
    ("black chair", "grey chair"),
    ("chair", "stool"),
    ("potted plant", "bush"),
    ("stop sign", "red sign"),
    ("traffic cone", "orange bucket"),
    ("cardboard box", "wooden crate"),
    ("backpack", "handbag"),
    ("cabinet", "locker"),
)

_ARTICLES = frozenset({"a", "an", "the"})


def normalise_label(text: str) -> str:
    """Lower-case ``text``, drop punctuation and articles, collapse spaces.

    >>> normalise_label("  The Fire-Extinguisher. ")
    'fire extinguisher'
    """
    words = re.sub(r"[^a-z0-9]+", " ", text.lower()).split()
    return " ".join(w for w in words if w not in _ARTICLES)


def object_names(obj: SceneObject) -> frozenset[str]:
    """The normalised label and category of ``obj``."""
    return frozenset({normalise_label(obj.label), normalise_label(obj.category)})


def matches_prompt(obj: SceneObject, prompt: str) -> bool:
    """Whether a detector prompted with ``prompt`` would name ``obj`` correctly.

    True when the normalised prompt equals the object's label or category, or is the trailing word
    sequence (the head noun phrase) of its label.
    """
    target = normalise_label(prompt)
    if not target:
        return False
    if target in object_names(obj):
        return True
    label = normalise_label(obj.label)
    return label.endswith(" " + target)


def close_label_pairs(
    scene: SceneSpec, *, generic: Iterable[tuple[str, str]] = GENERIC_CLOSE_LABELS
) -> frozenset[frozenset[str]]:
    """Every unordered pair of normalised names the data marks as semantically close.

    Args:
        scene: the scene; its goal and ``role == "distractor"`` objects give scene-specific pairs.
        generic: extra scene-independent pairs.
    """
    pairs: set[frozenset[str]] = set()
    goal_names = object_names(scene.goal)
    for obj in scene.objects:
        if obj.role != "distractor":
            continue
        for g in goal_names:
            for d in object_names(obj):
                if g != d:
                    pairs.add(frozenset({g, d}))
    for a, b in generic:
        na, nb = normalise_label(a), normalise_label(b)
        if na != nb:
            pairs.add(frozenset({na, nb}))
    return frozenset(pairs)


def is_confusable(obj: SceneObject, prompt: str, pairs: frozenset[frozenset[str]]) -> bool:
    """Whether ``obj`` does not match ``prompt`` but one of its names is marked close to it."""
    if matches_prompt(obj, prompt):
        return False
    target = normalise_label(prompt)
    return any(frozenset({name, target}) in pairs for name in object_names(obj))


def close_labels_of(prompt: str, pairs: frozenset[frozenset[str]]) -> tuple[str, ...]:
    """The names marked close to ``prompt``, sorted (so that draws from them are reproducible)."""
    target = normalise_label(prompt)
    out = {name for pair in pairs if target in pair for name in pair if name != target}
    return tuple(sorted(out))
