"""Reporting problems at YAML nodes: the error list one check of a mission collects, and node readers.

Every checking module (``trees.includes``, ``trees.substitution``, ``trees.node_checks``) shares one
:class:`Reporter`: it records each problem as a :class:`~trees.declarations.TreeError` at the node that
caused it, so that one check reports every problem (up to :data:`~trees.declarations.MAX_REPORTED_ERRORS`).
"""

from __future__ import annotations

from typing import Any

import yaml

from semexp_bt.files.yaml_source import YamlSourceError, node_value, shorten
from trees.declarations import MAX_REPORTED_ERRORS, TreeError, Where
from trees.registry import did_you_mean

#: A key given with its node and its value's node.
Item = tuple[str, yaml.Node, yaml.Node]

_STRING_TAG = "tag:yaml.org,2002:str"
#: Keys longer than this get no "did you mean" (the hint would cost more than it helps).
_HINTED_KEY_CHARS = 100
#: Longest message recorded; a longer one (a huge value echoed back) is cut.
_MESSAGE_CHARS = 1000


def _one_line(text: str) -> str:
    """``text`` with characters that are not printable (a newline in a value echoed back) escaped."""
    return text if text.isprintable() else "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class CheckStopped(Exception):
    """Checking stopped early (too many problems, or a mission past a size limit); the errors say why."""


def kind_of(node: yaml.Node) -> str:
    """How a message names what a node is: "a mapping", "a list", "the scalar 'x'"."""
    if isinstance(node, yaml.MappingNode):
        return "a mapping"
    if isinstance(node, yaml.SequenceNode):
        return "a list"
    return f"the scalar {shorten(node.value)}"


def hint(word: str, candidates: Any) -> str:
    """`` (did you mean 'x'?)`` for the closest candidate, or nothing."""
    close = did_you_mean(word, candidates) if len(word) <= _HINTED_KEY_CHARS else None
    return f" (did you mean '{close}'?)" if close else ""


class Reporter:
    """The problems found so far, and reading helpers that report instead of raising."""

    def __init__(self) -> None:
        self.errors: list[TreeError] = []

    def add(self, error: TreeError) -> None:
        """Record one problem (as one line); stop the check once :data:`MAX_REPORTED_ERRORS` are recorded."""
        message = _one_line(error.message)
        if len(message) > _MESSAGE_CHARS:
            message = message[: _MESSAGE_CHARS - 3] + "..."
        error = TreeError(_one_line(error.file), error.line, error.column, message)
        if error in self.errors:  # a subtree included twice reports its own problems once
            return
        if len(self.errors) >= MAX_REPORTED_ERRORS:
            self.errors.append(
                TreeError(error.file, error.line, error.column, f"stopped after {MAX_REPORTED_ERRORS} errors")
            )
            raise CheckStopped
        self.errors.append(error)

    def error(self, at: yaml.Node | Where, message: str) -> None:
        """Record ``message`` at a node (or a position)."""
        self.add((at if isinstance(at, Where) else Where.of(at)).error(message))

    def refused(self, exc: YamlSourceError, at: yaml.Node | None = None) -> None:
        """Record a reader's refusal: at its own position, else at ``at``, else at the file's start."""
        if exc.line is not None and exc.column is not None:
            self.add(TreeError(exc.file, exc.line, exc.column, exc.message))
        elif at is not None:
            self.error(at, exc.message)
        else:
            self.add(TreeError(exc.file, 1, 1, exc.message))

    def value(self, node: yaml.Node) -> tuple[Any, bool]:
        """The Python value of a node (plain values only); ``(None, False)`` after reporting a failure."""
        try:
            return node_value(node), True
        except YamlSourceError as exc:
            self.refused(exc)
            return None, False

    def mapping(self, node: yaml.Node, what: str) -> list[Item] | None:
        """``(key, key_node, value_node)`` of a mapping node, or ``None`` after reporting."""
        if not isinstance(node, yaml.MappingNode):
            self.error(node, f"{what} must be a mapping (key: value), got {kind_of(node)}")
            return None
        items: list[Item] = []
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                self.error(key_node, f"keys of {what} must be plain names, got {kind_of(key_node)}")
                continue
            items.append((str(key_node.value), key_node, value_node))
        return items

    def unknown_key(
        self, key: str, key_node: yaml.Node, allowed: tuple[str, ...] | list[str], what: str
    ) -> None:
        """Report a key that ``what`` does not have, with the closest allowed one and the full list."""
        listing = ", ".join(allowed) if allowed else "none"
        self.error(key_node, f"unknown key {shorten(key)} in {what}{hint(key, allowed)}; expected: {listing}")

    def string(self, node: yaml.Node, what: str) -> str | None:
        """The text of a non-empty string scalar, or ``None`` after reporting."""
        if not isinstance(node, yaml.ScalarNode) or node.tag != _STRING_TAG or not node.value:
            self.error(node, f"{what} must be a non-empty string, got {kind_of(node)}")
            return None
        return str(node.value)
