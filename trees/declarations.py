"""What a mission file may say and what checking it yields: the format's keys and limits, errors, declarations.

The format is specified in ``docs/trees.md``; the limits are its "What the loader refuses" section.
Nothing here reads a file or builds a behaviour (``trees.loader`` does both, through the checking modules).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from behaviours.spec import ParamSpec

#: Top-level keys of a mission or subtree file.
FILE_KEYS: tuple[str, ...] = ("mission", "parameters", "tree")
#: Keys of a node that names a type.
NODE_KEYS: tuple[str, ...] = ("type", "name", "params", "remap", "children")
#: Keys of a node that includes a subtree file.
INCLUDE_KEYS: tuple[str, ...] = ("include", "name", "args")
#: Keys of one declared subtree parameter.
SUBTREE_PARAMETER_KEYS: tuple[str, ...] = ("type", "default", "doc")
#: Kinds a subtree parameter may declare.
SUBTREE_PARAMETER_KINDS: tuple[str, ...] = ("int", "float", "bool", "str", "list")
#: File suffixes an include may name (only YAML is ever read; nothing is imported or evaluated).
SUBTREE_SUFFIXES: tuple[str, ...] = (".yaml", ".yml")

#: The ``mission:`` section. ``config`` (SemExpConfig overrides) is validated by semexp_bt.core.config.
MISSION_SETTINGS: dict[str, ParamSpec] = {
    "name": ParamSpec("str", doc="mission name for logs and records (default: the file's stem)", default=""),
    "instruction": ParamSpec("str", doc="the sentence naming the object to find", default=""),
    "instructions": ParamSpec(
        "list",
        items="str",
        doc="several sentences searched in turn (multi-object missions); use instead of 'instruction'",
        default=[],
    ),
    "robot": ParamSpec("str", doc="robot description", default="go1"),
    "backend": ParamSpec("enum", doc="robot backend", choices=("mujoco", "ros2"), default="mujoco"),
    "fidelity": ParamSpec(
        "enum",
        doc="kinematic: the base follows the twist; dynamic: legs, physics and gait",
        choices=("kinematic", "dynamic"),
        default="kinematic",
    ),
    "budget_s": ParamSpec("float", doc="mission time budget in robot-clock seconds", gt=0.0, default=300.0),
}
#: The key of the ``mission:`` section that holds SemExpConfig overrides.
CONFIG_KEY = "config"

# The limits of one mission (each file is also held to semexp_bt.files.yaml_source's caps). They keep checking and
# building in bounded time, memory and stack: the checker, the builder and py_trees' tick all recurse
# once per tree level.

#: Longest chain of includes (a file that includes a file that includes ...).
MAX_INCLUDE_DEPTH = 16
#: Deepest tree once includes are expanded (the shipped missions reach 14 levels).
MAX_TREE_DEPTH = 64
#: Most nodes in a tree once includes are expanded (the shipped missions have 44 to 51).
MAX_TREE_NODES = 10_000
#: Most problems reported for one mission; checking stops after the last.
MAX_REPORTED_ERRORS = 100


@dataclass(frozen=True)
class TreeError:
    """One problem in a mission file; ``line`` and ``column`` count from 1."""

    file: str
    line: int
    column: int
    message: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}: {self.message}"


class MissionLoadError(ValueError):
    """A mission file (or a subtree it includes) is invalid; ``errors`` lists every problem found."""

    def __init__(self, errors: list[TreeError]) -> None:
        self.errors = list(errors)
        lines = "\n".join(str(e) for e in self.errors)
        super().__init__(f"{len(self.errors)} error(s) in mission tree:\n{lines}")


@dataclass(frozen=True)
class Where:
    """A position in a mission file (1-based line and column)."""

    file: str
    line: int
    column: int

    @staticmethod
    def of(node: yaml.Node) -> Where:
        """Where a composed YAML node starts."""
        mark = node.start_mark
        return Where(mark.name, mark.line + 1, mark.column + 1)

    def error(self, message: str) -> TreeError:
        """A :class:`TreeError` at this position."""
        return TreeError(self.file, self.line, self.column, message)

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


@dataclass
class NodeDecl:
    """A validated node: what the builder will construct (includes already expanded)."""

    type_name: str
    name: str
    params: dict[str, Any]
    remap: dict[str, str]
    children: list[NodeDecl]
    file: str
    line: int
    column: int
    name_where: Where | None = None
    included_at: tuple[str, ...] = ()
    """The include sites ("file:line:col", outermost first) through which this node entered the tree."""

    def walk(self) -> Iterator[NodeDecl]:
        """This node and all below it, depth first (without recursion: a tree may be deep)."""
        stack = [self]
        while stack:
            decl = stack.pop()
            yield decl
            stack.extend(reversed(decl.children))


@dataclass(frozen=True)
class MissionSettings:
    """The ``mission:`` section, with defaults filled in (see :data:`MISSION_SETTINGS`)."""

    name: str
    instruction: str = ""
    instructions: list[str] = field(default_factory=list)
    robot: str = "go1"
    backend: str = "mujoco"
    fidelity: str = "kinematic"
    budget_s: float = 300.0
    config_overrides: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class MissionDocument:
    """A validated mission file: its settings and its declaration tree, includes expanded (nothing built).

    Attributes:
        settings: the ``mission:`` section, defaults filled in.
        declaration: the root node's declaration.
        source: the file it was read from.
    """

    settings: MissionSettings
    declaration: NodeDecl
    source: Path
