"""Words of object phrases: normalisation, plurals, a lexicon of object names, attributes and spelling.

The executive compares what a model calls a thing ("quadruped robot") with what the user asked for ("the
robot dog"). A sentence embedding does that for most pairs, but a small one misses common synonyms
(all-MiniLM-L6-v2 scores "robot dog" against "quadruped robot" at 0.19 of 1), so the lexical scorer and
the instruction parser share this module's knowledge of English object names:

- :data:`OBJECT_LEXICON`: concept -> the names English uses for it (a thesaurus of everyday objects,
  written for the product's vocabulary, not for any one scene's wording); :func:`canonical_tokens` maps
  every name of a concept to one token;
- :data:`COLOURS` and :data:`SIZES`: attribute words;
- :func:`singularise`: English plurals;
- :func:`correct_spelling`: a word one edit (insertion, deletion, substitution or transposition) from
  exactly one known word becomes that word; the known words are the lexicon's, the attributes and
  :data:`EXTRA_OBJECT_WORDS`.

This is a core module: standard library only.

Example:
    >>> canonical_tokens("Robot dogs") == canonical_tokens("quadruped robot")
    True
    >>> correct_spelling("extingusher")
    'extinguisher'
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable, Sequence

#: Concept -> the names English uses for it. Phrases are matched after plural stripping, longest first,
#: and replaced by the concept token (a multi-word concept joins its words with "_" so that it counts as
#: one word and can be a phrase's head).
OBJECT_LEXICON: dict[str, tuple[str, ...]] = {
    "extinguisher": ("fire extinguisher", "extinguisher"),
    "bin": (
        "bin",
        "trash can",
        "trash bin",
        "garbage can",
        "garbage bin",
        "waste bin",
        "rubbish bin",
        "litter bin",
        "recycling bin",
        "dustbin",
        "wastebasket",
        "waste basket",
        "wheelie bin",
        "dumpster",
        "refuse bin",
    ),
    "sign": ("sign", "traffic sign", "road sign", "street sign", "signpost", "sign post", "signboard"),
    "cart": (
        "cart",
        "trolley",
        "handcart",
        "hand cart",
        "pushcart",
        "push cart",
        "loading cart",
        "loading trolley",
        "platform cart",
        "platform trolley",
        "shopping cart",
        "shopping trolley",
    ),
    "hand_truck": ("hand truck", "dolly", "sack truck", "hand trolley"),
    "quadruped_robot": (
        "quadruped robot",
        "quadruped",
        "robot dog",
        "robotic dog",
        "legged robot",
        "four legged robot",
        "dog robot",
    ),
    "bus_stop": ("bus stop", "bus station", "bus shelter", "bus stop shelter", "bus terminal"),
    "box": ("box", "cardboard box", "carton box", "carton", "cardboard carton", "package", "parcel"),
    "crate": ("crate", "plastic crate", "storage crate", "tote"),
    "sofa": ("sofa", "couch", "settee"),
    "armchair": ("armchair", "easy chair"),
    "chair": ("chair", "seat", "stool"),
    "bucket": ("bucket", "pail"),
    "shelf": ("shelf", "shelving", "shelving unit", "rack", "bookshelf", "bookcase"),
    "cabinet": ("cabinet", "cupboard", "locker"),
    "table": ("table", "coffee table"),
    "desk": ("desk", "workstation"),
    "plant": ("plant", "potted plant", "houseplant", "pot plant"),
    "kiosk": ("kiosk", "booth", "stall"),
    "billboard": ("advertising board", "billboard", "advert board", "ad board", "hoarding board"),
    "car": ("car", "automobile", "parked car"),
    "van": ("van", "minivan"),
    "cone": ("traffic cone", "cone", "pylon"),
    "lamp_post": ("lamp post", "lamppost", "street light", "streetlight", "light pole"),
    "bench": ("bench", "park bench"),
    "tree": ("tree",),
    "bush": ("bush", "shrub"),
    "hedge": ("hedge", "hedgerow"),
    "pallet": ("pallet", "skid"),
    "forklift": ("forklift", "fork lift", "lift truck"),
    "gas_cylinder": ("gas cylinder", "gas bottle", "gas tank"),
    "robot_arm": ("robot arm", "robotic arm", "industrial arm", "manipulator"),
    "toy": ("toy",),
    "tv": ("tv", "television", "tv set"),
    "rug": ("rug", "carpet", "mat"),
    "door": ("door", "doorway"),
    "window": ("window",),
    "piano": ("piano",),
}

#: Colour words; ``gray`` is read as ``grey``.
COLOURS: frozenset[str] = frozenset(
    {"black", "white", "grey", "red", "green", "blue", "yellow", "orange", "purple", "pink", "brown",
     "silver", "gold", "beige", "cyan", "magenta"}
)  # fmt: skip
#: Spelling variants of colour words.
COLOUR_VARIANTS: dict[str, str] = {"gray": "grey", "colour": "color"}
#: Size words, by the size they name.
SIZES: dict[str, str] = {
    "big": "large", "large": "large", "huge": "large", "tall": "large",
    "small": "small", "little": "small", "tiny": "small", "short": "small",
}  # fmt: skip

#: Object words that are in no lexicon entry, for spelling correction.
EXTRA_OBJECT_WORDS: frozenset[str] = frozenset(
    {"bottle", "backpack", "bag", "handbag", "laptop", "monitor", "printer", "machine", "board",
     "display", "barrier", "fence", "partition", "divider", "hood", "fume", "stand", "news", "planter",
     "bollard", "pole", "marking", "lane", "grass", "flower", "bed", "shed", "garden", "loading",
     "wheelie", "plain", "empty", "office", "filing", "information", "industrial", "lab", "room",
     "wooden", "plastic", "metal", "cardboard", "hydrant", "stack", "boxes", "crates", "cylinder",
     "station", "shelter", "robot", "dog", "truck", "trolley", "legged", "four"}
)  # fmt: skip

#: Modifiers that make a phrase name something that is not its head noun's kind: a toy robot dog is no
#: robot dog, a model car no car (linguistics calls them non-subsective, or privative, adjectives). Any
#: other modifier only narrows the kind: a black office chair is a black chair.
NON_SUBSECTIVE_MODIFIERS: frozenset[str] = frozenset(
    {"toy", "model", "replica", "miniature", "fake", "imitation", "artificial", "dummy", "decoy", "mock",
     "counterfeit", "stuffed", "plush", "inflatable", "cutout", "statue", "figurine", "sculpture",
     "picture", "photo", "poster", "painting", "drawing", "sticker", "cartoon", "former"}
)  # fmt: skip

#: Plurals that the suffix rules of :func:`singularise` would get wrong.
IRREGULAR_SINGULARS: dict[str, str] = {
    "shelves": "shelf",
    "knives": "knife",
    "leaves": "leaf",
    "buses": "bus",
    "people": "person",
    "children": "child",
    "feet": "foot",
    "boxes": "box",
    "benches": "bench",
}

#: Words that carry no object identity.
STOPWORDS: frozenset[str] = frozenset(
    {"the", "a", "an", "some", "of", "with", "for", "and", "on", "in", "to"}
)
#: Prepositions that end the head noun phrase ("shelf with buckets": the head is "shelf").
HEAD_BREAKERS: frozenset[str] = frozenset({"of", "with", "for", "on", "in"})
#: Shortest word spelling correction touches (shorter words have too many neighbours).
MIN_CORRECTABLE_LENGTH = 3

_NON_WORD = re.compile(r"[^a-z0-9]+")


def words_of(text: str) -> list[str]:
    """Lower-case word tokens; anything that is not a letter or a digit separates words."""
    return [tok for tok in _NON_WORD.split(text.lower()) if tok]


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


@functools.cache
def _lexicon_phrases() -> tuple[tuple[tuple[str, ...], str], ...]:
    """(name words, concept) for every name, longest first (ties: alphabetical, for determinism)."""
    pairs = {
        tuple(singularise(w) for w in words_of(name)): concept
        for concept, names in OBJECT_LEXICON.items()
        for name in names
    }
    return tuple(sorted(pairs.items(), key=lambda kv: (-len(kv[0]), kv[0])))


def normalise_word(word: str) -> str:
    """One word as the lexicon reads it: singular, colour variants unified."""
    return COLOUR_VARIANTS.get(word, singularise(word))


@functools.lru_cache(maxsize=4096)
def canonical_tokens(phrase: str) -> tuple[tuple[str, ...], str | None]:
    """Normalise a phrase into concept tokens and its head.

    Steps: lower-case word tokens, plural stripping, colour variants unified, lexicon names replaced by
    their concept token (longest match first), stopwords dropped. The head is the last concept token
    before the first preposition in :data:`HEAD_BREAKERS`.

    Returns:
        ``(tokens, head)``; ``head`` is None when the phrase has no content word.
    """
    words = [normalise_word(w) for w in words_of(phrase)]
    concepts: list[str] = []
    i = 0
    phrases = _lexicon_phrases()
    while i < len(words):
        for key, concept in phrases:
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


def concept_names(phrase: str) -> tuple[str, ...]:
    """Every name of the one lexicon concept an object phrase names, each with the phrase's attributes.

    The names come sorted and the attributes in one order (sizes, then colours, each normalised and
    sorted), so every wording of one request gives the same tuple: "robot dogs", "the quadruped robot"
    and "Robotic dog" all give the names of ``quadruped_robot``; "big red bin" and "red large bin" the
    same attributed names. A phrase whose object words are not exactly one lexicon name ("toy robot dog",
    "piano stool", a word the lexicon does not know) gives itself, unchanged.

    Example:
        >>> concept_names("grey couches")
        ('grey couch', 'grey settee', 'grey sofa')
        >>> concept_names("toy robot dog")
        ('toy robot dog',)
    """
    words = [normalise_word(w) for w in words_of(phrase)]
    nouns = tuple(w for w in words if not is_attribute(w) and w not in STOPWORDS)
    concept = _concept_of_name().get(nouns)
    if concept is None:
        return (phrase,)
    colours, sizes = attribute_words(w for w in words if is_attribute(w))
    prefix = " ".join([*sorted(sizes), *sorted(colours)])
    names = sorted({" ".join(singularise(w) for w in words_of(name)) for name in OBJECT_LEXICON[concept]})
    return tuple(f"{prefix} {name}" if prefix else name for name in names)


@functools.cache
def _concept_of_name() -> dict[tuple[str, ...], str]:
    """A lexicon name's words (singular) -> its concept."""
    return dict(_lexicon_phrases())


