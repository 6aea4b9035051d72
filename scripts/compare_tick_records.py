"""The first tick at which two missions' per-tick records differ (``semexp-bt run ... --record FILE``).

Compares each tick's node statuses and feedback and its blackboard writes; the clearance guard's feedback
is left out by default, since it reports contact distances that only a simulator knows (over ROS 2 the
executive reads ``inf``). Used to compare an in-process run with the same episode over ROS 2
(docs/ros2.md, "Lockstep and realtime").

Usage: ``python scripts/compare_tick_records.py A.jsonl B.jsonl [--keep-clearance]``; exit 0 when the
records are the same, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

#: The node whose feedback carries ground truth (contact distances) a real robot does not report.
GROUND_TRUTH_NODE = "Clearance"


def comparable(line: str, *, drop: tuple[str, ...]) -> dict[str, Any]:
    """A tick's statuses, feedback and writes, without timings and the ``drop`` nodes."""
    tick = json.loads(line)
    nodes = {k: (v["status"], v["feedback"]) for k, v in tick["nodes"].items() if k not in drop}
    return {"tick": tick["tick"], "stamp_s": tick["stamp_s"], "nodes": nodes, "writes": tick["writes"]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a", type=Path)
    parser.add_argument("b", type=Path)
    parser.add_argument("--keep-clearance", action="store_true", help="compare the clearance guard too")
    args = parser.parse_args()
    drop = () if args.keep_clearance else (GROUND_TRUTH_NODE,)
    count = 0
    with args.a.open() as a, args.b.open() as b:
        for line_a, line_b in zip(a, b, strict=False):
            count += 1
            x, y = comparable(line_a, drop=drop), comparable(line_b, drop=drop)
            if x == y:
                continue
            print(f"first difference at tick {x['tick']} (t = {x['stamp_s']} s / {y['stamp_s']} s)")
            for name in sorted(x["nodes"].keys() | y["nodes"].keys()):
                if x["nodes"].get(name) != y["nodes"].get(name):
                    print(f"  node {name}: {x['nodes'].get(name)} | {y['nodes'].get(name)}")
            for write_a, write_b in zip(x["writes"], y["writes"], strict=False):
                if write_a != write_b:
                    print(f"  write {write_a}\n      | {write_b}")
                    break
            return 1
        rest_a, rest_b = sum(1 for _ in a), sum(1 for _ in b)
    if rest_a or rest_b:
        print(f"the same for {count} ticks, then one record ends ({rest_a} / {rest_b} more)")
        return 1
    print(f"the same at every one of {count} ticks")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
