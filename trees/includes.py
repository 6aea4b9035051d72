"""Reading a mission's files: the top-level file, its includes (each read once), cycles, sections, arguments.

Every file goes through the one safe reader (``semexp_bt.files.yaml_source``). An include must name a ``.yaml`` or
``.yml`` file, relative to the including file, whose resolved path (symlinks followed) lies inside the
include roots: the folder of the mission file the user named, and the product's own ``trees/`` folder (so a
mission anywhere may include the shipped subtrees). An include cycle, a chain deeper than
:data:`~trees.declarations.MAX_INCLUDE_DEPTH`, and a missing file, a directory, a device, a FIFO or a
symlink loop are errors at the include, never a hang.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import yaml

from behaviours.spec import ParamSpec
from semexp_bt.files.yaml_source import YamlSourceError, compose_yaml_file, shorten
from trees.declarations import (
    FILE_KEYS,
    INCLUDE_KEYS,
    MAX_INCLUDE_DEPTH,
    SUBTREE_PARAMETER_KEYS,
    SUBTREE_PARAMETER_KINDS,
    SUBTREE_SUFFIXES,
    TreeError,
)
from trees.reporting import Item, Reporter, hint
from trees.substitution import Environment, Substitution, Unknown

#: The product's own mission trees: every mission may include the subtrees shipped there.
SHIPPED_TREES = Path(__file__).resolve().parent


@dataclass
class SubtreeParam:
    """One declared subtree parameter: its kind and its default's node (``None``: none given)."""

    kind: str
    default: yaml.Node | None


@dataclass
class OpenedSubtree:
    """An include, resolved and read: the subtree's root node and the arguments it is checked with."""

    tree: yaml.Node
    path: Path
    identity: Path
    env: dict[str, yaml.Node | Unknown]
    relative: str


def identity(path: Path) -> Path:
    """The path a file is known by for caching and cycles (symlinks resolved; never raises on a loop)."""
    return Path(os.path.realpath(path))


def defaults_env(declared: Mapping[str, SubtreeParam]) -> dict[str, yaml.Node | Unknown]:
    """The arguments of a file checked on its own: defaults, or unknowns of the declared kind."""
    return {
        key: value.default if value.default is not None else Unknown(value.kind, key)
        for key, value in declared.items()
    }


