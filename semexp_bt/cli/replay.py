"""``semexp-bt replay TICKS.jsonl``: print a per-tick record back (what changed, tick by tick).

A record cut short by a killed mission replays up to its last whole tick; a torn last line is skipped
and reported. Exit status 2 for a file that is missing or has a damaged line before the last.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from semexp_bt.cli.arguments import print_error


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("record", type=Path, help="a per-tick record written by `semexp-bt run --record`")
    parser.add_argument("--all", action="store_true", help="print every node on every tick, not only changes")


def run(args: argparse.Namespace) -> int:
    from semexp_bt.app.recorder import RecordError, replay

    try:
        ticks = replay(args.record, only_changes=not args.all)
    except RecordError as exc:
        print_error(str(exc))
        return 2
    except OSError as exc:
        print_error(f"{args.record}: cannot read the record: {exc.strerror}")
        return 2
    print(f"{ticks} ticks")
    return 0
