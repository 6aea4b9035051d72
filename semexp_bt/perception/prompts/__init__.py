"""The fixed prompts of the model adapters: text templates and the JSON schemas of their replies.

Each prompt is two files beside this module: ``NAME.md`` (the text, with ``string.Template``
placeholders such as ``$instruction``) and ``NAME.schema.json`` (the JSON schema the reply must
satisfy, sent to servers that support structured output and checked on every reply). ``NAME`` ends
in its version (``scene_proposals_v1``); a change of wording is a new file, so that old records stay
explained. :attr:`PromptTemplate.version` also carries a hash of both files, so the relevance cache
(keyed by it) never serves a value that a different text produced.

Example:
    >>> prompt = load_prompt("relevance_v1")
    >>> prompt.version.startswith("relevance_v1@")
    True
"""

from __future__ import annotations

import functools
import hashlib
import json
import string
from dataclasses import dataclass
from pathlib import Path
from typing import Any

PROMPT_DIR = Path(__file__).resolve().parent

#: The VLM's scene-proposal prompt.
SCENE_PROPOSALS = "scene_proposals_v1"
#: The relevance LLM's batched scoring prompt.
RELEVANCE = "relevance_v1"


@dataclass(frozen=True)
class PromptTemplate:
    """One versioned prompt.

    Attributes:
        name: the file stem, e.g. ``scene_proposals_v1``.
        text: the template text (``string.Template`` syntax).
        schema: the reply's JSON schema.
        version: ``name@`` plus the first 12 hex digits of the SHA-256 of both files.
    """

    name: str
    text: str
    schema: dict[str, Any]
    version: str

    def render(self, **values: str) -> str:
        """The prompt with every placeholder filled (a missing value is a ``KeyError``)."""
        return string.Template(self.text).substitute(values)


@functools.cache
def load_prompt(name: str) -> PromptTemplate:
    """The prompt ``name`` (read once per process).

    Raises:
        FileNotFoundError: when ``NAME.md`` or ``NAME.schema.json`` is missing.
        ValueError: when the schema is not a JSON object.
    """
    text = (PROMPT_DIR / f"{name}.md").read_text(encoding="utf-8")
    schema_text = (PROMPT_DIR / f"{name}.schema.json").read_text(encoding="utf-8")
    schema = json.loads(schema_text)
    if not isinstance(schema, dict):
        raise ValueError(f"{PROMPT_DIR / f'{name}.schema.json'}: a JSON schema must be an object")
    digest = hashlib.sha256((text + "\0" + schema_text).encode("utf-8")).hexdigest()[:12]
    return PromptTemplate(name=name, text=text.strip(), schema=schema, version=f"{name}@{digest}")
