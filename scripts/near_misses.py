"""Where missions came close to the goal and how their confirmations went there (docs/planner.md, seventh round).

Two inputs, both written by the product:

- a sweep folder (``semexp-bt bench missions ... --trajectories N --out DIR``): per episode, its outcome and
  the nearest its base came to the goal's footprint (``SceneObject.boundary_distance_m`` over the
  trajectory, which the sweep keeps for the first N seeds);
- episode records (``semexp-bt run ... --json FILE``): every ``target_sighted``, ``confirmation_rejected``
  and ``target_confirmed`` event with the robot's distance to the goal at the next decision (decisions
  carry ``robot_xy``) and the event's reason;
- a sweep folder's refusals (``--refusals DIR``; rows written since session 33 list them): each refused
  confirmation sorted into the goal's (its first vote within :data:`ON_GOAL_M` of an object the instruction
  names) and another object's, with the further views' votes counted from the refusal's reason, so the
  per-view vote rate at the goal and at distractors can be read off a sweep.

Usage::

    .venv/bin/python scripts/near_misses.py --sweep runs/dev-s16
    .venv/bin/python scripts/near_misses.py --records runs/ep-warehouse_b-1001.json runs/ep-garden_sim-1000.json
    .venv/bin/python scripts/near_misses.py --refusals runs/dev-s33
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sims.catalogue import build_scene  # noqa: E402
from sims.naming import named_objects  # noqa: E402

#: The events that say what perception and confirmation made of the goal.
CONFIRMATION_EVENTS = ("target_sighted", "confirmation_rejected", "target_confirmed")
#: A refused first vote this close to the footprint of an object the instruction names was that object, m.
ON_GOAL_M = 0.5
#: How a ``too_few_views`` refusal's reason states its votes: "only V of N further views ...".
VOTES_OF_VIEWS = re.compile(r"only (\d+) of (\d+) further views")


def sweep_lines(folder: Path) -> list[str]:
    """One line per episode of a sweep: outcome, path, L*, final and nearest distance to the goal."""
    lines = []
    rows = [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines() if line.strip()]
    for row in sorted(rows, key=lambda r: (r["scene"], r["seed"])):
        goal = build_scene(row["scene"], seed=row["seed"]).goal
        nearest = None
        if row.get("trajectory_file"):
            xy = json.loads((folder / row["trajectory_file"]).read_text()).get("trajectory_xy") or []
            nearest = min((goal.boundary_distance_m((p[0], p[1])) for p in xy), default=None)
        near = "-" if nearest is None else f"{nearest:.2f}"
        lines.append(
            f"{row['scene']:12s} {row['seed']:5d} {'success' if row['success'] else row['outcome']:16s} "
            f"path {row['path_length_m']:6.1f} m  L* {row['geodesic_length_m']:5.1f} m  "
            f"end {row['distance_to_goal_m']:.2f} m  nearest {near} m"
        )
    return lines


def record_lines(record: dict[str, Any]) -> list[str]:
    """The confirmation events of one episode record with the robot's distance to the goal."""
    goal = build_scene(record["scene"], seed=record["seed"]).goal
    final = record["final_pose"]
    lines = [f"{record['scene']} {record['seed']}: {record['outcome']}, goal {goal.name}"]
    for event in record["events"]:
        if event["kind"] not in CONFIRMATION_EVENTS:
            continue
        later = [d["robot_xy"] for d in record["decisions"] if d["stamp_s"] >= event["stamp_s"]]
        xy = later[0] if later else [final["x_m"], final["y_m"]]
        what = event.get("reason") or event.get("label")
        lines.append(
            f"  {event['stamp_s']:6.1f} s {event['kind']:22s} robot {goal.boundary_distance_m(tuple(xy)):.2f} m "
            f"from the goal: {what}"
        )
    return lines


def refusal_lines(folder: Path) -> list[str]:
    """Per strategy, the sweep's refusals of the goal and of other objects, by cause, with the further
    views' votes of the ``too_few_views`` ones summed (rows without ``refusals`` are left out)."""
    causes: dict[tuple[str, str], collections.Counter[str]] = collections.defaultdict(collections.Counter)
    votes_views: dict[tuple[str, str], list[int]] = collections.defaultdict(lambda: [0, 0])
    for line in (folder / "episodes.jsonl").read_text().splitlines():
        row = json.loads(line) if line.strip() else None
        if not row or row.get("status") != "ok" or not row.get("refusals"):
            continue
        named = named_objects(build_scene(row["scene"], seed=row["seed"]), row["instruction"])
        for refusal in row["refusals"]:
            if "position_m" not in refusal:
                continue
            xy = (refusal["position_m"][0], refusal["position_m"][1])
            on_goal = min((o.boundary_distance_m(xy) for o in named), default=math.inf) <= ON_GOAL_M
            key = (row["strategy"], "the goal" if on_goal else "other objects")
            causes[key][refusal["cause"]] += 1
            counted = VOTES_OF_VIEWS.search(refusal.get("reason", ""))
            if counted:
                votes_views[key][0] += int(counted.group(1))
                votes_views[key][1] += int(counted.group(2))
    lines = []
    for strategy in sorted({strategy for strategy, _ in causes}):
        lines.append(f"{strategy}:")
        for whose in ("the goal", "other objects"):
            by_cause = causes[(strategy, whose)]
            votes, views = votes_views[(strategy, whose)]
            rate = f"{votes / views:.2f}" if views else "-"
            lines.append(
                f"  refused at {whose}: {sum(by_cause.values())} "
                f"({', '.join(f'{cause} {n}' for cause, n in sorted(by_cause.items()))}); "
                f"too_few_views: {votes} votes in {views} further views (rate {rate})"
            )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweep", type=Path, help="a bench missions output folder")
    parser.add_argument("--records", type=Path, nargs="*", default=[], help="semexp-bt run --json files")
    parser.add_argument(
        "--refusals", type=Path, help="a bench missions output folder (rows since session 33)"
    )
    args = parser.parse_args()
    if args.sweep is None and not args.records and args.refusals is None:
        parser.error("give --sweep DIR, --records FILE ... or --refusals DIR")
    lines = sweep_lines(args.sweep) if args.sweep is not None else []
    lines += refusal_lines(args.refusals) if args.refusals is not None else []
    for path in args.records:
        lines += record_lines(json.loads(path.read_text()))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
