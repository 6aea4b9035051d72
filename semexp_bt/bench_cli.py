"""``semexp-bt bench KIND``: benchmarks that write JSON and print a table.

Kinds: ``core`` (arbitration, memory update, decision latency).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kind", choices=("core",), help="which benchmark")
    parser.add_argument("--json", type=Path, default=None, help="write the figures here as JSON")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="fewer repeats, no 100k-node row (smoke test)")


def run(args: argparse.Namespace) -> int:
    if args.kind == "core":
        from semexp_bt.bench_core import format_table, run_core_bench, write_json

        result = run_core_bench(seed=args.seed, quick=args.quick)
        print(format_table(result))
        if args.json is not None:
            write_json(result, args.json)
        return 0 if all(result["floors_met"].values()) else 1
    return 2
