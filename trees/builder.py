"""Building py_trees behaviours from a validated declaration tree (``trees.loader`` checks it first)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import py_trees

from behaviours.spec import BuildContext
from semexp_bt.core.config import SemExpConfig
from trees.declarations import MissionLoadError, MissionSettings, NodeDecl, Where
from trees.registry import NodeRegistry


@dataclass
class Mission:
    """A built mission: its settings, the py_trees root, and the config its factories saw."""

    settings: MissionSettings
    root: py_trees.behaviour.Behaviour
    config: SemExpConfig
    source: Path
    declaration: NodeDecl


def build_tree(decl: NodeDecl, registry: NodeRegistry, context: BuildContext) -> py_trees.behaviour.Behaviour:
    """Build py_trees behaviours from a validated declaration, children first.

    The recursion is one frame per tree level; the checker caps the depth (``MAX_TREE_DEPTH``).

    Raises:
        MissionLoadError: when a factory fails (located at the node that failed).
    """
    children = [build_tree(child, registry, context) for child in decl.children]
    spec = registry.get(decl.type_name)
    where = Where(decl.file, decl.line, decl.column)
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
