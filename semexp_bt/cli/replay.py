"""``semexp-bt replay TICKS.jsonl``: print a per-tick record back (what changed, tick by tick)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("record", type=Path, help="a per-tick record written by `semexp-bt run --record`")
    parser.add_argument("--all", action="store_true", help="print every node on every tick, not only changes")


def run(args: argparse.Namespace) -> int:
    from semexp_bt.app.recorder import replay

    ticks = replay(args.record, only_changes=not args.all)
    print(f"{ticks} ticks")
    return 0
