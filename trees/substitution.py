"""Subtree parameters: ``${param}`` substitution into YAML nodes, and typed checking of substituted values.

A value that is exactly ``${param}`` becomes the argument's node (keeping its declared type); ``${param}``
inside a longer string is interpolated (scalars only); ``$${`` is a literal ``${``. A subtree file checked
on its own has no arguments for its parameters without default: those are :class:`Unknown`, and only
their declared kind is checked against the parameter they feed.

Example (a subtree's ``name: "Explore ${label}"`` with ``args: {label: office}``) gives the string node
``Explore office``; ``params: {num_failures: "${max_steps}"}`` gives the int node of ``max_steps``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import yaml

from behaviours.spec import ParamSpec
from trees.declarations import SUBTREE_PARAMETER_KINDS, Where
from trees.reporting import Reporter, hint

_SUBSTITUTION = re.compile(r"\$\{([^}]*)\}")
_ESCAPED_DOLLAR = "$${"
_STRING_TAG = "tag:yaml.org,2002:str"
#: Which declared subtree-parameter kinds may feed a parameter of each kind.
_COMPATIBLE_KINDS: dict[str, tuple[str, ...]] = {
    "int": ("int",),
    "float": ("int", "float"),
    "bool": ("bool",),
    "str": ("str",),
    "enum": ("str",),
    "list": ("list",),
    "any": SUBTREE_PARAMETER_KINDS,
}


@dataclass
class Unknown:
    """A subtree parameter without a default, seen while checking the subtree file on its own."""

    kind: str
    parameter: str
    where: Where | None = None


#: The arguments a subtree's nodes are checked with: a node per parameter, or an :class:`Unknown`.
Environment = Mapping[str, yaml.Node | Unknown]


class Substitution:
    """Substitutes subtree arguments into nodes and checks values, reporting problems to ``reporter``."""

    def __init__(self, reporter: Reporter) -> None:
        self.reporter = reporter

    def substitute(self, node: yaml.Node, env: Environment) -> yaml.Node | Unknown | None:
        """Replace ``${param}`` in a node by the subtree arguments; ``None`` after reporting."""
        if isinstance(node, yaml.SequenceNode):
            items = []
            for item in node.value:
                replaced = self.substitute(item, env)
                if replaced is None:
                    return None
                if isinstance(replaced, Unknown):
                    return Unknown("list", replaced.parameter, replaced.where)
                items.append(replaced)
            return yaml.SequenceNode(node.tag, items, node.start_mark, node.end_mark, node.flow_style)
        if isinstance(node, yaml.MappingNode):
            pairs = []
            for key_node, value_node in node.value:
                replaced = self.substitute(value_node, env)
                if replaced is None or isinstance(replaced, Unknown):
                    return replaced
                pairs.append((key_node, replaced))
            return yaml.MappingNode(node.tag, pairs, node.start_mark, node.end_mark, node.flow_style)
        if node.tag != _STRING_TAG or "${" not in node.value:
            return node
        text = node.value
        whole = _SUBSTITUTION.fullmatch(text)
        if whole and not text.startswith(_ESCAPED_DOLLAR):
            return self._lookup(whole.group(1), node, env)
        return self._interpolate(node, env)

    def _interpolate(self, node: yaml.Node, env: Environment) -> yaml.Node | Unknown | None:
        """``${param}`` inside a longer string: every argument must be a scalar."""
        text = node.value
        pieces: list[str] = []
        unknown: Unknown | None = None
        position = 0
        for match in _SUBSTITUTION.finditer(text):
            start = match.start()
            if start > 0 and text[start - 1] == "$":
                pieces.append(text[position : start - 1] + match.group(0))
                position = match.end()
                continue
            pieces.append(text[position:start])
            position = match.end()
            found = self._lookup(match.group(1), node, env)
            if found is None:
                return None
            if isinstance(found, Unknown):
                unknown = found
                continue
            if not isinstance(found, yaml.ScalarNode):
                self.reporter.error(
                    node,
                    f"subtree parameter '{match.group(1)}' is not a scalar and cannot be "
                    "interpolated into a string",
                )
                return None
            value, ok = self.reporter.value(found)
            if not ok:
                return None
            pieces.append(str(value).lower() if isinstance(value, bool) else str(value))
        pieces.append(text[position:])
        if unknown is not None:
            return Unknown("str", unknown.parameter, unknown.where)
        return yaml.ScalarNode(_STRING_TAG, "".join(pieces), node.start_mark, node.end_mark, "'")

    def _lookup(self, parameter: str, node: yaml.Node, env: Environment) -> yaml.Node | Unknown | None:
        if parameter in env:
            found = env[parameter]
            if isinstance(found, Unknown):
                return Unknown(found.kind, found.parameter, Where.of(node))
            return found
        declared = ", ".join(env) if env else "none"
        self.reporter.error(
            node, f"unknown subtree parameter '${{{parameter}}}'{hint(parameter, env)}; declared: {declared}"
        )
        return None

    def check_value(self, spec: ParamSpec, node: yaml.Node | Unknown, what: str) -> tuple[Any, bool]:
        """Validate one (substituted) value against its spec: ``(value, True)``, or ``(None, False)``."""
        if isinstance(node, Unknown):
            if node.kind not in _COMPATIBLE_KINDS[spec.kind]:
                self.reporter.error(
                    node.where or Where("?", 1, 1),
                    f"{what}: expected {spec.describe()}, but subtree parameter '{node.parameter}' is "
                    f"declared {node.kind}",
                )
                return None, False
            return node, True
        value, ok = self.reporter.value(node)
        if not ok:
            return None, False
        value, problem = spec.check(value)
        if problem is not None:
            self.reporter.error(node, f"{what}: {problem}")
            return None, False
        return value, True
