"""Load a mission tree from YAML: validate the whole file and its includes, then build py_trees.

Two passes. :func:`validate_mission` reads the file and every subtree it includes into plain
declarations (:class:`NodeDecl`) and collects EVERY problem as a :class:`TreeError` with file, line and
column (from ``yaml.compose`` marks). :func:`load_mission` builds behaviours only when that list is
empty, so a mission never starts half-built. The format is specified in ``docs/trees.md``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import py_trees
import yaml

from behaviours.spec import BLACKBOARD_KEY_PATTERN, BuildContext, ParamSpec
from semexp_bt.core.config import ConfigError, SemExpConfig, config_from_dict
from trees.registry import NodeRegistry, NodeSpec, default_registry, did_you_mean

__all__ = [
    "FILE_KEYS",
    "INCLUDE_KEYS",
    "MISSION_SETTINGS",
    "NODE_KEYS",
    "SUBTREE_PARAMETER_KEYS",
    "BuildContext",
    "Mission",
    "MissionDocument",
    "MissionLoadError",
    "MissionSettings",
    "NodeDecl",
    "TreeError",
    "analyse_mission",
    "build_tree",
    "load_mission",
    "parse_mission",
    "validate_mission",
]

#: Top-level keys of a mission or subtree file (``faults``: faults to inject in simulation, validated by
#: ``sims.faults``; mission files only).
FILE_KEYS: tuple[str, ...] = ("mission", "parameters", "tree", "faults")
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
_CONFIG_KEY = "config"

_SUBSTITUTION = re.compile(r"\$\{([^}]*)\}")
_ESCAPED_DOLLAR = "$${"


# ---------------------------------------------------------------------------------------------------
# Errors
# ---------------------------------------------------------------------------------------------------


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
class _Where:
    file: str
    line: int
    column: int

    @staticmethod
    def of(node: yaml.Node) -> _Where:
        mark = node.start_mark
        return _Where(mark.name, mark.line + 1, mark.column + 1)

    def error(self, message: str) -> TreeError:
        return TreeError(self.file, self.line, self.column, message)

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


# ---------------------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------------------


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
    name_where: _Where | None = None
    included_at: tuple[str, ...] = ()
    """The include sites ("file:line:col", outermost first) through which this node entered the tree."""

    def walk(self) -> Iterator[NodeDecl]:
        """This node and all below it, depth first."""
        yield self
        for child in self.children:
            yield from child.walk()


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
    faults: Any = None
    """The top-level ``faults:`` section as YAML gave it (``sims.faults.parse_faults`` validates it)."""
    faults_where: str = ""
    """``file:line:column`` of that section, for its errors."""


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


@dataclass
class Mission:
    """A built mission: its settings, the py_trees root, and the config its factories saw."""

    settings: MissionSettings
    root: py_trees.behaviour.Behaviour
    config: SemExpConfig
    source: Path
    declaration: NodeDecl


@dataclass
class _Unknown:
    """A subtree parameter without a default, seen while checking the subtree file on its own."""

    kind: str
    parameter: str
    where: _Where | None = None


@dataclass
class _SubtreeParam:
    kind: str
    default: yaml.Node | None


@dataclass
class _Analysis:
    settings: MissionSettings | None
    root: NodeDecl | None
    errors: list[TreeError]


# ---------------------------------------------------------------------------------------------------
# YAML helpers
# ---------------------------------------------------------------------------------------------------


def _kind_of(node: yaml.Node) -> str:
    if isinstance(node, yaml.MappingNode):
        return "a mapping"
    if isinstance(node, yaml.SequenceNode):
        return "a list"
    return f"the scalar {node.value!r}"


class _Checker:
    """Walks a mission file and its includes, collecting errors and declarations."""

    def __init__(self, registry: NodeRegistry) -> None:
        self.registry = registry
        self.errors: list[TreeError] = []
        self._files: dict[Path, yaml.Node | None] = {}
        self._constructor = yaml.constructor.SafeConstructor()

    # -- low level --------------------------------------------------------------------------------

    def error(self, node: yaml.Node | _Where, message: str) -> None:
        where = node if isinstance(node, _Where) else _Where.of(node)
        self.errors.append(where.error(message))

    def value(self, node: yaml.Node) -> tuple[Any, bool]:
        """The Python value of a node (safe tags only); ``(None, False)`` after reporting a failure."""
        try:
            return self._constructor.construct_object(node, deep=True), True
        except yaml.YAMLError as exc:
            problem = getattr(exc, "problem", None) or str(exc)
            self.error(node, f"invalid value: {problem}")
            return None, False

    def mapping(self, node: yaml.Node, what: str) -> list[tuple[str, yaml.Node, yaml.Node]] | None:
        """``(key, key_node, value_node)`` of a mapping node, or ``None`` after reporting."""
        if not isinstance(node, yaml.MappingNode):
            self.error(node, f"{what} must be a mapping (key: value), got {_kind_of(node)}")
            return None
        items: list[tuple[str, yaml.Node, yaml.Node]] = []
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                self.error(key_node, f"keys of {what} must be plain names, got {_kind_of(key_node)}")
                continue
            items.append((str(key_node.value), key_node, value_node))
        return items

    def unknown_key(
        self, key: str, key_node: yaml.Node, allowed: tuple[str, ...] | list[str], what: str
    ) -> None:
        hint = did_you_mean(key, allowed)
        suggestion = f" (did you mean '{hint}'?)" if hint else ""
        listing = ", ".join(allowed) if allowed else "none"
        self.error(key_node, f"unknown key '{key}' in {what}{suggestion}; expected: {listing}")

    def string(self, node: yaml.Node, what: str) -> str | None:
        if not isinstance(node, yaml.ScalarNode) or node.tag != "tag:yaml.org,2002:str" or not node.value:
            self.error(node, f"{what} must be a non-empty string, got {_kind_of(node)}")
            return None
        return str(node.value)

    def compose(self, path: Path, display: str, at: yaml.Node | None) -> yaml.Node | None:
        """The composed root node of a file (cached), or ``None`` after reporting why not."""
        key = path.resolve()
        if key in self._files:
            return self._files[key]
        root: yaml.Node | None = None
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            reason = "not found" if isinstance(exc, FileNotFoundError) else f"unreadable ({exc.strerror})"
            if at is None:
                self.errors.append(TreeError(display, 1, 1, f"mission file {reason}"))
            else:
                self.error(at, f"subtree file {reason}: '{at.value}' (looked for {display})")
            self._files[key] = None
            return None
        loader = yaml.SafeLoader(text)
        loader.name = display  # marks carry the file, so errors in included files name them
        try:
            root = loader.get_single_node()
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            context = (
                f" ({exc.context} at line {exc.context_mark.line + 1})"
                if exc.context and exc.context_mark
                else ""
            )
            problem = exc.problem or "invalid YAML"
            line, column = (mark.line + 1, mark.column + 1) if mark else (1, 1)
            if "${" in " ".join(text.splitlines()[max(0, line - 2) : line]):
                # `{a: ${x}}` is invalid YAML: braces are flow indicators.
                context += '; quote substitutions inside {...} or [...], e.g. {a: "${x}"}'
            self.errors.append(TreeError(display, line, column, f"YAML syntax error: {problem}{context}"))
        except yaml.YAMLError as exc:
            self.errors.append(TreeError(display, 1, 1, f"YAML syntax error: {exc}"))
        finally:
            loader.dispose()
        if root is not None:
            self._check_duplicate_keys(root)
        elif not any(e.file == display for e in self.errors):
            self.errors.append(
                TreeError(display, 1, 1, "file is empty; expected a mapping with a 'tree' key")
            )
        self._files[key] = root
        return root

    def _check_duplicate_keys(self, node: yaml.Node) -> None:
        # PyYAML silently keeps the last of two equal keys; a mission file that says a thing twice is a bug.
        stack = [node]
        seen_nodes: set[int] = set()
        while stack:
            current = stack.pop()
            if id(current) in seen_nodes:
                continue
            seen_nodes.add(id(current))
            if isinstance(current, yaml.MappingNode):
                first: dict[str, yaml.Node] = {}
                for key_node, value_node in current.value:
                    if isinstance(key_node, yaml.ScalarNode):
                        if key_node.value in first:
                            line = first[key_node.value].start_mark.line + 1
                            self.error(
                                key_node, f"duplicate key '{key_node.value}' (first given at line {line})"
                            )
                        else:
                            first[key_node.value] = key_node
                    stack.append(value_node)
            elif isinstance(current, yaml.SequenceNode):
                stack.extend(current.value)

    # -- substitution -------------------------------------------------------------------------------

    def substitute(
        self, node: yaml.Node, env: Mapping[str, yaml.Node | _Unknown]
    ) -> yaml.Node | _Unknown | None:
        """Replace ``${param}`` in a node by the subtree arguments; ``None`` after reporting."""
        if isinstance(node, yaml.SequenceNode):
            items = []
            for item in node.value:
                replaced = self.substitute(item, env)
                if replaced is None:
                    return None
                if isinstance(replaced, _Unknown):
                    return _Unknown("list", replaced.parameter, replaced.where)
                items.append(replaced)
            return yaml.SequenceNode(node.tag, items, node.start_mark, node.end_mark, node.flow_style)
        if isinstance(node, yaml.MappingNode):
            pairs = []
            for key_node, value_node in node.value:
                replaced = self.substitute(value_node, env)
                if replaced is None or isinstance(replaced, _Unknown):
                    return replaced
                pairs.append((key_node, replaced))
            return yaml.MappingNode(node.tag, pairs, node.start_mark, node.end_mark, node.flow_style)
        if node.tag != "tag:yaml.org,2002:str" or "${" not in node.value:
            return node
        text = node.value
        whole = _SUBSTITUTION.fullmatch(text)
        if whole and not text.startswith(_ESCAPED_DOLLAR):
            return self._lookup(whole.group(1), node, env)
        # Interpolation into a longer string: every argument must be a scalar.
        pieces: list[str] = []
        unknown: _Unknown | None = None
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
            if isinstance(found, _Unknown):
                unknown = found
                continue
            if not isinstance(found, yaml.ScalarNode):
                self.error(
                    node,
                    f"subtree parameter '{match.group(1)}' is not a scalar and cannot be "
                    "interpolated into a string",
                )
                return None
            value, ok = self.value(found)
            if not ok:
                return None
            pieces.append(str(value).lower() if isinstance(value, bool) else str(value))
        pieces.append(text[position:])
        if unknown is not None:
            return _Unknown("str", unknown.parameter, unknown.where)
        return yaml.ScalarNode("tag:yaml.org,2002:str", "".join(pieces), node.start_mark, node.end_mark, "'")

    def _lookup(self, parameter: str, node: yaml.Node, env: Mapping[str, yaml.Node | _Unknown]) -> Any:
        if parameter in env:
            found = env[parameter]
            if isinstance(found, _Unknown):
                return _Unknown(found.kind, found.parameter, _Where.of(node))
            return found
        hint = did_you_mean(parameter, env)
        suggestion = f" (did you mean '{hint}'?)" if hint else ""
        declared = ", ".join(env) if env else "none"
        self.error(node, f"unknown subtree parameter '${{{parameter}}}'{suggestion}; declared: {declared}")
        return None

    def check_value(self, spec: ParamSpec, node: yaml.Node | _Unknown, what: str) -> tuple[Any, bool]:
        """Validate one (substituted) value against its spec."""
        if isinstance(node, _Unknown):
            compatible = {
                "int": ("int",),
                "float": ("int", "float"),
                "bool": ("bool",),
                "str": ("str",),
                "enum": ("str",),
                "list": ("list",),
                "any": SUBTREE_PARAMETER_KINDS,
            }[spec.kind]
            if node.kind not in compatible:
                self.error(
                    node.where or _Where("?", 1, 1),
                    f"{what}: expected {spec.describe()}, but subtree parameter '{node.parameter}' is "
                    f"declared {node.kind}",
                )
                return None, False
            return node, True
        value, ok = self.value(node)
        if not ok:
            return None, False
        value, problem = spec.check(value)
        if problem is not None:
            self.error(node, f"{what}: {problem}")
            return None, False
        return value, True

    # -- files --------------------------------------------------------------------------------------

    def top_level(self, path: Path) -> _Analysis:
        display = os.path.normpath(str(path))
        root = self.compose(path, display, at=None)
        if root is None:
            return _Analysis(None, None, self.errors)
        items = self.mapping(root, "a mission file")
        if items is None:
            return _Analysis(None, None, self.errors)
        sections = self._sections(items, display, root, is_subtree=False)
        settings = self._settings(sections.get("mission"), default_name=path.stem)
        if "faults" in sections:
            faults, ok = self.value(sections["faults"])
            if ok:
                settings = replace(settings, faults=faults, faults_where=str(_Where.of(sections["faults"])))
        # Checked on its own, a subtree's parameters take their defaults; one without a default is
        # unknown, and only its declared type is checked against the parameters it feeds.
        env = _env(self._parameters(sections.get("parameters")) or {})
        decl = None
        if "tree" in sections:
            decl = self.node(sections["tree"], path, env, (path.resolve(),))
        if decl is not None:
            self._check_unique_names(decl)
        return _Analysis(settings, decl, self.errors)

    def _sections(
        self,
        items: list[tuple[str, yaml.Node, yaml.Node]],
        display: str,
        root: yaml.Node,
        *,
        is_subtree: bool,
    ) -> dict[str, yaml.Node]:
        sections: dict[str, yaml.Node] = {}
        for key, key_node, value_node in items:
            if key not in FILE_KEYS:
                self.unknown_key(
                    key, key_node, FILE_KEYS, "a subtree file" if is_subtree else "a mission file"
                )
            elif key == "mission" and is_subtree:
                self.error(
                    key_node,
                    "a subtree file must not have a 'mission' section; mission settings belong "
                    "in the top-level file",
                )
            elif key == "faults" and is_subtree:
                self.error(
                    key_node,
                    "a subtree file must not have a 'faults' section; faults belong in the mission file",
                )
            else:
                sections[key] = value_node
        if "tree" not in sections:
            self.error(root, "missing key 'tree' (the root node of the tree)")
        return sections

    def _settings(self, node: yaml.Node | None, *, default_name: str) -> MissionSettings:
        values: dict[str, Any] = {k: s.default for k, s in MISSION_SETTINGS.items()}
        values["name"] = default_name
        overrides: dict[str, Any] = {}
        if node is not None:
            items = self.mapping(node, "the 'mission' section") or []
            allowed = (*MISSION_SETTINGS, _CONFIG_KEY)
            for key, key_node, value_node in items:
                if key == _CONFIG_KEY:
                    overrides = self._config(value_node)
                elif key not in MISSION_SETTINGS:
                    self.unknown_key(key, key_node, allowed, "the 'mission' section")
                else:
                    value, ok = self.check_value(
                        MISSION_SETTINGS[key], value_node, f"mission setting '{key}'"
                    )
                    if ok:
                        values[key] = value
                    if key == "instructions" and any(k == "instruction" for k, _, _ in items):
                        self.error(key_node, "give either 'instruction' or 'instructions', not both")
        return MissionSettings(config_overrides=overrides, **values)

    def _config(self, node: yaml.Node) -> dict[str, Any]:
        value, ok = self.value(node)
        if not ok:
            return {}
        try:
            config_from_dict(value, where="")
        except ConfigError as exc:
            message = str(exc).removeprefix(": ")
            key_path = re.search(r"'([\w.]+)'", message)
            self.error(
                self._locate(node, key_path.group(1) if key_path else ""), f"config override: {message}"
            )
            return {}
        return dict(value or {})

    def _locate(self, node: yaml.Node, dotted: str) -> yaml.Node:
        """The deepest node along a dotted key path (the value, or the key when the key is unknown)."""
        current = node
        for part in dotted.split(".") if dotted else []:
            if not isinstance(current, yaml.MappingNode):
                break
            for key_node, value_node in current.value:
                if key_node.value == part:
                    current = value_node
                    break
            else:
                return current
        return current

    def _parameters(self, node: yaml.Node | None) -> dict[str, _SubtreeParam] | None:
        """Declared subtree parameters (``None`` after reporting that the section is not a mapping)."""
        declared: dict[str, _SubtreeParam] = {}
        if node is None:
            return declared
        items = self.mapping(node, "'parameters'")
        if items is None:
            return None
        for name, key_node, spec_node in items:
            if not name.isidentifier():
                self.error(key_node, f"subtree parameter name '{name}' must be an identifier")
                continue
            fields = self.mapping(spec_node, f"subtree parameter '{name}'")
            if fields is None:
                continue
            kind: str | None = None
            default: yaml.Node | None = None
            for key, field_key, field_value in fields:
                if key not in SUBTREE_PARAMETER_KEYS:
                    self.unknown_key(key, field_key, SUBTREE_PARAMETER_KEYS, f"subtree parameter '{name}'")
                elif key == "type":
                    kind = self.string(field_value, f"type of subtree parameter '{name}'")
                    if kind is not None and kind not in SUBTREE_PARAMETER_KINDS:
                        self.error(
                            field_value,
                            f"type of subtree parameter '{name}' must be one of "
                            f"{', '.join(SUBTREE_PARAMETER_KINDS)}, got '{kind}'",
                        )
                        kind = None
                elif key == "default":
                    default = field_value
            if kind is None:
                if not any(k == "type" for k, _, _ in fields):
                    self.error(spec_node, f"subtree parameter '{name}' needs a 'type'")
                continue
            if default is not None:
                kind_spec = ParamSpec(kind, doc="")  # type: ignore[arg-type]  # kind checked above
                ok = self.check_value(kind_spec, default, f"default of subtree parameter '{name}'")[1]
                if not ok:
                    default = None
                    continue
            declared[name] = _SubtreeParam(kind, default)
        return declared

    # -- nodes --------------------------------------------------------------------------------------

    def node(
        self,
        node: yaml.Node,
        file: Path,
        env: Mapping[str, yaml.Node | _Unknown],
        stack: tuple[Path, ...],
    ) -> NodeDecl | None:
        """Validate one node (expanding an include) and its children; ``None`` when it has errors."""
        items = self.mapping(node, "a tree node")
        if items is None:
            return None
        keys = {key for key, _, _ in items}
        if "include" in keys:
            return self._include(node, items, file, env, stack)
        by_key = {key: (key_node, value_node) for key, key_node, value_node in items}
        misspelt_children = False
        for key, key_node, _ in items:
            if key not in NODE_KEYS:
                self.unknown_key(key, key_node, NODE_KEYS, "a tree node")
                misspelt_children = misspelt_children or did_you_mean(key, NODE_KEYS) == "children"
        spec: NodeSpec | None = None
        type_name = "?"
        if "type" not in by_key:
            self.error(node, "a tree node needs 'type' (a node type) or 'include' (a subtree file)")
        else:
            type_node = by_key["type"][1]
            type_name = self.string(type_node, "'type'") or "?"
            spec = self.registry.get(type_name)
            if spec is None and type_name != "?":
                hint = self.registry.suggest(type_name)
                suggestion = f" (did you mean '{hint}'?)" if hint else ""
                self.error(type_node, f"unknown node type '{type_name}'{suggestion}")
        name, name_where = self._name(by_key, env, default=type_name)
        children_decls: list[NodeDecl] = []
        children_ok = True
        if "children" in by_key:
            children_key, children_node = by_key["children"]
            if not isinstance(children_node, yaml.SequenceNode):
                self.error(
                    children_node, f"'children' must be a list of tree nodes, got {_kind_of(children_node)}"
                )
                children_ok = False
            else:
                for child_node in children_node.value:
                    child = self.node(child_node, file, env, stack)
                    if child is None:
                        children_ok = False
                    else:
                        children_decls.append(child)
        if spec is None:
            return None
        if not misspelt_children:  # one mistake, one message: "childern" is not also "no children"
            self._check_arity(spec, node, by_key, children_decls if children_ok else None)
        child_names = [c.name for c in children_decls] if children_ok else None
        params = self._params(spec, node, by_key.get("params"), env, child_names)
        remap = self._remap(spec, by_key.get("remap"), env)
        if params is None or remap is None or not children_ok:
            return None
        where = _Where.of(node)
        return NodeDecl(
            type_name=spec.type_name,
            name=name,
            params=params,
            remap=remap,
            children=children_decls,
            file=where.file,
            line=where.line,
            column=where.column,
            name_where=name_where,
        )

    def _name(
        self, by_key: dict[str, tuple[yaml.Node, yaml.Node]], env: Mapping[str, Any], *, default: str
    ) -> tuple[str, _Where | None]:
        if "name" not in by_key:
            return default, None
        name_node = by_key["name"][1]
        replaced = self.substitute(name_node, env)
        if replaced is None:
            return default, None
        if isinstance(replaced, _Unknown):
            return f"<{name_node.value}>", _Where.of(name_node)
        name = self.string(replaced, "'name'")
        return (name, _Where.of(replaced)) if name is not None else (default, None)

    def _check_arity(
        self,
        spec: NodeSpec,
        node: yaml.Node,
        by_key: dict[str, tuple[yaml.Node, yaml.Node]],
        children: list[NodeDecl] | None,
    ) -> None:
        if children is None:
            return
        count = len(children)
        at = by_key["children"][0] if "children" in by_key else node
        if spec.arity == "none" and "children" in by_key:
            self.error(at, f"node type '{spec.type_name}' is a leaf and takes no children, got {count}")
        elif spec.arity == "one" and count != 1:
            self.error(
                at, f"node type '{spec.type_name}' is a decorator and takes exactly 1 child, got {count}"
            )
        elif spec.arity == "many" and count == 0:
            self.error(at, f"node type '{spec.type_name}' is a composite and needs at least 1 child, got 0")

    def _params(
        self,
        spec: NodeSpec,
        node: yaml.Node,
        entry: tuple[yaml.Node, yaml.Node] | None,
        env: Mapping[str, Any],
        child_names: list[str] | None,
    ) -> dict[str, Any] | None:
        """Validated parameters, defaults filled in; the cross-check runs only when the children are valid."""
        given: dict[str, tuple[yaml.Node, Any]] = {}
        ok = True
        if entry is not None:
            items = self.mapping(entry[1], f"'params' of '{spec.type_name}'")
            if items is None:
                return None
            for key, key_node, value_node in items:
                param = spec.params.get(key)
                if param is None:
                    hint = did_you_mean(key, spec.params)
                    suggestion = f" (did you mean '{hint}'?)" if hint else ""
                    expected = ", ".join(spec.params) if spec.params else "none"
                    self.error(
                        key_node,
                        f"unknown parameter '{key}' for node type '{spec.type_name}'{suggestion}; "
                        f"expected: {expected}",
                    )
                    ok = False
                    continue
                replaced = self.substitute(value_node, env)
                if replaced is None:
                    ok = False
                    given[key] = (value_node, None)  # reported; not also "missing"
                    continue
                value, valid = self.check_value(param, replaced, f"parameter '{key}' of '{spec.type_name}'")
                ok = ok and valid
                given[key] = (value_node, value)
        values: dict[str, Any] = {}
        for key, param in spec.params.items():
            if key in given:
                values[key] = given[key][1]
            elif param.required:
                self.error(
                    node,
                    f"missing required parameter '{key}' for node type '{spec.type_name}'; "
                    f"expected {param.describe()} ({param.doc})",
                )
                ok = False
            else:
                values[key] = param.default
        if not ok:
            return None
        checkable = child_names is not None and not any(isinstance(v, _Unknown) for v in values.values())
        if spec.cross_check is not None and checkable and child_names is not None:
            for problem_key, problem in spec.cross_check(values, child_names):
                at = (
                    given[problem_key][0]
                    if problem_key in given
                    else (entry[0] if entry is not None else node)
                )
                self.error(at, f"node type '{spec.type_name}': {problem}")
                ok = False
        return values if ok else None

    def _remap(
        self, spec: NodeSpec, entry: tuple[yaml.Node, yaml.Node] | None, env: Mapping[str, Any]
    ) -> dict[str, str] | None:
        if entry is None:
            return {}
        items = self.mapping(entry[1], f"'remap' of '{spec.type_name}'")
        if items is None:
            return None
        remap: dict[str, str] = {}
        ok = True
        for key, key_node, value_node in items:
            if key not in spec.blackboard_keys:
                if not spec.blackboard_keys:
                    self.error(
                        key_node,
                        f"bad remap: node type '{spec.type_name}' declares no blackboard keys to remap "
                        f"(got '{key}')",
                    )
                else:
                    hint = did_you_mean(key, spec.blackboard_keys)
                    suggestion = f" (did you mean '{hint}'?)" if hint else ""
                    self.error(
                        key_node,
                        f"bad remap: '{key}' is not a blackboard key of node type '{spec.type_name}'"
                        f"{suggestion}; its keys: {', '.join(spec.blackboard_keys)}",
                    )
                ok = False
                continue
            replaced = self.substitute(value_node, env)
            if replaced is None:
                ok = False
                continue
            if isinstance(replaced, _Unknown):
                remap[key] = f"<{replaced.parameter}>"
                continue
            target, valid = self.value(replaced)
            known = self.registry.board_keys
            if not valid:
                ok = False
            elif not isinstance(target, str) or not BLACKBOARD_KEY_PATTERN.fullmatch(target) or "." in target:
                self.error(
                    replaced,
                    f"bad remap: target of '{key}' must be a blackboard key like 'name' or '/ns/name', "
                    f"got {target!r}",
                )
                ok = False
            elif known is not None and target.lstrip("/") not in known:
                hint = did_you_mean(target, known)
                suggestion = f" (did you mean '{hint}'?)" if hint else ""
                self.error(
                    replaced,
                    f"bad remap: target '{target}' of '{key}' is not a key of the blackboard schema"
                    f"{suggestion}",
                )
                ok = False
            else:
                remap[key] = target
        return remap if ok else None

    def _include(
        self,
        node: yaml.Node,
        items: list[tuple[str, yaml.Node, yaml.Node]],
        file: Path,
        env: Mapping[str, yaml.Node | _Unknown],
        stack: tuple[Path, ...],
    ) -> NodeDecl | None:
        by_key = {key: (key_node, value_node) for key, key_node, value_node in items}
        for key, key_node, _ in items:
            if key not in INCLUDE_KEYS:
                self.unknown_key(key, key_node, INCLUDE_KEYS, "an include node")
        include_node = by_key["include"][1]
        relative = self.string(include_node, "'include'")
        if relative is None:
            return None
        if not relative.endswith(SUBTREE_SUFFIXES):
            self.error(
                include_node,
                f"'include' must name a YAML file ({', '.join(SUBTREE_SUFFIXES)}), got '{relative}'",
            )
            return None
        path = file.parent / relative
        display = os.path.normpath(str(path))
        resolved = path.resolve()
        if resolved in stack:
            chain = [os.path.basename(str(p)) for p in stack[stack.index(resolved) :]] + [
                os.path.basename(display)
            ]
            self.error(include_node, f"include cycle: {' -> '.join(chain)}")
            return None
        root = self.compose(path, display, at=include_node)
        if root is None:
            return None
        file_items = self.mapping(root, "a subtree file")
        if file_items is None:
            return None
        sections = self._sections(file_items, display, root, is_subtree=True)
        declared = self._parameters(sections.get("parameters"))
        if declared is None or "tree" not in sections:
            return None
        sub_env = self._arguments(declared, by_key.get("args"), node, env, relative)
        if sub_env is None:
            return None
        decl = self.node(sections["tree"], path, sub_env, (*stack, resolved))
        if decl is None:
            return None
        site = str(_Where.of(include_node))
        for inner in decl.walk():
            inner.included_at = (site, *inner.included_at)
        if "name" in by_key:
            name, name_where = self._name(by_key, env, default=decl.name)
            decl.name, decl.name_where = name, name_where
        return decl

    def _arguments(
        self,
        declared: dict[str, _SubtreeParam],
        entry: tuple[yaml.Node, yaml.Node] | None,
        include: yaml.Node,
        env: Mapping[str, yaml.Node | _Unknown],
        relative: str,
    ) -> dict[str, yaml.Node | _Unknown] | None:
        values: dict[str, yaml.Node | _Unknown] = {}
        ok = True
        if entry is not None:
            items = self.mapping(entry[1], "'args'")
            if items is None:
                return None
            for key, key_node, value_node in items:
                if key not in declared:
                    hint = did_you_mean(key, declared)
                    suggestion = f" (did you mean '{hint}'?)" if hint else ""
                    listing = ", ".join(declared) if declared else "none"
                    self.error(
                        key_node,
                        f"unknown argument '{key}' for subtree '{relative}'{suggestion}; its parameters: {listing}",
                    )
                    ok = False
                    continue
                replaced = self.substitute(value_node, env)
                if replaced is None:
                    ok = False
                    continue
                _, valid = self.check_value(
                    ParamSpec(declared[key].kind, doc=""),  # type: ignore[arg-type]
                    replaced,
                    f"argument '{key}' of subtree '{relative}'",
                )
                if valid:
                    values[key] = replaced
                ok = ok and valid
        for key, parameter in declared.items():
            if key in values:
                continue
            if parameter.default is None:
                self.error(
                    include,
                    f"missing argument '{key}' for subtree '{relative}' (a {parameter.kind} without default)",
                )
                ok = False
            else:
                values[key] = parameter.default
        return values if ok else None

    def _check_unique_names(self, root: NodeDecl) -> None:
        first: dict[str, NodeDecl] = {}
        for decl in root.walk():
            if decl.name in first:
                previous = first[decl.name]
                where = decl.name_where or _Where(decl.file, decl.line, decl.column)
                earlier = str(previous.name_where or _Where(previous.file, previous.line, previous.column))
                if previous.included_at:
                    earlier += f" included at {' <- '.join(reversed(previous.included_at))}"
                here = (
                    f" (this one included at {' <- '.join(reversed(decl.included_at))})"
                    if decl.included_at
                    else ""
                )
                self.error(
                    where,
                    f"duplicate node name '{decl.name}'{here}, first used at {earlier}; names must be unique "
                    "in a tree: set 'name' on one of them (in a subtree included twice, build names from a "
                    'parameter, e.g. name: "Plan ${prefix}")',
                )
            else:
                first[decl.name] = decl


def _env(declared: Mapping[str, _SubtreeParam]) -> dict[str, yaml.Node | _Unknown]:
    """The argument environment of a file checked on its own: defaults, or unknowns of the declared kind."""
    return {
        key: value.default if value.default is not None else _Unknown(value.kind, key)
        for key, value in declared.items()
    }


def _dedupe(errors: list[TreeError]) -> list[TreeError]:
    """Drop repeats (a subtree included twice reports its own problems once), keeping order."""
    return list(dict.fromkeys(errors))


# ---------------------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------------------


def analyse_mission(
    path: str | Path, registry: NodeRegistry | None = None
) -> tuple[MissionSettings | None, NodeDecl | None, list[TreeError]]:
    """Read and validate a mission (or subtree) file and its includes without building anything.

    Returns:
        ``(settings, root declaration, errors)``; the declaration is complete only when errors is empty.
    """
    checker = _Checker(registry if registry is not None else default_registry())
    analysis = checker.top_level(Path(path))
    return analysis.settings, analysis.root, _dedupe(analysis.errors)


def validate_mission(path: str | Path, registry: NodeRegistry | None = None) -> list[TreeError]:
    """Every problem in a mission file and the subtrees it includes (empty when it is valid)."""
    return analyse_mission(path, registry)[2]


def build_tree(decl: NodeDecl, registry: NodeRegistry, context: BuildContext) -> py_trees.behaviour.Behaviour:
    """Build py_trees behaviours from a validated declaration, children first.

    Raises:
        MissionLoadError: when a factory fails (located at the node that failed).
    """
    children = [build_tree(child, registry, context) for child in decl.children]
    spec = registry.get(decl.type_name)
    where = _Where(decl.file, decl.line, decl.column)
    if spec is None:
        raise MissionLoadError([where.error(f"unknown node type '{decl.type_name}'")])
    params = {
        key: (spec.params[key].convert(value) if spec.params[key].convert else value)  # type: ignore[misc]
        for key, value in decl.params.items()
    }
    try:
        return spec.factory(
            name=decl.name, params=params, children=children, context=context, remap=dict(decl.remap)
        )
    except Exception as exc:  # a factory's failure, whatever it is, must name the node that failed
        raise MissionLoadError(
            [where.error(f"cannot build node '{decl.name}' of type '{decl.type_name}': {exc}")]
        ) from exc


def parse_mission(path: str | Path, registry: NodeRegistry | None = None) -> MissionDocument:
    """Read and validate a mission file and its includes once, building nothing.

    Raises:
        MissionLoadError: listing every problem (file, line, column).
    """
    settings, decl, errors = analyse_mission(path, registry)
    if errors or settings is None or decl is None:
        raise MissionLoadError(errors or [TreeError(str(path), 1, 1, "no tree")])
    return MissionDocument(settings=settings, declaration=decl, source=Path(path))


def load_mission(
    mission: str | Path | MissionDocument, *, registry: NodeRegistry | None = None, context: BuildContext
) -> Mission:
    """Build the py_trees tree of a mission (parsed first when given a path) with ``context``.

    The factories see ``context.config`` as it is: the mission's own ``config:`` section is one layer of
    the configuration the application resolves before building (``semexp_bt.app.configuration``).

    Raises:
        MissionLoadError: listing every problem, before anything is built.
    """
    registry = registry if registry is not None else default_registry()
    document = mission if isinstance(mission, MissionDocument) else parse_mission(mission, registry)
    root = build_tree(document.declaration, registry, context)
    return Mission(
        settings=document.settings,
        root=root,
        config=context.config,
        source=document.source,
        declaration=document.declaration,
    )
