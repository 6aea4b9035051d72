"""``semexp-bt tree``: check mission files, show a tree, generate the node reference.

A problem in a mission file is one line, ``file:line:column: message``, and exit status 2 (``check``
prints every problem of every file on stdout, its report; ``show`` prints them on stderr).

Examples:
    semexp-bt tree check trees/*.yaml trees/subtrees/*.yaml
    semexp-bt tree show trees/object_search.yaml
    semexp-bt tree docs --out docs/node_reference.md
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from semexp_bt.app.executive import RUNNER_KEYS
from semexp_bt.cli.arguments import output_file
from trees.docs_gen import node_reference_markdown
from trees.loader import MissionSettings, NodeDecl, analyse_mission, validate_mission
from trees.registry import NodeRegistry, default_registry

#: Exit status when a mission file has problems (as for any bad input on the command line).
EXIT_INVALID = 2

#: py_trees' ascii symbols, so `tree show` reads like py_trees.display.ascii_tree.
_SYMBOLS = {
    ("Sequence", True): "{-}",
    ("Sequence", False): "[-]",
    ("Selector", True): "{o}",
    ("Selector", False): "[o]",
    "Parallel": "/_/",
    "composite": "[+]",
    "decorator": "-^-",
    "behaviour": "-->",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="tree_command", metavar="ACTION")
    sub.required = True
    check = sub.add_parser("check", help="validate mission/subtree files; print 'ok' or every error")
    check.add_argument("files", nargs="+", type=Path, metavar="FILE")
    show = sub.add_parser("show", help="print a mission tree with node types and parameters")
    show.add_argument("file", type=Path, metavar="FILE")
    docs = sub.add_parser("docs", help="write the node reference (markdown) generated from the registry")
    docs.add_argument("--out", type=output_file, default=None, help="output file (default: stdout)")


def run(args: argparse.Namespace) -> int:
    registry = default_registry()
    if args.tree_command == "check":
        return _check(args.files, registry)
    if args.tree_command == "show":
        return _show(args.file, registry)
    return _docs(args.out, registry)


def _check(files: list[Path], registry: NodeRegistry) -> int:
    failed = False
    for path in files:
        errors = validate_mission(path, registry)
        if errors:
            failed = True
            for error in errors:
                print(error)
        else:
            print(f"{path}: ok")
    return EXIT_INVALID if failed else 0


def _show(path: Path, registry: NodeRegistry) -> int:
    settings, root, errors = analyse_mission(path, registry)
    if errors or root is None or settings is None:
        for error in errors:
            print(error, file=sys.stderr)
        return EXIT_INVALID
    print(render_settings(settings))
    print(render_tree(root, registry))
    return 0


def node_reference(registry: NodeRegistry) -> str:
    """``docs/node_reference.md``: the registry's node types, and the blackboard keys with their writers
    (the runner's initial board among them)."""
    return node_reference_markdown(registry, other_writers={"runner": RUNNER_KEYS})


def _docs(out: Path | None, registry: NodeRegistry) -> int:
    text = node_reference(registry)
    if out is None:
        sys.stdout.write(text)
    else:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
        print(f"wrote {out} ({len(list(registry))} node types)")
    return 0


def _format_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value if value and " " not in value else repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_format_value(v) for v in value) + "]"
    return repr(value)


def render_settings(settings: MissionSettings) -> str:
    """One line per mission setting."""
    lines = [f"mission {settings.name}"]
    if settings.instruction:
        lines.append(f"  instruction: {settings.instruction}")
    lines.append(
        f"  robot: {settings.robot}  backend: {settings.backend}  fidelity: {settings.fidelity}  "
        f"budget_s: {settings.budget_s:g}"
    )
    if settings.config_overrides:
        lines.append(f"  config: {settings.config_overrides}")
    return "\n".join(lines)


def render_tree(root: NodeDecl, registry: NodeRegistry) -> str:
    """The declared tree as ascii art: symbol, name, type, parameters and remaps of every node."""
    lines: list[str] = []

    def visit(decl: NodeDecl, depth: int) -> None:
        spec = registry.get(decl.type_name)
        group = spec.group if spec is not None else "behaviour"
        symbol = _SYMBOLS.get((decl.type_name, bool(decl.params.get("memory"))))
        symbol = symbol or _SYMBOLS.get(decl.type_name) or _SYMBOLS[group]
        details = [decl.type_name] + [f"{k}={_format_value(v)}" for k, v in decl.params.items()]
        details += [f"{k}->{v}" for k, v in decl.remap.items()]
        lines.append(f"{'    ' * depth}{symbol} {decl.name} ({', '.join(details)})")
        for child in decl.children:
            visit(child, depth + 1)

    visit(root, 0)
    return "\n".join(lines)