class Includes:
    """The files of one mission check, each composed once; problems go to the shared reporter."""

    def __init__(self, reporter: Reporter, substitution: Substitution, mission_file: Path) -> None:
        self.reporter = reporter
        self.substitution = substitution
        self.roots = (identity(mission_file.parent), SHIPPED_TREES)
        self._composed: dict[Path, yaml.Node | None] = {}

    # -- files ----------------------------------------------------------------------------------------

    def read_mission_file(self, path: Path) -> yaml.Node | None:
        """The root node of the file the user named (it may be anywhere), or ``None`` after reporting."""
        return self._compose(path, os.path.normpath(str(path)), roots=None, at=None, what="mission file")

    def _compose(
        self, path: Path, display: str, *, roots: tuple[Path, ...] | None, at: yaml.Node | None, what: str
    ) -> yaml.Node | None:
        key = identity(path)
        if key in self._composed:
            return self._composed[key]
        root: yaml.Node | None = None
        try:
            root = compose_yaml_file(path, display=display, roots=roots)
        except YamlSourceError as exc:
            self._report_refusal(exc, at, what)
        else:
            if root is None:
                self.reporter.add(
                    TreeError(display, 1, 1, "file is empty; expected a mapping with a 'tree' key")
                )
        self._composed[key] = root
        return root

    def _report_refusal(self, exc: YamlSourceError, at: yaml.Node | None, what: str) -> None:
        if exc.is_whole_file and at is not None:  # say it where the include names the file
            self.reporter.error(at, f"{what} {exc.message}: {shorten(at.value)} (looked for {exc.file})")
            return
        if exc.is_whole_file:
            self.reporter.add(TreeError(exc.file, 1, 1, f"{what} {exc.message}"))
            return
        message = exc.message
        if "${" in exc.excerpt and message.startswith("YAML syntax error"):
            # `{a: ${x}}` is invalid YAML: braces are flow indicators.
            message += '; quote substitutions inside {...} or [...], e.g. {a: "${x}"}'
        self.reporter.refused(YamlSourceError(exc.file, message, exc.line, exc.column))

    # -- sections of a file ---------------------------------------------------------------------------

    def sections(self, items: list[Item], root: yaml.Node, *, is_subtree: bool) -> dict[str, yaml.Node]:
        """The top-level sections of a file by key (unknown keys and a subtree's ``mission`` reported)."""
        sections: dict[str, yaml.Node] = {}
        for key, key_node, value_node in items:
            if key not in FILE_KEYS:
                what = "a subtree file" if is_subtree else "a mission file"
                self.reporter.unknown_key(key, key_node, FILE_KEYS, what)
            elif key == "mission" and is_subtree:
                self.reporter.error(
                    key_node,
                    "a subtree file must not have a 'mission' section; mission settings belong "
                    "in the top-level file",
                )
            else:
                sections[key] = value_node
        if "tree" not in sections:
            self.reporter.error(root, "missing key 'tree' (the root node of the tree)")
        return sections

    def parameters(self, node: yaml.Node | None) -> dict[str, SubtreeParam] | None:
        """Declared subtree parameters (``None`` after reporting that the section is not a mapping)."""
        declared: dict[str, SubtreeParam] = {}
        if node is None:
            return declared
        items = self.reporter.mapping(node, "'parameters'")
        if items is None:
            return None
        for name, key_node, spec_node in items:
            if not name.isidentifier():
                self.reporter.error(key_node, f"subtree parameter name {shorten(name)} must be an identifier")
                continue
            parameter = self._parameter(name, spec_node)
            if parameter is not None:
                declared[name] = parameter
        return declared

    def _parameter(self, name: str, spec_node: yaml.Node) -> SubtreeParam | None:
        fields = self.reporter.mapping(spec_node, f"subtree parameter '{name}'")
        if fields is None:
            return None
        kind: str | None = None
        default: yaml.Node | None = None
        for key, field_key, field_value in fields:
            if key not in SUBTREE_PARAMETER_KEYS:
                self.reporter.unknown_key(
                    key, field_key, SUBTREE_PARAMETER_KEYS, f"subtree parameter '{name}'"
                )
            elif key == "type":
                kind = self.reporter.string(field_value, f"type of subtree parameter '{name}'")
                if kind is not None and kind not in SUBTREE_PARAMETER_KINDS:
                    self.reporter.error(
                        field_value,
                        f"type of subtree parameter '{name}' must be one of "
                        f"{', '.join(SUBTREE_PARAMETER_KINDS)}, got {shorten(kind)}",
                    )
                    kind = None
            elif key == "default":
                default = field_value
        if kind is None:
            if not any(k == "type" for k, _, _ in fields):
                self.reporter.error(spec_node, f"subtree parameter '{name}' needs a 'type'")
            return None
        if default is not None:
            kind_spec = ParamSpec(kind, doc="")  # type: ignore[arg-type]  # kind checked above
            if not self.substitution.check_value(
                kind_spec, default, f"default of subtree parameter '{name}'"
            )[1]:
                return None
        return SubtreeParam(kind, default)

    # -- includes -------------------------------------------------------------------------------------

    def open(
        self, node: yaml.Node, items: list[Item], file: Path, env: Environment, stack: tuple[Path, ...]
    ) -> OpenedSubtree | None:
        """Resolve and read the subtree an include node names; ``None`` after reporting why not.

        Args:
            node: the include node.
            items: its keys.
            file: the including file.
            env: the including file's arguments (an include's ``args`` may use them).
            stack: the identities of the files being included, outermost first (for cycles).
        """
        by_key = {key: (key_node, value_node) for key, key_node, value_node in items}
        for key, key_node, _ in items:
            if key not in INCLUDE_KEYS:
                self.reporter.unknown_key(key, key_node, INCLUDE_KEYS, "an include node")
        include_node = by_key["include"][1]
        relative = self.reporter.string(include_node, "'include'")
        if relative is None:
            return None
        if not relative.endswith(SUBTREE_SUFFIXES):
            self.reporter.error(
                include_node,
                f"'include' must name a YAML file ({', '.join(SUBTREE_SUFFIXES)}), got {shorten(relative)}",
            )
            return None
        path = file.parent / relative
        display = os.path.normpath(str(path))
        known_as = identity(path)
        if known_as in stack:
            chain = [p.name for p in stack[stack.index(known_as) :]] + [os.path.basename(display)]
            self.reporter.error(include_node, f"include cycle: {' -> '.join(chain)}")
            return None
        if len(stack) > MAX_INCLUDE_DEPTH:
            self.reporter.error(
                include_node, f"includes nested deeper than {MAX_INCLUDE_DEPTH} files (the loader's cap)"
            )
            return None
        root = self._compose(path, display, roots=self.roots, at=include_node, what="subtree file")
        if root is None:
            return None
        file_items = self.reporter.mapping(root, "a subtree file")
        if file_items is None:
            return None
        sections = self.sections(file_items, root, is_subtree=True)
        declared = self.parameters(sections.get("parameters"))
        if declared is None or "tree" not in sections:
            return None
        sub_env = self._arguments(declared, by_key.get("args"), node, env, relative)
        if sub_env is None:
            return None
        return OpenedSubtree(sections["tree"], path, known_as, sub_env, relative)

    def _arguments(
        self,
        declared: dict[str, SubtreeParam],
        entry: tuple[yaml.Node, yaml.Node] | None,
        include: yaml.Node,
        env: Environment,
        relative: str,
    ) -> dict[str, yaml.Node | Unknown] | None:
        values: dict[str, yaml.Node | Unknown] = {}
        ok = True
        if entry is not None:
            items = self.reporter.mapping(entry[1], "'args'")
            if items is None:
                return None
            for key, key_node, value_node in items:
                if key not in declared:
                    listing = ", ".join(declared) if declared else "none"
                    self.reporter.error(
                        key_node,
                        f"unknown argument {shorten(key)} for subtree '{relative}'{hint(key, declared)}; "
                        f"its parameters: {listing}",
                    )
                    ok = False
                    continue
                replaced = self.substitution.substitute(value_node, env)
                if replaced is None:
                    ok = False
                    continue
                _, valid = self.substitution.check_value(
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
                self.reporter.error(
                    include,
                    f"missing argument '{key}' for subtree '{relative}' (a {parameter.kind} without default)",
                )
                ok = False
            else:
                values[key] = parameter.default
        return values if ok else None
