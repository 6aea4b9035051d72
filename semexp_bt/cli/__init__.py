"""The ``semexp-bt`` console command: one module per subcommand.

May import: everything (it is the top layer).

Each subcommand lives in its own module that exposes ``add_arguments(parser)`` and ``run(args) -> int``;
modules are imported only when their subcommand runs, so ``semexp-bt --help`` stays fast and a broken
optional backend cannot break unrelated commands.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from semexp_bt.app.process_heap import keep_freed_memory
from semexp_bt.cli.arguments import OneLineArgumentParser

#: subcommand -> (module, one-line help). Modules are listed once, here.
COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("semexp_bt.cli.run", "run one mission tree on a robot backend"),
    "perceive": (
        "semexp_bt.cli.perceive",
        "run the configured real models and the arbitration on one picture",
    ),
    "replay": ("semexp_bt.cli.replay", "print a per-tick record back"),
    "view": ("semexp_bt.cli.view", "replay a saved mission view in the browser"),
    "export": ("semexp_bt.cli.export", "export a saved mission view as MCAP (ROS 2 messages)"),
    "tree": ("semexp_bt.cli.tree", "validate (check) or print (show) a mission tree"),
    "scene": ("semexp_bt.cli.scene", "list scenes or render one"),
    "bench": ("semexp_bt.cli.bench", "benchmarks: core, ..."),
    "gait": ("semexp_bt.cli.gait", "train or inspect the RL gait"),
    "sim-bridge": (
        "semexp_bt.cli.sim_bridge",
        "serve a simulated episode on ROS 2 topics (the Go1 driver's)",
    ),
}


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog="semexp-bt", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, (module, help_text) in COMMANDS.items():
        sp = sub.add_parser(name, help=help_text)
        sp.set_defaults(_module=module)
        # Arguments are added lazily: only the chosen subcommand's module is imported.
        sp.set_defaults(_needs_args=True)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        parser.parse_args(argv)  # prints help or the usage error and exits
        return 2
    name = argv[0]
    keep_freed_memory()
    module = importlib.import_module(COMMANDS[name][0])
    # Usage errors are one line and exit status 2 (semexp_bt.cli.arguments), in every subcommand.
    sub_parser = OneLineArgumentParser(prog=f"semexp-bt {name}", description=COMMANDS[name][1])
    module.add_arguments(sub_parser)
    try:
        args = sub_parser.parse_args(argv[1:])
    except SystemExit as stop:  # --help (0) or a bad value (2, its one line already printed)
        return stop.code if isinstance(stop.code, int) else 2
    return int(module.run(args) or 0)


if __name__ == "__main__":
    raise SystemExit(main())