def is_attribute(word: str) -> bool:
    """Whether ``word`` is a colour or a size word."""
    return COLOUR_VARIANTS.get(word, word) in COLOURS or word in SIZES


def attribute_words(words: Iterable[str]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The colours and sizes (normalised: ``gray`` -> ``grey``, ``big`` -> ``large``) among ``words``."""
    colours: list[str] = []
    sizes: list[str] = []
    for word in words:
        w = COLOUR_VARIANTS.get(word, word)
        if w in COLOURS:
            colours.append(w)
        elif w in SIZES:
            sizes.append(SIZES[w])
    return tuple(dict.fromkeys(colours)), tuple(dict.fromkeys(sizes))


@functools.cache
def known_words() -> frozenset[str]:
    """Every word spelling correction may produce: the lexicon's, the attributes', the extra object words."""
    words: set[str] = set(COLOURS) | set(COLOUR_VARIANTS) | set(SIZES) | set(EXTRA_OBJECT_WORDS)
    for names in OBJECT_LEXICON.values():
        for name in names:
            words.update(words_of(name))
    return frozenset(words)


def _one_edit(a: str, b: str) -> bool:
    """Whether ``a`` and ``b`` differ by exactly one insertion, deletion, substitution or transposition."""
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        diffs = [i for i in range(len(a)) if a[i] != b[i]]
        if len(diffs) == 1:
            return True
        return (
            len(diffs) == 2
            and diffs[1] == diffs[0] + 1
            and a[diffs[0]] == b[diffs[1]]
            and a[diffs[1]] == b[diffs[0]]
        )
    short, long = (a, b) if len(a) < len(b) else (b, a)
    i = 0
    while i < len(short) and short[i] == long[i]:
        i += 1
    return short[i:] == long[i + 1 :]


@functools.cache
def object_words() -> frozenset[str]:
    """The words of object names (the lexicon's and :data:`EXTRA_OBJECT_WORDS`), without attributes."""
    return frozenset(w for w in known_words() if not is_attribute(w))


def correct_spelling(word: str, vocabulary: frozenset[str] | None = None) -> str:
    """``word``, or the known word a single edit away from it (see the module docstring).

    A known word, a word shorter than :data:`MIN_CORRECTABLE_LENGTH`, a plural of a known word, and a word
    with no known neighbour are returned unchanged. Neighbours are ranked object words first, then the
    rest of ``vocabulary`` (attributes, request words); a word with several neighbours in the first rank
    that has any is ambiguous and returned unchanged (a typo is not guessed).
    """
    vocabulary = known_words() if vocabulary is None else vocabulary
    if word in vocabulary or len(word) < MIN_CORRECTABLE_LENGTH or word.isdigit():
        return word
    if singularise(word) in vocabulary:
        return word
    neighbours = [known for known in vocabulary if _one_edit(word, known)]
    objects = object_words()
    for rank in ([w for w in neighbours if w in objects], [w for w in neighbours if w not in objects]):
        if rank:
            return rank[0] if len(rank) == 1 else word
    return word


def correct_phrase(words: Sequence[str]) -> tuple[list[str], list[tuple[str, str]]]:
    """Each word spelling-corrected, and the ``(typed, corrected)`` pairs that changed."""
    corrected = [correct_spelling(w) for w in words]
    return corrected, [(a, b) for a, b in zip(words, corrected, strict=True) if a != b]
