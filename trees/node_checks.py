"""Checking a mission's nodes against the registry: types, names, arity, parameters, remaps, settings.

:class:`NodeChecker` turns the YAML node of a tree into :class:`~trees.declarations.NodeDecl` (expanding
includes through :class:`~trees.includes.Includes`), reporting every problem at the node that caused it.
A tree deeper than :data:`~trees.declarations.MAX_TREE_DEPTH` or larger than
:data:`~trees.declarations.MAX_TREE_NODES` (includes expanded) is refused; the latter stops the check.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from behaviours.spec import BLACKBOARD_KEY_PATTERN
from semexp_bt.core.config import ConfigError, config_from_dict
from semexp_bt.files.yaml_source import shorten
from trees.declarations import (
    CONFIG_KEY,
    MAX_TREE_DEPTH,
    MAX_TREE_NODES,
    MISSION_SETTINGS,
    NODE_KEYS,
    MissionSettings,
    NodeDecl,
    Where,
)
from trees.includes import Includes
from trees.registry import NodeRegistry, NodeSpec, did_you_mean
from trees.reporting import CheckStopped, Item, Reporter, hint, kind_of
from trees.substitution import Environment, Substitution, Unknown

#: A key's node and its value's node.
Entry = tuple[yaml.Node, yaml.Node]


class NodeChecker:
    """Checks tree nodes (and the ``mission:`` section) of one mission; problems go to ``reporter``."""

    def __init__(
        self, registry: NodeRegistry, reporter: Reporter, substitution: Substitution, includes: Includes
    ) -> None:
        self.registry = registry
        self.reporter = reporter
        self.substitution = substitution
        self.includes = includes
        self.nodes_checked = 0

    # -- nodes ----------------------------------------------------------------------------------------

    def node(
        self, node: yaml.Node, file: Path, env: Environment, stack: tuple[Path, ...], depth: int = 1
    ) -> NodeDecl | None:
        """Validate one node (expanding an include) and its children; ``None`` when it has errors.

        Args:
            node: the node's YAML.
            file: the file it is in.
            env: the arguments of that file's parameters.
            stack: the identities of the files being included, outermost first.
            depth: the node's depth in the expanded tree (the root is 1).

        Raises:
            CheckStopped: past :data:`MAX_TREE_NODES` nodes, or past the reporter's error cap.
        """
        if depth > MAX_TREE_DEPTH:
            self.reporter.error(node, f"tree nested deeper than {MAX_TREE_DEPTH} nodes (the loader's cap)")
            return None
        items = self.reporter.mapping(node, "a tree node")
        if items is None:
            return None
        if any(key == "include" for key, _, _ in items):  # the subtree's root takes this node's place
            return self._include(node, items, file, env, stack, depth)
        self.nodes_checked += 1
        if self.nodes_checked > MAX_TREE_NODES:
            self.reporter.error(
                node, f"tree has more than {MAX_TREE_NODES} nodes with includes expanded (the loader's cap)"
            )
            raise CheckStopped
        by_key = {key: (key_node, value_node) for key, key_node, value_node in items}
        misspelt_children = False
        for key, key_node, _ in items:
            if key not in NODE_KEYS:
                self.reporter.unknown_key(key, key_node, NODE_KEYS, "a tree node")
                misspelt_children = misspelt_children or did_you_mean(key, NODE_KEYS) == "children"
        spec = self._spec(node, by_key)
        type_name = spec.type_name if spec is not None else "?"
        name, name_where = self._name(by_key, env, default=type_name)
        children, children_ok = self._children(by_key, file, env, stack, depth)
        if spec is None:
            return None
        if not misspelt_children:  # one mistake, one message: "childern" is not also "no children"
            self._check_arity(spec, node, by_key, children if children_ok else None)
        child_names = [c.name for c in children] if children_ok else None
        params = self._params(spec, node, by_key.get("params"), env, child_names)
        remap = self._remap(spec, by_key.get("remap"), env)
        if params is None or remap is None or not children_ok:
            return None
        where = Where.of(node)
        return NodeDecl(
            type_name=spec.type_name,
            name=name,
            params=params,
            remap=remap,
            children=children,
            file=where.file,
            line=where.line,
            column=where.column,
            name_where=name_where,
        )

    def _spec(self, node: yaml.Node, by_key: dict[str, Entry]) -> NodeSpec | None:
        if "type" not in by_key:
            self.reporter.error(node, "a tree node needs 'type' (a node type) or 'include' (a subtree file)")
            return None
        type_node = by_key["type"][1]
        type_name = self.reporter.string(type_node, "'type'")
        if type_name is None:
            return None
        spec = self.registry.get(type_name)
        if spec is None:
            close = self.registry.suggest(type_name) if len(type_name) <= 100 else None
            suggestion = f" (did you mean '{close}'?)" if close else ""
            self.reporter.error(type_node, f"unknown node type {shorten(type_name)}{suggestion}")
        return spec

    def _children(
        self, by_key: dict[str, Entry], file: Path, env: Environment, stack: tuple[Path, ...], depth: int
    ) -> tuple[list[NodeDecl], bool]:
        if "children" not in by_key:
            return [], True
        children_node = by_key["children"][1]
        if not isinstance(children_node, yaml.SequenceNode):
            self.reporter.error(
                children_node, f"'children' must be a list of tree nodes, got {kind_of(children_node)}"
            )
            return [], False
        children: list[NodeDecl] = []
        ok = True
        for child_node in children_node.value:
            child = self.node(child_node, file, env, stack, depth + 1)
            if child is None:
                ok = False
            else:
                children.append(child)
        return children, ok

    def _include(
        self,
        node: yaml.Node,
        items: list[Item],
        file: Path,
        env: Environment,
        stack: tuple[Path, ...],
        depth: int,
    ) -> NodeDecl | None:
        opened = self.includes.open(node, items, file, env, stack)
        if opened is None:
            return None
        decl = self.node(opened.tree, opened.path, opened.env, (*stack, opened.identity), depth)
        if decl is None:
            return None
        include_node = next(value for key, _, value in items if key == "include")
        site = str(Where.of(include_node))
        for inner in decl.walk():
            inner.included_at = (site, *inner.included_at)
        by_key = {key: (key_node, value_node) for key, key_node, value_node in items}
        if "name" in by_key:
            decl.name, decl.name_where = self._name(by_key, env, default=decl.name)
        return decl

    def _name(self, by_key: dict[str, Entry], env: Environment, *, default: str) -> tuple[str, Where | None]:
        if "name" not in by_key:
            return default, None
        name_node = by_key["name"][1]
        replaced = self.substitution.substitute(name_node, env)
        if replaced is None:
            return default, None
        if isinstance(replaced, Unknown):
            return f"<{name_node.value}>", Where.of(name_node)
        name = self.reporter.string(replaced, "'name'")
        return (name, Where.of(replaced)) if name is not None else (default, None)

    def _check_arity(
        self, spec: NodeSpec, node: yaml.Node, by_key: dict[str, Entry], children: list[NodeDecl] | None
    ) -> None:
        if children is None:
            return
        count = len(children)
        at = by_key["children"][0] if "children" in by_key else node
        if spec.arity == "none" and "children" in by_key:
            self.reporter.error(
                at, f"node type '{spec.type_name}' is a leaf and takes no children, got {count}"
            )
        elif spec.arity == "one" and count != 1:
            self.reporter.error(
                at, f"node type '{spec.type_name}' is a decorator and takes exactly 1 child, got {count}"
            )
        elif spec.arity == "many" and count == 0:
            self.reporter.error(
                at, f"node type '{spec.type_name}' is a composite and needs at least 1 child, got 0"
            )

    # -- parameters and remaps ------------------------------------------------------------------------

    def _params(
        self,
        spec: NodeSpec,
        node: yaml.Node,
        entry: Entry | None,
        env: Environment,
        child_names: list[str] | None,
    ) -> dict[str, Any] | None:
        """Validated parameters, defaults filled in; the cross-check runs only when the children are valid."""
        given: dict[str, tuple[yaml.Node, Any]] = {}
        ok = True
        if entry is not None:
            items = self.reporter.mapping(entry[1], f"'params' of '{spec.type_name}'")
            if items is None:
                return None
            for key, key_node, value_node in items:
                param = spec.params.get(key)
                if param is None:
                    expected = ", ".join(spec.params) if spec.params else "none"
                    self.reporter.error(
                        key_node,
                        f"unknown parameter {shorten(key)} for node type '{spec.type_name}'"
                        f"{hint(key, spec.params)}; expected: {expected}",
                    )
                    ok = False
                    continue
                replaced = self.substitution.substitute(value_node, env)
                if replaced is None:
                    ok = False
                    given[key] = (value_node, None)  # reported; not also "missing"
                    continue
                what = f"parameter '{key}' of '{spec.type_name}'"
                value, valid = self.substitution.check_value(param, replaced, what)
                ok = ok and valid
                given[key] = (value_node, value)
        values: dict[str, Any] = {}
        for key, param in spec.params.items():
            if key in given:
                values[key] = given[key][1]
            elif param.required:
                self.reporter.error(
                    node,
                    f"missing required parameter '{key}' for node type '{spec.type_name}'; "
                    f"expected {param.describe()} ({param.doc})",
                )
                ok = False
            else:
                values[key] = param.default
        if not ok:
            return None
        checkable = child_names is not None and not any(isinstance(v, Unknown) for v in values.values())
        if spec.cross_check is not None and checkable and child_names is not None:
            for problem_key, problem in spec.cross_check(values, child_names):
                at = (
                    given[problem_key][0]
                    if problem_key in given
                    else (entry[0] if entry is not None else node)
                )
                self.reporter.error(at, f"node type '{spec.type_name}': {problem}")
                ok = False
        return values if ok else None

    def _remap(self, spec: NodeSpec, entry: Entry | None, env: Environment) -> dict[str, str] | None:
        if entry is None:
            return {}
        items = self.reporter.mapping(entry[1], f"'remap' of '{spec.type_name}'")
        if items is None:
            return None
        remap: dict[str, str] = {}
        ok = True
        for key, key_node, value_node in items:
            if key not in spec.blackboard_keys:
                self._unknown_remap_key(spec, key, key_node)
                ok = False
                continue
            replaced = self.substitution.substitute(value_node, env)
            if replaced is None:
                ok = False
                continue
            if isinstance(replaced, Unknown):
                remap[key] = f"<{replaced.parameter}>"
                continue
            target, valid = self.reporter.value(replaced)
            known = self.registry.board_keys
            if not valid:
                ok = False
            elif not isinstance(target, str) or not BLACKBOARD_KEY_PATTERN.fullmatch(target) or "." in target:
                self.reporter.error(
                    replaced,
                    f"bad remap: target of '{key}' must be a blackboard key like 'name' or '/ns/name', "
                    f"got {shorten(target)}",
                )
                ok = False
            elif known is not None and target.lstrip("/") not in known:
                self.reporter.error(
                    replaced,
                    f"bad remap: target '{target}' of '{key}' is not a key of the blackboard schema"
                    f"{hint(target, known)}",
                )
                ok = False
            else:
                remap[key] = target
        return remap if ok else None

    def _unknown_remap_key(self, spec: NodeSpec, key: str, key_node: yaml.Node) -> None:
        if not spec.blackboard_keys:
            self.reporter.error(
                key_node,
                f"bad remap: node type '{spec.type_name}' declares no blackboard keys to remap (got {shorten(key)})",
            )
        else:
            self.reporter.error(
                key_node,
                f"bad remap: {shorten(key)} is not a blackboard key of node type '{spec.type_name}'"
                f"{hint(key, spec.blackboard_keys)}; its keys: {', '.join(spec.blackboard_keys)}",
            )

    # -- the whole tree -------------------------------------------------------------------------------

    def check_unique_names(self, root: NodeDecl) -> None:
        """Report every node whose name an earlier node (in depth-first order) already has."""
        first: dict[str, NodeDecl] = {}
        for decl in root.walk():
            if decl.name not in first:
                first[decl.name] = decl
                continue
            previous = first[decl.name]
            where = decl.name_where or Where(decl.file, decl.line, decl.column)
            earlier = str(previous.name_where or Where(previous.file, previous.line, previous.column))
            if previous.included_at:
                earlier += f" included at {' <- '.join(reversed(previous.included_at))}"
            here = (
                f" (this one included at {' <- '.join(reversed(decl.included_at))})"
                if decl.included_at
                else ""
            )
            self.reporter.error(
                where,
                f"duplicate node name {shorten(decl.name)}{here}, first used at {earlier}; names must be unique "
                "in a tree: set 'name' on one of them (in a subtree included twice, build names from a "
                'parameter, e.g. name: "Plan ${prefix}")',
            )

    # -- the mission section --------------------------------------------------------------------------

    def settings(self, node: yaml.Node | None, *, default_name: str) -> MissionSettings:
        """The ``mission:`` section with defaults filled in (invalid settings reported and defaulted)."""
        values: dict[str, Any] = {k: s.default for k, s in MISSION_SETTINGS.items()}
        values["name"] = default_name
        overrides: dict[str, Any] = {}
        if node is not None:
            items = self.reporter.mapping(node, "the 'mission' section") or []
            allowed = (*MISSION_SETTINGS, CONFIG_KEY)
            for key, key_node, value_node in items:
                if key == CONFIG_KEY:
                    overrides = self._config(value_node)
                elif key not in MISSION_SETTINGS:
                    self.reporter.unknown_key(key, key_node, allowed, "the 'mission' section")
                else:
                    value, ok = self.substitution.check_value(
                        MISSION_SETTINGS[key], value_node, f"mission setting '{key}'"
                    )
                    if ok:
                        values[key] = value
                    if key == "instructions" and any(k == "instruction" for k, _, _ in items):
                        self.reporter.error(key_node, "give either 'instruction' or 'instructions', not both")
        return MissionSettings(config_overrides=overrides, **values)

    def _config(self, node: yaml.Node) -> dict[str, Any]:
        value, ok = self.reporter.value(node)
        if not ok:
            return {}
        try:
            config_from_dict(value, where="")
        except ConfigError as exc:
            message = str(exc).removeprefix(": ")
            key_path = re.search(r"'([\w.]+)'", message)
            self.reporter.error(
                _locate(node, key_path.group(1) if key_path else ""), f"config override: {message}"
            )
            return {}
        return dict(value or {})


def _locate(node: yaml.Node, dotted: str) -> yaml.Node:
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
