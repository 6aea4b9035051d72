"""Load a mission tree from YAML: validate the whole file and its includes, then build py_trees.

Two passes. :func:`validate_mission` reads the file and every subtree it includes into plain
declarations (:class:`NodeDecl`) and collects EVERY problem as a :class:`TreeError` with file, line and
column (from ``yaml.compose`` marks). :func:`load_mission` builds behaviours only when that list is
empty, so a mission never starts half-built. The format is specified in ``docs/trees.md``.

The work is split by concept:

- ``semexp_bt.files.yaml_source``: the one safe YAML reader (file type, symlinks, size, UTF-8, tabs, nesting,
  aliases, tags, duplicate keys);
- ``trees.includes``: the mission's files, includes and their cycles, sections, subtree parameters and
  arguments;
- ``trees.substitution``: ``${param}`` substitution and typed checking of substituted values;
- ``trees.node_checks``: node types, names, arity, parameters, remaps and the ``mission:`` section;
- ``trees.builder``: py_trees behaviours from a checked declaration;
- ``trees.declarations``: the format's keys and limits, errors and declarations.

A mission file cannot run code: only plain YAML values are read (no tag constructs an object), an
include reads only a ``.yaml``/``.yml`` file inside the include roots, and nothing is imported or
evaluated.
"""

from __future__ import annotations

from pathlib import Path

from behaviours.spec import BuildContext
from trees.builder import Mission, build_tree
from trees.declarations import (
    FILE_KEYS,
    INCLUDE_KEYS,
    MISSION_SETTINGS,
    NODE_KEYS,
    SUBTREE_PARAMETER_KEYS,
    MissionDocument,
    MissionLoadError,
    MissionSettings,
    NodeDecl,
    TreeError,
)
from trees.includes import Includes, defaults_env, identity
from trees.node_checks import NodeChecker
from trees.registry import NodeRegistry, default_registry
from trees.reporting import CheckStopped, Reporter
from trees.substitution import Substitution

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


def analyse_mission(
    path: str | Path, registry: NodeRegistry | None = None
) -> tuple[MissionSettings | None, NodeDecl | None, list[TreeError]]:
    """Read and validate a mission (or subtree) file and its includes without building anything.

    Returns:
        ``(settings, root declaration, errors)``; the declaration is complete only when errors is empty.
    """
    path = Path(path)
    reporter = Reporter()
    substitution = Substitution(reporter)
    includes = Includes(reporter, substitution, path)
    checker = NodeChecker(
        registry if registry is not None else default_registry(), reporter, substitution, includes
    )
    settings: MissionSettings | None = None
    decl: NodeDecl | None = None
    try:
        root = includes.read_mission_file(path)
        items = reporter.mapping(root, "a mission file") if root is not None else None
        if items is not None and root is not None:
            sections = includes.sections(items, root, is_subtree=False)
            settings = checker.settings(sections.get("mission"), default_name=path.stem)
            # Checked on its own, a subtree's parameters take their defaults; one without a default is
            # unknown, and only its declared type is checked against the parameters it feeds.
            env = defaults_env(includes.parameters(sections.get("parameters")) or {})
            if "tree" in sections:
                decl = checker.node(sections["tree"], path, env, (identity(path),))
            if decl is not None:
                checker.check_unique_names(decl)
    except CheckStopped:
        decl = None
    return settings, decl, reporter.errors


def validate_mission(path: str | Path, registry: NodeRegistry | None = None) -> list[TreeError]:
    """Every problem in a mission file and the subtrees it includes (empty when it is valid)."""
    return analyse_mission(path, registry)[2]


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
